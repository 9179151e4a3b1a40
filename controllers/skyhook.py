"""Skyhook (Karnopp) control: a damper between the body and an inertial 'sky', plus an optional
groundhook term on the wheel.

    F = -c_sky * v_body - c_ground * v_wheel * (-1)   per corner,

i.e. F = -c_sky·ż_body + c_ground·ż_wheel with F positive pushing the body up and the wheel down, so the
groundhook term damps the wheel's absolute motion.  The model's passive damper stays in place (the
actuator acts in parallel).  Optionally limited to what a semi-active damper could do (``semi_active``:
the force is kept only when it opposes the travel rate, i.e. F·(ż_body − ż_wheel) <= 0).
"""
from __future__ import annotations

import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller


class SkyhookParams(Params):
    c_sky: float = Field(2500.0, ge=0, description="skyhook damping, N·s/m")
    c_ground: float = Field(0.0, ge=0, description="groundhook damping, N·s/m (needs wheel_vel)")
    semi_active: bool = Field(False, description="clip to dissipative forces (needs travel_rate)")


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

    def _get(self, y, name):
        return y[name] if name in y else y[f"state.{name}"]

    def step(self, t, y):
        vb = self._get(y, "corner_body_vel")
        f = -self.p.c_sky * vb
        if np.any(self.p.c_ground > 0):
            f = f + self.p.c_ground * self._get(y, "wheel_vel")
        if self.p.semi_active:
            vr = self._get(y, "travel_rate")
            f = np.where(f * vr <= 0, f, 0.0)
        return f
