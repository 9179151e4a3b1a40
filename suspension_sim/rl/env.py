"""Gymnasium environments on the simulator: one car (:class:`SuspensionEnv`) and an ensemble of N cars in one
compiled loop (:class:`SuspensionVectorEnv`).

::

    import gymnasium, suspension_sim
    env = gymnasium.make("suspension_sim/QuarterCar-v0")           # or HalfCar-v0, FullCar-v0
    env = suspension_sim.rl.make_gym_env("scenarios/quickstart.yaml", variant="passive")
    venv = gymnasium.make_vec("suspension_sim/QuarterCar-v0", num_envs=256,
                              vectorization_mode="vector_entry_point")

**Observation** — the scenario's declared sensors, concatenated in the order they are declared, each with its
own noise, bias, delay, quantisation and rate (the measurement pipeline of ``simulate()``); then, only if the
scenario sets ``controller.full_state: true``, the true plant quantities ``state.*``.  A ``Box(-inf, inf,
(D,), float32)`` in SI units (m, m/s, m/s², N, rad) times ``obs_scale`` (default 1: SI units unchanged).
``env.unwrapped.observation_labels`` names each entry (``"travel.single"``, ``"corner_body_vel.front"``...).
For the presets: ``corner_body_acc`` [m/s²], ``corner_body_vel`` [m/s], ``travel`` [m] (body − wheel,
extension +), ``travel_rate`` [m/s], one value per corner each.

**Action** — the actuator command per corner, normalised: ``Box(-1, 1, (n_corners,), float32)``; the
command is ``clip(a, -1, 1) · action_scale``, ``action_scale`` defaulting to the actuator's limit
(``max_force`` [N] of the ideal actuator, ``spool_limit`` [m] of the hydraulic one; give it otherwise).  Held
over one control step (``sim.control_dt``; the presets: 5 ms), which is one environment step.

**Reward** — minus a cost, from the *true* plant state at the end of the step, averaged over corners
(:class:`Reward`; every weight configurable, ``reward=Reward(...)`` or ``reward={...}``)::

    cost = w_acc · a_w²                                    a_w: ISO 2631-1 Wk-weighted vertical acceleration
                                                                of the body above the corner [m/s²]
         + w_travel · max(|s| − travel_limit, 0)²          s: suspension travel [m]
         + w_tire · (F_t / F_static)²                      F_t: dynamic tire force, F_static the static load
         + w_power · |F_a · ṡ|                             F_a: actuator force [N], ṡ travel rate [m/s]
    reward = −cost   (− termination_penalty − w_remaining · steps left in the episode, on the step that terminates)

Defaults ``w_acc=1, travel_limit=0.08 m, w_travel=1e4, w_tire=1, w_power=1e-4, terminate_travel=0.15 m,
termination_penalty=100, w_remaining=5``: the passive quarter car on the class C road at 20 m/s costs about
1.4 per step (mostly the Wk term), so ending an episode early by hitting the travel limit never pays.
The Wk filter is the one of the ``iso2631_wk_rms`` metric (bilinear sections, :mod:`..metrics.iso2631`),
discretised at the control rate and run step by step.  The weights are chosen here, not from a paper.

**Termination** — ``|s| > terminate_travel`` on any corner, or a diverging run (the simulator's divergence
guard; ``info["diverged"]``).  **Truncation** — at ``sim.duration`` (``duration / control_dt`` steps; the
last observation is at ``t = duration``).

**Randomisation** — every episode draws, from the env's generator (seeded by ``reset(seed=...)``), a new
road seed and a new sensor-noise seed, and one value of every ``randomize`` entry: ``{dotted scenario path:
distribution}`` with the batch sweep's distributions (``{dist: uniform, low: 250, high: 350}``, ``{dist:
choice, values: [B, C, D]}``, any scipy.stats name; see :mod:`suspension_sim.batch`), e.g.
``randomize={"vehicle.params.sprung_mass": {"dist": "uniform", "low": 250, "high": 350}}`` (load).

**Vectorised** — :class:`SuspensionVectorEnv` runs N cars as one ensemble in the compiled loop (one MuJoCo
model, one loop call per control step for all cars).  Car i is the single env seeded with ``seed + i``
(equal value by value while no car terminates).  The cars share the episode clock: they all truncate
together at ``sim.duration``, and the next ``step`` starts a new episode for all (new draws per car).  A car
that terminates early is reset in place at the next ``step`` (autoreset mode NEXT_STEP): its body and wheels
are put at rest on the road under them (a car heavier than it was levelled with, sagged as at the start
of a run) and the episode goes on from there with zero command for that step;
its actuator (lag, delay line, spool and pressure, coil currents), its effects' states and its sensors (delay
lines, sample-and-hold) start again from their initial state, as in a new env (``System.reset_cars``; the
other cars are untouched, and the car's road and noise stream go on; the trapezoidal integrator's last-step
velocities of the car restart too: value by value a new env, docs/learning.md).  A diverging
car stops the ensemble's run: that car terminates, the others truncate, and all start a new episode.
"""
from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector.utils import batch_space

