"""The sensor pipeline (delay -> bias + noise -> quantisation -> sample-and-hold), seeding, and what a
controller is allowed to see."""
import numpy as np
import pytest

import suspension_sim as ss
from suspension_sim.controllers.base import Controller
from suspension_sim.config import parse_scenario
from suspension_sim.registry import CONTROLLERS

SEEN = {}


@CONTROLLERS.register("_test_recorder")
class Recorder(Controller):
    """Test-only: records the keys it is given."""

    def step(self, t, y):
        SEEN["keys"] = sorted(y)
        return self.zeros()


def run(sensors, controller=None, seed=0, duration=2.0):
    raw = {"road": {"type": "sine", "params": {"amplitude": 0.02, "frequency": 1.5}, "speed": 0},
           "sensors": sensors, "sim": {"duration": duration, "seed": seed}}
    if controller:
        raw["controller"] = controller
    return ss.simulate(parse_scenario(raw))


def test_delay_is_whole_control_steps():
    r = run([{"name": "lvdt", "type": "travel", "delay": 0.005}])
    y, true = r.ts["sensor.lvdt.value"].to_numpy(), r.ts["travel"].to_numpy()
    np.testing.assert_allclose(y[5:], true[:-5], rtol=0, atol=1e-15)
    assert np.max(np.abs(y[5:] - true[5:])) > 1e-4  # and it is really delayed


def test_sample_and_hold_at_rate():
    r = run([{"name": "slow", "type": "travel", "rate": 100}])
    y, true = r.ts["sensor.slow.value"].to_numpy(), r.ts["travel"].to_numpy()
    blocks = y.reshape(-1, 10)
    assert np.all(blocks == blocks[:, :1])  # constant over each 10 ms hold
    np.testing.assert_allclose(blocks[:, 0], true.reshape(-1, 10)[:, 0], atol=1e-15)


def test_noise_bias_and_seed():
    sens = [{"name": "acc", "type": "corner_body_acc", "noise_std": 0.05, "bias": 0.2}]
    a, b, c = run(sens, seed=1), run(sens, seed=1), run(sens, seed=2)
    err = a.ts["sensor.acc.value"].to_numpy() - a.ts["corner_body_acc"].to_numpy() if "corner_body_acc" in a.ts \
        else a.ts["sensor.acc.value"].to_numpy() - a.ts["body_acc"].to_numpy()
    assert abs(err.mean() - 0.2) < 4 * 0.05 / np.sqrt(err.size)
    assert abs(err.std() / 0.05 - 1) < 0.05
    np.testing.assert_array_equal(a.ts["sensor.acc.value"], b.ts["sensor.acc.value"])
    assert not np.array_equal(a.ts["sensor.acc.value"], c.ts["sensor.acc.value"])


def test_quantisation():
    q = 0.001
    r = run([{"name": "lvdt", "type": "travel", "quantization": q}])
    y, true = r.ts["sensor.lvdt.value"].to_numpy(), r.ts["travel"].to_numpy()
    np.testing.assert_allclose(y / q, np.round(y / q), atol=1e-9)
    assert np.max(np.abs(y - true)) <= q / 2 + 1e-12
    assert np.max(np.abs(y - true)) > q / 4  # really quantised


def test_controller_sees_declared_sensors_only():
    r = run([{"name": "lvdt", "type": "travel"}], controller={"type": "_test_recorder"}, duration=0.01)
    assert SEEN["keys"] == ["lvdt"]
    assert r.info["full_state_access"] is False
    r = run([{"name": "lvdt", "type": "travel"}], controller={"type": "_test_recorder", "full_state": True},
            duration=0.01)
    assert "lvdt" in SEEN["keys"] and "state.body_pos" in SEEN["keys"] and "state.travel" in SEEN["keys"]
    assert r.info["full_state_access"] is True


