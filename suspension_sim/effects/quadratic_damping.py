"""Quadratic (orifice) damping on the suspension: F = −C_v·v·|v|."""
from __future__ import annotations

import numba
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class QuadraticDampingParams(Params):
    c_v: PerCornerNonNeg = Field(250.0, description="velocity-squared damping coefficient C_v in N·s²/m² "
                                 "(one value, or one per corner)")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [c_v]."""
    return -p[0] * v * abs(v)


@EFFECTS.register("quadratic_damping")
class QuadraticDamping(Effect):
    """Velocity-squared (orifice) damper on the suspension: F = −C_v·v·|v| (adds to the linear damper).

    Force law: ``F = −c_v · v · |v|`` with ``v`` the travel rate (m/s, positive = extension) and ``c_v`` in
    N·s²/m² (the thesis's orifice damper ``C_v``, 250 N·s²/m² for its SDOF rig); positive F pushes the body
    up.  It acts in addition to the vehicle's linear damper; set ``vehicle.params.damping: 0`` for a purely
    quadratic damper.

    Signature in measured data: the damping force grows with the square of the travel rate.  The residual
    force (measured − linear model) plotted against travel rate is an odd parabola through the origin, the
    same in compression and rebound.  A linear model fitted on small strokes under-damps large, fast ones
    (body and wheel resonance peaks shrink more than linearly with excitation level); on small inputs the
    effect nearly vanishes, so it is found only in records with large travel rates.
    """

    Params = QuadraticDampingParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {"c_v": FreeParameter("F/v**2", init=0.05)}
    signature = ("residual force vs travel rate is an odd parabola v|v| (same in compression and rebound); "
                 "extra damping grows with stroke speed, resonance peaks drop more than linearly with amplitude")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        return self.pack(corner_array(self, "c_v")), self.pack()
