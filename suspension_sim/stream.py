"""A long run's log, chunk by chunk: :class:`LogStream` is the sink of a chunked :class:`~suspension_sim.log.Logger`.

A log that does not fit in the logger's buffer (:func:`~suspension_sim.log.buffer_rows`, ~30 simulated
seconds per chunk) is never held whole.  Each full chunk is

- appended to each car's ``timeseries.parquet`` as a Parquet row group (``pyarrow.parquet.ParquetWriter``,
  the schema ``DataFrame.to_parquet`` writes for the same columns: the file reads back as the one-shot file
  does, same columns, same dtypes);
- fed to the metrics' accumulators (:class:`~suspension_sim.metrics.base.Accumulator`, the one law of each
  built-in metric: sums, maxima, counts, the ISO 2631 filter state carried over; equal to the whole log as
  one chunk to rounding);
- thinned into a bounded *preview* (every q-th log instant, at most :data:`PREVIEW_MB`), from which the
  plots are drawn and the metrics without a streaming version are computed (``info["streamed_log"]`` names
  them and q).

Memory is then the chunk, the preview and the writers' buffers, whatever the duration.  Where the file goes:
``sim.stream_paths`` (one path per car; ``suspension-sim run`` points it into the run folder), else a
temporary file per car that the :class:`~suspension_sim.results.Result` reads on demand and removes when it
is garbage-collected (also for a run logging a set of channels: its ``timeseries`` is those channels' whole
log); a batch that keeps no time series (``log_channels="metrics"``) writes none, and its ``timeseries`` is the
preview, with a warning.
"""
from __future__ import annotations

import math
import os
import tempfile
import weakref
from pathlib import Path

import numpy as np

#: the preview (plots, metrics without a streaming version) holds at most this many MB of an ensemble's log
PREVIEW_MB = 32.0


def _unlink(paths) -> None:
    for p in paths:
        try:
            os.unlink(p)
        except OSError:
            pass


def _close_and_remove(state: dict) -> None:
    """Finalizer of an unfinished stream (the run failed or was abandoned): close the writers, remove the files."""
    for w in state.get("writers") or []:
        if w is not None:
            try:
                w.close()
            except Exception:  # noqa: BLE001 - best effort on the way out
                pass
    if not state.get("done"):
        _unlink([p for p in state.get("paths") or [] if p is not None])