from ..config import Scenario, parse_scenario
from ..errors import ScenarioError, SimulationDiverged
from .runner import EnsembleRunner


@dataclass
class Reward:
    """Weights of the per-step cost (module docstring)."""

    w_acc: float = 1.0  # per (m/s²)² of Wk-weighted body acceleration above a corner
    travel_limit: float = 0.08  # m: travel beyond this costs w_travel per m²
    w_travel: float = 1e4
    w_tire: float = 1.0  # per (dynamic tire force / static tire force)²
    w_power: float = 1e-4  # per W of |actuator force × travel rate|
    terminate_travel: float = 0.15  # m: |travel| beyond this ends the episode
    termination_penalty: float = 100.0  # on the terminating step, plus w_remaining per step not run
    w_remaining: float = 5.0  # > the cost per step of any sane policy, so that ending early never pays

    @classmethod
    def of(cls, r) -> "Reward":
        if r is None:
            return cls()
        if isinstance(r, cls):
            return r
        if isinstance(r, dict):
            names = {f.name for f in dataclasses.fields(cls)}
            bad = sorted(set(r) - names)
            if bad:
                raise ScenarioError(f"reward: unknown weight(s) {', '.join(bad)} (known: {', '.join(sorted(names))})")
            return cls(**{k: float(v) for k, v in r.items()})
        raise TypeError("reward must be a Reward or a dict of weights")


class WkFilter:
    """ISO 2631-1 Wk weighting run sample by sample over an array of channels (direct form II transposed
    second-order sections, the arithmetic of ``scipy.signal.sosfilt``)."""

    def __init__(self, fs: float, shape: tuple):
        from ..metrics.iso2631 import weighting_sos

        self.sos = weighting_sos(fs, "Wk")
        self.z = np.zeros((len(self.sos), 2) + tuple(shape))

    def reset(self, mask=None):
        if mask is None:
            self.z[...] = 0.0
        else:
            self.z[:, :, mask] = 0.0

    def __call__(self, x):
        z = self.z
        for j, (b0, b1, b2, _, a1, a2) in enumerate(self.sos):
            y = b0 * x + z[j, 0]
            z[j, 0] = b1 * x - a1 * y + z[j, 1]
            z[j, 1] = b2 * x - a2 * y
            x = y
        return x


