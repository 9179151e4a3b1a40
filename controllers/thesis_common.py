"""Shared pieces of the thesis controllers (Vallurupalli 1996, Ch. 3–7).

Each thesis controller is its design (computed once in ``reset`` from its parameters), its law (a numba
kernel for one car, :mod:`suspension_sim.compiled`) and the layout of the kernel's rows ``p`` (parameters)
and ``st`` (state).  The base :class:`controllers.base.Controller` broadcasts the kernel over an ensemble
for the Python loop; the compiled loop inlines it.  This module holds what several of them share:

- design: :class:`ZOHFilter` (a continuous LTI filter discretised by zero-order hold), :func:`darma`,
  :func:`predictor`, :func:`theta_from_predictor`, :func:`am_poly`, the estimator design
  :class:`DiscreteMRAC`, and :func:`shared_value`;
- layout: :class:`KernelLayout`;
- kernel helpers: :func:`zoh_y` / :func:`zoh_yu` / :func:`zoh_update` (run a ZOHFilter), :func:`dm_step`
  (one step of the discrete MRAC of Ch. 4 and 7), the dot products and sums :func:`k_dot`,
  :func:`k_dot_seq`, :func:`k_sum_pw`, and :func:`stamped_cache`.

Not a controller itself (nothing is registered here).
"""
from __future__ import annotations

import hashlib
from pathlib import Path

import numba
import numpy as np
from scipy.signal import cont2discrete


def shared_value(x) -> float:
    """The single value of a stacked parameter.  The thesis controllers build one design (filters, DARMA
    model, Riccati gains) for the whole ensemble, so their parameters must be equal across its cars; an
    ensemble whose cars differ in them raises a ScenarioError (run such cars as separate simulations)."""
    a = np.asarray(x, dtype=float).reshape(-1)
    if a.size and not np.all(a == a[0]):
        from suspension_sim.errors import ScenarioError

        raise ScenarioError("the thesis controllers need the same controller parameters for every car of an "
                            "ensemble", field="controller.params")
    return float(a[0])


def ref_value(x, default: float) -> float:
    """A reference-model parameter that defaults to a nominal design value: ``default`` when ``x`` is None,
    else its single value (:func:`shared_value`).  The thesis's reference models are fixed ("coded in the
    controller"); a run started from a wrong initial design keeps them by giving them explicitly."""
    return float(default) if x is None else shared_value(x)


class ZOHFilter:
    """A continuous LTI filter (A, B, C, D) discretised by zero-order hold at ``dt``
    (``scipy.signal.cont2discrete``): x[k+1] = Ad x[k] + Bd u[k], y[k] = Cd x[k] + Dd u[k], run in a kernel
    as ``copies`` independent copies per car (:func:`zoh_y`, :func:`zoh_yu`, :func:`zoh_update`).

    The state holds the inputs up to k−1, so the output before this step's update lags the input by one
    sample when D = 0: a signal computed from the filter's own output can be fed back without an algebraic
    loop."""

    def __init__(self, A, B, C, D, dt: float, copies: int = 1, method: str = "zoh"):
        Ad, Bd, Cd, Dd, _ = cont2discrete((np.atleast_2d(A), np.atleast_2d(B), np.atleast_2d(C),
                                           np.atleast_2d(D)), dt, method=method)
        self.Ad, self.Bd, self.Cd, self.Dd = Ad, Bd, Cd, Dd
        self.copies = copies

    @classmethod
    def tf(cls, num, den, dt, copies=1):
        """From a transfer function (numerator/denominator coefficients, highest power first)."""
        from scipy.signal import tf2ss

        A, B, C, D = tf2ss(num, den)
        return cls(A, B, C, D, dt, copies)

    @property
    def n_states(self) -> int:
        return self.Ad.shape[0]

    def pack(self, lay, hp: int) -> int:
        """Place the filter in a KernelLayout: matrices in p, the zero state of every copy and a scratch in
        st, the header (ZOH_HEADER values) at the reserved p columns hp on.  Returns the state's first st
        column."""
        ns, nin, nout = self.n_states, self.Bd.shape[1], self.Cd.shape[0]
        po = lay.p(np.concatenate([self.Ad.ravel(), self.Bd.ravel(), self.Cd.ravel(), self.Dd.ravel()]))
        so = lay.st(np.zeros(self.copies * ns))
        sc = lay.st(np.zeros(ns))
        lay.set_p(hp, [po, ns, nin, nout, so, sc, float(np.any(self.Dd))])
        return so


