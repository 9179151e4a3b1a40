"""Electromagnetic (variable-reluctance) actuator of Toscano & Dumas: a push/pull pair of solenoid units with
coil current control.  Command = force demand (N).

Force law (their Eq. 6, fitted to their measurements; x = core position in m, i in A):

    F_m = p(x)·i²,   p(x) = 0.197 − 1.94·x + 26.34·x² − 239.54·x³   (N/A²)

A unit only pulls its core (the force acts towards minimum reluctance), so a two-sided actuator is a pair:
the *push* unit produces positive suspension force (body up, wheel down), the *pull* unit negative force;
the force along the suspension is F = p(x_push)·i_push² − p(x_pull)·i_pull².  Core positions (chosen; the
paper gives only the force law): both cores sit at ``x0`` at the static equilibrium and move with the
suspension travel s in opposite senses, x_push = x0 − s, x_pull = x0 + s, clipped to the fitted stroke
[``x_min``, ``x_max``] (p > 0 there: p(0) = 0.197, p(0.05) = 0.136, p(0.1) = 0.026 N/A²; p has a root
near 0.11 m).

Coil (Eq. 7, electrical part): L·di/dt = −R·i + u, with R and L chosen (not in the paper): R = 0.2 Ω,
L = 5 mH (τ = L/R = 25 ms), a ±48 V H-bridge supply (``u_max``), current ≥ 0 (the coil current of a
reluctance actuator needs no sign; the bridge freewheels at 0) and a current limit ``i_max`` = 100 A on the
reference (up to 1360 N per unit at x0 = 0.05 m).  The moving core's mechanical dynamics (mass, guide
friction of Eq. 7) are part of the unsprung/sprung masses; the back-EMF of the moving core is neglected,
as in the paper's model.

Current control (Eq. 8): u = (1/T_i)·∫(i_r − i)dt − K_i·i, with i_r = sqrt(F/p(x)) for the unit that
carries the demanded force (the other unit's reference is 0).  This I-P structure gives the closed loop
L·s² + (R + K_i)·s + 1/T_i; the defaults place both poles at 2π·100 Hz (critically damped):
1/T_i = L·ω², K_i = 2ωL − R.  The integrator stops while the voltage saturates (anti-windup).  The current
loop is integrated with ``substeps`` sub-steps per physics step (semi-implicit: the coil's resistive
term backward Euler, the controller explicit).

States (logged as ``act.<name><suffix>``): ``current_push``, ``current_pull``, ``current_ref_push``,
``current_ref_pull``, ``voltage_push``, ``voltage_pull`` and the produced ``force``.
"""
from __future__ import annotations

import math

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..kernels import optional
from ..registry import ACTUATORS
from .base import Actuator

P_COEFS = (0.197, -1.94, 26.34, -239.54)  # Eq. (6), N/A², ascending powers of x (m)

class ElectromagneticParams(Params):
    resistance: float = Field(0.2, gt=0, description="coil resistance R, Ω")
    inductance: float = Field(0.005, gt=0, description="coil inductance L, H")
    u_max: float = Field(48.0, gt=0, description="supply voltage limit ±u_max, V")
    i_max: float = Field(100.0, gt=0, description="current limit on the reference, A")
    bandwidth: float = Field(100.0, gt=0, description="Hz, current-loop poles (both) used for the default gains")
    Ti: float | None = Field(None, gt=0, description="s, integral time of Eq. (8) (default from bandwidth)")
    Ki: float | None = Field(None, ge=0, description="Ω, current feedback gain of Eq. (8) (default from bandwidth)")
    x0: float = Field(0.05, description="m, core position of both units at the static equilibrium")
    x_min: float = Field(0.0, description="m, fitted stroke of the force law")
    x_max: float = Field(0.1, description="m")
    push_pull: bool = Field(True, description="a push/pull pair (two-sided); false = one pulling unit only "
                                              "(negative forces)")
    substeps: int = Field(2, ge=1, description="current-loop sub-steps per physics step (2 at dt = 0.5 ms: "
                                               "h·ω = 0.16 for the 100 Hz loop)")


# ---------------------------------------------------------------------------------------------------------
# the law for one corner.
# p = [x0, x_min, x_max, push_pull?, i_max, substeps (ensemble max), u_max, K_i, 1/T_i, R, L]
# st = [i_push, i_pull, I_push, I_pull, u_push, u_pull, i_ref_push, i_ref_pull, F]
_PC_DESC = P_COEFS[::-1]  # highest power first


@numba.njit(cache=True)
def _kclip(x, lo, hi):
    """x clipped to [lo, hi] (NaN propagates)."""
    if x < lo:
        return lo
    if x > hi:
        return hi
    return x


