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
  they add ODE states and a force on the suspension.

Parameters may be numbers or functions of time (parameter variations).

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
        f_susp = self._ks(t) * (self._Ls - s) - self._cs(t) * v
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

    def rhs(self, t, y):
        zs, vs, zu, vu = y[:4]
        f_susp, f_tire, dy = self.forces(t, y)
        a_s = f_susp / self._ms(t) - self.g
        a_u = (f_tire - f_susp) / self._mu(t) - self.g
        return [vs, a_s, vu, a_u, *dy]

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
        for a, b in zip(edges[:-1], edges[1:]):
            sol = solve_ivp(self.rhs, (a, b), y0, method=method, rtol=rtol, atol=atol, max_step=max_step,
                            dense_output=True)
            if not sol.success:
                raise RuntimeError(sol.message)
            sel = (t_eval >= a) & ((t_eval < b) | (b == edges[-1]))
            if sel.any():
                Y[:, sel] = sol.sol(t_eval[sel])
            y0 = sol.y[:, -1]
        out = {"t": t_eval, "body_z": Y[0], "body_vel": Y[1], "wheel_z": Y[2], "wheel_vel": Y[3],
               "travel": Y[0] - Y[2], "travel_rate": Y[1] - Y[3]}
        acc = np.array([self.rhs(t, Y[:, i]) for i, t in enumerate(t_eval)])
        out["body_acc"], out["wheel_acc"] = acc[:, 1], acc[:, 3]
        out["road"] = np.array([self.road(t) for t in t_eval])
        ft = np.array([self.forces(t, Y[:, i])[1] for i, t in enumerate(t_eval)])
        out["tire_force"] = ft - self.static_tire_force
        out["suspension_force"] = np.array([self.forces(t, Y[:, i])[0] for i, t in enumerate(t_eval)])
        if self.extra_states:
            out["extra"] = Y[4:]
        return out
