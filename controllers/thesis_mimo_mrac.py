"""Thesis Ch. 7: discrete MIMO MRAC of the half car (bounce + pitch, two actuators), Vallurupalli 1996.

Plant (Eqs. 7.1–7.6, model ``half_car`` with ``damping_front/rear: 0`` and the ``quadratic_damping``
(C = 2500 N·s²/m²), ``bump_stop`` (K_es = 80 kN/m, D/2 = 0.125 m) and ``coulomb_friction`` effects):
M Z̈ + F(Z, Ż, t) = G U + H W + S(t), Z = [x_b, θ, x_l1, x_t1], S(t) carrying the static loads and the
pitch moment M_s·a·h of the acceleration/braking manoeuvre (``vehicle.maneuver: accel_brake``).

Outputs Y = [x_b, θ] (``body_pos``; θ positive = nose down, ISO 8855 — the thesis's G matrix
[[1, 1], [d1, −d2], …] uses nose-up positive), inputs U = [u_front, u_rear] (positive pushes the body up).

Design, following the thesis's steps:

1. linearised model about the operating point: here the rigid body on the two suspensions,
   M_g q̈ + TᵀC0T q̇ + TᵀK0T q = Tᵀ U_T with q = [x_b, θ], T = [[1, −a], [1, b]] (corner heights
   x_b − aθ, x_b + bθ), K0 the spring stiffness and C0 a describing-function linear damping of the
   velocity-squared damper (``lin_damping``).  The thesis linearises the full 8-state model; a DARMA
   model with second-order polynomials per output (n = 2, as in the thesis) is exact for this 4-state
   body model, and the wheel hop (≈ 8 Hz) is left to the estimator as unmodelled dynamics — our choice;
2. zero-order-hold discretisation at the control step (``scipy.signal.cont2discrete``; thesis 0.01 s);
3. interactor: with β0 = CΓ nonsingular (both actuators act on bounce and pitch at the first sample)
   the interactor matrix is q·I, so the delay structure is diagonal, D = 1 + ``delay_steps``;
4. predictor a_m(q⁻¹)Y[k+D] = α(q⁻¹)Y[k] + β(q⁻¹)U[k] + c with matrix polynomials (matrix Diophantine
   F A + q⁻ᴰ G = a_m I) and control law U[k] = Θᵀφ[k] (:class:`thesis_common.DiscreteMRAC`);
5. matrix least squares with a shared covariance P* (one P for both columns of Θ) and covariance
   addition; the sign/magnitude constraint on (β0)⁻¹ projects its diagonal into
   [``beta_inv_range``] × its nominal value (sign kept);
6. ``kappa`` < 1 weights control increments (see :class:`thesis_common.DiscreteMRAC`) — our addition
   against the sampling-zero ringing of the pure d-step-ahead law.

The constant c/β0 in Θ is the operating-point force (the thesis's static and manoeuvre loads S(t)): it
is what removes the braking nose dive.  It is ours (the printed φ has no constant); ``bias: false`` removes it.  U_T = u + K0·w + C0·ẇ per corner (nominal road force,
``road_feedforward``), so the actuators get u = U_T − K0·w − C0·ẇ.

Reference ("two-tier skyhook", Eq. 7.7): the same half car with springs K_m, no passive damper, skyhook
dampers C_m on the absolute velocity of both body attachment points and dampers D_m between each wheel and
the ground (parallel to the tire); thesis values K_m = 17 kN/m, C_m = D_m = 9 kN·s/m, I_m = 1125 kg·m²,
tire 100 kN/m; masses as the plant's (the controller's nominal M_s, I unless ``ref_sprung_mass``,
``ref_pitch_inertia`` give them: a run started from a wrong initial design keeps the thesis's reference).  The
reference is driven by the measured road under both wheels and has no manoeuvre input: it stays level under braking, so the target pitch is the road-induced pitch only.

Signals: ``ref_z``/``ref_pitch`` (target for the current reading), ``err.0/1``, ``ref_acc`` (reference
heave acceleration), ``theta.k`` (Θ unscaled, flattened), ``bias.0/1`` (the operating-point forces c
mapped to actuator forces, N).

The law is the numba kernel ``_kernel`` for one car (with thesis_common.dm_step; the base Controller
broadcasts it over an ensemble, the compiled loop inlines it); tests/test_kernels_thesis.py checks it
against the equations above.
"""
from __future__ import annotations

from typing import Literal

