"""Sinusoidal road or base excitation."""
from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from ..components import Params
from ..registry import ROADS
from ._common import cosine_window, cosine_window_rate, edge_weight
from .base import Road


class SineParams(Params):
    amplitude: float = Field(0.01, description="m (half the peak-to-peak height)")
    frequency: float | None = Field(None, gt=0, description="temporal frequency in Hz (a rig input)")
    wavelength: float | None = Field(None, gt=0, description="spatial wavelength in m (a road at the set speed)")
    phase: float = Field(0.0, description="rad")
    start: float = Field(0.0, ge=0, description="start time (temporal) or distance (spatial)")
    fade_in: float = Field(0.0, ge=0, description="cosine fade-in length in s (temporal) or m (spatial)")

    @model_validator(mode="after")
    def _one(self):
        if (self.frequency is None) == (self.wavelength is None):
            raise ValueError("give exactly one of frequency (Hz) or wavelength (m)")
        return self


@ROADS.register("sine")
class Sine(Road):
    """Sine: z = A·sin(2π f (t − t0) + φ) (temporal, `frequency`) or A·sin(2π (x − x0)/λ + φ) (spatial)."""

    Params = SineParams

    def _law(self, t, x):
        p = self.p
        if p.frequency is not None:
            s, k = np.asarray(t, dtype=float) - p.start, 2 * np.pi * p.frequency
        else:
            s, k = np.asarray(x, dtype=float) - p.start, 2 * np.pi / p.wavelength
        arg = k * s + p.phase
        z = p.amplitude * (np.sin(arg) - np.sin(p.phase))
        dz = p.amplitude * k * np.cos(arg)
        if p.fade_in > 0:
            z, dz = z * cosine_window(s, p.fade_in), dz * cosine_window(s, p.fade_in) + z * cosine_window_rate(
                s, p.fade_in)
        return s, np.where(s >= 0, z, 0.0), edge_weight(s) * dz

    def height(self, t, x, track=0):
        return self._law(t, x)[1]

    def slopes(self, t, x, track=0):
        dz = self._law(t, x)[2]
        return (dz, np.zeros_like(dz)) if self.p.frequency is not None else (np.zeros_like(dz), dz)
