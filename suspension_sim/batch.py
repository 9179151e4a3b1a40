"""Headless batch runs: sweep files, expansion into resolved scenarios, ensembles, engines, faults, resume.

A *sweep file* (YAML) names a base scenario and what varies, by the dotted paths of ``run --set``::

    name: qc_sensitivity
    base: quickstart.yaml            # relative to the sweep file (or an inline scenario mapping)
    set:                             # fixed overrides applied to every run
      sim.duration: 5
    grid:                            # cartesian product
      vehicle.params.damping: [800, 1000, 1400]
      controller.params.c_sky: [0, 1500, 3000]
    lists:                           # zipped: the i-th values go together (equal lengths)
      vehicle.params.sprung_mass:   [250, 290, 330]
      vehicle.params.unsprung_mass: [50, 59, 68]
    random:                          # n samples, crossed with the grid and the lists
      n: 20
      seed: 7
      method: lhs                    # random | lhs | sobol (scipy.stats.qmc)
      params:
        vehicle.params.spring_stiffness: {dist: uniform, low: 14000, high: 20000}
        actuator.params.time_constant:   {dist: lognorm, s: 0.5, scale: 0.005}
        road.params.road_class:          {dist: choice, values: [B, C, D]}
    seeds: {count: 5, start: 100}    # Monte Carlo: every variant with road.seed = 100..104
    ensemble_size: 64                # cars per MuJoCo model per worker task (0 = automatic)
    time_limit: 120                  # wall seconds per run
    keep_timeseries: false

Distributions are ``scipy.stats`` distributions by name with their parameters (``loc``, ``scale`` and shape
parameters such as ``s`` or ``a``), sampled by the inverse CDF of uniform numbers from numpy's generator or
a scipy quasi-Monte-Carlo engine; ``uniform`` also takes ``low``/``high``, ``norm`` also ``mean``/``std``,
and ``choice`` picks from ``values``.

Runs are grouped into *ensembles* of structurally equal scenarios (same model, effects, sensors pipeline,
controller and actuator types, timing; numeric parameters and the road may differ) that run as one MuJoCo
model (:class:`~suspension_sim.simulation.Simulation`).  Grouping depends only on the sweep, never on the
engine or the number of workers, and a car's result alone equals its result inside an ensemble, so every
engine and worker count gives identical summary rows (except wall times).

Faults: an ensemble that raises, diverges, produces NaN or exceeds its time limit is re-run car by car, so
one bad car never spoils the others; each failing run is recorded with its ``status`` (``error``,
``diverged``, ``nan``, ``timeout``) and ``error`` text.  Results are appended to ``parts/*.parquet`` as
they arrive and consolidated into ``summary.parquet`` at the end; re-running into the same folder
recomputes only runs that are missing or failed, keyed by :meth:`Scenario.hash`.
"""
from __future__ import annotations

import copy
import itertools
import json
import math
import os
import shutil
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from .components import format_validation_error
from .config import parse_scenario, read_yaml
from .errors import ScenarioError, SimulationDiverged

STATUSES = ("ok", "error", "diverged", "nan", "timeout")
TIMING_COLUMNS = ("wall_time_s",)


# ------------------------------------------------------------------------------------------------------
# sweep file schema
# ------------------------------------------------------------------------------------------------------
class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DistCfg(BaseModel):
    """A distribution: ``dist`` is ``choice`` (with ``values``) or a scipy.stats distribution name; the
    other keys are its parameters."""

    model_config = ConfigDict(extra="allow")
    dist: str
    values: Optional[list[Any]] = None

    @model_validator(mode="after")
    def _check(self):
        if self.dist == "choice":
            if not self.values:
                raise ValueError("dist 'choice' needs a non-empty 'values' list")
        else:
            self.frozen()  # raises ValueError for an unknown distribution or bad parameters
        return self

    def kwargs(self) -> dict:
        kw = dict(self.model_extra or {})
        if self.dist == "uniform" and ("low" in kw or "high" in kw):
            lo, hi = float(kw.pop("low", 0.0)), float(kw.pop("high", 1.0))
            if hi <= lo:
                raise ValueError("uniform needs high > low")
            kw.update(loc=lo, scale=hi - lo)
        if self.dist == "norm":
            if "mean" in kw:
                kw["loc"] = kw.pop("mean")
            if "std" in kw:
                kw["scale"] = kw.pop("std")
        return kw

    def frozen(self):
        from scipy import stats

        d = getattr(stats, self.dist, None)
        if not isinstance(d, (stats.rv_continuous, stats.rv_discrete)):
            raise ValueError(f"unknown distribution {self.dist!r} (use 'choice' or a scipy.stats name, e.g. "
                             "uniform, norm, lognorm, truncnorm, loguniform, randint)")
        try:
            fr = d(**self.kwargs())
            fr.ppf(0.5)
        except TypeError as e:
            raise ValueError(f"bad parameters for {self.dist}: {e}") from None
        return fr

    def from_uniform(self, u: np.ndarray) -> list:
        if self.dist == "choice":
            idx = np.minimum((u * len(self.values)).astype(int), len(self.values) - 1)
            return [self.values[i] for i in idx]
        x = self.frozen().ppf(u)
        if not np.all(np.isfinite(x)):
            raise ValueError(f"distribution {self.dist} gives non-finite samples (unbounded support?)")
        if np.issubdtype(np.asarray(x).dtype, np.integer) or isinstance(self.frozen().dist, _discrete()):
            return [int(v) for v in x]
        return [float(v) for v in x]


