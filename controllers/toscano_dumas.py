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
Initial estimates ``beta_k0``, ``beta_b0`` (default 0: the controller starts knowing nothing, so F_m = k_r Δx + b_r Δv at first).  F_m in the estimator
is the commanded force (``force_sensor`` = an actuator_force sensor name uses the measured force instead).
M defaults to the corner's static load / g.

Sensors: ``travel`` (Δx = −travel), ``travel_rate`` (Δv = −rate) and the body velocity above the corner
(``corner_body_vel``), as the paper's state feedback assumes.  Signals: ``fk_hat``, ``fb_hat`` (the
estimated stiffness and damping at the current Δx, Δv), ``v_err`` (ṽ), ``beta_k.i``, ``beta_b.i``.
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field

from suspension_sim.components import Params
from suspension_sim.registry import CONTROLLERS

from .base import Controller

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


def basis(u: np.ndarray, n_rules: int, umax: float, membership: str, alpha_two: float) -> np.ndarray:
    """Normalised fuzzy basis functions ψ_i(u), shape u.shape + (n_rules,)."""
    u = np.asarray(u, dtype=float)
    if membership == "triangular" and n_rules == 2:
        mu = np.maximum(np.minimum(alpha_two * u + 1.0, 1.0 - alpha_two * u), 0.0)
        return np.stack([mu, 1.0 - mu], axis=-1)
    m = np.linspace(-umax, umax, n_rules)  # Eq. (16)
    d = u[..., None] - m
    if membership == "gaussian":
        sigma = 2 * umax / (2 * np.sqrt(2 * LN2) * (n_rules - 1))
        mu = np.exp(-0.5 * (d / sigma) ** 2)
    else:
        h = 2 * umax / (n_rules - 1)
        mu = np.maximum(1.0 - np.abs(d) / h, 0.0)
        # outside the range the end triangles hold (so the sum never vanishes)
        mu[..., 0] = np.where(u <= m[0], 1.0, mu[..., 0])
        mu[..., -1] = np.where(u >= m[-1], 1.0, mu[..., -1])
    s = mu.sum(axis=-1, keepdims=True)
    return mu / np.maximum(s, 1e-300)


@CONTROLLERS.register("toscano_dumas")
class ToscanoDumas(Controller):
    """Toscano–Dumas fuzzy adaptive compensation: the suspension follows a reference stiffness and damping."""

    Params = ToscanoDumasParams

    @classmethod
    def required_sensors(cls, raw):
        req = [raw.get("travel_sensor", "travel"), raw.get("rate_sensor", "travel_rate"),
               raw.get("velocity_sensor", "corner_body_vel")]
        if raw.get("force_sensor"):
            req.append(raw["force_sensor"])
        return req

    def reset(self):
        n, nc = self.ctx.n_cars, self.ctx.n_corners
        p = self.p
        self.nk, self.nb = int(np.max(p.n_rules_k)), int(np.max(p.n_rules_b))
        self.beta_k = np.broadcast_to(np.asarray(p.beta_k0, float).reshape(-1, 1, 1), (n, nc, self.nk)).copy()
        self.beta_b = np.broadcast_to(np.asarray(p.beta_b0, float).reshape(-1, 1, 1), (n, nc, self.nb)).copy()
        if p.body_mass is not None:
            self.M = np.broadcast_to(np.asarray(p.body_mass, float).reshape(-1, 1), (n, nc)).copy()
        else:
            self.M = np.asarray(self.ctx.static_suspension_force, float) / G
        self.v_hat = None
        self._last = None
        self.v_err = np.zeros((n, nc))
        self.F = np.zeros((n, nc))
        self.fk = np.zeros((n, nc))
        self.fb = np.zeros((n, nc))
        self.memb = p.membership if isinstance(p.membership, str) else p.membership[0]

    def _psi(self, dx, dv):
        p = self.p
        pk = basis(dx, self.nk, float(np.max(p.range_dx)), self.memb, ALPHA_K * 0.2 / float(np.max(p.range_dx)))
        pb = basis(dv, self.nb, float(np.max(p.range_dv)), self.memb, ALPHA_B * 20.0 / float(np.max(p.range_dv)))
        return pk, pb

    def step(self, t, y):
        p = self.p
        dt = self.ctx.control_dt
        dx = -np.asarray(y[p.travel_sensor], float)
        dv = -np.asarray(y[p.rate_sensor], float)
        v = np.asarray(y[p.velocity_sensor], float)
        F_prev = np.asarray(y[p.force_sensor], float) if p.force_sensor else self.F
        if self.v_hat is None:
            self.v_hat = v.copy()
        # estimator (20) and gradient law (27) over the last control step (explicit Euler, from the values
        # of the previous step's regressors; the α term exactly)
        if self._last is not None:
            dx0, dv0, pk0, pb0 = self._last
            fk0 = np.sum(self.beta_k * pk0, axis=-1)
            fb0 = np.sum(self.beta_b * pb0, axis=-1)
            drive = (fk0 * dx0 + fb0 * dv0 + F_prev) / self.M
            a = np.asarray(p.alpha, float)
            e = np.exp(-a * dt)
            self.v_hat = e * self.v_hat + (1 - e) * self._v0 + drive * dt
            self.v_err = v - self.v_hat
            gk = (np.asarray(p.lambda_k, float) / self.M)[..., None]
            gb = (np.asarray(p.lambda_b, float) / self.M)[..., None]
            self.beta_k = self.beta_k + dt * gk * pk0 * (dx0 * self.v_err)[..., None]
            self.beta_b = self.beta_b + dt * gb * pb0 * (dv0 * self.v_err)[..., None]
        pk, pb = self._psi(dx, dv)
        self.fk = np.sum(self.beta_k * pk, axis=-1)
        self.fb = np.sum(self.beta_b * pb, axis=-1)
        self.F = (p.k_ref - self.fk) * dx + (p.b_ref - self.fb) * dv  # control (28)
        self._last = (dx, dv, pk, pb)
        self._v0 = v
        return self.F

    def signals(self):
        out = {"fk_hat": self.fk, "fb_hat": self.fb, "v_err": self.v_err}
        if self.ctx.n_corners == 1:
            out["beta_k"] = self.beta_k[:, 0, :]
            out["beta_b"] = self.beta_b[:, 0, :]
        return out
