"""Continuous nonlinear adaptive control with fuzzy-basis approximators (Toscano & Dumas, *Continuous
nonlinear adaptive control of an active vehicle suspension*, IFAC 2002), per corner.

Plant (their Eq. 10), with Δx = x_m − x_M (wheel − body) = −travel and Δv = −travel rate:

    M·v̇_M = f_k(Δx)·Δx + f_b(Δv)·Δv + F_m

f_k (a secant stiffness) and f_b (a secant damping) are unknown.  Goal: the suspension behaves as the
reference stiffness k_r and damping b_r (Eq. 11; the paper uses k_r = 10000 N/m, b_r = 1000 N·s/m).

- Approximators (15)–(18): f̂_k(Δx) = Σ β̂_k^i ψ_k^i(Δx), f̂_b(Δv) = Σ β̂_b^i ψ_b^i(Δv), ψ^i = μ^i / Σμ
  (singleton consequents, product inference, centre of gravity).  ``membership``:

  * ``triangular`` with 2 rules (default): the paper's Eqs. (32)–(33), rules "if Δ is A then β¹", "if Δ is
    not A then β²", μ_A(Δ) = max(min(αΔ + 1, 1 − αΔ), 0), ψ¹ = μ_A, ψ² = 1 − μ_A, α_k = 50√2/(17√ln2)
    ≈ 5.0 /m, α_b = √2/(34√ln2) ≈ 0.05 s/m (half-widths 0.2 m and 20 m/s: the ranges Δx ∈ [−0.2, 0.2],
    Δv ∈ [−20, 20] of (32));
  * ``triangular`` with N > 2 rules: triangles centred on the uniform grid m_i of (16) over the range,
    half-width one grid spacing (a partition of unity; the printed Table 2 parametrisation is garbled);
  * ``gaussian``: μ_i = exp(−½((Δ − m_i)/σ)²) with m_i and σ of Eq. (16).

- Estimator (20): dv̂_M/dt = −α(v̂_M − v_M) + [f̂_k Δx + f̂_b Δv + F_m]/M, error ṽ = v_M − v̂_M.
- Gradient law (27): dβ̂_k^i/dt = (λ_k/M) ψ_k^i(Δx) Δx ṽ, dβ̂_b^i/dt = (λ_b/M) ψ_b^i(Δv) Δv ṽ.
- Control (28): F_m = (k_r − f̂_k(Δx))·Δx + (b_r − f̂_b(Δv))·Δv.

Not given by the paper, chosen: α = 200 1/s; λ_k = 1e12, λ_b = 1e10.  ṽ is the error e/M filtered by
1/(s + α), so the adaptation rate is about λ·(ψΔ)²/(α·M²) and the filter's phase lag at the body-motion
frequencies degrades the gradient direction unless α is well above them (α = 20 1/s, 43° at 3 Hz, tracked the
paper's time-varying stiffness with 0.8× the error of the constant nominal guess; α = 200 with λ scaled
accordingly, 0.56×).  With Δx ≈ 1–2 cm and Δv ≈ 0.2 m/s the constant-case estimates settle within ≈ 1 s.
Initial estimates ``beta_k0``, ``beta_b0`` (default 0: the controller starts knowing nothing, so F_m = k_r Δx + b_r Δv at first).

The known-parameter reference (not an adaptive law; a baseline the adaptive one should approach): with
``known_k_sine`` and/or ``known_b_sine`` = [amplitude, frequency Hz, phase rad] the estimates are *held* at the
schedule β̂_k^i(t) = beta_k0 + A_k·sin(2πf_k·t + φ_k), β̂_b^i(t) = beta_b0 + A_b·sin(2πf_b·t + φ_b) at every
control instant (every rule alike, so f̂ = the schedule exactly: the ψ sum to 1), with no adaptation; the one
not given is held at its constant beta_0.  Given the plant's true k_M(t), b_M(t) (the ``varying_stiffness``
effect's and a ``sine`` variation's convention, the same formula), the law (28) and the estimator (20) then act
with the truth: the controller the paper's adaptation tries to become.  With λ = 0 and no schedule the
estimates are held at beta_0 (the constant known-parameter case).  F_m in the estimator
is the commanded force (``force_sensor`` = an actuator_force sensor name uses the measured force instead).
M defaults to the corner's static load / g.

Sensors: ``travel`` (Δx = −travel), ``travel_rate`` (Δv = −rate) and the body velocity above the corner
(``corner_body_vel``), as the paper's state feedback assumes.  Signals: ``fk_hat``, ``fb_hat`` (the
estimated stiffness and damping at the current Δx, Δv), ``v_err`` (ṽ), ``beta_k.i``, ``beta_b.i``.

The law is written once, as the numba function ``_kernel`` (one car; sums in numpy's pairwise order); the
compiled loop inlines it and the base class runs it over the ensemble in the Python loop.
"""
from __future__ import annotations