def _discrete():
    from scipy import stats

    return stats.rv_discrete


class RandomCfg(_Strict):
    n: int = Field(..., ge=1, description="number of samples")
    seed: int = Field(0, ge=0)
    method: Literal["random", "lhs", "sobol"] = "random"
    params: dict[str, DistCfg]


class SeedsCfg(_Strict):
    count: int = Field(..., ge=1, description="repeats of every variant with a different seed")
    start: int = Field(0, ge=0)
    path: str = Field("road.seed", description="the scenario field the seed goes into")


class Sweep(_Strict):
    name: Optional[str] = None
    description: str = ""
    base: Union[str, dict[str, Any]] = Field(
        ..., description="base scenario: a file (relative to the sweep file) or an inline scenario mapping")
    set: dict[str, Any] = Field(default_factory=dict)
    grid: dict[str, list[Any]] = Field(default_factory=dict)
    lists: dict[str, list[Any]] = Field(default_factory=dict)
    random: Optional[RandomCfg] = None
    seeds: Optional[SeedsCfg] = None
    ensemble_size: int = Field(0, ge=0, description="cars per MuJoCo model per task (0 = automatic)")
    time_limit: Optional[float] = Field(None, gt=0, description="wall seconds per run")
    keep_timeseries: bool = False

    @model_validator(mode="after")
    def _check(self):
        lens = {len(v) for v in self.lists.values()}
        if len(lens) > 1:
            raise ValueError("all 'lists' entries must have the same length")
        for k, v in self.grid.items():
            if not v:
                raise ValueError(f"grid {k!r} has no values")
        return self


def load_sweep(path: str | Path) -> tuple[Sweep, dict]:
    """The validated sweep and its base scenario's raw dict."""
    from .strict import check as strict_check

    raw = read_yaml(path, "sweep file")
    try:
        sw = Sweep.model_validate(raw)
        strict_check(raw, sw)
    except ValidationError as err:
        f, msg = format_validation_error(err)
        raise ScenarioError(msg, source=str(path), field=f) from None
    except ScenarioError as err:  # a lax conversion or a non-finite number: name the sweep file
        msg = str(err)[len(err.field) + 2:] if err.field and str(err).startswith(err.field + ": ") else str(err)
        raise ScenarioError(msg, source=str(path), field=err.field) from None
    if isinstance(sw.base, dict):
        base = copy.deepcopy(sw.base)
    else:
        base_path = (Path(path).parent / sw.base) if not Path(sw.base).is_absolute() else Path(sw.base)
        if not base_path.exists():
            raise ScenarioError(f"base scenario {sw.base!r} not found (looked at {base_path})", source=str(path),
                                field="base")
        base = read_yaml(base_path)
    base.pop("variants", None)
    if sw.name is None:
        sw.name = Path(path).stem
    return sw, base


# ------------------------------------------------------------------------------------------------------
# expansion
# ------------------------------------------------------------------------------------------------------
def set_path(raw: dict, path: str, value: Any, source: str | None = None, field: str | None = None) -> dict:
    """Set ``path.to.key`` (the dotted paths of ``run --set``; list items by index) to a Python value."""
    keys = path.strip().split(".")
    if not all(keys):
        raise ScenarioError(f"empty key in {path!r}", source=source, field=field)
    node: Any = raw
    for i, k in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(node, list):
            try:
                j = int(k)
                if last:
                    node[j] = copy.deepcopy(value)
                else:
                    node = node[j]
            except (ValueError, IndexError):
                raise ScenarioError(f"no list item {k!r} in {path!r}", source=source, field=field) from None
            continue
        if not isinstance(node, dict):
            raise ScenarioError(f"{'.'.join(keys[:i])!r} is not a mapping", source=source, field=field)
        if last:
            node[k] = copy.deepcopy(value)
        else:
            if k not in node or node[k] is None:
                node[k] = {}
            node = node[k]
    return raw