def darma(Ac, Bc, Cc, dt):
    """DARMA form A(q⁻¹) Y[k] = B(q⁻¹) U[k] of a continuous 2nd-order-per-output MIMO model
    ẋ = Ac x + Bc u, y = Cc x with x = [y, ẏ] (2m states), by ZOH discretisation.  Returns the matrix
    coefficient lists A = [I, A1, A2] and B = [0, B1, B2] (B0 = 0: the ZOH delay of one step).

    The discrete state model x[k+1] = Φx[k] + Γu[k] of order 2m with m outputs is converted by the
    observability form: with O = [C; CΦ] invertible, Y[k+2] = CΦ²O⁻¹[Y[k]; Y[k+1]] + (terms in u)."""
    Phi, Gam, _, _, _ = cont2discrete((Ac, Bc, Cc, np.zeros((Cc.shape[0], Bc.shape[1]))), dt, method="zoh")
    m = Cc.shape[0]
    O = np.vstack([Cc, Cc @ Phi])
    L = Cc @ Phi @ Phi @ np.linalg.inv(O)  # Y[k+2] = L[:, :m] Y[k] + L[:, m:] Y[k+1] + ...
    # y[k+1] = CΦx + CΓu[k];  y[k+2] = CΦ²x + CΦΓu[k] + CΓu[k+1]
    # x = O⁻¹([y[k]; y[k+1]] − [0; CΓu[k]])
    Oi = np.linalg.inv(O)
    Lu = -(Cc @ Phi @ Phi @ Oi[:, m:]) @ (Cc @ Gam)  # effect of u[k] through the O⁻¹ correction
    A1 = -L[:, m:]
    A2 = -L[:, :m]
    B1 = Cc @ Gam  # coefficient of u[k+1] in y[k+2]  -> q⁻¹
    B2 = Cc @ Phi @ Gam + Lu  # coefficient of u[k] in y[k+2] -> q⁻²
    I = np.eye(m)
    return [I, A1, A2], [np.zeros_like(B1), B1, B2]


def predictor(A, B, am, d):
    """Goodwin–Sin d-step-ahead predictor (thesis Eqs. 4.47–4.49, matrix form of Ch. 7).

    Plant: A(q⁻¹) Y[k] = q⁻ᵈ B'(q⁻¹) U[k] where here ``B`` is given with its ZOH delay included
    (B[0] = 0) and ``d`` counts *extra* whole-sample delays (the loop delay).  ``am``: scalar reference
    polynomial coefficients [1, am1, am2].  Returns (D, alpha, beta): the total delay D = d + 1 and matrix
    coefficient lists with  am(q⁻¹) Y[k+D] = Σ alpha_i Y[k−i] + Σ beta_j U[k−j]  (i = 0, 1; j = 0..D).
    Solved by F(q⁻¹)A(q⁻¹) + q⁻ᴰG(q⁻¹) = am(q⁻¹)·I with F of degree D−1 (F0 = I), alpha = G,
    beta = F·B shifted by the delay."""
    m = A[0].shape[0]
    D = d + 1
    I = np.eye(m)
    am = list(am) + [0.0] * (D + 3)
    na = len(A) - 1
    F = [I.copy()]
    for j in range(1, D):
        Fj = am[j] * I - sum(F[j - i] @ A[i] for i in range(1, min(j, na) + 1))
        F.append(Fj)
    G = []
    for j in range(D, D + na):
        Gj = am[j] * I - sum(F[j - i] @ A[i] for i in range(1, na + 1) if 0 <= j - i < D)
        G.append(Gj)
    # F·B with B = [0, B1, B2]: coefficient of q^-(j+1) -> beta_j (the q^-1 absorbed in D)
    Bs = B[1:]
    beta = [np.zeros((m, Bs[0].shape[1])) for _ in range(D + len(Bs) - 1)]
    for i, Fi in enumerate(F):
        for j, Bj in enumerate(Bs):
            beta[i + j] += Fi @ Bj
    return D, G, beta