def _resolve(scenario, variant, overrides, source=None) -> tuple[Scenario, str | None]:
    """A scenario path, Scenario, preset name or scenario dict -> (one resolved Scenario, source)."""
    from .presets import PRESETS

    if isinstance(scenario, str) and scenario in PRESETS:
        raw = copy.deepcopy(PRESETS[scenario])
        source = f"preset {scenario}"
    elif isinstance(scenario, dict):
        raw = copy.deepcopy(scenario)
    elif isinstance(scenario, (str, Path)):
        source = str(scenario)
        from ..config import read_yaml

        raw = read_yaml(scenario)
    elif isinstance(scenario, Scenario):
        raw = scenario.model_dump(mode="json")
    else:
        raise TypeError("scenario must be a path, a preset name, a scenario dict or a Scenario")
    from ..config import apply_set, pick_variant

    for s in overrides or []:
        apply_set(raw, s, source=source)
    sc = parse_scenario(raw, source=source)
    return pick_variant(sc, variant, source), source


def _action_scale(sim, action_scale, source):
    if action_scale is not None:
        a = np.asarray(action_scale, dtype=float)
        if np.any(~np.isfinite(a)) or np.any(a <= 0):
            raise ScenarioError("action_scale must be positive and finite", source=source)
        return np.broadcast_to(a, (sim.plant.nc,)).copy()
    from ..controllers.policy import command_limit

    lim = command_limit(sim.actuator.p)
    if lim is not None:
        return np.broadcast_to(lim[0].reshape(-1), (sim.plant.nc,)).copy()
    raise ScenarioError(f"actuator {sim.actuator.name!r} has no command limit: pass action_scale=<command for "
                        "action 1>", source=source, field="actuator.params")


