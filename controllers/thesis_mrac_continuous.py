"""Thesis Ch. 3: continuous-time direct MRAC of the SDOF fail-safe suspension (Vallurupalli 1996).

Plant (Eq. 3.1, model ``sdof``): M ẍ + C(ẋ − ẇ) + K(x − w) + Mg − Kδ_st − F_act = 0, written (Eq. 3.3–3.4)
as M ẍ + C ẋ + K x = F_cont with F_cont = F_act + C ẇ + K w − M g + K δ_st.  Design model
G(s) = b0/A(s), A = s² + 2ζ_pω_p s + ω_p², b0 = 1/M.  Skyhook reference model (Eq. 3.7):
M_m ẍ_m + D_m ẋ_m + K_m (x_m − w) = 0, G_m = ω_m²/A_m(s).

Regulator (Åström–Wittenmark pole placement, Eqs. 3.11–3.20): R F_cont = T w − S x, R = s + r1,
S = s0 s + s1, T = t0 s + t1, observer A0 = s + a0, from A R + b0 S = A0 A_m and T = A0 B_m/b0:
r1 = a0 + 2ζ_mω_m − 2ζ_pω_p, s0 = (ω_m² + 2a0ζ_mω_m − ω_p² − 2r1ζ_pω_p)/b0, s1 = (a0ω_m² − r1ω_p²)/b0,
t0 = ω_m²/b0, t1 = a0ω_m²/b0 ([RECON]: the OCR prints t1 = a0ω_m/b0; T = A0·ω_m²/b0 gives a0ω_m²/b0).

Error model and adaptation (Eqs. 3.23–3.35): with P = P1·P2, P1 = A_m, P2 = A0 (so Q = A0 A_m = P and
the filtered error is e itself), regressor φ = (F/P, s·x/P, x/P, −s·w/P, −w/P) and parameters
Θ = (r1 − a0, s0, s1, t0, t1) (the first entry multiplies F/P: R = P2 + (r1 − a0)), control
F_cont = −Θᵀ(P1 φ), error augmentation η = −(F/P1 + φᵀΘ), augmented error ε = e + b̂0 η + K_v ė
(the thesis's velocity term; K_v in s), normalised gradient law dΘ/dt = Γφε/(α + φᵀΓφ), and the
gradient estimate of b0 (Eq. 3.35, partly garbled; read as db̂0/dt = −γ_b η ε̂/(α_b + η²) with the
prediction error ε̂ = e + b̂0 η).  The filters run at the control step by zero-order hold (the thesis
integrates them "by simple trapezoidal integration" at 0.01 s).

Static level — an addition the thesis does not spell out.  After a load step the term −ΔM·g enters
F_cont as a constant disturbance d; the regulator structure has no constant term, and the thesis
obtains its "mean upward force of 1500 N" through the estimated M* in Eq. 3.6 without giving the law.
We add one parameter θ_d with regressor 1/P (the filtered constant 1): R(F + d) = R F + r1·d exactly for
a constant d, so the error model stays linear in parameters and θ_d converges to r1·d; the actuator then
carries the extra static load, F_act → ΔM·g.  ``static_level: false`` removes it (pure thesis structure).
θ_d has its own normalised law (gain ``gamma_d``), the other five share the normalised gradient law.

Filter choice — also ours when ``p1`` is set: the thesis takes P1 = A_m; for D_m = 6000 N·s/m, A_m has a
slow pole at −0.86 rad/s, so the filtered regressors (and θ_d) see a load step only after seconds, and the
body first drops ≈ 1 m.  The theory allows any stable monic P1 of degree 2 (the error model keeps
b0·Q/(A0·A_m) = b0 with Q = A0·A_m; the filtered error becomes e_f = (Q/P)·e); ``p1`` sets P1 = (s + p1)².

Gains not given by the thesis (γ, α, K_v, γ_b) are parameters; the scenario files give and justify them.
Initial Θ: the nominal design values from M*, C*, K* (the thesis: "good adaptation with the approximation
of M*, C*, K* as the initial design values"), or ``theta0`` explicitly.

Sensors: ``body_pos`` (x from the static equilibrium), ``body_vel`` (ẋ, for the velocity error), ``road``
(w) and ``road_vel`` (ẇ) — the base of the rig.  Signals: ``theta.k``, ``b0``, ``ref_x``, ``ref_acc``,
``ref_travel``, ``err``.
"""
from __future__ import annotations

from typing import Optional

import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from .thesis_common import FilterBank, _f