def theta_from_predictor(alpha, beta, with_bias=True):
    """Controller parameter matrix Θ (p × m) of the linear control law U[k] = Θᵀ φ[k] with
    φ[k] = [−Y[k], −Y[k−1], −U[k−1], …, −U[k−nb+1], −1, Ȳ*[k+D]] (thesis Eq. 4.55, matrix form):
    Θ = [β0⁻¹α0, β0⁻¹α1, β0⁻¹β1, …, β0⁻¹c, β0⁻¹]ᵀ.  The bias c (operating-point force: static load,
    manoeuvre moment) starts at 0."""
    Bi = np.linalg.inv(beta[0])
    blocks = [Bi @ a for a in alpha] + [Bi @ b for b in beta[1:]]
    if with_bias:
        blocks.append(np.zeros((Bi.shape[0], 1)))
    blocks.append(Bi)
    return np.hstack(blocks).T


def am_poly(wn: float, zeta: float, dt: float):
    """Discrete reference polynomial [1, am1, am2] with the poles of s² + 2ζωs + ω² mapped by z = e^(s·dt)."""
    poles = np.roots([1.0, 2 * zeta * wn, wn * wn])
    return np.real(np.poly(np.exp(poles * dt)))


class DiscreteMRAC:
    """Design of the discrete direct MRAC of thesis Ch. 4 (SISO) and Ch. 7 (MIMO, matrix least squares);
    the law is the kernel helper :func:`dm_step`.

    DARMA model A(q⁻¹)Y[k] = q⁻ᴰ B(q⁻¹) U[k] + c with m outputs and m inputs (``darma`` + ``predictor``);
    control law U[k] = Θᵀ φ[k] with φ[k] = [−Y[k], −Y[k−1], −U[k−1], …, −U[k−D], −1, Ȳ*[k+D]] where
    Ȳ*[k+D] = a_m(q⁻¹)Y*[k+D] is the filtered reference output; Θ is estimated by recursive least squares
    on the identity U[k−D] = Θᵀ φ̃[k−D] (φ̃ carries the measured Ȳ[k] = a_m(q⁻¹)Y[k] in its last block),
    with covariance addition q·I bounded by a trace limit (Vogel–Edgar, thesis Eq. 4.56:
    P ← P − Pφφᵀ P/(1 + φᵀPφ) + Q, Q dropped while trace(P) + trace(Q) would reach ``trace_max``) and one
    covariance P shared by the m columns of Θ (the thesis's matrix least squares).  After each update the
    β0⁻¹ block (the rows of Ȳ*) is projected: its diagonal keeps the sign of the nominal value and a
    magnitude between ``beta_inv_range`` × nominal (the thesis's sign/magnitude constraint on (β0)⁻¹).
    The same update with an instrument z in place of φ̃ in Pφ (P ← P − Pzφ̃ᵀP/(1 + φ̃ᵀPz) + Q) is recursive
    instrumental variables (:func:`dm_step`'s ``zo``; ``thesis_mimo_mrac``'s ``estimator: iv_probe``, ours).

    ``kappa`` < 1 weights the control increments (Goodwin–Sin weighted one-step-ahead control with the
    cost (Y − Y*)² + λ(ΔU)², κ = β0²/(β0² + λ)): U[k] = κ·Θᵀφ[k] + (1 − κ)·U[k−1].  The pure d-step-ahead
    law (κ = 1, the thesis) cancels the zero that zero-order-hold sampling puts near z = −1 for a
    relative-degree-two plant, so its control rings at the Nyquist frequency; κ < 1 removes the
    cancellation and keeps zero steady-state error (the estimator's identity holds for any input).

    ``bias=False`` (the printed φ, which has no constant) zeroes the bias row's regressor entry, initial
    covariance and covariance addition: its parameter stays at 0 and the law is the printed one.

    ``p0_bias``/``q_bias`` give the bias parameter (the operating-point force) its own initial covariance
    and covariance addition, so that it can track load changes quickly while the model parameters adapt
    slowly (less drift when the excitation is poor, e.g. a manoeuvre on a flat road).

    The regressor is scaled by the nominal magnitudes of Θ (parameters of order 1), so one scalar ``p0``
    and ``q`` serve all entries; the kernel state holds the scaled Θ.
    """

    def __init__(self, theta0, m, D, am, p0, q, trace_max, beta_inv_range=(0.2, 5.0), u_max=None,
                 bias_scale=1000.0, kappa=1.0, p0_bias=None, q_bias=None, bias=True):
        self.kappa = kappa
        self.bias = bool(bias)
        self.m, self.D, self.am = m, D, np.asarray(am, dtype=float)
        theta0 = np.asarray(theta0, dtype=float)
        self.npar = theta0.shape[0]
        # scaling: per-row magnitude of the nominal Θ (floor for zero rows: bias)
        sc = np.max(np.abs(theta0), axis=1)
        sc[sc == 0] = bias_scale
        self.sc = sc
        self.theta0 = theta0 / sc[:, None]  # scaled
        ib = self.npar - m - 1  # row of the bias (regressor −1)
        d0 = np.full(self.npar, float(p0))
        d0[ib] = p0 if p0_bias is None else p0_bias
        self.P0 = np.diag(d0)
        self.q = np.full(self.npar, float(q))
        self.q[ib] = q if q_bias is None else q_bias
        if not self.bias:  # the printed φ has no constant: its regressor entry, covariance and Q row are zero, so
            sc[ib] = 0.0  # the bias parameter stays at 0 (the kernel's layout is unchanged)
            self.P0[ib, ib] = 0.0
            self.q[ib] = 0.0
        self.trace_max = trace_max
        bi = slice(self.npar - m, self.npar)
        bi_nom = np.diag(theta0[bi]) / sc[bi]
        self.bounds = [sorted((beta_inv_range[0] * bi_nom[i], beta_inv_range[1] * bi_nom[i])) for i in range(m)]
        self.u_max = u_max
        self.n_hist = 2 * D + 3  # Y[k], Y[k−1], … and U[k−1], U[k−2], … kept

    def theta0_unscaled(self) -> np.ndarray:
        """The initial Θ (p × m) in physical units (as the kernel's Θ signal gives it)."""
        return self.theta0 * self.sc[:, None]

    def pack(self, lay, hd: int, n: int) -> None:
        """Place the estimator in a KernelLayout for :func:`dm_step`: its initial state in st, constants in
        p, the header at the reserved p columns hd..hd+DM_HEADER−1.  The summation order of Θᵀφ follows Θ's
        storage: along p for m = 1 or a lone car (n = 1), along m for an ensemble (see DM_HEADER)."""
        npar, m, D, nh = self.npar, self.m, self.D, self.n_hist
        if npar > 128:
            raise ValueError("dm_step sums trace(P) pairwise for at most 128 parameters")
        pc = m == 1 or n == 1
        so = {"theta": lay.st((self.theta0.T if pc else self.theta0).ravel()),
              "P": lay.st(self.P0.ravel()), "Y": lay.st(np.zeros(nh * m)), "U": lay.st(np.zeros(nh * m)),
              "Phi": lay.st(np.zeros((D + 1) * npar)), "err": lay.st(np.zeros(m))}
        scr = lay.st(np.zeros(3 * npar + 2 * m))
        sc = lay.p(self.sc)
        q = lay.p(self.q)
        lo = lay.p([b[0] for b in self.bounds])
        hi = lay.p([b[1] for b in self.bounds])
        trQ = float(np.trace(np.diag(self.q)))
        am = [float(a) for a in self.am[:3]]
        lay.set_p(hd, [m, D, npar, nh, so["theta"], so["P"], so["Y"], so["U"], so["Phi"], so["err"], scr,
                       sc, q, trQ, float(self.trace_max), lo, hi, *am, float(self.kappa),
                       float(self.u_max is not None), 0.0 if self.u_max is None else float(self.u_max), float(pc)])