class _Core:
    """What the single and the vectorised env share: scenario draws, the ensemble run, observation, reward."""

    def __init__(self, scenario, n_envs: int, *, variant=None, overrides=None, reward=None, randomize=None,
                 obs_scale=None, action_scale=None):
        from ..batch import DistCfg

        sc, source = _resolve(scenario, variant, overrides)
        if not sc.sensors and not sc.controller.full_state:
            raise ScenarioError("the environment observes the scenario's declared sensors: declare at least one",
                                source=source, field="sensors")
        self.source = source
        self.n = int(n_envs)
        if self.n < 1:
            raise ValueError("n_envs must be >= 1")
        # one control step more than the episode, so that the last observation (t = duration) exists
        self.n_episode_steps = int(round(sc.sim.duration / sc.sim.control_dt))
        sim_cfg = sc.sim.model_copy(update={"duration": sc.sim.duration + sc.sim.control_dt})
        ctrl = sc.controller.model_copy(update={"type": "passive", "params": {}})
        outs = sc.outputs.model_copy(update={"timeseries": False, "plots": False, "viewer": False, "report": False})
        self.base = sc.model_copy(update={"sim": sim_cfg, "controller": ctrl, "outputs": outs})
        self.base_raw = self.base.model_dump(mode="json")
        self.reward = Reward.of(reward)
        try:
            self.randomize = {str(k): (v if isinstance(v, DistCfg) else DistCfg.model_validate(v))
                              for k, v in (randomize or {}).items()}
        except Exception as exc:  # pydantic's message, one line
            raise ScenarioError(f"randomize: {str(exc).splitlines()[-1] if str(exc) else exc}", source=source) from None
        self.sim = None
        self.runner = None
        self._obs_scale_arg, self._action_scale_arg = obs_scale, action_scale
        # spaces from a probe build (one car)
        self._build([self.base] * self.n)
        self.control_dt = self.base.sim.control_dt
        self.nc = self.sim.plant.nc
        self.corners = list(self.sim.geom.corner_names)
        self.layout = self.sim.cctx.reading_layout()
        self.labels = []
        for name, w in self.layout.items():
            labs = self.sim.cctx.sensors.get(name) or [str(j) for j in range(w)]
            self.labels += [f"{name}.{lab}" if lab else name for lab in labs[:w]]
        self.obs_dim = sum(self.layout.values())
        self.obs_scale = self._scale_vector(obs_scale)
        self.action_scale = _action_scale(self.sim, action_scale, source)
        self.command_unit = self.sim.cctx.command_unit
        self.wk = WkFilter(1.0 / self.control_dt, (self.n, self.nc))
        self.static_tire = np.maximum(np.abs(self.sim.plant.static_tire), 1e-9) if self.sim.plant.has_tire else None

    def _scale_vector(self, obs_scale):
        if obs_scale is None:
            return np.ones(self.obs_dim)
        if isinstance(obs_scale, dict):
            out = []
            for name, w in self.layout.items():
                out += [float(obs_scale.get(name, 1.0))] * w
            unknown = sorted(set(obs_scale) - set(self.layout))
            if unknown:
                raise ScenarioError(f"obs_scale: no sensor {', '.join(unknown)} (has: {', '.join(self.layout)})",
                                    source=self.source)
            return np.asarray(out)
        a = np.asarray(obs_scale, dtype=float).reshape(-1)
        if a.size not in (1, self.obs_dim):
            raise ScenarioError(f"obs_scale: {a.size} values for {self.obs_dim} observations", source=self.source)
        return np.broadcast_to(a, (self.obs_dim,)).copy()

    # -- episodes -------------------------------------------------------------------------------------
    def draw(self, rng: np.random.Generator) -> Scenario | dict:
        """One car's scenario for a new episode, drawn from ``rng`` (road seed, noise seed, randomised values)."""
        road_seed, sim_seed = (int(x) for x in rng.integers(0, 2**31 - 1, size=2))
        if not self.randomize:
            return self.base.model_copy(update={
                "road": self.base.road.model_copy(update={"seed": road_seed}),
                "sim": self.base.sim.model_copy(update={"seed": sim_seed})})
        from ..batch import set_path

        raw = copy.deepcopy(self.base_raw)
        raw["road"]["seed"] = road_seed
        raw["sim"]["seed"] = sim_seed
        for path, dist in self.randomize.items():
            set_path(raw, path, dist.from_uniform(np.array([rng.random()]))[0], self.source, field=f"randomize.{path}")
        return parse_scenario(raw, source=self.source, field_prefix="randomize")

    def _build(self, scenarios):
        from ..simulation import Simulation

        if self.runner is not None:
            self.runner.close()
        self.sim = Simulation(scenarios, self.source, log_channels="metrics")
        self.runner = EnsembleRunner(self.sim)
        self._params_key = [self._param_key(s) for s in scenarios]

    @staticmethod
    def _param_key(sc):
        d = sc.model_dump(mode="json")
        d.pop("road", None)
        d["sim"].pop("seed", None)
        return d

    def _reseed(self, scenarios) -> bool:
        """Reuse the built ensemble when only the road and the seeds change (building 256 cars takes ~2 s):
        new roads and sensor noise streams, as Simulation builds them."""
        if self.sim is None or len(scenarios) != self.sim.plant.n:
            return False
        if self.randomize and [self._param_key(s) for s in scenarios] != self._params_key:
            return False
        from ..registry import ROADS
        from ..roads.base import RoadContext
        from ..build import SpeedProfile
        from ..components import validate_params

        sim = self.sim
        P = sim.plant
        speeds, roads = [], []
        for i, s in enumerate(scenarios):
            sp = SpeedProfile(s.road.speed, sim.duration, sim.dt)
            rcls = ROADS.get(s.road.type, field="road.type", source=self.source)
            rp = validate_params(rcls.Params, s.road.params, "road.params", self.source)
            seed = s.road.seed if s.road.seed is not None else s.sim.seed
            dist = float(sp.distance(sim.duration)) if sp.const is not None else sp.max_distance
            rctx = RoadContext(duration=sim.duration, distance=dist, wheelbase=P.vcls.wheelbase(P.params[i]),
                               mean_speed=sp.mean(sim.duration), dt=sim.dt,
                               n_tracks=1 + int(max(sim.geom.tracks) > 0), tracks=s.road.tracks)
            speeds.append(sp)
            roads.append(rcls(rp, np.random.default_rng([seed, 8608]), rctx))
        sim.speeds, sim.roads = speeds, roads
        sim.scenarios = list(scenarios)  # the sensors' noise streams restart from these seeds (System.reset)
        return True

    def start(self, scenarios):
        """Start a new episode for every car; returns the observation (n, D)."""
        if self.runner is not None:
            self.runner.close()
        if not self._reseed(scenarios):
            self._build(scenarios)
        self.wk.reset()
        self.k = 0
        out = self.runner.start()
        if out is None:  # pragma: no cover - a run shorter than one control step
            raise ScenarioError("sim.duration is shorter than one control step", source=self.source)
        self.t, readings, state = out
        self.state = state
        return self.observe(readings)

    def observe(self, readings) -> np.ndarray:
        cols = [np.asarray(readings[name], dtype=float).reshape(self.n, -1) for name in self.layout]
        obs = np.concatenate(cols, axis=1) * self.obs_scale
        return obs

    def command(self, action) -> np.ndarray:
        a = np.asarray(action, dtype=float).reshape(self.n, self.nc)
        return np.clip(np.nan_to_num(a), -1.0, 1.0) * self.action_scale

    def advance(self, command):
        """One control step; returns (obs, cost (n, nc) terms dict, diverged car or None, ended)."""
        try:
            out = self.runner.step(command)
        except SimulationDiverged as exc:
            return None, exc
        if out is None:  # pragma: no cover - the run ended (the episode truncates one step earlier)
            return None, None
        self.k += 1
        self.t, readings, self.state = out
        return self.observe(readings), None

    def penalty(self) -> float:
        """The termination penalty at the current step (the steps not run are charged)."""
        r = self.reward
        return r.termination_penalty + r.w_remaining * max(self.n_episode_steps - self.k, 0)

    def costs(self, state) -> dict:
        """Per-car cost terms (n,) and the worst |travel| (n,) from the true state."""
        r = self.reward
        aw = self.wk(np.asarray(state.corner_body_acc, dtype=float))
        s = np.asarray(state.travel, dtype=float)
        terms = {"acc": r.w_acc * np.mean(aw ** 2, axis=1)}
        excess = np.maximum(np.abs(s) - r.travel_limit, 0.0)
        terms["travel"] = r.w_travel * np.mean(excess ** 2, axis=1)
        if self.static_tire is not None and r.w_tire:
            terms["tire"] = r.w_tire * np.mean((np.asarray(state.tire_force) / self.static_tire) ** 2, axis=1)
        else:
            terms["tire"] = np.zeros(self.n)
        if r.w_power:
            terms["power"] = r.w_power * np.mean(np.abs(np.asarray(state.actuator_force) *
                                                        np.asarray(state.travel_rate)), axis=1)
        else:
            terms["power"] = np.zeros(self.n)
        bad = ~np.isfinite(s).all(axis=1)
        return terms, np.where(bad, np.inf, np.max(np.abs(s), axis=1))

    def close(self):
        if self.runner is not None:
            self.runner.close()


