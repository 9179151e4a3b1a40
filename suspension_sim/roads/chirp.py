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
from ._common import cosine_window, cosine_window_rate, edge_weight
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

    def frequency(self, s):
        """Instantaneous frequency (Hz) of the sweep at time s after its start (scipy's laws)."""
        p = self.p
        T, f0, f1 = p.duration, p.f0, p.f1
        if p.method == "linear":
            return f0 + (f1 - f0) * s / T
        if p.method == "quadratic":
            return f0 + (f1 - f0) * (s / T) ** 2
        if p.method == "logarithmic":
            return f0 * (f1 / f0) ** (s / T)
        return f0 * f1 * T / ((f0 - f1) * s + f1 * T)  # hyperbolic

    def slopes(self, t, x, track=0):
        p = self.p
        s = np.asarray(t, dtype=float) - p.start
        taper = p.taper if p.taper is not None else min(0.1 * p.duration, 1.0)
        sc = np.clip(s, 0.0, p.duration)
        # z = A·sin ϕ(s) (scipy's cos(ϕ − 90°)), so dz/ds = A·cos ϕ(s)·2π f(s), cos ϕ being scipy's chirp at 0°
        dz = p.amplitude * chirp(sc, f0=p.f0, t1=p.duration, f1=p.f1, method=p.method, phi=0.0) \
            * 2.0 * np.pi * self.frequency(sc)
        if taper > 0:
            z = p.amplitude * chirp(sc, f0=p.f0, t1=p.duration, f1=p.f1, method=p.method, phi=-90.0)
            w0, w1 = cosine_window(sc, taper), cosine_window(p.duration - sc, taper)
            dz = dz * w0 * w1 + z * (cosine_window_rate(sc, taper) * w1 - w0 * cosine_window_rate(p.duration - sc, taper))
        dz = edge_weight(s) * edge_weight(p.duration - s) * dz
        return dz, np.zeros_like(dz)
