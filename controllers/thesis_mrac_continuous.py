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
(the thesis's velocity term; K_v in s), the normalised gradient law as printed (Eq. 3.34),
dΘ/dt = γφε/(α + φᵀφ), written in the coordinates Θ/S scaled by the nominal magnitudes S = |Θ_nom| (ours: the
entries differ by four orders of magnitude), i.e. dΘ/dt = γS²φε/(α + φᵀS²φ): γ sets the rate (≈ γ·b0 in the
best-excited direction); γ = 0 turns the adaptation of Θ off.  And the
gradient estimate of b0 (Eq. 3.35, partly garbled; read as db̂0/dt = −γ_b η ε̂/(α_b + η²) with the
prediction error ε̂ = e + b̂0 η).  The filters run at the control step by zero-order hold (the thesis
integrates them "by simple trapezoidal integration" at 0.01 s).

Static level — an addition the thesis does not spell out.  After a load step the term −ΔM·g enters
F_cont as a constant disturbance d; the regulator structure has no constant term, and the thesis
obtains its "mean upward force of 1500 N" through the estimated M* in Eq. 3.6 without giving the law.
We add one parameter θ_d with regressor 1/P (the filtered constant 1): R(F + d) = R F + r1·d exactly for
a constant d, so the error model stays linear in parameters and θ_d converges to r1·d; the actuator then
carries the extra static load, F_act → ΔM·g.  Off by default (``static_level: false``, the thesis's structure
as printed); the scenarios name the variants that turn it on (``mrac_thetad*``).
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
``ref_travel``, ``err``, ``phi.k`` (the regressor, k = 5 is θ_d's) and ``eps`` (the augmented error).

θ_d with a large γ_d (20000 in the load-step scenarios) is not only a static term: its normalised law is a
high-gain integral action on ε that makes the loop follow the reference with any Θ (even Θ = 0), so Θ then
need not adapt (scenarios/thesis_ch3_adaptation.yaml shows both).

The law is the numba kernel ``_kernel`` for one car (the base Controller broadcasts it over an ensemble for
the Python loop; the compiled loop inlines it), written out for this controller's fixed filter orders
(≈ 0.06 µs per call against ≈ 1.1 µs with the generic filter helpers of thesis_common:
benchmarks/bench_mrac_kernel.py); tests/test_kernels_thesis.py checks it against the equations above.
"""
from __future__ import annotations

from typing import Optional

import numba
import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from .thesis_common import ZOH_HEADER, KernelLayout, ZOHFilter, shared_value, stamped_cache


class MRACContinuousParams(Params):
    mass: float = Field(250.0, gt=0, description="nominal M* (kg): initial b0 = 1/M*, and Eq. 3.6")
    stiffness: float = Field(5000.0, ge=0, description="nominal K* (N/m), Eq. 3.6 and initial Θ")
    damping: float = Field(250.0, ge=0, description="nominal C* (N·s/m), Eq. 3.6 and initial Θ")
    ref_mass: float = Field(250.0, gt=0, description="reference M_m (kg)")
    ref_stiffness: float = Field(5000.0, gt=0, description="reference K_m (N/m)")
    ref_damping: float = Field(6000.0, gt=0, description="reference skyhook damper D_m (N·s/m)")
    a0: float = Field(2.0, gt=0, description="observer polynomial A0 = s + a0 (thesis: 2)")
    gamma: float = Field(1.0, ge=0, description="adaptation gain γ of the printed normalised law γφε/(α + φᵀφ) (0: adaptation of Θ off)")
    alpha: float = Field(1e-6, gt=0, description="normalisation α in γφε/(α + φᵀΓφ)")
    p1: Optional[float] = Field(None, gt=0, description="P1 = (s + p1)² instead of the thesis's P1 = A_m "
                                "(see module doc); none = thesis")
    k_v: float = Field(0.1, ge=0, description="velocity-error weight K_v (s) in the augmented error")
    gamma_b0: float = Field(0.0, ge=0, description="b0 estimator gain (0 = keep b0 = 1/M*)")
    static_level: bool = Field(False, description="adapt the static-load parameter θ_d (ours, not in the thesis; see module doc); default off: the printed law")
    gamma_d: float = Field(20000.0, ge=0, description="gain of θ_d's own normalised law dθ_d/dt = γ_d φ_d ε/(α + φ_d²); "
                           "the rate of static-level recovery is ≈ γ_d·b0 (1/s)")
    theta0: Optional[list[float]] = Field(None, description="initial Θ (6 values incl. θ_d); default nominal")
    fully_active: bool = Field(False, description="C = K = 0 in Eq. 3.6 (fully active suspension)")


# ---- the law: one control step for one car (suspension_sim.compiled) ---------------------------------------
# p: the filters' headers (ZOH_HEADER values each, in _FILTERS order), then the scalars _PS.., Γ (5), then the
# filter matrices.  st: Θ (6), b0, F, the signals ref_x, ref_acc, ref_travel, err, the scratch φ (6), P1φ (6)
# and the filter inputs (F, x, w, 1) (unused by the specialised kernel), then the filter states (and their
# unused scratch).
_FILTERS = ("fEf", "fP", "fsP", "fP2", "fsP2", "fP1", "ref")
_HEF, _HP, _HSP, _HP2, _HSP2, _HP1, _HREF = (ZOH_HEADER * i for i in range(len(_FILTERS)))
_PS = ZOH_HEADER * len(_FILTERS)  # scalars: sensor offsets x, ẋ, w, ẇ; h, K_v, α, γ_d, static, γ_b0, b-range, Kc, Cc, 2ζω, ω², γ
_PG = _PS + 17  # S² (5): the per-parameter scaling (Γ = γ·S²)
_ST_TH, _ST_B0, _ST_F, _ST_RX, _ST_RA, _ST_RT, _ST_E = 0, 6, 7, 8, 9, 10, 11
_ST_PHI, _ST_P1PHI, _ST_U = 12, 18, 24
_ST_EPS = _ST_P1PHI  # the augmented error ε (a signal; the slot is P1·φ scratch the specialised kernel does not use)
_ST_N = 28

# The kernel is written out for this controller's fixed filter orders (P = P1·P2 of degree 3, P1 and the
# reference of degree 2, P2 of degree 1), with every matrix and state at a fixed offset: no header decoding,
# no runtime-sized loops, all values in locals (a store to st cannot force p to be read again).  The generic
# helpers of thesis_common (zoh_y/zoh_yu/zoh_update/k_dot) cost ≈ 1 µs per call for the same few hundred flops
# (benchmarks/bench_mrac_kernel.py).  The sums keep k_dot's order (even terms, odd terms, then their sum,
# each from 0.0; see thesis_common).
# (n states, n inputs, n outputs, n copies) of each filter; kernel_data checks them against the ZOHFilters.
_SIZES = {"fEf": (3, 1, 1, 1), "fP": (3, 1, 1, 4), "fsP": (3, 1, 1, 2), "fP2": (1, 1, 1, 4),
          "fsP2": (1, 1, 1, 2), "fP1": (2, 1, 1, 1), "ref": (2, 1, 2, 1)}


def _fixed_layout():
    """{filter: (p offset of Ad, st offset of the state)} as kernel_data/ZOHFilter.pack place them."""
    po, so, out = _PG + 5, _ST_N, {}
    for nm in _FILTERS:
        ns, nin, nout, k = _SIZES[nm]
        out[nm] = (po, so)
        po += ns * ns + ns * nin + nout * ns + nout * nin
        so += k * ns + ns
    return out


_LAY = _fixed_layout()
_MEF, _SEF = _LAY["fEf"]
_MP, _SP = _LAY["fP"]
_MSP, _SSP = _LAY["fsP"]
_MP2, _SP2 = _LAY["fP2"]
_MSP2, _SSP2 = _LAY["fsP2"]
_MP1, _SP1 = _LAY["fP1"]
_MREF, _SREF = _LAY["ref"]


@numba.njit(inline="always")
def _d1(a0, b0):
    """k_dot of 1 term."""
    return (0.0 + a0 * b0) + 0.0


@numba.njit(inline="always")
def _d2(a0, a1, b0, b1):
    """k_dot of 2 terms."""
    return (0.0 + a0 * b0) + (0.0 + a1 * b1)


@numba.njit(inline="always")
def _d3(a0, a1, a2, b0, b1, b2):
    """k_dot of 3 terms."""
    return ((0.0 + a0 * b0) + a2 * b2) + (0.0 + a1 * b1)


@numba.njit(inline="always")
def _d6(a0, a1, a2, a3, a4, a5, b0, b1, b2, b3, b4, b5):
    """k_dot of 6 terms."""
    return (((0.0 + a0 * b0) + a2 * b2) + a4 * b4) + (((0.0 + a1 * b1) + a3 * b3) + a5 * b5)


@numba.njit(inline="always")
def _y3(p, m, st, s):
    """Cd x of a 3-state, 1-input, 1-output filter (matrices at p[m:], state at st[s:s + 3])."""
    return _d3(p[m + 12], p[m + 13], p[m + 14], st[s], st[s + 1], st[s + 2])


@numba.njit(inline="always")
def _up3(p, m, x0, x1, x2, v):
    """The next state Ad x + Bd v of a 3-state, 1-input filter (zoh_update's sums)."""
    return (_d3(p[m], p[m + 1], p[m + 2], x0, x1, x2) + _d1(p[m + 9], v),
            _d3(p[m + 3], p[m + 4], p[m + 5], x0, x1, x2) + _d1(p[m + 10], v),
            _d3(p[m + 6], p[m + 7], p[m + 8], x0, x1, x2) + _d1(p[m + 11], v))


@numba.njit(inline="always")
def _up2(p, m, x0, x1, v):
    """The next state of a 2-state, 1-input filter."""
    return (_d2(p[m], p[m + 1], x0, x1) + _d1(p[m + 4], v),
            _d2(p[m + 2], p[m + 3], x0, x1) + _d1(p[m + 5], v))


@numba.njit(inline="always")
def _up1(p, m, x0, v):
    """The next state of a 1-state, 1-input filter."""
    return _d1(p[m], x0) + _d1(p[m + 1], v)


@stamped_cache
@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    x = y[int(p[_PS])]
    xd = y[int(p[_PS + 1])]
    w = y[int(p[_PS + 2])]
    wd = y[int(p[_PS + 3])]
    h = p[_PS + 4]
    k_v = p[_PS + 5]
    alpha = p[_PS + 6]
    # filter states (inputs up to the previous step)
    a0, a1, a2 = st[_SP], st[_SP + 1], st[_SP + 2]  # 1/P: F, x, w, 1
    b0_, b1, b2 = st[_SP + 3], st[_SP + 4], st[_SP + 5]
    c0, c1, c2 = st[_SP + 6], st[_SP + 7], st[_SP + 8]
    d0, d1, d2 = st[_SP + 9], st[_SP + 10], st[_SP + 11]
    e0, e1, e2 = st[_SSP], st[_SSP + 1], st[_SSP + 2]  # s/P: x, w
    f0, f1, f2 = st[_SSP + 3], st[_SSP + 4], st[_SSP + 5]
    q0, q1, q2, q3 = st[_SP2], st[_SP2 + 1], st[_SP2 + 2], st[_SP2 + 3]  # 1/P2: F, x, w, 1
    r0, r1 = st[_SSP2], st[_SSP2 + 1]  # s/P2: x, w
    g0, g1 = st[_SP1], st[_SP1 + 1]  # 1/P1: F
    m0, m1 = st[_SREF], st[_SREF + 1]  # reference: x_m, ẋ_m
    n0, n1, n2 = st[_SEF], st[_SEF + 1], st[_SEF + 2]  # Q/P: e
    # regressor φ and P1·φ (filter outputs before this step's update)
    ph0 = _y3(p, _MP, st, _SP)
    ph1 = _y3(p, _MSP, st, _SSP)
    ph2 = _y3(p, _MP, st, _SP + 3)
    ph3 = -_y3(p, _MSP, st, _SSP + 3)
    ph4 = -_y3(p, _MP, st, _SP + 6)
    ph5 = _y3(p, _MP, st, _SP + 9)
    cp2 = p[_MP2 + 2]
    cs2 = p[_MSP2 + 2]
    ds2 = p[_MSP2 + 3]
    pp0 = _d1(cp2, q0)
    pp1 = _d1(cs2, r0)
    pp3 = _d1(cs2, r1)
    if p[_HSP2 + 6] != 0.0:
        pp1 = pp1 + _d1(ds2, x)
        pp3 = pp3 + _d1(ds2, w)
    pp3 = -pp3
    pp2 = _d1(cp2, q1)
    pp4 = -_d1(cp2, q2)
    pp5 = _d1(cp2, q3)
    xr0 = _d2(p[_MREF + 6], p[_MREF + 7], m0, m1)
    xr1 = _d2(p[_MREF + 8], p[_MREF + 9], m0, m1)
    e = x - xr0
    ef = _y3(p, _MEF, st, _SEF)
    if p[_HEF + 6] != 0.0:
        ef = ef + _d1(p[_MEF + 15], e)
    ed = xd - xr1
    FP1 = _d2(p[_MP1 + 6], p[_MP1 + 7], g0, g1)
    b0 = st[_ST_B0]
    th0, th1, th2, th3, th4, th5 = st[_ST_TH], st[_ST_TH + 1], st[_ST_TH + 2], st[_ST_TH + 3], st[_ST_TH + 4], \
        st[_ST_TH + 5]
    eta = -(FP1 + _d6(ph0, ph1, ph2, ph3, ph4, ph5, th0, th1, th2, th3, th4, th5))
    eps = ef + b0 * eta + k_v * ed
    # adaptation: the printed normalised law γφε/(α + φᵀφ) in the scaled coordinates Θ/S (Euler over the
    # control step; Σ φ_k S_k² φ_k in order from 0.0); γ multiplies the normalised step, as printed
    G0, G1, G2, G3, G4 = p[_PG], p[_PG + 1], p[_PG + 2], p[_PG + 3], p[_PG + 4]
    den = alpha + (((((0.0 + ph0 * G0 * ph0) + ph1 * G1 * ph1) + ph2 * G2 * ph2) + ph3 * G3 * ph3)
                   + ph4 * G4 * ph4)
    r = eps / den
    hg = h * p[_PS + 16]
    th0 += hg * G0 * ph0 * r
    th1 += hg * G1 * ph1 * r
    th2 += hg * G2 * ph2 * r
    th3 += hg * G3 * ph3 * r
    th4 += hg * G4 * ph4 * r
    if p[_PS + 8] != 0.0:
        th5 += h * p[_PS + 7] * ph5 * eps / (alpha + ph5 * ph5)
    bn = b0
    if p[_PS + 9] > 0.0:
        epsh = ef + b0 * eta
        b = b0 - h * p[_PS + 9] * eta * epsh / (1e-12 + eta * eta)
        bn = min(max(b, p[_PS + 10]), p[_PS + 11])
    F = -_d6(th0, th1, th2, th3, th4, th5, pp0, pp1, pp2, pp3, pp4, pp5)
    fact = F - p[_PS + 13] * wd - p[_PS + 12] * w
    ra = -p[_PS + 14] * xr1 - p[_PS + 15] * (xr0 - w)
    # advance the filters with this step's inputs
    A0, A1, A2 = _up3(p, _MP, a0, a1, a2, F)
    B0, B1, B2 = _up3(p, _MP, b0_, b1, b2, x)
    C0, C1, C2 = _up3(p, _MP, c0, c1, c2, w)
    D0, D1, D2 = _up3(p, _MP, d0, d1, d2, 1.0)
    E0, E1, E2 = _up3(p, _MSP, e0, e1, e2, x)
    F0, F1, F2 = _up3(p, _MSP, f0, f1, f2, w)
    Q0 = _up1(p, _MP2, q0, F)
    Q1 = _up1(p, _MP2, q1, x)
    Q2 = _up1(p, _MP2, q2, w)
    Q3 = _up1(p, _MP2, q3, 1.0)
    R0 = _up1(p, _MSP2, r0, x)
    R1 = _up1(p, _MSP2, r1, w)
    G0n, G1n = _up2(p, _MP1, g0, g1, F)
    M0, M1 = _up2(p, _MREF, m0, m1, w)
    N0, N1, N2 = _up3(p, _MEF, n0, n1, n2, e)
    # stores
    st[_SP], st[_SP + 1], st[_SP + 2] = A0, A1, A2
    st[_SP + 3], st[_SP + 4], st[_SP + 5] = B0, B1, B2
    st[_SP + 6], st[_SP + 7], st[_SP + 8] = C0, C1, C2
    st[_SP + 9], st[_SP + 10], st[_SP + 11] = D0, D1, D2
    st[_SSP], st[_SSP + 1], st[_SSP + 2] = E0, E1, E2
    st[_SSP + 3], st[_SSP + 4], st[_SSP + 5] = F0, F1, F2
    st[_SP2], st[_SP2 + 1], st[_SP2 + 2], st[_SP2 + 3] = Q0, Q1, Q2, Q3
    st[_SSP2], st[_SSP2 + 1] = R0, R1
    st[_SP1], st[_SP1 + 1] = G0n, G1n
    st[_SREF], st[_SREF + 1] = M0, M1
    st[_SEF], st[_SEF + 1], st[_SEF + 2] = N0, N1, N2
    st[_ST_TH], st[_ST_TH + 1], st[_ST_TH + 2], st[_ST_TH + 3], st[_ST_TH + 4], st[_ST_TH + 5] = \
        th0, th1, th2, th3, th4, th5
    st[_ST_B0] = bn
    st[_ST_F] = F
    st[_ST_E] = e
    st[_ST_EPS] = eps
    st[_ST_PHI], st[_ST_PHI + 1], st[_ST_PHI + 2], st[_ST_PHI + 3], st[_ST_PHI + 4], st[_ST_PHI + 5] = \
        ph0, ph1, ph2, ph3, ph4, ph5
    st[_ST_RX] = xr0
    st[_ST_RA] = ra
    st[_ST_RT] = xr0 - w
    u[0] = fact


@CONTROLLERS.register("thesis_mrac_continuous")
class MRACContinuous(Controller):
    """Thesis Ch. 3 continuous direct MRAC (pole placement + augmented error + normalised gradient) for the SDOF rig."""

    Params = MRACContinuousParams
    requires = ("body_pos", "body_vel", "road", "road_vel")
    kernel = staticmethod(_kernel)
    kernel_lanes = True  # straight-line in y and st (branches on p only): four cars per call in the compiled loop

    def reset(self):
        super().reset()
        p, h = self.p, self.ctx.control_dt
        M, C, K = shared_value(p.mass), shared_value(p.damping), shared_value(p.stiffness)
        Mm, Km, Dm = shared_value(p.ref_mass), shared_value(p.ref_stiffness), shared_value(p.ref_damping)
        a0 = shared_value(p.a0)
        wm2, zw2 = Km / Mm, Dm / Mm  # ω_m², 2ζ_mω_m
        wp2, zp2 = K / M, C / M
        b0 = 1.0 / M
        r1 = a0 + zw2 - zp2
        s0 = (wm2 + a0 * zw2 - wp2 - r1 * zp2) / b0
        s1 = (a0 * wm2 - r1 * wp2) / b0
        t0, t1 = wm2 / b0, a0 * wm2 / b0
        self.theta_nom = np.array([r1 - a0, s0, s1, t0, t1, 0.0])
        self.theta0 = np.asarray(p.theta0, dtype=float) if p.theta0 is not None else self.theta_nom
        # per-parameter gain: scaled by the nominal magnitudes (conditioning of the normalised law)
        scale = np.abs(self.theta_nom).copy()
        scale[5] = 1000.0 * max(abs(r1), 1.0)  # θ_d ≈ r1·d with d of the order of kN
        self.scale2 = scale[:5] ** 2
        self.Gamma = shared_value(p.gamma) * self.scale2
        self.b0 = b0
        self.b_lim = (0.2 * b0, 5.0 * b0)
        Am = [1.0, zw2, wm2]
        P2 = [1.0, a0]
        P1 = Am if p.p1 is None else [1.0, 2 * shared_value(p.p1), shared_value(p.p1) ** 2]
        Pp = np.polymul(P1, P2)
        # e_f = (Q/P) e with Q = A0·A_m; 1/P on (F, x, w, 1) and s/P on (x, w); 1/P2 on (F, x, w, 1) and s/P2
        # on (x, w) for P1·φ; F/P1; the reference model (states [x_m, ẋ_m], input w)
        self.filters = {"fEf": ZOHFilter.tf(np.polymul(P2, Am), Pp, h), "fP": ZOHFilter.tf([1.0], Pp, h, 4),
                        "fsP": ZOHFilter.tf([1.0, 0.0], Pp, h, 2), "fP2": ZOHFilter.tf([1.0], P2, h, 4),
                        "fsP2": ZOHFilter.tf([1.0, 0.0], P2, h, 2), "fP1": ZOHFilter.tf([1.0], P1, h),
                        "ref": ZOHFilter(np.array([[0.0, 1.0], [-wm2, -zw2]]), np.array([[0.0], [wm2]]), np.eye(2),
                                         np.zeros((2, 1)), h)}
        self.wm2, self.zw2 = wm2, zw2
        self.Kc, self.Cc = (0.0, 0.0) if p.fully_active else (K, C)

    def kernel_data(self):
        n = self.ctx.n_cars
        lay = KernelLayout(n)
        lay.p(np.zeros(_PS))  # filter headers, filled by ZOHFilter.pack
        sl = [float(self.ctx.sensor_slice(nm)[0]) for nm in ("body_pos", "body_vel", "road", "road_vel")]
        p = self.p
        lay.p(sl + [self.ctx.control_dt, shared_value(p.k_v), shared_value(p.alpha), shared_value(p.gamma_d),
                    float(bool(p.static_level)), shared_value(p.gamma_b0), self.b_lim[0], self.b_lim[1], self.Kc,
                    self.Cc, self.zw2, self.wm2, shared_value(p.gamma)])
        assert lay.p(self.scale2) == _PG
        assert lay.st(self.theta0) == _ST_TH
        lay.st([self.b0, 0.0, 0.0, 0.0, 0.0, 0.0])  # b0, F, ref_x, ref_acc, ref_travel, err
        assert lay.st(np.zeros(_ST_N - _ST_PHI)) == _ST_PHI
        for i, nm in enumerate(_FILTERS):
            self.filters[nm].pack(lay, ZOH_HEADER * i)
        p, st = lay.arrays()
        for i, nm in enumerate(_FILTERS):  # the specialised kernel reads the filters at fixed offsets
            ns, nin, nout, k = _SIZES[nm]
            po, ns_, nin_, nout_, so = p[0, ZOH_HEADER * i:ZOH_HEADER * i + 5]
            if (po, so, ns_, nin_, nout_, self.filters[nm].copies) != (*_LAY[nm], ns, nin, nout, k):
                raise AssertionError(f"thesis_mrac_continuous kernel: filter {nm} not in the fixed layout")
        return p, st

    def kernel_signals(self):
        return {"theta": (_ST_TH, _ST_TH + 6), "b0": (_ST_B0, _ST_B0 + 1), "ref_x": (_ST_RX, _ST_RX + 1),
                "ref_acc": (_ST_RA, _ST_RA + 1), "ref_travel": (_ST_RT, _ST_RT + 1), "err": (_ST_E, _ST_E + 1), "phi": (_ST_PHI, _ST_PHI + 6), "eps": (_ST_EPS, _ST_EPS + 1)}
