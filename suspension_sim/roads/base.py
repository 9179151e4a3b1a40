"""Road interface.

A road gives the height (m, z up) under a wheel.  The simulation calls :meth:`Road.height` with, for each
corner, the *corner time* ``t`` (the time at which the front axle was where this wheel is now, so temporal
inputs reach the rear wheels later) and the *corner distance* ``x`` travelled along the road (m).  Spatial
roads (bumps given by a length, ISO 8608, measured profiles) use ``x``; temporal inputs (a sine in Hz, a
bump given by a duration, rig signals) use ``t``.  ``track`` is 0 for the left (or only) wheel track and 1
for the right one.

One Road object serves one car (each car of an ensemble has its own, seeded) and is vectorised over the
sample arrays.  Construction receives the validated params, a ``numpy.random.Generator`` and a
:class:`RoadContext` (duration, maximum distance, speed) so random roads can pre-generate their profile.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..components import NoParams


@dataclass
class RoadContext:
    duration: float  # s
    distance: float  # m travelled by the front axle over the run
    wheelbase: float  # m, front-to-rear extent (0 for one-corner models)
    mean_speed: float  # m/s
    dt: float  # physics step (s)
    n_tracks: int = 1
    tracks: str = "same"  # scenario road.tracks: left/right tracks 'same' or 'independent' (random roads)


class Road:
    """Base class. Subclasses set ``Params`` and implement :meth:`height`."""

    name = "road"
    Params = NoParams

    def __init__(self, p, rng: np.random.Generator, ctx: RoadContext):
        self.p = p
        self.rng = rng
        self.ctx = ctx

    def height(self, t: np.ndarray, x: np.ndarray, track: int = 0) -> np.ndarray:
        raise NotImplementedError

    def velocity(self, t: np.ndarray, x: np.ndarray, track: int, dt: float) -> np.ndarray:
        """Road height rate dz/dt along the samples (default: central differences of :meth:`height` in
        time, valid for samples taken every ``dt``)."""
        z = self.height(t, x, track)
        if z.size < 2:
            return np.zeros_like(z)
        return np.gradient(z, dt)