class KernelLayout:
    """Builds a compiled controller's rows p (n_cars, kp) and st (n_cars, ks) block by block; each add
    returns the block's first column.  Shared values (the same for every car) are given as a scalar or
    1-D array, per-car values as (n_cars, k) with ``per_car=True``."""

    def __init__(self, n: int):
        self.n = n
        self._blocks = {"p": [], "st": []}
        self._size = {"p": 0, "st": 0}

    def _add(self, which, values, per_car):
        a = np.asarray(values, dtype=float)
        a = a.reshape(self.n, -1) if per_car else np.broadcast_to(a.reshape(1, -1), (self.n, a.size))
        off = self._size[which]
        self._blocks[which].append(np.array(a))
        self._size[which] += a.shape[1]
        return off

    def p(self, values, per_car=False) -> int:
        return self._add("p", values, per_car)

    def st(self, values, per_car=False) -> int:
        return self._add("st", values, per_car)

    def set_p(self, off: int, values) -> None:
        """Overwrite shared values of p starting at column off (a block reserved earlier)."""
        a = np.asarray(values, dtype=float).reshape(-1)
        start = 0
        for b in self._blocks["p"]:
            if start <= off < start + b.shape[1]:
                j = off - start
                if j + a.size > b.shape[1]:
                    raise ValueError("set_p crosses a block boundary")
                b[:, j:j + a.size] = a[None, :]
                return
            start += b.shape[1]
        raise IndexError(off)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        out = []
        for which in ("p", "st"):
            bl = self._blocks[which]
            a = np.concatenate(bl, axis=1) if bl else np.zeros((self.n, 0))
            out.append(np.ascontiguousarray(a, dtype=np.float64))
        return out[0], out[1]


