"""Skyhook (Karnopp) control: a damper between the body and an inertial 'sky', plus an optional
groundhook term on the wheel.

    F = -c_sky * v_body - c_ground * v_wheel * (-1)   per corner,

i.e. F = -c_sky·ż_body + c_ground·ż_wheel with F positive pushing the body up and the wheel down, so the
groundhook term damps the wheel's absolute motion.  The model's passive damper stays in place (the
actuator acts in parallel).  Optionally limited to what a semi-active damper could do (``semi_active``:
the force is kept only when it opposes the travel rate, i.e. F·(ż_body − ż_wheel) <= 0).
"""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller


class SkyhookParams(Params):
    c_sky: float = Field(2500.0, ge=0, description="skyhook damping, N·s/m")
    c_ground: float = Field(0.0, ge=0, description="groundhook damping, N·s/m (needs wheel_vel)")
    semi_active: bool = Field(False, description="clip to dissipative forces (needs travel_rate)")


# kernel parameter row: c_sky, c_ground, groundhook on (1/0), semi-active on (1/0), offsets in y of
# corner_body_vel, wheel_vel, travel_rate (-1 when not used)
_P_CSKY, _P_CGROUND, _P_GROUND, _P_SEMI, _P_VB, _P_WV, _P_VR = range(7)


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """Compiled ``Skyhook.step`` for one car (same operations in the same order as the numpy law)."""
    c_sky = p[_P_CSKY]
    c_ground = p[_P_CGROUND]
    ground = p[_P_GROUND] != 0.0
    semi = p[_P_SEMI] != 0.0
    ovb = int(p[_P_VB])
    owv = int(p[_P_WV])
    ovr = int(p[_P_VR])
    for c in range(u.shape[0]):
        f = -c_sky * y[ovb + c]
        if ground:
            f = f + c_ground * y[owv + c]
        if semi:
            if not (f * y[ovr + c] <= 0):
                f = 0.0
        u[c] = f


@CONTROLLERS.register("skyhook")
class Skyhook(Controller):
    """Skyhook damper on the body above each corner (optional groundhook and semi-active clipping)."""

    Params = SkyhookParams

    @classmethod
    def required_sensors(cls, raw):
        req = ["corner_body_vel"]
        if float(raw.get("c_ground", 0) or 0) > 0:
            req.append("wheel_vel")
        if raw.get("semi_active"):
            req.append("travel_rate")
        return req

    kernel = staticmethod(_kernel)

    def _get(self, y, name):
        return y[name] if name in y else y[f"state.{name}"]

    def step(self, t, y):
        vb = self._get(y, "corner_body_vel")
        f = -self.p.c_sky * vb
        if np.any(self.p.c_ground > 0):
            f = f + self.p.c_ground * self._get(y, "wheel_vel")
        semi = self._semi()
        if np.any(semi):
            vr = self._get(y, "travel_rate")
            f = np.where(semi & ~(f * vr <= 0), 0.0, f)  # semi-active cars keep f only where f·vr <= 0
        return f

    def _semi(self):
        """(n_cars, 1) bools: the cars with semi-active clipping (the flag may differ across an ensemble)."""
        v = self.p.semi_active
        return np.asarray(v if isinstance(v, list) else [v] * self.ctx.n_cars, dtype=bool).reshape(-1, 1)

    def kernel_data(self):
        n = self.ctx.n_cars
        ground = bool(np.any(self.p.c_ground > 0))
        semi = self._semi()[:, 0]

        def offset(name, used):
            if not used:
                return -1.0
            try:
                return float(self.ctx.sensor_slice(name)[0])
            except KeyError:  # read from the full plant state (controller.full_state): not in the kernel's y
                raise NotImplementedError(f"skyhook kernel needs the declared sensor {name!r}") from None

        p = np.empty((n, 7))
        p[:, _P_CSKY] = np.broadcast_to(np.asarray(self.p.c_sky, dtype=float).reshape(-1), (n,))
        p[:, _P_CGROUND] = np.broadcast_to(np.asarray(self.p.c_ground, dtype=float).reshape(-1), (n,))
        p[:, _P_GROUND] = float(ground)
        p[:, _P_SEMI] = semi
        p[:, _P_VB] = offset("corner_body_vel", True)
        p[:, _P_WV] = offset("wheel_vel", ground)
        p[:, _P_VR] = offset("travel_rate", bool(np.any(semi)))
        return np.ascontiguousarray(p), np.zeros((n, 0))
