"""Metric interface.

A metric is a function registered by name that takes a :class:`RunView` (one car's log) and returns a flat
``dict[str, float]`` (keys are metric names with units implied by SI; per-corner values carry the corner
suffix, e.g. ``travel_rms_front``)::

    @METRICS.register("body_acc")
    def body_acc(run: RunView) -> dict[str, float]:
        a = run.col("body_acc")          # or run.ts["body_acc"].to_numpy()
        return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}

``run.col(name)`` returns a channel as a 1-D float array (``KeyError`` when the log has no such channel: the
metric is then skipped for that model); ``run.ts`` is the whole log as a pandas DataFrame, built on demand
when the view was made from arrays (it costs more than the metric itself for short runs).

Optionally a metric also gets an *ensemble* version that computes it for every car of an ensemble at once
from ``(n_cars, n_log)`` arrays (:class:`EnsembleView`) and returns ``key -> (n_cars,) array``, with the same
keys in the same order as the per-car function and **bit-identical** values (the same floating-point
operations on every car's samples: numpy reductions along the contiguous last axis sum in the same pairwise
order as on one car's 1-D array; ``tests/test_results_fast.py`` checks it against the per-car function)::

    @ensemble_version(body_acc, channels=("body_acc",))
    def _body_acc_many(ens: EnsembleView) -> dict[str, np.ndarray]:
        a = ens.col("body_acc")
        return {"body_acc_rms": rms_rows(a), "body_acc_peak": np.max(np.abs(a), axis=1)}

Metrics without one are computed car by car (:func:`suspension_sim.results.compute_metrics`); an ensemble
version may raise ``NotImplementedError`` to fall back to that for a particular ensemble.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


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
            a = self.channels[name] = np.ascontiguousarray(a)
        return a

    def has(self, name: str) -> bool:
        return name == "t" or name in self.channels

    @property
    def n_samples(self) -> int:
        return len(self.t)

    @property
    def dt(self) -> float:
        t = self.t
        return float(t[1] - t[0]) if len(t) > 1 else 0.0


def ensemble_version(metric, channels: tuple = ()):
    """Decorator: attach ``fn(ens: EnsembleView) -> {key: (n_cars,) array}`` to the per-car ``metric`` as its
    ensemble version (same keys, same order, bit-identical values).  ``channels``: the log channels it reads
    (``{s}`` stands for every corner suffix), so that channels logged as strided views (e.g. ``L[:, :, j]``
    of one ``(n_cars, n_log, n_channels)`` buffer) are made contiguous together in one cache-friendly pass
    beforehand; channels read without being declared are copied one by one when strided (slower)."""

    def deco(fn):
        metric.ensemble = fn
        metric.ensemble_channels = tuple(channels)
        return fn

    return deco


def rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def rms_rows(x: np.ndarray) -> np.ndarray:
    """:func:`rms` of every row of a 2-D array (bit-identical to ``rms`` of each row)."""
    if x.shape[1] == 0:
        return np.full(x.shape[0], np.nan)
    return np.sqrt(np.mean(x * x, axis=1))


def peak_rows(x: np.ndarray) -> np.ndarray:
    """max |x| of every row."""
    if x.shape[1] == 0:
        return np.full(x.shape[0], np.nan)
    return np.max(np.abs(x), axis=1)


def fraction_rows(mask: np.ndarray) -> np.ndarray:
    """Share of True per row (bit-identical to ``_util.fraction`` of each row)."""
    if mask.shape[1] == 0:
        return np.full(mask.shape[0], np.nan)
    return np.mean(mask, axis=1)


# ----------------------------------------------------------------------------------------------------------
# streaming versions (long runs: the log arrives in chunks and is never held whole)
# ----------------------------------------------------------------------------------------------------------
def stream_version(metric):
    """Decorator: attach a streaming version to the per-car ``metric``: a class made with the run's
    :class:`EnsembleView` *without* samples (``meta``: suffixes, static loads, stop gaps, infos; ``t`` empty),
    whose ``update(chunk)`` gets each chunk of the log as an :class:`EnsembleView` (``chunk.t`` the chunk's
    times, ``chunk.dt`` the log step) and whose ``result()`` returns ``key -> (n_cars,) array`` with the
    same keys as the ensemble version.  Reductions over chunks (sums, maxima, counts, filter states carried
    over) equal the one-shot metric to rounding (~1e-15 relative); on a log that is one chunk they are the
    same sums.  A metric without one is computed from a bounded decimated copy of the log on runs longer
    than one chunk (and the run's ``info`` says so)."""

    def deco(cls):
        metric.stream = cls
        return cls

    return deco


class Reductions:
    """Per-car running reductions of a streamed log: ``sum``/``max``/``count`` of ``(n_cars, rows)`` chunks
    under a key, ``n`` samples so far, ``dt`` the log step and ``t_prev``/``last`` for trapezoid sums."""

    def __init__(self):
        self.v: dict = {}
        self.n = 0
        self.dt = 0.0
        self.last: dict = {}

    def start(self, chunk: "EnsembleView") -> None:
        """Call once per chunk before the reductions: counts its samples, records the log step."""
        if self.n == 0 and len(chunk.t) > 1:
            self.dt = float(chunk.t[1] - chunk.t[0])
        self.n += len(chunk.t)

    def sum(self, key, x: np.ndarray) -> None:
        s = np.sum(x, axis=1)
        self.v[key] = s if key not in self.v else self.v[key] + s

    def max(self, key, x: np.ndarray) -> None:
        if x.shape[1] == 0:
            return
        m = np.max(x, axis=1)
        self.v[key] = m if key not in self.v else np.maximum(self.v[key], m)

    def count(self, key, mask: np.ndarray) -> None:
        c = np.count_nonzero(mask, axis=1).astype(float)
        self.v[key] = c if key not in self.v else self.v[key] + c

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

    def sum_value(self, key, s: np.ndarray) -> None:
        self.v[key] = s if key not in self.v else self.v[key] + s

    def get(self, key, n_cars: int) -> np.ndarray:
        return self.v.get(key, np.full(n_cars, np.nan))

    def mean(self, key, n_cars: int) -> np.ndarray:
        return self.get(key, n_cars) / self.n if self.n else np.full(n_cars, np.nan)

    def rms(self, key, n_cars: int) -> np.ndarray:
        return np.sqrt(self.mean(key, n_cars))

    @property
    def duration(self) -> float:
        return self.n * self.dt


class CornerRmsPeakStream:
    """Streaming version of a per-corner RMS-and-peak metric: ``{key}_rms{s}`` and ``{key}_peak{s}`` (max |x|)
    of channel ``{channel}{s}`` for every corner suffix ``s``.  A subclass sets :attr:`channel` and :attr:`key`,
    and may add per-corner keys after them with :meth:`more` (keys in the ensemble version's order)."""

    channel = ""
    key = ""

    def __init__(self, meta: EnsembleView):
        self.meta, self.r = meta, Reductions()

    def update(self, ens: EnsembleView) -> None:
        self.r.start(ens)
        for s in ens.suffixes:
            x = ens.col(f"{self.channel}{s}")
            self.r.sum(f"ss{s}", x * x)
            self.r.max(f"pk{s}", np.abs(x))

    def more(self, s: str, rms: np.ndarray) -> dict:
        """Further keys of corner ``s`` from its streamed RMS (none by default)."""
        return {}

    def result(self) -> dict:
        n, out = self.meta.n_cars, {}
        for s in self.meta.suffixes:
            r = self.r.rms(f"ss{s}", n)
            out[f"{self.key}_rms{s}"] = r
            out[f"{self.key}_peak{s}"] = self.r.get(f"pk{s}", n)
            out.update(self.more(s, r))
        return out