# ---------------------------------------------------------------------------------------------------------
# Kernel helpers: scalar numba functions for one car, reading p and st rows laid out by KernelLayout.
#
# Summation order.  The sums keep a fixed order, that of the numpy implementation the kernels replaced, so
# that results stay bit-identical across versions: k_dot adds the even terms and the odd terms in two
# running sums (unrolled by 8: terms i+6, i+4, i+2, i of a block of 8 in that order) and returns their sum
# (np.einsum's order for a reduction contiguous in both operands on x86-64); k_dot_seq sums in order from
# 0.0; k_sum_pw in numpy's pairwise order (np.trace).
# ---------------------------------------------------------------------------------------------------------
# numba's on-disk cache of a kernel is keyed by its own file and bytecode only: a controller's kernel that
# calls these helpers would be loaded unchanged after an edit of this file.  stamped_cache adds a hash of
# this file to the key of a controller kernel's cache.
KERNEL_STAMP = hashlib.sha256(Path(__file__).read_bytes()).hexdigest()[:16]


def stamped_cache(dispatcher):
    """Decorator (outside ``numba.njit(cache=True)``): key the function's on-disk cache also to this
    file's source (KERNEL_STAMP), so that an edit here recompiles the kernels that inline its helpers.
    Uses numba's FunctionCache._index_key; without it (another numba) the cache stays as numba makes it."""
    try:
        from numba.core.caching import FunctionCache
    except ImportError:  # pragma: no cover
        return dispatcher
    if not isinstance(getattr(dispatcher, "_cache", None), FunctionCache) or not hasattr(FunctionCache, "_index_key"):
        return dispatcher  # pragma: no cover

    class _StampedCache(FunctionCache):
        def _index_key(self, sig, codegen):
            return (*super()._index_key(sig, codegen), KERNEL_STAMP)

    dispatcher._cache = _StampedCache(dispatcher.py_func)
    return dispatcher