import numba
import numpy as np
from pydantic import Field, model_validator

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from .thesis_common import (DM_HEADER, ZOH_HEADER, DiscreteMRAC, KernelLayout, ZOHFilter, am_poly, darma, dm_step,
                            dm_theta_strides, k_dot, predictor, ref_value, shared_value, stamped_cache,
                            theta_from_predictor, zoh_update, zoh_y)


class MIMOParams(Params):
    sprung_mass: float = Field(500.0, gt=0, description="nominal M_s (kg)")
    pitch_inertia: float = Field(1125.0, gt=0, description="nominal I (kg·m²)")
    unsprung_mass: float = Field(45.0, gt=0, description="nominal unsprung mass per axle, reference model (kg)")
    a: float = Field(1.5, gt=0, description="d1, c.g. to front axle (m)")
    b: float = Field(1.5, gt=0, description="d2, c.g. to rear axle (m)")
    stiffness: float = Field(17000.0, gt=0, description="K0 per axle (N/m)")
    lin_damping: float = Field(500.0, ge=0, description="C0: describing-function linear damping per axle (N·s/m)")
    tire_stiffness: float = Field(100000.0, gt=0, description="reference tire stiffness (N/m)")
    ref_sprung_mass: float | None = Field(None, gt=0, description="M_ms of the reference (kg); default the nominal M_s")
    ref_pitch_inertia: float | None = Field(None, gt=0, description="I_m of the reference (kg·m²); default the "
                                            "nominal I")
    ref_stiffness: float = Field(17000.0, gt=0, description="K_m (N/m)")
    ref_skyhook: float = Field(9000.0, ge=0, description="C_m skyhook dampers at the body attachment points (N·s/m)")
    ref_wheel_damping: float = Field(9000.0, ge=0, description="D_m wheel-to-ground dampers (N·s/m)")
    ref_freq: float = Field(2.0, gt=0, description="a_m(q⁻¹): natural frequency of the desired output dynamics (Hz)")
    ref_zeta: float = Field(1.0, gt=0, description="a_m(q⁻¹): damping ratio")
    delay_steps: int = Field(0, ge=0, description="loop delay in control steps (sensor delay)")
    p0: float = Field(1e-4, gt=0, description="initial covariance (scaled)")
    q: float = Field(1e-6, ge=0, description="covariance addition (scaled)")
    p0_bias: float = Field(1.0, gt=0, description="initial covariance of the bias (operating-point force) parameter")
    q_bias: float = Field(0.1, ge=0, description="covariance addition of the bias parameter")
    trace_max: float = Field(5.0, gt=0, description="trace bound")
    kappa: float = Field(1.0, gt=0, le=1, description="control-increment weighting (1 = the thesis; < 1 ours)")
    beta_inv_range: tuple[float, float] = Field((0.2, 5.0), description="allowed (β0)⁻¹ diagonal / nominal")
    road_feedforward: bool = Field(True, description="U_T = u + K0·w + C0·ẇ (see module doc)")
    bias: bool = Field(True, description="the constant −1 in φ with its parameter (the operating-point force; ours, "
                       "not in the printed φ); false = the printed regressor, which holds no static or manoeuvre load "
                       "without an output error")
    probe_amplitude: float = Field(0.0, ge=0, description="closed-loop probing (ours, not the thesis's): a random "
                                   "±amplitude force (N) per actuator, new each control step, added to U and seen "
                                   "by the estimator; 0 = off (the thesis)")
    probe_seed: int = Field(1, ge=1, lt=2147483647, description="seed of the probe's generator")
    estimator: Literal["ls", "iv_probe"] = Field(
        "ls", description="ls: recursive least squares on the identity with the measured Ȳ[k] in the regressor (the "
        "thesis); iv_probe (ours): recursive instrumental variables, the instruments the same regressor built from "
        "the nominal model's response to the probe alone (needs probe_amplitude > 0)")

    @model_validator(mode="after")
    def _iv_needs_probe(self):
        if self.estimator == "iv_probe" and not np.all(np.asarray(self.probe_amplitude, dtype=float) > 0):
            raise ValueError("estimator iv_probe needs probe_amplitude > 0 (its instruments are the probe's)")
        return self