@dataclass
class RunSpec:
    """One run of a sweep: its overrides (dotted path -> value), and what identifies it."""

    run_id: int
    values: dict[str, Any]  # the varied values (columns of the summary)
    hash: str = ""
    seed: int = 0
    group_key: int = 0


def _scalar(v):
    return v if isinstance(v, (int, float, str, bool)) or v is None else json.dumps(v)


def _samples(rc: RandomCfg) -> list[dict]:
    d = len(rc.params)
    if rc.method == "random":
        u = np.random.default_rng(rc.seed).random((rc.n, d))
    else:
        from scipy.stats import qmc

        eng = qmc.LatinHypercube(d=d, seed=rc.seed) if rc.method == "lhs" else qmc.Sobol(d=d, scramble=True, seed=rc.seed)
        u = eng.random(rc.n)
    cols = {}
    for j, (path, dist) in enumerate(rc.params.items()):
        cols[path] = dist.from_uniform(u[:, j])
    return [{p: cols[p][i] for p in cols} for i in range(rc.n)]


def count_runs(sw: Sweep) -> int:
    """The number of runs of a sweep, computed without expanding it."""
    n = math.prod(len(v) for v in sw.grid.values()) if sw.grid else 1
    n *= len(next(iter(sw.lists.values()))) if sw.lists else 1
    n *= sw.random.n if sw.random else 1
    n *= sw.seeds.count if sw.seeds else 1
    return n


def combinations(sw: Sweep) -> list[dict]:
    """The overrides of every run (grid × lists × random samples × seeds), in a fixed order."""
    from . import limits

    limits.check("sweep_runs", count_runs(sw), field="grid/lists/random/seeds")
    grid = [dict(zip(sw.grid, combo)) for combo in itertools.product(*sw.grid.values())] if sw.grid else [{}]
    n_list = len(next(iter(sw.lists.values()))) if sw.lists else 0
    lists = [{k: v[i] for k, v in sw.lists.items()} for i in range(n_list)] or [{}]
    rand = _samples(sw.random) if sw.random else [{}]
    seeds = ([{sw.seeds.path: sw.seeds.start + i} for i in range(sw.seeds.count)] if sw.seeds else [{}])
    out = []
    for g, l_, r, s in itertools.product(grid, lists, rand, seeds):
        out.append({**g, **l_, **r, **s})
    return out


def build_raw(base: dict, sw: Sweep, values: dict, source: str | None = None) -> dict:
    raw = copy.deepcopy(base)
    for p, v in sw.set.items():
        set_path(raw, p, v, source, field=f"set.{p}")
    for p, v in values.items():
        set_path(raw, p, v, source, field=p)
    outs = raw.setdefault("outputs", {}) or {}
    outs.update(plots=False, timeseries=bool(sw.keep_timeseries))
    raw["outputs"] = outs
    return raw


def ensemble_key(sc) -> tuple:
    """Scenarios with equal keys can share one ensemble MuJoCo model in a batch: the structure key of
    :func:`~suspension_sim.simulation.structure_key` plus everything the loop takes from the first car only
    (the sensor pipelines, the sim limits, non-numeric component parameters).  Numeric component and
    vehicle parameters, the road and the seeds may differ."""
    from .simulation import structure_key

    d = sc.resolved_dict()
    for k in ("name", "description", "notes", "outputs", "variants", "road"):
        d.pop(k, None)
    d["sim"].pop("seed", None)

    def mask(x):
        if isinstance(x, bool) or x is None or isinstance(x, str):
            return x
        if isinstance(x, (int, float)):
            return "#"
        if isinstance(x, list) and x and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in x):
            return f"#{len(x)}"
        if isinstance(x, list):
            return [mask(v) for v in x]
        if isinstance(x, dict):
            return {k: mask(v) for k, v in x.items()}
        return x

    v = d["vehicle"]
    v["params"] = mask(v["params"])
    for e in v.get("effects", []):
        e["params"] = mask(e["params"])
    for var in v.get("variations", []):
        var["times"], var["values"] = mask(var["times"]), mask(var["values"])
    if v.get("maneuver"):
        v["maneuver"]["params"] = mask(v["maneuver"]["params"])
    for s in d.get("sensors", []):
        s["params"] = mask(s["params"])
    d["actuator"]["params"] = mask(d["actuator"]["params"])
    d["controller"]["params"] = mask(d["controller"]["params"])
    return (structure_key(sc), json.dumps(d, sort_keys=True, default=str))


@dataclass
class Plan:
    sweep: Sweep
    base: dict
    source: str
    runs: list[RunSpec]
    groups: list[list[int]]  # run ids per ensemble task
    varied: list[str]  # varied dotted paths (summary columns)
    n_log: int = 0
    duration: float = 0.0
    combos: list = field(default_factory=list)  # the overrides of every run, as expanded


