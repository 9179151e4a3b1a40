"""Output-error calibration: free parameters that make the simulated outputs, driven by the measured inputs,
match the measured outputs on the training part of a record (scipy ``least_squares``, trust-region
reflective with bounds).

The cost is the sum over output channels of the squared NRMSE (error RMS / standard deviation of the
measured channel), so channels in different units weigh alike.  The Jacobian is a forward finite
difference computed as one parallel batch of perturbed simulations (:func:`fastsim.run_batch`).  The 95 %
intervals come from the Gauss–Newton covariance ``σ²·(JᵀJ)⁻¹``, inflated by ``N/N_eff`` for the
autocorrelation of the residuals (``N_eff`` from the residual autocorrelation, Bartlett's formula), since
residuals of a dynamic model are far from independent.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from . import fastsim as fs
from .io import Record
from .model import ModelSpec


class Problem:
    """A record prepared for simulation: input arrays, output channels, weights and an initial state."""

    def __init__(self, rec: Record, max_substep: float = 1e-3, skip: int = 0, omega_max: float = 0.0):
        self.rec = rec
        self.kind = rec.kind
        n = len(rec)
        self.dt = rec.dt
        # RK4 sub-steps: h <= max_substep and omega_max·h <= 0.25 (fastest natural frequency of the model)
        h = min(max_substep, 0.25 / omega_max) if omega_max > 0 else max_substep
        self.nsub = max(1, int(np.ceil(self.dt / h - 1e-9)))
        self.parallel = True
        ins = rec.inputs
        if rec.kind == "damper":
            road, roaddot = ins["disp"], ins["vel"]
        elif rec.kind == "half_car":
            road = ins["road_front"]
            roaddot = np.gradient(road, self.dt)
        else:
            road = ins.get("road", ins.get("base", np.zeros(n)))
            roaddot = np.gradient(road, self.dt) if np.any(road) else np.zeros(n)
        force = ins.get("force", ins.get("force_front", np.zeros(n)))
        self.inputs = {"road": np.ascontiguousarray(road, float), "roaddot": np.ascontiguousarray(roaddot, float),
                       "force": np.ascontiguousarray(force, float)}
        self.has_force = "force" in ins and bool(np.any(ins["force"]))
        if rec.kind == "half_car":
            rr = np.ascontiguousarray(ins["road_rear"], float)
            self.inputs.update(road_r=rr, roaddot_r=np.ascontiguousarray(np.gradient(rr, self.dt)),
                               force_r=np.ascontiguousarray(ins.get("force_rear", np.zeros(n)), float))
            self.has_force = any(k in ins and bool(np.any(ins[k])) for k in ("force_front", "force_rear"))
        chans = fs.CHANNELS[rec.kind]
        self.channels = [c for c in chans if c in rec.outputs]
        self.col = np.array([chans.index(c) for c in self.channels])
        self.Y = np.stack([rec.outputs[c] for c in self.channels], axis=1)
        self.scale = np.maximum(self.Y.std(axis=0), 1e-12)
        self.skip = skip
        self.x0 = initial_state(rec, self.dt)

    @staticmethod
    def omega_max(spec) -> float:
        """Fastest natural frequency (rad/s) of the nominal model (for the sub-step)."""
        P = spec.P
        if spec.kind == "quarter_car":
            mr = P[fs.MS] * P[fs.MU] / (P[fs.MS] + P[fs.MU])
            return float(np.sqrt((P[fs.KT] + P[fs.K]) / P[fs.MU]) + np.sqrt(P[fs.K] / mr))
        if spec.kind == "sdof":
            return float(np.sqrt(max(P[fs.K], 0) / P[fs.MS]))
        if spec.kind == "half_car":
            m = 0.5 * P[fs.MS]
            return float(max(np.sqrt((P[kt] + P[k]) / P[mu]) + np.sqrt(P[k] * (m + P[mu]) / (m * P[mu]))
                             for k, kt, mu in ((fs.K, fs.KT, fs.MU), (fs.K_R, fs.KT_R, fs.MU_R))))
        return 0.0

    def simulate(self, P, a: int = 0, b: int | None = None) -> np.ndarray:
        """Simulated output channels (N, n_ch) from sample 0 to b (the state is carried from the start)."""
        b = len(self.rec) if b is None else b
        ins = {k: v[:b] for k, v in self.inputs.items()}
        out = fs.run(self.kind, P, ins, self.dt, self.nsub, self.x0)
        return out[a:, self.col]

    def simulate_batch(self, Pm, b: int | None = None) -> np.ndarray:
        b = len(self.rec) if b is None else b
        ins = {k: v[:b] for k, v in self.inputs.items()}
        out = fs.run_batch(self.kind, Pm, ins, self.dt, self.nsub, self.x0, parallel=self.parallel)
        return out[:, :, self.col]

    def nrmse(self, sim, a: int, b: int) -> dict[str, float]:
        a = max(a, self.skip)
        e = sim[a:b] - self.Y[a:b]
        return {c: float(np.sqrt(np.mean(e[:, i] ** 2)) / self.scale[i]) for i, c in enumerate(self.channels)}

    def rmse(self, sim, a: int, b: int) -> dict[str, float]:
        a = max(a, self.skip)
        e = sim[a:b] - self.Y[a:b]
        return {c: float(np.sqrt(np.mean(e[:, i] ** 2))) for i, c in enumerate(self.channels)}


def initial_state(rec: Record, dt: float) -> np.ndarray:
    """State at the first sample from measured positions where available (velocities from a one-sided
    second-order difference), else rest at equilibrium."""
    o = rec.outputs

    def pv(y):
        # local quadratic fit over the first samples (noise-robust position and velocity at t = 0)
        n0 = int(min(max(10, len(y) // 200), 50, len(y)))
        tt = np.arange(n0) * dt
        c = np.polyfit(tt, y[:n0], 2)
        return float(c[2]), float(c[1])

    if rec.kind == "half_car":
        return np.zeros(8)  # the record starts at rest (initial-state estimation not implemented for a half car)
    x = np.zeros(4)
    if rec.kind == "quarter_car":
        if "body_pos" in o:
            x[0], x[1] = pv(o["body_pos"])
        if "wheel_pos" in o:
            x[2], x[3] = pv(o["wheel_pos"])
        elif "body_pos" in o and "susp_travel" in o:
            x[2], x[3] = pv(o["body_pos"] - o["susp_travel"])
    elif rec.kind == "sdof":
        if "pos" in o:
            x[0], x[1] = pv(o["pos"])
        if "vel" in o:
            x[1] = float(o["vel"][0])
    return x


@dataclass
class FitResult:
    spec: ModelSpec
    x: np.ndarray
    P: np.ndarray
    cost: float  # mean over channels of NRMSE² on the fitted window
    n: int
    ci95: dict = field(default_factory=dict)
    std: dict = field(default_factory=dict)
    nfev: int = 0
    success: bool = True

    @property
    def params(self) -> dict[str, float]:
        return {f.name: float(v) for f, v in zip(self.spec.free, self.x)}

    def bic(self) -> float:
        return self.n * np.log(max(self.cost, 1e-300)) + len(self.x) * np.log(self.n)

    def aic(self) -> float:
        return self.n * np.log(max(self.cost, 1e-300)) + 2 * len(self.x)


def _residual_fn(prob: Problem, spec: ModelSpec, a: int, b: int, xs):
    w = 1.0 / (prob.scale * np.sqrt((b - max(a, prob.skip)) * len(prob.channels)))
    a = max(a, prob.skip)

    def resid_of(sim):
        return ((sim[a:b] - prob.Y[a:b]) * w).ravel()

    def fun(z):
        P = spec.vector(z * xs)
        return resid_of(prob.simulate(P, 0, b))

    def jac(z):
        x = z * xs
        hs = 1e-4 * np.maximum(np.abs(x), xs) / xs
        Z = np.repeat(z[None, :], len(z) + 1, axis=0)
        for i in range(len(z)):
            # step inward near an upper bound
            Z[i + 1, i] += hs[i]
        Pm = np.stack([spec.vector(zz * xs) for zz in Z])
        sims = prob.simulate_batch(Pm, b)
        r0 = resid_of(sims[0])
        J = np.empty((r0.size, len(z)))
        for i in range(len(z)):
            J[:, i] = (resid_of(sims[i + 1]) - r0) / hs[i]
        return J

    return fun, jac


def fit(prob: Problem, spec: ModelSpec, a: int, b: int, starts: list[np.ndarray] | None = None,
        max_nfev: int = 60) -> FitResult:
    """Fit ``spec``'s free parameters on samples [a, b) (simulating from sample 0)."""
    if not spec.free:
        sim = prob.simulate(spec.P, 0, b)
        cost = float(np.mean(np.square(list(prob.nrmse(sim, a, b).values()))))
        return FitResult(spec, np.zeros(0), spec.P.copy(), cost, b - max(a, prob.skip))
    xs = np.array([max(f.scale, 1e-12) for f in spec.free])
    lo = np.array([f.lo for f in spec.free]) / xs
    hi = np.array([f.hi for f in spec.free]) / xs
    fun, jac = _residual_fn(prob, spec, a, b, xs)
    best = None
    for x0 in (starts or [spec.x0]):
        with np.errstate(invalid="ignore"):  # the masked branch evaluates inf - inf for unbounded sides
            lo_in = np.where(np.isfinite(lo), lo + 1e-9 * np.maximum(1, np.abs(lo)), lo)
            hi_in = np.where(np.isfinite(hi), hi - 1e-9 * np.maximum(1, np.abs(hi)), hi)
        z0 = np.clip(np.asarray(x0, float) / xs, lo_in, hi_in)
        try:
            res = least_squares(fun, z0, jac=jac, bounds=(lo, hi), method="trf", x_scale="jac",
                                max_nfev=max_nfev, ftol=1e-8, xtol=1e-8, gtol=1e-10)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if best is None or res.cost < best.cost:
            best = res
    if best is None:
        raise RuntimeError("calibration failed for every start")
    x = best.x * xs
    r = best.fun
    cost = float(2 * best.cost)  # = mean NRMSE² over channels (residuals are pre-normalised)
    n = b - max(a, prob.skip)
    out = FitResult(spec, x, spec.vector(x), cost / 1.0, n, nfev=best.nfev, success=best.success)
    # covariance: residuals r_i = e_i * w; sigma² per normalised residual
    J = best.jac * 1.0
    nres = r.size
    s2 = float(r @ r) / max(nres - len(x), 1)
    try:
        JtJ_inv = np.linalg.pinv(J.T @ J)
        neff = effective_n(r.reshape(n, -1))
        cov_z = s2 * JtJ_inv * (nres / max(neff, 1.0))
        sd = np.sqrt(np.maximum(np.diag(cov_z), 0)) * xs
    except np.linalg.LinAlgError:
        sd = np.full(len(x), np.nan)
    out.std = {f.name: float(s) for f, s in zip(spec.free, sd)}
    out.ci95 = {f.name: [float(v - 1.96 * s), float(v + 1.96 * s)] for f, v, s in zip(spec.free, x, sd)}
    return out


def effective_n(r: np.ndarray, max_lag: int = 2000) -> float:
    """Effective number of independent residuals: N / (1 + 2 Σ ρ_k), summed until ρ first drops below 0.05
    (per channel, the smallest over channels, times the number of channels)."""
    r = np.atleast_2d(r)
    if r.shape[0] < r.shape[1]:
        r = r.T
    n, nch = r.shape
    best = np.inf
    for c in range(nch):
        x = r[:, c] - r[:, c].mean()
        f = np.fft.rfft(x, 2 * n)
        ac = np.fft.irfft(f * np.conj(f))[: min(max_lag, n)]
        if ac[0] <= 0:
            continue
        rho = ac / ac[0]
        below = np.nonzero(rho < 0.05)[0]
        m = below[0] if below.size else len(rho)
        tau = 1 + 2 * rho[1:m].sum()
        best = min(best, n / max(tau, 1.0))
    return float(best * nch) if np.isfinite(best) else float(n * nch)
