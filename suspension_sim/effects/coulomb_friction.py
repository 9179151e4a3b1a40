"""Coulomb (dry) friction in the suspension: F = −F_c·sgn(v), with sticking."""
from __future__ import annotations

import warnings
from typing import Literal, Optional

import numba
import numpy as np
from pydantic import Field, model_validator

from ..components import Params
from ..registry import EFFECTS
from ._common import PerCornerNonNeg, PerCornerPos, corner_array, per_car, reduced_mass
from ..free_parameters import FreeParameter
from .base import Effect


class CoulombFrictionParams(Params):
    force: PerCornerNonNeg = Field(100.0, description="friction force level F_c in N (one value, or one per corner)")
    law: Optional[Literal["stick_slip", "tanh"]] = Field(
        None, description="stick_slip: exact sticking up to F_c (time-stepping); tanh: smooth "
        "F = −F_c·tanh(v/v_eps), creeps under loads below F_c. Default: tanh when v_eps is given, else stick_slip")
    v_eps: PerCornerPos = Field(0.01, description="tanh law only: regularisation velocity in m/s "
                                "(96 % of F_c at 2·v_eps)")
    step_force: Literal["start", "mean"] = Field(
        "start", description="the force applied over a physics step. start: the law at the rate at the start "
        "of the step (stick_slip: the time-stepping projection); mean: the law's mean over the step, the rate "
        "taken as linear through it and the friction force's own part of that rate solved implicitly (tanh: "
        "first order at a rate reversal inside the step becomes second order, no chatter at any v_eps; "
        "stick_slip: exact with the other forces held over the step, a reversal inside it slides each way for "
        "its part of the step, and the other forces include this step's actuator force)")

    @model_validator(mode="after")
    def _law(self):
        if self.law is None:
            self.law = "tanh" if "v_eps" in self.model_fields_set else "stick_slip"
        return self


@numba.njit(cache=True)
def _tanh_step_mean(Fc, w0, w1, g):
    """The tanh law's mean force over one step (``step_force: mean``): the F with
    ``F = −F_c·mean(tanh(w))`` over ``w`` linear from ``w0 = v/v_eps`` to ``w1 + g·F``, where ``w1`` is the
    end-of-step rate without friction (``(v + a_other·dt)/v_eps``) and ``g = dt/(m_r·v_eps)``.  The mean of
    tanh over a ramp is a difference of log cosh over the ramp's width.  The residual is increasing in F and
    changes sign on [−F_c, F_c]: Newton's method, kept inside the bracket by bisection."""
    if not Fc > 0.0:
        return 0.0
    # sliding: the ramp stays where tanh is 1 to double precision (tanh(19) = 1 − 6e-17) whatever F in
    # [−F_c, F_c] is (the end rate w1 + g·F lies within w1 ± g·F_c); most steps of a ride, at no cost
    if w0 > 19.0 and w1 - g * Fc > 19.0:
        return -Fc
    if w0 < -19.0 and w1 + g * Fc < -19.0:
        return Fc
    a0 = abs(w0)
    L0 = a0 + np.log1p(np.exp(-2.0 * a0))  # log cosh(w0) + log 2
    lo = -Fc
    hi = Fc
    F = -Fc * np.tanh(0.5 * (w0 + w1))
    for _ in range(60):
        w = w1 + g * F
        d = w - w0
        if abs(d) < 1e-6:  # a narrow ramp: the mean is tanh at its middle (error ~d²/24)
            m = np.tanh(0.5 * (w0 + w))
            dm = 0.5 * (1.0 - m * m)
        else:
            a = abs(w)
            e = np.exp(-2.0 * a)
            th = (1.0 - e) / (1.0 + e)
            m = (a + np.log1p(e) - L0) / d
            dm = ((th if w >= 0.0 else -th) - m) / d  # d(mean)/dw at the ramp's end
        r = F + Fc * m
        if r > 0.0:
            hi = F
        elif r < 0.0:
            lo = F
        else:
            return F
        Fn = F - r / (1.0 + Fc * dm * g)
        if abs(Fn - F) <= 1e-12 * Fc:
            return Fn
        if not (lo < Fn < hi):
            Fn = 0.5 * (lo + hi)
        F = Fn
    return F


