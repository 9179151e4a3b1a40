"""Swept sine (chirp) base/road input in time, built on :func:`scipy.signal.chirp`.

    z(t) = A·sin-chirp(t − t0; f0 → f1 over ``duration``)·w(t),   t0 ≤ t ≤ t0 + duration, 0 otherwise

``method``: linear, quadratic, logarithmic or hyperbolic frequency sweep (scipy's definitions; the
logarithmic and hyperbolic sweeps need f0, f1 > 0).  The phase starts at −90° of scipy's cosine, i.e. as a
sine, so z(t0) = 0; the envelope w is a cosine taper of ``taper`` seconds at both ends (default 10 % of the
duration, at most 1 s) so that the input starts and ends with zero height and slope.  For rig-style
frequency-response runs (a temporal input: the rear wheels of a half car get it after the front-to-rear
travel time).
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator
from scipy.signal import chirp

from ..components import Params
from ..registry import ROADS
from ._common import cosine_window
from .base import Road


class ChirpParams(Params):
    amplitude: float = Field(0.01, description="m")
    f0: float = Field(0.5, gt=0, description="Hz at the start of the sweep")
    f1: float = Field(20.0, gt=0, description="Hz at the end of the sweep")
    duration: float = Field(20.0, gt=0, description="s, sweep time")
    start: float = Field(0.0, ge=0, description="s")
    method: Literal["linear", "quadratic", "logarithmic", "hyperbolic"] = "linear"
    taper: Optional[float] = Field(None, ge=0, description="s, cosine taper at each end "
                                                            "(default min(0.1·duration, 1 s))")

    @model_validator(mode="after")
    def _taper(self):
        if self.taper is not None and 2 * self.taper > self.duration:
            raise ValueError(f"taper {self.taper} s is longer than half the duration ({self.duration} s)")
        return self


@ROADS.register("chirp")
class Chirp(Road):
    """Swept sine (scipy.signal.chirp: linear/quadratic/log/hyperbolic) from f0 to f1 Hz, tapered ends."""

    Params = ChirpParams

    def height(self, t, x, track=0):
        p = self.p
        s = np.asarray(t, dtype=float) - p.start
        taper = p.taper if p.taper is not None else min(0.1 * p.duration, 1.0)
        inside = (s >= 0) & (s <= p.duration)
        sc = np.clip(s, 0.0, p.duration)
        z = p.amplitude * chirp(sc, f0=p.f0, t1=p.duration, f1=p.f1, method=p.method, phi=-90.0)
        if taper > 0:
            z = z * cosine_window(sc, taper) * cosine_window(p.duration - sc, taper)
        return np.where(inside, z, 0.0)
