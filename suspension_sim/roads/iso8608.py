"""ISO 8608 random road: classes A–H (or an explicit Gd(n0)), seeded, generated in space.

Target (ISO 8608, displacement PSD, one-sided, in m³ = m²/(cycles/m))::

    Gd(n) = Gd(n0)·(n/n0)^(−w),   n0 = 0.1 cycles/m,   w = 2 (``waviness``),   n_min ≤ n ≤ n_max

Class geometric means Gd(n0) in 10⁻⁶ m³: A 16, B 64, C 256, D 1024, E 4096, F 16384, G 65536,
H 262144 (each class spans a factor 4 of Gd(n0)); ``gd_n0`` overrides the class.  Default band
n_min = 0.011 to n_max = 2.83 cycles/m (wavelengths 90 m to 0.35 m, the band of the standard); at a speed
V the temporal band is V·n_min … V·n_max Hz (0.22–57 Hz at 20 m/s).

Generation (inverse FFT = a sum of sinusoids on the frequency grid k·Δn, Δn = 1/(N·dx)): on the distance
grid x = x0 + j·dx covering [−wheelbase, distance + margin] (and at least 4/n_min long so the longest
wavelengths are resolved)::

    z(x) = Σ_k a_k cos(2π n_k (x − x0)) + b_k sin(2π n_k (x − x0))

- ``amplitudes: random`` (default): a_k, b_k independent N(0, Gd(n_k)·Δn) — a Gaussian stationary road
  whose periodogram scatters like a real one (χ² with 2 degrees of freedom per frequency);
- ``amplitudes: deterministic``: a_k = A_k cos φ_k, b_k = −A_k sin φ_k with A_k = √(2 Gd(n_k) Δn) and
  uniform random phases (the classic "sum of sinusoids with random phase": exact variance per frequency).

Either way E[z²] = Σ Gd(n_k) Δn ≈ ∫ Gd dn.  The grid profile is evaluated by a cubic spline (dx default
1/(8 n_max), so the shortest wavelength has 8 samples; spline error < 0.1 %).  Left/right tracks
(track 0/1) use the same profile or independent ones (scenario ``road.tracks: same|independent``; the
second track is drawn from the same seeded generator after the first).

A run longer than :data:`MAX_LENGTH` (20 km: 1000 s at 20 m/s) drives a periodic road instead: the profile is
generated over 20 km (the inverse FFT makes it periodic, with Δn = 1/20 km) and repeated without a seam
(:class:`~._common.PeriodicProfile`), so the road's memory (~4 doubles per sample, 8 samples per 0.35 m)
does not grow with the duration.  Shorter runs are generated as before (same numbers for the same seed).

``fade_in`` (default 5 m): the profile is multiplied by a half-cosine ramp over the first 5 m after the
start line x = 0 (0 before it), so every wheel stands on flat road at t = 0 (the rear wheels start at
x = −wheelbase) and the run starts at the static equilibrium; 5 m is 0.25 s at 20 m/s, long against the
wheel-hop period and short against a typical run.  ``fade_in: 0`` keeps the unfaded road (the run then
starts off equilibrium, on the road's actual height under each wheel).
"""
from __future__ import annotations

from typing import Literal, Optional

import numpy as np
from pydantic import Field, model_validator
from scipy import fft as sfft

from ..components import Params
from ..registry import ROADS
from ._common import MAX_LENGTH, GriddedProfile, PeriodicProfile, generation_range, tracks_mode
from .base import Road

N0 = 0.1  # cycles/m, ISO 8608 reference spatial frequency
CLASS_GD_N0 = {c: 16e-6 * 4.0 ** i for i, c in enumerate("ABCDEFGH")}  # m³, geometric means


def iso8608_psd(n, gd_n0: float, waviness: float = 2.0, n_min: float = 0.0, n_max: float = np.inf):
    """One-sided displacement PSD Gd(n) (m³) at spatial frequencies n (cycles/m), 0 outside [n_min, n_max]."""
    n = np.asarray(n, dtype=float)
    with np.errstate(divide="ignore"):
        g = gd_n0 * (np.where(n > 0, n, np.inf) / N0) ** (-waviness)
    return np.where((n >= n_min) & (n <= n_max) & (n > 0), g, 0.0)