def _spaces(core: _Core):
    obs = spaces.Box(-np.inf, np.inf, (core.obs_dim,), np.float32)
    act = spaces.Box(-1.0, 1.0, (core.nc,), np.float32)
    return obs, act


class SuspensionEnv(gym.Env):
    """One car of a scenario as a Gymnasium environment (see the module docstring).

    ``scenario``: a scenario path, a preset name (``quarter_car``, ``half_car``, ``full_car``), a scenario
    dict or a :class:`Scenario`; ``variant`` picks a variant; ``overrides``: ``path=value`` strings as for
    ``run --set``.  ``reward``: :class:`Reward` or a dict of its weights.  ``randomize``: {path:
    distribution}.  ``obs_scale``: a number, one per observation, or {sensor name: factor}.
    ``action_scale``: the command of action +1 (default: the actuator's limit)."""

    metadata = {"render_modes": []}

    def __init__(self, scenario="quarter_car", variant: str | None = None, *, overrides=None, reward=None,
                 randomize=None, obs_scale=None, action_scale=None, render_mode=None):
        self._core = _Core(scenario, 1, variant=variant, overrides=overrides, reward=reward, randomize=randomize,
                           obs_scale=obs_scale, action_scale=action_scale)
        self.observation_space, self.action_space = _spaces(self._core)
        self.observation_labels = list(self._core.labels)
        self.corners = list(self._core.corners)
        self.command_unit = self._core.command_unit
        self.action_scale = self._core.action_scale.copy()
        self.max_episode_steps = self._core.n_episode_steps
        self.render_mode = render_mode
        self._done = True

    @property
    def simulation(self):
        """The running :class:`~suspension_sim.simulation.Simulation` (its ``loop`` says which loop ran)."""
        return self._core.sim

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        obs = self._core.start([self._core.draw(self.np_random)])
        self._done = False
        return obs[0].astype(np.float32), {"t": self._core.t}

    def step(self, action):
        if self._done:
            raise RuntimeError("the episode is over: call reset()")
        core, r = self._core, self._core.reward
        obs, diverged = core.advance(core.command(action))
        if obs is None:
            self._done = True
            core.runner.close()
            return (np.zeros(core.obs_dim, np.float32), -core.penalty(), True, False,
                    {"t": core.t, "diverged": True, "error": str(diverged) if diverged else "run ended"})
        terms, worst = core.costs(core.state)
        cost = float(sum(v[0] for v in terms.values()))
        terminated = bool(worst[0] > r.terminate_travel) or not np.all(np.isfinite(obs))
        truncated = (not terminated) and core.k >= core.n_episode_steps
        reward = -cost - (self._core.penalty() if terminated else 0.0)
        if terminated or truncated:
            self._done = True
            core.runner.close()
        info = {"t": core.t, "cost": {k: float(v[0]) for k, v in terms.items()}}
        return np.nan_to_num(obs[0]).astype(np.float32), reward, terminated, truncated, info

    def close(self):
        self._core.close()


