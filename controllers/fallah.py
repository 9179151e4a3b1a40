"""Robust bang-bang control with an affine parameter-dependent Lyapunov function (Fallah, Sorniotti &
Gruber, *A novel robust optimal active control of vehicle suspension systems*), one controller per corner,
with the paper's state estimation from a 6-axis IMU at the c.g. and one LVDT per corner.

Model (their Eq. 3), per corner, states x = [z_s, ż_s, z_s − z_u, ż_s − ż_u]:

    ẋ = A(m_s)·x + B1·u + B2·z_r,   u = f/f_max,  1/m_e = −(1/m_s + 1/m_u)
    A = [[0, 1, 0, 0], [0, 0, −k_s/m_s, −b_s/m_s], [0, 0, 0, 1], [k_t/m_u, 0, k_s/m_e − k_t/m_u, b_s/m_e]]
    B1 = [0, −1/m_s, 0, 1/m_e]ᵀ

In the paper u > 0 pulls the body down and the wheel up (B1); our actuator force is positive upward on the
body, so F = −f.  The corner's m_s is its static sprung load / g, m_u, k_s, b_s, k_t are the vehicle's
(per axle) parameters; all can be overridden.

Uncertainty and LMIs (Eqs. 14–16).  The sprung mass is uncertain by ±``mass_uncertainty`` (10 %).  A is
affine in 1/m_s, not in m_s, so the uncertain parameter is θ ∈ [−1, 1] with 1/m_s = q_c + θ·q_h spanning
[1/(1.1 m_s), 1/(0.9 m_s)] (the paper writes θ ∈ [m_s_min, m_s_max]; reconstructed so that A(θ) = A0 + θ·A1
is exactly affine).  P(θ) = P0 + θ·P1 must satisfy, at the two vertices θ = ±1,

    P(θ) > 0,   A(θ)ᵀP(θ) + P(θ)A(θ) + Q ≤ 0,      and   A1ᵀP1 + P1A1 ≥ 0   (multi-convexity)

(5 LMIs, the paper's 2^(N+1) + N with N = 1), which by multi-convexity hold for every θ ∈ [−1, 1].  The
paper states a feasibility problem; its solution set is a cone, so the switching direction B1ᵀP would be
arbitrary.  Chosen here: the term Q > 0 (a comfort weighting, ``q_weights`` on the scaled states) and the
objective "minimise trace(P0)", which makes xᵀP(θ)x the least robust upper bound of the passive cost
∫xᵀQx dt.  Default Q = diag(100, 4, 1, 0.1) on the scaled states (scales 5 cm, 0.2 m/s, 5 cm,
0.5 m/s): weighting the body displacement heavily gives a switching function whose z_s term is small
(s ≈ −1.1·z_s + ż_s + 3.7·Δ + 0.013·Δ̇ for the front corner of the full car).  With Q = diag(1, 4, 1, 0.1) the
z_s term is −3.2: a strong positive feedback on the (drifting, mean-removed) displacement estimate, and the
controlled body then wandered slowly after the bump (RMS displacement +44 % against passive, while the
heave acceleration still dropped 47 %).  On the full-car bump, diag(100, 4, 1, 0.1) gives −53 % RMS heave
acceleration and −21 % RMS displacement; on the DLC −68 % RMS roll acceleration and −33 % RMS roll.  The states are scaled by ``state_scales`` before the SDP for conditioning.  Solved with cvxpy and
an open-source conic solver (Clarabel, else SCS); infeasibility raises a one-line ScenarioError.

Control law.  Eq. (17): f = −f_max·sgn(B1ᵀP(θ)x), evaluated at the nominal θ = 0 (m_s is unknown to the
controller; ``theta`` sets another value).  Eq. (18) as printed, f = −f_max/(1 + e^(−a·B1ᵀPx + c)), is
one-sided (0 … −f_max), which cannot be the smoothed sign function it is said to replace (in our convention
F = f_max/(1 + e^(a·s + c)) = (symmetric F + f_max)/2: half the gain and a constant f_max/2 upward; run as
``sigmoid: printed``, the variant ``fallah_printed_sigmoid``); reconstructed as the symmetric sigmoid 2/(1 + e^(−a·s − c)) − 1 (= tanh(a·s/2) for c = 0; → sgn(s) as a → ∞).  The switching
function is normalised so that it reads in m/s: s = B1ᵀPx / |B1ᵀP·e2| (e2 = the ż_s direction), so ``a``
(s/m) fixes the body velocity at which the force saturates (a = 4 s/m: 76 % of f_max at 0.5 m/s), and the
small-signal gain a·f_max/2 is a skyhook-like damping (N·s/m).  With s oriented so that s ≈ ż_s + …, the
paper's f = −f_max·sgn(B1ᵀPx) becomes, in our sign convention (F = −f) and smoothed,

    F = −f_max·(2/(1 + e^(−(a·s + c))) − 1).

State estimation (Section 4), from the sensors only:

- suspension deflection Δ = z_s − z_u: the LVDT (``travel``);
- its rate by the hybrid smooth (one-sided, noise-robust) differentiator, Eq. (19).  The printed
  coefficients (16, 1, 10, −10, −6, 9)/28 do not sum to zero (not a derivative); reconstructed as
  (16Δ0 + Δ1 − 10Δ2 − 10Δ3 − 6Δ4 + 9Δ5)/(28Δt), Δi = Δ(t − iΔt), which is exact for quadratics
  (Σc_i = 0, Σ i·c_i = −28, Σ i²c_i = 0) — the one-sided smooth differentiator of Holoborodko;
- c.g. heave velocity: the IMU's vertical acceleration integrated (trapezoidal), minus the mean of the
  integrated velocity since t = 0 (the paper: "at each time instant the mean of velocity over integration
  interval time is subtracted", read literally: the default, ``mean_window`` null); ``mean_window`` = T
  takes the mean over the last T seconds instead (ours; the variant ``fallah_window`` of the scenarios, 2 s);
- corner body velocity, Eqs. (21)–(23): ż_s = ż_cg + (ω × r)_z with ω = (φ̇, θ̇, 0) from the gyros and
  r = (x_c, y_c, 0) the corner position: ż_s = ż_cg + y_c·φ̇ − x_c·θ̇ (roll positive = right side down,
  pitch positive = nose down; the printed r matrix is garbled, this is the geometry);
- z_s: the corner velocity integrated, "the state z_s is estimated from integration of (21)" (the default);
  ``position_mean_removal`` also removes the same mean from it (ours, in ``fallah_window``: without removal
  the double integral drifts, about −0.8 cm by the end of the bump run).

Signals logged (``ctrl.<name>.<corner index>``): the estimates ``zs_hat``, ``vs_hat``, ``dv_hat``
(Δ̇ estimate) and the switching function ``s``; the truth is in the run log (``body_z``, ``pitch``, ``roll``
and their rates, ``travel_rate``).

The estimation and the law are written once, as the numba function ``_kernel`` (one car); the compiled loop
inlines it and the base class runs it over the ensemble in the Python loop.
"""
from __future__ import annotations

