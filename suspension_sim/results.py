"""One car's result: its time series and metrics (the log of a run is :mod:`.log`, files :mod:`.outputs`).

A :class:`Result` holds one car's time series (a pandas DataFrame, SI units) and its metrics.  Columns:

- ``t``; body degrees of freedom: ``body_z``, ``body_vel``, ``body_acc`` (heave), ``pitch``,
  ``pitch_rate``, ``pitch_acc``, ``roll``, ``roll_rate``, ``roll_acc`` where the model has them;
- per corner (suffix ``''``, ``_front``/``_rear`` or ``_fl``...): ``travel``, ``travel_rate``, ``wheel_z``,
  ``wheel_vel``, ``wheel_acc``, ``road``, ``road_vel``, ``tire_force`` (dynamic, relative to the static
  load, positive = more compression), ``actuator_force``, ``command``, ``effect_force`` (sum of suspension
  effects), ``tire_effect_force``;
- ``act.<state>{s}`` actuator states, ``sensor.<name>.<label>`` sensor readings, ``ctrl.<signal>[.k]``
  controller signals.
"""
from __future__ import annotations

import functools
import platform
import warnings
from dataclasses import dataclass, field

import numba
import numpy as np
import pandas as pd

from . import buffers
from .log import Logger, frame, stop_gap_sides_all, stop_gaps_all

@dataclass
class Result:
    """One car's run: ``timeseries`` (DataFrame), ``metrics`` (dict), the resolved ``scenario`` and
    ``info`` (static loads, wall time, whether the controller had full-state access, versions).

    Results made from a logger (:meth:`from_logger`, :meth:`many_from_logger`) build their DataFrame only
    when ``timeseries`` (``ts``) is first read (batches without time series never need it): until then they
    hold views of the logger's arrays (one ensemble's logs, shared by its cars; the logger itself and the
    simulation are not kept).  Pickling builds it first."""

    scenario: object
    timeseries: pd.DataFrame
    info: dict
    metrics: dict = field(default_factory=dict)

    @classmethod
    def from_logger(cls, logger: Logger, i: int, sim, wall: float) -> "Result":
        """Car ``i``'s result.  The results and metrics of all cars of the logger are computed together on
        the first call (vectorised over the ensemble, :meth:`many_from_logger`) and handed out one by one
        to the calls for each car, so a loop over the cars costs one ensemble computation; the logger's
        arrays must not change between those calls (a new run needs a new :class:`Logger`)."""
        key = (id(sim), float(wall), id(logger.t), tuple(id(a) for a in logger.ch.values()))
        cache = logger.__dict__.get("_results_cache")
        if cache is None or cache[0] != key or i not in cache[1]:
            cache = logger.__dict__["_results_cache"] = (key, dict(enumerate(cls.many_from_logger(logger, sim, wall))))
        r = cache[1].pop(i)
        if not cache[1]:
            del logger.__dict__["_results_cache"]
        return r

    @classmethod
    def many_from_logger(cls, logger: Logger, sim, wall: float) -> list["Result"]:
        """Every car's result, metrics computed for the whole ensemble at once where the metric has an
        ensemble version (bit-identical to the per-car computation, see ``metrics/base.py``); time series
        built on demand."""
        t = logger.t
        ch = dict(logger.ch)  # a snapshot of the channel dict (the arrays are shared, not copied)
        shared: dict = {}  # what the cars' DataFrames can share (the column Index)
        infos = infos_of(sim, wall)
        gaps = [inf["stop_gap"] for inf in infos]
        out = []
        for i, info in enumerate(infos):
            r = cls.__new__(cls)
            r.scenario = sim.scenarios[i]
            r.__dict__["_ts"] = None
            r.__dict__["_src"] = (t, ch, i, shared)
            r.info = info
            r.metrics = {}
            out.append(r)
        metrics = compute_metrics_many(t, ch, logger.sfx, infos, gaps, [r.view for r in out])
        for r, m in zip(out, metrics):
            r.metrics = m
        return out

    @property
    def ts(self) -> pd.DataFrame:
        return self.timeseries

    def _columns(self) -> dict | None:
        src = self.__dict__.get("_src")
        if src is None or self.__dict__.get("_ts") is not None:
            return None
        t, ch, i, _ = src
        cols = {"t": t}
        cols.update((k, a[i]) for k, a in ch.items())
        return cols

    @property
    def timeseries_file(self):
        """The Parquet file holding a streamed (long) run's time series (read by :attr:`timeseries` on
        demand), or None when the time series is in memory."""
        return self.__dict__.get("_file")

    def preview_frame(self) -> pd.DataFrame:
        """The time series for plots and views: the whole log, or for a streamed run its bounded preview
        (every ``info["streamed_log"]["preview_every"]``-th log instant)."""
        pv = self.__dict__.get("_preview")
        if pv is None:
            return self.timeseries
        t, ch, i = pv
        return frame(["t", *ch], [t] + [a[i] for a in ch.values()])

    def preview_view(self):
        """A :class:`~suspension_sim.metrics.base.RunView` of :meth:`preview_frame` (metrics without a
        streaming version on a streamed run)."""
        from .metrics.base import RunView

        pv = self.__dict__.get("_preview")
        if pv is None:
            return self.view()
        t, ch, i = pv
        cols = {"t": t}
        cols.update((k, a[i]) for k, a in ch.items())
        return RunView(ts=None, suffixes=self.info["suffixes"], static_tire_force=self.info["static_tire_force"],
                       stop_gap=self.info.get("stop_gap", {}), info=self.info, columns=cols)

    def view(self):
        from .metrics.base import RunView

        cols = self._columns()
        return RunView(ts=None if cols is not None else self.timeseries, suffixes=self.info["suffixes"],
                       static_tire_force=self.info["static_tire_force"], stop_gap=self.info.get("stop_gap", {}),
                       info=self.info, columns=cols)

    def __getstate__(self):
        if self.__dict__.get("_file") is None:
            self.timeseries  # noqa: B018 - build the DataFrame: never pickle the whole ensemble's logs
        return self.__dict__

    def __setstate__(self, state):
        state = dict(state)
        if "timeseries" in state:  # pickled before the time series became lazy
            state["_ts"], state["_src"] = state.pop("timeseries"), None
        self.__dict__.update(state)


