"""The per-car results and metrics path as it was before the ensemble-vectorised one (commit 441d2fb), kept
verbatim in one place as the reference for ``tests/test_results_fast.py`` and the "before" column of
``benchmarks/bench_results.py``: one DataFrame per car (``Logger.frame``), metrics computed from DataFrame
column lookups, car by car, the info dict rebuilt per car.  Not used by the package."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import integrate, signal

from suspension_sim.metrics.iso2631 import MIN_FILTER_RATE, MTVV_TAU, _weighting_sos
from suspension_sim.results import versions


class View:
    def __init__(self, ts, suffixes, static_tire_force, stop_gap, info):
        self.ts, self.suffixes, self.static_tire_force = ts, suffixes, static_tire_force
        self.stop_gap, self.info = stop_gap, info

    @property
    def dt(self) -> float:
        t = self.ts["t"].to_numpy()
        return float(t[1] - t[0]) if len(t) > 1 else 0.0


def rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")


def duration(run) -> float:
    return len(run.ts) * run.dt


def fraction(mask) -> float:
    mask = np.asarray(mask, dtype=bool)
    return float(np.mean(mask)) if mask.size else float("nan")


def peak(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x))) if x.size else float("nan")


def actuator_force(run) -> dict:
    out = {}
    for s in run.suffixes:
        f = run.ts[f"actuator_force{s}"].to_numpy()
        out[f"actuator_force_rms{s}"] = rms(f)
        out[f"actuator_force_peak{s}"] = peak(f)
    return out


def actuator_power(run) -> dict:
    out = {}
    t = run.ts["t"].to_numpy()
    tot = {"actuator_power_mean_abs": 0.0, "actuator_power_mean_pos": 0.0, "actuator_energy": 0.0}
    for s in run.suffixes:
        p = run.ts[f"actuator_force{s}"].to_numpy() * run.ts[f"travel_rate{s}"].to_numpy()
        vals = {
            "actuator_power_mean_abs": float(np.mean(np.abs(p))) if p.size else float("nan"),
            "actuator_power_mean_pos": float(np.mean(np.clip(p, 0.0, None))) if p.size else float("nan"),
            "actuator_energy": float(integrate.trapezoid(np.abs(p), t)) if p.size > 1 else 0.0,
        }
        for k, v in vals.items():
            out[f"{k}{s}"] = v
            tot[k] += v
        out[f"actuator_power_peak{s}"] = peak(p)
    if len(run.suffixes) > 1:
        out.update({f"{k}_total": v for k, v in tot.items()})
    return out


def body_acc(run) -> dict:
    a = run.ts["body_acc"].to_numpy()
    return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}


def weighted(x, fs: float, name: str = "Wk") -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return x.copy()
    up = max(1, int(math.ceil(MIN_FILTER_RATE / fs - 1e-9)))
    if up == 1:
        return signal.sosfilt(_weighting_sos(float(fs), name), x)
    xu = signal.resample_poly(x, up, 1, padtype="edge")
    return signal.sosfilt(_weighting_sos(float(fs * up), name), xu)[::up][: x.size]


def vdv(aw, fs: float) -> float:
    aw = np.asarray(aw, dtype=float)
    if aw.size < 2:
        return 0.0
    return float(integrate.trapezoid(aw ** 4, dx=1.0 / fs) ** 0.25)


def mtvv(aw, fs: float, tau: float = MTVV_TAU) -> float:
    aw = np.asarray(aw, dtype=float)
    n = int(round(tau * fs))
    if aw.size == 0:
        return float("nan")
    if n < 1 or n >= aw.size:
        return rms(aw)
    c = np.concatenate([[0.0], np.cumsum(aw * aw)])
    ms = (c[n:] - c[:-n]) / n
    return float(np.sqrt(max(np.max(ms), 0.0)))


def iso2631(run) -> dict:
    a = run.ts["body_acc"].to_numpy()
    if run.dt <= 0:
        return {}
    fs = 1.0 / run.dt
    aw = weighted(a, fs, "Wk")
    awr = rms(aw)
    return {
        "body_acc_wk_rms": awr,
        "body_acc_vdv": vdv(aw, fs),
        "body_acc_wk_mtvv": mtvv(aw, fs),
        "body_acc_wk_crest": float(np.max(np.abs(aw)) / awr) if awr > 0 else float("nan"),
    }


def _attitude(run, dof: str) -> dict:
    ang = run.ts[dof].to_numpy()
    out = {f"{dof}_peak": peak(ang), f"{dof}_rms": rms(ang)}
    if f"{dof}_acc" in run.ts:
        acc = run.ts[f"{dof}_acc"].to_numpy()
        out[f"{dof}_acc_rms"] = rms(acc)
        out[f"{dof}_acc_peak"] = peak(acc)
    return out


def pitch(run) -> dict:
    return _attitude(run, "pitch")


def roll(run) -> dict:
    return _attitude(run, "roll")


def suspension_travel(run) -> dict:
    out = {}
    T = duration(run)
    for s in run.suffixes:
        x = run.ts[f"travel{s}"].to_numpy()
        out[f"travel_rms{s}"] = rms(x)
        out[f"travel_peak{s}"] = peak(x)
        sides = (run.info or {}).get("stop_gap_sides", {}).get(s)
        gap = run.stop_gap.get(s)
        if sides is None and gap is not None:
            sides = (gap, gap)
        if sides is not None:
            f = fraction((x < -sides[0]) | (x > sides[1]))
            out[f"travel_stop_fraction{s}"] = f
            out[f"travel_stop_time{s}"] = f * T
    return out


LIFTOFF_TOL = 1e-9


def tire_liftoff(run) -> dict:
    out = {}
    T = duration(run)
    for s in run.suffixes:
        static = float(run.static_tire_force[s])
        total = static + run.ts[f"tire_force{s}"].to_numpy()
        f = fraction(total <= LIFTOFF_TOL * max(abs(static), 1.0))
        out[f"tire_liftoff_fraction{s}"] = f
        out[f"tire_liftoff_time{s}"] = f * T
    return out


def tire_load(run) -> dict:
    out = {}
    for s in run.suffixes:
        f = run.ts[f"tire_force{s}"].to_numpy()
        static = float(run.static_tire_force[s])
        r = rms(f)
        out[f"tire_force_rms{s}"] = r
        out[f"tire_force_peak{s}"] = peak(f)
        out[f"tire_load_rms_rel{s}"] = r / static if static > 0 else float("nan")
    return out


def wheel_acc(run) -> dict:
    out = {}
    for s in run.suffixes:
        a = run.ts[f"wheel_acc{s}"].to_numpy()
        out[f"wheel_acc_rms{s}"] = rms(a)
        out[f"wheel_acc_peak{s}"] = peak(a)
    return out


#: the built-in metrics by registered name, in the registry's (sorted) order
METRICS = {"actuator_force": actuator_force, "actuator_power": actuator_power, "body_acc": body_acc,
           "iso2631": iso2631, "pitch": pitch, "roll": roll, "suspension_travel": suspension_travel,
           "tire_liftoff": tire_liftoff, "tire_load": tire_load, "wheel_acc": wheel_acc}


def frame(logger, i: int) -> pd.DataFrame:
    arrs = [logger.t] + [arr[i] for arr in logger.ch.values()]
    if all(a.dtype == np.float64 for a in arrs):
        block = np.empty((len(logger.t), len(arrs)))
        for k, a in enumerate(arrs):
            block[:, k] = a
        return pd.DataFrame(block, columns=["t", *logger.ch], copy=False)
    return pd.DataFrame(dict(zip(["t", *logger.ch], arrs)))


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
    out = {}
    for eff, sel in sim.effects:
        if eff.name == "bump_stop":  # (the effect kept g_c/g_e attributes before its law was written once)
            g_c, g_e = eff.gaps()
            g_c = np.broadcast_to(np.asarray(g_c, dtype=float), (sim.plant.n, len(sel)))
            g_e = np.broadcast_to(np.asarray(g_e, dtype=float), (sim.plant.n, len(sel)))
            for k, c in enumerate(sel):
                out[sim.plant.suffixes[c]] = [float(g_c[i, k]), float(g_e[i, k])]
    return out


def info(sim, i: int, wall: float) -> dict:
    P = sim.plant
    return {
        "model": P.vcls.name,
        "suffixes": P.suffixes,
        "corners": [c.name for c in P.corners],
        "corner_x": [float(c.x) for c in P.corners],
        "corner_y": [float(c.y) for c in P.corners],
        "corner_track": [int(c.track) for c in P.corners],
        "static_tire_force": {s: float(P.static_tire[i, c]) for c, s in enumerate(P.suffixes)},
        "static_suspension_force": {s: float(P.static_susp[i, c]) for c, s in enumerate(P.suffixes)},
        "stop_gap": _stop_gaps(sim, i),
        "stop_gap_sides": _stop_gap_sides(sim, i),
        "full_state_access": bool(sim.full_state),
        # info added later (not a computation path): the integrator used, sim.integrator: auto resolved
        "integrator": sim.integrator,
        "integrator_reason": sim.integrator_reason,
        "wall_time_s": wall / P.n,
        "ensemble_size": P.n,
        "versions": versions(),
    }


def metrics_of(ts: pd.DataFrame, inf: dict) -> dict:
    view = View(ts, inf["suffixes"], inf["static_tire_force"], inf.get("stop_gap", {}), inf)
    out: dict = {}
    for fn in METRICS.values():
        try:
            vals = fn(view)
        except KeyError:
            continue
        out.update({k: float(v) for k, v in vals.items()})
    return out


def from_logger(logger, i: int, sim, wall: float) -> tuple[pd.DataFrame, dict, dict]:
    """The old ``Result.from_logger``: (timeseries, info, metrics) of car ``i``."""
    inf = info(sim, i, wall)
    ts = frame(logger, i)
    return ts, inf, metrics_of(ts, inf)