from typing import Literal, Optional

import numba
import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.errors import ScenarioError
from suspension_sim.registry import CONTROLLERS

from .base import Controller, block_offsets

G = 9.81
HYBRID_COEFS = np.array([16.0, 1.0, -10.0, -10.0, -6.0, 9.0]) / 28.0  # Eq. (19), reconstructed


class FallahParams(Params):
    f_max: float = Field(6000.0, gt=0, description="N, actuator force limit (the paper: 6000 N)")
    a: float = Field(4.0, gt=0, description="s/m, sigmoid slope on the normalised switching function (m/s)")
    c: float = Field(0.0, description="sigmoid centre shift (dimensionless; 0 = symmetric)")
    mass_uncertainty: float = Field(0.10, ge=0, lt=1, description="relative sprung-mass uncertainty (±)")
    theta: float = Field(0.0, ge=-1, le=1, description="θ at which P(θ) and B1 are evaluated (0 = nominal)")
    q_weights: list[float] = Field([100.0, 4.0, 1.0, 0.1], min_length=4, max_length=4,
                                   description="Q diagonal on the scaled states [z_s, ż_s, Δ, Δ̇] (see docstring)")
    state_scales: list[float] = Field([0.05, 0.2, 0.05, 0.5], min_length=4, max_length=4,
                                      description="m, m/s, m, m/s: state scaling for the SDP")
    lmi_margin: float = Field(1e-6, ge=0, description="strictness margin of the LMIs (on the scaled problem)")
    solver: Optional[str] = Field(None, description="cvxpy solver name (default: CLARABEL, else SCS)")
    mean_window: Optional[float] = Field(None, gt=0, description="s, moving window of the velocity mean removal; "
                                         "null (the paper as printed) = the running mean since t = 0")
    position_mean_removal: bool = Field(False, description="remove the same mean from the integrated z_s too "
                                        "(ours; the paper integrates (21) plainly)")
    sigmoid: Literal["symmetric", "printed"] = Field(
        "symmetric", description="Eq. (18): 'symmetric' (our reconstruction, 2/(1 + e^(-(a*s + c))) - 1) or "
        "'printed' (the paper's one-sided f = -f_max/(1 + e^(-a*B1'Px + c)): F from 0 to +f_max)")
    # sensor names
    acc_sensor: str = Field("body_acc", description="IMU accelerometer (first component: heave, m/s²)")
    gyro_sensor: Optional[str] = Field("gyro", description="IMU rate gyros (pitch/roll rates); null = none")
    travel_sensor: str = Field("travel", description="LVDTs: suspension deflection per corner")
    # quarter-car data per corner (default: from the vehicle; a value or one per corner)
    sprung_mass: Optional[list[float] | float] = Field(None, description="kg per corner (default: static load/g)")
    unsprung_mass: Optional[list[float] | float] = None
    spring_stiffness: Optional[list[float] | float] = None
    damping: Optional[list[float] | float] = None
    tire_stiffness: Optional[list[float] | float] = None


