"""A ``dm_control`` reinforcement-learning environment around a scenario (``make_env(..., api="gymnasium")``
gives the Gymnasium one of :mod:`suspension_sim.rl`).

::

    from suspension_sim.envs import make_env

    env = make_env("scenarios/quickstart.yaml", variant="passive", w_travel=1e3)
    ts = env.reset()
    while not ts.last():
        ts = env.step(policy(ts.observation))      # action: one actuator command per corner
    result = env.physics.result()                  # the episode's Result (time series, metrics)

- **Observation**: the scenario's declared sensors only, ``{sensor name: float64 array (k,)}`` with the
  sensors' own noise, bias, delay, quantisation and rate (plus the true ``state.*`` quantities if, and only
  if, the scenario sets ``controller.full_state: true``).
- **Action**: the actuator command per corner, shape ``(n_corners,)`` (a force in N for the ideal and
  electromagnetic actuators; see the actuator's ``command_unit``).  Bounds: ``±actuator.params.max_force``
  when the actuator has one, else ``±action_bound`` if given, else unbounded.  Actions are not clipped by the
  environment; a saturating actuator saturates them as it would any controller's command.
- **Step**: one environment step = one control step (``sim.control_dt``); the command is held (zero-order
  hold) over it.  **Episode**: ``sim.duration`` (``control.Environment``'s time limit, so the last step has
  discount 1).
- **Reward** (a cost, chosen here and not from a paper), from the *true* plant state at the end of the step,
  summed over corners::

      r = −Σ_c ( w_acc·a_c² + w_travel·s_c² + w_force·F_c² + w_tire·Ft_c² )

  with a_c the vertical acceleration of the body above corner c [m/s²], s_c the suspension travel [m], F_c
  the actuator force [N] and Ft_c the dynamic tire force [N].  Defaults ``w_acc=1``, ``w_travel=1e3``
  (1 cm of travel costs as much as 0.32 m/s²), ``w_force=1e-7`` (1 kN costs as much as 0.32 m/s²),
  ``w_tire=0``.

The physics is :class:`~suspension_sim.simulation.Simulation`'s own loop, driven step by step through
:meth:`Simulation.start`/:meth:`Simulation.control_step` (road, effects, actuator, sensors, ZOH, logging and
the divergence guard are the same as in ``simulate()``), so a zero-action episode reproduces the passive run
exactly.  The scenario's controller is replaced by ``passive`` (the agent is the controller).

:class:`SuspensionPhysics` subclasses ``dm_control.mujoco.Physics`` around the simulation's MjModel/MjData
(so named indexing and ``physics.render()`` work as usual); :class:`SuspensionTask` is a
``dm_control.rl.control.Task``.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
from dm_control.mujoco import engine as _engine
from dm_control.mujoco import wrapper as _wrapper
from dm_control.rl import control
from dm_env import specs

from .config import Scenario, load_scenario, pick_variant
from .loop import plant_state
from .sensors.base import full_state_readings, period_mean_acc
from .simulation import Simulation


@dataclass
class RewardWeights:
    """Weights of the per-step cost (see the module docstring)."""

    w_acc: float = 1.0
    w_travel: float = 1e3
    w_force: float = 1e-7
    w_tire: float = 0.0


class SuspensionPhysics(_engine.Physics):
    """``dm_control.mujoco.Physics`` whose stepping delegates to a :class:`Simulation`.

    ``step(nstep)`` advances ``nstep`` physics steps (a whole number of control steps) holding the command
    given to :meth:`set_control`; :meth:`reset` restarts the run.  :meth:`readings` are the sensor readings
    at the current control instant, :meth:`plant_state` the true plant quantities there, :meth:`result` the
    logged run once the episode is over.
    """

    def __init__(self, make_sim, reseed: bool = False):
        self._make_sim = make_sim
        self._reseed = reseed
        self._episode = 0
        self.sim: Simulation = make_sim(0)
        self._command = None
        self._readings = None
        self._state = None
        self._done = True
        super().__init__(_wrapper.MjData(self.sim.plant.data))

    # -- dm_control.mujoco.Physics ------------------------------------------------------------------
    def reset(self, keyframe_id=None):
        if self._reseed and self._episode > 0:
            self.sim = self._make_sim(self._episode)
            self._reload_from_data(_wrapper.MjData(self.sim.plant.data))
        self._episode += 1
        P = self.sim.plant
        self._command = np.zeros((P.n, P.nc))
        self._readings = self.sim.start()
        self._state = self.sim.state
        self._done = self._readings is None
        if self._done:  # a run shorter than one physics step
            self._readings, self._state = self._final_readings()

    def after_reset(self):
        pass  # the simulation has set the state (dm_control's default would call mj_forward)

    def set_control(self, control_):
        P = self.sim.plant
        u = np.asarray(control_, dtype=float)
        if u.size != P.n * P.nc:
            raise ValueError(f"action must have {P.nc} value(s) (one command per corner), got shape {u.shape}")
        self._command = u.reshape(P.n, P.nc).copy()

    def step(self, nstep: int = 1):
        sub = self.sim.sub
        if nstep % sub:
            raise ValueError(f"step({nstep}): must be a whole number of control steps ({sub} physics steps each)")
        for _ in range(nstep // sub):
            if self._done:
                raise RuntimeError("the episode is over: call reset()")
            r = self.sim.control_step(self._command)
            if r is None:
                self._done = True
                self._readings, self._state = self._final_readings()
            else:
                self._readings, self._state = r, self.sim.state

    def time(self):
        return self.sim.duration if self._done else float(self.sim.t)

    def timestep(self):
        return self.sim.dt

    # -- extras ---------------------------------------------------------------------------------------
    @property
    def done(self) -> bool:
        return self._done

    def readings(self) -> dict:
        return self._readings

    def plant_state(self):
        """True plant quantities (:class:`~suspension_sim.sensors.base.PlantState`) at the current instant."""
        return self._state

    def result(self):
        """The episode's :class:`~suspension_sim.results.Result` (time series and metrics), once it is over."""
        if not self._done or self.sim.results is None:
            raise RuntimeError("the episode is not over yet")
        return self.sim.results[0]

    def _final_readings(self):
        """Sensor readings and true state at t = duration, after the simulation loop has ended (for the last
        observation and reward).  The loop's final state is complete except for the position-dependent
        quantities, which ``mj_step1`` computes without advancing time, with the road placed at t = duration."""
        sim = self.sim
        P, m, d = sim.plant, sim.plant.model, sim.plant.data
        k = sim.n_steps
        z, zd = sim.road_chunk(k, k + 1)[:2]
        road, road_vel = z[:, 0, :], zd[:, 0, :]
        acc, F_act, F_teff = sim.end_forces  # the last physics step's, as the loop would hold them
        P.place_road(d, road, road_vel)
        mujoco.mj_step1(m, d)
        P.restore_road()
        period_mean_acc(d.qvel, sim.v_ctrl, sim.acc_dofs, sim.acc_period, sim.acc_mean)
        state = plant_state(sim, k * sim.dt, road, road_vel, acc, F_act, F_teff, sim.acc_mean)
        readings = {ch.name: ch.sample(state) for ch in sim.sensors}
        if sim.full_state:
            readings.update(full_state_readings(state))
        return readings, state


