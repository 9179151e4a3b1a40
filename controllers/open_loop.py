"""Open-loop command signals for rigs and system identification: a prescribed actuator command per corner,
independent of any measurement (no sensors needed).

    u(t) = offset + s(t − start)      for start <= t < stop,   offset otherwise

with ``s`` one of

- ``constant``: ``amplitude`` at all times (``start``/``stop`` ignored);
- ``step``: ``amplitude`` from ``start`` on (back to ``offset`` at ``stop``: a pulse);
- ``sine``: ``amplitude·sin(2π·frequency·τ + phase)``;
- ``multisine``: ``amplitude·Σ_i a_i·sin(2π·f_i·τ + φ_i)`` over ``frequencies``, with ``a_i`` = ``amplitudes``
  (default: all 1) and ``phases``: ``schroeder`` (low crest factor, φ_i = −π·i·(i−1)/N, i = 1..N), ``random`` (seeded) or
  ``zero``;
- ``chirp``: ``amplitude·scipy.signal.chirp(τ, f0, t1, f1, method)`` with the phase shifted by −90° so that
  it starts at zero like the sine (``method``: linear, quadratic, logarithmic, hyperbolic);
- ``prbs``: ``±amplitude`` following a maximum-length binary sequence (``scipy.signal.max_len_seq``, ``nbits``,
  seeded initial register), one bit per ``hold`` seconds;
- ``random``: seeded Gaussian white noise of standard deviation ``amplitude``, held for ``hold`` seconds
  (default: one control step);
- ``table``: a recorded signal from a CSV file with columns ``time_column`` (s) and ``column`` (or one column
  per corner), interpolated (``linear`` or ``previous`` = zero-order hold), held at the end values outside
  the table, multiplied by ``amplitude``; table time 0 is ``start``.  A relative ``file`` is relative to the
  working directory.

``amplitude`` and ``offset`` may be one value or one per corner (e.g. ``amplitude: [500, 0]`` drives only
the front of a half car).  ``fade_in`` (s) ramps the signal in with a half cosine from ``start``.  The
random signals are the same on every corner unless ``independent: true``.  The command's unit is the
actuator's (N for a force actuator).

The law is written once, as the numba function ``_kernel`` (one car).  The ``random`` signal's samples are
drawn lazily from numpy Generators, in Python (its controller is an ``_OpenLoopRandom``: the compiled loop
returns to Python at its control instants), and handed to the same law.
"""
from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Literal, Optional, Union

import numba
import numpy as np
from pydantic import Field, model_validator
from scipy.signal import max_len_seq

from suspension_sim.compiled.numpy_order import pairwise_sum
from suspension_sim.components import Params
from suspension_sim.errors import ScenarioError
from suspension_sim.kernels import broadcast_controller, call, f64
from suspension_sim.registry import CONTROLLERS

from .base import Controller

Num = Union[float, list[float]]


