"""Browser 3D view of a run with meshcat: live while simulating, or recorded into a self-contained ``viewer.html``.

The scene is drawn from what a run logs (the :class:`~suspension_sim.results.Result` time series and ``info``:
corner suffixes and positions, static loads, bump-stop gaps), so it works for every model: SDOF rig, quarter,
half and full car.  What it shows (display sizes are fixed, only motions come from the run):

- the **body** (blue box) heaving, pitching (positive = nose down) and rolling (positive = right side down);
- the **wheels** (dark cylinders with light spokes) moving with ``wheel_z{s}`` and turning with the distance
  travelled (angle = distance / display radius);
- the **suspension springs** (coils between wheel and body, beside each wheel) whose length is the display
  length plus the suspension travel, coloured green → yellow → red as ``|travel|`` approaches the bump-stop gap
  (``info['stop_gap']``; a run without bump stops uses :data:`DEFAULT_GAP`, shown in the legend);
- **actuator force arrows** (orange, beside the body at each corner) pointing up for a force pushing the body up,
  :data:`ARROW_PER_N` m per newton (0.3 m per kN, at most :data:`ARROW_MAX`);
- the **road** with its real profile passing under the car (the car stays at x = 0, the road moves by the
  distance travelled, so on a half or full car the rear wheels meet a bump later), drawn from the road heights
  logged under every wheel; a rig input without travel (speed 0) is drawn as plates moving under the wheels;
- a red **lift-off marker** under a wheel whenever its total tire force (static + ``tire_force{s}``) is <= 0;
- the **time** on screen and **camera presets** (:data:`CAMERAS`).

Two outputs share that scene:

- :func:`write_viewer` records a meshcat animation into a static page: meshcat's own JavaScript bundle is
  embedded and the scene is fed to it as msgpack commands decoded in the page (the same thing meshcat's
  ``static_html`` produces, without starting its server), so the page opens offline from disk and can be mailed.
  It adds a small overlay (time, play/pause, scrub slider, speed, camera presets, legend) and a JavaScript hook,
  ``window.suspensionSim`` (``seek(t)``, ``play()``, ``pause()``, ``time()``, ``camera(name)``, ``duration``), also
  driven by the URL fragment ``#t=1.5`` (show that time, paused) and ``#camera=side``.
- :func:`attach_live_viewer` streams a running :class:`~suspension_sim.simulation.Simulation` to a meshcat
  server bound to 127.0.0.1 (its URL printed), at real time or a chosen rate, through the simulation's
  ``log_hooks``.
"""
from __future__ import annotations

import base64
import json
import math
import os
import subprocess
import sys
import time as _time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

# display sizes (m); only the motions come from the run
WHEEL_R = 0.30
TIRE_W = 0.20
BODY_H = 0.20
BODY_Z = 0.90  # body centre height at static equilibrium
SPRING_R = 0.055
ARROW_PER_N = 0.3e-3  # actuator arrow length per newton (0.3 m per kN), clipped to ARROW_MAX
ARROW_MAX = 1.2
ARROW_LENGTH = 0.3  # drawn length of the arrow model (scaled in z)
DEFAULT_GAP = 0.08  # travel shown red when the run has no bump stop (m)
ROAD_DEPTH = 0.04
ROAD_DX = 0.05  # road profile sampling (m) for the drawn surface
ROAD_POINTS = 6000  # at most this many samples per track (coarser on long runs)
TARGET_Z = 0.55  # the scene is shifted down by this, so the camera (which looks at the origin) sees the car

BODY_COLOR = 0x3366CC
TIRE_COLOR = 0x202020
SPOKE_COLOR = 0xC8C8C8
ARROW_COLOR = 0xFF8800
LIFTOFF_COLOR = 0xFF0033
ROAD_COLOR = (0.33, 0.33, 0.35)
ROAD_STRIPE = (0.52, 0.52, 0.55)
GROUND_COLOR = 0x8FA37A
BACKGROUND = ((0.94, 0.95, 0.97), (0.80, 0.84, 0.88))  # top, bottom

# camera presets: direction from the look-at point (unit-free, scaled by the car size), world axes
CAMERAS = {
    "three_quarter": (0.75, -1.0, 0.45),
    "side": (0.0, -1.0, 0.12),
    "front": (1.0, -0.12, 0.25),
    "rear": (-1.0, -0.12, 0.25),
    "top": (0.02, -0.05, 1.0),
    "wheel": (0.25, -0.62, 0.02),
}

ROOT = "suspension_sim"


# ------------------------------------------------------------------------------------------------------------
# small math helpers
def _quat_xyzw_axis(axis: str, angle: np.ndarray) -> np.ndarray:
    a = np.asarray(angle, dtype=float) / 2.0
    q = np.zeros(a.shape + (4,))
    q[..., "xyz".index(axis)] = np.sin(a)
    q[..., 3] = np.cos(a)
    return q


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ax, ay, az, aw = np.moveaxis(a, -1, 0)
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], axis=-1)


def _matrix(pos, quat=None, scale=None) -> np.ndarray:
    """4x4 homogeneous matrix from position, quaternion (x, y, z, w) and scale."""
    T = np.eye(4)
    if quat is not None:
        x, y, z, w = quat
        T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    if scale is not None:
        T[:3, :3] = T[:3, :3] * np.asarray(scale, dtype=float)[None, :]
    T[:3, 3] = pos
    return T


