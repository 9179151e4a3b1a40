"""The log of a run (one ensemble): :class:`Logger` records the channels at every logged step.

The channels and their units are listed in :mod:`suspension_sim.results`, which turns a log into one
:class:`~suspension_sim.results.Result` per car.  :func:`stop_gaps_all` and :func:`stop_gap_sides_all` read
the bump stops' gaps from the built system for the metrics and the 3D view.
"""
from __future__ import annotations

import os

import numpy as np
import pandas as pd

from .channels import body_channels


#: A log of at most :data:`CAR_MB` per car and :data:`BUFFER_MB` in all (all cars, all channels) is held whole,
#: as one chunk; a longer one is held in chunks of at most :data:`CHUNK_S` simulated seconds (and
#: :data:`BUFFER_MB`), each handed to the logger's ``sink`` (Parquet row groups, streaming metrics) when full.
#: A single car's long run therefore peaks flat (a 30 s chunk is ~15 MB), and an ensemble of many short runs
#: that fits is not pushed through Parquet chunk by chunk (a 256-car, 2 s batch of 245 MB ran its loop 3x
#: slower when streamed at a 64 MB total).  ``SUSPENSION_SIM_LOG_BUFFER_MB`` (the total, and then also the
#: per-car bound when smaller) and ``SUSPENSION_SIM_LOG_CHUNK_S`` override them.
BUFFER_MB = 512.0
CAR_MB = 64.0
CHUNK_S = 30.0


def log_channels_estimate(sim) -> int:
    """An upper estimate of the logged channels per car (body dofs × 3, ~16 per corner, sensors, signals)."""
    P = sim.plant
    n = 3 * len(P.body_joints) + 16 * P.nc + 8
    for ch in getattr(sim, "sensors", []):
        try:
            n += max(1, len(ch.sensor.labels()))
        except Exception:  # noqa: BLE001 - an estimate
            n += P.nc
    return n + 4 * P.nc


