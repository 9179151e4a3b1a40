"""Digressive (blow-off) damping (effects/digressive_damping.py): the car's damper rate c up to a knee rate,
(1 − drop)·c beyond it, each side its own knee and relief.

- the law (the car's −c·v plus the effect) against hand values in every branch, per corner and per car;
- drop 0 is the plain damper (no force at all), and the damper never returns energy: F·v ≤ 0 at every rate,
  while the effect alone gives energy back against the linear damper (it is a relief, not more damping);
- the step mean against a numerical quadrature of the law over the step's rate ramp;
- a quarter car with the effect against the scipy quarter car with the digressive law (the plain car is far
  from it), and the compiled loop against the Python loop, bit for bit.
"""
from __future__ import annotations

import numpy as np
import pytest

from reference_models import QuarterCarRef
from suspension_sim.components import stack_params, validate_params
from suspension_sim.effects.base import EffectContext
from suspension_sim.registry import EFFECTS

C = 1500.0  # N·s/m, the car's damper
DT = 5e-4


def build(raws, n_sel=1, c=C):
    cls = EFFECTS.get("digressive_damping")
    plist = [validate_params(cls.Params, raw, "x") for raw in raws]
    n = len(plist)
    one = np.ones((n, n_sel))
    ctx = EffectContext(n_cars=n, corners=[f"c{i}" for i in range(n_sel)], dt=DT,
                        static_suspension_force=2500 * one, static_tire_force=3400 * one,
                        spring_stiffness=17000 * one, damping=c * one, tire_stiffness=190000 * one,
                        tire_damping=0 * one, effective_mass=50 * one)
    return cls(stack_params(plist, n_sel), ctx)


def total(eff, v, c=C):
    """The damper's whole force at rates v (n_cars, n_sel): the car's −c·v plus the effect."""
    v = np.asarray(v, float)
    return -c * v + eff.force(np.zeros_like(v), v, 0.0, DT)


P = {"v_knee_comp": 0.2, "v_knee_reb": 0.4, "drop_comp": 0.6, "drop_reb": 0.3}


def digressive(v, p=P, c=C):
    """The damper's whole force at rate v, written out: −R(v), R = c·|v| up to the knee of v's side, then
    c·v_k + (1 − drop)·c·(|v| − v_k), with v's sign."""
    k, d = (p["v_knee_reb"], p["drop_reb"]) if v > 0 else (p["v_knee_comp"], p["drop_comp"])
    av = abs(v)
    R = c * av if av <= k else c * k + (1 - d) * c * (av - k)
    return -float(np.sign(v)) * R


def test_force_law_by_hand():
    eff = build([P])
    # inside the knees: the plain damper
    for v in (0.1, -0.1, 0.4, -0.2, 0.0):
        np.testing.assert_allclose(total(eff, [[v]])[0, 0], -C * v, rtol=1e-12, atol=1e-12)
    # rebound beyond 0.4 m/s: −(c·0.4 + 0.7·c·(0.6 − 0.4)) = −(600 + 210)
    np.testing.assert_allclose(total(eff, [[0.6]])[0, 0], -810.0, rtol=1e-12)
    # compression beyond 0.2 m/s: +(c·0.2 + 0.4·c·(0.5 − 0.2)) = 300 + 180
    np.testing.assert_allclose(total(eff, [[-0.5]])[0, 0], 480.0, rtol=1e-12)
    # per corner and per car: knees and reliefs as lists, a second car with the other side's values
    eff2 = build([{**P, "v_knee_reb": [0.4, 0.1]}, {"v_knee_comp": 0.4, "v_knee_reb": 0.2, "drop_comp": 0.3,
                                                   "drop_reb": [0.6, 1.0]}], n_sel=2)
    F = total(eff2, [[0.6, 0.6], [-0.6, 0.6]])
    np.testing.assert_allclose(F, [[-810.0, -(150.0 + 0.7 * C * 0.5)],
                                   [C * 0.4 + 0.7 * C * 0.2, -C * 0.2]], rtol=1e-12)


