"""Sinusoidal road or base excitation."""
from __future__ import annotations

import numpy as np
from pydantic import Field, model_validator

from ..components import Params
from ..registry import ROADS
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

    def height(self, t, x, track=0):
        p = self.p
        if p.frequency is not None:
            s = np.asarray(t, dtype=float) - p.start
            arg = 2 * np.pi * p.frequency * s + p.phase
        else:
            s = np.asarray(x, dtype=float) - p.start
            arg = 2 * np.pi * s / p.wavelength + p.phase
        z = p.amplitude * (np.sin(arg) - np.sin(p.phase))
        if p.fade_in > 0:
            w = np.clip(s / p.fade_in, 0, 1)
            z = z * 0.5 * (1 - np.cos(np.pi * w))
        return np.where(s >= 0, z, 0.0)
