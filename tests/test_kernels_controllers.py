"""Compiled controller kernels (issue 7) against their numpy ``step``: each test runs a short closed loop in
Python (suspension_sim.compiled.testing.check_controller), replays every control step's readings through
the kernel, one car at a time, and compares commands and logged signals.

Laws built from + − × ÷ and comparisons only are required to match exactly (0.0).  Where the numpy law
uses a transcendental function or a BLAS matrix product, the kernel may round differently in the last
place; those tests allow 1e-12 relative to the largest magnitude compared and say why."""
import numpy as np
import pytest

from suspension_sim.compiled.testing import check_controller
from suspension_sim.config import parse_scenario, load_scenario
from suspension_sim.simulation import Simulation


def _quarter(controller, sensors, duration=0.5, road=None, **sim):
    return parse_scenario(dict(
        name="kernel_test",
        road=road or dict(type="sine", params={"frequency": 1.7, "amplitude": 0.02}),
        sensors=sensors,
        actuator=dict(type="ideal", params=dict(max_force=3000.0, time_constant=0.002)),
        controller=controller,
        sim={**dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001, seed=3), **sim},
    ))


def _python_run(sim):
    """The Python closed loop: per control step {t, readings, u, signals} (to check which branches occur)."""
    out = []
    readings = sim.start()
    while readings is not None:
        u = np.broadcast_to(np.asarray(sim.controller.step(sim.t, readings), dtype=float),
                            (sim.plant.n, sim.plant.nc)).copy()
        out.append(dict(t=sim.t, readings=readings, u=u,
                        signals={k: np.array(v, dtype=float) for k, v in sim.controller.signals().items()}))
        readings = sim.control_step(u)
    return out


# passive / skyhook ---------------------------------------------------------------------------------------

# check_controller concatenates the readings of the declared sensors and cannot handle none: the runs of
# controllers that read nothing declare one unused sensor
UNUSED = [dict(type="travel")]


def test_passive_kernel_is_zero():
    sims = [Simulation([_quarter(dict(type="passive"), [dict(type="corner_body_vel")])]),
            Simulation([_quarter(dict(type="passive"), UNUSED, duration=0.2)] * 3)]
    for sim in sims:
        assert check_controller(sim) == 0.0


SKY_SENSORS = [dict(type="travel_rate", noise_std=0.01), dict(type="corner_body_vel", noise_std=0.005),
               dict(type="wheel_vel", noise_std=0.01)]


def test_skyhook_kernel_single_car_exact():
    sc = _quarter(dict(type="skyhook", params=dict(c_sky=2500.0)), [dict(type="corner_body_vel", noise_std=0.002)])
    assert check_controller(Simulation([sc])) == 0.0


def test_skyhook_kernel_ensemble_groundhook_semi_active_exact():
    """Three cars with different gains, one without groundhook, semi-active clipping active on all (the
    numpy law applies one flag to the ensemble); noisy travel rate so that both sides of the clip occur."""
    scs = [_quarter(dict(type="skyhook", params=dict(c_sky=cs, c_ground=cg, semi_active=True)), SKY_SENSORS)
           for cs, cg in ((2500.0, 0.0), (1200.0, 800.0), (4000.0, 300.0))]
    u = np.array([s["u"] for s in _python_run(Simulation(scs))])
    assert np.sum(u == 0.0) > 50 and np.sum(u != 0.0) > 50  # both branches of the clip, on every car
    assert np.all(np.sum(u == 0.0, axis=0) > 0) and np.all(np.sum(u != 0.0, axis=0) > 0)
    assert check_controller(Simulation(scs)) == 0.0


def test_skyhook_kernel_groundhook_without_clip_half_car_exact():
    sc = parse_scenario(dict(
        vehicle=dict(model="half_car"), road=dict(type="sine", params={"frequency": 1.2, "amplitude": 0.02}, speed=10),
        sensors=[dict(type="corner_body_vel"), dict(type="wheel_vel")],
        controller=dict(type="skyhook", params=dict(c_sky=2000.0, c_ground=500.0)),
        sim=dict(duration=0.3, dt=0.0005, control_dt=0.001, log_dt=0.001)))
    assert check_controller(Simulation([sc, sc.model_copy(deep=True)])) == 0.0