class LogStream:
    """The sink of one ensemble's chunked log (see the module doc)."""

    def __init__(self, sim, n_log: int, chunk_rows: int):
        from .log import log_channels_estimate
        from .metrics.base import EnsembleView
        from .registry import METRICS
        from .results import infos_of

        self.n = sim.plant.n
        self.sfx = list(sim.plant.suffixes)
        self.infos = infos_of(sim, 0.0)
        self.n_log, self.chunk_rows = n_log, chunk_rows
        static = {s: np.array([float(inf["static_tire_force"][s]) for inf in self.infos])
                  for s in self.sfx if all(s in inf.get("static_tire_force", {}) for inf in self.infos)}
        self.meta = dict(suffixes=self.sfx, static_tire_force=static,
                         stop_gaps=[inf["stop_gap"] for inf in self.infos], infos=self.infos)
        empty = EnsembleView(channels={}, t=np.zeros(0), **self.meta)
        self.streams: dict = {}
        self.rest: list = []  # metrics computed from the preview
        for name, fn in METRICS.items():
            cls = getattr(fn, "stream", None)
            if cls is None:
                self.rest.append(name)
                continue
            try:
                self.streams[name] = cls(empty)
            except NotImplementedError:
                self.rest.append(name)
        self.skipped: set = set()  # metrics whose channels the log lacks
        rows = max(1000, int(PREVIEW_MB * 1e6 / (8.0 * self.n * log_channels_estimate(sim))))
        self.q = max(1, math.ceil(n_log / rows))
        self.prev_t: list = []
        self.prev_ch: dict = {}
        self.seen = 0
        self.names = None
        paths = getattr(sim, "stream_paths", None)
        self.temporary = paths is None
        if paths is None and getattr(sim, "log_channels", "all") != "metrics":
            paths = []
            for i in range(self.n):
                fd, p = tempfile.mkstemp(prefix="suspension_sim_log_", suffix=".parquet")
                os.close(fd)
                paths.append(Path(p))
        self.paths = [Path(p) for p in paths] if paths is not None else [None] * self.n
        self._state = {"writers": None, "paths": list(self.paths), "done": False}
        self._fin = weakref.finalize(self, _close_and_remove, self._state)

    # -- chunks ------------------------------------------------------------------------------------------
    def feed(self, t: np.ndarray, ch: dict) -> None:
        """One chunk: ``t`` (rows,), ``ch`` name -> (n_cars, rows) (views of the logger's buffer)."""
        from .metrics.base import EnsembleView

        rows = len(t)
        if self.names is None:
            self._open(ch)
        self._write(t, ch)
        ens = EnsembleView(channels=dict(ch), t=np.array(t), **self.meta)
        for name, s in list(self.streams.items()):
            try:
                s.update(ens)
            except KeyError:  # this model's log lacks the metric's channel: skipped, as one-shot
                del self.streams[name]
                self.skipped.add(name)
            except NotImplementedError:
                del self.streams[name]
                self.rest.append(name)
        first = (-self.seen) % self.q  # the chunk's first row whose global index is a multiple of q
        sel = slice(first, rows, self.q)
        self.prev_t.append(np.array(t[sel]))
        for k, a in ch.items():
            self.prev_ch.setdefault(k, []).append(np.array(a[:, sel]))
        self.seen += rows

    def _open(self, ch: dict) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        from .log import frame

        self.names = ["t", *ch]
        probe = frame(self.names, [np.zeros(1)] + [np.zeros(1, dtype=a.dtype) for a in ch.values()])
        self.schema = pa.Schema.from_pandas(probe, preserve_index=False)
        for p in self.paths:
            if p is not None:
                p.parent.mkdir(parents=True, exist_ok=True)
        self._state["writers"] = [pq.ParquetWriter(str(p), self.schema) if p is not None else None
                                  for p in self.paths]

    def _write(self, t, ch) -> None:
        import pyarrow as pa

        writers = self._state["writers"]
        if not any(w is not None for w in writers):
            return
        tcol = pa.array(np.ascontiguousarray(t))
        for i, w in enumerate(writers):
            if w is None:
                continue
            cols = [tcol]
            for name in self.names[1:]:
                a = ch.get(name)
                cols.append(pa.array(np.ascontiguousarray(a[i]) if a is not None else np.full(len(t), np.nan)))
            w.write_table(pa.Table.from_arrays(cols, schema=self.schema), row_group_size=max(1, len(t)))

    def close(self) -> None:
        for w in self._state["writers"] or []:
            if w is not None:
                w.close()
        self._state["writers"] = None
        self._state["done"] = True

    # -- results -----------------------------------------------------------------------------------------
    def preview(self) -> tuple[np.ndarray, dict]:
        t = np.concatenate(self.prev_t) if self.prev_t else np.zeros(0)
        return t, {k: np.concatenate(v, axis=1) for k, v in self.prev_ch.items()}

    def results(self, sim, wall: float) -> list:
        """One :class:`~suspension_sim.results.Result` per car: the streamed metrics (and those of the
        preview), the time series read from its file on demand, the preview for plots."""
        from .registry import METRICS
        from .results import Result, compute_metrics_many, infos_of

        infos = infos_of(sim, wall)
        pt, pch = self.preview()
        rest = [nm for nm in self.rest if nm not in self.skipped]
        note = {"chunk_rows": int(self.chunk_rows), "preview_every": int(self.q)}
        if rest:
            note["metrics_from_preview"] = list(rest)
        out = []
        for i, info in enumerate(infos):
            info["streamed_log"] = dict(note)
            r = Result.__new__(Result)
            r.scenario = sim.scenarios[i]
            r.info = info
            r.metrics = {}
            r.__dict__["_ts"] = None
            r.__dict__["_src"] = None
            r.__dict__["_file"] = self.paths[i]
            r.__dict__["_preview"] = (pt, pch, i)
            if self.paths[i] is not None and self.temporary:
                weakref.finalize(r, _unlink, [str(self.paths[i])])
            out.append(r)
        gaps = [inf["stop_gap"] for inf in infos]
        views = [r.preview_view for r in out]
        for name in METRICS.names():
            if name in self.streams:
                cols = [(k, np.broadcast_to(np.asarray(v, dtype=float), (self.n,)).tolist())
                        for k, v in self.streams[name].result().items()]
                for i, r in enumerate(out):
                    r.metrics.update((k, lst[i]) for k, lst in cols)
            elif name in rest and len(pt) > 0:
                for r, m in zip(out, compute_metrics_many(pt, pch, self.sfx, infos, gaps, views, only={name})):
                    r.metrics.update(m)
        return out
