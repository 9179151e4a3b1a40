"""Sinusoidal road or base excitation."""
from __future__ import annotations

import numba
import numpy as np
from pydantic import Field, model_validator

from .. import buffers
from ..components import Params
from ..registry import ROADS
from ._common import cosine_window, cosine_window_rate, edge_weight
from .base import Road


class SineParams(Params):
    amplitude: float = Field(0.01, description="m (half the peak-to-peak height)")
    frequency: float | None = Field(None, gt=0, description="temporal frequency in Hz (a rig input)")
    wavelength: float | None = Field(None, gt=0, description="spatial wavelength in m (a road at the set speed)")
    phase: float = Field(0.0, description="rad")
    start: float = Field(0.0, ge=0, description="start time (temporal) or distance (spatial)")
    fade_in: float = Field(0.0, ge=0, description="cosine fade-in length in s (temporal) or m (spatial)")

    @model_validator(mode="after")
    def _one(self):
        if (self.frequency is None) == (self.wavelength is None):
            raise ValueError("give exactly one of frequency (Hz) or wavelength (m)")
        return self


@ROADS.register("sine")
class Sine(Road):
    """Sine: z = A·sin(2π f (t − t0) + φ) (temporal, `frequency`) or A·sin(2π (x − x0)/λ + φ) (spatial)."""

    Params = SineParams

    def _law(self, t, x):
        p = self.p
        if p.frequency is not None:
            s, k = np.asarray(t, dtype=float) - p.start, 2 * np.pi * p.frequency
        else:
            s, k = np.asarray(x, dtype=float) - p.start, 2 * np.pi / p.wavelength
        return sine_law(s, p.amplitude, k, p.phase, p.fade_in if p.fade_in > 0 else None)

    def height(self, t, x, track=0):
        return self._law(t, x)[0]

    def slopes(self, t, x, track=0):
        dz = self._law(t, x)[1]
        return (dz, np.zeros_like(dz)) if self.p.frequency is not None else (np.zeros_like(dz), dz)

    def height_slopes(self, t, x, track=0):
        z, dz = self._law(t, x)
        return (z, dz, np.zeros_like(dz)) if self.p.frequency is not None else (z, np.zeros_like(dz), dz)

    @classmethod
    def height_slopes_many(cls, roads, t, x, track=0, grid=None):
        """Every road's law at once: the parameters as columns, one array expression per kind (temporal or
        spatial, with or without a fade-in); the numbers of each road alone (elementwise the same operations).

        ``grid`` (:class:`~suspension_sim.roads.base.StepGrid`, from :meth:`System.road_chunk` at a constant
        speed): the samples are physics steps on a uniform grid.  A sine without fade-in is then evaluated by
        the angle-addition recurrence (:func:`sine_grid`, a rotation per step, re-anchored on exact sin/cos
        every ``grid.M`` steps of the run, so every value depends on its step only, not on the chunking)
        instead of a sine and a cosine per sample: equal to the closed form within ~1e-14 of the amplitude."""
        kinds: dict = {}
        for k, r in enumerate(roads):
            kinds.setdefault((r.p.frequency is not None, r.p.fade_in > 0), []).append(k)
        out = None
        for (temporal, fade), idx in kinds.items():
            ps = [roads[k].p for k in idx]

            def col(name):
                return np.array([getattr(p, name) for p in ps], dtype=float)[:, None]

            if temporal:
                k = 2 * np.pi * col("frequency")
            else:
                k = 2 * np.pi / col("wavelength")
            if grid is not None and not fade:
                src, anchors, h = (t, grid.t_anchor, grid.dt) if temporal else (x, grid.x_anchor, grid.dx)
                # computed step-major (a step's rows side by side) and returned as (rows, samples) views of it,
                # which road_chunk copies into its step-major chunk without a transpose
                # (in buffers of earlier chunks that nothing reads any more: no fresh pages to fault in)
                z, dz = buffers.empty((len(src), len(idx))), buffers.empty((len(src), len(idx)))
                sine_grid(np.asarray(src, dtype=float), col("start")[:, 0], k[:, 0], col("phase")[:, 0],
                          col("amplitude")[:, 0], np.asarray(anchors, dtype=float), int(grid.g0), int(grid.M),
                          float(h), z, dz)
                z, dz = z.T, dz.T
            else:
                s = (np.asarray(t, dtype=float) if temporal else np.asarray(x, dtype=float))[None, :] - col("start")
                z, dz = sine_law(s, col("amplitude"), k, col("phase"), col("fade_in") if fade else None)
            # the slope that is zero: a read-only broadcast zero on the grid (road_chunk only reads it; a fresh
            # array of the chunk's size cost a page fault per 4 KB), else an array
            zero = np.broadcast_to(0.0, dz.shape) if grid is not None and not fade else np.zeros_like(dz)
            res = (z, dz, zero) if temporal else (z, zero, dz)
            if len(kinds) == 1:
                return res
            if out is None:
                out = tuple(np.empty((len(roads), z.shape[1])) for _ in range(3))
            for a, v in zip(out, res):
                a[idx] = v
        return out