def _ts_get(self) -> pd.DataFrame:
    d = self.__dict__
    ts = d.get("_ts")
    if ts is None and d.get("_file") is not None:  # a streamed run: read from its file (not kept)
        return pd.read_parquet(d["_file"])
    if ts is None and d.get("_preview") is not None:  # a streamed run without a file: the preview
        q = self.info.get("streamed_log", {}).get("preview_every")
        warnings.warn(f"this run was logged for its metrics only (log_channels='metrics') and streamed: its "
                      f"timeseries is the preview, every {q}-th log instant; log its channels (log_channels="
                      f"'all' or a set of names) for the whole time series", stacklevel=2)
        return self.preview_frame()
    if ts is None:
        src = d.get("_src")
        if src is not None:
            t, ch, i, shared = src
            ts = d["_ts"] = frame(["t", *ch], [t] + [arr[i] for arr in ch.values()], shared)
            d["_src"] = None
    return ts


def _ts_set(self, value) -> None:
    self.__dict__["_ts"] = value
    self.__dict__["_src"] = None
    self.__dict__["_file"] = self.__dict__["_preview"] = None


# ``timeseries`` stays a dataclass field (constructor, repr, fields() unchanged) read through a property,
# so that results made from a logger build their DataFrame only when it is used
Result.timeseries = property(_ts_get, _ts_set, doc="one car's log as a DataFrame (columns: see the module doc)")


def previewed(r):
    """``r``, or for a streamed (long) run a copy whose time series is its bounded preview (every q-th log
    instant, ``info["streamed_log"]``): plots never read a long run's whole file."""
    pf = getattr(r, "preview_frame", None)
    if pf is None or getattr(r, "__dict__", {}).get("_preview") is None:
        return r
    return type(r)(scenario=r.scenario, timeseries=pf(), info=r.info, metrics=r.metrics)


