"""Cubic (hardening or softening) suspension stiffness: F = −k3·s³."""
from __future__ import annotations

import numba
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerReal, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class CubicStiffnessParams(Params):
    k3: PerCornerReal = Field(1.0e6, description="cubic stiffness in N/m³ (> 0 hardening, < 0 softening; "
                              "one value, or one per corner)")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [k3]."""
    return -p[0] * s ** 3.0


@EFFECTS.register("cubic_stiffness")
class CubicStiffness(Effect):
    """Cubic spring on the suspension: F = −k3·s³ (hardening for k3 > 0), added to the linear spring.

    Force law: ``F = −k3 · s³`` with ``s`` the travel from static equilibrium (m, positive = extension) and
    ``k3`` in N/m³; positive F pushes the body up.  The cubic term is measured from the static equilibrium,
    so the static sag is unchanged.  A softening spring (k3 < 0) loses stiffness at large travel and can
    snap through (|s| > sqrt(k/|k3|)): keep strokes below that.

    Signature in measured data: stiffness that depends on amplitude.  The residual force plotted against
    travel is an odd cubic (zero slope at the origin); the resonance frequency moves with the excitation
    level (up for hardening: a Duffing oscillator, e.g. the Silverbox benchmark), the frequency response
    bends and can jump, and sine inputs produce odd harmonics (3f) in the response.
    """

    Params = CubicStiffnessParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {"k3": FreeParameter("F/s**3", init=0.0, lo=None)}
    signature = ("residual force vs travel is an odd cubic s³; resonance frequency shifts with amplitude "
                 "(Duffing), odd harmonics 3f under sine input")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        return self.pack(corner_array(self, "k3")), self.pack()