class SuspensionVectorEnv(gym.vector.VectorEnv):
    """N cars of a scenario as one ensemble in the compiled loop (see the module docstring); arguments as
    :class:`SuspensionEnv` plus ``num_envs``."""

    metadata = {"autoreset_mode": gym.vector.AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 16, scenario="quarter_car", variant: str | None = None, *, overrides=None,
                 reward=None, randomize=None, obs_scale=None, action_scale=None, render_mode=None):
        self._core = _Core(scenario, num_envs, variant=variant, overrides=overrides, reward=reward,
                           randomize=randomize, obs_scale=obs_scale, action_scale=action_scale)
        self.num_envs = int(num_envs)
        self.single_observation_space, self.single_action_space = _spaces(self._core)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.observation_labels = list(self._core.labels)
        self.corners = list(self._core.corners)
        self.action_scale = self._core.action_scale.copy()
        self.max_episode_steps = self._core.n_episode_steps
        self.render_mode = render_mode
        self._rngs = None
        self._restart = np.zeros(self.num_envs, bool)  # cars to reset in place at the next step
        self._new_episode = True  # the whole ensemble starts over at the next step

    @property
    def simulation(self):
        return self._core.sim

    def _seed(self, seed):
        if seed is None:
            ss = np.random.SeedSequence()
            self._rngs = [np.random.default_rng(s) for s in ss.spawn(self.num_envs)]
        else:
            seeds = [seed + i for i in range(self.num_envs)] if isinstance(seed, int) else list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"{len(seeds)} seeds for {self.num_envs} envs")
            # the generators of gymnasium.Env.reset(seed=s): car i is the single env seeded with seed + i
            from gymnasium.utils import seeding

            self._rngs = [seeding.np_random(int(s))[0] for s in seeds]

    def _start(self):
        obs = self._core.start([self._core.draw(g) for g in self._rngs])
        self._restart[:] = False
        self._new_episode = False
        return np.nan_to_num(obs).astype(np.float32)

    def reset(self, *, seed=None, options=None):
        if seed is not None or self._rngs is None:
            self._seed(seed)
        return self._start(), {}

    def step(self, actions):
        n, core, r = self.num_envs, self._core, self._core.reward
        if self._new_episode:
            obs = self._start()
            z = np.zeros(n)
            f = np.zeros(n, bool)
            return obs, z, f, f.copy(), {}
        cmd = core.command(actions)
        restarted = self._restart.copy()
        if restarted.any():
            core.runner.restart_cars(np.nonzero(restarted)[0], np.asarray(core.state.road),
                                     np.asarray(core.state.road_vel))
            core.wk.reset(restarted)
            cmd[restarted] = 0.0
        obs, diverged = core.advance(cmd)
        if obs is None:  # the run diverged: the diverging car terminates, the others truncate
            car = getattr(diverged, "car", None)
            term = np.zeros(n, bool)
            if car is None:
                term[:] = True
            else:
                term[int(car)] = True
            rew = np.where(term, -core.penalty(), 0.0)
            self._new_episode = True
            core.runner.close()
            obs = np.zeros((n, core.obs_dim), np.float32)
            return obs, rew, term, ~term, {"diverged": term.copy()}
        terms, worst = core.costs(core.state)
        cost = sum(terms.values())
        terminated = (worst > r.terminate_travel) | ~np.all(np.isfinite(obs), axis=1)
        reward = -cost - np.where(terminated, core.penalty(), 0.0)
        truncated = np.zeros(n, bool)
        if core.k >= core.n_episode_steps:
            truncated = ~terminated
            self._new_episode = True
            core.runner.close()
        reward[restarted] = 0.0
        terminated[restarted] = False
        truncated[restarted] = False if not self._new_episode else truncated[restarted]
        self._restart = terminated.copy()
        return np.nan_to_num(obs).astype(np.float32), reward, terminated, truncated, {}

    def close_extras(self, **kwargs):
        self._core.close()


