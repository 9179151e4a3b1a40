"""Rounded step and rounded pulse (shock inputs of the thesis's excitation mode I).

Vallurupalli (1996, §2.2.1) lists "round pulse, oscillatory step and round step ... shock excitations as
used by Rakheja and Sankar" without formulas.  We use the classical shock-isolation forms (Snowdon's
rounded step and rounded pulse, as used in that literature), with u = (s − s0)/τ ≥ 0 and s = t or x::

    step:   z = h·[1 − (1 + u)·e^(−u)]          (0 → h, smooth: z, z' continuous; 50 % at u ≈ 1.68,
                                                 90 % at u ≈ 3.89)
    pulse:  z = h·(e/2)²·u²·e^(−u)               (0 → peak h at u = 2 → back to 0; area h·τ·e²/2)

Both are 0 before s0.  τ is ``time_constant`` (s, temporal) or ``length_constant`` (m, spatial); a smaller
τ is a more severe shock (the severity parameter of the literature is ν = 1/(ω_n τ)).  The formulas were
chosen here because the thesis gives none; the step's final level h stays, so the body settles at a new
level h above the start (positions are logged from the initial equilibrium).
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from ..components import Params
from ..registry import ROADS
from ._common import TrackSel, on_track
from .base import Road


class RoundStepParams(Params):
    height: float = Field(0.05, description="m, final level (step) or peak (pulse); negative = down")
    shape: Literal["step", "pulse"] = Field("step", description="rounded step or rounded pulse")
    time_constant: Optional[float] = Field(None, gt=0, description="s, τ of a temporal shape")
    length_constant: Optional[float] = Field(None, gt=0, description="m, τ of a spatial shape")
    start: float = Field(0.0, ge=0, description="s (temporal) or m along the road (spatial)")
    track: TrackSel = Field("both", description="both, left (track 0) or right (track 1)")

    @model_validator(mode="after")
    def _one(self):
        if (self.time_constant is None) == (self.length_constant is None):
            raise ValueError("give exactly one of time_constant (s) or length_constant (m)")
        return self


def rounded_step(u):
    u = np.maximum(np.asarray(u, dtype=float), 0.0)
    return 1.0 - (1.0 + u) * np.exp(-u)


def rounded_pulse(u):
    u = np.maximum(np.asarray(u, dtype=float), 0.0)
    return (np.e / 2.0) ** 2 * u * u * np.exp(-u)


@ROADS.register("round_step")
class RoundStep(Road):
    """Rounded step h[1 − (1 + u)e^−u] or rounded pulse h(e/2)²u²e^−u, u = (s − s0)/τ, in time or space."""

    Params = RoundStepParams

    def height(self, t, x, track=0):
        p = self.p
        spatial = p.length_constant is not None
        s = np.asarray(x if spatial else t, dtype=float)
        if not on_track(p.track, track):
            return np.zeros_like(s)
        tau = p.length_constant if spatial else p.time_constant
        u = (s - p.start) / tau
        f = rounded_step(u) if p.shape == "step" else rounded_pulse(u)
        return np.where(u >= 0, p.height * f, 0.0)

    def slopes(self, t, x, track=0):
        p = self.p
        spatial = p.length_constant is not None
        s = np.asarray(x if spatial else t, dtype=float)
        if not on_track(p.track, track):
            dz = np.zeros_like(s)
        else:
            tau = p.length_constant if spatial else p.time_constant
            u = np.maximum((s - p.start) / tau, 0.0)
            df = u * np.exp(-u) if p.shape == "step" else (np.e / 2.0) ** 2 * (2.0 * u - u * u) * np.exp(-u)
            dz = np.where(s >= p.start, p.height * df / tau, 0.0)
        return (np.zeros_like(dz), dz) if spatial else (dz, np.zeros_like(dz))
