"""The hydraulic actuator (suspension_sim/actuators/hydraulic.py) against an independent scipy reference
of the same equations, step-size independence, spool end stops and sign conventions."""
from __future__ import annotations

import numpy as np
import pytest

import suspension_sim as ss
from suspension_sim.controllers.base import Controller
from suspension_sim.registry import CONTROLLERS

from reference_models import ExtraState, QuarterCarRef, nrmse

A, ALPHA, BETA, GAMMA, PS = 3.35e-4, 4.515e13, 1.0, 1.545e9, 10342500.0

# an open-loop spool programme, switching at whole control steps (so the reference can restart there)
TIMES = [0.0, 0.1, 0.4, 0.7, 1.0]
VALUES = [0.0, 0.002, -0.003, 0.001, 0.0]


def spool_program(t):
    return VALUES[int(np.searchsorted(TIMES, t + 1e-9, side="right")) - 1]


@CONTROLLERS.register("test_spool_program")
class SpoolProgram(Controller):
    """Test-only: open-loop spool input from TIMES/VALUES, or a constant ``level`` (params not used)."""

    level = None

    def step(self, t, y):
        u = spool_program(t) if SpoolProgram.level is None else SpoolProgram.level
        return np.full((self.ctx.n_cars, self.ctx.n_corners), u)


def road(t):
    return 0.02 * np.sin(2 * np.pi * 2.0 * t)


def road_vel(t):
    return 0.02 * 2 * np.pi * 2.0 * np.cos(2 * np.pi * 2.0 * t)


def scenario(dt=5e-4, duration=1.2, **act):
    return ss.config.parse_scenario({
        "road": {"type": "sine", "params": {"amplitude": 0.02, "frequency": 2.0}},
        "actuator": {"type": "hydraulic", "params": act},
        "controller": {"type": "test_spool_program"},
        "sensors": [{"name": "spool", "type": "actuator_state", "params": {"state": "spool_position"}}],
        "sim": {"duration": duration, "dt": dt, "control_dt": 0.001, "log_dt": 0.001},
        "outputs": {"plots": False},
    })


def reference(duration=1.2, friction=0.0, tau=1 / 30):
    """The same quarter car + actuator written as one ODE and solved by solve_ivp (LSODA, tight tolerances)."""
    def w3(P, xv):
        D = PS - np.sign(xv) * P
        return np.sign(D) * np.sqrt(abs(D))

    def deriv(y, s, v, t):
        P, xv = y
        return [-BETA * P - ALPHA * A * v + GAMMA * xv * w3(P, xv), (spool_program(t) - xv) / tau]

    def force(y, s, v, t):
        return A * y[0] - friction * np.tanh(v / 0.01)

    ref = QuarterCarRef(road=road, road_vel=road_vel, extra_states=[ExtraState(2, [0.0, 0.0], deriv, force)])
    t = np.arange(0.0, duration, 0.001)
    out = ref.simulate(t, breaks=TIMES[1:], method="LSODA", rtol=1e-8, atol=1e-10)
    out["actuator_force"] = A * out["extra"][0] - friction * np.tanh(out["travel_rate"] / 0.01)
    return out


@pytest.mark.parametrize("friction", [0.0, 250.0])
def test_matches_solve_ivp_reference(friction):
    r = ss.simulate(scenario(friction_max=friction))
    ref = reference(friction=friction)
    ts = r.ts
    assert np.max(np.abs(ts["act.load_pressure"])) > 2e6  # the programme really drives the pressure
    for key in ("body_z", "travel", "wheel_z", "actuator_force"):
        assert nrmse(ts[key].to_numpy(), ref[key]) < 0.01, key
    assert nrmse(ts["act.spool_position"].to_numpy(), ref["extra"][1]) < 0.01


def test_halving_the_physics_step_changes_nothing():
    a = ss.simulate(scenario(dt=5e-4)).ts
    b = ss.simulate(scenario(dt=2.5e-4)).ts
    for key in ("body_z", "travel", "actuator_force", "act.load_pressure"):
        assert nrmse(a[key].to_numpy(), b[key].to_numpy()) < 0.005, key


def test_spool_end_stops_and_sign_convention():
    SpoolProgram.level = 0.02  # twice the end stop
    try:
        sc = scenario(duration=0.3)
        sc.road.params = {"amplitude": 0.0, "frequency": 1.0}
        r = ss.simulate(sc)
    finally:
        SpoolProgram.level = None
    ts = r.ts
    xv = ts["act.spool_position"].to_numpy()
    assert np.max(np.abs(xv)) <= 0.01 + 1e-12
    assert xv[-1] == pytest.approx(0.01, rel=1e-6)
    # the sensor sees the same spool position
    assert np.allclose(ts["sensor.spool.value"].to_numpy(), xv, atol=1e-12)
    # positive spool opening -> positive load pressure -> the body is pushed up, the wheel down (initially),
    # and the cylinder extends
    assert ts["act.load_pressure"].iloc[-1] > 1e6
    early = ts.iloc[1:11]
    assert (early["body_acc"] > 0).all() and (early["wheel_acc"] < 0).all()
    assert ts["travel"].iloc[-1] > 0.05
    assert np.allclose(ts["act.hydraulic_force"], A * ts["act.load_pressure"])


def test_rest_stays_at_rest():
    SpoolProgram.level = 0.0
    try:
        sc = scenario(duration=0.2)
        sc.road.params = {"amplitude": 0.0, "frequency": 1.0}
        r = ss.simulate(sc)
    finally:
        SpoolProgram.level = None
    assert np.max(np.abs(r.ts["actuator_force"])) < 1e-9
    assert np.max(np.abs(r.ts["body_z"])) < 1e-9


def test_ensemble_with_and_without_end_stops():
    """Cars of one ensemble may differ in their spool stop (None = no stop)."""
    from suspension_sim.simulation import Simulation

    SpoolProgram.level = 0.02
    try:
        scs = []
        for lim in (None, 0.01, 0.015):
            sc = scenario(duration=0.2, spool_limit=lim)
            sc.road.params = {"amplitude": 0.0, "frequency": 1.0}
            scs.append(sc)
        res = Simulation(scs).run()
    finally:
        SpoolProgram.level = None
    peaks = [float(np.max(np.abs(r.ts["act.spool_position"]))) for r in res]
    assert peaks[0] > 0.015 and peaks[1] == pytest.approx(0.01) and peaks[2] == pytest.approx(0.015)