def test_missing_sensor_is_a_scenario_error():
    with pytest.raises(ss.ScenarioError, match="needs sensor"):
        parse_scenario({"road": {"type": "flat"}, "controller": {"type": "skyhook"}})



# ---- accelerometer sampling (params.sampling: instant | period_mean) ---------------------------------------
def test_period_mean_law_constant_jerk():
    """The law itself on a closed form: under a constant jerk j, v(t) = j t²/2, the mean acceleration over
    the period [t − T, t] is j (t − T/2); the last physics step's (the instant reading) is j (t − dt/2)."""
    from suspension_sim.sensors.base import period_mean_acc

    j, T, dt = 40.0, 1e-3, 5e-4
    v = lambda t: 0.5 * j * t * t  # noqa: E731
    dofs = np.array([0], dtype=np.int64)
    v_last, out = np.array([v(0.0)]), np.zeros(1)
    for k in range(1, 6):
        t = k * T
        period_mean_acc(np.array([v(t)]), v_last, dofs, T, out)
        assert out[0] == pytest.approx(j * (t - T / 2), rel=1e-12)
        instant = (v(t) - v(t - dt)) / dt
        assert abs(instant - out[0]) == pytest.approx(j * (T - dt) / 2, rel=1e-9)  # the old reading is off
        assert v_last[0] == v(t)


@pytest.mark.parametrize("compiled", ["1", "0"])
def test_period_mean_accelerometer_reads_the_control_period_mean(compiled, monkeypatch):
    """In a run, both loops: the period-mean sensor reads (v(t) − v(t − T))/T of the logged velocities at
    every control instant; the instant one reads the last physics step's (v(t) − v(t − dt))/dt, which differs."""
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", compiled)
    raw = {"road": {"type": "bump", "params": {"height": 0.05, "length": 0.5, "start": 0.05}, "speed": 10.0},
           "sensors": [{"name": "mean", "type": "corner_body_acc", "params": {"sampling": "period_mean"}},
                       {"name": "inst", "type": "corner_body_acc", "params": {"sampling": "instant"}},
                       {"name": "wmean", "type": "wheel_acc", "params": {"sampling": "period_mean"}},
                       {"type": "corner_body_vel"}],
           "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
           "sim": {"duration": 0.3, "dt": 0.0005, "control_dt": 0.002, "log_dt": 0.0005}}
    ts = ss.simulate(parse_scenario(raw)).ts
    sub, T, dt = 4, 0.002, 0.0005
    v, w = ts["body_vel"].to_numpy(), ts["wheel_vel"].to_numpy()
    k = np.arange(sub, len(v), sub)  # log rows of the control instants (after the first)
    mean_v = (v[k] - v[k - sub]) / T
    inst_v = (v[k] - v[k - 1]) / dt
    np.testing.assert_allclose(ts["sensor.mean.value"].to_numpy()[k], mean_v, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ts["sensor.inst.value"].to_numpy()[k], inst_v, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ts["sensor.wmean.value"].to_numpy()[k], (w[k] - w[k - sub]) / T, rtol=1e-9, atol=1e-9)
    assert np.max(np.abs(mean_v - inst_v)) > 0.05 * np.max(np.abs(inst_v))  # the two readings differ


def test_period_mean_refuses_a_slower_rate_and_unknown_values():
    base = {"road": {"type": "flat"}, "sim": {"duration": 0.01}}
    with pytest.raises(ss.ScenarioError, match="period_mean"):
        ss.simulate(parse_scenario({**base, "sensors": [{"type": "body_acc", "rate": 100,
                                                         "params": {"sampling": "period_mean"}}]}))
    with pytest.raises(ss.ScenarioError, match="sampling"):
        ss.simulate(parse_scenario({**base, "sensors": [{"type": "body_acc", "params": {"sampling": "mean"}}]}))
    with pytest.raises(ss.ScenarioError, match="sampling"):
        ss.simulate(parse_scenario({**base, "sensors": [{"type": "travel", "params": {"sampling": "period_mean"}}]}))
