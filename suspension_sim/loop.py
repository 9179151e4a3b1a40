"""The Python loop: steps a built :class:`~suspension_sim.build.System` and records into a logger.

Per physics step ``dt`` (default 0.5 ms), for every car of the ensemble at once:

1. the road plates are placed kinematically at the road height (and rate) under each wheel;
2. time-varying parameters and manoeuvre loads are applied (at control instants / every step);
3. ``mj_step1`` computes positions and velocities (tendon lengths = travel, tire deflection);
4. at control instants (every ``control_dt``) the sensors sample the plant and the controller returns a
   command, held (zero-order hold) until the next control instant;
5. the actuator force and the effect forces are computed from the state at the start of the step (an effect
   that reads the actuator force gets this step's) and written to the corner motors;
6. ``mj_step2`` integrates (implicitfast: tendon dampers implicit) and the actuator states advance.

Logging happens every ``log_dt``.  A NaN or runaway state stops the run with
:class:`~suspension_sim.errors.SimulationDiverged` naming the time, the state and a hint
(:func:`check_divergence`).  The compiled loop (:mod:`suspension_sim.compiled.loop`) runs the same steps.
"""
from __future__ import annotations

import contextlib
import os
import time as _time

import mujoco
import numpy as np

from .errors import SimulationDiverged
from .sensors.base import PlantState, full_state_readings, period_mean_acc


