"""The build: scenarios -> a :class:`System` of components with explicit inputs and outputs, no stepping.

One ensemble (structurally equal scenarios, parameters may differ per car) becomes:

- the plant (:class:`~suspension_sim.plant.Plant`: one MuJoCo model holding every car; inputs: road height
  and rate under each wheel, actuator and effect forces per corner; outputs: the MuJoCo state);
- ``effects``: (effect, corner indices) pairs; input travel and rate (or tire deflection), output a force;
- ``actuator``: input the command, travel and rate, output the force on each corner;
- ``roads`` and ``speeds``: road height under each wheel over time (:meth:`System.road_chunk`);
- ``variations``: time-varying model parameters (:meth:`System.apply_variations`), ``maneuver``: inertial
  loads;
- ``sensors``: true plant quantities -> readings; ``controller``: readings -> command per corner.

Stepping the system is :mod:`suspension_sim.loop` (Python) and :mod:`suspension_sim.compiled.loop`;
:class:`suspension_sim.simulation.Simulation` builds, runs and logs.
"""
from __future__ import annotations

import dataclasses
import functools
import inspect
from typing import Sequence

import mujoco
import numba
import numpy as np

from . import buffers
from .actuators.base import ActuatorContext
from .components import stack_params, validate_many, validate_params
from .config import EFFECT_PREFIX, Scenario, effect_labels, effect_variation_target
from .controllers.base import ControlContext
from .effects.base import EffectContext
from .errors import ScenarioError
from .maneuvers import build_maneuver
from .plant import Plant
from .registry import ACTUATORS, CONTROLLERS, EFFECTS, ROADS, SENSORS
from .roads.base import ANCHOR, RoadContext, StepGrid
from .sensors.base import PlantState, SensorChannel, SensorContext

STRUCTURE_KEYS = ("vehicle.model", "effects", "actuator.type", "controller.type", "sensors", "sim")


def structure_key(sc: Scenario) -> tuple:
    """Scenarios with equal keys can be simulated together as one ensemble (parameters may differ)."""
    return (
        sc.vehicle.model,
        tuple((e.type, tuple(e.corners) if e.corners != "all" else "all") for e in sc.vehicle.effects),
        tuple((v.param, v.kind, v.mode) for v in sc.vehicle.variations),
        sc.vehicle.maneuver.type if sc.vehicle.maneuver else None,
        sc.actuator.type,
        sc.controller.type,
        sc.controller.full_state,
        tuple((s.name, s.type) for s in sc.sensors),
        (sc.sim.duration, sc.sim.dt, sc.sim.control_dt, sc.sim.log_dt, sc.sim.integrator),
    )



def held_effects_note(effects) -> str:
    """The part of ``auto``'s reason that says which effects hold their force at the step start over each physics
    step (``step_force: start``, their default): that force is first order in the step whatever the integrator,
    so "second order" holds for the linear suspension only (README, Accuracy).  Empty when there is none."""
    held = []
    for eff, _ in effects:
        sf = getattr(eff.p, "step_force", None)
        if sf is not None and any(v != "mean" for v in (sf if isinstance(sf, list) else [sf])):
            held.append(eff.label)
    if not held:
        return ""
    return (f"; {', '.join(held)} hold{'s' if len(held) == 1 else ''} the step-start force over each step "
            "(first order in it; step_force: mean is second order)")

