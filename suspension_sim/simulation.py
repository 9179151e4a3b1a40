"""The simulation loop.

Per physics step ``dt`` (default 0.5 ms), for every car of the ensemble at once:

1. the road plates are placed kinematically at the road height (and rate) under each wheel;
2. time-varying parameters and manoeuvre loads are applied (at control instants / every step);
3. ``mj_step1`` computes positions and velocities (tendon lengths = travel, tire deflection);
4. at control instants (every ``control_dt``) the sensors sample the plant and the controller returns a
   command, held (zero-order hold) until the next control instant;
5. the actuator force and the effect forces are computed from the state at the start of the step and
   written to the corner motors;
6. ``mj_step2`` integrates (implicitfast: tendon dampers implicit) and the actuator states advance.

Logging happens every ``log_dt``.  A NaN or runaway state stops the run with
:class:`~suspension_sim.errors.SimulationDiverged` naming the time, the state and a hint.
"""
from __future__ import annotations


import contextlib
import dataclasses
import os
import time as _time
from pathlib import Path
from typing import Callable, Sequence

import mujoco
import numpy as np

from .actuators.base import ActuatorContext
from .components import stack_params, validate_params
from .config import Scenario, load_scenario
from .effects.base import EffectContext
from .errors import ScenarioError, SimulationDiverged
from .plant import Plant
from .registry import ACTUATORS, CONTROLLERS, EFFECTS, ROADS, SENSORS
from .roads.base import RoadContext
from .sensors.base import PlantState, SensorChannel, SensorContext, full_state_readings

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


class SpeedProfile:
    """Vehicle speed and distance over time (constant, or linear between [time, speed] points)."""

    def __init__(self, speed, duration: float, dt: float):
        if isinstance(speed, (int, float)):
            self.const = float(speed)
            self.t = self.x = None
        else:
            self.const = None
            pts = np.asarray(speed, dtype=float)
            tg = np.arange(0.0, duration + 2 * dt, dt)
            v = np.interp(tg, pts[:, 0], pts[:, 1])
            x = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
            self.t, self.v, self.x = tg, v, x

    def distance(self, t):
        if self.const is not None:
            return self.const * np.asarray(t, dtype=float)
        return np.interp(t, self.t, self.x)

    def speed(self, t):
        if self.const is not None:
            return np.full_like(np.asarray(t, dtype=float), self.const)
        return np.interp(t, self.t, self.v)

    def time_at(self, x, t_now):
        """Time at which the front axle was at distance x (x may be behind the start)."""
        if self.const is not None:
            if self.const <= 0:
                return np.asarray(t_now, dtype=float)
            return np.asarray(x, dtype=float) / self.const
        v0 = max(self.v[0], 1e-9)
        xt = np.asarray(x, dtype=float)
        inside = np.interp(xt, self.x, self.t) if self.x[-1] > self.x[0] else np.asarray(t_now, dtype=float)
        before = xt / v0 if self.v[0] > 0 else np.zeros_like(xt)
        return np.where(xt < 0, before, inside)

    @property
    def max_distance(self) -> float:
        return float(self.x[-1]) if self.const is None else 0.0

    def mean(self, duration):
        return self.const if self.const is not None else float(np.mean(self.v))