def infos_of(sim, wall: float) -> list[dict]:
    """Every car's ``Result.info`` (the pieces shared by the ensemble computed once)."""
    P = sim.plant
    n = P.n
    sfx = P.suffixes
    model = P.vcls.name
    corners = [c.name for c in P.corners]
    cx = [float(c.x) for c in P.corners]
    cy = [float(c.y) for c in P.corners]
    ct = [int(c.track) for c in P.corners]
    st = np.asarray(P.static_tire, dtype=float).reshape(n, len(sfx)).tolist()
    ss = np.asarray(P.static_susp, dtype=float).reshape(n, len(sfx)).tolist()
    gaps, sides = stop_gaps_all(sim), stop_gap_sides_all(sim)
    full = bool(sim.full_state)
    w = wall / P.n
    out = []
    for i in range(n):
        out.append({
            "model": model,
            "suffixes": P.suffixes,
            "corners": list(corners),
            # corner geometry (m; x forward from the c.g., y left) and road track, for the 3D viewer
            "corner_x": list(cx),
            "corner_y": list(cy),
            "corner_track": list(ct),
            "static_tire_force": dict(zip(sfx, st[i])),
            "static_suspension_force": dict(zip(sfx, ss[i])),
            "stop_gap": gaps[i],
            "stop_gap_sides": sides[i],
            "full_state_access": full,
            # the integrator used (sim.integrator: auto resolves at build time) and why
            "integrator": getattr(sim, "integrator", None),
            "integrator_reason": getattr(sim, "integrator_reason", ""),
            "wall_time_s": w,
            "ensemble_size": P.n,
            "versions": versions(),
        })
    return out


def compute_metrics(result: Result) -> dict:
    """Every registered metric of one result (metrics whose channels the log lacks are skipped)."""
    from .registry import METRICS

    view = result.view()
    out: dict = {}
    for name, fn in METRICS.items():
        try:
            vals = fn(view)
        except KeyError:
            continue  # the channel this metric needs is not in this model's log
        out.update({k: float(v) for k, v in vals.items()})
    return out


def compute_metrics_many(t, channels: dict, suffixes, infos: list, stop_gaps: list, views: list,
                         only: set | None = None) -> list[dict]:
    """:func:`compute_metrics` of every car of an ensemble: ``channels`` name -> ``(n_cars, n_log)``,
    ``t`` the common time axis, ``infos``/``stop_gaps`` per car, ``views[i]()`` car i's :class:`RunView`
    (made only for metrics without an ensemble version).  Same keys, order and values as car by car.
    ``only``: the names of the metrics to compute (default: every registered one)."""
    from .metrics.base import EnsembleView
    from .registry import METRICS

    n = len(infos)
    outs: list[dict] = [{} for _ in range(n)]
    cache: dict = {}

    def view(i):
        if i not in cache:
            cache[i] = views[i]()
        return cache[i]

    ens = None
    t = np.asarray(t)
    if len(t) >= 2 and t.dtype == np.float64 and all(a.dtype == np.float64 for a in channels.values()):
        needed = [fn.ensemble_channels for _, fn in METRICS.items() if getattr(fn, "ensemble", None) is not None]
        needed = [c.format(s=s) if "{s}" in c else c for chs in needed for c in chs
                  for s in (suffixes if "{s}" in c else [""])]
        chans = _contiguous(channels, [c for c in dict.fromkeys(needed) if c in channels])
        static = {s: np.array([float(inf["static_tire_force"][s]) for inf in infos])
                  for s in suffixes if all(s in inf.get("static_tire_force", {}) for inf in infos)}
        ens = EnsembleView(channels=chans, t=t, suffixes=list(suffixes), static_tire_force=static,
                           stop_gaps=stop_gaps, infos=infos)
    for name, fn in METRICS.items():
        if only is not None and name not in only:
            continue
        many = getattr(fn, "ensemble", None) if ens is not None else None
        if many is not None:
            try:
                vals = many(ens)
            except KeyError:
                continue  # the channel this metric needs is not in this model's log
            except NotImplementedError:
                pass  # this ensemble needs the car-by-car path
            else:
                cols = [(k, np.broadcast_to(np.asarray(v, dtype=float), (n,)).tolist()) for k, v in vals.items()]
                for i, o in enumerate(outs):
                    for k, lst in cols:
                        o[k] = lst[i]
                continue
        for i, o in enumerate(outs):
            try:
                vals = fn(view(i))
            except KeyError:
                continue
            o.update({k: float(v) for k, v in vals.items()})
    return outs


