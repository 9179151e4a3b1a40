"""The dm_control environment (suspension_sim/envs.py) and the step-wise Simulation API it runs on."""
import dm_env
import numpy as np
import pandas as pd
import pytest

import suspension_sim as ss
from suspension_sim.config import parse_scenario
from suspension_sim.envs import make_env
from suspension_sim.errors import ScenarioError
from suspension_sim.simulation import Simulation


def _raw(controller="passive", **sim):
    return dict(
        name="env_test",
        road=dict(type="sine", params={"frequency": 1.7, "amplitude": 0.01}),
        sensors=[dict(type="corner_body_vel", noise_std=0.005), dict(name="lvdt", type="travel", delay=0.004),
                 dict(type="body_acc", rate=250)],
        actuator=dict(type="ideal", params=dict(max_force=800.0, time_constant=0.002)),
        controller=dict(type=controller, params={"c_sky": 2000.0} if controller == "skyhook" else {}),
        sim={**dict(duration=0.6, control_dt=0.002, log_dt=0.001, seed=3), **sim},
    )


def _run_episode(env, policy):
    ts = env.reset()
    steps = [ts]
    while not ts.last():
        ts = env.step(policy(ts.observation))
        steps.append(ts)
    return steps


def test_step_api_matches_run():
    sc = parse_scenario(_raw("skyhook"))
    ref = Simulation([sc]).run()[0].ts
    sim = Simulation([sc])
    readings, n = sim.start(), 0
    while readings is not None:
        readings = sim.control_step(sim.controller.step(sim.t, readings))
        n += 1
    assert n == round(0.6 / 0.002)
    pd.testing.assert_frame_equal(sim.results[0].ts, ref, check_exact=True)


def test_specs_and_observation_keys():
    env = make_env(parse_scenario(_raw()))
    a = env.action_spec()
    assert a.shape == (1,)
    np.testing.assert_array_equal(a.minimum, [-800.0])
    np.testing.assert_array_equal(a.maximum, [800.0])
    obs_spec = env.observation_spec()
    assert list(obs_spec) == ["corner_body_vel", "lvdt", "body_acc"]
    ts = env.reset()
    assert ts.step_type == dm_env.StepType.FIRST
    assert list(ts.observation) == list(obs_spec)  # declared sensors only, no true state
    for k, spec in obs_spec.items():
        spec.validate(ts.observation[k])


def test_full_state_adds_state_observations_only_when_granted():
    raw = _raw()
    raw["controller"]["full_state"] = True
    env = make_env(parse_scenario(raw))
    obs = env.reset().observation
    assert {"corner_body_vel", "lvdt", "body_acc"} <= set(obs)
    assert "state.travel" in obs and all(k.startswith("state.") for k in set(obs) - {"corner_body_vel", "lvdt", "body_acc"})


def test_episode_length_time_and_zero_action_matches_passive_simulate():
    sc = parse_scenario(_raw())
    env = make_env(sc)
    steps = _run_episode(env, lambda obs: np.zeros(1))
    n = round(0.6 / 0.002)
    assert len(steps) == n + 1
    assert [s.step_type for s in steps[1:-1]] == [dm_env.StepType.MID] * (n - 1)
    assert steps[-1].step_type == dm_env.StepType.LAST and steps[-1].discount == 1.0
    assert env.physics.time() == pytest.approx(0.6)
    assert all(np.isfinite(s.reward) and s.reward <= 0 for s in steps[1:])
    ref = ss.simulate(sc).ts
    pd.testing.assert_frame_equal(env.physics.result().ts, ref, check_exact=True)


def test_skyhook_policy_through_env_matches_skyhook_run():
    """An agent computing the skyhook law from the observations reproduces the skyhook run exactly."""
    sc = parse_scenario(_raw("skyhook"))
    env = make_env(sc)
    _run_episode(env, lambda obs: -2000.0 * obs["corner_body_vel"])
    ref = ss.simulate(sc).ts
    got = env.physics.result().ts
    assert np.abs(ref["command"]).max() > 10  # the policy did act
    pd.testing.assert_frame_equal(got, ref, check_exact=True)