def steps(sim, logger, progress=None):
    """The Python loop of ``sim`` (a built :class:`~suspension_sim.build.System`), as a generator: yields the
    sensor readings at each control instant and is sent the command; records into ``logger``
    (:class:`~suspension_sim.log.Logger`) and returns the wall time (s) of the loop.

    ``sim`` also carries the run's hooks (``sim.log_hooks``: ``hook(logger, j, t)`` after each logged step, j
    the step's row in the logger's buffer)
    and, at each control instant, ``sim.t`` and ``sim.state`` (the true :class:`PlantState` of the
    readings); at the end ``sim.end_forces`` (the last step's acceleration, actuator and tire-effect forces)."""
    P = sim.plant
    m, d = P.model, P.data
    n, nc = P.n, P.nc
    sim.reset()
    command = np.zeros((n, nc))
    F_act = np.zeros((n, nc))
    F_eff = np.zeros((n, nc))
    F_teff = np.zeros((n, nc))
    acc = np.zeros(m.nv)
    chunk = max(sim.sub, 2000 // sim.sub * sim.sub)
    wall0 = _time.perf_counter()
    prog_every = max(1, sim.n_steps // 100)
    road_chunk = None
    readings: dict = {}
    # fast paths (same arithmetic, so identical results): strided views of MjData where the ensemble's
    # layout is regular instead of fancy indexing, no gathers for effects acting on every corner
    S = sim.slots = Slots(P, d)
    effects = [(e, sel, len(sel) == nc and bool(np.all(sel == np.arange(nc)))) for e, sel in sim.effects]
    tire_effects = any(e.target == "tire" for e, _ in sim.effects)
    zeros = np.zeros((n, nc))
    v_prev = sim.v_prev  # trapezoidal: the velocities at the previous step (System.reset, reset_cars)
    sim.half_cs, sim.half_ct = 0.5 * P.susp_c, 0.5 * P.tire_c
    for k in range(sim.n_steps):
        t = k * sim.dt
        j = k % chunk
        if j == 0:
            road_chunk = sim.road_chunk(k, min(k + chunk, sim.n_steps))
        road, road_vel = road_chunk[0][:, j, :], road_chunk[1][:, j, :]
        if P.road_dof:
            S.road_q.set(road)
            S.road_v.set(road_vel)
            S.road_servo.set(road)
        else:
            P.place_road(d, road, road_vel)
        control_now = k % sim.sub == 0
        if control_now and sim.variations:
            sim.apply_variations(t)
        if sim.maneuver is not None:
            d.qfrc_applied[:] = 0.0
            sim.maneuver.apply(t, d)
        if sim.rk4:
            # the plates are 1e12 kg (plant.py): this force gives them the road's acceleration, so within
            # the RK4 stages they follow the road to O(dt^3) and dampers to the road see its velocity
            d.qfrc_applied[P.road_v] = P.road_mass * road_chunk[2][:, j, :]
        mujoco.mj_step1(m, d)
        if control_now:
            sim.last_forces = (F_act, F_eff, F_teff)
            check_divergence(sim, t, d)
            period_mean_acc(d.qvel, sim.v_ctrl, sim.acc_dofs, sim.acc_period, sim.acc_mean)
            state = plant_state(sim, t, road, road_vel, acc, F_act, F_teff, sim.acc_mean)
            command, readings = yield from exchange(sim, t, state)
        travel = S.susp_len.get()
        rate = S.susp_vel.get()
        if sim.trap:
            trapezoidal_coupling(sim, d, v_prev)
        F_act = sim.actuator.force(command, travel, rate, t)
        if effects:
            F_eff = zeros.copy()
            F_teff = zeros.copy()
            if tire_effects:
                tlen, tvel = S.tire_len.get(), S.tire_vel.get()
                if not P.road_dof:  # wheel − road
                    tlen, tvel = tlen - road, tvel - road_vel
            for eff, sel, every in effects:
                fa = ((F_act if every else F_act[:, sel]),) if eff.reads_actuator_force else ()
                if eff.target == "tire":
                    if every:
                        F_teff += eff.force(tlen, tvel, t, sim.dt, *fa)
                    else:
                        F_teff[:, sel] += eff.force(tlen[:, sel], tvel[:, sel], t, sim.dt, *fa)
                elif every:
                    F_eff += eff.force(travel, rate, t, sim.dt, *fa)
                else:
                    F_eff[:, sel] += eff.force(travel[:, sel], rate[:, sel], t, sim.dt, *fa)
            S.eff_s.set(F_eff)
            if P.has_tire and P.road_dof:
                S.eff_t.set(F_teff)
        if sim.trap:  # the explicit half of the linear dampers, on the effect motors
            S.eff_s.set(F_eff + (-sim.half_cs * rate))
            S.eff_t.set(F_teff + P.tire_road_force(road_vel) + (-sim.half_ct * S.tire_vel.get()))
        elif not P.road_dof:  # the road-rate part of the tire damper rides on the tire effect motor
            S.eff_t.set(F_teff + P.tire_road_force(road_vel))
        S.act.set(F_act)
        log_now = k % sim.log_every == 0
        if log_now:
            jl = logger.local(k // sim.log_every)  # the row in the log buffer (a full buffer is flushed)
            logger.pre(jl, t, road, road_vel, travel, rate, command, F_act, F_eff, F_teff, readings)
        need_acc = log_now or (k + 1) % sim.sub == 0
        v_before = d.qvel.copy() if (need_acc and not sim.rk4) else None
        if sim.rk4:
            if need_acc:
                # RK4: the acceleration at the step start, with this step's forces (exact at t_k; the
                # velocity difference would be the step's mean acceleration, half a step late)
                mujoco.mj_forwardSkip(m, d, mujoco.mjtStage.mjSTAGE_VEL, 1)
                acc = d.qacc.copy()
            mujoco.mj_step(m, d)  # a full RK4 step (mj_step1 above only served the sensors and forces)
        else:
            mujoco.mj_step2(m, d)
        if need_acc and not sim.rk4:
            # the acceleration the step applied, (v[k+1] - v[k]) / dt: with implicit damping d.qacc (the
            # explicit acceleration at the step start) differs from it by O(dt·c/m)
            acc = (d.qvel - v_before) / sim.dt
        if log_now:
            logger.post(jl, acc)
            for hook in sim.log_hooks:
                hook(logger, jl, t)
        sim.actuator.advance(command, travel, rate, t, sim.dt)
        if progress is not None and k % prog_every == 0:
            progress(k / sim.n_steps)
    sim.end_forces = (acc, F_act, F_teff)  # the last step's acceleration and forces (envs.py's last observation)
    check_divergence(sim, sim.n_steps * sim.dt, d)
    P.restore_road()
    wall = _time.perf_counter() - wall0
    if progress is not None:
        progress(1.0)
    return wall


def exchange(sim, t, state):
    """A control instant of either loop: the sensors sample ``state``, the readings are yielded to the
    controller's caller, and the command sent back (broadcast to (n_cars, n_corners)) is returned with the
    readings.  Used as ``command, readings = yield from exchange(sim, t, state)``."""
    readings = {ch.name: ch.sample(state) for ch in sim.sensors}
    if sim.full_state:
        readings.update(full_state_readings(state))
    sim.t, sim.state = t, state
    command = np.asarray((yield readings), dtype=float)
    shape = (sim.plant.n, sim.plant.nc)
    if command.shape != shape:
        command = np.broadcast_to(command, shape).astype(float)
    return command, readings


def plant_state(sim, t, road, road_vel, acc, F_act, F_tire_eff, acc_mean=None) -> PlantState:
    """The true plant quantities at time ``t`` (read from MuJoCo after ``mj_step1``) that the sensors sample;
    ``acc`` is the last physics step's acceleration, ``acc_mean`` (all dofs; None: zero) the mean over the
    control period ending at ``t`` (:func:`~suspension_sim.sensors.base.period_mean_acc`)."""
    P, d = sim.plant, sim.plant.data
    travel = d.ten_length[P.susp_t]
    travel_rate = d.ten_velocity[P.susp_t]
    wheel_pos = d.qpos[P.wheel_q]
    wheel_vel = d.qvel[P.wheel_v]
    wheel_acc = acc[P.wheel_v] if P.has_tire else np.zeros_like(travel)
    if acc_mean is None:
        acc_mean = np.zeros_like(acc)
    if P.has_tire:
        tl, tr = P.tire_deflection(d, road, road_vel)
        tire = -sim.kt * tl - sim.ct * tr + F_tire_eff
    else:
        tire = np.zeros_like(travel)
    st = PlantState(
        t=t, body_pos=d.qpos[P.body_q], body_vel=d.qvel[P.body_v], body_acc=acc[P.body_v],
        corner_body_pos=travel + wheel_pos, corner_body_vel=travel_rate + wheel_vel,
        corner_body_acc=sim.corner_body_acc(acc),
        wheel_pos=wheel_pos, wheel_vel=wheel_vel, wheel_acc=wheel_acc, travel=travel, travel_rate=travel_rate,
        road=road, road_vel=road_vel, tire_force=tire, actuator_force=F_act,
        body_acc_mean=acc_mean[P.body_v], corner_body_acc_mean=sim.corner_body_acc(acc_mean),
        wheel_acc_mean=acc_mean[P.wheel_v] if P.has_tire else np.zeros_like(travel),
        actuator_states=sim.actuator.states())
    if any(ch.sensor.name == "road_preview" for ch in sim.sensors):
        st.extra["road_preview"] = lambda dist: sim.road_preview(t, dist)
    return st


def trapezoidal_coupling(sim, d, v_prev):
    """Generalized forces standing in for the body-wheel entries of the suspension dampers' implicit
    half, which MuJoCo's implicit step leaves out (body and wheel are separate kinematic trees): with the
    velocity change of the coming step taken as the last step's, body dof b gets Σ_c (c_c/2)·J_cb·Δv_wheel,c
    and wheel c gets (c_c/2)·Σ_b J_cb·Δv_body,b.  Then updates v_prev (the compiled loop does the same,
    in the same order)."""
    P = sim.plant
    dvb = d.qvel[P.body_v] - v_prev[P.body_v]
    dvw = d.qvel[P.wheel_v] - v_prev[P.wheel_v]
    Jb, hc = sim.Jb, sim.half_cs
    fb = 0.0
    for c in range(P.nc):
        fb = fb + (hc[:, c, None] * Jb[:, c, :]) * dvw[:, c, None]
    sw = 0.0
    for b in range(Jb.shape[2]):
        sw = sw + Jb[:, :, b] * dvb[:, b, None]
    fw = hc * sw
    if sim.maneuver is None:
        d.qfrc_applied[P.body_v] = fb
        d.qfrc_applied[P.wheel_v] = fw
    else:  # on top of the manoeuvre's loads of this step
        d.qfrc_applied[P.body_v] += fb
        d.qfrc_applied[P.wheel_v] += fw
    v_prev[P.body_v] = d.qvel[P.body_v]
    v_prev[P.wheel_v] = d.qvel[P.wheel_v]


def check_divergence(sim, t, d):
    """Raise :class:`~suspension_sim.errors.SimulationDiverged` (time, state, hint) if a car's state is not
    finite, beyond ``sim.max_displacement``/``max_velocity``, or MuJoCo met a NaN/Inf since the reset."""
    P = sim.plant
    q, v = d.qpos[P.free_q], d.qvel[P.free_v]
    lim_x = sim.scenarios[0].sim.max_displacement
    lim_v = sim.scenarios[0].sim.max_velocity
    ws = getattr(sim, "warn_stats", None)
    if ws is None or ws[0] is not d:  # MuJoCo's warning counters (live views, cheap to read)
        ws = sim.warn_stats = (d, [(name, d.warning[w]) for name, w in _BAD])
    if np.abs(q).max() <= lim_x and np.abs(v).max() <= lim_v and not _mj_bad_values(d, ws[1]):
        return  # the common case, cheaply (NaN fails the comparisons)
    if _mj_bad_values(d, ws[1]):
        # MuJoCo replaced a NaN/Inf (in ctrl, qpos, qvel or qacc) and went on: report it, never hide it
        what = _mj_bad_values(d, ws[1])
        car = _car_of_ctrl(P, d.warning[mujoco.mjtWarning.mjWARN_BADCTRL].lastinfo) if what == "ctrl" else None
        forces = getattr(sim, "last_forces", ())
        if what == "ctrl" and any(not np.all(np.isfinite(f)) for f in forces):
            hint = "NaN: a force law, actuator or controller produced NaN/Inf (MuJoCo zeroed it and went on)"
        else:
            hint = (f"runaway state: MuJoCo met a huge value in {what} and reset the state; the controller may be "
                    "unstable or the step too large for a stiff element")
        from .divergence import nonfinite_state

        raise SimulationDiverged(t, nonfinite_state(sim, what, car), hint, car=car if P.n > 1 else None)
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


_BLAS_LIMITED = False


def one_blas_thread():
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


class Slot:
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


class Slots:
    def __init__(self, P, d):
        if P.road_dof:
            self.road_q, self.road_v, self.road_servo = Slot(d.qpos, P.road_q), Slot(d.qvel, P.road_v), Slot(d.ctrl, P.road_servo)
        self.susp_len, self.susp_vel = Slot(d.ten_length, P.susp_t), Slot(d.ten_velocity, P.susp_t)
        self.tire_len, self.tire_vel = Slot(d.ten_length, P.tire_t), Slot(d.ten_velocity, P.tire_t)
        self.eff_s, self.eff_t, self.act = Slot(d.ctrl, P.eff_s), Slot(d.ctrl, P.eff_t), Slot(d.ctrl, P.act)