# ---- the law: one control step for one car (suspension_sim.compiled) ---------------------------------------
# p: the reference filter's header, the DiscreteMRAC header, the scalars _PS.. (sensor offsets of body_pos,
# road, road_vel; D; n targets; st offset of the targets; a_m (3); K0, C0, feed-forward on; probe amplitude;
# estimator (0 ls, 1 iv_probe), p offset of the aux model [A1, A2, B1, B2] (16), st offset of the IV state),
# row 4 of the reference A (8) and B (4) matrices, then matrices.  st: the signals ref_z, ref_pitch, ref_acc,
# err (2), bias (2), the scratch [w, ẇ] (4), Y (2), Ȳ* (2), r (8), the probe (2), its generator's state (1),
# the signal Θ (unscaled, p·2), the targets (n targets × 2), then the estimator's and filter's states.
_HREF, _HDM = 0, ZOH_HEADER
_PS = ZOH_HEADER + DM_HEADER
_PA4, _PB4 = _PS + 16, _PS + 24
_ST_RZ, _ST_RP, _ST_RA, _ST_E, _ST_BIAS, _ST_WIN, _ST_Y, _ST_YB, _ST_R, _ST_PR, _ST_LCG, _ST_TH = (
    0, 1, 2, 3, 5, 7, 11, 13, 15, 23, 25, 26)


@numba.njit(cache=True)
def _iv_instrument(p, st, hd, pa, ie):
    """The instrument of recursive instrumental variables (``estimator: iv_probe``, ours) for :func:`dm_step`'s
    update on the identity U[k−D] = Θᵀφ̃[k−D]: z[k−D] is φ̃[k−D] built from the nominal rigid-body DARMA model's
    response Ye to the probe e alone, z = [−Ye[k−D], −Ye[k−D−1], −e[k−D−1], …, −e[k−2D], −1, a_m(q⁻¹)Ye[k]],
    independent of the road.  Advances Ye and the z history and returns the st offset of z[k−D] (followed by
    dm_step's scratch of p values).  The IV state at ie: e history (max(D, 2) + 1 rows of 2), Ye history (3 × 2),
    the z history (D + 1 rows of p), scratch (2p + 2: z[k−D], dm_step's Pᵀφ̃, Ye[k])."""
    m = 2
    D = int(p[hd + 1])
    npar = int(p[hd + 2])
    SC = int(p[hd + 11])
    bi = npar - m
    ne = max(D, 2) + 1
    iy = ie + 2 * ne
    iz = iy + 6
    s0 = iz + (D + 1) * npar
    Z, YE = s0, s0 + 2 * npar
    # Ye[k] = −A1 Ye[k−1] − A2 Ye[k−2] + B1 e[k−1] + B2 e[k−2]
    for r in range(2):
        v = 0.0
        for c in range(2):
            v += (-p[pa + 2 * r + c] * st[iy + c] - p[pa + 4 + 2 * r + c] * st[iy + 2 + c]
                  + p[pa + 8 + 2 * r + c] * st[ie + c] + p[pa + 12 + 2 * r + c] * st[ie + 2 + c])
        st[YE + r] = v
    for j in range(npar):
        st[Z + j] = st[iz + (D - 1) * npar + j]
    for c in range(2):  # the new last block: a_m(q⁻¹)Ye[k]
        st[Z + bi + c] = (p[hd + 17] * st[YE + c] + p[hd + 18] * st[iy + c] + p[hd + 19] * st[iy + 2 + c]) * p[SC + bi + c]
    # histories: Ye, then z[k] = [−Ye[k], −Ye[k−1], −e[k−1] … −e[k−D], −1, (Ȳe filled at its update)] · scaling
    for c in range(2):
        st[iy + 4 + c] = st[iy + 2 + c]
        st[iy + 2 + c] = st[iy + c]
        st[iy + c] = st[YE + c]
    for k in range(D, 0, -1):
        for j in range(npar):
            st[iz + k * npar + j] = st[iz + (k - 1) * npar + j]
    j = 0
    for k in range(2):
        for c in range(2):
            st[iz + j] = -st[iy + 2 * k + c] * p[SC + j]
            j += 1
    for k in range(D):
        for c in range(2):
            st[iz + j] = -st[ie + 2 * k + c] * p[SC + j]
            j += 1
    st[iz + j] = -1.0 * p[SC + j]
    j += 1
    for c in range(2):
        st[iz + j] = 0.0
        j += 1
    return Z