def quarter_car_matrices(ms, mu, ks, bs, kt):
    """A, B1, B2 of Eq. (3) (the paper's sign of u: positive pulls the body down)."""
    ime = -(1.0 / ms + 1.0 / mu)
    A = np.array([[0, 1, 0, 0],
                  [0, 0, -ks / ms, -bs / ms],
                  [0, 0, 0, 1],
                  [kt / mu, 0, ks * ime - kt / mu, bs * ime]], dtype=float)
    B1 = np.array([0.0, -1.0 / ms, 0.0, ime])
    B2 = np.array([0.0, 0.0, 0.0, -kt / mu])
    return A, B1, B2


def affine_model(ms, mu, ks, bs, kt, rel: float):
    """A0, A1 with A(θ) = A0 + θ·A1 exact for 1/m_s = q_c + θ·q_h, θ ∈ [−1, 1], m_s ∈ [(1−rel)m, (1+rel)m]."""
    q_lo, q_hi = 1.0 / ((1 + rel) * ms), 1.0 / ((1 - rel) * ms)
    Aa, _, _ = quarter_car_matrices(1.0 / q_lo, mu, ks, bs, kt)
    Ab, _, _ = quarter_car_matrices(1.0 / q_hi, mu, ks, bs, kt)
    return 0.5 * (Aa + Ab), 0.5 * (Ab - Aa)


def solve_lmis(A0, A1, Q, margin=1e-6, solver=None):
    """P0, P1 of P(θ) = P0 + θP1 from the LMIs (14)–(16) with Q (see module docstring); raises ScenarioError
    when infeasible."""
    import cvxpy as cp

    n = A0.shape[0]
    P0 = cp.Variable((n, n), symmetric=True)
    P1 = cp.Variable((n, n), symmetric=True)
    I = np.eye(n)
    cons = []
    for th in (-1.0, 1.0):
        A = A0 + th * A1
        P = P0 + th * P1
        cons += [P >> margin * I, A.T @ P + P @ A + Q << -margin * I]
    cons += [A1.T @ P1 + P1 @ A1 >> 0]
    prob = cp.Problem(cp.Minimize(cp.trace(P0)), cons)
    names = [solver] if solver else [s for s in ("CLARABEL", "SCS") if s in cp.installed_solvers()]
    if not names:
        raise ScenarioError("no SDP solver for cvxpy (install clarabel or scs)", field="controller.params.solver")
    status = None
    for s in names:
        try:
            prob.solve(solver=s)
            status = prob.status
        except cp.error.SolverError as err:  # try the next solver
            status = f"solver error ({err})"
            continue
        if status in ("optimal", "optimal_inaccurate") and _lmis_hold(A0, A1, P0.value, P1.value, Q):
            return np.asarray(P0.value), np.asarray(P1.value)
        status = f"{status}, LMIs violated by the returned P" if status.startswith("optimal") else status
    raise ScenarioError(f"LMIs (14)-(16) infeasible for this corner's model (status: {status}); reduce "
                        f"mass_uncertainty or change q_weights", field="controller.params")