def buffer_rows(sim, n_log: int) -> int:
    """Rows (log instants) the log buffer of ``sim`` holds: ``n_log`` when the whole log fits in
    :data:`CAR_MB` per car and :data:`BUFFER_MB` in all, else a chunk (at least 2 rows)."""
    budget = float(os.environ.get("SUSPENSION_SIM_LOG_BUFFER_MB") or BUFFER_MB) * 1e6
    per_car = min(CAR_MB * 1e6, budget)
    row = 8.0 * sim.plant.n * log_channels_estimate(sim)
    if n_log * row <= budget and n_log * row / sim.plant.n <= per_car:
        return n_log
    chunk_s = float(os.environ.get("SUSPENSION_SIM_LOG_CHUNK_S") or CHUNK_S)
    rows = min(int(chunk_s / (sim.log_every * sim.dt) + 1e-9), int(budget // row))
    return int(min(n_log, max(2, rows)))


class Logger:
    """The log of one ensemble run: ``t`` (rows,) and ``ch`` channel name -> (n_cars, rows) arrays holding
    log instants ``base`` .. ``base + rows - 1`` (``rows`` = :attr:`cap`; the whole log when it fits in
    memory, see :func:`buffer_rows`).

    The Python loop calls :meth:`pre` (positions, forces, readings, signals) and :meth:`post`
    (accelerations) at each logged step; the compiled loop writes ``t`` and ``ch`` itself.  When the buffer is
    full the loops call :meth:`flush`, which hands it to ``sink.feed(t, ch)`` (:class:`~suspension_sim.stream.
    LogStream`: Parquet row groups and streaming metrics) and moves ``base`` on; :meth:`finish` flushes the
    last rows of a chunked log.  :attr:`streamed` tells whether the log was chunked."""

    def __init__(self, sim, n_log: int, cap: int | None = None, sink=None):
        self.sim = sim
        P = sim.plant
        self.n, self.nc, self.n_log = P.n, P.nc, n_log
        self.cap = n_log if cap is None else int(max(1, min(cap, n_log)))
        self.base = 0
        self.sink = sink
        self.log_every, self.dt = sim.log_every, sim.dt
        self.t = np.zeros(self.cap)
        self.ch: dict[str, np.ndarray] = {}
        self.sfx = P.suffixes

    @property
    def streamed(self) -> bool:
        return self.cap < self.n_log

    def local(self, j: int) -> int:
        """The buffer row of log instant ``j`` (flushing the full buffer first when ``j`` is past it)."""
        i = j - self.base
        if i >= self.cap:
            self.flush()
            i = j - self.base
        return i

    def flush(self, rows: int | None = None) -> None:
        """Hand the buffer's first ``rows`` (default: all) to the sink and start the next chunk there."""
        rows = self.cap if rows is None else rows
        if self.sink is not None and rows > 0:
            self.sink.feed(self.t[:rows], {k: a[:, :rows] for k, a in self.ch.items()})
        self.base += rows
        self.t[:] = (np.arange(self.base, self.base + self.cap) * self.log_every) * self.dt

    def finish(self) -> None:
        """After the run: a chunked log hands its last rows to the sink (a whole log stays as it is)."""
        if self.streamed:
            if self.base < self.n_log:
                self.flush(self.n_log - self.base)
            if self.sink is not None:
                self.sink.close()

    def _put(self, name, j, value):
        """value: (n,) per car; j a buffer row."""
        arr = self.ch.get(name)
        if arr is None:
            arr = self.ch[name] = np.full((self.n, self.cap), np.nan)
        arr[:, j] = value

    def _corner(self, base, j, values):
        for c, s in enumerate(self.sfx):
            self._put(f"{base}{s}", j, values[:, c])

    def pre(self, j, t, road, road_vel, travel, rate, command, F_act, F_eff, F_teff, readings):
        P, d = self.sim.plant, self.sim.plant.data
        self.t[j] = t
        for k, jn in enumerate(P.body_joints):
            pn, vn, _ = body_channels(jn)
            self._put(pn, j, d.qpos[P.body_q[:, k]])
            self._put(vn, j, d.qvel[P.body_v[:, k]])
        self._corner("travel", j, travel)
        self._corner("travel_rate", j, rate)
        if P.has_tire:
            self._corner("wheel_z", j, d.qpos[P.wheel_q])
            self._corner("wheel_vel", j, d.qvel[P.wheel_v])
            tl, tr = P.tire_deflection(d, road, road_vel)
            self._corner("tire_force", j, -self.sim.kt * tl - self.sim.ct * tr + F_teff)
            self._corner("tire_effect_force", j, F_teff)
        self._corner("road", j, road)
        self._corner("road_vel", j, road_vel)
        self._corner("command", j, command)
        self._corner("actuator_force", j, F_act)
        self._corner("effect_force", j, F_eff)
        for name, val in self.sim.actuator.states().items():
            if name != "force":
                self._corner(f"act.{name}", j, np.asarray(val).reshape(self.n, self.nc))
        for name, val in readings.items():
            if name.startswith("state."):
                continue
            labels = self.sim.cctx.sensors.get(name) or [str(i) for i in range(np.shape(val)[1])]
            val = np.asarray(val).reshape(self.n, -1)
            for c in range(val.shape[1]):
                lab = labels[c] if c < len(labels) else str(c)
                self._put(f"sensor.{name}.{lab}" if lab else f"sensor.{name}", j, val[:, c])
        for name, val in self.sim.controller.signals().items():
            val = np.asarray(val, dtype=float).reshape(self.n, -1)
            if val.shape[1] == 1:
                self._put(f"ctrl.{name}", j, val[:, 0])
            else:
                for c in range(val.shape[1]):
                    self._put(f"ctrl.{name}.{c}", j, val[:, c])
        for eff, sel in self.sim.effects:
            for name, val in eff.signals().items():
                val = np.asarray(val, dtype=float).reshape(self.n, -1)
                for c in range(val.shape[1]):
                    self._put(f"effect.{eff.label}.{name}.{c}", j, val[:, c])

    def post(self, j, qacc):
        P = self.sim.plant
        for k, jn in enumerate(P.body_joints):
            _, _, an = body_channels(jn)
            self._put(an, j, qacc[P.body_v[:, k]])
        if P.has_tire:
            self._corner("wheel_acc", j, qacc[P.wheel_v])

    def frame(self, i: int) -> pd.DataFrame:
        return frame(["t", *self.ch], [self.t] + [arr[i] for arr in self.ch.values()])

    def keep_until(self, err) -> None:
        """Hand a divergence stop (:class:`~suspension_sim.errors.SimulationDiverged`) the log instants before
        it: both loops have written every instant before the step at which the check failed (the stop's own
        instant is not logged).  Not for a log streamed in chunks (the earlier chunks went to the sink)."""
        if self.streamed or not self.ch:
            return
        k = int(round(err.time / self.dt))  # the physics step at which the check failed
        rows = max(0, min(self.cap, -(-k // self.log_every)))
        t, ch, n = self.t, dict(self.ch), self.n
        err.keep_log(lambda: [frame(["t", *ch], [t[:rows]] + [a[i, :rows] for a in ch.values()]) for i in range(n)])


def frame(names: list, arrs: list, shared: dict | None = None) -> pd.DataFrame:
    if all(a.dtype == np.float64 for a in arrs):
        # one float block: ~3x cheaper than a dict of columns (matters for batches of short runs)
        block = np.empty((len(arrs[0]), len(arrs)))
        for k, a in enumerate(arrs):
            block[:, k] = a
        if shared is not None:  # the cars of an ensemble share one (immutable) column Index: 5x cheaper
            columns = shared.get("columns")  # (one ensemble: one channel snapshot, the same names)
            if columns is None:
                columns = shared["columns"] = pd.Index(names)
            return pd.DataFrame(block, columns=columns, copy=False)
        return pd.DataFrame(block, columns=names, copy=False)
    return pd.DataFrame(dict(zip(names, arrs)))


def frame_from_columns(columns: dict) -> pd.DataFrame:
    """The DataFrame of one car's log from ``name -> 1-D array`` (``t`` first), as :meth:`Logger.frame`
    builds it."""
    return frame(list(columns), list(columns.values()))


def stop_gaps_all(sim) -> list[dict]:
    """Per car: corner suffix -> gap (m) of the bump_stop effects (for the metrics and the 3D view)."""
    n = sim.plant.n
    out: list[dict] = [{} for _ in range(n)]
    for eff, sel in sim.effects:
        gap = getattr(eff.p, "gap", None)
        if eff.name == "bump_stop" and gap is not None:
            g = np.broadcast_to(np.asarray(gap, dtype=float), (n, len(sel))).tolist()
            for k, c in enumerate(sel):
                s = sim.plant.suffixes[c]
                for i in range(n):
                    out[i][s] = g[i][k]
    return out


def stop_gap_sides_all(sim) -> list[dict]:
    """Per car: corner suffix -> [compression gap, extension gap] (m) of a bump_stop effect (they may
    differ)."""
    n = sim.plant.n
    out: list[dict] = [{} for _ in range(n)]
    for eff, sel in sim.effects:
        if eff.name == "bump_stop" and hasattr(eff, "gaps"):
            g_c, g_e = eff.gaps()
            g_c = np.broadcast_to(np.asarray(g_c, dtype=float), (n, len(sel))).tolist()
            g_e = np.broadcast_to(np.asarray(g_e, dtype=float), (n, len(sel))).tolist()
            for k, c in enumerate(sel):
                s = sim.plant.suffixes[c]
                for i in range(n):
                    out[i][s] = [g_c[i][k], g_e[i][k]]
    return out
