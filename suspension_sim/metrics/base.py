"""Metric interface.

A metric is registered by name and maps one car's log (:class:`RunView`) to a flat ``dict[str, float]`` (keys
are metric names with units implied by SI; per-corner values carry the corner suffix, e.g.
``travel_rms_front``).  The simplest is a plain function::

    @METRICS.register("travel_range")
    def travel_range(run: RunView) -> dict[str, float]:
        return {f"travel_range{s}": float(np.ptp(run.col(f"travel{s}"))) for s in run.suffixes}

``run.col(name)`` returns a channel as a 1-D float array (``KeyError`` when the log has no such channel: the
metric is then skipped for that model); ``run.ts`` is the whole log as a pandas DataFrame, built on demand
when the view was made from arrays.  Such a metric is computed car by car, and on a long (streamed) run from a
bounded decimated copy of its log.

The built-in metrics are written once, as an :class:`Accumulator`: reductions over chunks of an ensemble's
log, ``(n_cars, rows)`` arrays (:class:`EnsembleView`).  :func:`metric` makes the registered function from it
and attaches the other two forms, so that the one law serves

- one car: the whole log as one chunk of one car (``f(run)``);
- an ensemble after a batch: the whole log as one chunk, every car at once (``f.ensemble(ens)``, vectorised
  over the cars; numpy reductions along the contiguous last axis sum each car's row in the same order as
  one car's, so the two give the same numbers);
- a long run: chunk by chunk as it is logged (``f.stream``, :mod:`suspension_sim.stream`), equal to the
  one-chunk values to rounding.

The same keys come in the same order in all three.  See :func:`metric` for an example.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np
import pandas as pd

from ..compiled.numpy_order import leaf_sums, pairwise_plan, pairwise_sum, push_leaf


@dataclass
class RunView:
    """One car's log: ``ts`` (a DataFrame) or ``columns`` (name -> 1-D array, ``t`` first, in the DataFrame's
    column order; ``ts`` is then built from them on first access)."""

    ts: pd.DataFrame  # columns: t, body_z, body_vel, body_acc, [pitch...], travel{s}, ... (see results.py)
    suffixes: list[str]  # corner suffixes ('' for one-corner models)
    static_tire_force: dict[str, float]  # suffix -> N
    stop_gap: dict[str, float] = field(default_factory=dict)  # suffix -> m (bump-stop free travel), if any
    info: dict = field(default_factory=dict)
    columns: dict | None = field(default=None, repr=False)

    def col(self, name: str) -> np.ndarray:
        """Channel ``name`` as a 1-D float array (``KeyError`` if the log has none)."""
        if self.columns is not None:
            return self.columns[name]
        return self.ts[name].to_numpy()

    def has(self, name: str) -> bool:
        return name in self.columns if self.columns is not None else name in self.ts

    @property
    def n_samples(self) -> int:
        return len(self.columns["t"]) if self.columns is not None else len(self.ts)

    @property
    def dt(self) -> float:
        t = self.col("t")
        return float(t[1] - t[0]) if len(t) > 1 else 0.0


def _ts_get(self) -> pd.DataFrame:
    ts = self.__dict__.get("_ts")
    if ts is None and self.__dict__.get("columns") is not None:
        from ..log import frame_from_columns

        ts = self.__dict__["_ts"] = frame_from_columns(self.columns)
    return ts


def _ts_set(self, value) -> None:
    self.__dict__["_ts"] = value


# ``ts`` stays a dataclass field (same constructor, repr, fields()) but is read through a property, so a view
# made from arrays builds its DataFrame only if some metric asks for it
RunView.ts = property(_ts_get, _ts_set, doc="the log as a DataFrame (built on first access from ``columns``)")


@dataclass
class EnsembleView:
    """The logs of every car of an ensemble, for ensemble versions of metrics.

    ``col(name)`` -> ``(n_cars, n_log)`` array (C-contiguous rows, one per car); ``t`` the common time axis;
    ``static_tire_force`` suffix -> ``(n_cars,)``; ``infos`` and ``stop_gaps`` the per-car ``info`` and
    ``stop_gap`` dicts (what :class:`RunView` carries for one car)."""

    channels: dict  # name -> (n_cars, n_log)
    t: np.ndarray
    suffixes: list[str]
    static_tire_force: dict  # suffix -> (n_cars,) array
    stop_gaps: list = field(default_factory=list)  # per car: suffix -> m
    infos: list = field(default_factory=list)  # per car: the Result's info dict

    @property
    def n_cars(self) -> int:
        return len(self.infos) if self.infos else next(iter(self.channels.values())).shape[0]

    def col(self, name: str) -> np.ndarray:
        """Channel ``name`` of every car, ``(n_cars, n_log)`` with contiguous rows (``KeyError`` if absent)."""
        if name == "t":
            return np.broadcast_to(self.t, (self.n_cars, len(self.t)))
        a = self.channels[name]
        if not a.flags.c_contiguous:  # rows contiguous: numpy then sums each car's row pairwise as for one car
            if is_steps(a):  # a step-major channel (held): turned round in tiles, ~half numpy's time
                r = np.empty(a.shape)
                _rows_of_steps(a.T, r)
                a = self.channels[name] = r
            else:
                a = self.channels[name] = np.ascontiguousarray(a)
        return a

    def held(self, name: str) -> np.ndarray:
        """Channel ``name`` of every car, ``(n_cars, n_log)``, in the layout it is held in: C-contiguous rows, or
        the transpose of a C-contiguous step-major ``(n_log, n_cars)`` array (the compiled loop's log, gathered
        channel by channel without turning it round).  For reductions that take either layout (elementwise
        numpy, ``np.count_nonzero``, :meth:`Reductions.rms_peak`); numpy sums along axis 1 need :meth:`col`."""
        if name == "t":
            return self.col(name)
        a = self.channels[name]
        return a if a.flags.c_contiguous or a.T.flags.c_contiguous else self.col(name)

    def has(self, name: str) -> bool:
        return name == "t" or name in self.channels

    @property
    def n_samples(self) -> int:
        return len(self.t)

    @property
    def dt(self) -> float:
        t = self.t
        return float(t[1] - t[0]) if len(t) > 1 else 0.0


def rms(x) -> float:
    """RMS of a 1-D array (NaN when empty): for metrics written as plain per-car functions."""
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


# ----------------------------------------------------------------------------------------------------------
# the law of a built-in metric: an accumulator over the chunks of an ensemble's log
# ----------------------------------------------------------------------------------------------------------
class Accumulator:
    """A metric written once, as reductions over chunks of an ensemble's log.

    Made with the run's :class:`EnsembleView` (``meta``: suffixes, static loads, stop gaps, infos; its samples
    are not read), :meth:`update` gets each chunk of the log in time order as an :class:`EnsembleView`
    (``(n_cars, rows)`` channels, ``chunk.t`` the chunk's times, ``chunk.dt`` the log step) and
    :meth:`result` returns ``key -> (n_cars,) array``.  :func:`metric` derives from it the per-car function
    (the whole log as one chunk of one car) and the ensemble version (the whole log as one chunk); a long
    run feeds it chunk by chunk (:mod:`suspension_sim.stream`).  A reduction over one chunk is the one-pass
    reduction (the same numpy operations on the same rows: bit-identical for one car and for many); over
    several it equals it to rounding (~1e-15 relative).

    ``channels``: the log channels it reads (``{s}`` stands for every corner suffix), so that a batch logs
    only those and gathers them together before the metrics.  Raise ``KeyError`` (``chunk.col`` does) when
    the log lacks a channel: the metric is then skipped; ``NotImplementedError`` from ``__init__`` to have
    the metric computed car by car for this ensemble."""

    channels: tuple = ()

    def __init__(self, meta: EnsembleView):
        self.meta, self.n = meta, meta.n_cars
        self.r = Reductions(self.n)

    def update(self, chunk: EnsembleView) -> None:
        raise NotImplementedError

    def result(self) -> dict:
        raise NotImplementedError


class Reductions:
    """Per-car running reductions of a chunked log, by key: ``sum``/``max``/``count`` of ``(n_cars, rows)``
    chunks, trapezoid sums, ``n`` samples so far and ``dt`` the log step (call :meth:`start` per chunk)."""

    def __init__(self, n_cars: int):
        self.n_cars = n_cars
        self.v: dict = {}
        self.n = 0
        self.dt = 0.0
        self.last: dict = {}

    def start(self, chunk: EnsembleView) -> None:
        """Call once per chunk before the reductions: counts its samples, records the log step."""
        if self.n == 0 and len(chunk.t) > 1:
            self.dt = float(chunk.t[1] - chunk.t[0])
        self.n += len(chunk.t)

    def sum_value(self, key, s: np.ndarray) -> None:
        self.v[key] = s if key not in self.v else self.v[key] + s

    def sum(self, key, x: np.ndarray) -> None:
        self.sum_value(key, np.sum(x, axis=1))

    def max(self, key, x: np.ndarray) -> None:
        if x.shape[1] == 0:
            return
        self.max_value(key, np.max(x, axis=1))

    def count(self, key, mask: np.ndarray) -> None:
        self.sum_value(key, np.count_nonzero(mask, axis=1).astype(float))

    def max_value(self, key, m: np.ndarray) -> None:
        """Fold the chunk's maxima ``m`` (n_cars,) into ``key``."""
        self.v[key] = m if key not in self.v else np.maximum(self.v[key], m)

    def rms_peak(self, key, x: np.ndarray) -> None:
        """Sum of squares and max |x| of ``x`` under ``key`` (read with :meth:`rms` and :meth:`peak`): the
        numbers of ``np.sum(x * x, axis=1)`` and ``np.max(np.abs(x), axis=1)``, in one compiled pass."""
        if x.shape[1] == 0:
            self.sum_value(f"{key}.ss", np.zeros(x.shape[0]))
            return
        ss, pk = np.empty(x.shape[0]), np.empty(x.shape[0])
        if is_steps(x):  # a step-major channel (EnsembleView.held): the cars side by side, the same sums
            colsq_maxabs(x.T, ss, pk)
        else:
            sumsq_maxabs(rows_of(x), ss, pk)
        self.sum_value(f"{key}.ss", ss)
        self.max_value(f"{key}.pk", pk)

    def trapezoid(self, key, y: np.ndarray, t: np.ndarray) -> None:
        """∫ y dt over the chunks (scipy's trapezoid rule, the previous chunk's last sample joined on)."""
        prev = self.last.get(key)
        if prev is not None:
            y = np.concatenate([prev[0], y], axis=1)
            t = np.concatenate([prev[1], t])
        if y.shape[1] > 1:
            from scipy import integrate

            self.sum_value(key, integrate.trapezoid(y, t, axis=-1))
        self.last[key] = (y[:, -1:], t[-1:])

    def trapezoid_value(self, key, s: np.ndarray | None, last_y: np.ndarray, last_t: np.ndarray) -> None:
        """Fold a chunk's trapezoid sum ``s`` (None: no interval yet) into ``key``, with the chunk's last sample
        (``(n_cars, 1)``) and time (``(1,)``) for the next chunk (what :meth:`trapezoid` keeps)."""
        if s is not None:
            self.sum_value(key, s)
        self.last[key] = (last_y, last_t)

    def get(self, key, default: float = np.nan) -> np.ndarray:
        return self.v.get(key, np.full(self.n_cars, default))

    def mean(self, key) -> np.ndarray:
        """Sum under ``key`` over the samples so far (NaN when there were none)."""
        return self.get(key) / self.n if self.n else np.full(self.n_cars, np.nan)

    def rms(self, key) -> np.ndarray:
        return np.sqrt(self.mean(f"{key}.ss"))

    def peak(self, key) -> np.ndarray:
        return self.get(f"{key}.pk")

    @property
    def duration(self) -> float:
        """Length of the record so far, s (each sample standing for one log step)."""
        return self.n * self.dt


class _OneCar(EnsembleView):
    """One car's :class:`RunView` seen as an ensemble of one car (its channels read on demand)."""

    def __init__(self, run: RunView):
        super().__init__(channels={}, t=np.asarray(run.col("t"), dtype=float), suffixes=list(run.suffixes),
                         static_tire_force={s: np.array([float(v)]) for s, v in run.static_tire_force.items()},
                         stop_gaps=[run.stop_gap], infos=[run.info])
        self.run = run

    def col(self, name: str) -> np.ndarray:
        if name == "t":
            return self.t[None, :]
        a = self.channels.get(name)
        if a is None:
            a = self.channels[name] = np.ascontiguousarray(self.run.col(name), dtype=float)[None, :]
        return a

    def held(self, name: str) -> np.ndarray:
        return self.col(name)

    def has(self, name: str) -> bool:
        return name in self.channels or self.run.has(name)


def one_chunk(acc: type, ens: EnsembleView) -> dict:
    """``acc``'s result on a whole log given as one chunk: ``key -> (n_cars,) array``."""
    a = acc(ens)
    a.update(ens)
    return a.result()


def metric(acc: type):
    """Decorator: the registrable metric of an :class:`Accumulator` subclass, a function
    ``f(run: RunView) -> dict[str, float]`` (the accumulator on the whole log of one car), with
    ``f.ensemble(ens)`` (on the whole log of an ensemble), ``f.stream`` (the accumulator, for long runs) and
    ``f.ensemble_channels`` attached::

        @METRICS.register("body_acc")
        @metric
        class BodyAcc(Accumulator):
            \"\"\"RMS and peak heave acceleration of the body at the c.g. (m/s²).\"\"\"

            channels = ("body_acc",)

            def update(self, chunk):
                self.r.start(chunk)
                self.r.rms_peak("a", chunk.col("body_acc"))

            def result(self):
                return {"body_acc_rms": self.r.rms("a"), "body_acc_peak": self.r.peak("a")}
    """

    def per_car(run: RunView) -> dict:
        return {k: float(np.asarray(v, dtype=float).reshape(-1)[0]) for k, v in one_chunk(acc, _OneCar(run)).items()}

    def ensemble(ens: EnsembleView) -> dict:
        return one_chunk(acc, ens)

    per_car.__name__ = per_car.__qualname__ = acc.__name__
    per_car.__module__, per_car.__doc__ = acc.__module__, acc.__doc__
    per_car.ensemble, per_car.stream, per_car.ensemble_channels = ensemble, acc, tuple(acc.channels)
    return per_car


class CornerRmsPeak(Accumulator):
    """A per-corner RMS-and-peak metric: ``{key}_rms{s}`` and ``{key}_peak{s}`` (max |x|) of channel
    ``{channel}{s}`` for every corner suffix ``s``.  A subclass sets :attr:`channel` and :attr:`key`, and may
    add per-corner keys after them with :meth:`more`."""

    channel = ""
    key = ""

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls.channels = (f"{cls.channel}{{s}}",)

    def update(self, chunk: EnsembleView) -> None:
        self.r.start(chunk)
        for s in chunk.suffixes:
            self.r.rms_peak(s, chunk.held(f"{self.channel}{s}"))

    def more(self, s: str, rms: np.ndarray) -> dict:
        """Further keys of corner ``s`` from its RMS (none by default)."""
        return {}

    def result(self) -> dict:
        out = {}
        for s in self.meta.suffixes:
            r = self.r.rms(s)
            out[f"{self.key}_rms{s}"] = r
            out[f"{self.key}_peak{s}"] = self.r.peak(s)
            out.update(self.more(s, r))
        return out


# ----------------------------------------------------------------------------------------------------------
# compiled reductions: numpy's numbers (the same operations; sums in numpy's pairwise order, numpy_order),
# one pass over each car's row instead of a numpy pass and a temporary per operation
# ----------------------------------------------------------------------------------------------------------
def rows_of(x) -> np.ndarray:
    """``x`` as a C-contiguous float64 2-D array (a view when it is one)."""
    return np.ascontiguousarray(x, dtype=np.float64)


def is_steps(x) -> bool:
    """Whether ``x`` (n_cars, rows) is the transpose of a C-contiguous float64 step-major array (and not itself
    C-contiguous): the kernels then run over its steps with the cars side by side (:func:`colsq_maxabs`)."""
    return x.ndim == 2 and x.dtype == np.float64 and not x.flags.c_contiguous and x.T.flags.c_contiguous


@numba.njit(cache=True, inline="always")
def fold_max(m, a):  # pragma: no cover - compiled
    """np.maximum.reduce's step: NaN once seen stays, else the larger."""
    if m == m and not a <= m:
        return a
    return m


@numba.njit(cache=True, inline="always")
def max_nonneg(a, n):  # pragma: no cover - compiled
    """The largest of a[0:n] (n >= 1, values >= 0 or NaN), NaN ignored: four independent running maxima
    (np.max's number when a holds no NaN; the callers know from their sum whether it does)."""
    m0 = a[0]
    m1 = m0
    m2 = m0
    m3 = m0
    j = 0
    while j + 4 <= n:
        m0 = a[j] if a[j] > m0 else m0
        m1 = a[j + 1] if a[j + 1] > m1 else m1
        m2 = a[j + 2] if a[j + 2] > m2 else m2
        m3 = a[j + 3] if a[j + 3] > m3 else m3
        j += 4
    while j < n:
        m0 = a[j] if a[j] > m0 else m0
        j += 1
    m0 = m1 if m1 > m0 else m0
    m2 = m3 if m3 > m2 else m2
    return m2 if m2 > m0 else m0


@numba.njit(cache=True, nogil=True)
def sumsq_maxabs(x, ss, pk):  # pragma: no cover - compiled
    """ss[r] = np.sum(x[r] * x[r]) (numpy's pairwise order) and pk[r] = np.max(np.abs(x[r])) (NaN when x[r]
    holds a NaN, which is when the sum of squares is NaN); rows of at least one sample."""
    n = x.shape[1]
    tmp = np.empty(n)
    ab = np.empty(n)
    for r in range(x.shape[0]):
        for j in range(n):
            v = x[r, j]
            tmp[j] = v * v
            ab[j] = abs(v)
        ss[r] = pairwise_sum(tmp, 0, n)
        pk[r] = max_nonneg(ab, n) if ss[r] == ss[r] else np.nan


@numba.njit(cache=True, nogil=True)
def _rows_of_steps(x, r):  # pragma: no cover - compiled
    """r[c, j] = x[j, c]: a step-major (rows, cars) array as per-car rows, 64 × 64 tiles at a time."""
    n, m = x.shape
    for j0 in range(0, n, 64):
        j1 = min(j0 + 64, n)
        for c0 in range(0, m, 64):
            c1 = min(c0 + 64, m)
            for c in range(c0, c1):
                for j in range(j0, j1):
                    r[c, j] = x[j, c]


@numba.njit(cache=True, nogil=True)
def colsq_maxabs(x, ss, pk):  # pragma: no cover - compiled
    """:func:`sumsq_maxabs` of every column of a step-major ``x`` (rows, cars): ss[c] = np.sum(x[:, c] ** 2) in
    numpy's pairwise order (the same tree of additions per car, :func:`~suspension_sim.compiled.numpy_order.
    pairwise_plan`, the cars side by side in each) and pk[c] = max |x[:, c]| (NaN when ss[c] is); at least
    one row.  The same numbers as sumsq_maxabs of the transposed rows."""
    n, m = x.shape
    lo, ln, merges = pairwise_plan(n)
    T = np.empty((128, m))
    acc = np.empty((8, m))
    res = np.empty(m)
    stack = np.empty((64, m))
    for c in range(m):
        pk[c] = 0.0
    top = 0
    for li in range(lo.shape[0]):
        r0 = lo[li]
        for i in range(ln[li]):
            for c in range(m):
                v = x[r0 + i, c]
                T[i, c] = v * v
                a = abs(v)
                pk[c] = a if a > pk[c] else pk[c]
        leaf_sums(T, ln[li], acc, res)
        top = push_leaf(stack, top, res, merges[li])
    for c in range(m):
        ss[c] = stack[0, c]
        if ss[c] != ss[c]:
            pk[c] = np.nan


@numba.njit(cache=True, inline="always")
def trapezoid_terms(y, t, prev_y, prev_t, has_prev, tmp):  # pragma: no cover - compiled
    """tmp[j] = ((t[j+1] − t[j])·(y[j+1] + y[j])) / 2.0 over [prev_y, y] at [prev_t, t] (scipy.integrate.trapezoid's
    terms, the previous chunk's last sample joined on when ``has_prev``); returns the number of terms."""
    n = y.shape[0]
    q = 0
    if has_prev and n > 0:
        tmp[0] = ((t[0] - prev_t) * (y[0] + prev_y)) / 2.0
        q = 1
    for j in range(n - 1):
        tmp[q] = ((t[j + 1] - t[j]) * (y[j + 1] + y[j])) / 2.0
        q += 1
    return q
