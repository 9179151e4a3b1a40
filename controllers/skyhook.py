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


# parameter row: c_sky, c_ground, groundhook on (1/0), semi-active on (1/0), starts in y of corner_body_vel,
# wheel_vel, travel_rate (-1 when no car of the ensemble uses it)
_P_CSKY, _P_CGROUND, _P_GROUND, _P_SEMI, _P_VB, _P_WV, _P_VR = range(7)


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: F = −c_sky·ż_body (+ c_ground·ż_wheel), clipped to F·(ż_body − ż_wheel) <= 0 when
    semi-active."""
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
            if not (f * y[ovr + c] <= 0):  # a NaN product clips too
                f = 0.0
        u[c] = f


@CONTROLLERS.register("skyhook")
class Skyhook(Controller):
    """Skyhook damper on the body above each corner (optional groundhook and semi-active clipping)."""

    Params = SkyhookParams
    kernel = staticmethod(_kernel)

    @classmethod
    def required_sensors(cls, raw):
        req = ["corner_body_vel"]
        if float(raw.get("c_ground", 0) or 0) > 0:
            req.append("wheel_vel")
        if raw.get("semi_active"):
            req.append("travel_rate")
        return req

    def kernel_data(self):
        n = self.ctx.n_cars
        col = self.per_car
        ground = col(self.p.c_ground) > 0
        semi = np.broadcast_to(np.asarray(self.p.semi_active, dtype=bool).reshape(-1), (n,))  # may differ per car
        p = np.empty((n, 7))
        p[:, _P_CSKY] = col(self.p.c_sky)
        p[:, _P_CGROUND] = col(self.p.c_ground)
        p[:, _P_GROUND] = ground
        p[:, _P_SEMI] = semi
        p[:, _P_VB] = self.ctx.reading_start("corner_body_vel")
        p[:, _P_WV] = self.ctx.reading_start("wheel_vel") if ground.any() else -1
        p[:, _P_VR] = self.ctx.reading_start("travel_rate") if semi.any() else -1
        return p, np.zeros((n, 0))