def _contiguous(channels: dict, needed: list) -> dict:
    """``channels`` with the ``needed`` ones as arrays with C-contiguous rows (one row per car: numpy then sums
    every car's samples pairwise in the same order as one car's 1-D array), or for the compiled loop's log the
    transposes of C-contiguous step-major arrays (:meth:`~suspension_sim.metrics.base.EnsembleView.held`).  Channels logged as views of one
    3-D buffer, ``L[:, :, j]`` of ``(n_cars, n_log, n_channels)`` or ``L[:, :, j].T`` of ``(n_log, n_cars,
    n_channels)`` (the compiled loop's), are gathered together, a block of the buffer at a time (a strided copy
    per channel would read the whole buffer from memory once per channel)."""
    out = dict(channels)
    groups: dict = {}
    for name in needed:
        a = channels[name]
        if a.flags.c_contiguous:
            continue
        b, j, kind = a.base, None, None
        if isinstance(b, np.ndarray) and b.ndim == 3 and a.ndim == 2 and b.dtype == a.dtype and b.strides[2] > 0:
            if b.shape[:2] == a.shape and b.strides[:2] == a.strides:
                kind = "car"  # (car, log step, channel)
            elif b.shape[1::-1] == a.shape and b.strides[1::-1] == a.strides:
                kind = "step"  # (log step, car, channel)
        if kind is not None:
            off = a.__array_interface__["data"][0] - b.__array_interface__["data"][0]
            if off % b.strides[2] == 0 and 0 <= off // b.strides[2] < b.shape[2]:
                j = off // b.strides[2]
        if j is None:
            out[name] = np.ascontiguousarray(a)
        else:
            groups.setdefault((id(b), kind), (b, kind, []))[2].append((name, int(j)))
    for b, kind, items in groups.values():
        idx = [j for _, j in items]
        bs = max(1, (1 << 20) // max(1, b.shape[1] * b.shape[2] * b.itemsize))  # ~1 MB of the buffer per block
        if kind == "car":
            g = buffers.empty((len(idx), b.shape[0], b.shape[1])) if b.dtype == np.float64 else \
                np.empty((len(idx), b.shape[0], b.shape[1]), dtype=b.dtype)
            for c0 in range(0, b.shape[0], bs):
                g[:, c0:c0 + bs] = np.take(b[c0:c0 + bs], idx, axis=2).transpose(2, 0, 1)
        elif b.dtype == np.float64 and b.flags.c_contiguous:  # the compiled loop's log: one compiled pass
            # step-major channels (channel, log step, car), a streaming pass over the log; each channel is the
            # (car, log step) transpose of one, which the built-in metrics reduce over the steps with the cars
            # side by side (EnsembleView.held: the same numbers as over each car's row)
            g = buffers.empty((len(idx), b.shape[0], b.shape[1]))
            _split_step_major(b, np.asarray(idx, dtype=np.int64), g)
            for k, (name, _) in enumerate(items):
                out[name] = g[k].T
            continue
        else:
            g = np.empty((len(idx), b.shape[1], b.shape[0]), dtype=b.dtype)
            for r0 in range(0, b.shape[0], bs):
                g[:, :, r0:r0 + bs] = np.take(b[r0:r0 + bs], idx, axis=2).transpose(2, 1, 0)
        for k, (name, _) in enumerate(items):
            out[name] = g[k]
    return out


@numba.njit(cache=True, nogil=True)
def _split_step_major(b, idx, g):  # pragma: no cover - compiled
    """g[k, r, car] = b[r, car, idx[k]]: channels of a step-major log (step, car, channel) each as a step-major
    (step, car) array, in one sequential pass over the log (about 60 % of the time of a gather into (car,
    step) rows, which turns every block of the log round)."""
    n_r, n_c = b.shape[0], b.shape[1]
    for r in range(n_r):
        for k in range(idx.size):
            j = idx[k]
            for c in range(n_c):
                g[k, r, c] = b[r, c, j]


def versions() -> dict:
    return dict(_versions())


@functools.lru_cache(maxsize=None)
def _versions() -> dict:  # importlib.metadata is slow: once per process, not once per car
    import mujoco

    from .version import __version__

    out = {"suspension_sim": __version__, "mujoco": mujoco.__version__, "python": platform.python_version(),
           "numpy": np.__version__}
    try:
        import dm_control  # noqa: F401
        from importlib.metadata import version

        out["dm_control"] = version("dm-control")
    except Exception:  # pragma: no cover
        pass
    return out