from typing import Literal, Optional

import numba
import numpy as np
from pydantic import Field

from suspension_sim.compiled.numpy_order import pairwise_sum
from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller, block_offsets

G = 9.81
LN2 = np.log(2.0)
ALPHA_K = 50 * np.sqrt(2) / (17 * np.sqrt(LN2))  # Eq. (33), 1/m
ALPHA_B = np.sqrt(2) / (34 * np.sqrt(LN2))  # Eq. (33), s/m


class ToscanoDumasParams(Params):
    k_ref: float = Field(10000.0, ge=0, description="reference stiffness k_M^r, N/m")
    b_ref: float = Field(1000.0, ge=0, description="reference damping b_M^r, N·s/m")
    alpha: float = Field(200.0, gt=0, description="estimator gain α of Eq. (20), 1/s")
    lambda_k: float = Field(1e12, ge=0, description="adaptation gain λ_k of Eq. (27)")
    lambda_b: float = Field(1e10, ge=0, description="adaptation gain λ_b of Eq. (27)")
    membership: Literal["triangular", "gaussian"] = "triangular"
    n_rules_k: int = Field(2, ge=2, description="rules of f̂_k (2 = the paper's A / not-A pair)")
    n_rules_b: int = Field(2, ge=2, description="rules of f̂_b")
    range_dx: float = Field(0.2, gt=0, description="m, Δx ∈ [−range, range] (Eq. 32)")
    range_dv: float = Field(20.0, gt=0, description="m/s, Δv ∈ [−range, range] (Eq. 32)")
    beta_k0: float = Field(0.0, description="initial stiffness estimates β̂_k^i, N/m")
    beta_b0: float = Field(0.0, description="initial damping estimates β̂_b^i, N·s/m")
    body_mass: Optional[float] = Field(None, gt=0, description="kg, M (default: the corner's static load / g)")
    travel_sensor: str = "travel"
    rate_sensor: str = "travel_rate"
    velocity_sensor: str = "corner_body_vel"
    force_sensor: Optional[str] = Field(None, description="measured actuator force sensor for the estimator "
                                                          "(default: the commanded force)")
    known_k_sine: Optional[list[float]] = Field(
        None, min_length=3, max_length=3, description="[amplitude N/m, frequency Hz, phase rad]: hold the "
        "stiffness estimates at beta_k0 + A·sin(2πft + φ), no adaptation (the known-parameter reference)")
    known_b_sine: Optional[list[float]] = Field(
        None, min_length=3, max_length=3, description="[amplitude N·s/m, frequency Hz, phase rad]: hold the "
        "damping estimates at beta_b0 + A·sin(2πft + φ), no adaptation (the known-parameter reference)")


# the law ---------------------------------------------------------------------------------------------------
(_P_KREF, _P_BREF, _P_OTR, _P_ORATE, _P_OVEL, _P_OF, _P_NK, _P_NB, _P_MEMBK, _P_MEMBB, _P_AK, _P_AB, _P_HK,
 _P_HB, _P_HOLD, _P_K0, _P_KA, _P_KW, _P_KPH, _P_B0, _P_BA, _P_BW, _P_BPH) = range(23)
_NP = 23  # then the rule centres m_k (nk), m_b (nb), then per corner λ_k/M, λ_b/M, e^(−α·dt), M
# membership codes: 0 the two-rule triangle pair of Eq. (33), 1 triangles on a grid, 2 gaussians