@numba.njit(cache=True)
def k_dot(a, ao, b, bo, n):
    """Σ_j a[ao + j]·b[bo + j], j < n: even and odd terms in two running sums, then their sum."""
    l0 = 0.0
    l1 = 0.0
    i = 0
    while n - i >= 8:
        l0 = (((l0 + a[ao + i + 6] * b[bo + i + 6]) + a[ao + i + 4] * b[bo + i + 4])
              + a[ao + i + 2] * b[bo + i + 2]) + a[ao + i] * b[bo + i]
        l1 = (((l1 + a[ao + i + 7] * b[bo + i + 7]) + a[ao + i + 5] * b[bo + i + 5])
              + a[ao + i + 3] * b[bo + i + 3]) + a[ao + i + 1] * b[bo + i + 1]
        i += 8
    while i < n:
        l0 = l0 + a[ao + i] * b[bo + i]
        if i + 1 < n:
            l1 = l1 + a[ao + i + 1] * b[bo + i + 1]
        i += 2
    return l0 + l1


@numba.njit(cache=True)
def k_dot_seq(a, ao, sa, b, bo, sb, n):
    """Σ_j a[ao + j·sa]·b[bo + j·sb] summed in order from 0.0."""
    acc = 0.0
    for j in range(n):
        acc += a[ao + j * sa] * b[bo + j * sb]
    return acc


# ZOHFilter header in p (7 values at hp): matrices offset, n states, n inputs, n outputs, state offset in
# st, scratch offset in st (n states), D ≠ 0 (ZOHFilter.pack).  Matrices at po: Ad (ns·ns), Bd (ns·nin), Cd (nout·ns),
# Dd (nout·nin), row-major; the state of copy c at st[so + c·ns : so + (c + 1)·ns].
ZOH_HEADER = 7


@numba.njit(cache=True)
def zoh_y(p, st, hp, c, o):
    """Output o of copy c of a ZOHFilter without feed-through: y = Cd x."""
    po = int(p[hp])
    ns = int(p[hp + 1])
    nin = int(p[hp + 2])
    so = int(p[hp + 4])
    return k_dot(p, po + ns * ns + ns * nin + o * ns, st, so + c * ns, ns)


@numba.njit(cache=True)
def zoh_yu(p, st, hp, c, o, u, uo):
    """Output o of copy c with the inputs u[uo : uo + nin]: y = Cd x + Dd u."""
    y = zoh_y(p, st, hp, c, o)
    if p[hp + 6] != 0.0:
        po = int(p[hp])
        ns = int(p[hp + 1])
        nin = int(p[hp + 2])
        nout = int(p[hp + 3])
        y = y + k_dot(p, po + ns * ns + ns * nin + nout * ns + o * nin, u, uo, nin)
    return y


@numba.njit(cache=True)
def zoh_update(p, st, hp, c, u, uo):
    """Advance copy c with the inputs u[uo : uo + nin]: x ← Ad x + Bd u."""
    po = int(p[hp])
    ns = int(p[hp + 1])
    nin = int(p[hp + 2])
    so = int(p[hp + 4]) + c * ns
    sc = int(p[hp + 5])
    for i in range(ns):
        st[sc + i] = k_dot(p, po + i * ns, st, so, ns) + k_dot(p, po + ns * ns + i * nin, u, uo, nin)
    for i in range(ns):
        st[so + i] = st[sc + i]


@numba.njit(cache=True)
def k_sum_pw(a, ao, sa, n):
    """Σ_j a[ao + j·sa], j < n ≤ 128, in the order of numpy's pairwise summation (np.sum, np.trace): in
    order from 0.0 below 8 terms, else 8 running partial sums combined as ((0+1)+(2+3))+((4+5)+(6+7)),
    then the rest in order."""
    if n < 8:
        acc = 0.0
        for j in range(n):
            acc += a[ao + j * sa]
        return acc
    r0 = a[ao]
    r1 = a[ao + sa]
    r2 = a[ao + 2 * sa]
    r3 = a[ao + 3 * sa]
    r4 = a[ao + 4 * sa]
    r5 = a[ao + 5 * sa]
    r6 = a[ao + 6 * sa]
    r7 = a[ao + 7 * sa]
    i = 8
    while i < n - (n % 8):
        r0 += a[ao + i * sa]
        r1 += a[ao + (i + 1) * sa]
        r2 += a[ao + (i + 2) * sa]
        r3 += a[ao + (i + 3) * sa]
        r4 += a[ao + (i + 4) * sa]
        r5 += a[ao + (i + 5) * sa]
        r6 += a[ao + (i + 6) * sa]
        r7 += a[ao + (i + 7) * sa]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[ao + i * sa]
        i += 1
    return res


