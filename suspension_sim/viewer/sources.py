"""Scenes from results and simulations: the road profile under each track, the distance travelled, the
frames to draw (see :mod:`suspension_sim.viewer`)."""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

from .scene import CarScene, ROAD_DX, ROAD_POINTS, RoadProfile, WHEEL_R, resample_profile


# ------------------------------------------------------------------------------------------------------------
# building scenes from results and simulations
def _speed_spec(scenario):
    road = scenario.road if hasattr(scenario, "road") else scenario["road"]
    sp = road.speed if hasattr(road, "speed") else road.get("speed", 20.0)
    sim = scenario.sim if hasattr(scenario, "sim") else scenario.get("sim", {})
    dur = sim.duration if hasattr(sim, "duration") else sim.get("duration", 10.0)
    dt = sim.dt if hasattr(sim, "dt") else sim.get("dt", 0.0005)
    return sp, float(dur), float(dt)


def distance_function(scenario) -> Callable[[np.ndarray], np.ndarray]:
    """Distance travelled (m) over time for a scenario (Scenario or resolved dict), as the simulation computes it."""
    from ..build import SpeedProfile

    sp, dur, dt = _speed_spec(scenario)
    prof = SpeedProfile(sp, dur, dt)
    return lambda t: np.asarray(prof.distance(np.asarray(t, dtype=float)), dtype=float)


def _tracks(info) -> tuple[list[int], list[float]]:
    """Track index of each corner and the lateral centre of each track strip."""
    cy = list(info.get("corner_y") or [0.0] * len(info["suffixes"]))
    tr = info.get("corner_track")
    if tr is None:
        tr = [1 if y < 0 else 0 for y in cy] if any(y != 0 for y in cy) else [0] * len(cy)
    tys = {}
    for k, y in zip(tr, cy):
        tys.setdefault(int(k), y)
    return [int(k) for k in tr], [tys[k] for k in sorted(tys)]


def road_profile_from_log(ts, info, distance) -> RoadProfile | None:
    """Road profile along the distance from the road heights logged under every wheel: wheel c at time t is at
    x(t) − (x_front − x_c), so every logged sample is a point of its track's profile.  None if the car does not
    travel (a rig input)."""
    t = ts["t"].to_numpy()
    x = np.asarray(distance(t), dtype=float)
    if x.size == 0 or float(np.nanmax(x) - np.nanmin(x)) < 0.5:
        return None
    sfx = list(info["suffixes"])
    cx = np.asarray(info.get("corner_x") or [0.0] * len(sfx), dtype=float)
    back = cx.max() - cx
    tr, tys = _tracks(info)
    n_tracks = len(tys)
    xs_all, zs_all = [], []
    for k in range(n_tracks):
        xs, zs = [], []
        for c, s in enumerate(sfx):
            if tr[c] == k and f"road{s}" in ts:
                xs.append(x - back[c])
                zs.append(ts[f"road{s}"].to_numpy())
        grid, z = resample_profile(np.concatenate(xs), np.concatenate(zs))
        xs_all.append(grid)
        zs_all.append(z)
    # one common grid, extended flat on both sides so the road reaches beyond the car
    lo = min(g[0] for g in xs_all) - 8.0
    hi = max(g[-1] for g in xs_all) + 25.0
    n = int(min(ROAD_POINTS, max(2, (hi - lo) / ROAD_DX)))
    grid = np.linspace(lo, hi, n)
    Z = np.stack([np.interp(grid, gx, gz) for gx, gz in zip(xs_all, zs_all)])
    width = 0.75 if n_tracks == 1 else min(0.6, max(0.3, abs(tys[0] - tys[-1]) - 0.1))
    ys = [0.0] if n_tracks == 1 else tys
    return RoadProfile(grid, Z, ys, width)


def road_profile_from_sim(sim, i: int = 0) -> RoadProfile | None:
    """Road profile of car ``i`` of a simulation computed from its road objects before the run (the live view
    needs the road ahead of the car), with the same corner timing as the simulation loop."""
    sp, road = sim.speeds[i], sim.roads[i]
    dur = sim.duration
    t_end = np.linspace(0, dur, 200)
    x_run = np.asarray(sp.distance(t_end), dtype=float)
    if float(x_run.max() - x_run.min()) < 0.5:
        return None
    geom = sim.geom
    back = float(np.max(sim.corner_back))
    lo, hi = float(x_run.min()) - back - 8.0, float(x_run.max()) + 25.0
    n = int(min(ROAD_POINTS, (hi - lo) / ROAD_DX))
    grid = np.linspace(lo, hi, n)
    info = {"suffixes": geom.suffixes, "corner_x": geom.corner_x, "corner_y": geom.corner_y,
            "corner_track": geom.tracks}
    tr, tys = _tracks(info)
    Z = []
    for k in range(len(tys)):
        c = tr.index(k)
        tc = np.asarray(sp.time_at(grid, dur), dtype=float)
        Z.append(np.nan_to_num(np.asarray(road.height(tc, grid, geom.tracks[c]), dtype=float)))
    width = 0.75 if len(tys) == 1 else min(0.6, max(0.3, abs(tys[0] - tys[-1]) - 0.1))
    return RoadProfile(grid, np.stack(Z), [0.0] if len(tys) == 1 else tys, width)


def scene_from_result(result, label: str = "", y_offset: float = 0.0, prefix: str = "car") -> CarScene:
    dist = distance_function(result.scenario)
    road = road_profile_from_log(result.timeseries, result.info, dist)
    return CarScene(result.info, result.timeseries.columns, dist, road, label=label, y_offset=y_offset,
                    prefix=prefix)


# ------------------------------------------------------------------------------------------------------------
# recorded animation → static page
def frame_times(duration: float, fps: float) -> np.ndarray:
    n = int(math.floor(duration * fps + 1e-9)) + 1
    return np.arange(n) / fps


def choose_fps(scene: CarScene, t_end: float, fps: float | None, max_frames: int = 6000) -> float:
    """30 frames/s, more when the wheels turn fast (at most 120° per frame so their spin reads correctly), at
    most ``max_frames`` frames."""
    if fps is None:
        tt = np.linspace(0, t_end, 400)
        x = np.asarray(scene.distance(tt))
        v = float(np.max(np.abs(np.diff(x)) / np.maximum(np.diff(tt), 1e-9))) if tt.size > 1 else 0.0
        fps = float(np.clip(math.ceil(v / (WHEEL_R * 2 * np.pi / 3)), 30, 120))
    if t_end > 0:
        fps = min(fps, max_frames / t_end)
    return float(fps)


def sample_columns(ts, t: np.ndarray) -> dict:
    tt = ts["t"].to_numpy()
    out = {}
    for name in ts.columns:
        if name == "t":
            continue
        v = ts[name].to_numpy()
        if v.dtype.kind in "fiu":
            out[name] = np.interp(t, tt, v.astype(float))
    return out
