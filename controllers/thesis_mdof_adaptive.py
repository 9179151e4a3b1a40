"""Thesis Ch. 6: MDOF continuous-time adaptive control (after Seraji) of the 2-DOF bounce model.

Plant (Eq. 6.1–6.3, model ``two_dof``), Z = [z_s, z_p] = [x_s − x_p, x_p − w], U = [u_s, u_p]:
M Z̈ + C(Z, Ż) + K(Z) + L(Ż) = −D ẅ + P U with M = [[M_s, M_s], [0, M_p]], D = [M_s, M_p],
P = [[1, 0], [−1, 1]] and the primary's friction, velocity-squared damping and limit stops in C, K, L.

Reference (dual skyhook, Eq. 6.4): M_ms ẍ_ms + D_ms ẋ_ms + K_ms (x_ms − x_mp) = 0,
M_mp ẍ_mp + D_mp ẋ_mp + K_mp (x_mp − w) − K_ms (x_ms − x_mp) = 0 (skyhook dampers on both masses;
Z_m = [x_ms − x_mp, x_mp − w]).  Thesis values D_ms = 800, D_mp = 2000 N·s/m, the other model values equal
to the plant's: here the controller's nominal M_s, M_p, K_s, K_p unless ``ref_*`` gives them (a run started from
a wrong initial design keeps the thesis's reference by giving them).

Control (Eq. 6.35): U = P⁻¹[U_ax + M0 Z̈_m + C0 Ż_m + K0 Z_m + D0 ẅ + K_p E + K_v Ė], E = Z_m − Z: the
feedforward (inverse linearised model acting on the reference), the feedback and the auxiliary signal
(the operating-point force; the thesis's N0 and L0 terms have the same regressor, the constant 1, as
U_ax, so they are lumped into it).  Adaptation (Eq. 6.67, Seraji): with Θ = R2 E + R3 Ė, each gain
G ∈ {K_p, K_v, U_ax, M0, C0, K0, D0} follows G(t) = G(0) + α_G ∫ Θ vᵀ dt + β_G Θ vᵀ, with
v = E, Ė, 1, Z̈_m, Ż_m, Z_m, ẅ respectively (PI-type laws).  R2, R3 are blocks of the solution of the
Lyapunov equation R Ω + Ωᵀ R = −Q⁺ for the desired error dynamics Ë + Ω2 Ė + Ω1 E = 0
(Ω1 = diag ω_e², Ω2 = diag 2ζ_eω_e), solved by ``scipy.linalg.solve_continuous_lyapunov``.

Initial gains: M0, C0, K0, D0 from the nominal linearised plant (C0 with ``primary_lin_damping`` for the
velocity-squared damper and friction of the primary), K_p(0) = M0 Ω1 − K0 and K_v(0) = M0 Ω2 − C0
(so that the nominal error dynamics are exactly Ë + Ω2 Ė + Ω1 E = 0, the thesis's pole placement).
The thesis gives no α_i, β_i, ω_e, ζ_e, Q⁺; the scenario files choose them.  Adaptation gains are
normalised per regressor by a nominal magnitude (``v_scale``) so one α and one β serve all laws, and
divided by 1 + |v|² (``normalised``, a normalised law — our addition: the raw law explodes on the ẅ impulse at a
bump's edge).  Also ours, for robustness on the rough dirt road (where the bare laws drift until the loop
goes unstable at the control step): a σ-leakage on the integral parts (``sigma``) and a bound on each adapted entry
(``gain_limit`` × its nominal entry, or 10 % of the matrix's largest entry if larger).  ``normalised: false``,
``sigma: 0``, ``gain_limit: null`` are the printed laws (the scenarios' default controller; our additions are their
named variants).

``keep_cancellation`` (ours, off by default): with the nominal gains row 0 of K_p and K_v is
[M_s·ω_e² − K_s, M_s·ω_e²] and [M_s·2ζω_e − C_s, M_s·2ζω_e], so a motion δ of the primary alone (E = [δ, −δ])
gives u_s = −K_s·δ − C_s·δ̇, the change of the secondary spring and damper force: the body does not feel the
primary.  The printed laws adapt the two entries separately; on a rough road the primary rattles at 50–80 Hz,
Θ·Ė rectifies it and K_v,00 − K_v,01 drifts by thousands of N·s/m, which passes the rattle to the body
(docs/reproductions/vallurupalli_thesis_1996.md, Ch. 6).  With the flag both row-0 entries take the mean of
their two steps, so the difference (the cancellation) stays at its nominal value.

ẅ: the derivative of the measured base velocity (``road_vel``) over the control step (a base
accelerometer in practice).  Sensors: ``travel`` (z_s, z_p), ``travel_rate``, ``road``, ``road_vel``.
Signals: ``ref_z.0/1`` (reference rattle spaces), ``err.0/1``, ``ref_acc`` (reference secondary-mass
absolute acceleration), ``kp.k``, ``kv.k``, ``uax.k``.

The law is the numba kernel ``_kernel`` for one car (the base Controller broadcasts it over an ensemble,
the compiled loop inlines it); tests/test_kernels_thesis.py checks it against the equations above.
"""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field
from scipy.linalg import solve_continuous_lyapunov

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller
from .thesis_common import (ZOH_HEADER, KernelLayout, ZOHFilter, k_dot, ref_value, shared_value, stamped_cache, zoh_update,
                            zoh_y)