# DiscreteMRAC header in p (DM_HEADER values at hd): m, D, n parameters, n history; st offsets of Θ (p·m),
# P (p·p), Y (nh·m), U (nh·m), Φ ((D+1)·p), err (m), scratch (3p + 2m: Pφ, φ_old, φ, Ȳ, u); p offsets of
# the scaling (p), q (p); trace(Q), trace bound; p offsets of the (β0)⁻¹ bounds lo (m), hi (m); a_m (3);
# κ; u_max set (0/1), u_max; Θ stored along p (0/1: then Θᵀφ is summed as k_dot, else in order with
# k_dot_seq; DiscreteMRAC.pack stores it along p for m = 1 or a lone car, as the former numpy version did).
DM_HEADER = 24


@numba.njit(cache=True)
def dm_theta_strides(p, hd):
    """(row, column) strides of Θ (p × m) in st: Θ[j, c] is st[TH + j·row + c·column]."""
    if p[hd + 23] != 0.0:
        return 1, int(p[hd + 2])
    return int(p[hd]), 1


@numba.njit(cache=True)
def dm_theta_dot(st, TH, tj, tc, c, v, npar):
    """Column c of Θᵀφ with φ = st[v : v + npar], summed as k_dot when Θ is stored along p (tj = 1), else in
    order."""
    if tj == 1:
        return k_dot(st, TH + c * tc, st, v, npar)
    return k_dot_seq(st, TH + c * tc, tj, st, v, 1, npar)