def _lmis_hold(A0, A1, P0, P1, Q, tol=1e-7) -> bool:
    """Check the solver's P0, P1: P(θ) > 0 and A(θ)ᵀP(θ) + P(θ)A(θ) + Q ≤ 0 at θ = ±1 (and on a grid,
    which multi-convexity implies), relative to the size of P."""
    if P0 is None or P1 is None:
        return False
    scale = max(np.abs(P0).max(), np.abs(Q).max(), 1e-300)
    for th in np.linspace(-1.0, 1.0, 11):
        A, P = A0 + th * A1, P0 + th * P1
        if np.linalg.eigvalsh(P).min() <= 0 or np.linalg.eigvalsh(A.T @ P + P @ A + Q).max() > tol * scale:
            return False
    return True


def _row(v) -> np.ndarray:
    """A 4-vector parameter shared by the ensemble (the first car's; must be equal for all)."""
    a = np.asarray(v, dtype=float).reshape(-1, 4)
    if not np.all(a == a[0]):
        raise ScenarioError("q_weights/state_scales must be the same for every car of an ensemble",
                            field="controller.params")
    return a[0]


def _axle_value(v, base: str, suffix: str):
    if hasattr(v, base):
        return getattr(v, base)
    ax = "front" if suffix in ("_front",) or suffix.startswith("_f") else "rear"
    if hasattr(v, f"{base}_{ax}"):
        return getattr(v, f"{base}_{ax}")
    raise ScenarioError(f"vehicle has no {base!r} for corner {suffix!r}: give controller.params.{base}",
                        field=f"controller.params.{base}")


def corner_quarter_cars(ctx, p) -> dict[str, np.ndarray]:
    """Quarter-car data of every corner, arrays (n_cars, n_corners): ms, mu, ks, bs, kt."""
    n, nc = ctx.n_cars, ctx.n_corners
    out = {}
    keys = {"ms": "sprung_mass", "mu": "unsprung_mass", "ks": "spring_stiffness", "bs": "damping",
            "kt": "tire_stiffness"}
    for k, base in keys.items():
        given = getattr(p, base)
        if given is not None:
            arr = np.asarray(given, dtype=float)
            arr = arr.reshape(arr.shape[0] if arr.ndim == 2 else 1, -1)
            out[k] = np.broadcast_to(arr, (n, nc)).astype(float)
        elif k == "ms":
            out[k] = np.asarray(ctx.static_suspension_force, dtype=float) / G
        else:
            cols = [np.broadcast_to(np.asarray(_axle_value(ctx.vehicle, base, s), dtype=float).reshape(-1), (n,))
                    for s in ctx.suffixes]
            out[k] = np.stack(cols, axis=1)
    return out


