"""Run logs and results.

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
import json
import platform
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

BODY_NAMES = {
    "body_z": ("body_z", "body_vel", "body_acc"),
    "pitch": ("pitch", "pitch_rate", "pitch_acc"),
    "roll": ("roll", "roll_rate", "roll_acc"),
}


class Logger:
    def __init__(self, sim, n_log: int):
        self.sim = sim
        P = sim.plant
        self.n, self.nc, self.n_log = P.n, P.nc, n_log
        self.t = np.zeros(n_log)
        self.ch: dict[str, np.ndarray] = {}
        self.sfx = P.suffixes

    def _put(self, name, j, value):
        """value: (n,) per car."""
        arr = self.ch.get(name)
        if arr is None:
            arr = self.ch[name] = np.full((self.n, self.n_log), np.nan)
        arr[:, j] = value

    def _corner(self, base, j, values):
        for c, s in enumerate(self.sfx):
            self._put(f"{base}{s}", j, values[:, c])

    def pre(self, j, t, road, road_vel, travel, rate, command, F_act, F_eff, F_teff, readings):
        P, d = self.sim.plant, self.sim.plant.data
        self.t[j] = t
        for k, jn in enumerate(P.body_joints):
            pn, vn, _ = BODY_NAMES.get(jn, (jn, f"{jn}_vel", f"{jn}_acc"))
            self._put(pn, j, d.qpos[P.body_q[:, k]])
            self._put(vn, j, d.qvel[P.body_v[:, k]])
        self._corner("travel", j, travel)
        self._corner("travel_rate", j, rate)
        if P.has_tire:
            self._corner("wheel_z", j, d.qpos[P.wheel_q])
            self._corner("wheel_vel", j, d.qvel[P.wheel_v])
            tl, tr = d.ten_length[P.tire_t], d.ten_velocity[P.tire_t]
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
                    self._put(f"effect.{eff.name}.{name}.{c}", j, val[:, c])

    def post(self, j, qacc):
        P = self.sim.plant
        for k, jn in enumerate(P.body_joints):
            _, _, an = BODY_NAMES.get(jn, (jn, f"{jn}_vel", f"{jn}_acc"))
            self._put(an, j, qacc[P.body_v[:, k]])
        if P.has_tire:
            self._corner("wheel_acc", j, qacc[P.wheel_v])

    def frame(self, i: int) -> pd.DataFrame:
        arrs = [self.t] + [arr[i] for arr in self.ch.values()]
        if all(a.dtype == np.float64 for a in arrs):
            # one float block: ~3x cheaper than a dict of columns (matters for batches of short runs)
            block = np.empty((len(self.t), len(arrs)))
            for k, a in enumerate(arrs):
                block[:, k] = a
            return pd.DataFrame(block, columns=["t", *self.ch], copy=False)
        return pd.DataFrame(dict(zip(["t", *self.ch], arrs)))


@dataclass
class Result:
    """One car's run: ``timeseries`` (DataFrame), ``metrics`` (dict), the resolved ``scenario`` and
    ``info`` (static loads, wall time, whether the controller had full-state access, versions)."""

    scenario: object
    timeseries: pd.DataFrame
    info: dict
    metrics: dict = field(default_factory=dict)

    @classmethod
    def from_logger(cls, logger: Logger, i: int, sim, wall: float) -> "Result":
        P = sim.plant
        info = {
            "model": P.vcls.name,
            "suffixes": P.suffixes,
            "corners": [c.name for c in P.corners],
            # corner geometry (m; x forward from the c.g., y left) and road track, for the 3D viewer
            "corner_x": [float(c.x) for c in P.corners],
            "corner_y": [float(c.y) for c in P.corners],
            "corner_track": [int(c.track) for c in P.corners],
            "static_tire_force": {s: float(P.static_tire[i, c]) for c, s in enumerate(P.suffixes)},
            "static_suspension_force": {s: float(P.static_susp[i, c]) for c, s in enumerate(P.suffixes)},
            "stop_gap": _stop_gaps(sim, i),
            "stop_gap_sides": _stop_gap_sides(sim, i),
            "full_state_access": bool(sim.full_state),
            "wall_time_s": wall / P.n,
            "ensemble_size": P.n,
            "versions": versions(),
        }
        r = cls(scenario=sim.scenarios[i], timeseries=logger.frame(i), info=info)
        r.metrics = compute_metrics(r)
        return r

    @property
    def ts(self) -> pd.DataFrame:
        return self.timeseries

    def view(self):
        from .metrics.base import RunView

        return RunView(ts=self.timeseries, suffixes=self.info["suffixes"],
                       static_tire_force=self.info["static_tire_force"], stop_gap=self.info.get("stop_gap", {}),
                       info=self.info)


def _stop_gaps(sim, i) -> dict:
    out = {}
    for eff, sel in sim.effects:
        gap = getattr(eff.p, "gap", None)
        if eff.name == "bump_stop" and gap is not None:
            g = np.broadcast_to(np.asarray(gap, dtype=float), (sim.plant.n, len(sel)))
            for k, c in enumerate(sel):
                out[sim.plant.suffixes[c]] = float(g[i, k])
    return out


def _stop_gap_sides(sim, i) -> dict:
    """suffix -> [compression gap, extension gap] (m) of a bump_stop effect (they may differ)."""
    out = {}
    for eff, sel in sim.effects:
        g_c, g_e = getattr(eff, "g_c", None), getattr(eff, "g_e", None)
        if eff.name == "bump_stop" and g_c is not None and g_e is not None:
            g_c = np.broadcast_to(np.asarray(g_c, dtype=float), (sim.plant.n, len(sel)))
            g_e = np.broadcast_to(np.asarray(g_e, dtype=float), (sim.plant.n, len(sel)))
            for k, c in enumerate(sel):
                out[sim.plant.suffixes[c]] = [float(g_c[i, k]), float(g_e[i, k])]
    return out


def compute_metrics(result: Result) -> dict:
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


def versions() -> dict:
    return dict(_versions())


@functools.lru_cache(maxsize=None)
def _versions() -> dict:  # importlib.metadata is slow: once per process, not once per car
    import mujoco

    from . import __version__

    out = {"suspension_sim": __version__, "mujoco": mujoco.__version__, "python": platform.python_version(),
           "numpy": np.__version__}
    try:
        import dm_control  # noqa: F401
        from importlib.metadata import version

        out["dm_control"] = version("dm-control")
    except Exception:  # pragma: no cover
        pass
    return out


def write_result(result: Result, out: Path, plots: bool = True, timeseries: bool = True) -> Path:
    """Write ``timeseries.parquet``, ``summary.json``, ``scenario.resolved.yaml`` and ``plots/*.png`` (and
    ``viewer.html`` / ``report.html`` when the scenario's ``outputs.viewer`` / ``outputs.report`` are set)."""
    import yaml

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if timeseries:
        result.timeseries.to_parquet(out / "timeseries.parquet", index=False)
    resolved = result.scenario.resolved_dict()
    resolved.pop("variants", None)
    resolved["sim"]["seed"] = result.scenario.sim.seed
    header = (f"# resolved by suspension_sim {result.info['versions'].get('suspension_sim')} "
              f"(mujoco {result.info['versions'].get('mujoco')}); rerun with: suspension-sim run {out / 'scenario.resolved.yaml'}\n")
    (out / "scenario.resolved.yaml").write_text(header + yaml.safe_dump(resolved, sort_keys=False))
    summary = {"name": result.scenario.name, "metrics": result.metrics, "info": result.info}
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    if plots:
        from .plots import plot_run

        plot_run({result.scenario.name: result}, out / "plots")
    outputs = getattr(result.scenario, "outputs", None)
    if getattr(outputs, "viewer", False):  # self-contained 3D view (suspension_sim.viewer)
        from .viewer import write_viewer

        write_viewer(result, out / "viewer.html")
    if getattr(outputs, "report", False):  # metrics, plots and the 3D view in one page (suspension_sim.report)
        from .report import write_report

        write_report(out, result=result)
    return out