class OpenLoopParams(Params):
    signal: Literal["constant", "step", "sine", "multisine", "chirp", "prbs", "random", "table"] = "sine"
    amplitude: Num = Field(1.0, description="amplitude (command unit), one value or one per corner")
    offset: Num = Field(0.0, description="constant added at all times, one value or one per corner")
    start: float = Field(0.0, ge=0, description="s, signal start")
    stop: Optional[float] = Field(None, gt=0, description="s, signal end (offset only afterwards)")
    fade_in: float = Field(0.0, ge=0, description="s, half-cosine fade-in from start")
    frequency: Optional[float] = Field(None, gt=0, description="Hz (sine)")
    phase: float = Field(0.0, description="rad (sine, chirp)")
    frequencies: Optional[list[float]] = Field(None, description="Hz (multisine lines)")
    amplitudes: Optional[list[float]] = Field(None, description="per line, times amplitude (multisine; default: all 1)")
    phases: Union[Literal["schroeder", "random", "zero"], list[float]] = Field(
        "schroeder", description="multisine phases: schroeder, random, zero or a list (rad)")
    f0: Optional[float] = Field(None, gt=0, description="Hz, chirp start frequency")
    f1: Optional[float] = Field(None, gt=0, description="Hz, chirp frequency reached at t1")
    t1: Optional[float] = Field(None, gt=0, description="s after start at which the chirp reaches f1")
    method: Literal["linear", "quadratic", "logarithmic", "hyperbolic"] = "linear"
    hold: Optional[float] = Field(None, gt=0, description="s per bit (prbs) or sample (random); default control_dt")
    nbits: int = Field(10, ge=2, le=31, description="prbs register length: period 2^nbits − 1 bits")
    seed: int = Field(0, description="seed of prbs, random and random multisine phases")
    independent: bool = Field(False, description="independent random sequences per corner")
    file: Optional[str] = Field(None, description="CSV file (table)")
    time_column: str = Field("time", description="table time column (s)")
    column: Union[str, list[str]] = Field("value", description="table value column, or one per corner")
    interpolation: Literal["linear", "previous"] = "linear"

    @model_validator(mode="after")
    def _needs(self):
        need = {"sine": ["frequency"], "multisine": ["frequencies"], "chirp": ["f0", "f1", "t1"], "table": ["file"]}
        missing = [k for k in need.get(self.signal, []) if getattr(self, k) is None]
        if missing:
            raise ValueError(f"signal '{self.signal}' needs {', '.join(missing)}")
        if self.signal == "multisine":
            if not self.frequencies or any(f <= 0 for f in self.frequencies):
                raise ValueError("frequencies must be a non-empty list of positive values (Hz)")
            for name in ("amplitudes", "phases"):
                v = getattr(self, name)
                if isinstance(v, list) and len(v) != len(self.frequencies):
                    raise ValueError(f"{name} needs one value per frequency ({len(self.frequencies)})")
        if self.stop is not None and self.stop <= self.start:
            raise ValueError("stop must be after start")
        if self.signal == "table":
            cols = [self.column] if isinstance(self.column, str) else list(self.column)
            load_table(self.file, self.time_column, tuple(cols))  # a bad file fails validation
        return self


def _csv_error(path, msg):
    return ScenarioError(msg, source=f"table file {path}")


def load_table(path: str, time_column: str, columns: tuple[str, ...]):
    """(time array, values (len, n_columns)) of a CSV command table; bad files raise a one-line error."""
    p = Path(path)
    try:
        mtime = p.stat().st_mtime
    except OSError:
        raise _csv_error(path, "file not found") from None
    return _load_table(str(p), mtime, time_column, columns)


