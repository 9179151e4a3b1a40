"""Tire lift-off: the tire pushes but never pulls (total tire force ≥ 0)."""
from __future__ import annotations

import numba

from ..registry import EFFECTS
from ..free_parameters import FreeParameter
from .base import Effect


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [k_t, c_t, F_static], st = [lifted]."""
    pull = p[0] * s + p[1] * v - p[2]
    st[0] = 1.0 if pull > 0 else 0.0
    return pull if pull > 0.0 else 0.0  # np.maximum(0.0, pull)


@EFFECTS.register("tire_liftoff")
class TireLiftoff(Effect):
    """Unilateral tire contact: the total tire force (static load included) never becomes negative.

    Force law (target = tire): the linear tire gives the wheel ``F_lin = F_static − k_t·x − c_t·ẋ`` in total,
    with ``x`` = wheel − road from equilibrium (m), ``F_static`` the static tire load, ``k_t``/``c_t`` the
    tire stiffness and damping (from the vehicle parameters).  This effect adds the correction
    ``ΔF = max(0, −F_lin) = max(0, k_t·x + c_t·ẋ − F_static)`` (positive pushes the wheel up), so the total
    tire force is ``max(0, F_lin)``: the wheel leaves the road when the dynamic load would exceed the static
    load in tension, flies under gravity and the suspension force, and lands when the tire is compressed
    again.  Lift-off is decided on the force (with tire damping a fast-rebounding tire can lose load while
    still touching); with ``c_t = 0`` this is the geometric condition ``x > F_static/k_t``.  No parameters:
    it uses the vehicle's nominal tire stiffness, damping and static load (a time-varying tire stiffness or
    mass is not followed).

    Signature in measured data: the tire force is clipped at zero (dynamic tire load flat at −static load),
    the wheel acceleration sits near −g + F_susp/m_u during the flights, and landings give impacts in wheel
    and body acceleration; appears only on large inputs near the wheel-hop frequency (10–15 Hz) or on
    sharp bumps, and a linear model predicts negative (pulling) tire forces there.
    """

    target = "tire"
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {}
    signature = ("tire force clipped at zero total load (dynamic load flat at −static); wheel in free flight, "
                 "landing impacts; only on large inputs near wheel hop")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        ctx = self.ctx
        return self.pack(ctx.tire_stiffness, ctx.tire_damping, ctx.static_tire_force), self.pack(0.0)

    def kernel_signals(self):
        """``lifted``: 1 while the wheel is off the road."""
        return {"lifted": 0}
