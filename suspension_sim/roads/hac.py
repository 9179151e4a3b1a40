"""The thesis's random road: Hac's PSD for asphalt and dirt through a 3rd-order shaping filter.

Source: Vallurupalli (1996), Ch. 2, Eqs. 2.1–2.5 (after Hac, Vehicle System Dynamics 16, 1987), and the
state form used by the Ch. 5 stochastic optimal controller (Eqs. 5.2–5.8).

PSD (Eq. 2.1), with a = μ2·v, b = μ3·v, c = μ1·v and ω in rad/s::

    S(ω) = (μ4/π)·c/(ω² + c²) + (μ5/π)·a(ω² + a² + b²)/((ω² + a² − b²)² + 4a²b²)

This is the two-sided spectral density (per rad/s, −∞ < ω < ∞) of a road whose autocorrelation along the
distance ξ is R(ξ) = μ4·e^(−μ1|ξ|) + μ5·e^(−μ2|ξ|)·cos(μ3 ξ): the variance is μ4 + μ5 (asphalt
9.0·10⁻⁶ m², σ = 3.0 mm; dirt 9.9·10⁻⁴ m², σ = 31 mm).  One-sided per Hz: G(f) = 4π·S(2πf); in space
(cycles/m) Gd(n) = 4π·S(2πn; v = 1).  The thesis's nomenclature gives S in m²/Hz; we read Eq. 2.1 as the
two-sided density per rad/s, the only reading under which μ4 and μ5 are variances (Hac's definition).

Coefficients (thesis §2.2.2, from Hac): asphalt μ = (0.2, 0.05, 0.6) m⁻¹, (7.65·10⁻⁶, 1.35·10⁻⁶) m²;
dirt μ = (0.8, 0.5, 1.1) m⁻¹, (7.4·10⁻⁴, 2.5·10⁻⁴) m².

Shaping filter (Eq. 2.3): ϑ0 w''' + ϑ1 w'' + ϑ2 w' + ϑ3 w = ϑ4 ξ'' + ϑ5 ξ' + ϑ6 ξ, white noise ξ of PSD S0,
S(ω) = |H(iω)|²·S0 (Eq. 2.2), with (Eq. 2.5)::

    ϑ0 = 1, ϑ1 = ε1 + √(ε2 + 2ε0), ϑ2 = ε0 + ε1·√(ε2 + 2ε0), ϑ3 = ε1·ε0,
    ϑ4 = √(ε5/(S0 π)), ϑ5 = √(ε5/(S0 π)·(ε4 + 2ε3)), ϑ6 = √(ε5/(S0 π))·ε3,
    ε1 = μ1 v, ε2 = 2v²(μ2² − μ3²), ε5 = (μ4 μ1 + μ5 μ2) v,
    ε4 = [2μ4μ1(μ2² − μ3²) + μ5μ2(μ1² + μ2² + μ3²)]·v³/ε5,
    ε0 = v²(μ2² + μ3²),   ε3² = [μ4μ1(μ2² + μ3²)² + μ5μ1²μ2(μ2² + μ3²)]·v⁵/ε5.

Reconstruction notes (the OCR of Eq. 2.5 is garbled/incomplete; we re-derived every coefficient by
factorising Eq. 2.1, and say where we differ):

- ϑ3 is missing from the OCR text; the factorisation gives ϑ3 = ε1·ε0 (denominator
  (s + c)(s² + 2a s + a² + b²), so √(ε2 + 2ε0) = 2a).
- The printed ε0² = v⁴μ3²(μ3² + 2μ2²) and ε3² = [μ4μ1μ3²(2μ2² + μ3²) + …] both lack the μ2⁴v⁴ term that
  the constant of Eq. 2.1's denominator, (a² − b²)² + 4a²b² = (a² + b²)², contains — an algebra slip
  (dropping a⁴) or an OCR loss.  We use the exact (a² + b²)² by default; ``thesis_eps0: true`` uses the
  printed form.  The difference is 5·10⁻⁵ in ε0² for asphalt and 3 % for dirt (the thesis itself notes
  that its coefficients "vary from those derived by Hac").
- Eq. 5.1's right-hand side is printed ϑ4 ξ' + ϑ5 ξ' + ϑ6 ξ; Eq. 2.3 (ϑ4 ξ'') is meant.

State form (Eqs. 5.2–5.8): w1 = w, ẇ1 = w2 + χ1 ξ, ẇ2 = w3 + χ2 ξ, ẇ3 = −ϑ3 w1 − ϑ2 w2 − ϑ1 w3 + χ3 ξ,
χ1 = ϑ4, χ2 = ϑ5 − ϑ1 χ1, χ3 = ϑ6 − ϑ1 χ2 − ϑ2 χ1, i.e. M_d = [[0,1,0],[0,0,1],[−ϑ3,−ϑ2,−ϑ1]],
D_d = [χ1, χ2, χ3]ᵀ, w = [1 0 0]·W (:func:`hac_shaping_filter`).

Generation.  The road is a spatial process (S at speed v is S at v = 1 rescaled: S_v(ω) = S_1(ω/v)/v), so
we filter seeded white noise through the filter at v = 1 m/s *along the distance*, with the exact
discretisation of the continuous stochastic system on the grid dx (Van Loan's matrix exponential: the
transition e^(A·dx) and the exact noise covariance Q_d = ∫₀^dx e^(Aτ)BBᵀe^(Aᵀτ)dτ; initial state drawn
from the stationary covariance), and evaluate the grid by a cubic spline.  At a constant speed this is the
same process as filtering white noise in time at the vehicle speed (the thesis's method), and it stays
right when the speed varies and for the rear wheels (which meet the same road later).  The grid samples
are exact samples of the continuous process, so content above ≈ 1/(4·dx) is aliased (default
dx = 0.02 m: exact up to ≈ 12 cycles/m, 250 Hz at 20 m/s).  Tracks, ``fade_in`` and ``margin`` as in
:mod:`.iso8608`.

A run longer than 20 km (:data:`~._common.MAX_LENGTH`, 1000 s at 20 m/s) drives a periodic road, as the ISO
8608 one does, so the road's memory does not grow with the duration: the filter runs over one period
N·dx ≥ 20 km plus a blend of M samples (:func:`periodic_hac`), and the last M samples are blended into the
first M with weights sin θ, cos θ (θ rising smoothly from 0 to π/2; sin² + cos² = 1 keeps the variance,
the two stretches being 20 km apart and independent), so that the profile closes on itself without a seam
and is repeated (:class:`~._common.PeriodicProfile`).  The blend (10 correlation lengths 1/min(μ1, μ2), at
least 100 m: 200 m for asphalt) is the only stretch whose samples are not the filter's own.  Shorter runs
are generated as before (the same numbers for the same seed).
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, field_validator
from scipy.linalg import expm, solve_continuous_lyapunov
from scipy.signal import lfilter

from ..components import Params
from ..registry import ROADS
from ._common import MAX_LENGTH, GriddedProfile, PeriodicProfile, generation_range, tracks_mode
from .base import Road

HAC_COEFFICIENTS = {
    # μ1, μ2, μ3 (1/m), μ4, μ5 (m²) — thesis §2.2.2 (from Hac 1987)
    "asphalt": (0.2, 0.05, 0.6, 7.65e-6, 1.35e-6),
    "dirt": (0.8, 0.5, 1.1, 7.4e-4, 2.5e-4),
}


def _mu(road) -> tuple[float, ...]:
    if isinstance(road, str):
        if road not in HAC_COEFFICIENTS:
            raise ValueError(f"unknown Hac road {road!r} (known: {', '.join(HAC_COEFFICIENTS)})")
        return HAC_COEFFICIENTS[road]
    mu = tuple(float(m) for m in road)
    if len(mu) != 5:
        raise ValueError("Hac coefficients are five numbers μ1..μ5")
    return mu


def hac_psd(omega, road="asphalt", speed: float = 20.0):
    """Eq. 2.1: two-sided PSD S(ω) (m²/(rad/s)) of the road height at ``speed`` (m/s), ω in rad/s.
    ``road``: 'asphalt', 'dirt' or five coefficients (μ1, μ2, μ3, μ4, μ5)."""
    m1, m2, m3, m4, m5 = _mu(road)
    v = float(speed)
    w2 = np.asarray(omega, dtype=float) ** 2
    a, b, c = m2 * v, m3 * v, m1 * v
    return (m4 / np.pi) * c / (w2 + c * c) + (m5 / np.pi) * a * (w2 + a * a + b * b) / (
        (w2 + a * a - b * b) ** 2 + 4 * a * a * b * b)


def hac_spatial_psd(n, road="asphalt"):
    """One-sided spatial PSD Gd(n) (m³) at n cycles/m: 4π·S(2πn; v = 1) (comparable with ISO 8608)."""
    return 4.0 * np.pi * hac_psd(2.0 * np.pi * np.asarray(n, dtype=float), road, 1.0)


def hac_filter_coefficients(road="asphalt", speed: float = 20.0, S0: float = 1.0 / (2.0 * np.pi),
                            thesis_eps0: bool = False) -> np.ndarray:
    """ϑ0..ϑ6 of Eq. 2.3/2.5 (see the module docstring).  ``S0``: two-sided PSD of the white noise per rad/s
    (default 1/2π, i.e. unit-intensity white noise E[ξ(t)ξ(t')] = δ(t − t'))."""
    m1, m2, m3, m4, m5 = _mu(road)
    v = float(speed)
    if v <= 0:
        raise ValueError("the Hac filter needs a speed > 0")
    e1 = m1 * v
    e2 = 2.0 * v * v * (m2 * m2 - m3 * m3)
    e5 = (m4 * m1 + m5 * m2) * v
    e4 = (2 * m4 * m1 * (m2 * m2 - m3 * m3) + m5 * m2 * (m1 * m1 + m2 * m2 + m3 * m3)) * v ** 3 / e5
    if thesis_eps0:  # as printed in the thesis (no μ2⁴ term)
        e0 = np.sqrt(v ** 4 * m3 * m3 * (m3 * m3 + 2 * m2 * m2))
        e3sq = (m4 * m1 * m3 * m3 * (2 * m2 * m2 + m3 * m3) + m5 * m1 * m1 * m2 * (m2 * m2 + m3 * m3)) * v ** 5 / e5
    else:  # exact factorisation of Eq. 2.1
        e0 = v * v * (m2 * m2 + m3 * m3)
        e3sq = (m4 * m1 * (m2 * m2 + m3 * m3) ** 2 + m5 * m1 * m1 * m2 * (m2 * m2 + m3 * m3)) * v ** 5 / e5
    e3 = np.sqrt(e3sq)
    q = np.sqrt(e2 + 2.0 * e0)
    g = np.sqrt(e5 / (S0 * np.pi))
    th = np.array([1.0, e1 + q, e0 + e1 * q, e1 * e0, g, g * np.sqrt(e4 + 2.0 * e3), g * e3])
    return th


def hac_shaping_filter(road="asphalt", speed: float = 20.0, thesis_eps0: bool = False):
    """The Ch. 5 road model Ẇ = M_d W + D_d ξ, w = C W (thesis Eqs. 5.2–5.8) at ``speed`` (m/s).

    ξ is unit-intensity white noise (E[ξ(t)ξ(t')] = δ(t − t'), two-sided PSD 1/2π per rad/s), so the
    output w has the two-sided PSD S(ω) of Eq. 2.1 and variance μ4 + μ5.  Returns (M_d (3×3), D_d (3×1),
    C (1×3)) with W = [w, ẇ − χ1 ξ, ẅ − χ1 ξ̇ − χ2 ξ].  ``road``: 'asphalt', 'dirt' or (μ1..μ5).
    """
    th = hac_filter_coefficients(road, speed, thesis_eps0=thesis_eps0)
    t1, t2, t3, t4, t5, t6 = th[1:]
    chi1 = t4
    chi2 = t5 - t1 * chi1
    chi3 = t6 - t1 * chi2 - t2 * chi1
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-t3, -t2, -t1]])
    B = np.array([[chi1], [chi2], [chi3]])
    C = np.array([[1.0, 0.0, 0.0]])
    return A, B, C


def _exact_discretisation(A, B, h):
    """Van Loan: transition Φ = e^(A h) and noise covariance Q_d = ∫₀^h e^(Aτ)BBᵀe^(Aᵀτ)dτ (unit intensity)."""
    n = A.shape[0]
    F = np.zeros((2 * n, 2 * n))
    F[:n, :n] = -A
    F[:n, n:] = B @ B.T
    F[n:, n:] = A.T
    E = expm(F * h)
    Phi = E[n:, n:].T
    Qd = Phi @ E[:n, n:]
    return Phi, 0.5 * (Qd + Qd.T)


def _psd_sqrt(Q):
    lam, V = np.linalg.eigh(Q)
    return V * np.sqrt(np.clip(lam, 0.0, None))


def generate_hac(road, rng: np.random.Generator, n_samples: int, dx: float, thesis_eps0: bool = False):
    """Samples w(k·dx), k = 0..n−1, of the spatial Hac road (filter at v = 1 m/s, exact discretisation)."""
    A, B, C = hac_shaping_filter(road, 1.0, thesis_eps0)
    Phi, Qd = _exact_discretisation(A, B, dx)
    L = _psd_sqrt(Qd)
    P = solve_continuous_lyapunov(A, -B @ B.T)
    W0 = _psd_sqrt(0.5 * (P + P.T)) @ rng.standard_normal(3)
    # modal form: Φ = V Λ V⁻¹ (distinct poles −c, −a ± ib) -> three first-order recursions, run by lfilter
    lam, V = np.linalg.eig(Phi)
    Vi = np.linalg.inv(V)
    e = Vi @ (L @ rng.standard_normal((3, n_samples - 1)))
    z = np.empty((3, n_samples), dtype=complex)
    z0 = Vi @ W0
    for i in range(3):
        u = np.concatenate([[z0[i]], e[i]])
        z[i] = lfilter([1.0], [1.0, -lam[i]], u)
    return np.real((C @ V) @ z)[0]


def periodic_hac(road, rng: np.random.Generator, dx: float, thesis_eps0: bool = False) -> np.ndarray:
    """One period (N samples, N·dx ≥ :data:`MAX_LENGTH`) of a periodic Hac road: the filter's samples over
    N + M, the last M blended into the first M (module docstring), so that sample N would be sample 0."""
    m1, m2 = _mu(road)[:2]
    N = int(np.ceil(MAX_LENGTH / dx))
    M = int(np.ceil(max(100.0, 10.0 / min(m1, m2)) / dx))
    z = generate_hac(road, rng, N + M, dx, thesis_eps0)
    theta = 0.25 * np.pi * (1.0 - np.cos(np.pi * np.arange(M) / M))  # 0 -> π/2, flat at both ends
    z[:M] = np.sin(theta) * z[:M] + np.cos(theta) * z[N:]
    return z[:N].copy()


class HacParams(Params):
    surface: Literal["asphalt", "dirt"] = Field("asphalt", description="thesis coefficient set (Ch. 2)")
    mu: Optional[list[float]] = Field(None, description="explicit (μ1, μ2, μ3 in 1/m, μ4, μ5 in m²); "
                                                        "overrides surface")
    dx: float = Field(0.02, gt=0, le=0.5, description="m, generation grid (aliasing above ≈ 1/(4·dx))")
    thesis_eps0: bool = Field(False, description="use the thesis's printed ε0, ε3 (without the μ2⁴ term)")
    fade_in: float = Field(5.0, ge=0, description="m, cosine fade-in after the start line (0 = none)")
    margin: float = Field(50.0, ge=0, description="m generated beyond the run's distance (look-ahead)")

    @field_validator("mu")
    @classmethod
    def _mu5(cls, v):
        if v is not None and (len(v) != 5 or any(m <= 0 for m in v)):
            raise ValueError("mu must be five positive numbers (μ1, μ2, μ3 in 1/m, μ4, μ5 in m²)")
        return v

    @property
    def road(self):
        return tuple(self.mu) if self.mu is not None else self.surface


@ROADS.register("hac")
class Hac(Road):
    """Thesis (Hac) random road, asphalt or dirt: white noise through the 3rd-order shaping filter (Eqs. 2.1–2.5)."""

    Params = HacParams

    def __init__(self, p, rng, ctx):
        super().__init__(p, rng, ctx)
        x0, x1 = generation_range(ctx, p.margin)
        n_prof = 2 if (tracks_mode(ctx) == "independent" and ctx.n_tracks > 1) else 1
        if x1 - x0 > MAX_LENGTH:  # a long run: one period, repeated (bounded memory)
            self.profiles = [PeriodicProfile(x0, p.dx, periodic_hac(p.road, rng, p.dx, p.thesis_eps0), p.fade_in)
                             for _ in range(n_prof)]
            return
        n = int(np.ceil((x1 - x0) / p.dx)) + 2
        self.profiles = [GriddedProfile(x0, p.dx, generate_hac(p.road, rng, n, p.dx, p.thesis_eps0), p.fade_in)
                         for _ in range(n_prof)]

    def height(self, t, x, track=0):
        return self.profiles[min(track, len(self.profiles) - 1)](x)

    def slopes(self, t, x, track=0):
        dz = self.profiles[min(track, len(self.profiles) - 1)].slope(x)
        return np.zeros_like(dz), dz