@numba.njit(cache=True)
def dm_step(p, st, hd, y, yo, ybs, ybo, zo):
    """One step of the discrete MRAC (:class:`DiscreteMRAC`) for one car: y[yo : yo + m] the output Y[k],
    ybs[ybo : ybo + m] the filtered target Ȳ*[k+D].  Shifts the histories, updates Θ and P on the identity
    U[k−D] = Θᵀφ̃[k−D] with the instrument z[k−D]: Θ += Pz·ε/(1 + φ̃ᵀPz), P −= Pz·(Pᵀφ̃)ᵀ/(1 + φ̃ᵀPz), then the
    covariance addition while trace(P) + trace(Q) stays below the bound, and the (β0)⁻¹ projection; and computes
    U[k] = κ·Θᵀφ[k] + (1 − κ)·U[k−1], clipped to ±u_max when set.  U[k] is left in the newest U slot,
    st[U : U + m] (U = int(p[hd + 7])).

    ``zo`` < 0: z = φ̃, recursive least squares (the thesis; P stays symmetric and is kept so).  ``zo`` ≥ 0:
    recursive instrumental variables with z[k−D] at st[zo : zo + p] (the caller's), st[zo + p : zo + 2p] a
    scratch for Pᵀφ̃ (P is not symmetric then)."""
    m = int(p[hd])
    D = int(p[hd + 1])
    npar = int(p[hd + 2])
    nh = int(p[hd + 3])
    TH = int(p[hd + 4])
    PP = int(p[hd + 5])
    Y = int(p[hd + 6])
    U = int(p[hd + 7])
    PH = int(p[hd + 8])
    ER = int(p[hd + 9])
    S = int(p[hd + 10])
    SC = int(p[hd + 11])
    Q = int(p[hd + 12])
    PPHI, PHO, PHI, YB, UN = S, S + npar, S + 2 * npar, S + 3 * npar, S + 3 * npar + m
    tj, tc = dm_theta_strides(p, hd)
    bi = npar - m
    # Y ← roll(Y, 1); Y[0] = y;  Ȳ[k] = a_m(q⁻¹) Y[k]
    for k in range(nh - 1, 0, -1):
        for c in range(m):
            st[Y + k * m + c] = st[Y + (k - 1) * m + c]
    for c in range(m):
        st[Y + c] = y[yo + c]
    for c in range(m):
        st[YB + c] = p[hd + 17] * y[yo + c] + p[hd + 18] * st[Y + m + c] + p[hd + 19] * st[Y + 2 * m + c]
    started = False
    for j in range(npar):
        st[PHO + j] = st[PH + (D - 1) * npar + j]
        if st[PHO + j] != 0.0:
            started = True
    for c in range(m):
        st[PHO + bi + c] = st[YB + c] * p[SC + bi + c]
    if started:  # rls_update with target U[k−D]
        iv = zo >= 0
        Z = zo if iv else PHO  # the instrument (least squares: φ̃ itself)
        for i in range(npar):  # Pz
            st[PPHI + i] = k_dot(st, PP + i * npar, st, Z, npar)
        PT = PPHI  # Pᵀφ̃: Pz when P is symmetric and z = φ̃
        if iv:
            PT = zo + npar
            for i in range(npar):
                st[PT + i] = k_dot_seq(st, PP + i, npar, st, PHO, 1, npar)
        denom = 1.0 + k_dot(st, PHO, st, PPHI, npar)
        for c in range(m):
            st[ER + c] = st[U + (D - 1) * m + c] - dm_theta_dot(st, TH, tj, tc, c, PHO, npar)
        for j in range(npar):
            g = st[PPHI + j] / denom
            for c in range(m):
                st[TH + j * tj + c * tc] += g * st[ER + c]
        for i in range(npar):
            for j in range(npar):
                st[PP + i * npar + j] -= st[PPHI + i] * st[PT + j] / denom
        if (k_sum_pw(st, PP, npar + 1, npar) + p[hd + 13]) < p[hd + 14]:
            for i in range(npar):
                st[PP + i * (npar + 1)] += p[Q + i]
        if not iv:
            for i in range(npar):
                for j in range(i + 1, npar):
                    v = 0.5 * (st[PP + i * npar + j] + st[PP + j * npar + i])
                    st[PP + i * npar + j] = v
                    st[PP + j * npar + i] = v
        lo = int(p[hd + 15])
        hi = int(p[hd + 16])
        for c in range(m):
            kk = TH + (bi + c) * tj + c * tc
            st[kk] = min(max(st[kk], p[lo + c]), p[hi + c])
    # φ[k] = [−Y[k], −Y[k−1], −U[k−1], …, −U[k−D], −1, Ȳ*[k+D]] · scaling
    j = 0
    for k in range(2):
        for c in range(m):
            st[PHI + j] = -st[Y + k * m + c] * p[SC + j]
            j += 1
    for k in range(D):
        for c in range(m):
            st[PHI + j] = -st[U + k * m + c] * p[SC + j]
            j += 1
    st[PHI + j] = -1.0 * p[SC + j]
    j += 1
    for c in range(m):
        st[PHI + j] = ybs[ybo + c] * p[SC + j]
        j += 1
    kappa = p[hd + 20]
    for c in range(m):
        uc = dm_theta_dot(st, TH, tj, tc, c, PHI, npar)
        if kappa < 1.0:
            uc = kappa * uc + (1.0 - kappa) * st[U + c]
        if p[hd + 21] != 0.0:
            uc = min(max(uc, -p[hd + 22]), p[hd + 22])
        st[UN + c] = uc
    # Φ ← roll(Φ, 1); Φ[0] = φ;  U ← roll(U, 1); U[0] = u
    for k in range(D, 0, -1):
        for j in range(npar):
            st[PH + k * npar + j] = st[PH + (k - 1) * npar + j]
    for j in range(npar):
        st[PH + j] = st[PHI + j]
    for k in range(nh - 1, 0, -1):
        for c in range(m):
            st[U + k * m + c] = st[U + (k - 1) * m + c]
    for c in range(m):
        st[U + c] = st[UN + c]