class MDOFParams(Params):
    sprung_mass: float = Field(85.0, gt=0, description="nominal M_s (kg)")
    primary_mass: float = Field(4.5, gt=0, description="nominal M_p (kg)")
    secondary_stiffness: float = Field(31500.0, gt=0, description="nominal K_s (N/m)")
    secondary_damping: float = Field(100.0, ge=0, description="nominal C_s (N·s/m)")
    primary_stiffness: float = Field(8700.0, gt=0, description="nominal K_p (N/m)")
    primary_lin_damping: float = Field(300.0, ge=0, description="equivalent linear damping of the primary's nonlinear damper + friction (N·s/m)")
    ref_sprung_mass: float | None = Field(None, gt=0, description="M_ms of the reference (kg); default the nominal M_s")
    ref_primary_mass: float | None = Field(None, gt=0, description="M_mp of the reference (kg); default the nominal M_p")
    ref_secondary_stiffness: float | None = Field(None, gt=0, description="K_ms of the reference (N/m); default the "
                                                  "nominal K_s")
    ref_primary_stiffness: float | None = Field(None, gt=0, description="K_mp of the reference (N/m); default the "
                                                "nominal K_p")
    ref_skyhook_secondary: float = Field(800.0, gt=0, description="D_ms (N·s/m)")
    ref_skyhook_primary: float = Field(2000.0, gt=0, description="D_mp (N·s/m)")
    error_freq: float = Field(10.0, gt=0, description="ω_e/2π of the desired error dynamics (Hz)")
    error_zeta: float = Field(1.0, gt=0, description="ζ_e of the desired error dynamics")
    alpha: float = Field(1.0, ge=0, description="integral adaptation gain α_i (all laws, normalised)")
    beta: float = Field(0.1, ge=0, description="proportional adaptation gain β_i (all laws, normalised)")
    sigma: float = Field(0.0, ge=0, description="leakage σ (1/s) on the integral parts (σ-modification, our addition; "
                         "0 = the thesis)")
    gain_limit: float | None = Field(None, gt=0, description="each adapted gain entry stays within ± gain_limit × its "
                                     "nominal scale (our addition); null = no bound (the thesis)")
    normalised: bool = Field(False, description="divide each law's step by 1 + |v|² (a normalised law, our addition); "
                             "false = the printed laws (Eq. 6.67)")
    adapt_model: bool = Field(True, description="adapt M0, C0, K0, D0 as well (False: only K_p, K_v, U_ax)")
    keep_cancellation: bool = Field(False, description="ours, not the thesis's: row 0 of K_p and K_v adapts its two "
                                    "entries by the same step, keeping the nominal cancellation of the primary's motion")


