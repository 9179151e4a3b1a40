"""ISO 2631-1 frequency-weighted vertical acceleration (Wk): weighted RMS, VDV, MTVV and crest factor.

Source of the weighting
-----------------------
ISO 2631-1:1997, *Mechanical vibration and shock — Evaluation of human exposure to whole-body vibration —
Part 1: General requirements*, Annex A (normative), "Mathematical definition of the frequency weightings".
Each weighting is the product of four analog transfer functions (s = j2πf, ωi = 2πfi):

- high-pass band limit  Hh(s) = 1 / (1 + √2·ω1/s + (ω1/s)²)
- low-pass band limit   Hl(s) = 1 / (1 + √2·s/ω2 + (s/ω2)²)
- a-v transition        Ht(s) = (1 + s/ω3) / (1 + s/(Q4·ω4) + (s/ω4)²)
- upward step           Hs(s) = (1 + s/(Q5·ω5) + (s/ω5)²) / (1 + s/(Q6·ω6) + (s/ω6)²) · (ω5/ω6)²

with the parameters of the standard's Annex A table (recalled, see below):

====  ====  =====  ====  ====  ====  ====  ====  ====  ====
 W    f1    f2     f3    f4    Q4    f5    Q5    f6    Q6
====  ====  =====  ====  ====  ====  ====  ====  ====  ====
 Wk   0.4   100    12.5  12.5  0.63  2.37  0.91  3.35  0.91
 Wd   0.4   100    2.0   2.0   0.63  —     —     —     —
====  ====  =====  ====  ====  ====  ====  ====  ====  ====

Note: the upward step of Wk goes from 2.37 Hz to **3.35 Hz** (f6 = 3.35, not 2.37: with f5 = f6 the step
would vanish and Wk would be 0.99 instead of the tabulated 0.482 at 1 Hz — the step halves the weighting
below about 2 Hz, (f5/f6)² = 0.50).  The parameters were recalled from the standard
(no copy of it is in the project) and checked against the standard's one-third-octave table of Wk factors
(ISO 2631-1:1997 Table 3, "principal frequency weightings", factors ×1000 at the nominal band frequencies,
e.g. 1 Hz: 482, 4 Hz: 967, 5 Hz: 1039, 8 Hz: 1036, 16 Hz: 768): the analog function below reproduces every
tabulated value from 0.1 to 400 Hz to within the table's rounding (3 significant digits), which would not
happen with a wrong parameter.  ``tests/test_metrics.py`` holds that check.

Discretisation
--------------
Each section is discretised separately with the **bilinear (Tustin) transform with frequency prewarping**
at the section's own characteristic frequency (f1, f2, f4 and √(f5·f6)) — ``scipy.signal.bilinear`` with
the sample rate replaced by ω_p / (2·tan(ω_p/(2·fs))), which maps ω_p exactly — and the four sections are
applied as one second-order-section cascade with ``scipy.signal.sosfilt``.  The bilinear transform squeezes
each section's roll-off towards the Nyquist frequency, so the signal is first upsampled (by an integer
factor with ``scipy.signal.resample_poly``) to at least :data:`MIN_FILTER_RATE` Hz when it is logged
slower, filtered there and decimated back by taking every L-th sample (the weighted signal carries no
content above the original Nyquist frequency).  The upsampler extends the record at each end with its end
value (``padtype="edge"``), so that the start of the weighted signal depends only on the start of the record
and the weighting is written once, for a signal that arrives chunk by chunk (:class:`WeightedStream`: the
upsampler on overlapping segments, the filter state carried over with ``sosfilt``'s ``zi``); a whole record
is one chunk.  At 2 kHz the digital magnitude is within 0.4 % of the
analog |W(f)| from 0.1 to 80 Hz.

Upsampling, filtering and decimation run as one compiled pass over blocks of cars side by side
(:func:`upsampled_filtered`; :func:`sosfilt_rows` without upsampling) that forms the same sums and the same
filter recursion as ``resample_poly`` and ``sosfilt``, term by term, so the weighted signal is theirs bit for bit
(``tests/test_iso2631_filter.py``), at about a third of their cost and without storing the upsampled signal.

Quantities (ISO 2631-1 §6)
--------------------------
- ``a_w`` (weighted RMS, m/s²) = sqrt(1/T ∫ a_w(t)² dt)
- ``VDV`` (vibration dose value, m/s^1.75) = (∫ a_w(t)⁴ dt)^(1/4)
- ``MTVV`` (maximum transient vibration value, m/s²): the maximum of the running RMS over τ = 1 s (linear
  integration, the standard's Eq. 2); over the whole record when it is shorter than τ.
- crest factor = max |a_w| / a_w (the standard says the basic RMS method may underestimate above 9).
"""
from __future__ import annotations

