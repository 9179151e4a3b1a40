"""The ideal force actuator's non-idealities against their definitions: pure delay, first-order lag (exact
ZOH discretisation), rate limit and saturation."""
import numpy as np

from suspension_sim.actuators.base import ActuatorContext
from suspension_sim.actuators.ideal import IdealActuator, IdealParams
from suspension_sim.components import stack_params

DT = 5e-4


def make(**kw):
    p = stack_params([IdealParams(**kw)], 1)
    return IdealActuator(p, ActuatorContext(1, 1, DT, 1e-3, np.zeros((1, 1))))


def drive(act, u):
    out = []
    z = np.zeros((1, 1))
    for k, uk in enumerate(u):
        cmd = np.full((1, 1), uk)
        out.append(act.force(cmd, z, z, k * DT)[0, 0])
        act.advance(cmd, z, z, k * DT, DT)
    return np.array(out)


def test_ideal_passes_the_command_through():
    u = np.sin(np.arange(200) * 0.1) * 1000
    np.testing.assert_array_equal(drive(make(), u), u)


def test_delay():
    u = np.sin(np.arange(200) * 0.1) * 1000
    y = drive(make(delay=0.005), u)  # 10 physics steps
    np.testing.assert_allclose(y[10:], u[:-10])
    assert np.all(y[:10] == 0)


def test_first_order_lag_step():
    tau = 0.01
    y = drive(make(time_constant=tau), np.ones(400) * 100.0)
    k = np.arange(400)
    np.testing.assert_allclose(y, 100.0 * (1 - np.exp(-(k + 1) * DT / tau)), rtol=1e-12)


def test_rate_limit_and_saturation():
    y = drive(make(rate_limit=1e5, max_force=300.0), np.ones(100) * 1000.0)
    np.testing.assert_allclose(y[:6], 50.0 * np.arange(1, 7))  # a 1e5 N/s ramp is 50 N per 0.5 ms step ...
    assert y.max() == 300.0 and np.all(y[6:] == 300.0)  # ... up to the saturation
    y = drive(make(max_force=30.0), np.linspace(-100, 100, 50))
    assert y.min() == -30.0 and y.max() == 30.0
