"""Time-varying plant-effect parameters (``vehicle.variations`` entries ``effects.<label>.<param>``): the effect's
force follows its law with the varied value at the control instants of the variation schedule, in the compiled
and the Python loop alike; a wrong address is a one-line error naming the file and the field."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from suspension_sim.config import load_scenario, parse_scenario
from suspension_sim.errors import ScenarioError
from suspension_sim.simulation import Simulation

T, CDT = 2.0, 0.01  # run length, control step (the variations' schedule)
C1, C2 = 1500.0, 800.0  # N s^2/m^2: the first and the second (label quadratic_damping#2) orifice damper


def _scenario(variations):
    return parse_scenario({
        "name": "eff_var",
        "vehicle": {"model": "quarter_car", "params": {"damping": 300.0},
                    "effects": [{"type": "quadratic_damping", "params": {"c_v": C1}},
                                {"type": "quadratic_damping", "params": {"c_v": C2}}],
                    "variations": variations},
        "road": {"type": "sine", "params": {"amplitude": 0.03, "frequency": 1.7}},
        "sim": {"duration": T, "dt": 5e-4, "control_dt": CDT, "log_dt": 5e-4}})


RAMP = {"param": "effects.quadratic_damping.c_v", "kind": "ramp", "mode": "scale", "times": [0.0, 0.5, 1.5],
        "values": [1.0, 1.0, 0.4]}
STEP2 = {"param": "effects.quadratic_damping#2.c_v", "kind": "step", "mode": "set", "times": [1.0], "values": [0.0]}


def _c_expected(t):
    """(c_v of the first damper, of the second) in force at time t: the variation value at the last control
    instant (both loops apply variations at control instants and hold them in between)."""
    tc = np.floor(np.asarray(t) / CDT + 1e-9) * CDT
    return C1 * np.interp(tc, RAMP["times"], RAMP["values"]), np.where(tc >= 1.0, 0.0, C2)


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_effect_parameter_drift_changes_the_force_as_the_law_says(monkeypatch, compiled):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    sim = Simulation([_scenario([RAMP, STEP2])])
    ts = sim.run()[0].ts
    assert (sim.loop == "python") == (not compiled)
    t, v, F = ts.t.to_numpy(), ts.travel_rate.to_numpy(), ts.effect_force.to_numpy()
    c1, c2 = _c_expected(t)
    # the logged force is the two laws with the varied coefficients, at every logged step (a few times named)
    want = -(c1 + c2) * v * np.abs(v)
    assert np.max(np.abs(F - want)) <= 1e-9 * np.max(np.abs(want))
    for tq, c1q, c2q in ((0.3, C1, C2), (1.0, C1 * 0.7, 0.0), (1.505, C1 * 0.4, 0.0), (1.9, C1 * 0.4, 0.0)):
        k = int(np.argmin(np.abs(t - tq)))
        assert F[k] == pytest.approx(-(c1q + c2q) * v[k] * abs(v[k]), rel=1e-9, abs=1e-9)
    # the baseline without the variations keeps the nominal force (so the check above could fail)
    ts0 = Simulation([_scenario([])]).run()[0].ts
    late = t > 1.6
    v0, F0 = ts0.travel_rate.to_numpy(), ts0.effect_force.to_numpy()
    assert np.allclose(F0, -(C1 + C2) * v0 * np.abs(v0), rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(F[late])) < 0.5 * np.max(np.abs(F0[late]))


def test_both_loops_agree_and_a_rerun_restarts_from_the_nominal_parameters(monkeypatch):
    """The compiled and the Python loop give the same run; running the same Simulation again starts from the
    nominal c_v (the variation left it at 40 % and 0)."""
    out = {}
    for compiled in (True, False):
        monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
        sim = Simulation([_scenario([RAMP, STEP2])])
        a = sim.run()[0].ts
        b = sim.run()[0].ts
        assert np.array_equal(a.effect_force.to_numpy(), b.effect_force.to_numpy())
        out[compiled] = a
    assert np.allclose(out[True].body_z.to_numpy(), out[False].body_z.to_numpy(), rtol=0, atol=1e-12)


def test_a_drift_on_some_corners_leaves_the_others(monkeypatch):
    """Half car, one damper effect on both corners, the drift on the front only: the rear keeps c_v."""
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    sc = parse_scenario({
        "vehicle": {"model": "half_car", "effects": [{"type": "quadratic_damping", "params": {"c_v": C1}}],
                    "variations": [{"param": "effects.quadratic_damping.c_v", "kind": "step", "mode": "scale",
                                    "times": [0.5], "values": [0.5], "corners": ["front"]}]},
        "road": {"type": "sine", "params": {"amplitude": 0.03, "frequency": 1.7}},
        "sim": {"duration": 1.0, "dt": 5e-4, "control_dt": CDT, "log_dt": 5e-4}})
    ts = Simulation([sc]).run()[0].ts
    t = ts.t.to_numpy()
    for corner, c_late in (("front", 0.5 * C1), ("rear", C1)):
        v, F = ts[f"travel_rate_{corner}"].to_numpy(), ts[f"effect_force_{corner}"].to_numpy()
        c = np.where(t >= 0.5, c_late, C1)
        assert np.allclose(F, -c * v * np.abs(v), rtol=1e-9, atol=1e-9), corner


BAD = [
    ("effects.quadratic_damping", "an effect parameter is addressed as effects.<label>.<param>"),
    ("effects.bump_stop.gap", "no effect labelled 'bump_stop' (this vehicle's effects: quadratic_damping, "
                              "quadratic_damping#2)"),
    ("effects.quadratic_damping#3.c_v", "no effect labelled 'quadratic_damping#3'"),
    ("effects.quadratic_damping.c", "effect 'quadratic_damping' has no numeric parameter 'c' (can vary: c_v)"),
]


@pytest.mark.parametrize("param, text", BAD, ids=[b[0] for b in BAD])
def test_a_wrong_address_is_a_one_line_error(tmp_path, param, text):
    raw = yaml.safe_load(yaml.safe_dump(_scenario([]).model_dump(mode="json")))
    raw["vehicle"]["variations"] = [{**RAMP, "param": param}]
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(raw))
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{p}: vehicle.variations.0.param: "), msg
    assert text in msg


def test_a_string_parameter_cannot_vary_and_corners_must_be_the_effects(tmp_path):
    raw = yaml.safe_load(yaml.safe_dump(_scenario([]).model_dump(mode="json")))
    raw["vehicle"]["effects"] = [{"type": "coulomb_friction", "params": {"force": 100.0, "law": "tanh"}}]
    raw["vehicle"]["variations"] = [{**RAMP, "param": "effects.coulomb_friction.law"}]
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(raw))
    with pytest.raises(ScenarioError, match=r"vehicle\.variations\.0\.param: effect 'coulomb_friction' has no "
                                            r"numeric parameter 'law' \(can vary: force, v_eps\)"):
        load_scenario(p)
    raw["vehicle"]["variations"] = [{**RAMP, "param": "effects.coulomb_friction.force", "corners": ["rear"]}]
    p.write_text(yaml.safe_dump(raw))
    with pytest.raises(ScenarioError, match=r"vehicle\.variations\.0\.corners: unknown corner"):
        load_scenario(p)


def test_stick_slip_effective_mass_follows_a_varying_mass():
    """The stick-slip friction's m_r (its sticking force and a reversal's time inside a step) is the effective
    mass at the current masses: under a +150 kg load step on the 250 kg rig it is 400 kg, not the initial 250
    (which made the law first order in the step under the thesis Ch. 4 load), and a new run starts at 250 again."""
    def sc(dur):
        return parse_scenario({
            "name": "mr", "vehicle": {
                "model": "sdof", "params": {"sprung_mass": 250, "spring_stiffness": 5000, "damping": 0},
                "effects": [{"type": "coulomb_friction",
                             "params": {"force": 1000, "law": "stick_slip", "step_force": "mean"}}],
                "variations": [{"param": "sprung_mass", "kind": "step", "mode": "add", "times": [0.5, 1.0],
                                "values": [150, 0]}]},
            "road": {"type": "sine", "params": {"amplitude": 0.03, "frequency": 1.0}},
            "sim": {"duration": dur, "dt": 1e-4, "control_dt": 0.01, "log_dt": 1e-3, "integrator": "RK4"}})
    sim = Simulation([sc(0.8)])
    sim.run()
    m_r = lambda: float(sim.effects[0][0].kernel_arrays()[0][0, 0, 1])  # noqa: E731 (p = [F_c, m_r, ...])
    assert m_r() == pytest.approx(400.0, rel=1e-9)  # during the load
    sim.reset()
    assert m_r() == pytest.approx(250.0, rel=1e-9)  # a new run: the nominal mass
    sim = Simulation([sc(1.2)])
    sim.run()
    assert m_r() == pytest.approx(250.0, rel=1e-9)  # the load removed at 1.0 s