class MRACContinuousParams(Params):
    mass: float = Field(250.0, gt=0, description="nominal M* (kg): initial b0 = 1/M*, and Eq. 3.6")
    stiffness: float = Field(5000.0, ge=0, description="nominal K* (N/m), Eq. 3.6 and initial Θ")
    damping: float = Field(250.0, ge=0, description="nominal C* (N·s/m), Eq. 3.6 and initial Θ")
    ref_mass: float = Field(250.0, gt=0, description="reference M_m (kg)")
    ref_stiffness: float = Field(5000.0, gt=0, description="reference K_m (N/m)")
    ref_damping: float = Field(6000.0, gt=0, description="reference skyhook damper D_m (N·s/m)")
    a0: float = Field(2.0, gt=0, description="observer polynomial A0 = s + a0 (thesis: 2)")
    gamma: float = Field(1.0, gt=0, description="adaptation gain γ (normalised law)")
    alpha: float = Field(1e-6, gt=0, description="normalisation α in γφε/(α + φᵀΓφ)")
    p1: Optional[float] = Field(None, gt=0, description="P1 = (s + p1)² instead of the thesis's P1 = A_m "
                                "(see module doc); none = thesis")
    k_v: float = Field(0.1, ge=0, description="velocity-error weight K_v (s) in the augmented error")
    gamma_b0: float = Field(0.0, ge=0, description="b0 estimator gain (0 = keep b0 = 1/M*)")
    static_level: bool = Field(True, description="adapt the static-load parameter θ_d (see module doc)")
    gamma_d: float = Field(20000.0, ge=0, description="gain of θ_d's own normalised law dθ_d/dt = γ_d φ_d ε/(α + φ_d²); "
                           "the rate of static-level recovery is ≈ γ_d·b0 (1/s)")
    theta0: Optional[list[float]] = Field(None, description="initial Θ (6 values incl. θ_d); default nominal")
    fully_active: bool = Field(False, description="C = K = 0 in Eq. 3.6 (fully active suspension)")