class SuspensionTask(control.Task):
    """Observation = declared sensor readings, action = command per corner, reward = −(weighted cost)."""

    def __init__(self, sim: Simulation, weights: RewardWeights, action_bound: float | None = None):
        self.weights = weights
        self.corners = list(sim.geom.corner_names)
        self.labels = {ch.name: ch.sensor.labels() for ch in sim.sensors}
        self.full_state = sim.full_state
        self.action_bound = action_bound
        self.command_unit = sim.cctx.command_unit

    def initialize_episode(self, physics):
        pass

    def before_step(self, action, physics):
        physics.set_control(action)

    def action_spec(self, physics):
        b = np.inf if self.action_bound is None else float(self.action_bound)
        n = len(self.corners)
        return specs.BoundedArray((n,), np.float64, np.full(n, -b), np.full(n, b),
                                  name=f"command[{self.command_unit}]:" + ",".join(self.corners))

    def get_observation(self, physics):
        r = physics.readings()
        obs = collections.OrderedDict()
        for name in self.labels:
            obs[name] = np.array(r[name][0], dtype=np.float64).reshape(-1)
        if self.full_state:
            for name, val in r.items():
                if name.startswith("state."):
                    obs[name] = np.array(np.asarray(val)[0], dtype=np.float64).reshape(-1)
        return obs

    def observation_spec(self, physics):
        if self.full_state:
            raise NotImplementedError  # control.Environment infers it from an observation
        return collections.OrderedDict(
            (name, specs.Array((len(lab),), np.float64, name=name)) for name, lab in self.labels.items())

    def get_reward(self, physics):
        s, w = physics.plant_state(), self.weights
        cost = w.w_acc * s.corner_body_acc[0] ** 2 + w.w_travel * s.travel[0] ** 2
        if w.w_force:
            cost = cost + w.w_force * s.actuator_force[0] ** 2
        if w.w_tire:
            cost = cost + w.w_tire * s.tire_force[0] ** 2
        return -float(np.sum(cost))

    def get_termination(self, physics):
        return 1.0 if physics.done else None


