"""Backlash: a spring connected through free play (a play operator)."""
from __future__ import annotations

import numba
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class BacklashParams(Params):
    stiffness: PerCornerNonNeg = Field(5000.0, description="stiffness k_b of the spring behind the play in N/m")
    play: PerCornerNonNeg = Field(0.002, description="half-width b of the play in m (total free motion 2·b)")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [k_b, b], st = [y] (the driven side of the play)."""
    hi = s + p[1]
    y = hi if hi < st[0] else st[0]  # np.minimum(s + b, y)
    lo = s - p[1]
    y = lo if lo > y else y  # np.maximum(s - b, ...)
    st[0] = y
    return -p[0] * y


@EFFECTS.register("backlash")
class Backlash(Effect):
    """A spring ``k_b`` acting on the suspension through free play of ±b (e.g. a worn link or mount).

    Force law: the driven side of the play follows the travel ``s`` with a lag of ``b`` (play operator):
    ``y ← max(s − b, min(s + b, y))``, starting at ``y = 0``; the force is ``F = −k_b·y`` (positive pushes
    the body up).  After every reversal of travel the force holds still for ``2·b`` of travel (the play is
    taken up), then follows with stiffness ``k_b``.  Rate independent; evaluated exactly each step.

    Signature in measured data: the residual force plotted against travel is a parallelogram: flat for 2·b
    after each reversal, then rising with slope k_b; a dead band of free motion at every reversal (clunks in
    acceleration when the play closes), most visible on small inputs.
    """

    Params = BacklashParams
    static_law = False  # path dependent: no force at rest defined by the travel alone
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {"stiffness": FreeParameter("max(k, F/s)", init=0.2),
                       "play": FreeParameter("s", init=0.1, size=False)}
    signature = ("residual force vs travel is a parallelogram: flat for 2·b after each reversal, then slope k_b; "
                 "dead band (free motion) at reversals")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        return self.pack(corner_array(self, "stiffness"), corner_array(self, "play")), self.pack(0.0)

    def kernel_signals(self):
        """``y``: position of the driven side of the play (m)."""
        return {"y": 0}
