"""Flat road (no excitation): for force-input runs and manoeuvres."""
from ..registry import ROADS
from .base import Road
import numpy as np


@ROADS.register("flat")
class Flat(Road):
    """Flat road: zero height everywhere (use with force inputs or manoeuvres)."""

    def height(self, t, x, track=0):
        return np.zeros_like(np.asarray(t, dtype=float))

    def slopes(self, t, x, track=0):
        z = self.height(t, x, track)
        return z, z.copy()