def _scenario(scenario, variant, source):
    if isinstance(scenario, (str, Path)):
        source = str(scenario)
        scenario = load_scenario(scenario)
    if not isinstance(scenario, Scenario):
        raise TypeError("make_env needs a scenario path or a Scenario")
    return pick_variant(scenario, variant, source), source


def make_env(scenario, variant: str | None = None, *, api: str = "dm_control", w_acc: float = 1.0,
             w_travel: float = 1e3, w_force: float = 1e-7, w_tire: float = 0.0, action_bound: float | None = None,
             reseed: bool = False, flat_observation: bool = False, **gym_kwargs):
    """A ``dm_control`` ``control.Environment`` for one scenario (path or :class:`Scenario`).

    ``api="gymnasium"`` returns a Gymnasium environment instead (:func:`suspension_sim.rl.env.make_gym_env`:
    its own reward, normalised actions, ``num_envs=N`` for the compiled ensemble; the keyword arguments after
    ``api`` are then those of that function).

    ``variant`` picks one of the scenario's variants.  Reward weights as in the module docstring.
    ``action_bound`` sets the action spec's bounds when the actuator has no ``max_force``.  ``reseed``: each
    new episode uses ``sim.seed`` (and the road seed) + episode index, so the road and the sensor noise
    change between episodes (the first episode is the scenario as written).
    """
    if api == "gymnasium":
        from .rl.env import make_gym_env

        return make_gym_env(scenario, variant, **gym_kwargs)
    if api != "dm_control":
        raise ValueError(f"api must be 'dm_control' or 'gymnasium', got {api!r}")
    if gym_kwargs:
        raise TypeError(f"make_env: unexpected argument(s) {', '.join(gym_kwargs)} for the dm_control api")
    sc, source = _scenario(scenario, variant, None)
    ctrl = sc.controller.model_copy(update={"type": "passive", "params": {}})
    sc = sc.model_copy(update={"controller": ctrl})

    def make_sim(episode: int) -> Simulation:
        s = sc
        if episode:
            road = s.road.model_copy(update={"seed": (s.road.seed if s.road.seed is not None else s.sim.seed) + episode})
            s = s.model_copy(update={"road": road, "sim": s.sim.model_copy(update={"seed": s.sim.seed + episode})})
        return Simulation([s], source)

    physics = SuspensionPhysics(make_sim, reseed=reseed)
    bound = getattr(physics.sim.actuator.p, "max_force", None)
    bound = float(np.max(bound)) if bound is not None else action_bound
    task = SuspensionTask(physics.sim, RewardWeights(w_acc, w_travel, w_force, w_tire), bound)
    sim = physics.sim
    return control.Environment(physics, task, time_limit=sim.duration, n_sub_steps=sim.sub,
                               flat_observation=flat_observation)