@stamped_cache
@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    ib = int(p[_PS])
    iw = int(p[_PS + 1])
    iwd = int(p[_PS + 2])
    D = int(p[_PS + 3])
    nt = int(p[_PS + 4])
    TG = int(p[_PS + 5])
    for c in range(2):
        st[_ST_Y + c] = y[ib + c]
        st[_ST_WIN + c] = y[iw + c]
        st[_ST_WIN + 2 + c] = y[iwd + c]
    for o in range(8):
        st[_ST_R + o] = zoh_y(p, st, _HREF, 0, o)
    zoh_update(p, st, _HREF, 0, st, _ST_WIN)
    for k in range(nt - 1, 0, -1):
        for c in range(2):
            st[TG + 2 * k + c] = st[TG + 2 * (k - 1) + c]
    for c in range(2):
        st[TG + c] = zoh_y(p, st, _HREF, 0, c)
    for c in range(2):
        st[_ST_YB + c] = p[_PS + 6] * st[TG + c] + p[_PS + 7] * st[TG + 2 + c] + p[_PS + 8] * st[TG + 4 + c]
    iv = p[_PS + 13] != 0.0
    zo = _iv_instrument(p, st, _HDM, int(p[_PS + 14]), int(p[_PS + 15])) if iv else -1
    dm_step(p, st, _HDM, st, _ST_Y, st, _ST_YB, zo)
    U = int(p[_HDM + 7])
    if p[_PS + 12] > 0.0:  # probing: ±amplitude, Park–Miller generator (exact in float64), in U's history too
        for c in range(2):
            st[_ST_LCG] = (16807.0 * st[_ST_LCG]) % 2147483647.0
            st[_ST_PR + c] = p[_PS + 12] if st[_ST_LCG] >= 1073741823.5 else -p[_PS + 12]
            st[U + c] += st[_ST_PR + c]
        if iv:  # e history: e[k], e[k−1], …
            ie = int(p[_PS + 15])
            D = int(p[_HDM + 1])
            for k in range(max(D, 2), 0, -1):
                for c in range(2):
                    st[ie + 2 * k + c] = st[ie + 2 * (k - 1) + c]
            for c in range(2):
                st[ie + c] = st[_ST_PR + c]
    for c in range(2):
        ff = 0.0
        if p[_PS + 11] != 0.0:
            ff = p[_PS + 9] * st[_ST_WIN + c] + p[_PS + 10] * st[_ST_WIN + 2 + c]
        u[c] = st[U + c] - ff
    # signals
    npar = int(p[_HDM + 2])
    TH = int(p[_HDM + 4])
    SC = int(p[_HDM + 11])
    tj, tc = dm_theta_strides(p, _HDM)
    for j in range(npar):
        for c in range(2):
            st[_ST_TH + 2 * j + c] = st[TH + j * tj + c * tc] * p[SC + j]
    for c in range(2):
        st[_ST_BIAS + c] = -st[_ST_TH + 2 * (npar - 3) + c]
        st[_ST_E + c] = st[_ST_Y + c] - st[TG + 2 * D + c]
    st[_ST_RZ] = st[_ST_R]
    st[_ST_RP] = st[_ST_R + 1]
    st[_ST_RA] = k_dot(p, _PA4, st, _ST_R, 8) + k_dot(p, _PB4, st, _ST_WIN, 4)