# ---- the law: one control step for one car (suspension_sim.compiled) ---------------------------------------
# p: sensor offsets (travel, travel_rate, road[-1], road_vel[-1]); h, α, β, σ, flags (adapt_model + 2·keep_cancellation
# + 4·normalised); R2, R3, P⁻¹
# (2 × 2 each), rows 2–3 of the reference A (2 × 4) and B (2); the reference filter's header; a table of the
# 7 gains (_KEYS order: n columns, p offset of [v_scale, G0, g_scale, limit], st offsets of I, G and the
# regressor); then those blocks.  st: the signals ref_z = Z_m (2), err = E (2), ref_acc, ref_x; ẇ_prev,
# ẇ_prev set; scratch x_r (4), ẍ_r (2), Ż_m, Z̈_m, Ė, Θ, v, tot (2 each), ẅ, 1; then I and G of each gain
# (the signals kp and uax are G's blocks), the filter state.
_KEYS = ("kp", "kv", "uax", "m0", "c0", "k0", "d0")
_P_R2, _P_R3, _P_PI, _P_AR, _P_BR, _P_REF, _P_KEYS = 9, 13, 17, 21, 29, 31, 31 + ZOH_HEADER
_ST_ZM, _ST_E, _ST_RA, _ST_RX, _ST_WDP, _ST_HAS = 0, 2, 4, 5, 6, 7
_ST_XR, _ST_XA, _ST_ZMD, _ST_ZMDD, _ST_ED, _ST_TH, _ST_V, _ST_TOT, _ST_WDD, _ST_ONE = 8, 12, 14, 16, 18, 20, 22, 24, 26, 27
_ST_N = 28


@stamped_cache
@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    iz = int(p[0])
    izd = int(p[1])
    w = y[int(p[2])]
    wd = y[int(p[3])]
    h = p[4]
    wdd = 0.0
    if st[_ST_HAS] != 0.0:
        wdd = (wd - st[_ST_WDP]) / h
    st[_ST_WDP] = wd
    st[_ST_HAS] = 1.0
    st[_ST_WDD] = wdd
    for o in range(4):
        st[_ST_XR + o] = zoh_y(p, st, _P_REF, 0, o)
    for i in range(2):
        st[_ST_XA + i] = k_dot(p, _P_AR + 4 * i, st, _ST_XR, 4) + p[_P_BR + i] * w
    st[_ST_ZM] = st[_ST_XR] - st[_ST_XR + 1]
    st[_ST_ZM + 1] = st[_ST_XR + 1] - w
    st[_ST_ZMD] = st[_ST_XR + 2] - st[_ST_XR + 3]
    st[_ST_ZMD + 1] = st[_ST_XR + 3] - wd
    st[_ST_ZMDD] = st[_ST_XA] - st[_ST_XA + 1]
    st[_ST_ZMDD + 1] = st[_ST_XA + 1] - wdd
    for i in range(2):
        st[_ST_E + i] = st[_ST_ZM + i] - y[iz + i]
        st[_ST_ED + i] = st[_ST_ZMD + i] - y[izd + i]
    for i in range(2):
        st[_ST_TH + i] = ((st[_ST_E] * p[_P_R2 + 2 * i] + st[_ST_E + 1] * p[_P_R2 + 2 * i + 1])
                          + (st[_ST_ED] * p[_P_R3 + 2 * i] + st[_ST_ED + 1] * p[_P_R3 + 2 * i + 1]))
    st[_ST_ONE] = 1.0
    a = p[5]
    b = p[6]
    sig = p[7]
    flags = int(p[8])
    nkeys = 7 if (flags & 1) != 0 else 3
    keep = (flags & 2) != 0
    normed = (flags & 4) != 0
    for kk in range(nkeys):
        tb = _P_KEYS + 5 * kk
        nk = int(p[tb])
        pb = int(p[tb + 1])
        io = int(p[tb + 2])
        go = int(p[tb + 3])
        ro = int(p[tb + 4])
        vs = p[pb]
        for j in range(nk):
            st[_ST_V + j] = st[ro + j] / vs
        nrm = 1.0
        if normed:
            nrm += k_dot(st, _ST_V, st, _ST_V, nk)
        for i in range(2):
            for j in range(nk):
                e = i * nk + j
                outer = st[_ST_TH + i] * st[_ST_V + j] * p[pb + 1 + 2 * nk + e] / nrm
                if keep and kk < 2 and i == 0:  # K_p, K_v row 0: one step for both entries (keep_cancellation)
                    outer = 0.5 * st[_ST_TH] * (st[_ST_V] * p[pb + 1 + 2 * nk] + st[_ST_V + 1] * p[pb + 2 + 2 * nk]) / nrm
                lim = p[pb + 1 + 4 * nk + e]
                ie = st[io + e] + (a * h * outer - sig * h * st[io + e])
                ie = min(max(ie, -lim), lim)
                st[io + e] = ie
                st[go + e] = p[pb + 1 + e] + ie + min(max(b * outer, -lim), lim)
    # tot = U_ax + M0 Z̈_m + C0 Ż_m + K0 Z_m + D0 ẅ + K_p E + K_v Ė (the table's G offsets, _KEYS order)
    gkp = int(p[_P_KEYS + 3])
    gkv = int(p[_P_KEYS + 5 + 3])
    gua = int(p[_P_KEYS + 10 + 3])
    gm0 = int(p[_P_KEYS + 15 + 3])
    gc0 = int(p[_P_KEYS + 20 + 3])
    gk0 = int(p[_P_KEYS + 25 + 3])
    gd0 = int(p[_P_KEYS + 30 + 3])
    for i in range(2):
        st[_ST_TOT + i] = (st[gua + i] + k_dot(st, gm0 + 2 * i, st, _ST_ZMDD, 2)
                           + k_dot(st, gc0 + 2 * i, st, _ST_ZMD, 2) + k_dot(st, gk0 + 2 * i, st, _ST_ZM, 2)
                           + st[gd0 + i] * wdd + k_dot(st, gkp + 2 * i, st, _ST_E, 2)
                           + k_dot(st, gkv + 2 * i, st, _ST_ED, 2))
    for i in range(2):
        u[i] = st[_ST_TOT] * p[_P_PI + 2 * i] + st[_ST_TOT + 1] * p[_P_PI + 2 * i + 1]
    zoh_update(p, st, _P_REF, 0, y, int(p[2]))
    st[_ST_RA] = st[_ST_XA]
    st[_ST_RX] = st[_ST_XR]