def usage_color(u: np.ndarray) -> np.ndarray:
    """Spring colour for travel usage u = |travel| / gap: green (0) → yellow (0.5) → red (>= 1)."""
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    r = np.clip(2.0 * u, 0, 1) * 0.9 + 0.1
    g = np.clip(2.0 * (1.0 - u), 0, 1) * 0.75 + 0.05
    b = np.full_like(u, 0.1)
    return np.stack([r, g, b], axis=-1)


# ------------------------------------------------------------------------------------------------------------
# geometry builders
def _helix_mesh(length: float, radius: float = SPRING_R, wire: float = 0.011, turns: int = 7,
                n_path: int = 150, n_ring: int = 6):
    """A coil spring along +z from 0 to ``length`` as a triangle tube (vertices, faces)."""
    s = np.linspace(0.0, 1.0, n_path)
    phi = 2 * np.pi * turns * s
    c = np.stack([radius * np.cos(phi), radius * np.sin(phi), length * s], axis=1)
    tangent = np.gradient(c, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.stack([np.cos(phi), np.sin(phi), np.zeros_like(phi)], axis=1)
    binormal = np.cross(tangent, normal)
    th = np.linspace(0, 2 * np.pi, n_ring, endpoint=False)
    verts = (c[:, None, :] + wire * (np.cos(th)[None, :, None] * normal[:, None, :]
                                      + np.sin(th)[None, :, None] * binormal[:, None, :])).reshape(-1, 3)
    faces = []
    for i in range(n_path - 1):
        for j in range(n_ring):
            a, b = i * n_ring + j, i * n_ring + (j + 1) % n_ring
            a2, b2 = a + n_ring, b + n_ring
            faces += [[a, a2, b], [b, a2, b2]]
    return verts, np.asarray(faces)


@dataclass
class RoadProfile:
    """Road height along the distance ``x`` (m, front axle travel) for each wheel track."""

    x: np.ndarray  # (nx,)
    z: np.ndarray  # (n_tracks, nx)
    track_y: list  # lateral centre of each track strip (m)
    width: float  # strip width (m)

    def height(self, x, track: int = 0) -> np.ndarray:
        return np.interp(x, self.x, self.z[track])


def _resample(xs: np.ndarray, zs: np.ndarray, max_points: int = 8000, dx_min: float = 0.02):
    order = np.argsort(xs, kind="stable")
    xs, zs = xs[order], zs[order]
    keep = np.concatenate([[True], np.diff(xs) > 1e-9])
    xs, zs = xs[keep], zs[keep]
    if xs.size < 2:
        x0 = xs[0] if xs.size else 0.0
        return np.array([x0 - 1.0, x0 + 1.0]), np.full(2, zs[0] if zs.size else 0.0)
    span = xs[-1] - xs[0]
    n = int(min(max_points, max(2, span / dx_min + 1)))
    grid = np.linspace(xs[0], xs[-1], n)
    return grid, np.interp(grid, xs, zs)


# ------------------------------------------------------------------------------------------------------------
class CarScene:
    """The static scene and the per-frame poses of one car, from a run's ``info`` and log channel names.

    ``distance(t)`` gives the distance travelled (m) at times ``t``; ``road`` is the road profile (or None for a
    rig input without travel).  :meth:`static_commands` lists the meshcat commands that build the scene and
    :meth:`poses` maps log columns (arrays over frames) to node poses.
    """

    def __init__(self, info: Mapping, columns, distance: Callable[[np.ndarray], np.ndarray],
                 road: RoadProfile | None, label: str = "", y_offset: float = 0.0, prefix: str = "car"):
        self.info = dict(info)
        self.columns = set(columns)
        self.sfx = list(info["suffixes"])
        nc = len(self.sfx)
        self.cx = np.asarray(info.get("corner_x") or [0.0] * nc, dtype=float)
        self.cy = np.asarray(info.get("corner_y") or [0.0] * nc, dtype=float)
        self.has_tire = all(f"wheel_z{s}" in self.columns for s in self.sfx)
        self.distance = distance
        self.road = road
        self.label = label
        self.prefix = prefix
        self.y_offset = y_offset
        span_x = float(self.cx.max() - self.cx.min())
        span_y = float(self.cy.max() - self.cy.min())
        self.body_len = span_x + 1.0 if span_x > 0 else 0.8
        # two-track cars: the body is narrower than the track so wheels and springs stay in sight (a schematic)
        self.body_w = max(0.6, span_y - 0.5) if span_y > 0 else 0.6
        self.body_h = BODY_H if span_x == 0 and span_y == 0 else 1.6 * BODY_H
        self.stop_gap = {s: float((info.get("stop_gap") or {}).get(s) or DEFAULT_GAP) for s in self.sfx}
        self.gap_from_run = bool(info.get("stop_gap"))
        self.static_tire = {s: float((info.get("static_tire_force") or {}).get(s, 0.0)) for s in self.sfx}
        self.static_susp = {s: float((info.get("static_suspension_force") or {}).get(s, 0.0)) for s in self.sfx}
        # lateral places: spring inboard of each wheel; actuator arrow outboard of the body (single track: on the
        # camera side, y < 0) or, on two-track cars, in line with the spring and 0.22 m towards the car's middle
        self.spring_y = np.where(self.cy > 0, self.cy - (TIRE_W / 2 + 0.09), self.cy + (TIRE_W / 2 + 0.09))
        if span_y == 0:
            self.spring_y = self.cy - (TIRE_W / 2 + 0.09)
            self.arrow_y = np.full(nc, -(self.body_w / 2 + 0.09))
            self.arrow_x = self.cx.copy()
        else:
            self.arrow_y = self.spring_y.copy()
            self.arrow_x = self.cx - np.sign(self.cx - (self.cx.max() + self.cx.min()) / 2) * 0.22
        self.base_z = WHEEL_R if self.has_tire else 0.05  # lower spring seat at equilibrium
        self.spring_len0 = BODY_Z - self.body_h / 2 - self.base_z
        self.moving_road = road is not None
        self.show_label = False  # a 3D name plate above the car (comparisons)

    # ---- paths
    def p(self, *names) -> str:
        return "/".join((ROOT, self.prefix) + names)

    @property
    def size(self) -> float:
        return max(self.body_len, self.body_w, 0.8)

    # ---- static scene
    def static_commands(self) -> list:
        import meshcat.geometry as g
        from meshcat.commands import SetObject, SetTransform

        P = _path
        out = []

        def obj(path, geom, mat, T=None):
            out.append(SetObject(geom, mat, P(path)))
            if T is not None:
                out.append(SetTransform(T, P(path)))

        lam = g.MeshLambertMaterial
        out.append(SetTransform(_matrix([0, self.y_offset, 0]), P(self.p())))
        xm = float(self.cx.max() + self.cx.min()) / 2  # the body node turns about the c.g. (x = 0)
        obj(self.p("body", "box"), g.Box([self.body_len, self.body_w, self.body_h]), lam(color=BODY_COLOR),
            _matrix([xm, 0, 0]))
        # a darker roof panel (towards the rear) so pitch and roll read well
        obj(self.p("body", "roof"), g.Box([self.body_len * 0.6, self.body_w * 0.8, 0.02]), lam(color=0x22447F),
            _matrix([xm - 0.05 * self.body_len, 0, self.body_h / 2 + 0.01]))
        for c, s in enumerate(self.sfx):
            name = s.lstrip("_") or "single"
            x, y = self.cx[c], self.cy[c]
            # arrow (scaled in z by the actuator force), child of the body
            obj(self.p("body", f"arrow_{name}", "shaft"), g.Cylinder(ARROW_LENGTH * 0.72, 0.022),
                lam(color=ARROW_COLOR), _matrix([0, 0, ARROW_LENGTH * 0.36], _quat_xyzw_axis("x", np.pi / 2)))
            obj(self.p("body", f"arrow_{name}", "head"),
                g.Cylinder(ARROW_LENGTH * 0.28, radiusTop=0.0, radiusBottom=0.055),
                lam(color=ARROW_COLOR), _matrix([0, 0, ARROW_LENGTH * 0.86], _quat_xyzw_axis("x", np.pi / 2)))
            out.append(SetTransform(_matrix([self.arrow_x[c], self.arrow_y[c], 0.0], None, [1, 1, 1e-4]),
                                    P(self.p("body", f"arrow_{name}"))))
            # spring
            v, f = _helix_mesh(self.spring_len0)
            obj(self.p(f"spring_{name}"), g.TriangularMeshGeometry(v, f), g.MeshPhongMaterial(color=0x33CC33))
            # wheel: node moves, spin child turns; tire and spokes; stub axle to the spring seat
            if self.has_tire:
                obj(self.p(f"wheel_{name}", "spin", "tire"), g.Cylinder(TIRE_W, WHEEL_R), lam(color=TIRE_COLOR))
                for k in range(2):
                    obj(self.p(f"wheel_{name}", "spin", f"spoke{k}"), g.Box([2 * WHEEL_R * 0.82, TIRE_W + 0.012, 0.07]),
                        lam(color=SPOKE_COLOR), _matrix([0, 0, 0], _quat_xyzw_axis("y", k * np.pi / 2)))
                dy = self.spring_y[c] - y
                obj(self.p(f"wheel_{name}", "stub"), g.Cylinder(abs(dy), 0.025), lam(color=0x777777),
                    _matrix([0, dy / 2, 0]))
                obj(self.p(f"wheel_{name}", "liftoff"), g.Ellipsoid([0.16, 0.16, 0.035]),
                    g.MeshBasicMaterial(color=LIFTOFF_COLOR))
                out.append(SetTransform(_matrix([0, 0, -WHEEL_R - 0.01]), P(self.p(f"wheel_{name}", "liftoff"))))
            if not self.moving_road:
                obj(self.p(f"plate_{name}", "box"), g.Box([0.8, max(0.6, TIRE_W + 0.4), 0.02]),
                    lam(color=0x555559), _matrix([0, (self.spring_y[c] - y) / 2, -0.01]))
        if self.moving_road:
            out.extend(self._road_commands())
        if self.show_label and self.label:
            # a name plate above the car, facing the front camera (+x)
            geom, mat = _text_object(self.label, font_size=40)
            obj(self.p("label"), geom, mat,
                _matrix([0, 0, BODY_Z + 0.9], _quat_xyzw_axis("z", np.pi / 2), [1.4, 1, 1.4]))
        return out

    def _road_commands(self) -> list:
        import meshcat.geometry as g
        from meshcat.commands import SetObject

        r = self.road
        verts, faces, cols = [], [], []
        n0 = 0
        for k, yc in enumerate(r.track_y):
            x, z = r.x, r.z[k]
            nx = x.size
            stripe = (np.floor(x) % 2 == 0)
            col = np.where(stripe[:, None], np.asarray(ROAD_STRIPE)[None, :], np.asarray(ROAD_COLOR)[None, :])
            yl, yr = yc + r.width / 2, yc - r.width / 2
            top_l = np.stack([x, np.full(nx, yl), z], 1)
            top_r = np.stack([x, np.full(nx, yr), z], 1)
            bot_l = np.stack([x, np.full(nx, yl), np.full(nx, -ROAD_DEPTH)], 1)
            bot_r = np.stack([x, np.full(nx, yr), np.full(nx, -ROAD_DEPTH)], 1)
            side = np.asarray(ROAD_COLOR) * 0.7
            for arr, cc in ((top_l, col), (top_r, col), (bot_l, np.tile(side, (nx, 1))), (bot_r, np.tile(side, (nx, 1)))):
                verts.append(arr)
                cols.append(cc)
            i = np.arange(nx - 1)
            TL, TR, BL, BR = n0 + i, n0 + nx + i, n0 + 2 * nx + i, n0 + 3 * nx + i
            for a, b in ((TR, TL), (TL, BL), (BR, TR)):  # top, left side, right side
                faces.append(np.stack([a, a + 1, b], 1))
                faces.append(np.stack([b, a + 1, b + 1], 1))
            n0 += 4 * nx
        V = np.concatenate(verts)
        C = np.concatenate(cols)
        F = np.concatenate(faces)
        return [SetObject(g.TriangularMeshGeometry(V, F, color=C),
                          g.MeshLambertMaterial(vertexColors=True), _path(self.p("road", "surface")))]

    # ---- poses
    def poses(self, cols: Mapping[str, np.ndarray], t: np.ndarray) -> dict:
        """Node path -> {property: array over frames} for the log columns ``cols`` sampled at times ``t``.

        Properties: ``position`` (n, 3), ``quaternion`` (n, 4; x, y, z, w), ``scale`` (n, 3), ``color`` (n, 3),
        ``visible`` (n,) bool."""
        t = np.asarray(t, dtype=float)
        n = t.size

        def col(name, default=0.0):
            v = cols.get(name)
            return np.full(n, default) if v is None else np.nan_to_num(np.asarray(v, dtype=float))

        out: dict = {}
        bz = col("body_z")
        q = _quat_mul(_quat_xyzw_axis("x", col("roll")), _quat_xyzw_axis("y", col("pitch")))
        out[self.p("body")] = {"position": np.stack([np.zeros(n), np.zeros(n), BODY_Z + bz], 1), "quaternion": q}
        dist = np.asarray(self.distance(t), dtype=float)
        if self.moving_road:
            # road coordinate d (front-axle distance) is drawn at world x = d − x(t) + x_front
            out[self.p("road")] = {"position": np.stack([self.cx.max() - dist, np.zeros(n), np.zeros(n)], 1)}
        spin = _quat_xyzw_axis("y", dist / WHEEL_R)
        for c, s in enumerate(self.sfx):
            name = s.lstrip("_") or "single"
            travel = col(f"travel{s}")
            road = col(f"road{s}")
            wz = col(f"wheel_z{s}") if self.has_tire else road
            base = self.base_z + wz
            length = np.maximum(self.spring_len0 + travel, 0.02)
            out[self.p(f"spring_{name}")] = {
                "position": np.stack([np.full(n, self.cx[c]), np.full(n, self.spring_y[c]), base], 1),
                "scale": np.stack([np.ones(n), np.ones(n), length / self.spring_len0], 1)}
            out[self.p(f"spring_{name}", "<object>")] = {"color": usage_color(np.abs(travel) / self.stop_gap[s])}
            fa = np.clip(col(f"actuator_force{s}") * ARROW_PER_N, -ARROW_MAX, ARROW_MAX) / ARROW_LENGTH
            fa = np.where(np.abs(fa) < 1e-4, 1e-4, fa)
            out[self.p("body", f"arrow_{name}")] = {"scale": np.stack([np.ones(n), np.ones(n), fa], 1),
                                                    "visible": np.abs(fa) * ARROW_LENGTH > 0.003}
            if self.has_tire:
                out[self.p(f"wheel_{name}")] = {
                    "position": np.stack([np.full(n, self.cx[c]), np.full(n, self.cy[c]), WHEEL_R + wz], 1)}
                out[self.p(f"wheel_{name}", "spin")] = {"quaternion": spin}
                total = self.static_tire[s] + col(f"tire_force{s}", 0.0)
                out[self.p(f"wheel_{name}", "liftoff")] = {"visible": total <= 0.0}
            if not self.moving_road:
                out[self.p(f"plate_{name}")] = {
                    "position": np.stack([np.full(n, self.cx[c]), np.full(n, self.cy[c]), road], 1)}
        return out


def _path(s: str):
    from meshcat.path import Path as MPath

    return MPath(("meshcat",)).append(s)


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
    from .simulation import SpeedProfile

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
        grid, z = _resample(np.concatenate(xs), np.concatenate(zs))
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


def animation_commands(scenes_and_ts, fps: float, t_end: float, repetitions: int = 1_000_000):
    """A meshcat SetAnimation for scenes (``[(scene, timeseries), ...]``) sampled at ``fps``."""
    from meshcat.animation import Animation, AnimationClip, AnimationTrack
    from meshcat.commands import SetAnimation

    t = frame_times(t_end, fps)
    frames = [round(float(v), 6) for v in t]
    anim = Animation(default_framerate=1)
    jstype = {"position": "vector3", "scale": "vector3", "quaternion": "quaternion", "color": "color",
              "visible": "boolean"}
    for scene, ts in scenes_and_ts:
        poses = scene.poses(sample_columns(ts, t), t)
        for path, props in poses.items():
            tracks = {}
            for prop, arr in props.items():
                name = "material.color" if prop == "color" else prop
                if prop == "visible":
                    vals = [bool(v) for v in arr]
                else:
                    vals = [[round(float(a), 6) for a in row] for row in np.asarray(arr)]
                tracks[name] = AnimationTrack(name, jstype[prop], frames=list(frames), values=vals)
            anim.clips[_path(path)] = AnimationClip(tracks=tracks, fps=1)
    return SetAnimation(anim, play=True, repetitions=repetitions), t


def _base_commands(size: float) -> list:
    """Hide meshcat's default grid and axes, set a light background, a ground plane and the camera."""
    import meshcat.geometry as g
    from meshcat.commands import SetObject, SetProperty, SetTransform

    out = [SetProperty("visible", False, _path("/Grid")), SetProperty("visible", False, _path("/Axes")),
           SetProperty("top_color", list(BACKGROUND[0]), _path("/Background")),
           SetProperty("bottom_color", list(BACKGROUND[1]), _path("/Background")),
           SetTransform(_matrix([0, 0, -TARGET_Z]), _path(ROOT)),
           SetObject(g.Box([120.0, 60.0, 0.02]), g.MeshLambertMaterial(color=GROUND_COLOR), _path(f"{ROOT}/ground")),
           SetTransform(_matrix([0, 0, -ROAD_DEPTH - 0.012]), _path(f"{ROOT}/ground"))]
    out += camera_commands("three_quarter", size)
    return out


def camera_position(name: str, size: float) -> list:
    """Camera position in meshcat's rotated camera frame (z up in the world is y there)."""
    if name not in CAMERAS:
        raise ValueError(f"unknown camera preset {name!r} (choose from {', '.join(CAMERAS)})")
    d = np.asarray(CAMERAS[name], dtype=float)
    d = d / np.linalg.norm(d) * (0.8 * size + 1.2) * (0.6 if name == "wheel" else 1.0)
    return [float(d[0]), float(d[2]), float(-d[1])]


def camera_commands(name: str, size: float) -> list:
    from meshcat.commands import SetProperty, SetTransform

    return [SetTransform(np.eye(4), _path("/Cameras/default")),
            SetProperty("position", camera_position(name, size), _path("/Cameras/default/rotated/<object>"))]


def _packed(cmds) -> list[str]:
    import umsgpack

    return [base64.b64encode(umsgpack.packb(c.lower())).decode("ascii") for c in cmds]


def meshcat_js() -> str:
    import meshcat

    return (Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js").read_text(encoding="utf-8")


def _legend(scenes) -> str:
    s = scenes[0]
    gap = ("bump-stop gap" if s.gap_from_run else f"{DEFAULT_GAP * 100:.0f} cm (no bump stop in this run)")
    return (f"springs: green &rarr; red as |travel| approaches the {gap}; "
            f"orange arrows: actuator force on the body ({ARROW_PER_N * 1000:.2g} m per kN); "
            "red disc: tire off the ground")


def build_html(scenes_and_ts, title: str = "suspension_sim run", fps: float | None = None,
               camera: str = "three_quarter", labels: list[str] | None = None) -> str:
    """The self-contained viewer page for one or more scenes (several cars side by side for comparisons)."""
    scenes = [s for s, _ in scenes_and_ts]
    t_end = float(max(ts["t"].iloc[-1] for _, ts in scenes_and_ts)) if scenes_and_ts else 0.0
    fps = choose_fps(scenes[0], t_end, fps)
    size = max(s.size for s in scenes) + (abs(scenes[-1].y_offset - scenes[0].y_offset) if len(scenes) > 1 else 0)
    cmds = _base_commands(size)
    for s in scenes:
        cmds += s.static_commands()
    anim, t = animation_commands(scenes_and_ts, fps, t_end)
    cmds.append(anim)
    cams = {k: camera_position(k, size) for k in CAMERAS}
    meta = {"duration": float(t[-1]) if t.size else 0.0, "fps": fps, "cameras": cams, "camera": camera,
            "labels": labels or [s.label for s in scenes]}
    return _TEMPLATE.format(title=_esc(title), js=meshcat_js(), cmds=json.dumps(_packed(cmds)),
                            meta=json.dumps(meta), legend=_legend(scenes),
                            options="".join(f'<option value="{k}"{" selected" if k == camera else ""}>{k}</option>'
                                            for k in CAMERAS))


def _esc(s: str) -> str:
    return str(s).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def write_viewer(result, path, fps: float | None = None, camera: str = "three_quarter") -> Path:
    """Write the recorded 3D view of ``result`` as a self-contained HTML page (opens offline)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    name = getattr(result.scenario, "name", None) or (result.scenario or {}).get("name", "run")
    scene = scene_from_result(result, label=str(name))
    path.write_text(build_html([(scene, result.timeseries)], title=f"{name} — 3D view", fps=fps, camera=camera),
                    encoding="utf-8")
    return path


def write_compare_viewer(results: Mapping[str, object], path, fps: float | None = None) -> Path:
    """Several runs side by side in one page (cars spaced sideways, each on its own road)."""
    path = Path(path)
    items, y = [], 0.0
    scenes = []
    for k, (label, r) in enumerate(results.items()):
        s = scene_from_result(r, label=label, prefix=f"car{k}")
        s.show_label = True
        scenes.append((s, r))
    widths = [s.body_w + 1.2 for s, _ in scenes]
    y = -sum(widths) / 2  # first run on the left seen from the front camera (screen right = +y)
    for (s, r), w in zip(scenes, widths):
        s.y_offset = y + w / 2
        y += w
        items.append((s, r.timeseries))
    path.write_text(build_html(items, title="comparison — 3D view", fps=fps, camera="front",
                               labels=list(results)), encoding="utf-8")
    return path


_TEMPLATE = """<!DOCTYPE html>
<html>
<head><meta charset="utf-8"><title>{title}</title>
<style>
 body {{ margin: 0; font-family: sans-serif; }}
 #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}
 #ss-overlay {{ position: absolute; left: 8px; top: 8px; background: rgba(255,255,255,0.85); padding: 6px 9px;
   border-radius: 6px; font-size: 13px; color: #222; max-width: 520px; }}
 #ss-time {{ font: bold 20px monospace; }}
 #ss-legend {{ font-size: 11px; color: #444; margin-top: 4px; }}
 #ss-slider {{ width: 300px; vertical-align: middle; }}
</style></head>
<body>
<div id="meshcat-pane"></div>
<div id="ss-overlay">
 <div><span id="ss-time">t = 0.000 s</span> <span id="ss-labels"></span></div>
 <div><button id="ss-play">pause</button>
  <input id="ss-slider" type="range" min="0" max="1" step="0.001" value="0">
  speed <select id="ss-speed"><option>0.1</option><option>0.25</option><option>0.5</option><option selected>1</option><option>2</option></select>
  camera <select id="ss-camera">{options}</select></div>
 <div id="ss-legend">{legend}</div>
</div>
<script>{js}</script>
<script>
(function() {{
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
window.viewer = viewer;
var META = {meta};
function b64(s) {{ var b = atob(s), u = new Uint8Array(b.length); for (var i = 0; i < b.length; i++) u[i] = b.charCodeAt(i); return u; }}
var CMDS = {cmds};
for (var i = 0; i < CMDS.length; i++) viewer.handle_command_bytearray(b64(CMDS[i]));
var an = viewer.animator;
function ensure() {{ an.actions.forEach(function(a) {{ a.enabled = true; a.paused = false; if (!a.isRunning()) a.play(); }}); }}
var api = {{
  duration: META.duration,
  time: function() {{ return an.time; }},
  seek: function(t) {{ if (an.playing) an.pause(); ensure(); an.seek(t); an.display_progress(t); viewer.render(); show(); }},
  play: function() {{ ensure(); an.play(); show(); }},
  pause: function() {{ an.pause(); show(); }},
  camera: function(name) {{
    var p = META.cameras[name]; if (!p) return false;
    viewer.set_property(["Cameras", "default", "rotated", "<object>"], "position", p);
    viewer.set_dirty(); viewer.render(); document.getElementById("ss-camera").value = name; return true; }},
  ready: true
}};
var timeEl = document.getElementById("ss-time"), slider = document.getElementById("ss-slider"),
    playBtn = document.getElementById("ss-play");
slider.max = META.duration;
document.getElementById("ss-labels").textContent = META.labels.length > 1 ? "(" + META.labels.join(" | ") + ")" : (META.labels[0] || "");
function show() {{ timeEl.textContent = "t = " + an.time.toFixed(3) + " s"; slider.value = an.time;
  playBtn.textContent = an.playing ? "pause" : "play"; }}
slider.addEventListener("input", function() {{ api.seek(parseFloat(slider.value)); }});
playBtn.addEventListener("click", function() {{ if (an.playing) api.pause(); else api.play(); }});
document.getElementById("ss-speed").addEventListener("change", function(e) {{ an.mixer.timeScale = parseFloat(e.target.value); }});
document.getElementById("ss-camera").addEventListener("change", function(e) {{ api.camera(e.target.value); }});
(function loop() {{ show(); requestAnimationFrame(loop); }})();
var h = {{}};
location.hash.replace(/^#/, "").split("&").forEach(function(kv) {{ var p = kv.split("="); if (p[0]) h[p[0]] = decodeURIComponent(p[1] || ""); }});
api.camera(h.camera || META.camera);
if (h.t !== undefined) api.seek(parseFloat(h.t));
window.suspensionSim = api;
}})();
</script>
</body>
</html>
"""


# ------------------------------------------------------------------------------------------------------------
# live viewer
_SERVER_CODE = r"""
import sys, tornado.web
from meshcat.servers import zmqserver as z
class LocalApp(tornado.web.Application):
    def listen(self, port, address="127.0.0.1", **kw):
        return super().listen(port, address=address, **kw)
class Bridge(z.ZMQWebSocketBridge):
    def handle_zmq(self, frames):
        if frames[0] == b"clients":  # how many browsers are connected
            self.zmq_socket.send(str(len(self.websocket_pool)).encode())
            return
        super().handle_zmq(frames)

    def make_app(self):
        return LocalApp([(r"/static/(.*)", z.StaticFileHandlerNoCache, {"path": z.VIEWER_ROOT, "default_filename": z.VIEWER_HTML}),
                         (r"/", z.WebSocketHandler, {"bridge": self})])
b = Bridge(host="127.0.0.1")
print("zmq_url=" + b.zmq_url, flush=True)
print("web_url=" + b.web_url, flush=True)
b.run()
"""


class LiveServer:
    """A meshcat server (websocket + files bound to 127.0.0.1, commands over ZMQ on 127.0.0.1)."""

    def __init__(self, timeout: float = 20.0):
        from .lifecycle import child_preexec

        self.proc = subprocess.Popen([sys.executable, "-u", "-c", _SERVER_CODE], stdout=subprocess.PIPE,
                                     stderr=subprocess.DEVNULL, start_new_session=True,
                                     preexec_fn=child_preexec())  # dies with us, SIGKILL included
        self.zmq_url = self.web_url = None
        t0 = _time.monotonic()
        while self.web_url is None:
            line = self.proc.stdout.readline().decode("utf-8", "replace").strip()
            if not line and self.proc.poll() is not None:
                raise RuntimeError("the meshcat server exited prematurely")
            if line.startswith("zmq_url="):
                self.zmq_url = line.split("=", 1)[1]
            elif line.startswith("web_url="):
                self.web_url = line.split("=", 1)[1]
            if _time.monotonic() - t0 > timeout:
                self.close()
                raise RuntimeError("the meshcat server did not start")
        import atexit

        atexit.register(self.close)

    @property
    def port(self) -> int:
        return int(self.web_url.split(":")[2].split("/")[0])

    def visualizer(self):
        import contextlib
        import io

        import meshcat

        with contextlib.redirect_stdout(io.StringIO()):  # meshcat prints the URL itself; we print our own
            self.vis = meshcat.Visualizer(zmq_url=self.zmq_url)
        return self.vis

    def clients(self) -> int:
        """Number of browsers connected to the viewer."""
        sock = self.vis.window.zmq_socket
        sock.send(b"clients")
        return int(sock.recv().decode())

    def wait_for_browser(self, timeout: float) -> bool:
        """Wait up to ``timeout`` s for a browser to connect; True if one did."""
        t0 = _time.monotonic()
        while _time.monotonic() - t0 < timeout:
            if self.clients() > 0:
                return True
            _time.sleep(0.1)
        return self.clients() > 0

    def close(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()


def _text_object(text: str, font_size: int = 64):
    import meshcat.geometry as g

    tex = g.GenericTexture({"type": "_text", "text": text, "font_size": font_size, "font_face": "monospace"})
    return g.Box([1.6, 0.001, 1.6]), g.MeshBasicMaterial(map=tex, transparent=True, opacity=1.0, color=0xFFFFFF, side=0)


class LiveView:
    """Streams frames to a meshcat visualizer: the static scene once, then poses with :meth:`show`, paced so one
    simulated second takes ``1/rate`` wall seconds (``rate`` = 0: as fast as the simulation runs)."""

    def __init__(self, vis, scene: CarScene, rate: float = 1.0, fps: float = 30.0, camera: str = "three_quarter"):
        self.vis, self.scene, self.rate, self.fps = vis, scene, rate, fps
        self.sent_frames = 0
        self._last_t = -np.inf
        self._last_text = -np.inf
        self._wall0 = None
        from meshcat.commands import Delete

        self._send_all([Delete(_path(ROOT))])  # a previous run's scene (variants share one server)
        self._send_all(_base_commands(scene.size))
        self._send_all(camera_commands(camera, scene.size))
        self._send_all(scene.static_commands())

    def _send_all(self, cmds):
        for c in cmds:
            self.vis.window.send(c)

    def show(self, t: float, cols: Mapping[str, float], force: bool = False):
        if not force and t - self._last_t < 1.0 / self.fps - 1e-12:
            return False
        from meshcat.commands import SetObject, SetProperty, SetTransform

        if self._wall0 is None:
            self._wall0 = _time.perf_counter() - (t / self.rate if self.rate > 0 else 0.0)
        elif self.rate > 0:
            wait = self._wall0 + t / self.rate - _time.perf_counter()
            if wait > 0:
                _time.sleep(wait)
        self._last_t = t
        poses = self.scene.poses({k: np.atleast_1d(v) for k, v in cols.items()}, np.atleast_1d(float(t)))
        for path, props in poses.items():
            p = _path(path)
            if "position" in props or "quaternion" in props or "scale" in props:
                pos = props.get("position", np.zeros((1, 3)))[0]
                q = props.get("quaternion", np.array([[0, 0, 0, 1.0]]))[0]
                sc = props.get("scale", np.ones((1, 3)))[0]
                self.vis.window.send(SetTransform(_matrix(pos, q, sc), p))
            if "color" in props:
                self.vis.window.send(SetProperty("color", [float(v) for v in props["color"][0]] + [1.0], p))
            if "visible" in props:
                self.vis.window.send(SetProperty("visible", bool(props["visible"][0]), p))
        if t - self._last_text >= 0.1 - 1e-9 or force:
            self._last_text = t
            geom, mat = _text_object(f"{t:.2f} s")
            self.vis.window.send(SetObject(geom, mat, _path(f"{ROOT}/clock")))
            self.vis.window.send(SetTransform(_matrix([0, 0, BODY_Z + 0.6], None, [self.scene.size / 1.5] * 3),
                                              _path(f"{ROOT}/clock")))
        self.sent_frames += 1
        return True


_SHARED: LiveServer | None = None  # one live server per process, reused by the variants of a run


def attach_live_viewer(sim, console=None, rate: float | None = None, fps: float = 30.0, camera: str = "three_quarter",
                       server: LiveServer | None = None, car: int = 0, wait: float | None = None,
                       open_browser: bool | None = None) -> LiveView:
    """Start a meshcat server on 127.0.0.1, print its URL and stream car ``car`` of ``sim`` while it runs.

    ``rate``: simulated seconds per wall second (default 1 = real time, env ``SUSPENSION_SIM_VIEW_RATE``; 0 =
    no pacing).  The view is fed through ``sim.log_hooks`` at every logged step (drawn at ``fps``).
    ``wait``: seconds to wait for a browser to connect before the run starts (default: env
    ``SUSPENSION_SIM_VIEW_WAIT``, else 30 s in an interactive terminal and 0 otherwise); ``open_browser``: try
    to open the URL in the default browser (default: in an interactive terminal)."""
    if rate is None:
        rate = float(os.environ.get("SUSPENSION_SIM_VIEW_RATE", "1.0"))
    interactive = sys.stdin is not None and sys.stdin.isatty() and sys.stdout.isatty()
    if wait is None:
        wait = float(os.environ.get("SUSPENSION_SIM_VIEW_WAIT", "30" if interactive else "0"))
    if open_browser is None:
        open_browser = interactive
    global _SHARED
    if server is None:
        if _SHARED is None or _SHARED.proc.poll() is not None:
            _SHARED = LiveServer()
        server = _SHARED
    vis = server.visualizer()
    P = sim.plant
    info = {"suffixes": P.suffixes, "corner_x": sim.geom.corner_x, "corner_y": sim.geom.corner_y,
            "corner_track": sim.geom.tracks,
            "static_tire_force": {s: float(P.static_tire[car, c]) for c, s in enumerate(P.suffixes)},
            "static_suspension_force": {s: float(P.static_susp[car, c]) for c, s in enumerate(P.suffixes)}}
    try:
        from .log import stop_gaps_all

        info["stop_gap"] = stop_gaps_all(sim)[car]
    except Exception:  # pragma: no cover - informative only
        info["stop_gap"] = {}
    columns = {f"{b}{s}" for s in P.suffixes for b in ("travel", "road", "actuator_force")}
    if P.has_tire:
        columns |= {f"{b}{s}" for s in P.suffixes for b in ("wheel_z", "tire_force")}
    sp = sim.speeds[car]
    scene = CarScene(info, columns, lambda t: np.asarray(sp.distance(np.asarray(t, dtype=float)), dtype=float),
                     road_profile_from_sim(sim, car), label=sim.scenarios[car].name)
    view = LiveView(vis, scene, rate=rate, fps=fps, camera=camera)
    view.server = server
    if console is not None:
        console.print(f"meshcat viewer: [bold]{server.web_url}[/] (open it in a browser; streaming at "
                      f"{'full speed' if rate <= 0 else f'{rate:g}x real time'})")
    else:
        print(f"meshcat viewer: {server.web_url}")
    if open_browser:
        import webbrowser

        try:
            webbrowser.open(server.web_url, new=2)
        except Exception:
            pass
    if wait > 0 and server.clients() == 0:
        msg = f"waiting up to {wait:g} s for a browser to open the viewer..."
        (console.print(msg) if console is not None else print(msg))
        server.wait_for_browser(wait)

    def hook(logger, j: int, t: float):
        if t - view._last_t < 1.0 / view.fps - 1e-12:
            return
        cols = {name: arr[car, j] for name, arr in logger.ch.items()}
        view.show(t, cols)

    sim.log_hooks.append(hook)
    return view


def replay_live(result, rate: float = 1.0, fps: float = 30.0, camera: str = "three_quarter", console=None,
                server: LiveServer | None = None) -> LiveView:
    """Stream a finished run to a live meshcat server (``suspension-sim view RUN --live``)."""
    server = server or LiveServer()
    scene = scene_from_result(result)
    view = LiveView(server.visualizer(), scene, rate=rate, fps=fps, camera=camera)
    view.server = server
    msg = f"meshcat viewer: {server.web_url}"
    (console.print(msg) if console is not None else print(msg))
    ts = result.timeseries
    t_end = float(ts["t"].iloc[-1])
    t = frame_times(t_end, fps)
    cols = sample_columns(ts, t)
    for j, tj in enumerate(t):
        view.show(float(tj), {k: v[j] for k, v in cols.items()}, force=True)
    return view
