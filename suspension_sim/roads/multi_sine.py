"""Sum of sines (the thesis's excitation mode I "combination of sines"), temporal or spatial.

    z(s) = Σ_i A_i·[sin(2π f_i (s − s0) + φ_i) − sin φ_i]·w(s − s0)     for s ≥ s0, 0 before,

with f_i in Hz (``frequencies``, s = corner time t) or 1/λ_i (``wavelengths`` in m, s = distance x).  The
constant Σ A_i sin φ_i is removed so the road is continuous (0) at the start; ``fade_in`` (s or m) adds a
cosine ramp w so that the slope is continuous too (w = 1 when fade_in = 0).  ``phases`` default to 0.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from pydantic import Field, model_validator

from ..components import Params
from ..registry import ROADS
from ._common import cosine_window, cosine_window_rate, edge_weight
from .base import Road


class MultiSineParams(Params):
    amplitudes: list[float] = Field(..., min_length=1, description="m, one per component")
    frequencies: Optional[list[float]] = Field(None, description="Hz (temporal input), one per component")
    wavelengths: Optional[list[float]] = Field(None, description="m (spatial input), one per component")
    phases: Optional[list[float]] = Field(None, description="rad, one per component (default 0)")
    start: float = Field(0.0, ge=0, description="s (temporal) or m (spatial)")
    fade_in: float = Field(0.0, ge=0, description="cosine fade-in length, s (temporal) or m (spatial)")

    @model_validator(mode="after")
    def _check(self):
        if (self.frequencies is None) == (self.wavelengths is None):
            raise ValueError("give exactly one of frequencies (Hz) or wavelengths (m)")
        vals = self.frequencies if self.frequencies is not None else self.wavelengths
        n = len(self.amplitudes)
        if len(vals) != n or (self.phases is not None and len(self.phases) != n):
            raise ValueError(f"amplitudes, {'frequencies' if self.frequencies is not None else 'wavelengths'} "
                             f"and phases must have the same length ({n})")
        if any(v <= 0 for v in vals):
            raise ValueError("frequencies/wavelengths must be > 0")
        return self


@ROADS.register("multi_sine")
class MultiSine(Road):
    """Sum of sines Σ A_i sin(2π f_i s + φ_i) (frequencies in Hz, or wavelengths in m), zero at the start."""

    Params = MultiSineParams

    def __init__(self, p, rng, ctx):
        super().__init__(p, rng, ctx)
        self.spatial = p.wavelengths is not None
        self.A = np.asarray(p.amplitudes, dtype=float)
        self.k = (1.0 / np.asarray(p.wavelengths, dtype=float)) if self.spatial else np.asarray(p.frequencies, float)
        self.phi = np.zeros_like(self.A) if p.phases is None else np.asarray(p.phases, dtype=float)

    def height(self, t, x, track=0):
        p = self.p
        s = np.asarray(x if self.spatial else t, dtype=float) - p.start
        arg = 2.0 * np.pi * s[..., None] * self.k + self.phi
        z = (np.sin(arg) - np.sin(self.phi)) @ self.A
        if p.fade_in > 0:
            z = z * cosine_window(s, p.fade_in)
        return np.where(s >= 0, z, 0.0)

    def slopes(self, t, x, track=0):
        p = self.p
        s = np.asarray(x if self.spatial else t, dtype=float) - p.start
        arg = 2.0 * np.pi * s[..., None] * self.k + self.phi
        dz = np.cos(arg) @ (2.0 * np.pi * self.k * self.A)
        if p.fade_in > 0:
            z = (np.sin(arg) - np.sin(self.phi)) @ self.A
            dz = dz * cosine_window(s, p.fade_in) + z * cosine_window_rate(s, p.fade_in)
        dz = edge_weight(s) * dz
        return (np.zeros_like(dz), dz) if self.spatial else (dz, np.zeros_like(dz))