@CONTROLLERS.register("thesis_mrac_continuous")
class MRACContinuous(Controller):
    """Thesis Ch. 3 continuous direct MRAC (pole placement + augmented error + normalised gradient) for the SDOF rig."""

    Params = MRACContinuousParams
    requires = ("body_pos", "body_vel", "road", "road_vel")

    def reset(self):
        p, n, h = self.p, self.ctx.n_cars, self.ctx.control_dt
        M, C, K = _f(p.mass), _f(p.damping), _f(p.stiffness)
        Mm, Km, Dm = _f(p.ref_mass), _f(p.ref_stiffness), _f(p.ref_damping)
        a0 = _f(p.a0)
        wm2, zw2 = Km / Mm, Dm / Mm  # ω_m², 2ζ_mω_m
        wp2, zp2 = K / M, C / M
        b0 = 1.0 / M
        r1 = a0 + zw2 - zp2
        s0 = (wm2 + a0 * zw2 - wp2 - r1 * zp2) / b0
        s1 = (a0 * wm2 - r1 * wp2) / b0
        t0, t1 = wm2 / b0, a0 * wm2 / b0
        self.theta_nom = np.array([r1 - a0, s0, s1, t0, t1, 0.0])
        th0 = np.asarray(p.theta0, dtype=float) if p.theta0 is not None else self.theta_nom
        self.theta = np.tile(th0, (n, 1))
        # per-parameter gain: scaled by the nominal magnitudes (conditioning of the normalised law)
        scale = np.abs(self.theta_nom).copy()
        scale[5] = 1000.0 * max(abs(r1), 1.0)  # θ_d ≈ r1·d with d of the order of kN
        self.Gamma = _f(p.gamma) * scale[:5] ** 2
        self.b0 = np.full(n, b0)
        self.b_lim = (0.2 * b0, 5.0 * b0)
        Am = [1.0, zw2, wm2]
        P2 = [1.0, a0]
        P1 = Am if p.p1 is None else [1.0, 2 * _f(p.p1), _f(p.p1) ** 2]
        Pp = np.polymul(P1, P2)
        self.fEf = FilterBank.tf(np.polymul(P2, Am), Pp, h, n, 1)  # e_f = (Q/P) e, Q = A0·A_m
        # 1/P on (F, x, w, 1) and s/P on (x, w); 1/P2 and s/P2 for P1·φ; F/P1; reference model
        self.fP = FilterBank.tf([1.0], Pp, h, n, 4)
        self.fsP = FilterBank.tf([1.0, 0.0], Pp, h, n, 2)
        self.fP2 = FilterBank.tf([1.0], P2, h, n, 4)
        self.fsP2 = FilterBank.tf([1.0, 0.0], P2, h, n, 2)
        self.fP1 = FilterBank.tf([1.0], P1, h, n, 1)
        # reference: states [x_m, ẋ_m], input w
        Ar = np.array([[0.0, 1.0], [-wm2, -zw2]])
        self.ref = FilterBank(Ar, np.array([[0.0], [wm2]]), np.eye(2), np.zeros((2, 1)), h, n, 1)
        self.wm2, self.zw2 = wm2, zw2
        self.F = np.zeros(n)
        self.Kc, self.Cc = (0.0, 0.0) if p.fully_active else (K, C)
        self._sig = {}

    def step(self, t, y):
        h = self.ctx.control_dt
        x = y["body_pos"][:, 0]
        xd = y["body_vel"][:, 0]
        w = y["road"][:, 0]
        wd = y["road_vel"][:, 0]
        n = x.shape[0]
        one = np.ones(n)
        # regressor φ (filter states hold inputs up to the previous step; x, w enter with feed-through)
        oP = self.fP.output()[:, :, 0]  # F/P, x/P, w/P, 1/P
        osP = self.fsP.output()[:, :, 0]  # s x/P, s w/P
        phi = np.stack([oP[:, 0], osP[:, 0], oP[:, 1], -osP[:, 1], -oP[:, 2], oP[:, 3]], axis=1)
        sig2 = np.stack([x, w], axis=1)[:, :, None]
        oP2 = self.fP2.output()[:, :, 0]  # F/P2, x/P2, w/P2, 1/P2
        osP2 = self.fsP2.output(sig2)[:, :, 0]  # s x/P2, s w/P2 (biproper)
        # x/P2, w/P2 are strictly proper: their state lags the current sample by one step (ZOH)
        P1phi = np.stack([oP2[:, 0], osP2[:, 0], oP2[:, 1], -osP2[:, 1], -oP2[:, 2], oP2[:, 3]], axis=1)
        # reference model and errors
        xr = self.ref.output()[:, 0, :]
        e = x - xr[:, 0]
        ef = self.fEf.output(e[:, None])[:, 0, 0]
        ed = xd - xr[:, 1]
        FP1 = self.fP1.output()[:, 0, 0]
        k = 5
        th = self.theta
        eta = -(FP1 + np.einsum("nk,nk->n", phi, th))
        eps = ef + self.b0 * eta + _f(self.p.k_v) * ed
        # adaptation (normalised gradient, Euler over the control step)
        G = self.Gamma
        den = _f(self.p.alpha) + np.einsum("nk,k,nk->n", phi[:, :k], G, phi[:, :k])
        self.theta[:, :k] += h * G[None, :] * phi[:, :k] * (eps / den)[:, None]
        if self.p.static_level:  # θ_d: its own normalised law (see module doc)
            pd = phi[:, 5]
            self.theta[:, 5] += h * _f(self.p.gamma_d) * pd * eps / (_f(self.p.alpha) + pd * pd)
        if _f(self.p.gamma_b0) > 0:
            epsh = ef + self.b0 * eta
            self.b0 = np.clip(self.b0 - h * _f(self.p.gamma_b0) * eta * epsh / (1e-12 + eta * eta),
                              *self.b_lim)
        # control (Eq. 3.29) and actuator force (Eq. 3.6 with M*g = K*δ_st)
        F = -np.einsum("nk,nk->n", self.theta, P1phi)
        Fact = F - self.Cc * wd - self.Kc * w
        # advance filters with this step's inputs
        self.fP.update(np.stack([F, x, w, one], axis=1))
        self.fsP.update(np.stack([x, w], axis=1))
        self.fP2.update(np.stack([F, x, w, one], axis=1))
        self.fsP2.update(np.stack([x, w], axis=1))
        self.fP1.update(F[:, None])
        self.ref.update(w[:, None])
        self.fEf.update(e[:, None])
        self.F = F
        acc_r = -self.zw2 * xr[:, 1] - self.wm2 * (xr[:, 0] - w)
        self._sig = {"theta": self.theta.copy(), "b0": self.b0.copy(), "ref_x": xr[:, 0],
                     "ref_acc": acc_r, "ref_travel": xr[:, 0] - w, "err": e}
        return Fact[:, None]

    def signals(self):
        return self._sig