@numba.njit(cache=True)
def _basis(u, nr, memb, alpha_two, m, lo_m, h, psi, lo):
    """The normalised fuzzy basis functions ψ_i(u) of a scalar u into psi[lo:lo+nr] (psi[lo+nr:lo+2nr] is
    scratch): memb 0 the paper's triangle pair (33) of slope alpha_two, 1 triangles of half-width h on the
    grid of rule centres m[lo_m:lo_m+nr] (the end ones held outside the range), 2 gaussians of width σ = h."""
    if memb == 0:
        a = alpha_two * u + 1.0
        b = 1.0 - alpha_two * u
        mu = a if (a <= b or a != a) else b  # np.minimum
        mu = mu if (mu >= 0.0 or mu != mu) else 0.0  # np.maximum
        psi[lo] = mu
        psi[lo + 1] = 1.0 - mu
        return
    w = lo + nr
    for i in range(nr):
        d = u - m[lo_m + i]
        if memb == 2:
            q = d / h
            psi[w + i] = np.exp(-0.5 * (q * q))
        else:
            x = 1.0 - np.abs(d) / h
            psi[w + i] = x if (x >= 0.0 or x != x) else 0.0
    if memb == 1:
        if u <= m[lo_m]:
            psi[w] = 1.0
        if u >= m[lo_m + nr - 1]:
            psi[w + nr - 1] = 1.0
    s = pairwise_sum(psi, w, nr)
    s = s if (s >= 1e-300 or s != s) else 1e-300
    for i in range(nr):
        psi[lo + i] = psi[w + i] / s