@numba.njit(cache=True)
def _kernel(s, v, t, dt, p, st, fa):
    """The force of one corner; p = [F_c, m_r, v_eps, law (0 stick_slip, 1 tanh, 2 tanh with step_force
    mean, 3 stick_slip with step_force mean)], st = [F, v_prev, has v_prev (1/0; 2: and g_prev), stuck, fa_prev,
    g_prev]; ``fa`` the
    actuator force of this step on the corner.  The laws of the class docstring: ``F = −F_c·tanh(v/v_eps)``,
    its mean over the step (:func:`_tanh_step_mean`), the time-stepping
    ``F = clip(−m_r·(v/dt + a_other), −F_c, F_c)`` (``a_other`` from the previous step), or its exact mean
    over the step (``a_other`` extrapolated, with this step's actuator force; a reversal inside the step)."""
    Fc = p[0]
    a_other = 0.0
    if p[3] == 3.0:
        # the other forces but the actuator's: their mean over the last step, extrapolated linearly over one step
        # from the step before (second order; the base's acceleration changes within one step); plus the
        # actuator force of this step in place of the last step's (a control instant's jump)
        g = 0.0
        if st[2] != 0.0:
            g1 = (v - st[1]) / dt - (st[0] + st[4]) / p[1]
            g = 2.0 * g1 - st[5] if st[2] > 1.0 else g1
            st[5] = g1
        a_other = g + fa / p[1]
    elif p[3] != 1.0 and st[2] != 0.0:
        a_other = (v - st[1]) / dt - st[0] / p[1]
    stuck = False
    if p[3] == 1.0:
        F = -Fc * np.tanh(v / p[2])
    elif p[3] == 2.0:
        F = _tanh_step_mean(Fc, v / p[2], (v + a_other * dt) / p[2], dt / (p[1] * p[2]))
    else:
        x = -p[1] * (v / dt + a_other)
        lo = -Fc
        F = lo if x < lo else x  # min(max(x, lo), hi)
        F = Fc if F > Fc else F
        stuck = abs(F) < Fc * (1 - 1e-9)
        if p[3] == 3.0 and v != 0.0:
            # the other forces push against the sliding direction harder than the friction holds (|a| > F_c/m_r):
            # the rate reverses after tau and slides on the other way (the projection above, which applies one
            # sign or sticks over the whole step, is exact in every other case)
            b = Fc / p[1]
            av = a_other if v > 0.0 else -a_other
            if av < -b:
                tau = abs(v) / (b - av)
                if tau < dt:
                    F = (Fc if v > 0.0 else -Fc) * (1.0 - 2.0 * tau / dt)
                    stuck = False
    st[0] = F
    st[1] = v
    st[2] = 2.0 if (p[3] == 3.0 and st[2] != 0.0) else 1.0
    st[3] = 1.0 if (stuck if p[3] == 3.0 else abs(F) < Fc * (1 - 1e-9)) else 0.0
    st[4] = fa
    return F