@CONTROLLERS.register("thesis_mimo_mrac")
class MIMOMRAC(Controller):
    """Thesis Ch. 7 discrete MIMO MRAC for the half car: matrix DARMA, interactor, predictor, matrix least squares."""

    Params = MIMOParams
    requires = ("body_pos", "road", "road_vel")
    kernel = staticmethod(_kernel)

    def reset(self):
        super().reset()
        p, h = self.p, self.ctx.control_dt
        if self.ctx.n_corners != 2 or self.ctx.vehicle_model != "half_car":
            from suspension_sim.errors import ScenarioError

            raise ScenarioError("thesis_mimo_mrac needs the half_car model", field="controller.type")
        M, I, a, b = shared_value(p.sprung_mass), shared_value(p.pitch_inertia), shared_value(p.a), shared_value(p.b)
        K, C = shared_value(p.stiffness), shared_value(p.lin_damping)
        T = np.array([[1.0, -a], [1.0, b]])
        Mg = np.diag([M, I])
        Mi = np.linalg.inv(Mg)
        Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ T.T @ (K * T), -Mi @ T.T @ (C * T)]])
        Bc = np.vstack([np.zeros((2, 2)), Mi @ T.T])
        Cc = np.hstack([np.eye(2), np.zeros((2, 2))])
        A, B = darma(Ac, Bc, Cc, h)
        self.aux = np.concatenate([A[1].ravel(), A[2].ravel(), B[1].ravel(), B[2].ravel()])
        self.am = am_poly(2 * np.pi * shared_value(p.ref_freq), shared_value(p.ref_zeta), h)
        D, alpha, beta = predictor(A, B, self.am, int(shared_value(p.delay_steps)))
        self.D = D
        th0 = theta_from_predictor(alpha, beta)
        self.core = DiscreteMRAC(th0, 2, D, self.am, shared_value(p.p0), shared_value(p.q), shared_value(p.trace_max),
                                 beta_inv_range=tuple(np.asarray(p.beta_inv_range, dtype=float).reshape(-1)[:2]),
                                 kappa=shared_value(p.kappa), p0_bias=shared_value(p.p0_bias),
                                 q_bias=shared_value(p.q_bias), bias=bool(shared_value(p.bias)))
        self.K0, self.C0 = K, C
        if not isinstance(p.estimator, str):
            from suspension_sim.errors import ScenarioError

            raise ScenarioError("thesis_mimo_mrac: every car of an ensemble needs the same estimator",
                                field="controller.params.estimator")
        self.iv = p.estimator == "iv_probe"
        # reference: two-tier skyhook half car; q_r = [x_b, θ, x_wf, x_wr], input [w_f, w_r]
        mu = shared_value(p.unsprung_mass)
        Km, Cm = shared_value(p.ref_stiffness), shared_value(p.ref_skyhook)
        Dm, kt = shared_value(p.ref_wheel_damping), shared_value(p.tire_stiffness)
        Mr = np.diag([ref_value(p.ref_sprung_mass, M), ref_value(p.ref_pitch_inertia, I), mu, mu])
        # corner heights of the body: T q; travel_i = (T q)_i − x_wi
        S = np.array([[1.0, -a, -1.0, 0.0], [1.0, b, 0.0, -1.0]])  # travels
        Tb = np.array([[1.0, -a, 0.0, 0.0], [1.0, b, 0.0, 0.0]])  # absolute corner heights (skyhook)
        Tw = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])  # wheel heights
        Kr = Km * S.T @ S + kt * Tw.T @ Tw
        Cr = Cm * Tb.T @ Tb + Dm * Tw.T @ Tw
        Mri = np.linalg.inv(Mr)
        Ar = np.block([[np.zeros((4, 4)), np.eye(4)], [-Mri @ Kr, -Mri @ Cr]])
        # inputs [w_f, w_r, ẇ_f, ẇ_r]: tire springs and wheel-to-ground dampers act on (x_w − w)
        Bw = np.zeros((4, 4))
        Bw[2, 0] = Bw[3, 1] = kt
        Bw[2, 2] = Bw[3, 3] = Dm
        Br = np.vstack([np.zeros((4, 4)), Mri @ Bw])
        self.Ar, self.Br = Ar, Br
        self.ref = ZOHFilter(Ar, Br, np.eye(8), np.zeros((8, 4)), h)
        self.n_targets = max(D + 1, 3)  # Y*[k+D], …, Y*[k] (2 each)

    def kernel_data(self):
        n, p, core = self.ctx.n_cars, self.p, self.core
        lay = KernelLayout(n)
        lay.p(np.zeros(_PS))  # headers, filled by pack
        sl = [float(self.ctx.sensor_slice(nm)[0]) for nm in ("body_pos", "road", "road_vel")]
        lay.p(sl + [self.D, self.n_targets, _ST_TH + 2 * core.npar, *[float(a) for a in self.am[:3]], self.K0,
                    self.C0, float(bool(p.road_feedforward)), shared_value(p.probe_amplitude),
                    float(self.iv), 0.0, 0.0])
        assert lay.p(self.Ar[4]) == _PA4 and lay.p(self.Br[4]) == _PB4
        st0 = np.zeros(_ST_TH)
        st0[_ST_LCG] = shared_value(p.probe_seed)
        assert lay.st(st0) == _ST_RZ  # signals, scratch, the probe's generator
        assert lay.st(core.theta0_unscaled().ravel()) == _ST_TH
        lay.st(np.zeros(2 * self.n_targets))
        core.pack(lay, _HDM, n)
        self.ref.pack(lay, _HREF)
        if self.iv:
            pa = lay.p(self.aux)
            ne = max(self.D, 2) + 1
            ie = lay.st(np.zeros(2 * ne + 6 + (self.D + 1) * core.npar + 2 * core.npar + 2))
            lay.set_p(_PS + 14, [pa, ie])
        return lay.arrays()

    def kernel_signals(self):
        npar = self.core.npar
        return {"ref_z": (_ST_RZ, _ST_RZ + 1), "ref_pitch": (_ST_RP, _ST_RP + 1), "ref_acc": (_ST_RA, _ST_RA + 1),
                "err": (_ST_E, _ST_E + 2), "bias": (_ST_BIAS, _ST_BIAS + 2), "theta": (_ST_TH, _ST_TH + 2 * npar),
                "probe": (_ST_PR, _ST_PR + 2)}