def test_reward_is_the_documented_cost():
    """With only the travel weight, −reward is travel² at each control instant (from the logged run)."""
    env = make_env(parse_scenario(_raw()), w_acc=0.0, w_travel=1.0, w_force=0.0)
    steps = _run_episode(env, lambda obs: np.array([200.0]))
    ts = env.physics.result().ts.set_index("t")["travel"]
    for i in (5, 100, 250):
        t = round(i * 0.002, 9)
        assert -steps[i].reward == pytest.approx(ts.loc[ts.index[np.argmin(np.abs(ts.index - t))]] ** 2, rel=1e-12)
    raw = _raw(log_dt=0.0005)
    raw["actuator"]["params"] = {}
    env2 = make_env(parse_scenario(raw), w_acc=0.0, w_travel=0.0, w_force=1.0)
    k = iter(range(10**6))
    steps2 = _run_episode(env2, lambda obs: np.array([300.0 * np.sin(0.1 * next(k))]))
    f = env2.physics.result().ts["actuator_force"].to_numpy()  # one row per physics step
    sub = env2.physics.sim.sub
    assert sub == 4  # dt 0.5 ms, control_dt 2 ms
    for i in (7, 150, 299):
        assert -steps2[i].reward == pytest.approx(f[sub * i - 1] ** 2, rel=1e-12)  # force over the last physics step
    assert len(set(np.round(f, 6))) > 100


def test_variants_reseed_and_bad_actions():
    raw = _raw()
    raw["variants"] = {"soft": {"vehicle": {"params": {"damping": 600.0}}}, "hard": {}}
    sc = parse_scenario(raw)
    with pytest.raises(ScenarioError, match="variant"):
        make_env(sc)
    env = make_env(sc, variant="soft", reseed=True)
    assert env.physics.sim.scenarios[0].vehicle.params["damping"] == 600.0
    o1 = [s.observation["corner_body_vel"][0] for s in _run_episode(env, lambda o: np.zeros(1))]
    o2 = [s.observation["corner_body_vel"][0] for s in _run_episode(env, lambda o: np.zeros(1))]
    assert o1 != o2  # new sensor-noise seed in the second episode
    env.reset()
    with pytest.raises(ValueError, match="one command per corner"):
        env.step(np.zeros(3))


def test_observations_are_the_loop_quantities_at_each_control_instant():
    """Noise-free sensors: the observation after step i is the state at t_i (travel logged at t_i; body
    acceleration of the physics step ending at t_i), including the final observation at t = duration."""
    raw = _raw(log_dt=0.0005)
    raw["sensors"] = [dict(type="travel"), dict(type="corner_body_acc")]
    env = make_env(parse_scenario(raw))
    k = iter(range(10**6))
    steps = _run_episode(env, lambda obs: np.array([300.0 * np.sin(0.05 * next(k))]))
    ts = env.physics.result().ts
    sub = env.physics.sim.sub
    for i in (1, 57, len(steps) - 2):
        assert steps[i].observation["travel"][0] == ts["travel"].iloc[sub * i]
        assert steps[i].observation["corner_body_acc"][0] == pytest.approx(ts["body_acc"].iloc[sub * i - 1], rel=1e-9, abs=1e-12)
    assert steps[-1].observation["corner_body_acc"][0] == pytest.approx(ts["body_acc"].iloc[-1], rel=1e-9, abs=1e-12)


def test_make_env_from_path_with_flat_observation(tmp_path):
    import yaml

    p = tmp_path / "rl.yaml"
    raw = _raw()
    raw["actuator"] = {"type": "ideal"}  # no max_force: unbounded unless action_bound is given
    p.write_text(yaml.safe_dump(raw))
    env = make_env(str(p), flat_observation=True, action_bound=1500.0)
    np.testing.assert_array_equal(env.action_spec().maximum, [1500.0])
    ts = env.reset()
    assert ts.observation["observations"].shape == (3,)  # corner_body_vel, lvdt, body_acc: one value each
    assert env.control_timestep() == pytest.approx(0.002)
    with pytest.raises(ScenarioError, match="rl.yaml: road.type"):
        p.write_text(yaml.safe_dump({**raw, "road": {"type": "moon"}}))
        make_env(p)
