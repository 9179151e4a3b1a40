"""Time-varying spring stiffness about the static equilibrium: F = −Δk(t)·s, Δk(t) = offset + A·sin(2πft + φ).

Changing ``vehicle.params.spring_stiffness`` through ``vehicle.variations`` changes a physical spring whose
free length stays fixed, so the static load it carries changes too (a softer spring sags: the force at
equilibrium moves by Δk·(static deflection), ≈ ±950 N for ±5000 N/m on a 290 kg quarter car).  Papers that
vary the stiffness in equations written about the equilibrium (Toscano & Dumas: k_M(t) = 15000 + 5000 sin 3t
in M·v̇ = f_k·Δx + …) mean the other thing: the stiffness of the deviation from equilibrium changes, the
static load stays carried.  This effect is that: added to the linear spring, the total stiffness about the
equilibrium is k + Δk(t) and the static sag is unchanged.
"""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerReal, corner_array
from .base import Effect


class VaryingStiffnessParams(Params):
    amplitude: PerCornerReal = Field(0.0, description="N/m, amplitude A of the sinusoidal stiffness change")
    frequency: float = Field(1.0, ge=0, description="Hz")
    phase: float = Field(0.0, description="rad")
    offset: PerCornerReal = Field(0.0, description="N/m, constant stiffness change")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [offset, A, 2πf, φ], st = [dk]."""
    dk = p[0] + p[1] * np.sin(p[2] * t + p[3])
    st[0] = dk
    return -dk * s


@EFFECTS.register("varying_stiffness")
class VaryingStiffness(Effect):
    """Stiffness change about the equilibrium, F = −(offset + A·sin(2πft + φ))·s (static load unchanged).

    Force law: ``F = −Δk(t)·s``, ``s`` = travel from static equilibrium, ``Δk(t) = offset + A sin(2πft + φ)``.

    Signature in measured data: the residual force against travel is a straight line through the origin whose
    slope oscillates in time (at f); the body resonance frequency is modulated; no change of ride height."""

    Params = VaryingStiffnessParams
    signature = "residual force ∝ travel with a slope that oscillates in time; ride height unchanged"

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        w = 2 * np.pi * np.asarray(self.p.frequency, dtype=float)
        p = self.pack(corner_array(self, "offset"), corner_array(self, "amplitude"), w, self.p.phase)
        return p, self.pack(0.0)

    def kernel_signals(self):
        """``dk``: the stiffness change Δk(t) (N/m)."""
        return {"dk": 0}
