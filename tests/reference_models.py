"""Independent reference models (plain scipy ``solve_ivp``), written without any code of ``suspension_sim``.

They are the yardstick for the MuJoCo plant: a test simulates the same system both ways, with the same road
function, and compares the trajectories by :func:`nrmse`.

:class:`QuarterCarRef` is the 2-DOF quarter car written with absolute forces (gravity and spring preloads
explicit), so time-varying masses and stiffnesses behave physically: a spring keeps its free length when its
stiffness changes, a mass change moves the equilibrium.  Coordinates (like the simulator's): ``zs``/``zu`` =
body/wheel heights from the nominal static equilibrium, travel ``s = zs − zu`` (positive = extension), tire
deflection ``x = zu − zr`` (negative = compression).

Extra force elements are plain functions, so each effect gets its own, independent implementation in the
test that uses it:

- ``suspension_forces``: ``f(s, v, t) -> N``, positive pushes the body up and the wheel down;
- ``tire_forces``: ``f(x, xdot, t) -> N``, positive pushes the wheel up (``x`` = wheel − road from
  equilibrium);
- ``extra_states``: :class:`ExtraState` objects for elements with internal states (hysteresis, actuators):
  they add ODE states and a force on the suspension;
- ``coulomb_force``: *exact* dry friction ``F_c`` in the suspension (set-valued at zero travel rate): the
  integration switches between slipping (``−F_c·sgn(v)``) and sticking (body and wheel move together while
  the friction force needed for that stays within ``±F_c``), with ``solve_ivp`` events at every switch.

Parameters may be numbers or functions of time (parameter variations).

:class:`SdofRef` is the thesis's SDOF rig (one mass over a moving base) with the same pluggable forces and
exact Coulomb friction.

Example::

    ref = QuarterCarRef(road=lambda t: 0.01 * np.sin(2 * np.pi * 2 * t),
                        suspension_forces=[lambda s, v, t: -1500.0 * v * abs(v)])
    out = ref.simulate(t_eval)         # dict of arrays: body_z, travel, body_acc, ...
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

G = 9.81


def nrmse(sim, ref) -> float:
    """Normalised RMS error: RMS(sim − ref) / RMS(ref)."""
    sim = np.asarray(sim, dtype=float)
    ref = np.asarray(ref, dtype=float)
    return float(np.sqrt(np.mean((sim - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)))


def _as_fn(v) -> Callable[[float], float]:
    if callable(v):
        return v
    val = float(v)
    return lambda t: val


@dataclass
class ExtraState:
    """An internal state vector ``y`` (``n`` values, initial ``y0``) with ``dy/dt = deriv(y, s, v, t)`` and a
    suspension force ``force(y, s, v, t)`` (positive pushes the body up)."""

    n: int
    y0: Sequence[float]
    deriv: Callable
    force: Callable


def road_rate(road: Callable[[float], float], h: float = 1e-6) -> Callable[[float], float]:
    """Central-difference time derivative of a road height function (for roads given as heights only)."""
    return lambda t: (road(t + h) - road(t - h)) / (2 * h)


@dataclass
class QuarterCarRef:
    sprung_mass: float | Callable = 290.0
    unsprung_mass: float | Callable = 59.0
    spring_stiffness: float | Callable = 16812.0
    damping: float | Callable = 1000.0
    tire_stiffness: float | Callable = 190000.0
    tire_damping: float | Callable = 0.0
    road: Callable[[float], float] = lambda t: 0.0
    road_vel: Callable[[float], float] | None = None
    suspension_forces: list = field(default_factory=list)
    tire_forces: list = field(default_factory=list)
    extra_states: list = field(default_factory=list)
    coulomb_force: float = 0.0
    g: float = G

    def __post_init__(self):
        self._ms, self._mu = _as_fn(self.sprung_mass), _as_fn(self.unsprung_mass)
        self._ks, self._cs = _as_fn(self.spring_stiffness), _as_fn(self.damping)
        self._kt, self._ct = _as_fn(self.tire_stiffness), _as_fn(self.tire_damping)
        if self.road_vel is None:
            self.road_vel = road_rate(self.road)
        # spring free lengths (as compressions) from the parameters at t = 0: the static loads
        ms0, mu0 = self._ms(0.0), self._mu(0.0)
        self.static_suspension_force = ms0 * self.g
        self.static_tire_force = (ms0 + mu0) * self.g
        self._Ls = self.static_suspension_force / self._ks(0.0)
        self._Lt = self.static_tire_force / self._kt(0.0)

    # ---------------------------------------------------------------------------------------------
    def forces(self, t, y):
        """(suspension force on the body, tire force on the wheel, extra-state derivatives)."""
        zs, vs, zu, vu = y[:4]
        s, v = zs - zu, vs - vu
        x, xd = zu - self.road(t), vu - self.road_vel(t)
        f_susp = self._ks(t) * (self._Ls - s) - self._cs(t) * v - self.coulomb_force * self._slip
        for f in self.suspension_forces:
            f_susp += f(s, v, t)
        dy = []
        k = 4
        for e in self.extra_states:
            ye = y[k:k + e.n]
            f_susp += e.force(ye, s, v, t)
            dy.extend(np.atleast_1d(e.deriv(ye, s, v, t)))
            k += e.n
        f_tire = self._kt(t) * (self._Lt - x) - self._ct(t) * xd
        for f in self.tire_forces:
            f_tire += f(x, xd, t)
        return f_susp, f_tire, dy

    _slip = 0.0  # exact Coulomb friction: +1/-1 slipping with v > 0 / v < 0, 0 sticking (or no friction)
    _stuck = False

    def stick_force(self, t, y):
        """Friction force that keeps the travel rate at zero (exact Coulomb friction, sticking)."""
        y = np.array(y, dtype=float)
        y[3] = y[1]
        slip, self._slip = self._slip, 0.0
        f_susp, f_tire, _ = self.forces(t, y)
        self._slip = slip
        ms, mu = self._ms(t), self._mu(t)
        return (f_tire / mu - f_susp * (1 / ms + 1 / mu)) / (1 / ms + 1 / mu)

    def rhs(self, t, y):
        zs, vs, zu, vu = y[:4]
        f_susp, f_tire, dy = self.forces(t, y)
        if self._stuck:  # body and wheel move together: internal forces cancel
            a = f_tire / (self._ms(t) + self._mu(t)) - self.g
            return [vs, a, vs, a, *dy]
        a_s = f_susp / self._ms(t) - self.g
        a_u = (f_tire - f_susp) / self._mu(t) - self.g
        return [vs, a_s, vu, a_u, *dy]

    def _segments(self, a, b, y0, **kw):
        """Integrate [a, b]; with exact Coulomb friction, one solve_ivp call per stick/slip phase."""
        if self.coulomb_force <= 0:
            sol = solve_ivp(self.rhs, (a, b), y0, dense_output=True, **kw)
            if not sol.success:
                raise RuntimeError(sol.message)
            return [(a, b, sol.sol)], sol.y[:, -1]
        Fc = self.coulomb_force
        out = []
        t = a
        y = np.asarray(y0, dtype=float)
        v = y[1] - y[3]
        # phase at the start: slip if moving, else stick if the friction can hold
        stuck = abs(v) < 1e-12 and abs(self.stick_force(t, y)) <= Fc
        slip = 0.0 if stuck else (float(np.sign(v)) if abs(v) >= 1e-12 else -float(np.sign(self.stick_force(t, y))))
        while t < b - 1e-12:
            self._stuck, self._slip = stuck, slip
            if stuck:
                y = y.copy()
                y[3] = y[1]

                def ev(tt, yy):
                    return Fc - abs(self.stick_force(tt, yy))
            else:
                d = slip

                def ev(tt, yy):
                    return d * (yy[1] - yy[3])
            ev.terminal, ev.direction = True, -1
            sol = solve_ivp(self.rhs, (t, b), y, dense_output=True, events=ev, **kw)
            if not sol.success:
                raise RuntimeError(sol.message)
            out.append((t, sol.t[-1], sol.sol, stuck, slip))
            t, y = sol.t[-1], sol.y[:, -1].copy()
            if sol.status != 1:
                break
            if stuck:  # the friction can no longer hold: slip against the force it would need
                Fs = self.stick_force(t, y)
                stuck, slip = False, -float(np.sign(Fs))
            else:  # the travel rate reached zero: stick if the friction can hold, else reverse
                y[3] = y[1]
                Fs = self.stick_force(t, y)
                if abs(Fs) < Fc:
                    stuck, slip = True, 0.0
                else:
                    slip = -float(np.sign(Fs))
        self._stuck, self._slip = False, 0.0
        return out, y

    def simulate(self, t_eval, rtol: float = 1e-10, atol: float = 1e-12, max_step: float = np.inf,
                 method: str = "DOP853", breaks: Sequence[float] = ()) -> dict:
        """Integrate from rest at equilibrium over ``[0, t_eval[-1]]``.  ``breaks``: times where the
        inputs are discontinuous (parameter steps); integration restarts there.  Returns a dict of arrays
        at ``t_eval``: ``body_z, body_vel, body_acc, wheel_z, wheel_vel, wheel_acc, travel, travel_rate,
        road, tire_force`` (dynamic tire force relative to the static load, positive = more compression)
        and ``suspension_force`` (total force of the suspension on the body)."""
        t_eval = np.asarray(t_eval, dtype=float)
        y0 = np.concatenate([np.zeros(4), *[np.asarray(e.y0, dtype=float) for e in self.extra_states]])
        edges = [0.0, *sorted(b for b in breaks if 0.0 < b < t_eval[-1]), float(t_eval[-1])]
        Y = np.zeros((len(y0), len(t_eval)))
        mode = np.zeros((2, len(t_eval)))  # (stuck, slip direction) for exact Coulomb friction
        kw = dict(method=method, rtol=rtol, atol=atol, max_step=max_step)
        for a, b in zip(edges[:-1], edges[1:]):
            segs, y0 = self._segments(a, b, y0, **kw)
            for seg in segs:
                s0, s1, fn = seg[:3]
                last = s1 >= edges[-1] - 1e-12
                sel = (t_eval >= s0) & ((t_eval < s1) | (last & (t_eval <= s1)))
                if sel.any():
                    Y[:, sel] = fn(t_eval[sel])
                    if len(seg) > 3:
                        mode[:, sel] = np.array(seg[3:], dtype=float)[:, None]
        out = {"t": t_eval, "body_z": Y[0], "body_vel": Y[1], "wheel_z": Y[2], "wheel_vel": Y[3],
               "travel": Y[0] - Y[2], "travel_rate": Y[1] - Y[3]}
        acc, fs, ft = [], [], []
        for i, t in enumerate(t_eval):
            self._stuck, self._slip = bool(mode[0, i]), mode[1, i]
            acc.append(self.rhs(t, Y[:, i]))
            f = self.forces(t, Y[:, i])
            fs.append(f[0] + (self.stick_force(t, Y[:, i]) if self._stuck else 0.0))
            ft.append(f[1])
        self._stuck, self._slip = False, 0.0
        acc = np.array(acc)
        out["body_acc"], out["wheel_acc"] = acc[:, 1], acc[:, 3]
        out["road"] = np.array([self.road(t) for t in t_eval])
        out["tire_force"] = np.array(ft) - self.static_tire_force
        out["suspension_force"] = np.array(fs)
        if self.coulomb_force > 0:
            out["stuck"] = mode[0].astype(bool)
        if self.extra_states:
            out["extra"] = Y[4:]
        return out


@dataclass
class SdofRef:
    """Single mass ``M`` on a spring ``K`` / damper ``C`` over a base moved by ``road`` (the thesis's SDOF rig),
    with pluggable suspension forces ``f(z, zdot, t)`` (``z`` = mass − base from equilibrium, positive pushes
    the mass up) and optional exact Coulomb friction ``coulomb_force`` (stick/slip with events).  Returns
    ``body_z, body_vel, body_acc, travel, travel_rate, road`` like :class:`QuarterCarRef`."""

    sprung_mass: float = 250.0
    spring_stiffness: float = 5000.0
    damping: float = 250.0
    road: Callable[[float], float] = lambda t: 0.0
    suspension_forces: list = field(default_factory=list)
    coulomb_force: float = 0.0
    g: float = G
    h: float = 1e-5  # step of the central differences giving the base velocity (10·h for the acceleration)

    def _base(self, t):
        h, w = self.h, self.road
        H = 10 * h
        return w(t), (w(t + h) - w(t - h)) / (2 * h), (w(t + H) - 2 * w(t) + w(t - H)) / H ** 2

    def other_force(self, t, y):
        """All forces on the mass but friction and gravity."""
        w, wd, _ = self._base(t)
        z, zd = y[0] - w, y[1] - wd
        f = self.spring_stiffness * (self.sprung_mass * self.g / self.spring_stiffness - z) - self.damping * zd
        for fn in self.suspension_forces:
            f += fn(z, zd, t)
        return f

    def stick_force(self, t, y):
        """Friction force that keeps the mass moving with the base."""
        return self.sprung_mass * (self._base(t)[2] + self.g) - self.other_force(t, y)

    def rhs(self, t, y, stuck=False, slip=0.0):
        if stuck:
            _, wd, wdd = self._base(t)
            return [wd, wdd]
        return [y[1], (self.other_force(t, y) - self.coulomb_force * slip) / self.sprung_mass - self.g]

    def simulate(self, t_eval, rtol: float = 1e-10, atol: float = 1e-12, method: str = "DOP853") -> dict:
        t_eval = np.asarray(t_eval, dtype=float)
        T, Fc = float(t_eval[-1]), self.coulomb_force
        y, t = np.zeros(2), 0.0
        Y = np.zeros((2, len(t_eval)))
        modes = np.zeros((2, len(t_eval)))
        stuck = Fc > 0 and abs(self.stick_force(0.0, y)) <= Fc
        slip = 0.0 if (stuck or Fc == 0) else -float(np.sign(self.stick_force(0.0, y)))
        while t < T - 1e-12:
            st, sl = stuck, slip
            if st:  # the mass rides on the base: no ODE; find when the friction can no longer hold it
                z0 = y[0] - self.road(t)
                hold = lambda tt: Fc - abs(self.stick_force(tt, [self.road(tt) + z0, self._base(tt)[1]]))
                grid = np.append(np.arange(t, T, 5e-4), T)
                t1 = T
                for a, b in zip(grid[:-1], grid[1:]):
                    if hold(b) < 0:
                        t1 = brentq(hold, a, b, xtol=1e-13)
                        break
                sel = (t_eval >= t) & ((t_eval < t1) | (t1 >= T - 1e-12))
                Y[0, sel] = [self.road(tt) + z0 for tt in t_eval[sel]]
                Y[1, sel] = [self._base(tt)[1] for tt in t_eval[sel]]
                modes[:, sel] = np.array([[1.0], [0.0]])
                t, y = t1, np.array([self.road(t1) + z0, self._base(t1)[1]])
                if t1 >= T - 1e-12:
                    break
                stuck, slip = False, -float(np.sign(self.stick_force(t, y)))
                continue
            if Fc <= 0:
                events = None
            else:
                def ev(tt, yy):
                    return sl * (yy[1] - self._base(tt)[1])
                ev.terminal, ev.direction = True, -1
                events = ev
            sol = solve_ivp(lambda tt, yy: self.rhs(tt, yy, st, sl), (t, T), y, method=method, rtol=rtol, atol=atol,
                            dense_output=True, events=events)
            if not sol.success:
                raise RuntimeError(sol.message)
            t1 = sol.t[-1]
            sel = (t_eval >= t) & ((t_eval < t1) | (t1 >= T - 1e-12))
            if sel.any():
                Y[:, sel] = sol.sol(t_eval[sel])
                modes[:, sel] = np.array([[0.0], [sl]])
            t, y = t1, sol.y[:, -1].copy()
            if sol.status != 1:
                break
            y[1] = self._base(t)[1]
            Fs = self.stick_force(t, y)
            stuck, slip = (True, 0.0) if abs(Fs) < Fc else (False, -float(np.sign(Fs)))
        base = np.array([self._base(t) for t in t_eval]).T
        acc = np.array([self.rhs(t, Y[:, i], bool(modes[0, i]), modes[1, i])[1] for i, t in enumerate(t_eval)])
        out = {"t": t_eval, "body_z": Y[0], "body_vel": Y[1], "body_acc": acc, "road": base[0],
               "travel": Y[0] - base[0], "travel_rate": Y[1] - base[1]}
        if Fc > 0:
            out["stuck"] = modes[0].astype(bool)
            out["slip"] = modes[1]
        return out