@lru_cache(maxsize=32)
def _load_table(path, mtime, time_column, columns):
    import pandas as pd

    try:
        df = pd.read_csv(path)
    except Exception as err:  # noqa: BLE001 - any parse failure is the user's file
        raise _csv_error(path, f"not a readable CSV ({type(err).__name__}: {str(err).splitlines()[0]})") from None
    have = [str(c) for c in df.columns]
    for c in (time_column, *columns):
        if c not in df.columns:
            raise _csv_error(path, f"no column {c!r} (has: {', '.join(have)})")
    out = []
    for c in (time_column, *columns):
        v = pd.to_numeric(df[c], errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise _csv_error(path, f"column {c!r}: non-numeric or missing value at data row {bad[0] + 1}")
        out.append(v)
    t = out[0]
    if t.size < 2:
        raise _csv_error(path, "needs at least two rows")
    if np.any(np.diff(t) <= 0):
        i = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 2
        raise _csv_error(path, f"column {time_column!r}: times must increase (data row {i})")
    return t, np.column_stack(out[1:])


# compiled kernel --------------------------------------------------------------------------------------------
# parameter row: a fixed header, then amplitude and offset per corner, then the signal's data (multisine
# lines f, a, φ; the PRBS sequence; the table's times and columns)
_SIGNALS = ("constant", "step", "sine", "multisine", "chirp", "prbs", "table", "random")
_METHODS = ("linear", "quadratic", "logarithmic", "hyperbolic")
(_H_SIG, _H_START, _H_HASSTOP, _H_STOP, _H_FADE, _H_HOLD, _H_FREQ, _H_PHASE, _H_METHOD, _H_F0, _H_F1, _H_T1,
 _H_LEN, _H_K, _H_PREV) = range(15)
_HEADER = 15


@numba.njit(cache=True)
def _chirp(t, f0, t1, f1, method, phi_deg):
    """scipy.signal.chirp(t, f0, t1, f1, method, phi) for a scalar t, in scipy's order of operations."""
    pi = np.pi
    if method == 0:
        beta = (f1 - f0) / t1
        phase = 2 * pi * (f0 * t + 0.5 * beta * t * t)
    elif method == 1:
        beta = (f1 - f0) / (t1 ** 2.0)
        phase = 2 * pi * (f0 * t + beta * t ** 3.0 / 3)
    elif method == 2:
        if f0 == f1:
            phase = 2 * pi * f0 * t
        else:
            beta = t1 / np.log(f1 / f0)
            phase = 2 * pi * beta * f0 * ((f1 / f0) ** (t / t1) - 1.0)
    else:
        if f0 == f1:
            phase = 2 * pi * f0 * t
        else:
            sing = -f1 * t1 / (f0 - f1)
            phase = 2 * pi * (-sing * f0) * np.log(np.abs(1 - t / sing))
    return np.cos(phase + phi_deg * (np.pi / 180.0))


@numba.njit(cache=True)
def _kernel(t, y, p, st, u):
    """The law for one car: u = offset + amplitude·s(τ) while active, offset otherwise; s(τ) goes into st[0:k]
    (k = 1: shared by the corners; st[1:] is scratch for the multisine terms); for ``random`` the caller has
    written the samples there."""
    nc = u.shape[0]
    sig = int(p[_H_SIG])
    amp = _HEADER
    off = _HEADER + nc
    d = _HEADER + 2 * nc
    if sig == 0:
        for c in range(nc):
            u[c] = p[off + c] + p[amp + c]
        return
    tau = t - p[_H_START]
    active = tau >= 0
    if p[_H_HASSTOP] != 0.0:
        active = active and t < p[_H_STOP]
    taum = max(tau, 0.0) if not np.isnan(tau) else tau
    k = int(p[_H_K])
    n = int(p[_H_LEN])
    # s(τ) into st[0:k] (k = 1: shared by the corners)
    if sig == 1:
        st[0] = 1.0
    elif sig == 2:
        st[0] = np.sin(2 * np.pi * p[_H_FREQ] * taum + p[_H_PHASE])
    elif sig == 3:
        for j in range(n):
            st[1 + j] = p[d + n + j] * np.sin(2 * np.pi * p[d + j] * taum + p[d + 2 * n + j])
        st[0] = pairwise_sum(st, 1, n)
    elif sig == 4:
        st[0] = _chirp(taum, p[_H_F0], p[_H_T1], p[_H_F1], int(p[_H_METHOD]), p[_H_PHASE] * (180.0 / np.pi) - 90.0)
    elif sig == 5:
        j = int(np.floor(taum / p[_H_HOLD] + 1e-9)) % n
        for c in range(k):
            st[c] = p[d + j * k + c]
    elif sig == 6:
        tt = p[d:d + n]
        if p[_H_PREV] != 0.0:
            j = np.searchsorted(tt, taum, side="right") - 1
            j = min(max(j, 0), n - 1)
            for c in range(k):
                st[c] = p[d + n + c * n + j]
        else:
            for c in range(k):
                st[c] = np.interp(taum, tt, p[d + n + c * n:d + n + (c + 1) * n])
    fade = p[_H_FADE]
    if fade > 0:  # half-cosine fade-in
        x = min(max(tau / fade, 0.0), 1.0)
        w = 0.5 - 0.5 * np.cos(np.pi * x)
        for c in range(k):
            st[c] = st[c] * w
    for c in range(nc):
        sc = st[c] if k > 1 else st[0]
        u[c] = p[off + c] + (p[amp + c] * sc if active else 0.0)


@CONTROLLERS.register("open_loop")
class OpenLoop(Controller):
    """Open-loop command: constant, step, sine, multisine, chirp, PRBS, random or a CSV table (no sensors)."""

    Params = OpenLoopParams
    requires = ()
    kernel = staticmethod(_kernel)

    def __new__(cls, *args, **kwargs):
        # the compiled loop looks for the kernel on the class: a 'random' signal (Gaussian samples drawn
        # lazily from numpy Generators as time goes on) has none, so its controller is an _OpenLoopRandom
        if cls is OpenLoop and args and getattr(args[0], "signal", None) == "random":
            cls = _OpenLoopRandom
        return super().__new__(cls)

    def _corner_array(self, name):
        n, nc = self.ctx.n_cars, self.ctx.n_corners
        a = np.asarray(getattr(self.p, name), dtype=float)
        a = a.reshape(1, -1) if a.ndim <= 1 else a.reshape(a.shape[0], -1)  # a list shared by the cars: one row
        if a.shape[0] not in (1, n) or a.shape[1] not in (1, nc):
            raise ScenarioError(f"needs one value or one per corner ({nc})", field=f"controller.params.{name}")
        return np.broadcast_to(a, (n, nc)).astype(float)

    def reset(self):
        super().reset()
        p, n, nc = self.p, self.ctx.n_cars, self.ctx.n_corners
        self.amp = self._corner_array("amplitude")
        self.off = self._corner_array("offset")
        self.sig = self.p.signal if isinstance(self.p.signal, str) else None
        if self.sig is None:
            raise ScenarioError("all cars of an ensemble must use the same signal type", field="controller.params.signal")
        col = lambda v: np.asarray(v, dtype=float).reshape(-1, 1) if v is not None else None  # noqa: E731
        self.start_ = col(p.start)
        stop = [np.inf if v is None else v for v in p.stop] if isinstance(p.stop, list) else p.stop  # cars differ
        self.stop_ = col(stop) if stop is not None else None
        self.fade = col(p.fade_in)
        seeds = np.asarray(p.seed, dtype=float).reshape(-1)
        seeds = np.broadcast_to(seeds, (n,)).astype(np.int64)
        self.rngs = [np.random.default_rng([int(s) & 0xFFFFFFFF, 4242]) for s in seeds]
        k = nc if p.independent else 1
        hold = [self.ctx.control_dt if v is None else v for v in p.hold] if isinstance(p.hold, list) else p.hold
        self.hold = col(hold) if hold is not None else np.full((n, 1), self.ctx.control_dt)
        if self.sig == "multisine":
            f = self._lines("frequencies")
            a = self._lines("amplitudes") if p.amplitudes is not None else np.ones_like(f)
            if p.phases == "schroeder":
                L = f.shape[1]
                i = np.arange(1, L + 1)
                ph = np.broadcast_to(-np.pi * i * (i - 1) / L, f.shape)
            elif p.phases == "random":
                ph = np.stack([r.uniform(-np.pi, np.pi, f.shape[1]) for r in self.rngs])
            elif p.phases == "zero":
                ph = np.zeros_like(f)
            else:
                ph = self._lines("phases")
            self.ms = (f, a, ph)  # (n, L) each
        elif self.sig == "prbs":
            seqs = []
            for i, r in enumerate(self.rngs):
                nb = int(np.asarray(p.nbits).reshape(-1)[0])
                cols = []
                for _ in range(k):
                    state = r.integers(0, 2, nb)
                    if not state.any():
                        state[0] = 1
                    cols.append(2.0 * max_len_seq(nb, state=state)[0] - 1.0)
                seqs.append(np.stack(cols, axis=1))  # (period, k)
            self.seq = seqs
        elif self.sig == "random":
            self.k = k
            self.noise = [np.zeros((0, k)) for _ in range(n)]
        elif self.sig == "table":
            files = [p.file] * n if isinstance(p.file, str) else list(p.file)
            self.tables = []
            for i in range(n):
                cols = p.column if isinstance(p.column, str) else p.column
                cols = (cols,) if isinstance(cols, str) else tuple(cols)
                if len(cols) not in (1, nc):
                    raise ScenarioError(f"needs one column or one per corner ({nc})", field="controller.params.column")
                t, v = load_table(files[i], p.time_column, cols)
                self.tables.append((t, v))

    def _lines(self, name):
        v = getattr(self.p, name)
        a = np.asarray(v, dtype=float)
        if a.ndim == 1:
            a = np.broadcast_to(a, (self.ctx.n_cars, a.size))
        return a.reshape(self.ctx.n_cars, -1)

    def kernel_data(self):
        n, nc = self.ctx.n_cars, self.ctx.n_corners
        p_, per_car = self.p, self.per_car

        if self.sig == "multisine":
            f, a, ph = (np.broadcast_to(x, (n, self.ms[0].shape[1])) for x in self.ms)
            data = [np.concatenate([f[i], a[i], ph[i]]) for i in range(n)]
            length, k, ks = f.shape[1], 1, 1 + f.shape[1]
        elif self.sig == "prbs":
            data = [q.reshape(-1) for q in self.seq]
            length = [len(q) for q in self.seq]  # per car
            ks = k = self.seq[0].shape[1]
        elif self.sig == "table":
            ks = k = self.tables[0][1].shape[1]
            if any(vv.shape[1] != k for _, vv in self.tables):
                raise NotImplementedError("open_loop kernel: table widths differ across the cars")
            length = [len(tt) for tt, _ in self.tables]  # per car
            data = [np.concatenate([tt, vv.T.reshape(-1)]) for tt, vv in self.tables]
        elif self.sig == "random":
            data = [np.zeros(0)] * n
            length, ks = 0, self.k
            k = ks
        else:
            data = [np.zeros(0)] * n
            length, k, ks = 0, 1, 1
        kp = _HEADER + 2 * nc + max(len(x) for x in data)
        p = np.zeros((n, kp))
        p[:, _H_SIG] = _SIGNALS.index(self.sig)
        p[:, _H_START] = self.start_[:, 0]
        p[:, _H_HASSTOP] = float(self.stop_ is not None)
        if self.stop_ is not None:
            p[:, _H_STOP] = np.broadcast_to(self.stop_, (n, 1))[:, 0]
        p[:, _H_FADE] = np.broadcast_to(self.fade, (n, 1))[:, 0]
        p[:, _H_HOLD] = np.broadcast_to(self.hold, (n, 1))[:, 0]
        if self.sig == "sine":
            p[:, _H_FREQ] = per_car(p_.frequency)
        if self.sig in ("sine", "chirp"):
            p[:, _H_PHASE] = per_car(p_.phase)
        if self.sig == "chirp":
            p[:, _H_METHOD] = _METHODS.index(p_.method)
            p[:, _H_F0], p[:, _H_F1], p[:, _H_T1] = per_car(p_.f0), per_car(p_.f1), per_car(p_.t1)
        p[:, _H_LEN] = length
        p[:, _H_K] = k
        p[:, _H_PREV] = float(self.sig == "table" and p_.interpolation == "previous")
        p[:, _HEADER:_HEADER + nc] = self.amp
        p[:, _HEADER + nc:_HEADER + 2 * nc] = self.off
        for i, x in enumerate(data):
            p[i, _HEADER + 2 * nc:_HEADER + 2 * nc + len(x)] = x
        return np.ascontiguousarray(p), np.zeros((n, ks))


class _OpenLoopRandom(OpenLoop):
    """OpenLoop with the ``random`` signal (see OpenLoop.__new__): Gaussian samples drawn lazily from numpy
    Generators, one per ``hold`` seconds, handed to the law; no compiled kernel."""

    kernel = None

    def step(self, t, y):
        if self._kd is None:
            self._kd = tuple(f64(x) for x in self.kernel_data())
        p, st = self._kd
        tau = np.maximum(t - self.start_[:, 0], 0.0)
        idx = np.floor(tau / self.hold[:, 0] + 1e-9).astype(np.int64)
        for i in range(self.ctx.n_cars):
            while idx[i] >= len(self.noise[i]):
                self.noise[i] = np.concatenate([self.noise[i], self.rngs[i].standard_normal((1024, self.k))])
            st[i, :self.k] = self.noise[i][max(idx[i], 0)]
        u = self.zeros()
        call(broadcast_controller, _kernel, float(t), np.zeros((self.ctx.n_cars, 0)), p, st, u)
        return u