class SpeedProfile:
    """Vehicle speed and distance over time (constant, or linear between [time, speed] points).

    A speed table is tabulated on the physics grid (speed, and distance by the trapezoid rule) for runs of up
    to :attr:`MAX_GRID` steps; a longer run uses the same law in closed form (distance piecewise quadratic
    between the table's points, inverted exactly for the rear wheels), so its memory does not grow with the
    duration (the grid would take 24 bytes per step: 4.8 GB at 1e5 s and 0.5 ms).  The two agree to rounding
    wherever the table's points fall on the grid."""

    MAX_GRID = 2 ** 22  # grid points (100 MB of tables; 35 min at 0.5 ms)

    def __init__(self, speed, duration: float, dt: float):
        self.knots = None
        if isinstance(speed, (int, float)):
            self.const = float(speed)
            self.t = self.x = None
            self.key = ("const", self.const)
            return
        self.const = None
        pts = np.asarray(speed, dtype=float)
        # equal keys: the same distance and speed at every time (road_chunk maps such wheels' paths once)
        self.key = ("table", pts.tobytes(), pts.shape, float(duration), float(dt))
        n_grid = int(np.ceil((duration + 2 * dt) / dt))  # the length of np.arange(0, duration + 2 dt, dt)
        if n_grid > self.MAX_GRID:  # closed form: knots at 0, the table's times inside the run, the end
            t_end = (n_grid - 1) * dt
            inner = pts[(pts[:, 0] > 0) & (pts[:, 0] < t_end), 0]
            kt = np.concatenate([[0.0], inner, [t_end]])
            kv = np.interp(kt, pts[:, 0], pts[:, 1])
            kx = np.concatenate([[0.0], np.cumsum(0.5 * (kv[1:] + kv[:-1]) * np.diff(kt))])
            self.knots = (kt, kv, kx, np.diff(kv) / np.diff(kt))
            self.t = self.x = self.v = None
            return
        tg = np.arange(0.0, duration + 2 * dt, dt)
        v = np.interp(tg, pts[:, 0], pts[:, 1])
        x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
        self.t, self.v, self.x = tg, v, x

    def _segment(self, t):
        kt, kv, kx, slope = self.knots
        t = np.clip(np.asarray(t, dtype=float), 0.0, kt[-1])
        i = np.clip(np.searchsorted(kt, t, side="right") - 1, 0, kt.size - 2)
        return t - kt[i], kv[i], kx[i], slope[i]

    def distance(self, t):
        if self.const is not None:
            return self.const * np.asarray(t, dtype=float)
        if self.knots is not None:
            tau, v0, x0, a = self._segment(t)
            return x0 + tau * (v0 + 0.5 * a * tau)
        return np.interp(t, self.t, self.x)

    def speed(self, t):
        if self.const is not None:
            return np.full_like(np.asarray(t, dtype=float), self.const)
        if self.knots is not None:
            kt, kv = self.knots[:2]
            return np.interp(np.clip(np.asarray(t, dtype=float), 0.0, kt[-1]), kt, kv)
        return np.interp(t, self.t, self.v)

    def time_at_rate(self, x, t_now):
        """d/dt of :meth:`time_at` (x − x(t_now) held, x advancing with the front axle): v(t_now)/v(time_at),
        1 where time_at returns t_now (no motion), 0 where the front axle stood still at x."""
        t_now = np.asarray(t_now, dtype=float)
        if self.const is not None or not self.max_distance > 0:  # (distance starts at 0)
            return np.ones_like(t_now)
        vc = self.speed(self.time_at(x, t_now))
        return np.where(vc > 1e-9, self.speed(t_now) / np.where(vc > 1e-9, vc, 1.0), 0.0)

    def time_at(self, x, t_now):
        """Time at which the front axle was at distance x (x may be behind the start)."""
        if self.const is not None:
            if self.const <= 0:
                return np.asarray(t_now, dtype=float)
            return np.asarray(x, dtype=float) / self.const
        xt = np.asarray(x, dtype=float)
        if self.knots is not None:
            kt, kv, kx, slope = self.knots
            v0 = max(kv[0], 1e-9)
            if kx[-1] > kx[0]:
                i = np.clip(np.searchsorted(kx, xt, side="right") - 1, 0, kt.size - 2)
                dx = np.clip(xt - kx[i], 0.0, None)
                root = np.sqrt(np.maximum(kv[i] ** 2 + 2.0 * slope[i] * dx, 0.0))
                den = kv[i] + root  # tau = 2 dx / (v + sqrt(v² + 2 a dx)): the root of x0 + v tau + a tau²/2 = x
                tau = np.where(den > 0, 2.0 * dx / np.where(den > 0, den, 1.0), 0.0)
                inside = np.minimum(kt[i] + tau, kt[i + 1])
            else:
                inside = np.asarray(t_now, dtype=float)
            before = xt / v0 if kv[0] > 0 else np.zeros_like(xt)
            return np.where(xt < 0, before, inside)
        v0 = max(self.v[0], 1e-9)
        inside = np.interp(xt, self.x, self.t) if self.x[-1] > self.x[0] else np.asarray(t_now, dtype=float)
        before = xt / v0 if self.v[0] > 0 else np.zeros_like(xt)
        return np.where(xt < 0, before, inside)

    @property
    def max_distance(self) -> float:
        if self.knots is not None:
            return float(self.knots[2][-1])
        return float(self.x[-1]) if self.const is None else 0.0

    def mean(self, duration):
        if self.knots is not None:  # the time average over the run (the grid's mean, in closed form)
            return float(self.knots[2][-1] / self.knots[0][-1])
        return self.const if self.const is not None else float(np.mean(self.v))


