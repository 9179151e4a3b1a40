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