def sine_law(s, amplitude, k, phase, fade_in):
    """(height, d height/ds) of A·(sin(k s + φ) − sin φ) for s ≥ 0 (0 before), times a cosine fade-in of
    ``fade_in`` (None: none); the parameters are numbers, or columns broadcasting with ``s`` (many roads)."""
    # the same operations as amplitude·(sin(k s + φ) − sin φ) and (amplitude·k)·cos(k s + φ), written into two
    # arrays instead of seven fresh temporaries (each a few MB for a batch chunk, faulted in page by page)
    arg = k * s
    if isinstance(arg, np.ndarray) and arg.ndim:
        arg += phase
        z = np.sin(arg)
        z -= np.sin(phase)
        np.multiply(amplitude, z, out=z)
        dz = np.cos(arg, out=arg)
        np.multiply(amplitude * k, dz, out=dz)
    else:  # a single number
        arg = arg + phase
        z, dz = amplitude * (np.sin(arg) - np.sin(phase)), amplitude * k * np.cos(arg)
    if fade_in is not None:
        w = cosine_window(s, fade_in)
        z, dz = z * w, dz * w + z * cosine_window_rate(s, fade_in)
    if np.all(s > 0):  # after the start (every chunk but the first): edge_weight is 1, the where a no-op
        return z, dz
    return np.where(s >= 0, z, 0.0), edge_weight(s) * dz


@numba.njit(cache=True, nogil=True)
def sine_grid(src, start, k, phase, amplitude, anchors, g0, M, h, z, dz):  # pragma: no cover - compiled
    """:func:`sine_law` without fade-in of rows r (parameters ``start``, ``k``, ``phase``, ``amplitude``) on
    samples ``src`` (corner time or distance) of consecutive physics steps g0, g0 + 1, ... spaced ``h`` apart,
    into ``z[j, r]``, ``dz[j, r]`` (step-major): sin and cos of k (s − start) + φ from exact values at the anchor
    steps (multiples of M; ``anchors[i]`` the sample of step M·(floor(g0/M) + i)) rotated step by step by k·h,
    so that a step's value is the same whichever chunk it is computed in.  The edge (0 before the start, the
    slope's edge weight) from ``src``; on the start itself the closed form's numbers.

    A step is one pass over the rows that rotates and writes (each row's numbers in one 64-byte record: its
    rotation state and constants), and the edge is looked at only in a chunk that has a sample at or before
    some row's start (the run's first chunk): the same operations on the same numbers as a rotation pass and
    an output pass per step with the edge test per sample, in half the time (the benchmark batch's 256 cars ×
    2000 steps: 4.3 → 2.0 ms per chunk)."""
    n = src.shape[0]
    R = start.shape[0]
    a0 = (g0 // M) * M
    S = np.empty((R, 8))  # per row: cos, sin (the rotation's state), cos k·h, sin k·h, A, sin φ, A·k
    for r in range(R):
        S[r, 5] = np.sin(phase[r])
        S[r, 6] = amplitude[r] * k[r]
        S[r, 2] = np.cos(k[r] * h)
        S[r, 3] = np.sin(k[r] * h)
        S[r, 4] = amplitude[r]
    s_min = np.inf
    edge = False  # some sample at or before some row's start (or a NaN): the edge is tested sample by sample
    for j in range(n):
        if src[j] != src[j]:
            edge = True
        elif src[j] < s_min:
            s_min = src[j]
    for r in range(R):
        if not s_min - start[r] > 0.0:
            edge = True
    for j in range(n):
        g = g0 + j
        m = g % M
        zj, dj = z[j], dz[j]
        if j == 0 or m == 0:
            anc = anchors[(g - m - a0) // M]
            for r in range(R):
                arg = k[r] * (anc - start[r]) + phase[r]
                cc, ss = np.cos(arg), np.sin(arg)
                for _ in range(m):
                    cc, ss = cc * S[r, 2] - ss * S[r, 3], ss * S[r, 2] + cc * S[r, 3]
                S[r, 0] = cc
                S[r, 1] = ss
                zj[r] = S[r, 4] * (ss - S[r, 5])
                dj[r] = S[r, 6] * cc
        else:
            for r in range(R):
                cc, ss = S[r, 0], S[r, 1]
                cn = cc * S[r, 2] - ss * S[r, 3]
                sn = ss * S[r, 2] + cc * S[r, 3]
                S[r, 0] = cn
                S[r, 1] = sn
                zj[r] = S[r, 4] * (sn - S[r, 5])
                dj[r] = S[r, 6] * cn
        if edge:
            for r in range(R):
                sj = src[j] - start[r]
                if not sj > 0.0:
                    if sj == 0.0:  # on the start: the closed form's exact numbers (the argument is φ)
                        zj[r] = 0.0
                        dj[r] = 0.5 * (S[r, 6] * np.cos(phase[r]))
                    else:
                        zj[r] = 0.0
                        dj[r] = 0.0 * dj[r]