def n_log_samples(n_steps: int, log_every: int) -> int:
    """Logged instants of a run: steps 0, log_every, 2·log_every, ... below n_steps (one more than
    n_steps // log_every when the duration is not a multiple of log_dt)."""
    return -(-int(n_steps) // int(log_every))


class System:
    """One ensemble's components, built from structurally equal scenarios (no stepping: see
    :mod:`suspension_sim.loop`)."""

    def __init__(self, scenarios: Sequence[Scenario], source: str | None = None):
        if not scenarios:
            raise ValueError("no scenario")
        keys = {structure_key(s) for s in scenarios}
        if len(keys) != 1:
            raise ScenarioError("scenarios of one ensemble must share model, effects, actuator, controller, "
                                "sensors and timing", source=source)
        self.scenarios = list(scenarios)
        self.source = source
        self.initial_q = self.initial_v = None  # the run's initial state off rest at q = 0 (see reset)
        sc0 = self.scenarios[0]
        sim = sc0.sim
        self.dt, self.control_dt, self.log_dt, self.duration = sim.dt, sim.control_dt, sim.log_dt, sim.duration
        self.sub = int(round(self.control_dt / self.dt))
        self.log_every = int(round(self.log_dt / self.dt))
        self.n_steps = int(round(self.duration / self.dt))
        auto = sim.integrator == "auto"
        self.plant = Plant([s.vehicle for s in self.scenarios], self.dt, source,
                           integrator="implicitfast" if auto else sim.integrator)
        self.rk4 = sim.integrator == "RK4"
        P = self.plant
        n, nc = P.n, P.nc
        # the period-mean accelerometers' dofs (body and wheels) and period (sensors.base.period_mean_acc)
        self.acc_dofs = np.ascontiguousarray(np.concatenate([d.ravel() for d in (P.body_v, P.wheel_v) if d is not None]),
                                             dtype=np.int64)
        self.acc_period = self.sub * self.dt
        self.geom = P.geometry
        m = P.model
        ks = m.tendon_stiffness[P.susp_t]
        cs = P.susp_c  # the full linear damping (MuJoCo holds half of it with the trapezoidal scheme)
        kt = m.tendon_stiffness[P.tire_t] if P.has_tire else np.zeros((n, nc))
        ct = P.tire_c
        self.kt, self.ct = kt, ct
        # integrator: "auto" takes the second-order trapezoidal scheme wherever it applies and is stable, else
        # implicitfast; the choice and its reason go into the run's info and scenario.resolved.yaml
        self.integrator, self.integrator_reason = sim.integrator, ""
        if auto:
            why_not = self.trapezoidal_refusal()
            if why_not is None:
                P.use_trapezoidal()
                self.integrator = "trapezoidal"
                self.integrator_reason = ("auto: second order; stable here (damping*dt/mass = "
                                          f"{self._trap_ratio:.3g} <= 1)")
            else:
                self.integrator = "implicitfast"
                self.integrator_reason = f"auto: trapezoidal not usable ({why_not[0]}), first-order fallback"
        self.trap = self.integrator == "trapezoidal"
        if self.trap and not auto:
            self.check_trapezoidal(source)

        # effects ------------------------------------------------------------------------------------
        self.effects = []
        self._effect_tendons: list = []
        for i, ecfg in enumerate(sc0.vehicle.effects):
            ecls = EFFECTS.get(ecfg.type, field=f"vehicle.effects.{i}.type", source=source)
            sel = list(range(nc)) if ecfg.corners == "all" else [self.geom.corner_names.index(c) for c in ecfg.corners]
            if ecls.target == "tire" and not P.has_tire:
                raise ScenarioError(f"effect '{ecfg.type}' acts on the tire, and model '{sc0.vehicle.model}' has none",
                                    source=source, field=f"vehicle.effects.{i}.type")
            plist = validate_many(ecls.Params, [s.vehicle.effects[i].params for s in self.scenarios],
                                  f"vehicle.effects.{i}.params", source)
            # the effect's tendons (its effective mass is recomputed when a varying mass changes it)
            self._effect_tendons.append((P.tire_t if ecls.target == "tire" else P.susp_t)[:, sel])
            ctx = EffectContext(n_cars=n, corners=[self.geom.corner_names[c] for c in sel], dt=self.dt,
                                static_suspension_force=P.static_susp[:, sel], static_tire_force=P.static_tire[:, sel],
                                spring_stiffness=ks[:, sel], damping=cs[:, sel], tire_stiffness=kt[:, sel],
                                tire_damping=ct[:, sel],
                                effective_mass=self.tendon_effective_mass(self._effect_tendons[-1]))
            self.effects.append((ecls(stack_params(plist, len(sel)), ctx), np.asarray(sel)))
        # the name an effect's signals are logged under (effect.LABEL.SIGNAL.k): the type's name, and for a second
        # effect of the same type (e.g. bump stops front and rear with other gaps) NAME#2, NAME#3, ... so that
        # the two never write the same columns
        for (eff, _), label in zip(self.effects, effect_labels([eff.name for eff, _ in self.effects])):
            eff.label = label
        if self.integrator == "trapezoidal" and self.integrator_reason:
            self.integrator_reason += held_effects_note(self.effects)
        if any(lv is not None for lv in P.level):
            self.initial_q = self.rest_offset()

        # actuator --------------------------------------------------------------------------------------
        acls = ACTUATORS.get(sc0.actuator.type, field="actuator.type", source=source)
        ap = stack_params(validate_many(acls.Params, [s.actuator.params for s in self.scenarios], "actuator.params",
                                        source), nc)
        self.actuator = acls(ap, ActuatorContext(n, nc, self.dt, self.control_dt, P.static_susp.copy()))

        # roads ----------------------------------------------------------------------------------------
        self.speeds, self.roads = [], []
        # cars with the same road, seed, speed and context share one road and speed profile (a sweep over
        # vehicle parameters builds and evaluates its road once, not once per car; road_chunk then evaluates
        # each distinct wheel path once)
        shared: dict = {}
        for i, s in enumerate(self.scenarios):
            seed = s.road.seed if s.road.seed is not None else s.sim.seed
            wb = P.vcls.wheelbase(P.params[i])
            key = (s.road.model_dump_json(), seed, wb)
            if key not in shared:
                sp = SpeedProfile(s.road.speed, self.duration, self.dt)
                rcls = ROADS.get(s.road.type, field="road.type", source=source)
                rp = validate_params(rcls.Params, s.road.params, "road.params", source)
                dist = float(sp.distance(self.duration)) if sp.const is not None else sp.max_distance
                rctx = RoadContext(duration=self.duration, distance=dist, wheelbase=wb,
                                   mean_speed=sp.mean(self.duration), dt=self.dt,
                                   n_tracks=1 + int(max(self.geom.tracks) > 0), tracks=s.road.tracks)
                shared[key] = (sp, rcls(rp, np.random.default_rng([seed, 8608]), rctx))
            sp, road = shared[key]
            self.speeds.append(sp)
            self.roads.append(road)
        # distance of each axle behind the front axle, per car (cars of an ensemble may differ in a, b)
        xs = np.asarray([[c.x for c in P.vcls.corners(p)] for p in P.params], dtype=float)
        self.corner_back = xs.max(axis=1, keepdims=True) - xs  # (n_cars, n_corners)

        # time-varying parameters -----------------------------------------------------------------------
        # (a vehicle parameter: its MjModel field; an effect's parameter, effects.<label>.<param>: the effect's
        # parameter rows, rewritten in place by Effect.set_param; both at the control instants of either loop)
        self.variations: list = []
        self._const_scratch = None  # MjData scratch for mj_setConst when a mass or inertia varies
        labels = [eff.label for eff, _ in self.effects]
        for vi, v in enumerate(sc0.vehicle.variations):
            cfgs = [s.vehicle.variations[vi] for s in self.scenarios]
            if v.param.startswith(EFFECT_PREFIX):
                k, name = effect_variation_target(v.param, labels, source, f"vehicle.variations.{vi}.param")
                eff = self.effects[k][0]
                cols = [eff.ctx.corners.index(c) for c in v.corners] if v.corners != "all" else None
                self.variations.append(EffectVariation(eff, name, cols, cfgs))
                continue
            fld, idx = P.variation_index(v.param, None if v.corners == "all" else list(v.corners))
            if fld.startswith("body"):
                self._const_scratch = mujoco.MjData(m)
            arr = getattr(m, fld).reshape(-1) if fld == "body_inertia" else getattr(m, fld)
            self.variations.append(ModelVariation(arr, idx, cfgs))
        self._mass_sig = self._mass_signature()  # the masses the effects' effective masses were computed at

        # manoeuvre (inertial loads) --------------------------------------------------------------------
        self.maneuver = None
        if sc0.vehicle.maneuver is not None:
            self.maneuver = build_maneuver(self.scenarios, P, source)

        # sensors ---------------------------------------------------------------------------------------
        sctx = SensorContext(n, self.geom.corner_names, self.geom.suffixes, P.body_joints, self.control_dt)
        self.sensors: list[SensorChannel] = []
        for i, scfg in enumerate(sc0.sensors):
            scls = SENSORS.get(scfg.type, field=f"sensors.{i}.type", source=source)
            sp_ = stack_params(validate_many(scls.Params, [s.sensors[i].params for s in self.scenarios],
                                             f"sensors.{i}.params", source), nc)
            self.sensors.append(SensorChannel(scfg, scls(sp_, sctx), self.control_dt, self.sensor_rng(i)))

        # controller ------------------------------------------------------------------------------------
        ccls = CONTROLLERS.get(sc0.controller.type, field="controller.type", source=source)
        cp = stack_params(validate_many(ccls.Params, [s.controller.params for s in self.scenarios],
                                        "controller.params", source), nc)
        vparams = stack_params(P.params, nc)
        self.full_state = sc0.controller.full_state
        self.cctx = ControlContext(
            n_cars=n, corners=self.geom.corner_names, suffixes=self.geom.suffixes, corner_x=self.geom.corner_x,
            corner_y=self.geom.corner_y, control_dt=self.control_dt, dt=self.dt, vehicle_model=sc0.vehicle.model,
            vehicle=vparams, sensors={ch.name: ch.sensor.labels() for ch in self.sensors},
            actuator=sc0.actuator.type, command_unit=acls.command_unit, full_state=self.full_state,
            static_suspension_force=P.static_susp.copy(), state_widths=self.state_widths(),
            extra={"actuator_params": ap})  # e.g. the policy controller's default action scale
        self.controller = ccls(cp, self.cctx)

    def state_widths(self) -> dict:
        """{"state.<name>": width} of the true plant quantities a full-state controller reads (the order of
        :func:`~suspension_sim.sensors.base.full_state_readings`)."""
        if not self.full_state:
            return {}
        nb, nc = len(self.plant.body_joints), self.plant.nc
        out = {}
        for f in dataclasses.fields(PlantState):
            if f.name in ("t", "actuator_states", "extra"):
                continue
            out[f"state.{f.name}"] = nb if f.name.startswith("body_") else nc
        for k, v in self.actuator.states().items():
            out[f"state.actuator.{k}"] = int(np.asarray(v).reshape(self.plant.n, -1).shape[1])
        return out

    # ------------------------------------------------------------------------------------------------
    def trapezoidal_refusal(self):
        """None if the trapezoidal scheme applies to this ensemble, else (short reason, the error's message).
        Its limits: a model with tires (the SDOF rig's base is a prescribed plate), no time-varying damping,
        and damping·dt/m_eff <= 1 on every suspension of every car (the body-wheel coupling is taken from the
        last step, which diverges for stiffer dampers; measured on the quarter car: stable at 2.0, divergent
        at 3.1)."""
        P, sc0 = self.plant, self.scenarios[0]
        if not P.has_tire:
            return ("model without tires",
                    f"integrator 'trapezoidal' needs a model with tires ({sc0.vehicle.model!r} has none); "
                    "use implicitfast or RK4")
        if any("damping" in v.param and not v.param.startswith(EFFECT_PREFIX) for v in sc0.vehicle.variations):
            return ("time-varying damping",
                    "integrator 'trapezoidal' does not support time-varying damping; use implicitfast or RK4")
        ratio = P.susp_c * self.dt / self.tendon_effective_mass(P.susp_t)
        self._trap_ratio = float(np.max(ratio))
        if self._trap_ratio > 1.0:
            return (f"damping*dt/mass = {self._trap_ratio:.3g} > 1",
                    f"integrator 'trapezoidal' needs damping*dt/mass <= 1 on every suspension (here "
                    f"{self._trap_ratio:.3g}); use a smaller sim.dt, or implicitfast (any damping)")
        return None

    def check_trapezoidal(self, source):
        why_not = self.trapezoidal_refusal()
        if why_not is not None:
            raise ScenarioError(why_not[1], source=source, field="sim.integrator")

    def tendon_effective_mass(self, tendons: np.ndarray) -> np.ndarray:
        """Effective mass 1/(J·M⁻¹·Jᵀ) (kg) along each fixed tendon of ``tendons`` (n_cars, k) at the initial pose,
        road plates held; inf for a tendon that moves no free dof.  For effects that need it (stick-slip)."""
        m = self.plant.model
        if not hasattr(self, "_Mfull"):
            d = mujoco.MjData(m)
            mujoco.mj_forward(m, d)
            self._Mfull = np.zeros((m.nv, m.nv))
            mujoco.mj_fullM(m, d, self._Mfull)
            free = set(self.plant.free_v.tolist())
            self._car_dofs = {}
            for v in range(m.nv):
                name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, int(m.dof_jntid[v])) or ""
                if v in free:
                    self._car_dofs.setdefault(name.split("/")[0], []).append(v)
        out = np.full(tendons.shape, np.inf)
        for i in range(tendons.shape[0]):
            dofs = np.asarray(self._car_dofs.get(f"car{i}", []), dtype=int)
            for k, t in enumerate(tendons[i]):
                J = np.zeros(m.nv)
                for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
                    J[m.jnt_dofadr[m.wrap_objid[w]]] += m.wrap_prm[w]
                Jf = J[dofs]
                if dofs.size and np.any(Jf):
                    out[i, k] = 1.0 / float(Jf @ np.linalg.solve(self._Mfull[np.ix_(dofs, dofs)], Jf))
        return out

    def road_chunk(self, k0: int, k1: int):
        """Road height and rate under each wheel for physics steps k0..k1-1: arrays (n, k1-k0, nc), views of
        step-major arrays (one step's road for all cars is contiguous, as the compiled loop reads it).

        Wheels are grouped by road type, speed law, axle position and track: each group maps its path (distance,
        corner time) once and asks the road class for the heights and slopes of all its roads at once
        (:meth:`~suspension_sim.roads.base.Road.height_slopes_many`: one array expression for a closed-form road,
        however many cars; a road object shared by several cars is evaluated once)."""
        n, nc = self.plant.n, self.plant.nc
        L = k1 - k0
        t = (np.arange(k0 - 1, k1 + 1)) * self.dt  # one extra sample each side (RK4's second differences)
        z = buffers.empty((L + 2, n, nc))  # a buffer of an earlier chunk that is no longer read (no fresh pages)
        zd = buffers.empty((L, n, nc))
        paths: dict = {}  # distance and speed of each distinct speed law
        for (rcls, key, back, track), (sp, roads, rows, cars, corners) in self._road_groups().items():
            if key not in paths:
                paths[key] = (sp.distance(t), sp.speed(t[1:-1]))
            x, v = paths[key]
            xc = x - back
            if back == 0:
                tc, tc_rate = t, 1.0
            else:
                tc = sp.time_at(xc, t)
                tc_rate = sp.time_at_rate(xc[1:-1], t[1:-1])
            grid = None
            if sp.const is not None and _takes_grid(rcls):  # a uniform step grid: corner time and distance at the anchor steps too
                g0 = k0 - 1
                ta = np.arange((g0 // ANCHOR) * ANCHOR, k1 + 1, ANCHOR) * self.dt
                xa = sp.distance(ta) - back
                grid = StepGrid(g0=g0, dt=self.dt, dx=sp.const * self.dt, x_anchor=xa,
                                t_anchor=ta if back == 0 else sp.time_at(xa, ta))
            h, zt, zx = rcls.height_slopes_many(roads, tc, xc, track, **({"grid": grid} if _takes_grid(rcls) else {}))
            # the exact time derivative of the height each wheel sees (Road.rate: the road's own derivative
            # law), zt·(corner time rate) + zx·speed, not a difference over ±dt (whose O(dt²) error on a spline
            # road moved results with the step); written step-major with the heights, wheel by wheel (a road
            # shared by several wheels: its row for each), in one compiled pass
            tcr = np.broadcast_to(np.asarray(tc_rate, dtype=float), (L,))
            h, zt, zx = (np.asarray(a, dtype=float) for a in (h, zt, zx))
            if h.strides[0] < h.strides[1] and zt.strides[0] < zt.strides[1]:  # a road computed step-major
                _place_road_steps(h.T, zt.T, zx.T, tcr, np.asarray(v, dtype=float), rows, cars * nc + corners,
                                  z.reshape(L + 2, n * nc), zd.reshape(L, n * nc))
            else:
                _place_road(h, zt, zx, tcr, np.asarray(v, dtype=float), rows, cars, corners, z, zd)
        zc, zdc = z[1:-1].transpose(1, 0, 2), zd.transpose(1, 0, 2)
        if self.rk4:  # RK4 also prescribes the plates' acceleration within a step
            return zc, zdc, ((z[2:] - 2 * z[1:-1] + z[:-2]) / self.dt ** 2).transpose(1, 0, 2)
        return zc, zdc

    def _road_groups(self) -> dict:
        """The wheels grouped by road type, speed law, axle offset and track: key -> (speed profile, the
        group's distinct road objects, each wheel's row among them, its car, its corner).  Fixed once built."""
        cache = self.__dict__.get("_road_groups_cache")
        if cache is not None and cache[0] == (len(self.roads), tuple(map(id, self.roads)), tuple(map(id, self.speeds))):
            return cache[1]
        nc = self.plant.nc
        groups: dict = {}  # (road type, speed law, axle offset, track) -> (speed profile, {road: wheels})
        for i, (road, sp) in enumerate(zip(self.roads, self.speeds)):
            for c in range(nc):
                g = groups.setdefault((type(road), sp.key, float(self.corner_back[i, c]), self.geom.tracks[c]),
                                      (sp, {}))
                g[1].setdefault(id(road), (road, []))[1].append((i, c))
        out = {}
        for key, (sp, members) in groups.items():
            roads = [r for r, _ in members.values()]
            wheels = [(r, i, c) for r, (_, ws) in enumerate(members.values()) for i, c in ws]
            out[key] = (sp, roads, *(np.array([w[j] for w in wheels], dtype=np.int64) for j in range(3)))
        self.__dict__["_road_groups_cache"] = ((len(self.roads), tuple(map(id, self.roads)),
                                                tuple(map(id, self.speeds))), out)
        return out

    def apply_variations(self, t: float):
        """Every time-varying parameter at time ``t`` (both loops call this at each control instant)."""
        for var in self.variations:
            var.apply(t)
        self._masses_set()

    def _masses_set(self) -> None:
        """After the model's varying masses were written (a variation applied or restored): MuJoCo precomputes the
        mass matrix of simple (slide-joint) bodies (dof_M0) in mj_setConst, without which a mass change would
        alter gravity but not inertia; then the effects' effective masses follow."""
        if self._const_scratch is not None:
            mujoco.mj_setConst(self.plant.model, self._const_scratch)
            self.update_effective_masses()

    def _mass_signature(self):
        m = self.plant.model
        return m.body_mass.tobytes() + m.body_inertia.tobytes()

    def update_effective_masses(self) -> None:
        """After a varying mass changed the model's masses: each effect's effective mass along its tendon
        (``EffectContext.effective_mass``, the stick-slip friction's ``m_r``) from the current mass matrix, written
        into the running kernel parameters (as :meth:`Effect.set_param` does).  A stick-slip law that kept the
        initial mass under the thesis's +150 kg load (250 kg against 400) made its sticking force and its
        reversal time inside a step those of the lighter body: first order in the step again."""
        sig = self._mass_signature()
        if sig == self._mass_sig:
            return
        self._mass_sig = sig
        self.__dict__.pop("_Mfull", None)  # the mass matrix at the new masses
        for (eff, _), tendons in zip(self.effects, self._effect_tendons):
            if eff.ctx.effective_mass is None:
                continue
            eff.ctx.effective_mass = self.tendon_effective_mass(tendons)
            eff.refresh_parameters()

    def road_preview(self, t, dist):
        out = np.empty((self.plant.n, self.plant.nc))
        # the sensor's stacked parameter: one distance per car ((n_cars, 1)) or a scalar
        dists = np.broadcast_to(np.asarray(dist, dtype=float).reshape(-1), (self.plant.n,))
        for i, (road, sp) in enumerate(zip(self.roads, self.speeds)):
            x = float(sp.distance(t))
            dist = float(dists[i])
            for c in range(self.plant.nc):
                xc = x - self.corner_back[i, c] + dist
                v = max(float(sp.speed(t)), 1e-9)
                out[i, c] = road.height(np.array([t + dist / v]), np.array([xc]), self.geom.tracks[c])[0]
        return out

    def reset(self):
        """Back to the start of a run: MuJoCo data reset, corner Jacobian rebuilt, and the actuator, controller,
        effects and sensor pipelines reset (both loops start with this)."""
        mujoco.mj_resetData(self.plant.model, self.plant.data)
        # the trapezoidal scheme's velocities at the last step (loop.trapezoidal_coupling; both loops step it in
        # place, and reset_cars restarts single cars in it)
        self.v_prev = np.zeros(self.plant.model.nv)
        self.build_corner_jacobian()
        self.actuator.reset()
        self.controller.reset()
        for var in self.variations:
            var.restore()  # the model and the effects restart from their nominal parameters
        self._masses_set()  # and the mass matrix and the effects' effective masses with them
        for e, _ in self.effects:
            e.reset()
        for j, ch in enumerate(self.sensors):
            ch.rng = self.sensor_rng(j, ch.rng)  # the noise streams start over too: a run started again repeats
            ch.reset()
        # the period-mean accelerometers' state (sensors.base.period_mean_acc): the velocities at the last control
        # instant (before the first: the initial ones) and the means
        self.v_ctrl = self.plant.data.qvel.copy()
        self.acc_mean = np.zeros(self.plant.model.nv)
        # the run's initial state, when it is not rest at the levelled ride height (q = 0, v = 0): positions
        # added to q = 0 and the velocities, per dof (nv); set by the build (a car heavier than it was levelled
        # with: :mod:`.statics`) or by the discrepancy search's engine before a run
        d, m = self.plant.data, self.plant.model
        if self.initial_q is not None:
            d.qpos[m.jnt_qposadr[m.dof_jntid]] += self.initial_q
        if self.initial_v is not None:
            d.qvel[:] = self.initial_v

    def rest_offset(self) -> np.ndarray:
        """Where the cars levelled with other masses than their own (``vehicle.levelled_with``) rest, from the
        levelled ride height (:func:`suspension_sim.statics.rest_offset`); the other cars at q = 0."""
        from .statics import gravity, rest_offset, tendon_jacobian

        P, m = self.plant, self.plant.model
        J = tendon_jacobian(m)
        # the generalized force the levelled springs leave over at q = 0: gravity minus the springs' preloads
        dg = gravity(m, mujoco.MjData(m)) + J.T @ (m.tendon_stiffness * m.tendon_lengthspring[:, 0])
        for i, lv in enumerate(P.level):
            if lv is None:
                for dofs in (P.body_v, P.wheel_v):
                    if dofs is not None:
                        dg[dofs[i]] = 0.0
        return rest_offset(P, self.effects, dg, J)

    def sensor_rng(self, j: int, current=None) -> "PerCarRNG":
        """The noise generator of sensor ``j`` at the start of a run: one stream per car, seeded by the car's
        ``sim.seed`` (the same alone and in any ensemble).  ``current`` is returned when it is that generator,
        still unused (seeding costs ~30 µs per car and sensor)."""
        key = (tuple(s.sim.seed for s in self.scenarios), j)
        if isinstance(current, PerCarRNG) and current.key == key and current.fresh:
            return current
        return PerCarRNG(key=key, seeds=[[s.sim.seed, 2631, j] for s in self.scenarios])

    def reset_cars(self, cars, state: PlantState) -> None:
        """Restart the components of the cars ``cars`` in the middle of a run (the vectorised env restarting a
        car in place), the other cars untouched: the actuator's and the effects' kernel states back to their
        initial values, and each sensor's pipeline (delay line, sample-and-hold) restarted on ``state``, the
        true plant quantities of those cars now, and the trapezoidal scheme's last-step velocities of those cars
        set to their velocities now (no velocity change, as at the start of a run), as are their velocities at the
        last control instant (the period-mean accelerometers' start).  The roads, the noise streams
        and the controller go on."""
        P = self.plant
        cars = np.asarray(cars, dtype=np.intp).reshape(-1)
        for dofs in (P.body_v, P.wheel_v):
            if dofs is not None:
                self.v_prev[dofs[cars]] = P.data.qvel[dofs[cars]]
                self.v_ctrl[dofs[cars]] = P.data.qvel[dofs[cars]]  # their period means start from now
        self.actuator.reset_cars(cars)
        for e, _ in self.effects:
            e.reset_cars(cars)
        for ch in self.sensors:
            ch.reset_cars(cars, state)

    def build_corner_jacobian(self):
        """Rows of each suspension tendon restricted to the body dofs (for corner body kinematics).  Built again
        only when the model's tendon wraps changed since the last build (every reset asks); one array pass per
        wrap index (the car-by-car Python loops took ~2.5 ms per reset of the 256-car benchmark batch)."""
        P, m = self.plant, self.plant.model
        done = self.__dict__.get("_jb_wraps")
        if done is not None and done[0] is P and done[1] is m and np.array_equal(done[2], m.wrap_prm):
            return
        n, nc, nb = P.n, P.nc, len(P.body_joints)
        Jb = np.zeros((n, nc, nb))
        ti = np.asarray(P.susp_t, dtype=np.intp).reshape(n, nc)
        adr, num = m.tendon_adr[ti], m.tendon_num[ti]
        body_v = np.asarray(P.body_v, dtype=np.intp).reshape(n, 1, nb)
        ii, cc = np.meshgrid(np.arange(n), np.arange(nc), indexing="ij")
        for k in range(int(num.max()) if num.size else 0):  # the k-th wrap of every tendon, in the wraps' order
            w = np.where(k < num, adr + k, 0)
            dof = m.jnt_dofadr[m.wrap_objid[w]]
            match = body_v == dof[:, :, None]  # (n, nc, nb): the body dof of each wrap's joint
            hit = (k < num) & match.any(axis=2)
            b = match.argmax(axis=2)  # the first match, as the car-by-car search took
            Jb[ii[hit], cc[hit], b[hit]] += m.wrap_prm[w[hit]]  # (each (car, corner) at most once per k)
        self.Jb = Jb
        self.__dict__["_jb_wraps"] = (P, m, m.wrap_prm.copy())

    def corner_body_acc(self, acc):
        """Acceleration of the body point above each corner: J_body · qacc (fixed tendons are linear)."""
        return np.einsum("ncb,nb->nc", self.Jb, acc[self.plant.body_v])


class PerCarRNG:
    """Noise generator of an ensemble: each car draws from its own stream (seeded by its scenario's
    ``sim.seed``), so a car's noise, and hence its result, is the same alone and inside any ensemble."""

    BLOCK = 256  # standard normals drawn ahead per car (the same stream as one draw per call, far cheaper)

    def __init__(self, rngs=None, key=None, seeds=None):
        """``rngs``: one generator per car, or ``seeds``: what to seed them from when the first draw comes (a
        sensor without noise never draws: its ensemble of 256 cars then costs no 7.7 ms of seeding and no 1280
        objects for Python's garbage collector to scan; the streams are the same)."""
        self._rngs = rngs
        self._seeds = seeds
        self.n = len(rngs) if rngs is not None else len(seeds)
        self.key = key  # what it was seeded from (System.sensor_rng)
        self.fresh = True  # no draw yet
        self._buf: dict = {}

    @property
    def rngs(self) -> list:
        if self._rngs is None:
            self._rngs = [np.random.default_rng(s) for s in self._seeds]
        return self._rngs

    def normal(self, loc=0.0, scale=1.0, size=None):
        self.fresh = False
        n = self.n
        if size is None or np.ndim(loc) or np.ndim(scale) or len(tuple(size)) < 1 or tuple(size)[0] != n:
            if size is None or n == 1:
                return self.rngs[0].normal(loc, scale, size)
            return np.stack([g.normal(loc, scale, tuple(size)[1:]) for g in self.rngs])
        key = tuple(size)[1:]
        buf, pos = self._block(key)
        if pos[0] == self.BLOCK and (pos == pos[0]).all():  # every car at the end of its block: one refill
            buf[...] = np.stack([g.standard_normal((self.BLOCK,) + key) for g in self.rngs])
            pos[:] = 0
        if (pos == pos[0]).all():
            out = loc + scale * buf[:, pos[0]]  # = Generator.normal(loc, scale) value by value
            pos += 1
            return out
        return self.normal_cars(np.arange(n), scale, key, loc)

    def normal_cars(self, cars, scale, key, loc=0.0):
        """Normal draws of shape ``key`` for the cars ``cars`` only, (len(cars),) + key, each from its car's
        stream (the other cars' streams do not move)."""
        self.fresh = False
        key = tuple(key)
        buf, pos = self._block(key)
        cars = np.asarray(cars, dtype=np.intp).reshape(-1)
        for i in cars:
            if pos[i] == self.BLOCK:
                buf[i] = self.rngs[i].standard_normal((self.BLOCK,) + key)
                pos[i] = 0
        out = loc + scale * buf[cars, pos[cars]]
        pos[cars] += 1
        return out

    def _block(self, key):
        if key not in self._buf:  # standard normals drawn ahead, per car, and each car's next one
            self._buf[key] = (np.empty((self.n, self.BLOCK) + key), np.full(self.n, self.BLOCK, dtype=np.int64))
        return self._buf[key]

    def __getattr__(self, name):  # other draws: the first car's stream (single runs unchanged)
        if name.startswith("_"):  # (private names: never a Generator's method; and no recursion before __init__)
            raise AttributeError(name)
        self.fresh = False
        return getattr(self.rngs[0], name)


class ModelVariation:
    """A time-varying vehicle parameter: the entries ``idx`` (n_cars, k) of the MjModel array ``arr``."""

    def __init__(self, arr, idx, cfgs):
        self.arr, self.idx, self.cfgs = arr, idx, cfgs
        self.nominal = arr[idx].copy()

    def apply(self, t: float) -> None:
        vals = np.empty_like(self.nominal)
        for i, v in enumerate(self.cfgs):
            vals[i] = variation_value(v, t, self.nominal[i])
        self.arr[self.idx] = vals

    def restore(self) -> None:
        self.arr[self.idx] = self.nominal


class EffectVariation:
    """A time-varying parameter ``name`` of a plant effect (``effects.<label>.<param>``), on the effect's corners
    ``cols`` (indices among its corners; None: all).  The stacked value is set through
    :meth:`~suspension_sim.effects.base.Effect.set_param`, which rewrites the kernel's parameter rows in place."""

    def __init__(self, effect, name: str, cols, cfgs):
        self.effect, self.name, self.cfgs = effect, name, cfgs
        n, k = effect.ctx.n_cars, len(effect.ctx.corners)
        self.original = getattr(effect.p, name)
        self.nominal = np.broadcast_to(np.asarray(self.original, dtype=float).reshape(n, -1), (n, k)).copy()
        self.mask = np.ones(k, bool) if cols is None else np.isin(np.arange(k), cols)

    def apply(self, t: float) -> None:
        vals = self.nominal.copy()
        for i, v in enumerate(self.cfgs):
            vals[i, self.mask] = variation_value(v, t, self.nominal[i, self.mask])
        self.effect.set_param(self.name, vals)

    def restore(self) -> None:
        self.effect.set_param(self.name, self.original)


def variation_value(v, t: float, nominal):
    """The value at time ``t`` of a time-varying parameter (``vehicle.variations`` entry ``v``) whose nominal
    value is ``nominal``."""
    if v.kind == "step":
        val = None
        for ti, vi in zip(v.times, v.values):
            if t >= ti:
                val = vi
        if val is None:
            return nominal
    elif v.kind == "ramp":
        val = float(np.interp(t, v.times, v.values))
    else:
        amp, f = v.values[0], v.values[1]
        ph = v.values[2] if len(v.values) > 2 else 0.0
        val = amp * np.sin(2 * np.pi * f * t + ph)
        if v.mode == "scale":
            return nominal * (1.0 + val)
    if v.mode == "add":
        return nominal + val
    if v.mode == "scale":
        return nominal * val
    return np.full_like(nominal, val)


@functools.lru_cache(maxsize=None)
def _takes_grid(rcls) -> bool:
    """Whether ``rcls.height_slopes_many`` takes the ``grid`` keyword (a road class written before it existed
    overrides the method without it)."""
    try:
        return "grid" in inspect.signature(rcls.height_slopes_many).parameters
    except (TypeError, ValueError):  # pragma: no cover
        return False


@numba.njit(cache=True, nogil=True)
def _place_road_steps(h, zt, zx, tc_rate, v, rows, wheel, z, zd):  # pragma: no cover - compiled
    """:func:`_place_road` of a road computed step-major: ``h``, ``zt``, ``zx`` (samples, rows) and ``z``, ``zd``
    (steps, wheels) with wheel ``car · corners + corner``: z[j, wheel[w]] = h[j, rows[w]] and zd[j, wheel[w]] =
    zt[j+1, rows[w]]·tc_rate[j] + zx[j+1, rows[w]]·v[j] (the same products and sum).  When every wheel has its
    own row in order (cars with their own roads, e.g. a sweep of road parameters) a step is a contiguous copy
    and a contiguous multiply-add, which the compiler vectorises; else gathered and scattered through the
    indices.  About half the time of the 3-D indexing it replaces (the benchmark batch's 256 cars × 2000
    steps: ~4 against ~8 ms per run)."""
    n_w = rows.shape[0]
    L2 = z.shape[0]
    ident = n_w == z.shape[1] and n_w <= h.shape[1]
    for w in range(n_w):
        if rows[w] != w or wheel[w] != w:
            ident = False
    for j in range(L2):
        hj, zj = h[j], z[j]
        if ident:
            for w in range(n_w):
                zj[w] = hj[w]
        else:
            for w in range(n_w):
                zj[wheel[w]] = hj[rows[w]]
        if j < L2 - 2:
            a, b = tc_rate[j], v[j]
            tj, xj, dj = zt[j + 1], zx[j + 1], zd[j]
            if ident:
                for w in range(n_w):
                    dj[w] = tj[w] * a + xj[w] * b
            else:
                for w in range(n_w):
                    r = rows[w]
                    dj[wheel[w]] = tj[r] * a + xj[r] * b


@numba.njit(cache=True, nogil=True)
def _place_road(h, zt, zx, tc_rate, v, rows, cars, corners, z, zd):  # pragma: no cover - compiled
    """z[j, car, corner] = h[row, j] and zd[j, car, corner] = zt[row, j+1]·tc_rate[j] + zx[row, j+1]·v[j] for
    every wheel (row, car, corner), in blocks of 64 steps (the step-major writes of a block stay in cache).  A road
    computed step-major goes to :func:`_place_road_steps` instead."""
    n_w = rows.shape[0]
    L2 = z.shape[0]
    B = 64
    for j0 in range(0, L2, B):
        j1 = min(j0 + B, L2)
        for w in range(n_w):
            r, i, c = rows[w], cars[w], corners[w]
            for j in range(j0, j1):
                z[j, i, c] = h[r, j]
            for j in range(j0, min(j1, L2 - 2)):
                zd[j, i, c] = zt[r, j + 1] * tc_rate[j] + zx[r, j + 1] * v[j]
