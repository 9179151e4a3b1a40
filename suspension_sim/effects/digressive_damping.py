"""Digressive (blow-off) damping: the car's damper rate c up to a knee rate, a lower rate r·c beyond it."""
from __future__ import annotations

from typing import Annotated, Literal, Union

import numba
from pydantic import Field

from ..components import Params
from ..free_parameters import FreeParameter
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array, step_mean_column
from .base import Effect

Share = Annotated[float, Field(ge=0, le=1)]
KNEE_MIN = 0.1  # the smallest fitted knee, × the record's RMS travel rate (see free_parameters)
PerCornerShare = Union[Share, list[Share]]


class DigressiveDampingParams(Params):
    v_knee_comp: PerCornerNonNeg = Field(0.3, description="knee rate in compression in m/s (travel rate < 0): the "
                                         "blow-off valve opens beyond it")
    v_knee_reb: PerCornerNonNeg = Field(0.3, description="knee rate in rebound (extension) in m/s (travel rate > 0)")
    drop_comp: PerCornerShare = Field(0.6, description="the share of the damper's rate c the valve relieves beyond "
                                      "the compression knee, 0–1: the rate there is (1 − drop)·c, i.e. the post-knee "
                                      "ratio r = 1 − drop (0: no blow-off, the plain damper; 1: a constant force)")
    drop_reb: PerCornerShare = Field(0.6, description="the same beyond the rebound knee")
    step_force: Literal["start", "mean"] = Field(
        "start", description="the force applied over a physics step. start: the law at the rate at the start of "
        "the step (first order); mean: the law's exact mean over the step with the rate taken as linear through "
        "it, its slope the last step's (second order, as the car's own trapezoidal damper)")


@numba.njit(cache=True)
def _relief(w, c, vkc, vkr, dc, dr):
    """The effect's force at rate ``w`` (N, + pushes the body up): ``drop·c·(|w| − v_k)·sgn(w)`` beyond the knee
    of w's side, 0 inside the knees."""
    if w > vkr:
        return dr * c * (w - vkr)
    if w < -vkc:
        return dc * c * (w + vkc)
    return 0.0


@numba.njit(cache=True)
def _relief_integral(w, c, vkc, vkr, dc, dr):
    """An antiderivative of :func:`_relief` in w (zero between the knees)."""
    if w > vkr:
        return 0.5 * dr * c * (w - vkr) ** 2
    if w < -vkc:
        return 0.5 * dc * c * (w + vkc) ** 2
    return 0.0


