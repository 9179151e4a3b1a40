"""Bouc–Wen hysteresis on the suspension: a rate-independent, saturating hysteretic force."""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, PerCornerPos, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class HysteresisParams(Params):
    force: PerCornerNonNeg = Field(100.0, description="saturation force F_h in N (one value, or one per corner)")
    x_y: PerCornerPos = Field(0.005, description="yield travel x_y in m: the element is stiff (F_h/x_y) after a "
                              "reversal and saturates at ±F_h after a few x_y of travel")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [F_h, x_y], st = [w, s_prev, has s_prev (1/0)].

    The state is updated exactly (n = 1, β = γ = ½) for the travel increment ds since the last step:
    dw/ds = (1 − |w|·(1 + sgn(ds·w))/2) / x_y, so while unloading (ds·w < 0) w moves linearly by ds/x_y until
    it crosses zero, and while loading (ds·w ≥ 0) w → sgn·(1 − (1 − |w|)·e^(−|ds|/x_y))."""
    if st[2] != 0.0:
        ds = s - st[1]
        sg = 1.0 if ds >= 0 else -1.0
        a = abs(ds) / p[1]
        u = sg * st[0]
        mu = -u
        mu = mu if mu > 0.0 else 0.0
        lin = a if a < mu else mu  # the linear (unloading) part of the increment
        u = u + lin
        a = a - lin
        if a > 0:
            u = 1.0 - (1.0 - u) * np.exp(-a)
        st[0] = sg * u
    st[1] = s
    st[2] = 1.0
    return -p[0] * st[0]


@EFFECTS.register("hysteresis")
class Hysteresis(Effect):
    """Bouc–Wen hysteresis on the suspension: F = −F_h·w with a dimensionless state w ∈ [−1, 1].

    Force law: ``dw/ds = (1 − |w|·(γ + β·sgn(ṡ·w)))/x_y`` with β = γ = ½ and exponent n = 1, driven by the
    travel ``s`` (m from equilibrium, positive = extension), and ``F = −F_h·w`` (positive pushes the body
    up).  After a reversal the element is stiff (``F_h/x_y``); as the travel continues the force saturates
    at ``∓F_h``.  It is rate independent: the loop depends on the travel path, not on its speed.  The state
    is advanced exactly for each step's travel increment (no step-size limit); w starts at 0.  For
    ``x_y → 0`` it tends to Coulomb friction of level F_h.

    Signature in measured data: the residual force plotted against travel forms a loop whose area per cycle
    does not depend on the travel rate (rate-independent energy loss, e.g. bushing or leaf-spring
    inter-leaf friction), with rounded corners of width ~x_y after each reversal; unlike Coulomb friction
    the force does not switch with the sign of the velocity at once.
    """

    Params = HysteresisParams
    static_law = False  # path dependent: no force at rest defined by the travel alone
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    free_parameters = {"force": FreeParameter("F", init=0.05),
                       "x_y": FreeParameter("s", init=0.2, lo=1e-3, size=False)}
    signature = ("residual force vs travel forms a rate-independent loop with rounded corners (width ~x_y) "
                 "after reversals; loop area independent of travel rate")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        return self.pack(corner_array(self, "force"), corner_array(self, "x_y")), self.pack(0.0, 0.0, 0.0)

    def kernel_signals(self):
        """``w``: the Bouc–Wen state (−1 … 1)."""
        return {"w": 0}