def test_drop_zero_is_the_plain_damper_and_the_damper_dissipates():
    v = np.linspace(-3.0, 3.0, 601).reshape(-1, 1)
    plain = build([{**P, "drop_comp": 0.0, "drop_reb": 0.0}])
    assert np.all(plain.force(np.zeros_like(v[:1]), v[:1], 0.0, DT) == 0.0)
    for raw in (P, {**P, "drop_comp": 1.0, "drop_reb": 1.0}, {**P, "v_knee_comp": 0.0, "v_knee_reb": 0.0}):
        eff = build([raw])
        F = np.array([total(eff, [[x]])[0, 0] for x in v[:, 0]])
        Fe = F + C * v[:, 0]  # the effect alone
        assert np.all(F * v[:, 0] <= 0.0)  # the damper takes energy out at every rate
        assert np.all(Fe * v[:, 0] >= 0.0) and np.max(Fe * v[:, 0]) > 100.0  # the relief gives some back
        assert np.all(np.abs(F) <= C * np.abs(v[:, 0]) + 1e-9)  # never more than the linear damper


def test_step_mean_is_the_mean_of_the_law_over_the_step():
    """``step_force: mean``: the force over a step is the law's mean over the rate ramp from v to 2·v − v_prev
    (here crossing a knee, inside one piece, and crossing zero and both knees), against Simpson's rule on a
    fine grid; the start-of-step law (the default) differs by more than the test's tolerance."""
    law = build([P])  # the start-of-step law
    for v_prev, v in ((0.35, 0.45), (0.7, 0.8), (-0.15, -0.25), (0.5, -0.3), (-0.4, 0.6)):
        eff = build([{**P, "step_force": "mean"}])
        eff.force(np.zeros((1, 1)), np.full((1, 1), v_prev), 0.0, DT)  # the previous step's rate
        got = eff.force(np.zeros((1, 1)), np.full((1, 1), v), DT, DT)[0, 0]
        w = np.linspace(v, 2 * v - v_prev, 20001)
        g = np.array([digressive(x) + C * x for x in w])  # the effect's part of the law
        ref = float(np.sum(g[:-1] + g[1:]) * 0.5 / (len(w) - 1))  # trapezoid rule: exact on a piecewise line
        start = law.force(np.zeros((1, 1)), np.full((1, 1), v), 0.0, DT)[0, 0]
        assert abs(got - ref) < 1e-3 * (1 + abs(ref)), (v_prev, v, got, ref)
        assert abs(start - ref) > 1e-2


def _scenario(effects, duration=1.5, amp=0.03, freq=3.0, damping=C):
    from suspension_sim.config import parse_scenario

    return parse_scenario({
        "vehicle": {"model": "quarter_car", "params": {"damping": damping}, "effects": effects},
        "road": {"type": "sine", "params": {"amplitude": amp, "frequency": freq, "fade_in": 0.3}},
        "sim": {"duration": duration, "dt": DT, "control_dt": 1e-3, "log_dt": 1e-3}})


EFF = [{"type": "digressive_damping", "params": {**P, "step_force": "mean"}}]


def test_quarter_car_against_the_reference(monkeypatch):
    """A quarter car on a 3 Hz sine (travel rates to ~0.7 m/s, past both knees) with the digressive damper,
    against the scipy quarter car with the law written out (damper ``−R(v)``); the plain car is far from it."""
    from test_effects import compare, road_fn
    from suspension_sim.simulation import Simulation

    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    # the plain car: drop 0 (no force at all, test above) in the same ensemble
    zero = [{"type": "digressive_damping", "params": {**P, "drop_comp": 0.0, "drop_reb": 0.0, "step_force": "mean"}}]
    ts, plain = (r.ts for r in Simulation([_scenario(EFF), _scenario(zero)]).run())

    rp = dict(amplitude=0.03, frequency=3.0, fade_in=0.3)
    ref = QuarterCarRef(road=road_fn(rp), damping=0.0, suspension_forces=[lambda s, v, t: digressive(v)])
    out = ref.simulate(ts.t.values)
    assert np.max(np.abs(out["travel_rate"])) > 0.6  # both knees crossed
    err = compare(ts, out, channels=("travel", "body_acc", "wheel_acc"))
    assert max(err.values()) < 0.01, err
    base = compare(plain, out, channels=("travel", "body_acc", "wheel_acc"))
    assert min(base.values()) > 5 * max(err.values()), base