@numba.njit(cache=True)
def _kmax(a, b):
    """max(a, b), NaN propagates."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a >= b else b


@numba.njit(cache=True)
def _kmin(a, b):
    """min(a, b), NaN propagates."""
    if a != a:
        return a
    if b != b:
        return b
    return a if a <= b else b


@numba.njit(cache=True)
def _kpoly(x):
    """p(x) of Eq. (6) by Horner's rule from 0."""
    y = 0.0
    for c in _PC_DESC:
        y = y * x + c
    return y


@numba.vectorize(["float64(float64)"], cache=True)
def p_of_x(x):
    """p(x) of Eq. (6), N/A², for x in m (an array or a number)."""
    return _kpoly(x)


@numba.njit(cache=True)
def _kgain(x):
    """max(p(x), 1e-6)."""
    return _kmax(_kpoly(x), 1e-6)


@numba.njit(cache=True)
def _kernel_force(cmd, s, v, t, dt, p, st):
    """The force of one corner: F = p(x_push)·i_push² − p(x_pull)·i_pull², x_push = x0 − s, x_pull = x0 + s
    clipped to the fitted stroke."""
    gp = _kgain(_kclip(p[0] - s, p[1], p[2]))
    gq = _kgain(_kclip(p[0] + s, p[1], p[2]))
    i0 = st[0]
    i1 = st[1]
    F = gp * (i0 * i0) - gq * (i1 * i1)
    st[8] = F
    return F


@numba.njit(cache=True)
def _kernel_advance(cmd, s, v, t, dt, p, st):
    """The state of one corner over dt: the current references i_r = sqrt(F/p(x)) (push unit for F > 0,
    pull unit for F < 0, at most i_max), then ``substeps`` sub-steps of each unit's PI current loop (Eq. 8,
    voltage saturation with anti-windup) and coil (resistive term backward Euler, i >= 0)."""
    gp = _kgain(_kclip(p[0] - s, p[1], p[2]))
    gq = _kgain(_kclip(p[0] + s, p[1], p[2]))
    push = _kmax(cmd, 0.0) if p[3] != 0.0 else 0.0
    pull = _kmax(-cmd, 0.0)
    st[6] = _kmin(math.sqrt(push / gp), p[4])
    st[7] = _kmin(math.sqrt(pull / gq), p[4])
    ns = int(p[5])
    h = dt / ns
    umax = p[6]
    Ki, gi, R, L = p[7], p[8], p[9], p[10]
    for _ in range(ns):
        for k in range(2):
            i = st[k]
            e = st[6 + k] - i
            u_raw = st[2 + k] - Ki * i
            u = _kmin(_kmax(u_raw, -umax), umax)
            hold = (u_raw > umax and e > 0) or (u_raw < -umax and e < 0)
            gate = 0.0 if hold else 1.0
            st[2 + k] = st[2 + k] + gate * (gi * h) * e
            st[k] = _kmax((i + (h / L) * u) / (1.0 + h * R / L), 0.0)
            st[4 + k] = u


@ACTUATORS.register("electromagnetic")
class ElectromagneticActuator(Actuator):
    """Toscano–Dumas reluctance actuator pair: F = p(x)·i² (Eq. 6), RL coils with PI current control (Eq. 8)."""

    Params = ElectromagneticParams
    command_unit = "N"

    kernel_force = staticmethod(_kernel_force)
    kernel_advance = staticmethod(_kernel_advance)

    def kernel_data(self):
        """(p, st) of the kernels; layout in the comment above ``_kernel_force``.  ``push_pull`` and
        ``substeps`` are ensemble-wide.  Default gains place both current-loop poles at 2π·bandwidth:
        1/T_i = L·ω², K_i = 2ωL − R."""
        p = self.p
        R, L = np.asarray(p.resistance, float), np.asarray(p.inductance, float)
        w = 2 * np.pi * np.asarray(p.bandwidth, float)
        Ti, Ki = optional(p.Ti), optional(p.Ki)  # NaN: not given (per car)
        inv_Ti = np.where(np.isnan(Ti), L * w ** 2, 1.0 / Ti)
        Ki = np.where(np.isnan(Ki), np.maximum(2 * w * L - R, 0.0), Ki)
        kp = self.pack(p.x0, p.x_min, p.x_max, float(bool(p.push_pull)), p.i_max, float(int(np.max(p.substeps))),
                       p.u_max, Ki, inv_Ti, R, L)
        return kp, self.pack(*([0.0] * 9))

    def kernel_states(self):
        return {"force": 8, "current_push": 0, "current_pull": 1, "current_ref_push": 6, "current_ref_pull": 7,
                "voltage_push": 4, "voltage_pull": 5}