import math
from functools import lru_cache

import numba
import numpy as np
from scipy import integrate, signal

from ..registry import METRICS
from ..compiled.numpy_order import pairwise_sum
from .base import Accumulator, fold_max, max_nonneg, metric, rows_of

#: Parameters (Hz, and quality factors) of ISO 2631-1:1997 Annex A for the weightings provided here.
WEIGHTINGS: dict[str, dict[str, float]] = {
    "Wk": dict(f1=0.4, f2=100.0, f3=12.5, f4=12.5, Q4=0.63, f5=2.37, Q5=0.91, f6=3.35, Q6=0.91),
    "Wd": dict(f1=0.4, f2=100.0, f3=2.0, f4=2.0, Q4=0.63),
}
#: The weighting filter runs at no less than this rate (Hz); slower signals are upsampled first.
MIN_FILTER_RATE = 2000.0
#: Integration time of the running RMS for MTVV (s), ISO 2631-1 §6.3.1.
MTVV_TAU = 1.0


def _params(name: str) -> dict[str, float]:
    try:
        return WEIGHTINGS[name]
    except KeyError:
        raise ValueError(f"unknown ISO 2631 weighting {name!r} (known: {', '.join(WEIGHTINGS)})") from None


def analog_sections(name: str = "Wk") -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The weighting's analog sections as ``(b, a, f_prewarp)``: polynomial coefficients in descending powers
    of s and the frequency (Hz) at which the section is prewarped when discretised."""
    p = _params(name)
    w = {k: 2 * math.pi * v for k, v in p.items() if k.startswith("f")}
    w1, w2, w3, w4 = w["f1"], w["f2"], w["f3"], w["f4"]
    r2 = math.sqrt(2.0)
    out = [
        (np.array([1.0, 0.0, 0.0]), np.array([1.0, r2 * w1, w1 ** 2]), p["f1"]),  # high-pass
        (np.array([w2 ** 2]), np.array([1.0, r2 * w2, w2 ** 2]), p["f2"]),  # low-pass
        # (1 + s/ω3)/(1 + s/(Q4 ω4) + s²/ω4²) multiplied through by ω4²
        (np.array([w4 ** 2 / w3, w4 ** 2]), np.array([1.0, w4 / p["Q4"], w4 ** 2]), p["f4"]),
    ]
    if "f5" in p:
        w5, w6 = w["f5"], w["f6"]
        # (1 + s/(Q5 ω5) + s²/ω5²)/(1 + s/(Q6 ω6) + s²/ω6²)·(ω5/ω6)² = (s² + ω5 s/Q5 + ω5²)/(s² + ω6 s/Q6 + ω6²)
        out.append((np.array([1.0, w5 / p["Q5"], w5 ** 2]), np.array([1.0, w6 / p["Q6"], w6 ** 2]),
                    math.sqrt(p["f5"] * p["f6"])))
    return out


def iso2631_weighting(freq, name: str = "Wk", complex_response: bool = False):
    """|W(f)| of the analog ISO 2631-1 weighting ``name`` at frequencies ``freq`` (Hz); the complex response
    if ``complex_response``."""
    f = np.atleast_1d(np.asarray(freq, dtype=float))
    h = np.ones(f.shape, dtype=complex)
    for b, a, _ in analog_sections(name):
        h *= signal.freqs(b, a, worN=2 * np.pi * f)[1]
    h = h if complex_response else np.abs(h)
    return h if np.ndim(freq) else h[0]


def weighting_sos(fs: float, name: str = "Wk") -> np.ndarray:
    """Second-order sections of the digital weighting filter at sample rate ``fs`` (Hz): each analog section
    discretised by the bilinear transform prewarped at its characteristic frequency (kept below 0.45·fs)."""
    return _weighting_sos(float(fs), name).copy()


@lru_cache(maxsize=64)
def _weighting_sos(fs: float, name: str) -> np.ndarray:
    sos = []
    for b, a, fp in analog_sections(name):
        fp = min(fp, 0.45 * fs)
        wp = 2 * math.pi * fp
        fs_warp = wp / (2 * math.tan(wp / (2 * fs)))
        bz, az = signal.bilinear(b, a, fs=fs_warp)
        sos.append(signal.tf2sos(bz, az))
    return np.vstack(sos)


def weighted(x, fs: float, name: str = "Wk") -> np.ndarray:
    """The ISO 2631-1 frequency-weighted signal a_w(t) of ``x`` sampled at ``fs`` (Hz), zero initial state
    (runs start at equilibrium).  Signals slower than :data:`MIN_FILTER_RATE` are filtered upsampled."""
    x = np.asarray(x, dtype=float)
    return weighted_rows(x[None, :], fs, name)[0]


def weighted_rows(x: np.ndarray, fs: float, name: str = "Wk") -> np.ndarray:
    """:func:`weighted` of every row of a 2-D array at once (one chunk of a :class:`WeightedStream`)."""
    x = np.asarray(x, dtype=float)
    if x.shape[1] == 0:
        return x.copy()
    w = WeightedStream(x.shape[0], fs, name)
    return np.concatenate([w.push(x), w.push(None, final=True)], axis=1)


@lru_cache(maxsize=16)
def _upsampling_window(up: int) -> np.ndarray:
    """The anti-imaging FIR filter ``resample_poly`` designs for an integer factor ``up`` (its default
    Kaiser window, β = 5, 2·10·up + 1 taps, cut-off at 1/up of Nyquist), designed once instead of per call;
    passed as ``window=`` it gives the very same filter (resample_poly scales it by ``up`` itself)."""
    w = signal.firwin(2 * 10 * up + 1, 1.0 / up, window=("kaiser", 5.0))
    w.flags.writeable = False
    return w


def sosfilt_rows(sos: np.ndarray, x: np.ndarray, zi: np.ndarray, step: int = 1) -> np.ndarray:
    """``scipy.signal.sosfilt(sos, x, axis=-1, zi=zi)[0][:, ::step]`` of the rows of ``x`` (one per car), ``zi``
    ``(n_sections, n_rows, 2)`` carried over in place: the same recursion (direct form II transposed, the same
    operations in the same order, so the same numbers bit for bit) run over blocks of cars side by side.  scipy
    filters one row after the other, each sample waiting for the one before (~2.7 ns per section and sample);
    here the cars of a block are independent chains (~1 ns), and only every ``step``-th output is stored."""
    x = np.asarray(x, dtype=np.float64)
    return _sosfilt_blocks(np.ascontiguousarray(sos, dtype=np.float64), x, zi, int(step))


@numba.njit(cache=True, nogil=True, inline="always")
def _state_in(zi, r0, nb, z0, z1):  # pragma: no cover - compiled
    """A block of cars' filter states from ``zi`` (sections, cars, 2) into ``z0``, ``z1`` (sections, block)."""
    for s in range(zi.shape[0]):
        for j in range(nb):
            z0[s, j] = zi[s, r0 + j, 0]
            z1[s, j] = zi[s, r0 + j, 1]