@CONTROLLERS.register("thesis_mdof_adaptive")
class MDOFAdaptive(Controller):
    """Thesis Ch. 6 MDOF continuous adaptive control (feedforward + feedback + auxiliary, PI adaptation laws) for the 2-DOF model."""

    Params = MDOFParams
    requires = ("travel", "travel_rate", "road", "road_vel")
    kernel = staticmethod(_kernel)

    def reset(self):
        super().reset()
        p, h = self.p, self.ctx.control_dt
        if self.ctx.n_corners != 2:
            from suspension_sim.errors import ScenarioError

            raise ScenarioError("thesis_mdof_adaptive needs the two-actuator model 'two_dof'", field="controller.type")
        Ms, Mp = shared_value(p.sprung_mass), shared_value(p.primary_mass)
        Ks, Cs = shared_value(p.secondary_stiffness), shared_value(p.secondary_damping)
        Kp, Cp = shared_value(p.primary_stiffness), shared_value(p.primary_lin_damping)
        self.M0 = np.array([[Ms, Ms], [0.0, Mp]])
        self.C0 = np.array([[Cs, 0.0], [-Cs, Cp]])
        self.K0 = np.array([[Ks, 0.0], [-Ks, Kp]])
        self.D0 = np.array([Ms, Mp])
        self.Pinv = np.linalg.inv(np.array([[1.0, 0.0], [-1.0, 1.0]]))
        we = 2 * np.pi * shared_value(p.error_freq)
        O1 = we * we * np.eye(2)
        O2 = 2 * shared_value(p.error_zeta) * we * np.eye(2)
        Kp0 = self.M0 @ O1 - self.K0
        Kv0 = self.M0 @ O2 - self.C0
        Om = np.block([[np.zeros((2, 2)), np.eye(2)], [-O1, -O2]])
        R = solve_continuous_lyapunov(Om.T, -np.eye(4))
        # normalise R so that Θ has the units of E scaled to ~1 at the error bandwidth
        self.R2, self.R3 = R[:2, 2:] * we * we, R[2:, 2:] * we * we
        self.O1, self.O2 = O1, O2
        # gains: nominal (G0) + integral part (I, starting at 0), each (2, k)
        self.G0 = {"kp": Kp0, "kv": Kv0, "uax": np.zeros((2, 1)), "m0": self.M0, "c0": self.C0, "k0": self.K0,
                   "d0": self.D0[:, None]}
        # regressor scales (typical magnitudes: 1 cm, 0.1 m/s, 1 kN-equivalent, 1 m/s², 0.1 m/s, 1 cm, 1 m/s²)
        self.v_scale = {"kp": 0.01, "kv": 0.1, "uax": 1.0, "m0": 1.0, "c0": 0.1, "k0": 0.01, "d0": 1.0}
        # per-entry scale of each gain matrix: its nominal entry, at least 10 % of its largest entry
        self.g_scale = {}
        for k, v in self.G0.items():
            a_ = np.abs(v)
            self.g_scale[k] = np.maximum(a_, 0.1 * a_.max()) if a_.max() > 0 else np.full(v.shape, 100.0)
        # reference: absolute states [x_ms, x_mp, ẋ_ms, ẋ_mp], input w; its masses and springs are the nominal
        # design's unless given (a wrong initial design keeps the thesis's reference: ref_* set explicitly)
        Dms, Dmp = shared_value(p.ref_skyhook_secondary), shared_value(p.ref_skyhook_primary)
        Mms, Mmp = ref_value(p.ref_sprung_mass, Ms), ref_value(p.ref_primary_mass, Mp)
        Kms, Kmp = ref_value(p.ref_secondary_stiffness, Ks), ref_value(p.ref_primary_stiffness, Kp)
        Mi = np.diag([1 / Mms, 1 / Mmp])
        Kr = np.array([[Kms, -Kms], [-Kms, Kms + Kmp]])
        Cr = np.diag([Dms, Dmp])
        A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ Kr, -Mi @ Cr]])
        B = np.concatenate([np.zeros(2), Mi @ np.array([0.0, Kmp])])[:, None]
        self.Ar, self.Br = A, B
        self.ref = ZOHFilter(A, B, np.eye(4), np.zeros((4, 1)), h)

    def kernel_data(self):
        n, p = self.ctx.n_cars, self.p
        lay = KernelLayout(n)
        off = [self.ctx.sensor_slice("travel")[0], self.ctx.sensor_slice("travel_rate")[0],
               self.ctx.sensor_slice("road")[1] - 1, self.ctx.sensor_slice("road_vel")[1] - 1]
        lay.p([float(o) for o in off] + [self.ctx.control_dt, shared_value(p.alpha), shared_value(p.beta),
                                         shared_value(p.sigma),
                                         float(bool(p.adapt_model)) + 2.0 * float(bool(p.keep_cancellation))
                                         + 4.0 * float(bool(p.normalised))])
        assert lay.p(self.R2) == _P_R2 and lay.p(self.R3) == _P_R3 and lay.p(self.Pinv) == _P_PI
        assert lay.p(self.Ar[2:]) == _P_AR and lay.p(self.Br[2:, 0]) == _P_BR
        assert lay.p(np.zeros(ZOH_HEADER + 5 * len(_KEYS))) == _P_REF
        assert lay.st(np.zeros(_ST_N)) == 0  # signals, ẇ_prev (not yet set), scratch
        reg = {"kp": _ST_E, "kv": _ST_ED, "uax": _ST_ONE, "m0": _ST_ZMDD, "c0": _ST_ZMD, "k0": _ST_ZM, "d0": _ST_WDD}
        table = []
        for k in _KEYS:
            g0 = np.asarray(self.G0[k], dtype=float)
            gl = shared_value(p.gain_limit) if p.gain_limit is not None else np.inf
            lim = gl * self.g_scale[k]
            pb = lay.p(np.concatenate([[self.v_scale[k]], g0.ravel(), self.g_scale[k].ravel(), lim.ravel()]))
            io = lay.st(np.zeros(g0.size))  # integral part I
            go = lay.st(g0.ravel())  # gain G
            table += [g0.shape[1], pb, io, go, reg[k]]
        lay.set_p(_P_REF + ZOH_HEADER, table)
        self.ref.pack(lay, _P_REF)
        self._kgo = {k: (int(table[5 * i + 2]), int(table[5 * i + 3])) for i, k in enumerate(_KEYS)}
        return lay.arrays()

    def kernel_signals(self):
        if not hasattr(self, "_kgo"):
            self.kernel_data()
        gkp, gkv, gua = self._kgo["kp"][1], self._kgo["kv"][1], self._kgo["uax"][1]
        return {"ref_z": (_ST_ZM, _ST_ZM + 2), "err": (_ST_E, _ST_E + 2), "ref_acc": (_ST_RA, _ST_RA + 1),
                "ref_x": (_ST_RX, _ST_RX + 1), "kp": (gkp, gkp + 4), "kv": (gkv, gkv + 4), "uax": (gua, gua + 2)}