def test_compiled_loop_equals_python_loop(monkeypatch):
    from suspension_sim.simulation import Simulation

    runs = {}
    for compiled in (True, False):
        monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
        sim = Simulation([_scenario(EFF, duration=0.6), _scenario([{"type": "digressive_damping",
                                                                      "params": P}], duration=0.6)])
        runs[compiled] = [r.ts for r in sim.run()]
        assert sim.loop == ("full" if compiled else "python")
    for a, b in zip(runs[True], runs[False]):
        assert a.equals(b)
    assert np.max(np.abs(runs[True][0]["effect_force"].to_numpy())) > 50.0  # the effect acted


@pytest.mark.parametrize("bad", [{"drop_comp": 1.2}, {"drop_reb": -0.1}, {"v_knee_comp": -0.1}])
def test_bad_parameters_rejected(bad):
    from suspension_sim.errors import ScenarioError

    with pytest.raises((ScenarioError, ValueError)):
        build([{**P, **bad}])


def test_the_search_engine_with_the_law_matches_the_independent_blind_truth():
    """diagnose's engine (the MuJoCo plant with the effect, as the search runs it) against the blind battery's
    own quarter car (benchmarks/blind_truth.py: scipy, its own digressive law, nothing from suspension_sim),
    noise-free: a van on an ISO D road, knees 0.45 / 0.6 m/s, ratios 0.3 / 0.5.  The engine is built with a
    damping of 1000 N·s/m; the set's own damping (4300) is the one the law uses (each set's context).  With the
    law's step mean (what the search fits, ``fit_settings``) within 0.3 % (measured 0.02–0.07 %); the start-of-step
    law 0.1–0.7 %; the plain damper (drop 0) 15–18 %."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_truth as bt
    from suspension_sim.diagnose.engine import Engine

    veh = dict(bt.VEHICLES["van"])
    fs = 1000.0
    d = bt.simulate(veh, {"digressive": dict(v_k=0.45, ratio=0.3, v_k_reb=0.6, ratio_reb=0.5)},
                    bt.iso_road(np.random.default_rng(3), "D", 20), bt.Zero(), 2.5, fs)
    v = np.gradient(d["susp_travel"], 1 / fs)
    assert v.min() < -0.9 and v.max() > 1.0  # well past both knees
    nominal = {**{k: veh[k] for k in ("sprung_mass", "unsprung_mass", "spring_stiffness", "tire_stiffness",
                                      "tire_damping")}, "damping": 1000.0}
    P = {"damping": veh["damping"], "digressive_damping.v_knee_comp": 0.45, "digressive_damping.v_knee_reb": 0.6,
         "digressive_damping.drop_comp": 0.7, "digressive_damping.drop_reb": 0.5}
    errs = {}
    for sf in ("mean", "start"):
        eng = Engine("quarter_car", {"road": d["road"]}, 1 / fs,
                     [("digressive_damping", "digressive_damping", "all", {"step_force": sf})], nominal)
        out = eng.run([P, {**P, "digressive_damping.drop_comp": 0.0, "digressive_damping.drop_reb": 0.0}])
        for c in ("body_acc", "wheel_acc", "susp_travel"):
            y = d[c]
            errs[sf, c] = [float(np.sqrt(np.mean((out[i, :, eng.channels.index(c)] - y) ** 2)) / np.std(y))
                           for i in (0, 1)]
    assert max(e[0] for (sf, _), e in errs.items() if sf == "mean") < 0.003, errs
    assert min(e[1] for e in errs.values()) > 0.1, errs  # the plain damper is far from the truth
    for c in ("body_acc", "wheel_acc", "susp_travel"):  # the step mean is the more accurate law
        assert errs["mean", c][0] < 0.5 * errs["start", c][0], errs
