"""Shared pieces of the road library (not a road itself: modules starting with ``_`` are not registered).

- :func:`cosine_window`: the 0 → 1 half-cosine ramp used for fade-ins and tapers;
- :class:`PulseParams` / :class:`PulseRoad`: an isolated shape (bump, half-sine) given either spatially
  (``length`` in m, ``start`` in m along the road) or temporally (``duration`` in s, ``start`` in s of
  corner time), optionally repeated and restricted to one wheel track;
- :class:`GriddedProfile`: a profile sampled on a regular distance grid, evaluated by a cubic spline
  (used by the random roads and the measured profile), with a cosine fade-in from the start line.
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator
from scipy.interpolate import CubicSpline

from ..components import Params
from .base import Road


def cosine_window(s, length) -> np.ndarray:
    """0 for s ≤ 0, ½(1 − cos(π s/length)) for 0 < s < length, 1 beyond (a step if length = 0).  ``length``:
    a number, or an array of positive lengths broadcasting with ``s`` (several roads at once)."""
    s = np.asarray(s, dtype=float)
    if np.ndim(length) == 0 and length <= 0:
        return (s >= 0).astype(float)
    u = np.clip(s / length, 0.0, 1.0)
    return 0.5 * (1.0 - np.cos(np.pi * u))


def cosine_window_rate(s, length) -> np.ndarray:
    """d/ds of :func:`cosine_window`: ½(π/length)·sin(π s/length) for 0 < s < length, 0 elsewhere (a step's
    derivative, an impulse, is left out: 0 everywhere for length = 0); ``length`` as in :func:`cosine_window`."""
    s = np.asarray(s, dtype=float)
    if np.ndim(length) == 0 and length <= 0:
        return np.zeros_like(s)
    inside = (s > 0) & (s < length)
    return np.where(inside, 0.5 * np.pi / length * np.sin(np.pi * np.clip(s / length, 0.0, 1.0)), 0.0)


def edge_weight(s) -> np.ndarray:
    """1 for s > 0, 0 for s < 0 and ½ at s = 0: the weight of a one-sided derivative at a shape's edge, so that a
    rate sampled exactly on a kink (a road starting with a slope at t = 0) is the mean of the two one-sided
    derivatives, the limit of a central difference as the step goes to 0 (elsewhere the exact derivative)."""
    s = np.asarray(s, dtype=float)
    return np.where(s > 0, 1.0, np.where(s == 0, 0.5, 0.0))


TrackSel = Literal["both", "left", "right"]


def on_track(sel: str, track: int) -> bool:
    """Whether a deterministic input selected for ``sel`` acts on wheel track ``track`` (0 left, 1 right;
    one-track models only have track 0, which counts as both)."""
    return sel == "both" or (sel == "left" and track == 0) or (sel == "right" and track == 1)


class PulseParams(Params):
    """Parameters of an isolated shape given in space or in time."""

    height: float = Field(0.05, description="m, peak height (negative for a pothole/dip)")
    length: Optional[float] = Field(None, gt=0, description="m, length along the road (spatial shape)")
    duration: Optional[float] = Field(None, gt=0, description="s, duration in corner time (temporal shape)")
    start: float = Field(0.0, ge=0, description="m along the road (spatial) or s (temporal) where the "
                                                  "front wheel meets the shape")
    repeat: int = Field(1, ge=1, description="number of identical shapes in a row")
    period: Optional[float] = Field(None, gt=0, description="start-to-start spacing of repeated shapes, "
                                                            "m or s (default: twice the length/duration)")
    track: TrackSel = Field("both", description="wheel track(s) the shape lies on: both, left (track 0) "
                                                "or right (track 1)")

    @model_validator(mode="after")
    def _one_of(self):
        if (self.length is None) == (self.duration is None):
            raise ValueError("give exactly one of length (m, spatial) or duration (s, temporal)")
        span = self.length if self.length is not None else self.duration
        if self.period is not None and self.repeat > 1 and self.period < span:
            raise ValueError(f"period {self.period} is shorter than the shape ({span}): shapes would overlap")
        return self


class PulseRoad(Road):
    """Base of isolated shapes: subclasses implement :meth:`shape` on u ∈ [0, 1] (0 outside)."""

    Params = PulseParams

    @staticmethod
    def shape(u: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    @staticmethod
    def shape_rate(u: np.ndarray) -> np.ndarray:  # pragma: no cover - abstract
        """d shape/du on u ∈ [0, 1]."""
        raise NotImplementedError

    @property
    def spatial(self) -> bool:
        return self.p.length is not None

    def _sum(self, s, track, fn, edges=False):
        p = self.p
        s = np.asarray(s, dtype=float)
        if not on_track(p.track, track):
            return np.zeros_like(s), 1.0
        span = p.length if self.spatial else p.duration
        period = p.period if p.period is not None else 2.0 * span
        z = np.zeros_like(s)
        for i in range(p.repeat):
            u = (s - p.start - i * period) / span
            inside = edge_weight(u) * edge_weight(1.0 - u) if edges else ((u >= 0) & (u <= 1))
            z = z + np.where(inside > 0, inside * fn(np.clip(u, 0.0, 1.0)), 0.0)
        return z, span

    def height(self, t, x, track=0):
        return self.p.height * self._sum(x if self.spatial else t, track, self.shape)[0]

    def slopes(self, t, x, track=0):
        z, span = self._sum(x if self.spatial else t, track, self.shape_rate, edges=True)
        dz = self.p.height * z / span
        zero = np.zeros_like(dz)
        return (zero, dz) if self.spatial else (dz, zero)


class GriddedProfile:
    """A road profile sampled at ``x0 + k·dx`` and evaluated by a C² cubic spline.

    Outside the sampled range the end values are held (the random roads generate a margin beyond the
    distance the car covers, so this only matters for look-ahead sensors far beyond the run).
    ``fade_in`` (m) multiplies the profile by :func:`cosine_window` from the start line x = 0, so every
    wheel (the rear ones start at x = −wheelbase) stands on flat road at t = 0 and the run starts at the
    static equilibrium.
    """

    def __init__(self, x0: float, dx: float, z: np.ndarray, fade_in: float = 0.0):
        z = np.asarray(z, dtype=float)
        xs = x0 + dx * np.arange(z.size)
        self.x0, self.dx, self.x1 = float(x0), float(dx), float(xs[-1])
        self.xs, self.z, self.fade_in = xs, z, float(fade_in)  # z: the unfaded samples
        self._spline = CubicSpline(xs, z)

    def __call__(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        z = self._spline(np.clip(x, self.x0, self.x1))
        if self.fade_in > 0:  # applied after interpolation: exactly 0 behind the start line
            z = z * cosine_window(x, self.fade_in)
        return z

    def _faded_slope(self, x, z, dz):
        if self.fade_in > 0:
            return dz * cosine_window(x, self.fade_in) + z * cosine_window_rate(x, self.fade_in)
        return dz

    def slope(self, x) -> np.ndarray:
        """dz/dx (m/m) of :meth:`__call__`: the spline's analytic derivative (0 where the end values are held),
        with the fade-in's product rule."""
        x = np.asarray(x, dtype=float)
        xc = np.clip(x, self.x0, self.x1)
        dz = edge_weight(x - self.x0) * edge_weight(self.x1 - x) * self._spline(xc, 1)
        return self._faded_slope(x, self._spline(xc), dz)