@numba.njit(cache=True, nogil=True, inline="always")
def _state_out(zi, r0, nb, z0, z1):  # pragma: no cover - compiled
    for s in range(zi.shape[0]):
        for j in range(nb):
            zi[s, r0 + j, 0] = z0[s, j]
            zi[s, r0 + j, 1] = z1[s, j]


@numba.njit(cache=True, nogil=True, inline="always")
def _biquads(sos, z0, z1, xc, nb):  # pragma: no cover - compiled
    """One sample ``xc`` of a block of cars through every section: scipy's _sosfilt, term by term (a0 = 1)."""
    for s in range(sos.shape[0]):
        b0, b1, b2, a1, a2 = sos[s, 0], sos[s, 1], sos[s, 2], sos[s, 4], sos[s, 5]
        for j in range(nb):
            xn = b0 * xc[j] + z0[s, j]
            z0[s, j] = b1 * xc[j] - a1 * xn + z1[s, j]
            z1[s, j] = b2 * xc[j] - a2 * xn
            xc[j] = xn


@numba.njit(cache=True, nogil=True)
def _sosfilt_blocks(sos, x, zi, step):  # pragma: no cover - compiled
    n_rows, n = x.shape
    ns = sos.shape[0]
    out = np.empty((n_rows, (n + step - 1) // step))
    B = 16  # cars side by side
    z0 = np.empty((ns, B))
    z1 = np.empty((ns, B))
    xc = np.empty(B)
    for r0 in range(0, n_rows, B):
        nb = min(B, n_rows - r0)
        _state_in(zi, r0, nb, z0, z1)
        for k in range(n):
            for j in range(nb):
                xc[j] = x[r0 + j, k]
            _biquads(sos, z0, z1, xc, nb)
            if k % step == 0:
                for j in range(nb):
                    out[r0 + j, k // step] = xc[j]
        _state_out(zi, r0, nb, z0, z1)
    return out



@lru_cache(maxsize=16)
def _upsampler_taps(up: int) -> tuple[np.ndarray, int, int]:
    """What ``resample_poly(x, up, 1, padtype="edge", window=_upsampling_window(up))`` convolves with: its
    filter ``h`` (the window times ``up``, one zero in front, zero-padded to a multiple of ``up``) arranged by
    phase and flipped as scipy's ``upfirdn`` holds it, the taps per phase, and the output samples it drops
    at the start (``n_pre_remove``)."""
    h = np.array(_upsampling_window(up))
    h *= up
    half_len = (h.size - 1) // 2
    n_pre_pad = 1 - half_len % 1
    h = np.concatenate([np.zeros(n_pre_pad), h])
    h = np.concatenate([h, np.zeros(-h.size % up)])
    flip = np.ascontiguousarray(h.reshape(-1, up).T[:, ::-1].ravel())
    flip.flags.writeable = False
    return flip, h.size // up, half_len + n_pre_pad


def upsampled_filtered(sos: np.ndarray, seg: np.ndarray, q0: int, q1: int, up: int, zi: np.ndarray) -> np.ndarray:
    """``sosfilt_rows(sos, resample_poly(seg, up, 1, axis=-1, padtype="edge", window=...)[:, q0:q1], zi, up)``
    in one pass, bit for bit: each upsampled sample is the sum scipy's ``upfirdn`` forms (the same products
    added in the same order, the segment extended by its end values), fed straight into the filter, over
    blocks of cars side by side; the upsampled signal is never stored."""
    flip, hpp, pre = _upsampler_taps(int(up))
    return _upfir_sos_blocks(np.ascontiguousarray(sos, dtype=np.float64), np.asarray(seg, dtype=np.float64),
                             int(q0), int(q1), int(up), flip, int(hpp), int(pre), zi)


@numba.njit(cache=True, nogil=True)
def _upfir_sos_blocks(sos, seg, q0, q1, up, flip, hpp, pre, zi):  # pragma: no cover - compiled
    n_rows, n_in = seg.shape
    ns = sos.shape[0]
    out = np.empty((n_rows, (q1 - q0 + up - 1) // up))
    B = 32
    z0 = np.empty((ns, B))
    z1 = np.empty((ns, B))
    xc = np.empty(B)
    ext = np.empty((n_in + 2 * hpp, B))  # the block's segment, car innermost, extended by its end values
    for r0 in range(0, n_rows, B):
        nb = min(B, n_rows - r0)
        _state_in(zi, r0, nb, z0, z1)
        for j in range(nb):
            for i in range(hpp):
                ext[i, j] = seg[r0 + j, 0]
                ext[hpp + n_in + i, j] = seg[r0 + j, n_in - 1]
            for i in range(n_in):
                ext[hpp + i, j] = seg[r0 + j, i]
        for q in range(q0, q1):
            p = q + pre  # upfirdn's output index: input sample p // up, phase p % up
            h0 = (p % up) * hpp
            e0 = p // up + 1  # ext row of the first input sample of the sum (input p // up - hpp + 1)
            for j in range(nb):
                xc[j] = 0.0
            for m in range(hpp):  # upfirdn's sum, term by term from 0.0
                hm = flip[h0 + m]
                for j in range(nb):
                    xc[j] = xc[j] + ext[e0 + m, j] * hm
            _biquads(sos, z0, z1, xc, nb)
            if (q - q0) % up == 0:
                for j in range(nb):
                    out[r0 + j, (q - q0) // up] = xc[j]
        _state_out(zi, r0, nb, z0, z1)
    return out


class WeightedStream:
    """:func:`weighted_rows` of a signal that arrives in chunks (``(n_cars, rows)`` each): :meth:`push` returns
    the weighted samples it can already give (the upsampler needs :attr:`margin` samples beyond them), and
    ``push(None, final=True)`` the rest.  The upsampler runs on segments that overlap by the margin (its FIR
    reaches ``10`` input samples either side; the kept samples see the same inputs in the same order as in
    one pass), and ``sosfilt`` carries its state (``zi``) from chunk to chunk."""

    def __init__(self, n_cars: int, fs: float, name: str = "Wk"):
        self.up = max(1, int(math.ceil(MIN_FILTER_RATE / fs - 1e-9)))
        self.sos = _weighting_sos(float(fs * self.up), name)
        self.zi = np.zeros((self.sos.shape[0], n_cars, 2))
        self.margin = 10 + 2  # input samples the upsampler's half-length reaches, and some
        self.buf = np.zeros((n_cars, 0))
        self.buf0 = 0  # global index of buf[:, 0]
        self.done = 0  # weighted samples given so far

    def push(self, x, final: bool = False) -> np.ndarray:
        if x is not None and x.shape[1]:  # (x may be the logger's buffer: only copies of it are kept)
            self.buf = x if self.buf.shape[1] == 0 else np.concatenate([self.buf, x], axis=1)
        total = self.buf0 + self.buf.shape[1]
        if self.up == 1:  # no upsampling: every sample filtered at once
            xu, self.done = self.buf, total
            self.buf, self.buf0 = self.buf[:, :0], total
            if xu.shape[1] == 0:
                return xu
            return sosfilt_rows(self.sos, xu, self.zi, 1)
        end = total if final else total - self.margin
        if end <= self.done:
            self.buf = np.array(self.buf)  # kept whole for the next chunk: a copy
            return self.buf[:, :0]
        seg0 = max(self.buf0, self.done - self.margin)
        seg1 = total if final else min(total, end + self.margin)
        seg = self.buf[:, seg0 - self.buf0:seg1 - self.buf0]
        # resample_poly(seg, up, 1, padtype="edge")[:, (done - seg0) * up:(end - seg0) * up] filtered, one pass
        y = upsampled_filtered(self.sos, seg, (self.done - seg0) * self.up, (end - seg0) * self.up, self.up, self.zi)
        self.done = end
        keep = max(self.buf0, end - self.margin)
        self.buf, self.buf0 = np.array(self.buf[:, keep - self.buf0:]), keep
        return y


class WeightedStats:
    """RMS, peak, VDV and MTVV of a weighted signal a_w that arrives in chunks (``(n_cars, rows)`` each, at
    ``fs`` Hz): :meth:`take` each, :meth:`result` at the end.  The running sum of a_w² for the MTVV windows is
    carried over exactly (the last window's worth kept).  Each chunk is reduced when the next one comes (or
    at the end), so that a record given as one :class:`WeightedStream` chunk (its samples returned in two
    pieces) is reduced in one pass."""

    def __init__(self, n_cars: int, fs: float, tau: float = MTVV_TAU):
        self.n, self.fs = n_cars, fs
        self.win = int(round(tau * fs))
        self.n_aw = 0
        self.ss = np.zeros(n_cars)
        self.pk = np.full(n_cars, np.nan)
        self.vdv4 = np.zeros(n_cars)
        self.prev4 = None
        self.c_tail = np.zeros((n_cars, 1))  # the last values of the running sum of a_w² (c[0] = 0)
        self.best = np.full(n_cars, -np.inf)
        self.pending = None

    def take(self, aw: np.ndarray, last: bool = False) -> None:
        """One chunk of a_w; ``last``: the record's last one (reduced together with the one before)."""
        if self.pending is not None:
            if last:  # the two pieces reduced as one row each (read in turn, not joined into a copy)
                self._reduce(self.pending, aw)
                self.pending = None
                return
            self._reduce(self.pending)
            self.pending = None
        if last:
            if aw.shape[1]:
                self._reduce(aw)
        elif aw.shape[1]:
            self.pending = np.ascontiguousarray(aw)  # (not a strided view holding the upsampled signal)

    def _reduce(self, aw: np.ndarray, aw2: np.ndarray | None = None) -> None:
        # one compiled pass per car (_reduce_rows), the numbers of the numpy form:
        #   sq = aw²; ss += Σ sq; pk = max(pk, max |aw|); a4 = sq² (pow(a_w, 4) costs 60 times more; the two
        #   differ by an ulp or two) with the last chunk's a4 joined on, vdv4 += trapezoid(a4, dx = 1/fs);
        #   the running sum of sq carried sequentially from the last value (np.cumsum's numbers), and the
        #   largest window mean (c[k] − c[k − win]) / win over the windows ending in this chunk
        #   (aw2: a second piece that follows aw, reduced as if the two were one row)
        aw = rows_of(aw)
        aw2 = aw[:, :0] if aw2 is None else rows_of(aw2)
        n_cars, n = aw.shape[0], aw.shape[1] + aw2.shape[1]
        T = self.c_tail.shape[1]
        k0 = self.n_aw + 1  # global index of the chunk's first running-sum value
        g0 = k0 - T  # global index of the row's first value (the tail's)
        a, b = max(self.win, k0) - g0, k0 + n - g0
        windows = self.win >= 1 and b > a
        keep = min(T + n, self.win + 1 if self.win >= 1 else 1)
        out = np.empty((5, n_cars))
        tail = np.empty((n_cars, keep))
        has_prev = self.prev4 is not None
        prev4 = self.prev4[:, 0] if has_prev else np.zeros(n_cars)
        _reduce_rows(aw, aw2, np.ascontiguousarray(self.c_tail), prev4, has_prev, 1.0 / self.fs, self.win if windows else 0,
                     a, b, out, tail)
        self.ss = self.ss + out[0]
        self.pk = out[1] if self.n_aw == 0 else np.maximum(self.pk, out[1])
        if n + has_prev > 1:
            self.vdv4 = self.vdv4 + out[2]
        if n:
            self.prev4 = out[3][:, None]
        if windows:
            self.best = np.maximum(self.best, out[4])
        self.n_aw += n
        self.c_tail = tail

    def result(self) -> dict:
        """``rms``, ``peak``, ``vdv`` (m/s^1.75; 0 below two samples) and ``mtvv`` (the RMS when the record is
        no longer than the window), ``(n_cars,)`` each."""
        if self.pending is not None:
            self._reduce(self.pending)
            self.pending = None
        n = self.n
        rms = np.sqrt(self.ss / self.n_aw) if self.n_aw else np.full(n, np.nan)
        # the fourth root as two square roots: correctly rounded, so one car and many give the same numbers
        # (numpy's vectorised pow(v, 0.25) differs from its scalar one by an ulp)
        vdv_ = np.sqrt(np.sqrt(self.vdv4)) if self.n_aw >= 2 else np.zeros(n)
        mt = rms if self.win < 1 or self.win >= self.n_aw else np.sqrt(np.maximum(self.best, 0.0))
        return {"rms": rms, "peak": self.pk, "vdv": vdv_, "mtvv": mt}


def _stats(aw, fs: float, tau: float = MTVV_TAU) -> dict:
    st = WeightedStats(1, fs, tau)
    st.take(np.asarray(aw, dtype=float).reshape(1, -1), last=True)
    return st.result()


def vdv(aw, fs: float) -> float:
    """Fourth-power vibration dose value (∫ a_w⁴ dt)^(1/4) in m/s^1.75 of a weighted signal at ``fs`` Hz."""
    return float(_stats(aw, fs)["vdv"][0])


def mtvv(aw, fs: float, tau: float = MTVV_TAU) -> float:
    """Maximum of the running RMS of ``aw`` over windows of ``tau`` s (whole record if shorter)."""
    return float(_stats(aw, fs, tau)["mtvv"][0])


@METRICS.register("iso2631")
@metric
class Iso2631(Accumulator):
    """ISO 2631-1 Wk-weighted body heave acceleration: RMS, VDV, MTVV (1 s) and crest factor."""

    channels = ("body_acc",)

    def __init__(self, meta):
        super().__init__(meta)
        self.w = None

    def update(self, chunk) -> None:
        if self.w is None:
            if chunk.dt <= 0:
                return
            self.w = WeightedStream(self.n, 1.0 / chunk.dt, "Wk")
            self.stats = WeightedStats(self.n, 1.0 / chunk.dt)
        self.stats.take(self.w.push(chunk.col("body_acc")))

    def result(self) -> dict:
        if self.w is None:
            return {}
        self.stats.take(self.w.push(None, final=True), last=True)
        st = self.stats.result()
        awr = st["rms"]
        with np.errstate(divide="ignore", invalid="ignore"):
            crest = np.where(awr > 0, st["peak"] / np.where(awr > 0, awr, 1.0), np.nan)
        return {"body_acc_wk_rms": awr, "body_acc_vdv": st["vdv"], "body_acc_wk_mtvv": st["mtvv"],
                "body_acc_wk_crest": crest}


@numba.njit(cache=True, nogil=True)
def _reduce_rows(aw, aw2, c_tail, prev4, has_prev, dx, win, a, b, out, tail):  # pragma: no cover - compiled
    """WeightedStats._reduce of each car's row: out[0] = Σ aw², out[1] = max |aw|, out[2] = the trapezoid sum
    of aw⁴ = (aw²)² with the previous chunk's last aw⁴ (prev4) joined on, at spacing dx, out[3] = the last aw⁴,
    out[4] = the largest (c[k] − c[k − win]) / win for k in [a, b) of the running sum c = [c_tail, c_tail[-1] + Σ aw²
    ...] (win = 0: none); ``tail`` gets c's last values.  Each row is aw's followed by aw2's (two pieces of one
    signal, read in turn).  numpy's and scipy's numbers (pairwise sums, the
    same operations in the same order)."""
    n1 = aw.shape[1]
    n = n1 + aw2.shape[1]
    T = c_tail.shape[1]
    sq = np.empty(n)
    a4 = np.empty(n)
    ab = np.empty(n)
    tmp = np.empty(n + 1)
    c = np.empty(T + n)
    keep = tail.shape[1]
    for r in range(aw.shape[0]):
        for j in range(n):
            v = aw[r, j] if j < n1 else aw2[r, j - n1]
            q = v * v
            sq[j] = q
            a4[j] = q * q
            ab[j] = abs(v)
        out[0, r] = pairwise_sum(sq, 0, n)
        out[1, r] = max_nonneg(ab, n) if out[0, r] == out[0, r] else np.nan  # Σ aw² is NaN iff an aw is
        # scipy.integrate.trapezoid(a4, dx=dx): terms (dx·(y[j+1] + y[j])) / 2.0
        qn = 0
        if has_prev and n > 0:
            tmp[0] = (dx * (a4[0] + prev4[r])) / 2.0
            qn = 1
        for j in range(n - 1):
            tmp[qn] = (dx * (a4[j + 1] + a4[j])) / 2.0
            qn += 1
        out[2, r] = pairwise_sum(tmp, 0, qn) if qn > 0 else 0.0
        out[3, r] = a4[n - 1] if n > 0 else prev4[r]
        for j in range(T):
            c[j] = c_tail[r, j]
        acc = c_tail[r, T - 1]
        for j in range(n):
            acc = acc + sq[j]
            c[T + j] = acc
        if win >= 1:
            best = 0.0
            for k in range(a, b):
                w = (c[k] - c[k - win]) / win
                best = w if k == a else fold_max(best, w)
            out[4, r] = best
        for j in range(keep):
            tail[r, j] = c[T + n - keep + j]