def auto_ensemble_size(n_log: int, budget_bytes: float = 150e6, bytes_per_sample: int = 400) -> int:
    """Cars per ensemble so that one task's logs stay within ``budget_bytes`` (the loop logs every channel
    of every car; a quarter car uses ~300 bytes per logged instant and car, a full car more)."""
    return int(max(1, min(256, budget_bytes // max(1, n_log * bytes_per_sample))))


def plan(path: str | Path, ensemble_size: int | None = None) -> Plan:
    """Expand a sweep file into resolved runs (validated, hashed) and ensemble groups."""
    source = str(path)
    sw, base = load_sweep(path)
    combos = combinations(sw)
    varied = list(dict.fromkeys(k for c in combos for k in c))
    runs: list[RunSpec] = []
    keys: dict[tuple, int] = {}
    n_log = 0
    duration = 0.0
    seen: dict[str, int] = {}
    for i, values in enumerate(combos):
        raw = build_raw(base, sw, values, source)
        sc = parse_scenario(raw, source=source, field_prefix=f"run {i} ({_fmt_values(values)})")
        h = sc.hash()
        if h in seen:
            raise ScenarioError(f"runs {seen[h]} and {i} resolve to the same scenario (hash {h}); "
                                "a varied path has no effect or values repeat", source=source)
        seen[h] = i
        gk = keys.setdefault(ensemble_key(sc), len(keys))
        seed = sc.road.seed if sc.road.seed is not None else sc.sim.seed
        runs.append(RunSpec(run_id=i, values={k: _scalar(values.get(k)) for k in varied}, hash=h, seed=int(seed),
                            group_key=gk))
        n_log = max(n_log, int(round(sc.sim.duration / sc.sim.log_dt)))
        duration += sc.sim.duration
    size = ensemble_size or sw.ensemble_size or auto_ensemble_size(n_log)
    if sw.keep_timeseries and not (ensemble_size or sw.ensemble_size):
        size = min(size, 16)
    groups: list[list[int]] = []
    by_key: dict[int, list[int]] = {}
    for r in runs:
        by_key.setdefault(r.group_key, []).append(r.run_id)
    for gk in sorted(by_key):
        ids = by_key[gk]
        # split evenly into chunks of at most `size`
        n_chunks = math.ceil(len(ids) / size)
        per = math.ceil(len(ids) / n_chunks)
        groups.extend(ids[i:i + per] for i in range(0, len(ids), per))
    return Plan(sw, base, source, runs, groups, varied, n_log, duration, combos)


def _fmt_values(values: dict) -> str:
    return ", ".join(f"{k}={v}" for k, v in values.items())[:200]


# ------------------------------------------------------------------------------------------------------
# running one ensemble (in a worker)
# ------------------------------------------------------------------------------------------------------
#: a kept time series larger than this (bytes; a long streamed run's file) goes from the worker to the batch
#: folder by path (moved), not as bytes in the result row (local workers and local Dask share the disk)
KEEP_BY_PATH_BYTES = 64e6


class RunTimeout(RuntimeError):
    pass


@dataclass
class Task:
    """What a worker needs for one ensemble: the base raw scenario, the sweep, the runs."""

    base: dict
    sweep: dict
    source: str
    runs: list[tuple[int, dict, str, int]]  # (run_id, values, hash, seed)


def _status_of(err: BaseException) -> str:
    if isinstance(err, RunTimeout):
        return "timeout"
    if isinstance(err, SimulationDiverged):
        return "nan" if str(err.hint).startswith("NaN") else "diverged"
    return "error"


def _err_text(err: BaseException) -> str:
    if isinstance(err, (ScenarioError, SimulationDiverged, RunTimeout)):
        return f"{type(err).__name__}: {err}"
    tb = traceback.extract_tb(err.__traceback__)
    where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
    return f"{type(err).__name__}: {err}{where}"[:2000]


def _simulate(scs: list, time_limit: float | None, keep_timeseries: bool = True) -> tuple[list, float]:
    from .simulation import Simulation

    t0 = time.perf_counter()
    sim = Simulation(scs, log_channels="all" if keep_timeseries else "metrics")
    progress = None
    if time_limit:
        limit = time_limit * len(scs)

        def progress(frac, t0=t0, limit=limit):
            if time.perf_counter() - t0 > limit:
                raise RunTimeout(f"exceeded the time limit of {limit:g} s wall at {100 * frac:.0f} % of the run")

    res = sim.run(progress)
    return res, time.perf_counter() - t0


def run_task(task: Task) -> list[dict]:
    """Run one ensemble; returns one summary row per run (with ``_timeseries`` parquet bytes if kept).
    Never raises: faults become rows with their status."""
    from .registry import load_plugins

    load_plugins()
    sw = Sweep.model_validate(task.sweep)
    scs, rows_fail = [], {}
    for run_id, values, h, seed in task.runs:
        try:
            scs.append(parse_scenario(build_raw(task.base, sw, values, task.source), source=task.source))
        except Exception as e:  # noqa: BLE001 - recorded per run
            rows_fail[run_id] = _row(run_id, values, h, seed, "error", _err_text(e), 0.0, {})
            scs.append(None)
    good = [(spec, sc) for spec, sc in zip(task.runs, scs) if sc is not None]
    rows = dict(rows_fail)
    rows.update(_run_group(good, sw))
    return [rows[r[0]] for r in task.runs]


def _run_group(good: list, sw: Sweep) -> dict:
    out = {}
    if not good:
        return out
    t0 = time.perf_counter()
    try:
        results, wall = _simulate([sc for _, sc in good], sw.time_limit, sw.keep_timeseries)
    except Exception as e:  # noqa: BLE001
        if len(good) == 1:
            (run_id, values, h, seed), _ = good[0]
            return {run_id: _row(run_id, values, h, seed, _status_of(e), _err_text(e), time.perf_counter() - t0, {})}
        for item in good:  # one car spoiled the ensemble: re-run every car alone
            out.update(_run_group([item], sw))
        return out
    for ((run_id, values, h, seed), sc), res in zip(good, results):
        bad = [k for k, v in res.metrics.items() if not np.isfinite(v)]
        status, err = ("nan", f"non-finite metrics: {', '.join(bad[:8])}") if bad else ("ok", "")
        row = _row(run_id, values, h, seed, status, err, wall / len(good), res.metrics)
        if sw.keep_timeseries:
            import io

            src = res.timeseries_file
            if src is not None and Path(src).stat().st_size > KEEP_BY_PATH_BYTES:
                # a long streamed run: its file is handed over by path (moved into the batch folder by the
                # Store), never read into memory; renamed first so the Result's clean-up leaves it alone
                keep = Path(src).with_name(Path(src).name + ".batch")
                os.replace(src, keep)
                row["_timeseries_file"] = str(keep)
            elif src is not None:  # a streamed run: its file, written as it ran
                row["_timeseries"] = Path(src).read_bytes()
            else:
                buf = io.BytesIO()
                res.timeseries.to_parquet(buf, index=False)
                row["_timeseries"] = buf.getvalue()
        out[run_id] = row
    return out


def _row(run_id, values, h, seed, status, error, wall, metrics) -> dict:
    row = {"run_id": int(run_id), "hash": h, "status": status, "error": error, "wall_time_s": float(wall),
           "seed": int(seed)}
    row.update({k: _scalar(v) for k, v in values.items()})
    row.update({f"metric.{k}": float(v) for k, v in metrics.items()})
    return row


# ------------------------------------------------------------------------------------------------------
# engines
# ------------------------------------------------------------------------------------------------------
class LocalEngine:
    """Local worker processes (``concurrent.futures.ProcessPoolExecutor``; forked where the platform
    allows it, so workers start without re-importing MuJoCo and see plugins registered by the caller)."""

    def __init__(self, workers: int | None = None):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.label = f"local processes ({self.workers})"

    def map(self, fn, tasks: list, on_result: Callable[[int, Any], None], on_fail: Callable[[int, BaseException], None]):
        if self.workers == 1:
            for i, t in enumerate(tasks):
                try:
                    on_result(i, fn(t))
                except Exception as e:  # noqa: BLE001
                    on_fail(i, e)
            return
        import multiprocessing as mp
        from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

        from collections import deque
        from concurrent.futures.process import BrokenProcessPool

        ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else None

        from .lifecycle import DeferredSignals, worker_initializer

        def fresh():  # workers die with this process (SIGKILL included), see suspension_sim.lifecycle
            return ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx, initializer=worker_initializer,
                                       initargs=(os.getpid(),))

        # Ctrl-C and SIGTERM are deferred to `stop.check()` (DeferredSignals: raised at an arbitrary bytecode,
        # the exception can leave a future's lock held, and the pool's manager thread, which interpreter exit
        # joins, then blocks on it forever); every wait polls so a signal is acted on within POLL_S
        with DeferredSignals() as stop:
            ex = fresh()

            def result_of(fut):
                while not wait([fut], timeout=self.POLL_S)[0]:
                    stop.check()
                stop.check()
                return fut.result()

            try:
                pending: dict = {}
                queue, suspects = deque(range(len(tasks))), []
                while queue or pending:
                    while queue and len(pending) < 2 * self.workers:
                        i = queue.popleft()
                        try:
                            pending[ex.submit(fn, tasks[i])] = i
                        except BrokenProcessPool:  # the pool broke since the last wait: its running tasks are suspects
                            queue.appendleft(i)
                            suspects.extend(pending.values())
                            pending.clear()
                            ex.shutdown(wait=False, cancel_futures=True)
                            ex = fresh()
                    done, _ = wait(pending, timeout=self.POLL_S, return_when=FIRST_COMPLETED)
                    stop.check()
                    broken = False
                    for f in done:
                        i = pending.pop(f)
                        try:
                            on_result(i, f.result())
                        except BrokenProcessPool:  # a worker died (e.g. a segfault in native code)
                            suspects.append(i)
                            broken = True
                        except Exception as e:  # noqa: BLE001
                            on_fail(i, e)
                    if broken:  # every task of the broken pool is a suspect; go on with a fresh pool
                        suspects.extend(pending.values())
                        pending.clear()
                        ex.shutdown(wait=False, cancel_futures=True)
                        ex = fresh()
                for i in suspects:  # one at a time: a task that breaks a pool alone is the culprit
                    try:
                        on_result(i, result_of(ex.submit(fn, tasks[i])))
                    except BrokenProcessPool as e:
                        on_fail(i, e)
                        ex.shutdown(wait=False, cancel_futures=True)
                        ex = fresh()
                    except Exception as e:  # noqa: BLE001
                        on_fail(i, e)
                ex.shutdown(wait=True)
                stop.check()
            except BaseException:  # Ctrl-C, SIGTERM: drop queued tasks and stop the running ones (results so far are kept)
                _stop_pool(ex)
                raise

    #: seconds between checks for a deferred Ctrl-C / SIGTERM while waiting for workers
    POLL_S = 0.2

    def close(self):
        pass


def _stop_pool(ex, grace: float = 2.0) -> None:
    """Stop a process pool now: its workers are terminated (killed if still alive after ``grace`` s), queued
    tasks dropped, and its manager thread, which sees the workers die, is given a moment to finish (interpreter
    exit joins it)."""
    procs = list((getattr(ex, "_processes", None) or {}).values())
    for p in procs:
        try:
            p.terminate()
        except Exception:  # noqa: BLE001 - already gone
            pass
    t_end = time.monotonic() + grace
    for p in procs:
        try:
            p.join(max(0.0, t_end - time.monotonic()))
            if p.is_alive():  # e.g. forked but not yet past its initializer (the parent's SIGTERM handler)
                p.kill()
                p.join(1.0)
        except Exception:  # noqa: BLE001
            pass
    manager = getattr(ex, "_executor_manager_thread", None)
    ex.shutdown(wait=False, cancel_futures=True)
    if manager is not None:
        manager.join(grace)


class DaskEngine:
    """Dask distributed: an existing scheduler (``tcp://host:8786``) or a local cluster of N worker
    processes (one thread each).  Workers must be able to import ``suspension_sim``."""

    def __init__(self, scheduler: str | None = None, n_local: int | None = None):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:  # pragma: no cover
            raise ScenarioError("the Dask engine needs dask[distributed]: pip install 'suspension-sim[batch]'") from None
        import logging

        for name in ("distributed", "distributed.scheduler", "distributed.nanny", "distributed.core",
                     "distributed.worker", "distributed.http.proxy"):
            logging.getLogger(name).setLevel(logging.WARNING)
        self.cluster = None
        if scheduler:
            self.client = Client(scheduler)
            self.label = f"dask {scheduler}"
        else:
            n = max(1, n_local or 1)
            # scheduler, workers and dashboard on the loopback interface only (never 0.0.0.0)
            self.cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                        dashboard_address="127.0.0.1:0", silence_logs=40)
            self.client = Client(self.cluster)
            self.label = f"dask local cluster ({n} workers)"
            from .lifecycle import die_with_parent

            # the nannies die with this process and the workers with their nanny (SIGKILL of batch included)
            self.client.run(die_with_parent, nanny=True)
            self.client.run(die_with_parent)
        # the package must be importable on the workers: send this checkout's path along (local clusters)
        import sys

        root = str(Path(__file__).resolve().parents[1])

        def _add_path(p=root):
            if p not in sys.path:
                sys.path.insert(0, p)

        self.client.run(_add_path)

    def map(self, fn, tasks, on_result, on_fail):
        from dask.distributed import as_completed

        n_workers = max(1, len(self.client.scheduler_info().get("workers", {})))
        limit = 4 * n_workers
        futs = {}
        it = iter(enumerate(tasks))
        ac = as_completed()
        for i, t in itertools.islice(it, limit):
            f = self.client.submit(fn, t, pure=False)
            futs[f.key] = i
            ac.add(f)
        for f in ac:
            i = futs.pop(f.key)
            try:
                on_result(i, f.result())
            except Exception as e:  # noqa: BLE001
                on_fail(i, e)
            f.release()
            nxt = next(it, None)
            if nxt is not None:
                nf = self.client.submit(fn, nxt[1], pure=False)
                futs[nf.key] = nxt[0]
                ac.add(nf)

    def close(self):
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


# ------------------------------------------------------------------------------------------------------
# output folder: parts, summary, resume
# ------------------------------------------------------------------------------------------------------
class Store:
    def __init__(self, out: Path):
        self.out = Path(out)
        self.parts = self.out / "parts"
        self.ts_dir = self.out / "timeseries"
        self.out.mkdir(parents=True, exist_ok=True)
        self.parts.mkdir(exist_ok=True)
        self._buf: list[dict] = []
        self._last = time.monotonic()
        self._k = len(list(self.parts.glob("part-*.parquet")))

    def previous(self):
        """Rows already in the folder (summary + parts), the latest row per hash."""
        import pandas as pd

        frames = []
        if (self.out / "summary.parquet").exists():
            try:
                frames.append(pd.read_parquet(self.out / "summary.parquet"))
            except Exception as err:  # noqa: BLE001 - written by rename, so only damaged from outside
                raise ScenarioError(f"summary.parquet is unreadable ({str(err).splitlines()[0][:100]}); move it away "
                                    "or run with --fresh", source=str(self.out)) from None
        for p in sorted(self.parts.glob("part-*.parquet")):
            try:
                frames.append(pd.read_parquet(p))
            except Exception:  # noqa: BLE001 - a part cut short by a crash
                p.unlink()
        if not frames:
            return None
        df = pd.concat(frames, ignore_index=True)
        return df.drop_duplicates("hash", keep="last")

    def add(self, rows: list[dict]):
        for r in rows:
            ts = r.pop("_timeseries", None)
            src = r.pop("_timeseries_file", None)
            if src is not None:
                self.ts_dir.mkdir(exist_ok=True)
                try:
                    shutil.move(src, self.ts_dir / f"{r['hash']}.parquet")
                except OSError as err:  # a remote worker's file: not on this machine
                    r["error"] = (r.get("error") or "") + f" time series not kept ({err.__class__.__name__})"
            if ts is not None:
                self.ts_dir.mkdir(exist_ok=True)
                tmp = self.ts_dir / f".{r['hash']}.tmp"
                tmp.write_bytes(ts)
                tmp.replace(self.ts_dir / f"{r['hash']}.parquet")
            self._buf.append(r)
        # every finished task is on disk at once (one small part file per task, merged at the end): a batch
        # killed at any moment loses no finished run
        self.flush()

    def flush(self):
        if not self._buf:
            return
        import pandas as pd

        df = _arrow_safe(pd.DataFrame(self._buf))
        tmp = self.parts / f".part-{self._k:06d}.tmp"
        df.to_parquet(tmp, index=False)
        tmp.rename(self.parts / f"part-{self._k:06d}.parquet")
        self._k += 1
        self._buf = []
        self._last = time.monotonic()

    def consolidate(self, plan: Plan):
        """Write ``summary.parquet``: one row per run of the sweep (latest result), in run order."""

        self.flush()
        df = self.previous()
        if df is None:
            return None
        order = {r.hash: r.run_id for r in plan.runs}
        df = df[df["hash"].isin(order)].copy()
        df["run_id"] = df["hash"].map(order).astype("int64")
        df = df.sort_values("run_id").reset_index(drop=True)
        front = ["run_id", "hash", "status", "error", "wall_time_s", "seed"] + [v for v in plan.varied if v in df]
        metrics = sorted(c for c in df.columns if c.startswith("metric."))
        rest = [c for c in df.columns if c not in front and c not in metrics]
        df = df[front + rest + metrics]
        df = _arrow_safe(df)
        tmp = self.out / ".summary.tmp"
        df.to_parquet(tmp, index=False)
        tmp.rename(self.out / "summary.parquet")
        for p in self.parts.glob("part-*.parquet"):
            p.unlink()
        return df


def _arrow_safe(df):
    """Columns mixing strings and numbers (e.g. a grid over [0.5, "auto"]) as strings, so Parquet accepts them."""
    for c in df.columns:
        if df[c].dtype == object:
            kinds = {type(v) for v in df[c] if v is not None and not (isinstance(v, float) and math.isnan(v))}
            if len(kinds) > 1 and not kinds <= {int, float, bool}:
                df[c] = df[c].map(lambda v: v if v is None or isinstance(v, str) else json.dumps(v))
    return df


# ------------------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------------------
@dataclass
class BatchReport:
    out: Path
    summary: Any  # pandas DataFrame
    n_total: int
    n_run: int
    n_skipped: int
    wall: float
    engine: str
    counts: dict = field(default_factory=dict)
    sim_seconds: float = 0.0


class BatchInterrupted(KeyboardInterrupt):
    """Ctrl-C stopped a batch; the runs finished before it are in ``out/summary.parquet`` (running the same
    batch again computes only the rest)."""

    def __init__(self, out: Path, n_done: int, n_run: int, n_total: int):
        self.out, self.n_done, self.n_run, self.n_total = Path(out), n_done, n_run, n_total
        super().__init__(f"interrupted: {n_done} of the {n_run} runs to compute finished ({n_total} in the sweep); "
                         f"results so far in {self.out / 'summary.parquet'}; run the same batch again to resume")


def run_batch(sweep_path: str | Path, out: str | Path | None = None, workers: int | None = None,
              scheduler: str | None = None, dask_local: int | None = None, resume: bool = True,
              ensemble_size: int | None = None, progress: Callable[[int, int], None] | None = None,
              engine=None) -> BatchReport:
    """Run a sweep; returns a :class:`BatchReport` (``summary`` is the summary DataFrame).

    ``resume`` (default) skips runs whose hash already has an ``ok`` row in ``out``; with ``resume=False``
    earlier results in ``out`` are discarded.  ``progress(done_runs, total_runs)`` is called as ensembles
    finish."""
    import shutil

    try:
        pl = plan(sweep_path, ensemble_size)
    except ScenarioError as err:
        if err.source is None:  # a limit hit while expanding: name the sweep file
            raise ScenarioError(str(err)[len(err.field) + 2:] if err.field else str(err), source=str(sweep_path),
                                field=err.field) from None
        raise
    out = Path(out) if out else Path("runs") / f"batch-{pl.sweep.name}"
    if not resume and out.exists():
        for name in ("summary.parquet", "parts", "timeseries"):
            p = out / name
            if p.is_dir():
                shutil.rmtree(p)
            elif p.exists():
                p.unlink()
    store = Store(out)
    done: set[str] = set()
    prev = store.previous() if resume else None
    if prev is not None:
        done = set(prev.loc[prev["status"] == "ok", "hash"])
    todo_groups = []
    for g in pl.groups:
        ids = [i for i in g if pl.runs[i].hash not in done]
        if ids:
            todo_groups.append(ids)
    # a resumed ensemble holds the runs still to do of its original group: same grouping key, so results agree
    sw_dump = pl.sweep.model_dump(mode="json")
    tasks = [Task(pl.base, sw_dump, pl.source,
                  [(i, pl.combos[i], pl.runs[i].hash, pl.runs[i].seed) for i in g]) for g in todo_groups]
    n_run = sum(len(g) for g in todo_groups)
    (out / "sweep.resolved.json").write_text(json.dumps({"sweep": sw_dump, "source": pl.source,
                                                         "n_runs": len(pl.runs)}, indent=1, default=str))
    eng = engine or (DaskEngine(scheduler, dask_local) if (scheduler or dask_local) else LocalEngine(workers))
    counter = {"done": 0}
    t0 = time.perf_counter()

    def on_result(i, rows):
        store.add(rows)
        counter["done"] += len(rows)
        if progress:
            progress(counter["done"], n_run)

    def on_fail(i, err):  # the task itself died (worker crash, lost connection)
        rows = [_row(rid, vals, h, seed, "error", f"worker failed: {_err_text(err)}", 0.0, {})
                for rid, vals, h, seed in tasks[i].runs]
        on_result(i, rows)

    stopped: BaseException | None = None
    try:
        if progress:
            progress(0, n_run)
        eng.map(run_task, tasks, on_result, on_fail)
    except (KeyboardInterrupt, SystemExit) as err:  # Ctrl-C, SIGTERM: the finished runs still make a summary
        stopped = err
    finally:
        store.flush()
        if engine is None:
            eng.close()
    wall = time.perf_counter() - t0
    df = store.consolidate(pl)
    if isinstance(stopped, KeyboardInterrupt):
        raise BatchInterrupted(out, counter["done"], n_run, len(pl.runs)) from None
    if stopped is not None:
        raise stopped
    counts = df["status"].value_counts().to_dict() if df is not None else {}
    return BatchReport(out=out, summary=df, n_total=len(pl.runs), n_run=n_run, n_skipped=len(pl.runs) - n_run,
                       wall=wall, engine=eng.label, counts=counts, sim_seconds=pl.duration)
