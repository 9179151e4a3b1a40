"""Each actuator's law (its numba kernels, broadcast over the ensemble by ``Actuator.force``/``advance``)
against the physics written out by hand: the ideal actuator's delay line, lag, rate limit and saturation,
the hydraulic valve flow equation and cylinder force, the reluctance force law and current references.

Also: a car inside an ensemble of cars with other parameters behaves as the car alone, the Python loop runs
the same kernels as the compiled loop (bit for bit, tanh and exp included), and an actuator written in plain
numpy, without kernels, still runs (in the Python loop).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from suspension_sim.actuators.base import Actuator, ActuatorContext
from suspension_sim.actuators.electromagnetic import ElectromagneticActuator
from suspension_sim.actuators.hydraulic import HydraulicActuator
from suspension_sim.actuators.ideal import IdealActuator
from suspension_sim.components import stack_params
from suspension_sim.config import parse_scenario
from suspension_sim.registry import ACTUATORS
from suspension_sim.simulation import Simulation

DT = 5e-4


def build(acls, params: list[dict], nc: int = 1, dt: float = DT):
    """The actuator as simulation.py builds it: stacked per-car params and an ActuatorContext."""
    n = len(params)
    plist = [acls.Params(**kw) for kw in params]
    return acls(stack_params(plist, nc), ActuatorContext(n, nc, dt, 2 * dt, np.zeros((n, nc))))


def one(x, shape=(1, 1)):
    return np.full(shape, float(x))


def par(act, name):
    """A stacked parameter of a lone car as a float."""
    return float(np.squeeze(getattr(act.p, name)))


# ---------------------------------------------------------------------------------------------------------
def test_ideal_delay_lag_rate_and_saturation_by_hand():
    """Delay of 2 steps, then F_k = a·F_{k−1} + (1 − a)·u with a = exp(−dt/τ), |ΔF| <= rate·dt, |F| <= F_max."""
    tau, rate, fmax = 0.002, 1e5, 300.0
    act = build(IdealActuator, [dict(delay=2 * DT, time_constant=tau, rate_limit=rate, max_force=fmax)])
    a = math.exp(-DT / tau)
    line, F, seen = [0.0, 0.0, 0.0], 0.0, []
    cmds = [1000.0] * 12 + [-50.0] * 20 + [20.0] * 10
    for k, u in enumerate(cmds):
        line = line[1:] + [u]
        lagged = a * F + (1 - a) * line[0]
        F = min(max(F + min(max(lagged - F, -rate * DT), rate * DT), -fmax), fmax)
        got = act.force(one(u), one(0.0), one(0.0), k * DT)[0, 0]
        act.advance(one(u), one(0.0), one(0.0), k * DT, DT)
        assert got == pytest.approx(F, rel=1e-12, abs=1e-9), k
        assert act.states()["force"][0, 0] == got
        seen.append(got)
    assert seen[:3] == [0.0, 0.0, 50.0] and max(seen) == fmax and min(seen) < 0  # delay, rate limit, saturation


def _hyd_state(act):
    st = act.states()
    return st["load_pressure"][0, 0], st["spool_position"][0, 0]


@pytest.mark.parametrize("P0,u,v", [(3e6, 2e-4, 0.05), (-2e6, -1.5e-4, -0.1),
                                    (-1.2e7, -2.5e-4, 0.02)])  # |P_L| > P_s against the open valve: w3 < 0
def test_hydraulic_valve_flow_equation(P0, u, v):
    """dP_L/dt = −β·P_L − α·A·v + γ·x_v·sgn(D)·sqrt|D|, D = P_s − sgn(x_v)·P_L (Lin & Kanellakopoulos Eq. 7):
    the change of P_L over a 1 ns step, from a state with the spool open, against the right-hand side."""
    kw = dict(beta=2.0, initial_pressure=P0, spool_limit=None, spool_time_constant=5e-4)
    act = build(HydraulicActuator, [kw])
    beta, alpha, area, gamma, Ps = (par(act, k) for k in ("beta", "alpha", "area", "gamma", "supply_pressure"))
    s = 0.0
    act.force(one(u), one(s), one(0.0), 0.0)
    act.advance(one(u), one(s), one(0.0), 0.0, 5e-4)  # opens the spool (travel held: v = 0)
    P1, xv = _hyd_state(act)
    assert np.sign(xv) == np.sign(u) and abs(xv) > 0.2 * abs(u)
    h = 1e-9
    act.advance(one(u), one(s), one(v), 5e-4, h)
    P2, _ = _hyd_state(act)
    D = Ps - math.copysign(1.0, xv) * P1
    rhs = -beta * P1 - alpha * area * v + gamma * xv * math.copysign(math.sqrt(abs(D)), D)
    assert (P2 - P1) / h == pytest.approx(rhs, rel=1e-5)
    assert abs(gamma * xv * math.sqrt(abs(D))) > 0.1 * abs(rhs)  # the valve term matters here
    assert (D < 0) == (P0 < -1e7)


def test_hydraulic_spool_lag_and_end_stop():
    """x_v → u exponentially with τ, clipped at the end stop."""
    act = build(HydraulicActuator, [dict(spool_time_constant=0.003, spool_limit=0.004)])
    act.advance(one(0.003), one(0.0), one(0.0), 0.0, 0.002)
    assert _hyd_state(act)[1] == pytest.approx(0.003 * (1 - math.exp(-0.002 / 0.003)), rel=1e-12)
    act.advance(one(0.02), one(0.0), one(0.0), 0.002, 0.01)
    assert _hyd_state(act)[1] == 0.004


def test_hydraulic_force_and_seal_friction():
    """F = A·P_L − F_f,max·tanh(v/v_f); the oil spring: P_L drops by α·A·Δtravel when the rod moves."""
    p = dict(initial_pressure=2e6, friction_max=250.0, friction_velocity=0.01)
    act = build(HydraulicActuator, [p])
    A, alpha = par(act, "area"), par(act, "alpha")
    F = act.force(one(0.0), one(0.01), one(0.004), 0.0)[0, 0]
    assert F == pytest.approx(A * 2e6 - 250.0 * math.tanh(0.4), rel=1e-9)
    assert act.states()["friction_force"][0, 0] == pytest.approx(250.0 * math.tanh(0.4), rel=1e-14)
    F = act.force(one(0.0), one(0.0100001), one(-0.02), 0.0)[0, 0]  # 0.1 µm more travel, same G
    assert F == pytest.approx(A * (2e6 - alpha * A * 1e-7) + 250.0 * math.tanh(2.0), rel=1e-9)


def test_electromagnetic_force_law_and_references():
    """i_r = sqrt(F/p(x)) on the unit that carries the demand (x = x0 ∓ s clipped to the stroke), at most i_max;
    once the currents settle, F = p(x_push)·i_push² − p(x_pull)·i_pull² equals the demand."""
    def p_of(x):
        return 0.197 - 1.94 * x + 26.34 * x ** 2 - 239.54 * x ** 3

    act = build(ElectromagneticActuator, [{}])
    for F_d, s in [(400.0, 0.01), (-250.0, -0.02), (800.0, 0.06)]:  # s = 0.06: x_push = −0.01 → x_min = 0
        act.reset()
        for k in range(400):
            act.advance(one(F_d), one(s), one(0.0), k * DT, DT)
        st = act.states()
        x_push, x_pull = min(max(0.05 - s, 0.0), 0.1), min(max(0.05 + s, 0.0), 0.1)
        if F_d > 0:
            assert st["current_ref_push"][0, 0] == pytest.approx(math.sqrt(F_d / p_of(x_push)), rel=1e-12)
            assert st["current_ref_pull"][0, 0] == 0.0
        else:
            assert st["current_ref_pull"][0, 0] == pytest.approx(math.sqrt(-F_d / p_of(x_pull)), rel=1e-12)
        F = act.force(one(F_d), one(s), one(0.0), 400 * DT)[0, 0]
        i_p, i_q = st["current_push"][0, 0], st["current_pull"][0, 0]
        assert F == pytest.approx(p_of(x_push) * i_p ** 2 - p_of(x_pull) * i_q ** 2, rel=1e-12)
        assert F == pytest.approx(F_d, rel=1e-4)
    act.reset()
    act.advance(one(1e5), one(0.0), one(0.0), 0.0, DT)
    assert act.states()["current_ref_push"][0, 0] == par(act, "i_max")


# ---------------------------------------------------------------------------------------------------------
ENSEMBLES = {
    IdealActuator: [dict(delay=0.002, time_constant=0.0, rate_limit=1e5, max_force=300.0),
                    dict(time_constant=0.005, max_force=500.0), dict(delay=0.0035, time_constant=0.02)],
    HydraulicActuator: [dict(spool_time_constant=0.003, spool_limit=0.004, initial_pressure=1e6),
                        dict(spool_limit=None, beta=3.0, area=4e-4, max_substep=1e-4, friction_max=100.0),
                        dict(spool_time_constant=0.01, spool_limit=0.006, supply_pressure=2e7, gamma=1e9)],
    ElectromagneticActuator: [dict(i_max=60.0, x_max=0.12, substeps=3),
                              dict(u_max=24.0, bandwidth=60.0, x0=0.04, substeps=3, Ti=0.002, Ki=0.5),
                              dict(i_max=150.0, x_min=0.01, x_max=0.09, bandwidth=150.0, substeps=3)],
}
SCALE = {IdealActuator: 1000.0, HydraulicActuator: 0.02, ElectromagneticActuator: 3000.0}


@pytest.mark.parametrize("acls", list(ENSEMBLES), ids=lambda c: c.__name__)
def test_a_car_in_an_ensemble_is_the_car_alone(acls):
    """Forces and states of each car of a mixed ensemble (optional limits given for some cars only, different
    delays) equal those of the car built alone (the ensemble-wide sub-step counts are the same here)."""
    params = ENSEMBLES[acls]
    rng = np.random.default_rng(2)
    steps, nc = 400, 2
    cmd = np.repeat(rng.uniform(-1, 1, (steps // 20, 3, nc)), 20, axis=0) * SCALE[acls]
    v = np.cumsum(rng.normal(0, 0.02, (steps, 3, nc)), axis=0)
    s = np.cumsum(v * DT, axis=0)
    ens = build(acls, params, nc)
    alone = [build(acls, [kw], nc) for kw in params]
    for k in range(steps):
        fe = ens.force(cmd[k], s[k], v[k], k * DT)
        ens.advance(cmd[k], s[k], v[k], k * DT, DT)
        se = ens.states()
        for i, a in enumerate(alone):
            sl = slice(i, i + 1)
            np.testing.assert_array_equal(fe[i], a.force(cmd[k, sl], s[k, sl], v[k, sl], k * DT)[0])
            a.advance(cmd[k, sl], s[k, sl], v[k, sl], k * DT, DT)
            for nm, val in a.states().items():
                np.testing.assert_array_equal(se[nm][i], val[0])
    assert np.all(np.any(fe != 0, axis=1))


def test_every_actuator_has_kernels():
    for name in ACTUATORS.names():
        cls = ACTUATORS.get(name)
        assert cls.kernel_force is not None and cls.kernel_advance is not None, name


# ---------------------------------------------------------------------------------------------------------
def _scenario(actuator, controller=None, duration=0.4, effects=()):
    return parse_scenario({
        "name": "act", "vehicle": {"model": "quarter_car", "effects": list(effects)},
        "road": {"type": "sine", "params": {"amplitude": 0.03, "frequency": 2.0}, "speed": 20.0},
        "sensors": [{"type": "corner_body_vel"}, {"type": "travel_rate"}],
        "actuator": actuator,
        "controller": controller or {"type": "skyhook", "params": {"c_sky": 2500.0}},
        "sim": {"duration": duration, "seed": 1}})


def _run(scs, compiled, monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    sim = Simulation(scs)
    return sim, sim.run()


@pytest.mark.parametrize("actuator", [
    {"type": "ideal", "params": {"time_constant": 0.003, "max_force": 800.0, "rate_limit": 2e5, "delay": 0.001}},
    {"type": "hydraulic", "params": {"friction_max": 250.0, "spool_time_constant": 0.003}},
    {"type": "electromagnetic", "params": {}},
], ids=lambda a: a["type"])
def test_python_loop_equals_compiled_loop(actuator, monkeypatch):
    """The two loops run the same kernels: every channel bit for bit (the hydraulic seal friction's tanh and
    the spool's exp included)."""
    ctrl = {"type": "open_loop", "params": {"signal": "sine", "amplitude": 0.004, "frequency": 3.0}} \
        if actuator["type"] == "hydraulic" else None
    scs = [_scenario(actuator, ctrl)]
    sim_c, rc = _run(scs, True, monkeypatch)
    sim_p, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop in ("full", "hybrid") and sim_p.loop == "python"
    assert rp[0].ts["actuator_force"].abs().max() > 10.0
    assert rp[0].ts.equals(rc[0].ts)


def test_actuator_in_plain_numpy_runs_in_the_python_loop(monkeypatch):
    """A user's actuator without kernels: its numpy force/advance/states drive the Python loop (the compiled
    loop declines it, naming it) and it matches the built-in ideal actuator with the same lag."""
    if "_test_numpy_lag" not in ACTUATORS._items:
        @ACTUATORS.register("_test_numpy_lag")
        class NumpyLag(Actuator):
            Params = IdealActuator.Params

            def reset(self):
                self.F = np.zeros((self.ctx.n_cars, self.ctx.n_corners))
                self.a = np.exp(-self.ctx.dt / np.asarray(self.p.time_constant, dtype=float))

            def force(self, command, travel, travel_rate, t):
                self.F = self.a * self.F + (1 - self.a) * command
                return self.F

            def advance(self, command, travel, travel_rate, t, dt):
                pass

            def states(self):
                return {"force": self.F}

    sim_u, ru = _run([_scenario({"type": "_test_numpy_lag", "params": {"time_constant": 0.004}})], True, monkeypatch)
    sim_b, rb = _run([_scenario({"type": "ideal", "params": {"time_constant": 0.004}})], True, monkeypatch)
    assert sim_u.loop == "python" and "_test_numpy_lag" in sim_u.loop_reason and sim_b.loop == "full"
    a, b = ru[0].ts, rb[0].ts
    assert b["actuator_force"].abs().max() > 10.0
    for col in ("body_z", "travel", "actuator_force"):
        np.testing.assert_allclose(a[col], b[col], rtol=0, atol=1e-12 * b[col].abs().max())