class Iso8608Params(Params):
    road_class: Literal["A", "B", "C", "D", "E", "F", "G", "H"] = Field(
        "C", description="ISO 8608 class (geometric-mean Gd(n0)); ignored when gd_n0 is given")
    gd_n0: Optional[float] = Field(None, gt=0, description="m³, explicit Gd(n0) at n0 = 0.1 cycles/m")
    waviness: float = Field(2.0, gt=0, le=4, description="exponent w of Gd(n0)·(n/n0)^−w")
    n_min: float = Field(0.011, gt=0, description="cycles/m, lowest spatial frequency generated")
    n_max: float = Field(2.83, gt=0, description="cycles/m, highest spatial frequency generated")
    dx: Optional[float] = Field(None, gt=0, description="m, generation grid (default 1/(8·n_max))")
    amplitudes: Literal["random", "deterministic"] = Field(
        "random", description="Gaussian random amplitudes, or deterministic amplitudes with random phases")
    fade_in: float = Field(5.0, ge=0, description="m, cosine fade-in after the start line (0 = none)")
    margin: float = Field(50.0, ge=0, description="m generated beyond the run's distance (look-ahead)")

    @model_validator(mode="after")
    def _band(self):
        if self.n_max <= self.n_min:
            raise ValueError(f"n_max ({self.n_max}) must exceed n_min ({self.n_min})")
        if self.dx is not None and self.dx > 1.0 / (2.0 * self.n_max):
            raise ValueError(f"dx = {self.dx} m cannot carry n_max = {self.n_max} cycles/m "
                             f"(needs dx ≤ 1/(2·n_max) = {1 / (2 * self.n_max):.4g} m; 1/(8·n_max) recommended)")
        return self

    @property
    def gd(self) -> float:
        return float(self.gd_n0) if self.gd_n0 is not None else CLASS_GD_N0[self.road_class]


def generate_iso8608(p: Iso8608Params, rng: np.random.Generator, x0: float, x1: float):
    """One seeded profile on a regular grid starting at x0 covering at least [x0, x1]: (dx, z)."""
    dx = float(p.dx) if p.dx is not None else 1.0 / (8.0 * p.n_max)
    length = max(x1 - x0, 4.0 / p.n_min)
    N = sfft.next_fast_len(int(np.ceil(length / dx)) + 1, real=True)
    dn = 1.0 / (N * dx)
    nk = np.arange(N // 2 + 1) * dn
    G = iso8608_psd(nk, p.gd, p.waviness, p.n_min, p.n_max)
    if N % 2 == 0:
        G[-1] = 0.0  # the Nyquist bin has no sine part: leave it out (n_max < Nyquist anyway)
    if p.amplitudes == "random":
        sd = np.sqrt(G * dn)
        a = rng.standard_normal(nk.size) * sd
        b = rng.standard_normal(nk.size) * sd
    else:
        A = np.sqrt(2.0 * G * dn)
        phi = rng.uniform(0.0, 2.0 * np.pi, nk.size)
        a, b = A * np.cos(phi), -A * np.sin(phi)
    c = 0.5 * N * (a - 1j * b)  # irfft: z_j = (1/N)·Σ c_k e^{2πi kj/N} (+ conjugates)
    z = sfft.irfft(c, n=N)
    return dx, z


@ROADS.register("iso8608")
class Iso8608(Road):
    """ISO 8608 random road, classes A–H or explicit Gd(n0), PSD Gd(n0)(n/n0)^−w, seeded, fade-in at the start."""

    Params = Iso8608Params

    def __init__(self, p, rng, ctx):
        super().__init__(p, rng, ctx)
        x0, x1 = generation_range(ctx, p.margin)
        periodic = x1 - x0 > MAX_LENGTH  # a long run: one period of MAX_LENGTH, repeated (bounded memory)
        n_prof = 2 if (tracks_mode(ctx) == "independent" and ctx.n_tracks > 1) else 1
        self.profiles = []
        for _ in range(n_prof):
            if periodic:  # z of length N from the inverse FFT: one period N·dx (z[N] would be z[0])
                dx, z = generate_iso8608(p, rng, x0, x0 + MAX_LENGTH)
                self.profiles.append(PeriodicProfile(x0, dx, z, p.fade_in))
            else:
                dx, z = generate_iso8608(p, rng, x0, x1)
                self.profiles.append(GriddedProfile(x0, dx, z, p.fade_in))

    def height(self, t, x, track=0):
        return self.profiles[min(track, len(self.profiles) - 1)](x)

    def slopes(self, t, x, track=0):
        dz = self.profiles[min(track, len(self.profiles) - 1)].slope(x)
        return np.zeros_like(dz), dz
