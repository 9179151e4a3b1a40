"""Passive suspension: the actuator is commanded to zero force."""
from __future__ import annotations

from suspension_sim.registry import CONTROLLERS

from .base import Controller


@CONTROLLERS.register("passive")
class Passive(Controller):
    """Passive: zero actuator command (the model's spring and damper act alone)."""

    def step(self, t, y):
        return self.zeros()
