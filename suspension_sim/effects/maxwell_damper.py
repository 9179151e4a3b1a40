"""Maxwell damper: the car's linear damper mounted on a compliant bushing (damping that fades with frequency)."""
from __future__ import annotations

import math

import numba
from pydantic import Field

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, corner_array
from ..free_parameters import FreeParameter
from .base import Effect


class MaxwellDamperParams(Params):
    compliance: PerCornerNonNeg = Field(5e-6, description="compliance h = 1/k_b of the damper's mount in m/N "
                                        "(0 = a rigid mount: the plain damper; 5e-6 = a 200 kN/m bushing)")


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st):
    """The force of one corner; p = [c, h] (the car's linear damping, the mount's compliance), st = [R, the
    previous step's rate, has it (1/0)]; R is the force the damper resists with (same sign as v).

    Over a step the rate is taken at the step's middle, ``v_m = v + (v − v_prev)/2`` (extrapolated from the last
    two steps; the first step: v), and held: ``dR/dt = (v_m − R/c)/h`` is then solved exactly (relaxation time
    τ = c·h): ``R ← c·v_m + (R − c·v_m)·e^(−dt/τ)``, and the force applied over the step is ``c·v_m − R̄`` with R̄
    the exact mean of R over the step.  The car's own linear damper gives ``−c·v`` (the trapezoidal scheme: the
    mean of the step's start and end rates, i.e. v_m to second order), so the sum is −R̄ to second order in the
    step (taken at the step's start instead, the difference c·(v_m − v) acted as a mass c·dt/2 on the travel:
    1.2 % error at 8 Hz and dt 0.5 ms against 0.04 %).  h = 0 or c = 0: R = c·v_m, no force at all."""
    c = p[0]
    h = p[1]
    vm = v + 0.5 * (v - st[1]) if st[2] != 0.0 else v
    st[1] = v
    st[2] = 1.0
    cv = c * vm
    if h <= 0.0 or c <= 0.0:
        st[0] = cv
        return 0.0
    a = dt / (c * h)
    d = st[0] - cv
    mean = cv + d * (-math.expm1(-a)) / a
    st[0] = cv + d * math.exp(-a)
    return cv - mean


@EFFECTS.register("maxwell_damper")
class MaxwellDamper(Effect):
    """The car's linear damper in series with a spring ``k_b = 1/h`` (a rubber top mount or bushing): a Maxwell
    element.  It turns the vehicle's damper (``vehicle.params.damping`` c of its corners) into that element.

    Force law: the damper's force R (resisting, same sign as the travel rate ``v``; positive = extension)
    follows ``dR/dt = k_b·(v − R/c)``, i.e. the mount deflects by R/k_b and the damper sees the rest of the
    motion; the suspension force is ``−R`` (positive pushes the body up).  The effect applies ``c·v − R`` on
    top of the car's linear ``−c·v`` (v at the middle of each physics step: see the kernel).  Under a sine of
    angular frequency ω: ``|R/v| = c/√(1 + (ω·c/k_b)²)``, R lagging v by ``atan(ω·c/k_b)``: a damper below the corner frequency ``f_b = k_b/(2π·c)`` and a spring k_b above it.  ``compliance: 0``
    is the plain damper.  The state is advanced exactly for each step (v held over the step), so a stiff
    mount (``c/k_b`` below the time step) needs no smaller step.  c is the car's damping when the system is
    built (or, in ``suspension-sim diagnose``, the parameter set's damping).

    Signature in measured data: damping that fades with frequency: the wheel-hop resonance is less damped
    than a damper fitted to the body mode predicts (and the body mode more), the residual force against
    travel rate has a phase lag (an ellipse, not a line, at the wheel frequency); the damper force lags the
    travel rate by ``atan(ω·c/k_b)``.
    """

    Params = MaxwellDamperParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py): the compliance in units of
    # 1/c, i.e. the relaxation time τ = c·h in seconds (start 10 ms: a corner at 16 Hz; 0 = the plain damper)
    free_parameters = {"compliance": FreeParameter("1/max(c, 1e-9)", init=0.01, hi=1.0)}
    signature = ("damping fades with frequency: the wheel-hop mode is under-damped against a damper fitted to the "
                 "body mode; the damper force lags the travel rate (residual force vs rate is an ellipse at "
                 "high frequency)")

    kernel = staticmethod(_kernel)

    def kernel_data(self):
        return self.pack(self.ctx.damping, corner_array(self, "compliance")), self.pack(0.0, 0.0, 0.0)

    def kernel_signals(self):
        """``R``: the damper's force at the end of the step (N, resisting: same sign as the travel rate)."""
        return {"R": 0}

    @staticmethod
    def fitted_notes(params: dict, travel, ci95: dict | None = None) -> dict:
        """The fitted compliance as the mount's stiffness k_b = 1/h."""
        h = params.get("compliance")
        if h is None or h <= 0:
            return {}
        return {"compliance": f"mount stiffness k_b = 1/h = {1e-3 / h:.4g} kN/m"}