@numba.njit(cache=True)
def _expand(st, o_beta, o_psi, n, o_tmp):
    """f̂ = Σ β̂_i·ψ_i of the blocks st[o_beta:o_beta+n], st[o_psi:o_psi+n], summed in numpy's pairwise order
    (st[o_tmp:o_tmp+n] is scratch)."""
    for i in range(n):
        st[o_tmp + i] = st[o_beta + i] * st[o_psi + i]
    return pairwise_sum(st, o_tmp, n)


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: estimator (20) and gradient law (27) over the last control step (explicit Euler
    from the previous step's regressors, the α term exactly), then the control (28) with the new estimates.
    Held (p[_P_HOLD] = 1, the known-parameter reference): no gradient step, the estimates are set to their
    schedule at t instead."""
    nc = u.shape[0]
    nk, nb = int(p[_P_NK]), int(p[_P_NB])
    dt = st[1]
    first = st[0] == 0.0
    # state layout (see kernel_data): [started, dt] then per corner blocks
    o_vhat = 2
    o_dx0 = o_vhat + nc
    o_dv0 = o_dx0 + nc
    o_v0 = o_dv0 + nc
    o_F = o_v0 + nc
    o_fk = o_F + nc
    o_fb = o_fk + nc
    o_verr = o_fb + nc
    o_bk = o_verr + nc
    o_bb = o_bk + nc * nk
    o_pk0 = o_bb + nc * nb
    o_pb0 = o_pk0 + 2 * nc * nk
    o_tmp = o_pb0 + 2 * nc * nb  # products for the sums: max(nk, nb)
    m0 = _NP
    pc = _NP + nk + nb  # per corner: gk, gb, e, M
    for c in range(nc):
        dx = -y[int(p[_P_OTR]) + c]
        dv = -y[int(p[_P_ORATE]) + c]
        v = y[int(p[_P_OVEL]) + c]
        F_prev = y[int(p[_P_OF]) + c] if p[_P_OF] >= 0 else st[o_F + c]
        gk, gb, e, M = p[pc + 4 * c], p[pc + 4 * c + 1], p[pc + 4 * c + 2], p[pc + 4 * c + 3]
        if first:
            st[o_vhat + c] = v
        else:
            dx0, dv0 = st[o_dx0 + c], st[o_dv0 + c]
            fk0 = _expand(st, o_bk + c * nk, o_pk0 + 2 * c * nk, nk, o_tmp)
            fb0 = _expand(st, o_bb + c * nb, o_pb0 + 2 * c * nb, nb, o_tmp)
            drive = (fk0 * dx0 + fb0 * dv0 + F_prev) / M
            v_hat = e * st[o_vhat + c] + (1 - e) * st[o_v0 + c] + drive * dt
            st[o_vhat + c] = v_hat
            v_err = v - v_hat
            st[o_verr + c] = v_err
            if p[_P_HOLD] == 0.0:
                for i in range(nk):
                    st[o_bk + c * nk + i] = st[o_bk + c * nk + i] + dt * gk * st[o_pk0 + 2 * c * nk + i] * (dx0 * v_err)
                for i in range(nb):
                    st[o_bb + c * nb + i] = st[o_bb + c * nb + i] + dt * gb * st[o_pb0 + 2 * c * nb + i] * (dv0 * v_err)
        if p[_P_HOLD] != 0.0:  # the known-parameter reference: the estimates are the schedule (the truth)
            bk_t = p[_P_K0] + p[_P_KA] * np.sin(p[_P_KW] * t + p[_P_KPH])
            bb_t = p[_P_B0] + p[_P_BA] * np.sin(p[_P_BW] * t + p[_P_BPH])
            for i in range(nk):
                st[o_bk + c * nk + i] = bk_t
            for i in range(nb):
                st[o_bb + c * nb + i] = bb_t
        _basis(dx, nk, int(p[_P_MEMBK]), p[_P_AK], p, m0, p[_P_HK], st, o_pk0 + 2 * c * nk)
        _basis(dv, nb, int(p[_P_MEMBB]), p[_P_AB], p, m0 + nk, p[_P_HB], st, o_pb0 + 2 * c * nb)
        fk = _expand(st, o_bk + c * nk, o_pk0 + 2 * c * nk, nk, o_tmp)  # approximators (15)
        fb = _expand(st, o_bb + c * nb, o_pb0 + 2 * c * nb, nb, o_tmp)
        F = (p[_P_KREF] - fk) * dx + (p[_P_BREF] - fb) * dv
        st[o_fk + c] = fk
        st[o_fb + c] = fb
        st[o_F + c] = F
        st[o_dx0 + c] = dx
        st[o_dv0 + c] = dv
        st[o_v0 + c] = v
        u[c] = F
    st[0] = 1.0


@CONTROLLERS.register("toscano_dumas")
class ToscanoDumas(Controller):
    """Toscano–Dumas fuzzy adaptive compensation: the suspension follows a reference stiffness and damping."""

    Params = ToscanoDumasParams
    kernel = staticmethod(_kernel)

    @classmethod
    def required_sensors(cls, raw):
        req = [raw.get("travel_sensor", "travel"), raw.get("rate_sensor", "travel_rate"),
               raw.get("velocity_sensor", "corner_body_vel")]
        if raw.get("force_sensor"):
            req.append(raw["force_sensor"])
        return req

    def reset(self):
        super().reset()
        n, nc = self.ctx.n_cars, self.ctx.n_corners
        p = self.p
        self.nk, self.nb = int(np.max(p.n_rules_k)), int(np.max(p.n_rules_b))
        if isinstance(p.body_mass, list):  # given for some cars of the ensemble only
            static = np.asarray(self.ctx.static_suspension_force, float) / G
            self.M = np.stack([static[i] if m is None else np.full(nc, float(m)) for i, m in enumerate(p.body_mass)])
        elif p.body_mass is not None:
            self.M = np.broadcast_to(np.asarray(p.body_mass, float).reshape(-1, 1), (n, nc)).copy()
        else:
            self.M = np.asarray(self.ctx.static_suspension_force, float) / G
        self.memb = p.membership if isinstance(p.membership, str) else p.membership[0]

    def _kernel_layout(self):
        """Offsets of the kernel's state blocks (after [started, control_dt]); must match _kernel."""
        nc, nk, nb = self.ctx.n_corners, self.nk, self.nb
        return block_offsets(2, (("vhat", nc), ("dx0", nc), ("dv0", nc), ("v0", nc), ("F", nc), ("fk", nc),
                                 ("fb", nc), ("verr", nc), ("bk", nc * nk), ("bb", nc * nb), ("pk0", 2 * nc * nk),
                                 ("pb0", 2 * nc * nb), ("tmp", max(nk, nb))))

    def kernel_data(self):
        n, nc, p, col = self.ctx.n_cars, self.ctx.n_corners, self.p, self.per_car
        nk, nb = self.nk, self.nb

        P = np.zeros((n, _NP + nk + nb + 4 * nc))
        P[:, _P_KREF], P[:, _P_BREF] = col(p.k_ref), col(p.b_ref)
        start = self.ctx.reading_start
        P[:, _P_OTR], P[:, _P_ORATE], P[:, _P_OVEL] = (start(p.travel_sensor), start(p.rate_sensor),
                                                       start(p.velocity_sensor))
        P[:, _P_OF] = start(p.force_sensor) if p.force_sensor else -1.0
        P[:, _P_NK], P[:, _P_NB] = nk, nb
        P[:, _P_K0], P[:, _P_B0] = col(p.beta_k0), col(p.beta_b0)
        for j, (key, o_a) in enumerate((("known_k_sine", _P_KA), ("known_b_sine", _P_BA))):
            v = getattr(p, key)
            rows = v if (isinstance(v, list) and v and (v[0] is None or isinstance(v[0], list))) else [v] * n
            for i, r in enumerate(rows):  # per car: [A, f, φ] or None (held at beta_0 if the other is given)
                if r is not None:
                    P[i, _P_HOLD] = 1.0
                    P[i, o_a:o_a + 3] = r[0], 2 * np.pi * r[1], r[2]
        # the ranges and memberships are the ensemble's (the largest range)
        ukmax, ubmax = float(np.max(p.range_dx)), float(np.max(p.range_dv))
        P[:, _P_AK], P[:, _P_AB] = ALPHA_K * 0.2 / ukmax, ALPHA_B * 20.0 / ubmax  # the pair's slope
        for j, (nr, umax) in enumerate(((nk, ukmax), (nb, ubmax))):
            memb, h, m = basis_shape(nr, umax, self.memb)
            P[:, (_P_MEMBK, _P_MEMBB)[j]] = memb
            P[:, _P_HK + j] = h
            P[:, _NP + (0 if j == 0 else nk):_NP + (nk if j == 0 else nk + nb)] = m
        dt = self.ctx.control_dt
        e = np.broadcast_to(np.exp(-np.asarray(p.alpha, float) * dt), (n, nc))
        gk = np.broadcast_to(np.asarray(p.lambda_k, float) / self.M, (n, nc))
        gb = np.broadcast_to(np.asarray(p.lambda_b, float) / self.M, (n, nc))
        pc = np.stack([gk, gb, e, np.broadcast_to(self.M, (n, nc))], axis=-1)  # (n, nc, 4)
        P[:, _NP + nk + nb:] = pc.reshape(n, -1)
        o = self._kernel_layout()
        S = np.zeros((n, o["_next"]))
        S[:, 1] = dt
        S[:, o["bk"]:o["bk"] + nc * nk] = np.asarray(p.beta_k0, float).reshape(-1, 1)
        S[:, o["bb"]:o["bb"] + nc * nb] = np.asarray(p.beta_b0, float).reshape(-1, 1)
        return P, S

    def kernel_signals(self):
        o, nc = self._kernel_layout(), self.ctx.n_corners
        out = {"fk_hat": (o["fk"], o["fk"] + nc), "fb_hat": (o["fb"], o["fb"] + nc), "v_err": (o["verr"], o["verr"] + nc)}
        if nc == 1:
            out["beta_k"] = (o["bk"], o["bk"] + self.nk)
            out["beta_b"] = (o["bb"], o["bb"] + self.nb)
        return out


def basis_shape(n_rules: int, umax: float, membership: str) -> tuple[int, float, np.ndarray]:
    """(membership code, h, rule centres) of ``_basis`` for ``n_rules`` rules on [−umax, umax]: the grid m_i of
    Eq. (16), h the triangles' half-width (one grid spacing) or the gaussians' σ of Eq. (16)."""
    if membership == "gaussian":
        return 2, 2 * umax / (2 * np.sqrt(2 * LN2) * (n_rules - 1)), np.linspace(-umax, umax, n_rules)
    return (0 if n_rules == 2 else 1), 2 * umax / (n_rules - 1), np.linspace(-umax, umax, n_rules)


def basis(u, n_rules: int, umax: float, membership: str, alpha_two: float) -> np.ndarray:
    """The normalised fuzzy basis functions ψ_i(u) (the law's ``_basis``) for an array u: shape u.shape +
    (n_rules,)."""
    memb, h, m = basis_shape(n_rules, umax, membership)
    u = np.asarray(u, dtype=float)
    out = np.empty(u.size * 2 * n_rules)
    for j, x in enumerate(u.reshape(-1)):
        _basis(float(x), n_rules, memb, alpha_two, m, 0, h, out, 2 * n_rules * j)
    return out.reshape(u.size, 2 * n_rules)[:, :n_rules].reshape(u.shape + (n_rules,))