# the law ---------------------------------------------------------------------------------------------------
(_P_DT, _P_NW, _P_PMR, _P_A, _P_C, _P_FMAX, _P_OACC, _P_OPITCH, _P_OROLL, _P_OTRAV, _P_SIG) = range(11)
_NP = 11  # then per corner: K (4), corner x, corner y
(_S_K, _S_VINT, _S_APREV, _S_SUMV) = range(4)
_NS = 4  # then blocks of n_corners: hist (6), z_int, sum_z, zs, vs, dv, s, F; then buf_v (nw), buf_z (nw·nc)
# (nw = 0: the running mean since t = 0, no buffers)


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """Estimation (Section 4) and control (17)-(18) for one car: the hybrid differentiator (19) on the LVDT
    history, the trapezoidal integrals of the heave acceleration and of the corner velocities (21)-(23) with
    the moving-mean removal, the switching function s = K·x and the sigmoid F = −f_max·(2/(1 + e^(−(a·s + c))) − 1)."""
    nc = u.shape[0]
    dt = p[_P_DT]
    nw = int(p[_P_NW])
    k = int(st[_S_K])
    o_hist = _NS
    o_zint = o_hist + 6 * nc
    o_sumz = o_zint + nc
    o_zs = o_sumz + nc
    o_vs = o_zs + nc
    o_dv = o_vs + nc
    o_s = o_dv + nc
    o_F = o_s + nc
    o_bufv = o_F + nc
    o_bufz = o_bufv + nw
    acc = y[int(p[_P_OACC])]
    pitch_rate = y[int(p[_P_OPITCH])] if p[_P_OPITCH] >= 0 else 0.0
    roll_rate = y[int(p[_P_OROLL])] if p[_P_OROLL] >= 0 else 0.0
    # LVDT history and the hybrid differentiator (19)
    otr = int(p[_P_OTRAV])
    for c in range(nc):
        travel = y[otr + c]
        for i in range(5, 0, -1):
            st[o_hist + i * nc + c] = st[o_hist + (i - 1) * nc + c]
        st[o_hist + c] = travel
        if k == 0:
            for i in range(1, 6):
                st[o_hist + i * nc + c] = travel
        acc_dv = 0.0
        for i in range(6):
            acc_dv += HYBRID_COEFS[i] * st[o_hist + i * nc + c]
        st[o_dv + c] = acc_dv / dt
    # c.g. heave velocity with the moving-mean removal
    if k > 0:
        st[_S_VINT] = st[_S_VINT] + 0.5 * (acc + st[_S_APREV]) * dt
    st[_S_APREV] = acc
    v_int = st[_S_VINT]
    if nw > 0:  # moving window of nw samples (ours)
        j = k % nw
        cnt = min(k + 1, nw)
        st[_S_SUMV] += v_int - st[o_bufv + j]
        st[o_bufv + j] = v_int
    else:  # the running mean since t = 0 (the paper's "mean of velocity over integration interval time")
        j = 0
        cnt = k + 1
        st[_S_SUMV] += v_int
    v_cg = v_int - st[_S_SUMV] / cnt
    pmr = p[_P_PMR] != 0.0
    fmax, a, cc = p[_P_FMAX], p[_P_A], p[_P_C]
    for c in range(nc):
        pc = _NP + 6 * c
        vs = v_cg + p[pc + 5] * roll_rate - p[pc + 4] * pitch_rate
        z = st[o_zint + c]
        if k > 0:
            z = z + 0.5 * (vs + st[o_vs + c]) * dt
            st[o_zint + c] = z
        st[o_vs + c] = vs
        if pmr:
            if nw > 0:
                st[o_sumz + c] += z - st[o_bufz + j * nc + c]
                st[o_bufz + j * nc + c] = z
            else:
                st[o_sumz + c] += z
            zs = z - st[o_sumz + c] / cnt
        else:
            zs = z
        st[o_zs + c] = zs
        sw = p[pc] * zs + p[pc + 1] * vs + p[pc + 2] * y[otr + c] + p[pc + 3] * st[o_dv + c]
        st[o_s + c] = sw
        arg = a * sw + cc
        arg = min(max(arg, -500.0), 500.0)
        if p[_P_SIG] != 0.0:  # Eq. (18) as printed: f = -f_max/(1 + e^(-a*B1'Px + c)), F = -f, B1'Px ∝ -s
            F = fmax / (1.0 + np.exp(arg))
        else:
            F = -fmax * (2.0 / (1.0 + np.exp(-arg)) - 1.0)
        st[o_F + c] = F
        u[c] = F
    st[_S_K] = k + 1


