"""Quadratic (orifice) damping on the suspension: F = −C_v·v·|v|."""
from __future__ import annotations

from typing import Literal

import numba
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array, step_mean_column
from ..free_parameters import FreeParameter
from .base import Effect


class QuadraticDampingParams(Params):
    c_v: PerCornerNonNeg = Field(250.0, description="velocity-squared damping coefficient C_v in N·s²/m² "
                                 "(one value, or one per corner)")
    step_force: Literal["start", "mean"] = Field(
        "start", description="the force applied over a physics step. start: the law at the rate at the start of "
        "the step (held over it: first order, an error c_v·|v|·a·dt); mean: the law's exact mean over the step "
        "with the rate taken as linear through it, its slope the last step's (second order)")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [c_v, step mean (1/0)], st = [v_prev, has v_prev (1/0)].  With the step mean,
    ``−c_v`` times the mean of ``w·|w|`` over ``w`` linear from ``v`` to ``v + a·dt``, ``a = (v − v_prev)/dt``
    the last step's mean acceleration along the suspension (zero at the first step)."""
    if p[1] == 0.0:
        return -p[0] * v * abs(v)
    w1 = 2.0 * v - st[0] if st[1] != 0.0 else v
    st[0] = v
    st[1] = 1.0
    if (v >= 0.0) == (w1 >= 0.0):  # one sign over the step: the mean of w² over a ramp, no cancellation
        m = (v * v + v * w1 + w1 * w1) / 3.0
        return -p[0] * (m if v + w1 >= 0.0 else -m)
    # a reversal inside the step: the mean of w·|w| is the difference of its antiderivative w²·|w|/3 (w1 ≠ v)
    return -p[0] * (w1 * w1 * abs(w1) - v * v * abs(v)) / (3.0 * (w1 - v))


@EFFECTS.register("quadratic_damping")
class QuadraticDamping(Effect):
    """Velocity-squared (orifice) damper on the suspension: F = −C_v·v·|v| (adds to the linear damper).

    Force law: ``F = −c_v · v · |v|`` with ``v`` the travel rate (m/s, positive = extension) and ``c_v`` in
    N·s²/m² (the thesis's orifice damper ``C_v``, 250 N·s²/m² for its SDOF rig); positive F pushes the body
    up.  It acts in addition to the vehicle's linear damper; set ``vehicle.params.damping: 0`` for a purely
    quadratic damper.

    The force is held over each physics step (``step_force: start``, the default: first order in the step, an
    impulse error ``c_v·|v|·a·dt²`` per step); ``step_force: mean`` holds the law's mean over the step with the rate
    taken as linear through it, at the last step's slope (second order).

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
        mean = step_mean_column(self)  # per car
        return self.pack(corner_array(self, "c_v"), mean), self.pack(0.0, 0.0)