@numba.njit(cache=True)
def _piece(w, vkc, vkr):
    return 1 if w > vkr else (-1 if w < -vkc else 0)


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [c, v_knee_comp, v_knee_reb, drop_comp, drop_reb, step mean (1/0)] (c the
    car's linear damping of the corner), st = [v_prev, has v_prev (1/0)].  The car's own linear damper gives
    ``−c·v``; this adds ``drop·c·(|v| − v_k)·sgn(v)`` beyond the knee of v's side, so the sum is the digressive
    law.  With the step mean: the exact mean of that over ``w`` linear from ``v`` to ``v + a·dt``,
    ``a = (v − v_prev)/dt`` the last step's mean acceleration along the suspension (zero at the first step)."""
    c, vkc, vkr, dc, dr = p[0], p[1], p[2], p[3], p[4]
    if p[5] == 0.0:
        return _relief(v, c, vkc, vkr, dc, dr)
    w1 = 2.0 * v - st[0] if st[1] != 0.0 else v
    st[0] = v
    st[1] = 1.0
    if _piece(v, vkc, vkr) == _piece(w1, vkc, vkr):  # one linear piece over the step: the law at its middle
        return _relief(0.5 * (v + w1), c, vkc, vkr, dc, dr)
    # a knee inside the step (w1 ≠ v): the difference of the antiderivative over the step's rates
    return (_relief_integral(w1, c, vkc, vkr, dc, dr) - _relief_integral(v, c, vkc, vkr, dc, dr)) / (w1 - v)


@EFFECTS.register("digressive_damping")
class DigressiveDamping(Effect):
    """A digressive damper: the car's damper with a blow-off valve that opens above a knee rate (one knee and
    one relief per side: bump and rebound valves usually differ).

    Force law (travel rate ``v``, m/s, positive = extension/rebound; positive F pushes the body up), with c the
    car's linear damping of the corner (``vehicle.params.damping``; in ``suspension-sim diagnose`` the parameter
    set's own), ``v_k`` and ``r = 1 − drop`` those of v's side:

    - ``|v| ≤ v_k``: ``F = −c·v`` (the plain damper);
    - ``|v| > v_k``: ``F = −(c·v_k + r·c·(|v| − v_k))·sgn(v)``: the rate drops from c to ``r·c``.

    The force is continuous and its slope jumps at the knee (an exact knee, as a damper map's corner or the
    truth laws of the blind battery state it): a smooth knee would need a width, a parameter the data rarely
    fix, and would bias the fitted knee; a kink in the slope is no stiffness (the force is held over a physics
    step like any other effect, and ``step_force: mean`` integrates the knee exactly).  The effect applies
    ``drop·c·(|v| − v_k)·sgn(v)`` on top of the car's ``−c·v``: with ``drop`` 0 it does nothing.

    Signature in measured data: the residual force against travel rate is zero between the knees and a straight
    line of slope ``drop·c`` (opposite to the damper's) beyond them: large, fast strokes are less damped than a
    linear damper fitted to small ones, so a linear model over-damps them (resonance peaks higher with
    excitation level), the opposite of quadratic damping.
    """

    Params = DigressiveDampingParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py).  c is the car's damping (free
    # or stated, as the model says): below the knees the record sees c alone, beyond them (1 − drop)·c, so the
    # three are identifiable when the rates cross the knees.  Each knee starts at the record's RMS travel rate
    # (a valve that opens within the rates the record holds), the relief at half the rate; a knee the fitted
    # window never crosses goes to 10× the RMS rate (``unseen``: no valve opening on that side).  A knee is kept
    # at 0.1× the RMS rate or above (about 8 % of a Gaussian record's rates below it): at zero it is no knee, the
    # damper is one linear rate per side, i.e. asymmetric_damping, which the library already holds with one
    # parameter (with knees free down to 0 this candidate was asymmetric_damping with the step mean and took its
    # place on the blind battery's asym_sedan_iso: knee 0 in compression, damping at the rebound rate)
    free_parameters = {"v_knee_comp": FreeParameter("v", init=1.0, lo=KNEE_MIN, size=False, unseen=10.0),
                       "v_knee_reb": FreeParameter("v", init=1.0, lo=KNEE_MIN, size=False, unseen=10.0),
                       "drop_comp": FreeParameter("1", init=0.5, lo=0.0, hi=1.0),
                       "drop_reb": FreeParameter("1", init=0.5, lo=0.0, hi=1.0)}
    # the law's mean over each step: the car's linear damper is trapezoidal (second order), the relief then is too
    fit_settings = {"step_force": "mean"}
    signature = ("residual force vs travel rate is zero between two knee rates and a line beyond them, opposite "
                 "to the damper's (less damping at high rates); large strokes less damped than small ones")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        p = self.pack(self.ctx.damping, corner_array(self, "v_knee_comp"), corner_array(self, "v_knee_reb"),
                      corner_array(self, "drop_comp"), corner_array(self, "drop_reb"), step_mean_column(self))
        return p, self.pack(0.0, 0.0)

    @staticmethod
    def fitted_notes(params: dict, travel, ci95: dict | None = None) -> dict:
        """Each side's relief as the post-knee ratio r = 1 − drop."""
        out = {}
        for side in ("comp", "reb"):
            d = params.get(f"drop_{side}")
            if d is not None:
                out[f"drop_{side}"] = f"post-knee ratio r = 1 − drop = {1.0 - float(d):.4g}"
        return out