@CONTROLLERS.register("fallah")
class Fallah(Controller):
    """Fallah–Sorniotti–Gruber robust bang-bang (affine Lyapunov LMIs, sigmoid) with IMU + LVDT estimation."""

    Params = FallahParams
    kernel = staticmethod(_kernel)

    @classmethod
    def required_sensors(cls, raw):
        req = [raw.get("acc_sensor", "body_acc"), raw.get("travel_sensor", "travel")]
        g = raw.get("gyro_sensor", "gyro")
        if g:
            req.append(g)
        return req

    def __init__(self, p, ctx):
        self.p, self.ctx = p, ctx
        self._design()
        self.reset()

    # -- design -----------------------------------------------------------------------------------------
    def _scalar(self, name):
        v = np.asarray(getattr(self.p, name), dtype=float)
        if v.size and not np.all(v == v.flat[0]):
            raise ScenarioError(f"{name} must be the same for every car of an ensemble", field=f"controller.params.{name}")
        return float(v.flat[0])

    def _design(self):
        ctx, p = self.ctx, self.p
        n, nc = ctx.n_cars, ctx.n_corners
        qc = corner_quarter_cars(ctx, p)
        self.qc = qc
        rel = self._scalar("mass_uncertainty")
        theta = self._scalar("theta")
        # 4-lists are stacked like per-corner lists ((n_cars, 4) arrays, or lists of lists): one row per car
        S = np.diag(_row(p.q_weights))
        scales = _row(p.state_scales)
        Sc = np.diag(scales)
        Si = np.diag(1.0 / scales)
        self.K = np.zeros((n, nc, 4))  # s = K·x (normalised switching function, m/s)
        self.P0 = np.zeros((n, nc, 4, 4))
        self.P1 = np.zeros((n, nc, 4, 4))
        cache = {}
        for i in range(n):
            for c in range(nc):
                vals = tuple(float(qc[k][i, c]) for k in ("ms", "mu", "ks", "bs", "kt"))
                key = (vals, rel)
                if key not in cache:
                    A0, A1 = affine_model(*vals, rel)
                    # scaled coordinates x = Sc·x̃: Ã = Sc⁻¹ A Sc, P = Sc⁻¹ P̃ Sc⁻¹
                    Pt0, Pt1 = solve_lmis(Si @ A0 @ Sc, Si @ A1 @ Sc, S, self._scalar("lmi_margin"), p.solver)
                    cache[key] = (Si @ Pt0 @ Si, Si @ Pt1 @ Si)
                P0, P1 = cache[key]
                self.P0[i, c], self.P1[i, c] = P0, P1
                ms = vals[0]
                q_lo, q_hi = 1.0 / ((1 + rel) * ms), 1.0 / ((1 - rel) * ms)
                m_theta = 1.0 / (0.5 * (q_lo + q_hi) + theta * 0.5 * (q_hi - q_lo))
                _, B1, _ = quarter_car_matrices(m_theta, *vals[1:])
                g = B1 @ (P0 + theta * P1)  # B1ᵀ P(θ)
                if abs(g[1]) < 1e-300:
                    raise ScenarioError("switching function has no body-velocity term", field="controller.params")
                # orient and normalise, s = −g·x/|g_2| (≈ ż_s + …): the paper's f = −f_max·sgn(g·x), ours
                # F = −f = f_max·sgn(g·x) = −f_max·sgn(s)
                self.K[i, c] = -g / abs(g[1])

    def reset(self):
        super().reset()
        mw = np.asarray(self.p.mean_window, dtype=object).reshape(-1)
        if all(m is None for m in mw):
            self.nw = 0  # the running mean since t = 0
        elif any(m is None for m in mw):
            raise ScenarioError("mean_window must be the same for every car of an ensemble",
                                field="controller.params.mean_window")
        else:
            self.nw = max(1, int(round(self._scalar("mean_window") / self.ctx.control_dt)))

    def _kernel_layout(self):
        """Offsets of the kernel's state blocks (after the _NS scalars); must match _kernel."""
        nc = self.ctx.n_corners
        return block_offsets(_NS, (("hist", 6 * nc), ("z_int", nc), ("sum_z", nc), ("zs", nc), ("vs", nc),
                                   ("dv", nc), ("s", nc), ("F", nc), ("buf_v", self.nw), ("buf_z", self.nw * nc)))

    def kernel_data(self):
        n, nc, p, col = self.ctx.n_cars, self.ctx.n_corners, self.p, self.per_car
        start = self.ctx.reading_start
        P = np.zeros((n, _NP + 6 * nc))
        P[:, _P_DT], P[:, _P_NW] = self.ctx.control_dt, self.nw
        P[:, _P_PMR] = col(p.position_mean_removal)  # may differ per car
        P[:, _P_A], P[:, _P_C], P[:, _P_FMAX] = col(p.a), col(p.c), col(p.f_max)
        sig = np.asarray(p.sigmoid, dtype=object).reshape(-1)
        P[:, _P_SIG] = np.broadcast_to(np.array([x == "printed" for x in sig], dtype=float), (n,))
        P[:, _P_OACC] = start(p.acc_sensor)  # its first component: heave
        labels = self.ctx.sensors.get(p.gyro_sensor, []) if p.gyro_sensor else []
        g0 = start(p.gyro_sensor) if p.gyro_sensor else 0
        P[:, _P_OPITCH] = g0 + labels.index("pitch") if "pitch" in labels else -1.0
        P[:, _P_OROLL] = g0 + labels.index("roll") if "roll" in labels else -1.0
        P[:, _P_OTRAV] = start(p.travel_sensor)
        cx = np.broadcast_to(np.asarray(self.ctx.corner_x, dtype=float).reshape(1, nc, 1), (n, nc, 1))
        cy = np.broadcast_to(np.asarray(self.ctx.corner_y, dtype=float).reshape(1, nc, 1), (n, nc, 1))
        P[:, _NP:] = np.concatenate([self.K, cx, cy], axis=-1).reshape(n, -1)
        return P, np.zeros((n, self._kernel_layout()["_next"]))

    def kernel_signals(self):
        o, nc = self._kernel_layout(), self.ctx.n_corners
        return {"zs_hat": (o["zs"], o["zs"] + nc), "vs_hat": (o["vs"], o["vs"] + nc),
                "dv_hat": (o["dv"], o["dv"] + nc), "s": (o["s"], o["s"] + nc)}