def make_gym_env(scenario="quarter_car", variant: str | None = None, num_envs: int | None = None, **kwargs):
    """A :class:`SuspensionEnv` (``num_envs=None``) or a :class:`SuspensionVectorEnv` of ``num_envs`` cars for
    a scenario path, preset name, scenario dict or :class:`Scenario`."""
    if num_envs is None:
        return SuspensionEnv(scenario, variant, **kwargs)
    return SuspensionVectorEnv(num_envs, scenario, variant, **kwargs)


def _preset_env(model: str, **kwargs):
    scenario = kwargs.pop("scenario", model)
    return SuspensionEnv(scenario, **kwargs)


def _preset_vector_env(model: str, num_envs: int = 1, **kwargs):
    scenario = kwargs.pop("scenario", model)
    return SuspensionVectorEnv(num_envs, scenario, **kwargs)


def quarter_car_env(**kw):
    return _preset_env("quarter_car", **kw)


def half_car_env(**kw):
    return _preset_env("half_car", **kw)


def full_car_env(**kw):
    return _preset_env("full_car", **kw)


def quarter_car_vector_env(num_envs: int = 1, **kw):
    return _preset_vector_env("quarter_car", num_envs, **kw)


def half_car_vector_env(num_envs: int = 1, **kw):
    return _preset_vector_env("half_car", num_envs, **kw)


def full_car_vector_env(num_envs: int = 1, **kw):
    return _preset_vector_env("full_car", num_envs, **kw)


__all__: list[Any] = ["SuspensionEnv", "SuspensionVectorEnv", "Reward", "WkFilter", "make_gym_env"]