@EFFECTS.register("coulomb_friction")
class CoulombFriction(Effect):
    """Dry (Coulomb) friction on the suspension: sticks while |F| ≤ F_c, F = −F_c·sgn(v) while slipping.

    Force law: ideal Coulomb friction, ``F = −F_c·sgn(v)`` for travel rate ``v ≠ 0`` and any
    ``|F| ≤ F_c`` that keeps ``v = 0`` (sticking); ``F_c`` in N (the thesis's ``F``: 1000 N on its 250 kg
    SDOF rig).  Positive F pushes the body up.  Two discretisations (``law``; when it is not given, giving
    ``v_eps`` selects ``tanh``, as the diagnose workflow's fitted models do, otherwise ``stick_slip``):

    - ``stick_slip`` (default), time-stepping in the manner of Moreau: each physics step applies the force
      that would bring the travel rate to zero by the end of the step, projected onto ``[−F_c, F_c]``::

          F_k = clip(−m_r·(v_k/dt + a_k), −F_c, F_c),   a_k = (v_k − v_{k−1})/dt − F_{k−1}/m_r

      where ``m_r`` is the effective mass along the suspension (``1/(J·M⁻¹·Jᵀ)`` from MuJoCo's mass matrix,
      ``1/(1/m_s + 1/m_u)`` for the quarter car; evaluated at the initial pose and nominal masses) and
      ``a_k`` the relative acceleration from all other forces, estimated from the previous step.  The suspension sticks for good
      under loads below F_c (no creep) and slips with exactly ±F_c otherwise.  Error is first order in dt
      at the stick/slip switches.  With ``step_force: mean`` the force is the exact law's mean over the step
      with the other forces held: the same projection, except that when the other forces push against the
      sliding direction harder than F_c the rate reverses inside the step at ``tau = |v|/(F_c/m_r + |a_k|)``
      and slides on, ``F = F_c·sgn(v)·(1 − 2·tau/dt)`` (the projection applies the new sign over the whole
      step: an impulse error up to 2·F_c·dt per reversal, always the same way); and ``a_k`` is this step's:
      ``a_k = 2·g_{k−1} − g_{k−2} + F_act,k/m_r``, ``g_{k−1} = (v_k − v_{k−1})/dt − (F_{k−1} + F_act,k−1)/m_r``
      the other forces but the actuator's over the last step, extrapolated over one step (a road's
      acceleration moves by more than F_c/m_r within a step), and the actuator force of this step (the effect
      reads it: ``reads_actuator_force``), so a command's jump at a control instant is not a step late.  On
      the thesis Ch. 4 dirt road these errors biased the MRAC's least-squares estimates with the step (its
      page: with RK4 and this law the band ratios and estimates change < 1.1 % from 0.125 to 0.016 ms).
    - ``tanh``: ``F = −F_c·tanh(v/v_eps)``: smooth, but a stiff damper ``F_c/v_eps`` near v = 0 instead of
      sticking, so under a net load ``P < F_c`` it creeps at ``v_eps·atanh(P/F_c)``.  Measured against exact
      stick-slip (tests/test_effects.py): < 1 % on a sliding-dominated ride, but 30–70 % trajectory error on
      a small-input ride where the exact model sticks 95 % of the time.  Stable while
      ``F_c/v_eps·dt/m_r ≲ 1`` (a warning names v_eps otherwise).  With ``step_force: mean`` the force over
      a step is the law's mean over it, the rate taken as linear through the step (its slope from the other
      forces estimated from the previous step as above, plus the friction force's own part, solved
      implicitly): a rate reversal inside the step gets the right impulse and a stiff law cannot chatter.
      Against a 1/32 ms reference (quarter car, F_c 180 N, 1 kHz road, v_eps 0.5–5 mm/s) the mean at a step
      h was as accurate as the start-of-step law at h/4 (body acceleration at 0.5 ms and v_eps 2 mm/s: 0.0072
      of its std against 0.0304; the start law at 0.125 ms: 0.0060).

    Why not MuJoCo's native friction: joint ``frictionloss`` does not apply (the suspension is a tendon
    between two slide joints).  Tendon ``frictionloss`` does apply (a soft constraint): with the stiffest
    ``solref`` (2·dt, 1) and a tight ``solimp`` it was about as accurate as ``stick_slip`` against exact
    stick-slip, but with MuJoCo's default solref (0.02 s) it creeps (20–45 % error when sticking), its
    softness is a solver setting rather than a physical parameter, and its force is a constraint force
    outside the plant's logged effect force, so the library keeps the law in the effect.

    Signature in measured data: a force step of 2·F_c at every travel-rate reversal (the residual force vs
    travel rate is a step through the origin, flat on each side); the suspension sticks on small inputs
    (dead band: the travel stays still until the road force exceeds F_c, so small-amplitude responses are
    stiff and pass the road input to the body), flat spots in the travel at reversals, harsh body
    acceleration on smooth roads, and energy loss per cycle proportional to amplitude (not amplitude²).
    """

    Params = CoulombFrictionParams
    # what `suspension-sim diagnose` may fit (suspension_sim/free_parameters.py)
    # (the smooth law with its v_eps fitted: a fit needs a force that is differentiable in its parameters;
    # its mean over the step: the coarse steps of a search stay accurate at rate reversals, see fit_step)
    free_parameters = {"force": FreeParameter("F", init=0.05),
                       "v_eps": FreeParameter("v", init=0.05, lo=0.01, hi=0.5, size=False)}
    fit_settings = {"law": "tanh", "step_force": "mean"}

    @staticmethod
    def fit_step(params: dict, mass: float) -> float | None:
        """The physics step the fitted law needs (diagnose: ``calibrate.Problem.step``), for the fitted
        ``params`` on a suspension whose lightest mass is ``mass``: the force is held over each step (error first
        order in it), and near zero rate the tanh law is a stiff damper F_c/v_eps, so the step keeps
        F_c/v_eps·dt/mass ≤ 0.2.  On the matrix's coulomb_friction seed 0 (F_c 143 N, truth tanh(v/2 mm/s),
        1 kHz) the true law itself leaves a held-out body-acceleration error of 0.0311 at the 0.5 ms step (that
        ratio 0.73), 0.0169 at 0.25 ms, 0.0070 at 0.125 ms (0.18) against sensor noise of 0.0222 (NRMSE): at
        0.5 ms the fit stopped at 0.0298.  The law's mean over the step (``step_force: mean``, what diagnose
        fits) is as accurate at 4× the step (class docstring): the ratio bound is 0.8 for it, so a law like
        the truth's runs at the record's 0.5 ms step, 4× faster than before."""
        F, ve = abs(float(params.get("force", 0.0))), float(params.get("v_eps", 0.0))
        if not (F > 0 and ve > 0 and mass > 0):
            return None
        return (0.8 if params.get("step_force") == "mean" else 0.2) * ve * mass / F
    signature = ("force step of 2·F_c at travel-rate reversal (residual vs velocity is a step through 0); "
                 "stick/dead band in travel on small inputs; flat spots at reversals")

    kernel = staticmethod(_kernel)
    # stick_slip with step_force mean estimates the other forces over the step with this step's actuator force
    reads_actuator_force = True

    def kernel_data(self):
        Fc = corner_array(self, "force")
        pairs = zip(per_car(self, "law"), per_car(self, "step_force"))
        code = np.array([(3.0 if sf == "mean" else 0.0) if lw != "tanh" else 2.0 if sf == "mean" else 1.0
                         for lw, sf in pairs]).reshape(-1, 1)  # per car
        tanh = code == 1.0  # the start-of-step tanh law (the mean over the step is implicit: no chatter)
        m_r = np.broadcast_to(reduced_mass(self.ctx), Fc.shape)
        v_eps = corner_array(self, "v_eps")
        dt = self.ctx.dt
        gain = np.where(tanh, Fc / v_eps * dt / m_r, 0.0)
        if np.any(gain > 1.0) and not getattr(self, "_warned", False):
            self._warned = True  # once per effect, not at every reset / run of a batch
            vmin = float(np.max(Fc * dt / m_r))
            warnings.warn(f"coulomb_friction: v_eps is small for dt={dt:g} s (F_c/v_eps·dt/m_red = "
                          f"{float(np.max(gain)):.2g} > 1): the friction force will chatter near zero travel "
                          f"rate; use v_eps >= {vmin:.2g} m/s or a smaller sim.dt", stacklevel=3)
        # st: F = 0 and stuck = 1 (|0| < F_c; 0 for F_c = 0) until the first step
        return self.pack(Fc, m_r, v_eps, code), self.pack(0.0, 0.0, 0.0, (0.0 < Fc * (1 - 1e-9)), 0.0, 0.0)

    def kernel_signals(self):
        """``force``: the friction force (N); ``stuck``: 1 while the friction holds below F_c."""
        return {"force": 0, "stuck": 3}