class Simulation:
    """One ensemble simulation. Build with structurally equal scenarios, then :meth:`run`."""

    def __init__(self, scenarios: Sequence[Scenario], source: str | None = None, n_threads: int = 1,
                 log_channels: str = "all"):
        if not scenarios:
            raise ValueError("no scenario")
        keys = {structure_key(s) for s in scenarios}
        if len(keys) != 1:
            raise ScenarioError("scenarios of one ensemble must share model, effects, actuator, controller, "
                                "sensors and timing", source=source)
        self.scenarios = list(scenarios)
        self.source = source
        # "metrics": the compiled loop may log only the channels the metrics read (batches without time
        # series); "all": every channel (the Python loop always logs everything)
        self.log_channels = log_channels
        # callables hook(logger, j, t) run after each logged step j (time t), e.g. the live 3D viewer
        # (suspension_sim.viewer.attach_live_viewer); logger.ch[name][car, j] holds the step's log channels
        self.log_hooks: list = []
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
            why_not = self._trapezoidal_refusal()
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
            self._check_trapezoidal(source)

        # effects ------------------------------------------------------------------------------------
        self.effects = []
        for i, ecfg in enumerate(sc0.vehicle.effects):
            ecls = EFFECTS.get(ecfg.type, field=f"vehicle.effects.{i}.type", source=source)
            sel = list(range(nc)) if ecfg.corners == "all" else [self.geom.corner_names.index(c) for c in ecfg.corners]
            if ecls.target == "tire" and not P.has_tire:
                raise ScenarioError(f"effect '{ecfg.type}' acts on the tire, and model '{sc0.vehicle.model}' has none",
                                    source=source, field=f"vehicle.effects.{i}.type")
            plist = [validate_params(ecls.Params, s.vehicle.effects[i].params, f"vehicle.effects.{i}.params", source)
                     for s in self.scenarios]
            ctx = EffectContext(n_cars=n, corners=[self.geom.corner_names[c] for c in sel], dt=self.dt,
                                static_suspension_force=P.static_susp[:, sel], static_tire_force=P.static_tire[:, sel],
                                spring_stiffness=ks[:, sel], damping=cs[:, sel], tire_stiffness=kt[:, sel],
                                tire_damping=ct[:, sel],
                                effective_mass=self._tendon_effective_mass(
                                    (P.tire_t if ecls.target == "tire" else P.susp_t)[:, sel]))
            self.effects.append((ecls(stack_params(plist, len(sel)), ctx), np.asarray(sel)))

        # actuator --------------------------------------------------------------------------------------
        acls = ACTUATORS.get(sc0.actuator.type, field="actuator.type", source=source)
        ap = stack_params([validate_params(acls.Params, s.actuator.params, "actuator.params", source)
                           for s in self.scenarios], nc)
        self.actuator = acls(ap, ActuatorContext(n, nc, self.dt, self.control_dt, P.static_susp.copy()))

        # roads ----------------------------------------------------------------------------------------
        self.speeds, self.roads = [], []
        for i, s in enumerate(self.scenarios):
            sp = SpeedProfile(s.road.speed, self.duration, self.dt)
            rcls = ROADS.get(s.road.type, field="road.type", source=source)
            rp = validate_params(rcls.Params, s.road.params, "road.params", source)
            seed = s.road.seed if s.road.seed is not None else s.sim.seed
            dist = float(sp.distance(self.duration)) if sp.const is not None else sp.max_distance
            rctx = RoadContext(duration=self.duration, distance=dist, wheelbase=P.vcls.wheelbase(P.params[i]),
                               mean_speed=sp.mean(self.duration), dt=self.dt,
                               n_tracks=1 + int(max(self.geom.tracks) > 0), tracks=s.road.tracks)
            self.speeds.append(sp)
            self.roads.append(rcls(rp, np.random.default_rng([seed, 8608]), rctx))
        # distance of each axle behind the front axle, per car (cars of an ensemble may differ in a, b)
        xs = np.asarray([[c.x for c in P.vcls.corners(p)] for p in P.params], dtype=float)
        self.corner_back = xs.max(axis=1, keepdims=True) - xs  # (n_cars, n_corners)

        # time-varying parameters -----------------------------------------------------------------------
        self.variations = []
        self._const_scratch = None  # MjData scratch for mj_setConst when a mass or inertia varies
        for vi, v in enumerate(sc0.vehicle.variations):
            fld, idx = P.variation_index(v.param)
            if fld.startswith("body"):
                self._const_scratch = mujoco.MjData(m)
            arr = getattr(m, fld).reshape(-1) if fld == "body_inertia" else getattr(m, fld)
            nominal = arr[idx].copy()
            cfgs = [s.vehicle.variations[vi] for s in self.scenarios]
            self.variations.append((arr, idx, nominal, cfgs))

        # manoeuvre (inertial loads) --------------------------------------------------------------------
        self.maneuver = None
        if sc0.vehicle.maneuver is not None:
            from .maneuvers import build_maneuver

            self.maneuver = build_maneuver(self.scenarios, P, source)

        # sensors ---------------------------------------------------------------------------------------
        sctx = SensorContext(n, self.geom.corner_names, self.geom.suffixes, P.body_joints, self.control_dt)
        self.sensors: list[SensorChannel] = []
        for i, scfg in enumerate(sc0.sensors):
            scls = SENSORS.get(scfg.type, field=f"sensors.{i}.type", source=source)
            sp_ = stack_params([validate_params(scls.Params, s.sensors[i].params, f"sensors.{i}.params", source)
                                for s in self.scenarios], nc)
            rng = _PerCarRNG([np.random.default_rng([s.sim.seed, 2631, i]) for s in self.scenarios])
            self.sensors.append(SensorChannel(scfg, scls(sp_, sctx), self.control_dt, rng))

        # controller ------------------------------------------------------------------------------------
        from suspension_sim.controllers.base import ControlContext

        ccls = CONTROLLERS.get(sc0.controller.type, field="controller.type", source=source)
        cp = stack_params([validate_params(ccls.Params, s.controller.params, "controller.params", source)
                           for s in self.scenarios], nc)
        vparams = stack_params(P.params, nc)
        self.full_state = sc0.controller.full_state
        self.cctx = ControlContext(
            n_cars=n, corners=self.geom.corner_names, suffixes=self.geom.suffixes, corner_x=self.geom.corner_x,
            corner_y=self.geom.corner_y, control_dt=self.control_dt, dt=self.dt, vehicle_model=sc0.vehicle.model,
            vehicle=vparams, sensors={ch.name: ch.sensor.labels() for ch in self.sensors},
            actuator=sc0.actuator.type, command_unit=acls.command_unit, full_state=self.full_state,
            static_suspension_force=P.static_susp.copy(), state_widths=self._state_widths(),
            extra={"actuator_params": ap})  # e.g. the policy controller's default action scale
        self.controller = ccls(cp, self.cctx)

    def _state_widths(self) -> dict:
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
    def _trapezoidal_refusal(self):
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
        if any("damping" in v.param for v in sc0.vehicle.variations):
            return ("time-varying damping",
                    "integrator 'trapezoidal' does not support time-varying damping; use implicitfast or RK4")
        ratio = P.susp_c * self.dt / self._tendon_effective_mass(P.susp_t)
        self._trap_ratio = float(np.max(ratio))
        if self._trap_ratio > 1.0:
            return (f"damping*dt/mass = {self._trap_ratio:.3g} > 1",
                    f"integrator 'trapezoidal' needs damping*dt/mass <= 1 on every suspension (here "
                    f"{self._trap_ratio:.3g}); use a smaller sim.dt, or implicitfast (any damping)")
        return None

    def _check_trapezoidal(self, source):
        why_not = self._trapezoidal_refusal()
        if why_not is not None:
            raise ScenarioError(why_not[1], source=source, field="sim.integrator")

    def _trapezoidal_coupling(self, d, v_prev):
        """Generalized forces standing in for the body-wheel entries of the suspension dampers' implicit
        half, which MuJoCo's implicit step leaves out (body and wheel are separate kinematic trees): with the
        velocity change of the coming step taken as the last step's, body dof b gets Σ_c (c_c/2)·J_cb·Δv_wheel,c
        and wheel c gets (c_c/2)·Σ_b J_cb·Δv_body,b.  Then updates v_prev (the compiled loop does the same,
        in the same order)."""
        P = self.plant
        dvb = d.qvel[P.body_v] - v_prev[P.body_v]
        dvw = d.qvel[P.wheel_v] - v_prev[P.wheel_v]
        Jb, hc = self._Jb, self._half_cs
        fb = 0.0
        for c in range(P.nc):
            fb = fb + (hc[:, c, None] * Jb[:, c, :]) * dvw[:, c, None]
        sw = 0.0
        for b in range(Jb.shape[2]):
            sw = sw + Jb[:, :, b] * dvb[:, b, None]
        fw = hc * sw
        if self.maneuver is None:
            d.qfrc_applied[P.body_v] = fb
            d.qfrc_applied[P.wheel_v] = fw
        else:  # on top of the manoeuvre's loads of this step
            d.qfrc_applied[P.body_v] += fb
            d.qfrc_applied[P.wheel_v] += fw
        v_prev[P.body_v] = d.qvel[P.body_v]
        v_prev[P.wheel_v] = d.qvel[P.wheel_v]

    def _tendon_effective_mass(self, tendons: np.ndarray) -> np.ndarray:
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

    def _road_chunk(self, k0: int, k1: int):
        """Road height and rate under each wheel for physics steps k0..k1-1: arrays (n, k1-k0, nc)."""
        n, nc = self.plant.n, self.plant.nc
        L = k1 - k0
        t = (np.arange(k0 - 1, k1 + 1)) * self.dt  # one extra sample each side for central differences
        z = np.empty((n, L + 2, nc))
        for i, (road, sp) in enumerate(zip(self.roads, self.speeds)):
            x = sp.distance(t)
            for c in range(nc):
                xc = x - self.corner_back[i, c]
                tc = t if self.corner_back[i, c] == 0 else sp.time_at(xc, t)
                z[i, :, c] = road.height(tc, xc, self.geom.tracks[c])
        zd = (z[:, 2:, :] - z[:, :-2, :]) / (2 * self.dt)
        if self.rk4:  # RK4 also prescribes the plates' acceleration within a step
            return z[:, 1:-1, :], zd, (z[:, 2:, :] - 2 * z[:, 1:-1, :] + z[:, :-2, :]) / self.dt ** 2
        return z[:, 1:-1, :], zd

    def _apply_variations(self, t: float):
        for arr, idx, nominal, cfgs in self.variations:
            vals = np.empty_like(nominal)
            for i, v in enumerate(cfgs):
                vals[i] = _variation_value(v, t, nominal[i])
            arr[idx] = vals
        if self._const_scratch is not None:
            # MuJoCo precomputes the mass matrix of simple (slide-joint) bodies (dof_M0) in mj_setConst: without
            # this a mass change would alter gravity but not inertia
            mujoco.mj_setConst(self.plant.model, self._const_scratch)

    def _state(self, t, road, road_vel, acc, F_act, F_tire_eff) -> PlantState:
        P, d = self.plant, self.plant.data
        travel = d.ten_length[P.susp_t]
        travel_rate = d.ten_velocity[P.susp_t]
        wheel_pos = d.qpos[P.wheel_q]
        wheel_vel = d.qvel[P.wheel_v]
        wheel_acc = acc[P.wheel_v] if P.has_tire else np.zeros_like(travel)
        if P.has_tire:
            tl, tr = P.tire_deflection(d, road, road_vel)
            tire = -self.kt * tl - self.ct * tr + F_tire_eff
        else:
            tire = np.zeros_like(travel)
        st = PlantState(
            t=t, body_pos=d.qpos[P.body_q], body_vel=d.qvel[P.body_v], body_acc=acc[P.body_v],
            corner_body_pos=travel + wheel_pos, corner_body_vel=travel_rate + wheel_vel,
            corner_body_acc=self._Jb_acc(acc),
            wheel_pos=wheel_pos, wheel_vel=wheel_vel, wheel_acc=wheel_acc, travel=travel, travel_rate=travel_rate,
            road=road, road_vel=road_vel, tire_force=tire, actuator_force=F_act,
            actuator_states=self.actuator.states())
        if any(ch.sensor.name == "road_preview" for ch in self.sensors):
            st.extra["road_preview"] = lambda dist: self._preview(t, dist)
        return st

    def _preview(self, t, dist):
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

    def _build_corner_jacobian(self):
        """Rows of each suspension tendon restricted to the body dofs (for corner body kinematics)."""
        P, m = self.plant, self.plant.model
        n, nc, nb = P.n, P.nc, len(P.body_joints)
        Jb = np.zeros((n, nc, nb))
        for i in range(n):
            for c in range(nc):
                ti = P.susp_t[i, c]
                for w in range(m.tendon_adr[ti], m.tendon_adr[ti] + m.tendon_num[ti]):
                    dof = m.jnt_dofadr[m.wrap_objid[w]]
                    hit = np.nonzero(P.body_v[i] == dof)[0]
                    if hit.size:
                        Jb[i, c, hit[0]] += m.wrap_prm[w]
        self._Jb = Jb

    def _Jb_acc(self, acc):
        """Acceleration of the body point above each corner: J_body · qacc (fixed tendons are linear)."""
        return np.einsum("ncb,nb->nc", self._Jb, acc[self.plant.body_v])

    # ------------------------------------------------------------------------------------------------
    def run(self, progress: Callable[[float], None] | None = None) -> list:
        """Simulate the whole run with the scenario's controller; one Result per car.

        Runs the compiled loop (:mod:`suspension_sim.compiled`) when the components have kernels, else the
        Python loop below; the results are the same.  :attr:`loop` tells which ran ("full", "hybrid",
        "python") and :attr:`loop_reason` why not the full compiled loop."""
        from .compiled.loop import plan, run as run_compiled

        mode, self.loop_reason = plan(self)
        self.loop = mode or "python"
        with _one_blas_thread(), _located(self):
            if mode is not None:
                self.results = run_compiled(self, mode, progress)
                return self.results
            readings = self.start(progress)
            while readings is not None:
                readings = self.control_step(self.controller.step(self.t, readings))
            return self.results

    def start(self, progress: Callable[[float], None] | None = None) -> dict:
        """Step-wise use (e.g. reinforcement learning): reset and advance to the first control instant.

        Returns the sensor readings at t = 0; then call :meth:`control_step` with each command.  The physics
        is the loop of :meth:`run` itself (which is built on these two methods), so results are identical."""
        self._loop = self._steps(progress)
        self.results = None
        return self.control_step(None)

    def control_step(self, command) -> dict | None:
        """Hold ``command`` (n_cars, n_corners) over one control step (zero-order hold) and return the
        readings at the next control instant, or None when the run has ended (then :attr:`results` holds one
        Result per car).  :attr:`t` is the time and :attr:`state` the true PlantState of the readings."""
        try:
            return self._loop.send(command) if command is not None else next(self._loop)
        except StopIteration as stop:
            self.results = stop.value
            return None

    def _steps(self, progress):
        from .results import Logger, Result

        P = self.plant
        m, d = P.model, P.data
        n, nc = P.n, P.nc
        mujoco.mj_resetData(m, d)
        self._build_corner_jacobian()
        self.actuator.reset()
        self.controller.reset()
        for e, _ in self.effects:
            e.reset()
        for ch in self.sensors:
            ch.reset()
        logger = Logger(self, n_log=n_log_samples(self.n_steps, self.log_every))
        command = np.zeros((n, nc))
        F_act = np.zeros((n, nc))
        F_eff = np.zeros((n, nc))
        F_teff = np.zeros((n, nc))
        acc = np.zeros(m.nv)
        chunk = max(self.sub, 2000 // self.sub * self.sub)
        wall0 = _time.perf_counter()
        prog_every = max(1, self.n_steps // 100)
        road_chunk = None
        readings: dict = {}
        # fast paths (same arithmetic, so identical results): strided views of MjData where the ensemble's
        # layout is regular instead of fancy indexing, no gathers for effects acting on every corner
        S = self._slots = _Slots(P, d)
        effects = [(e, sel, len(sel) == nc and bool(np.all(sel == np.arange(nc)))) for e, sel in self.effects]
        tire_effects = any(e.target == "tire" for e, _ in self.effects)
        zeros = np.zeros((n, nc))
        v_prev = np.zeros(m.nv)  # trapezoidal: the velocities at the previous step
        self._half_cs, self._half_ct = 0.5 * P.susp_c, 0.5 * P.tire_c
        for k in range(self.n_steps):
            t = k * self.dt
            j = k % chunk
            if j == 0:
                road_chunk = self._road_chunk(k, min(k + chunk, self.n_steps))
            road, road_vel = road_chunk[0][:, j, :], road_chunk[1][:, j, :]
            if P.road_dof:
                S.road_q.set(road)
                S.road_v.set(road_vel)
                S.road_servo.set(road)
            else:
                P.place_road(d, road, road_vel)
            control_now = k % self.sub == 0
            if control_now and self.variations:
                self._apply_variations(t)
            if self.maneuver is not None:
                d.qfrc_applied[:] = 0.0
                self.maneuver.apply(t, d)
            if self.rk4:
                # the plates are 1e12 kg (plant.py): this force gives them the road's acceleration, so within
                # the RK4 stages they follow the road to O(dt^3) and dampers to the road see its velocity
                d.qfrc_applied[P.road_v] = P.road_mass * road_chunk[2][:, j, :]
            mujoco.mj_step1(m, d)
            if control_now:
                self._last_forces = (F_act, F_eff, F_teff)
                self._check(t, d)
                state = self._state(t, road, road_vel, acc, F_act, F_teff)
                readings = {ch.name: ch.sample(state) for ch in self.sensors}
                if self.full_state:
                    readings.update(full_state_readings(state))
                self.t, self.state = t, state
                command = np.asarray((yield readings), dtype=float)
                if command.shape != (n, nc):
                    command = np.broadcast_to(command, (n, nc)).astype(float)
            travel = S.susp_len.get()
            rate = S.susp_vel.get()
            if self.trap:
                self._trapezoidal_coupling(d, v_prev)
            F_act = self.actuator.force(command, travel, rate, t)
            if effects:
                F_eff = zeros.copy()
                F_teff = zeros.copy()
                if tire_effects:
                    tlen, tvel = S.tire_len.get(), S.tire_vel.get()
                    if not P.road_dof:  # wheel − road
                        tlen, tvel = tlen - road, tvel - road_vel
                for eff, sel, every in effects:
                    if eff.target == "tire":
                        if every:
                            F_teff += eff.force(tlen, tvel, t, self.dt)
                        else:
                            F_teff[:, sel] += eff.force(tlen[:, sel], tvel[:, sel], t, self.dt)
                    elif every:
                        F_eff += eff.force(travel, rate, t, self.dt)
                    else:
                        F_eff[:, sel] += eff.force(travel[:, sel], rate[:, sel], t, self.dt)
                S.eff_s.set(F_eff)
                if P.has_tire and P.road_dof:
                    S.eff_t.set(F_teff)
            if self.trap:  # the explicit half of the linear dampers, on the effect motors
                S.eff_s.set(F_eff + (-self._half_cs * rate))
                S.eff_t.set(F_teff + P.tire_road_force(road_vel) + (-self._half_ct * S.tire_vel.get()))
            elif not P.road_dof:  # the road-rate part of the tire damper rides on the tire effect motor
                S.eff_t.set(F_teff + P.tire_road_force(road_vel))
            S.act.set(F_act)
            log_now = k % self.log_every == 0
            if log_now:
                logger.pre(k // self.log_every, t, road, road_vel, travel, rate, command, F_act, F_eff, F_teff, readings)
            need_acc = log_now or (k + 1) % self.sub == 0
            v_before = d.qvel.copy() if (need_acc and not self.rk4) else None
            if self.rk4:
                if need_acc:
                    # RK4: the acceleration at the step start, with this step's forces (exact at t_k; the
                    # velocity difference would be the step's mean acceleration, half a step late)
                    mujoco.mj_forwardSkip(m, d, mujoco.mjtStage.mjSTAGE_VEL, 1)
                    acc = d.qacc.copy()
                mujoco.mj_step(m, d)  # a full RK4 step (mj_step1 above only served the sensors and forces)
            else:
                mujoco.mj_step2(m, d)
            if need_acc and not self.rk4:
                # the acceleration the step applied, (v[k+1] - v[k]) / dt: with implicit damping d.qacc (the
                # explicit acceleration at the step start) differs from it by O(dt·c/m)
                acc = (d.qvel - v_before) / self.dt
            if log_now:
                logger.post(k // self.log_every, acc)
                for hook in self.log_hooks:
                    hook(logger, k // self.log_every, t)
            self.actuator.advance(command, travel, rate, t, self.dt)
            if progress is not None and k % prog_every == 0:
                progress(k / self.n_steps)
        self.end_forces = (acc, F_act, F_teff)  # the last step's acceleration and forces (envs.py's last observation)
        self._check(self.n_steps * self.dt, d)
        P.restore_road()
        wall = _time.perf_counter() - wall0
        if progress is not None:
            progress(1.0)
        return [Result.from_logger(logger, i, self, wall) for i in range(n)]

    def _check(self, t, d):
        P = self.plant
        q, v = d.qpos[P.free_q], d.qvel[P.free_v]
        lim_x = self.scenarios[0].sim.max_displacement
        lim_v = self.scenarios[0].sim.max_velocity
        ws = getattr(self, "_warn_stats", None)
        if ws is None or ws[0] is not d:  # MuJoCo's warning counters (live views, cheap to read)
            ws = self._warn_stats = (d, [(name, d.warning[w]) for name, w in _BAD])
        if np.abs(q).max() <= lim_x and np.abs(v).max() <= lim_v and not _mj_bad_values(d, ws[1]):
            return  # the common case, cheaply (NaN fails the comparisons)
        if _mj_bad_values(d, ws[1]):
            # MuJoCo replaced a NaN/Inf (in ctrl, qpos, qvel or qacc) and went on: report it, never hide it
            what = _mj_bad_values(d, ws[1])
            car = _car_of_ctrl(P, d.warning[mujoco.mjtWarning.mjWARN_BADCTRL].lastinfo) if what == "ctrl" else None
            forces = getattr(self, "_last_forces", ())
            if what == "ctrl" and any(not np.all(np.isfinite(f)) for f in forces):
                hint = "NaN: a force law, actuator or controller produced NaN/Inf (MuJoCo zeroed it and went on)"
            else:
                hint = (f"runaway state: MuJoCo met a huge value in {what} and reset the state; the controller may be "
                        "unstable or the step too large for a stiff element")
            from .divergence import nonfinite_state

            raise SimulationDiverged(t, nonfinite_state(self, what, car), hint, car=car if P.n > 1 else None)
        bad_q = ~np.isfinite(q) | (np.abs(q) > lim_x)
        bad_v = ~np.isfinite(v) | (np.abs(v) > lim_v)
        if bad_q.any() or bad_v.any():
            dof = P.free_v[np.argmax(bad_v)] if bad_v.any() else None
            qa = P.free_q[np.argmax(bad_q)] if bad_q.any() else None
            car = None
            state = {}
            for i in range(P.n):
                idx = np.concatenate([P.body_q[i], P.wheel_q[i]])
                if (qa is not None and qa in idx) or (dof is not None and dof in np.concatenate([P.body_v[i], P.wheel_v[i]])):
                    car = i
                    break
            ci = car or 0
            for k, jn in enumerate(P.body_joints):
                state[f"{jn}"] = float(d.qpos[P.body_q[ci, k]])
                state[f"{jn}_vel"] = float(d.qvel[P.body_v[ci, k]])
            for c, s in enumerate(P.suffixes):
                state[f"travel{s}"] = float(d.ten_length[P.susp_t[ci, c]])
            nonfinite = not (np.isfinite(q).all() and np.isfinite(v).all())
            hint = ("NaN: a force law produced an invalid value or the step is far too large for a stiff element"
                    if nonfinite else
                    "runaway state: the step may be too large for a stiff effect or actuator (try a smaller sim.dt), "
                    "the controller may be unstable, or the limits sim.max_displacement/max_velocity too tight")
            raise SimulationDiverged(t, state, hint, car=car if P.n > 1 else None)


def n_log_samples(n_steps: int, log_every: int) -> int:
    """Logged instants of a run: steps 0, log_every, 2·log_every, ... below n_steps (one more than
    n_steps // log_every when the duration is not a multiple of log_dt)."""
    return -(-int(n_steps) // int(log_every))


@contextlib.contextmanager
def _located(sim):
    """A divergence names the scenario file and the run (variant) it happened in."""
    try:
        yield
    except SimulationDiverged as err:
        car = err.car if err.car is not None and err.car < len(sim.scenarios) else 0
        raise err.locate(sim.source, sim.scenarios[car].name) from None


_BLAS_LIMITED = False


def _one_blas_thread():
    """One BLAS thread for the rest of the process, once (see suspension_sim/__init__.py: idle OpenBLAS
    threads spin and double a run's CPU time); a no-op context manager."""
    global _BLAS_LIMITED
    if not _BLAS_LIMITED and os.environ.get("OPENBLAS_NUM_THREADS", "1") == "1":
        _BLAS_LIMITED = True
        try:
            from threadpoolctl import threadpool_limits

            threadpool_limits(1, user_api="blas")
        except Exception:  # pragma: no cover - threadpoolctl missing or a BLAS it does not know
            pass
    return contextlib.nullcontext()


_BAD = (("ctrl", mujoco.mjtWarning.mjWARN_BADCTRL), ("qacc", mujoco.mjtWarning.mjWARN_BADQACC),
        ("qvel", mujoco.mjtWarning.mjWARN_BADQVEL), ("qpos", mujoco.mjtWarning.mjWARN_BADQPOS))


def _mj_bad_values(d, stats=None) -> str:
    """Name of the first array in which MuJoCo met a NaN/Inf since the reset ('' if none)."""
    for name, w in stats or [(name, d.warning[w]) for name, w in _BAD]:
        if w.number:
            return name
    return ""


def _car_of_ctrl(P, u: int):
    for i in range(P.n):
        grids = [P.act[i], P.eff_s[i]] + ([P.road_servo[i]] if P.road_dof else []) + \
            ([P.eff_t[i]] if P.eff_t is not None else [])
        if any(u in g for g in grids):
            return i
    return None


def _grid_view(arr: np.ndarray, idx: np.ndarray):
    """A strided ``(n, nc)`` view of the 1-D array ``arr`` at the index grid ``idx`` when the grid is regular
    (``idx[i, c] = base + i*si + c*sc``, si, sc >= 0), else None."""
    idx = np.asarray(idx)
    if arr.ndim != 1 or idx.ndim != 2 or idx.size == 0:
        return None
    n, nc = idx.shape
    base = int(idx[0, 0])
    si = int(idx[1, 0] - base) if n > 1 else 0
    sc = int(idx[0, 1] - base) if nc > 1 else 0
    if si < 0 or sc < 0:
        return None
    if not np.array_equal(idx, base + si * np.arange(n)[:, None] + sc * np.arange(nc)[None, :]):
        return None
    return np.lib.stride_tricks.as_strided(arr[base:], shape=(n, nc), strides=(si * arr.strides[0], sc * arr.strides[0]))


class _Slot:
    """Read (a copy) or write an ``(n, nc)`` index grid of a MjData array."""

    __slots__ = ("arr", "idx", "view")

    def __init__(self, arr, idx):
        self.arr, self.idx = arr, idx
        self.view = _grid_view(arr, idx) if idx is not None else None

    def get(self):
        return self.view.copy() if self.view is not None else self.arr[self.idx]

    def set(self, value):
        if self.view is not None:
            self.view[...] = value
        else:
            self.arr[self.idx] = value


class _Slots:
    def __init__(self, P, d):
        if P.road_dof:
            self.road_q, self.road_v, self.road_servo = _Slot(d.qpos, P.road_q), _Slot(d.qvel, P.road_v), _Slot(d.ctrl, P.road_servo)
        self.susp_len, self.susp_vel = _Slot(d.ten_length, P.susp_t), _Slot(d.ten_velocity, P.susp_t)
        self.tire_len, self.tire_vel = _Slot(d.ten_length, P.tire_t), _Slot(d.ten_velocity, P.tire_t)
        self.eff_s, self.eff_t, self.act = _Slot(d.ctrl, P.eff_s), _Slot(d.ctrl, P.eff_t), _Slot(d.ctrl, P.act)


class _PerCarRNG:
    """Noise generator of an ensemble: each car draws from its own stream (seeded by its scenario's
    ``sim.seed``), so a car's noise, and hence its result, is the same alone and inside any ensemble."""

    BLOCK = 256  # standard normals drawn ahead per car (the same stream as one draw per call, far cheaper)

    def __init__(self, rngs):
        self.rngs = rngs
        self._buf: dict = {}

    def normal(self, loc=0.0, scale=1.0, size=None):
        n = len(self.rngs)
        if size is None or np.ndim(loc) or np.ndim(scale) or len(tuple(size)) < 1 or tuple(size)[0] != n:
            if size is None or n == 1:
                return self.rngs[0].normal(loc, scale, size)
            return np.stack([g.normal(loc, scale, tuple(size)[1:]) for g in self.rngs])
        key = tuple(size)[1:]
        buf, pos = self._buf.get(key, (None, self.BLOCK))
        if pos == self.BLOCK:
            buf, pos = np.stack([g.standard_normal((self.BLOCK,) + key) for g in self.rngs]), 0
        self._buf[key] = (buf, pos + 1)
        return loc + scale * buf[:, pos]  # = Generator.normal(loc, scale) value by value

    def __getattr__(self, name):  # other draws: the first car's stream (single runs unchanged)
        return getattr(self.rngs[0], name)


def _variation_value(v, t: float, nominal):
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


def simulate(scenario, progress=None, source: str | None = None):
    """Simulate one scenario (path or :class:`Scenario`; a scenario with variants returns a dict
    variant -> Result), or a list of structurally equal scenarios as one ensemble (list of Results)."""
    if isinstance(scenario, (str, Path)):
        source = str(scenario)
        scenario = load_scenario(scenario)
    if isinstance(scenario, Scenario):
        variants = scenario.expand(source)
        if len(variants) == 1 and not scenario.variants:
            return Simulation([scenario], source).run(progress)[0]
        return {name: Simulation([sc], source).run(progress)[0] for name, sc in variants}
    scs = list(scenario)
    return Simulation(scs, source).run(progress)
