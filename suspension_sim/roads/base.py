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
    """Base class. Subclasses set ``Params`` and implement :meth:`height` and its derivative :meth:`slopes`."""

    name = "road"
    Params = NoParams

    def __init__(self, p, rng: np.random.Generator, ctx: RoadContext):
        self.p = p
        self.rng = rng
        self.ctx = ctx

    def height(self, t: np.ndarray, x: np.ndarray, track: int = 0) -> np.ndarray:
        raise NotImplementedError

    def slopes(self, t: np.ndarray, x: np.ndarray, track: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Partial derivatives (∂z/∂t in m/s, ∂z/∂x in m/m) of :meth:`height` at the samples: the road's own
        derivative law, which :meth:`rate` combines with the wheel's motion.  Every registered road gives
        its exact derivative; this default (for a road that does not) is a fine central difference."""
        t = np.asarray(t, dtype=float)
        x = np.asarray(x, dtype=float)
        h = 1e-6
        zt = (self.height(t + h, x, track) - self.height(t - h, x, track)) / (2 * h)
        zx = (self.height(t, x + h, track) - self.height(t, x - h, track)) / (2 * h)
        return zt, zx

    def rate(self, t: np.ndarray, x: np.ndarray, track: int, t_rate, x_rate) -> np.ndarray:
        """Road height rate dz/dt (m/s) under a wheel whose corner time advances at ``t_rate`` (s/s) and
        whose distance at ``x_rate`` (m/s): ∂z/∂t·ṫ + ∂z/∂x·ẋ, the exact time derivative of the height the
        wheel sees (both loops read it through :meth:`System.road_chunk`)."""
        zt, zx = self.slopes(t, x, track)
        return zt * t_rate + zx * x_rate

    def height_slopes(self, t: np.ndarray, x: np.ndarray, track: int = 0):
        """(:meth:`height`, ∂z/∂t, ∂z/∂x) at the same samples, the same numbers as :meth:`height` and
        :meth:`slopes`: the loops need both for every wheel and chunk, and a road whose height and slopes
        share work (one evaluation of a closed form, one spline lookup) overrides this to do it once."""
        zt, zx = self.slopes(t, x, track)
        return self.height(t, x, track), zt, zx

    @classmethod
    def height_slopes_many(cls, roads: list, t: np.ndarray, x: np.ndarray, track: int = 0,
                           grid: "StepGrid | None" = None):
        """:meth:`height_slopes` of several roads of this class on the same samples ``t``, ``x`` (1-D): three
        arrays ``(len(roads), samples)``, row k the numbers of ``roads[k]`` alone.  This default evaluates the
        roads one by one; a closed-form road evaluates them together, its parameters as columns (an
        ensemble's cars differ in amplitude or frequency, not in the law).  ``grid``: when the samples are
        consecutive physics steps at a constant speed, where they lie on the run's step grid (a road may use
        it for a recurrence along the steps; this default ignores it)."""
        shape = (len(roads), np.broadcast(np.asarray(t), np.asarray(x)).size)
        out = tuple(np.empty(shape) for _ in range(3))
        for k, road in enumerate(roads):
            for a, v in zip(out, road.height_slopes(t, x, track)):
                a[k] = v
        return out


#: physics steps between the exact anchors of a recurrence along a :class:`StepGrid` (a sine's rotation
#: rounds by ~2 ulp of the amplitude per step: ~1e-14 relative at most)
ANCHOR = 64


@dataclass(frozen=True)
class StepGrid:
    """The samples of :meth:`Road.height_slopes_many` as physics steps g0, g0 + 1, ... of a uniform grid (a
    constant speed): corner time advances by ``dt`` and distance by ``dx`` per step; ``t_anchor`` and
    ``x_anchor`` are the corner time and distance (the same functions of the step as the samples) at the
    steps M·i from M·floor(g0/M) up to the last sample (M = :data:`ANCHOR`)."""

    g0: int
    dt: float
    dx: float
    t_anchor: np.ndarray
    x_anchor: np.ndarray
    M: int = ANCHOR
