"""Passive suspension: the actuator is commanded to zero force."""
from __future__ import annotations

import numba
import numpy as np

from suspension_sim.registry import CONTROLLERS

from .base import Controller


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: zero command on every corner."""
    for c in range(u.shape[0]):
        u[c] = 0.0


@CONTROLLERS.register("passive")
class Passive(Controller):
    """Passive: zero actuator command (the model's spring and damper act alone)."""

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        n = self.ctx.n_cars
        return np.zeros((n, 0)), np.zeros((n, 0))