class PeriodicProfile(GriddedProfile):
    """A periodic road profile: samples ``z`` at ``x0 + k·dx`` (k < N) of one period ``N·dx``, repeated
    beyond it (``z[N] = z[0]``), evaluated by a periodic C² cubic spline; ``fade_in`` as in
    :class:`GriddedProfile`.  A random road generated by an inverse FFT is periodic, so the repetition has
    no seam; long runs drive it to keep the road's memory bounded."""

    def __init__(self, x0: float, dx: float, z: np.ndarray, fade_in: float = 0.0):
        z = np.asarray(z, dtype=float)
        zp = np.concatenate([z, z[:1]])
        xs = x0 + dx * np.arange(zp.size)
        self.x0, self.dx, self.x1 = float(x0), float(dx), float(xs[-1])
        self.period = float(xs[-1] - x0)
        self.xs, self.z, self.fade_in = xs, z, float(fade_in)
        self._spline = CubicSpline(xs, zp, bc_type="periodic")

    def __call__(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        z = self._spline(self.x0 + np.mod(x - self.x0, self.period))
        if self.fade_in > 0:
            z = z * cosine_window(x, self.fade_in)
        return z

    def slope(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        xm = self.x0 + np.mod(x - self.x0, self.period)
        return self._faded_slope(x, self._spline(xm), self._spline(xm, 1))


#: a run whose random road is longer than this (m) drives a periodic road of this length (bounded memory)
MAX_LENGTH = 20_000.0


def generation_range(ctx, margin: float) -> tuple[float, float]:
    """Distance range [−wheelbase, distance + margin] a random road must cover for a run."""
    return -float(ctx.wheelbase), float(ctx.distance) + float(margin)


def tracks_mode(ctx) -> str:
    """``same`` or ``independent``: from the scenario's ``road.tracks`` (passed in the RoadContext)."""
    return getattr(ctx, "tracks", "same") or "same"
