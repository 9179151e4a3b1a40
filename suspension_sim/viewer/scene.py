"""The 3D scene of one car drawn from a run's log: display sizes, colours, cameras, meshes and the
:class:`CarScene` that turns logged channels into meshcat poses (see :mod:`suspension_sim.viewer`)."""
from __future__ import annotations

from dataclasses import dataclass
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


def pose_matrix(pos, quat=None, scale=None) -> np.ndarray:
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


def resample_profile(xs: np.ndarray, zs: np.ndarray, max_points: int = 8000, dx_min: float = 0.02):
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

        P = meshcat_path
        out = []

        def obj(path, geom, mat, T=None):
            out.append(SetObject(geom, mat, P(path)))
            if T is not None:
                out.append(SetTransform(T, P(path)))

        lam = g.MeshLambertMaterial
        out.append(SetTransform(pose_matrix([0, self.y_offset, 0]), P(self.p())))
        xm = float(self.cx.max() + self.cx.min()) / 2  # the body node turns about the c.g. (x = 0)
        obj(self.p("body", "box"), g.Box([self.body_len, self.body_w, self.body_h]), lam(color=BODY_COLOR),
            pose_matrix([xm, 0, 0]))
        # a darker roof panel (towards the rear) so pitch and roll read well
        obj(self.p("body", "roof"), g.Box([self.body_len * 0.6, self.body_w * 0.8, 0.02]), lam(color=0x22447F),
            pose_matrix([xm - 0.05 * self.body_len, 0, self.body_h / 2 + 0.01]))
        for c, s in enumerate(self.sfx):
            name = s.lstrip("_") or "single"
            x, y = self.cx[c], self.cy[c]
            # arrow (scaled in z by the actuator force), child of the body
            obj(self.p("body", f"arrow_{name}", "shaft"), g.Cylinder(ARROW_LENGTH * 0.72, 0.022),
                lam(color=ARROW_COLOR), pose_matrix([0, 0, ARROW_LENGTH * 0.36], _quat_xyzw_axis("x", np.pi / 2)))
            obj(self.p("body", f"arrow_{name}", "head"),
                g.Cylinder(ARROW_LENGTH * 0.28, radiusTop=0.0, radiusBottom=0.055),
                lam(color=ARROW_COLOR), pose_matrix([0, 0, ARROW_LENGTH * 0.86], _quat_xyzw_axis("x", np.pi / 2)))
            out.append(SetTransform(pose_matrix([self.arrow_x[c], self.arrow_y[c], 0.0], None, [1, 1, 1e-4]),
                                    P(self.p("body", f"arrow_{name}"))))
            # spring
            v, f = _helix_mesh(self.spring_len0)
            obj(self.p(f"spring_{name}"), g.TriangularMeshGeometry(v, f), g.MeshPhongMaterial(color=0x33CC33))
            # wheel: node moves, spin child turns; tire and spokes; stub axle to the spring seat
            if self.has_tire:
                obj(self.p(f"wheel_{name}", "spin", "tire"), g.Cylinder(TIRE_W, WHEEL_R), lam(color=TIRE_COLOR))
                for k in range(2):
                    obj(self.p(f"wheel_{name}", "spin", f"spoke{k}"), g.Box([2 * WHEEL_R * 0.82, TIRE_W + 0.012, 0.07]),
                        lam(color=SPOKE_COLOR), pose_matrix([0, 0, 0], _quat_xyzw_axis("y", k * np.pi / 2)))
                dy = self.spring_y[c] - y
                obj(self.p(f"wheel_{name}", "stub"), g.Cylinder(abs(dy), 0.025), lam(color=0x777777),
                    pose_matrix([0, dy / 2, 0]))
                obj(self.p(f"wheel_{name}", "liftoff"), g.Ellipsoid([0.16, 0.16, 0.035]),
                    g.MeshBasicMaterial(color=LIFTOFF_COLOR))
                out.append(SetTransform(pose_matrix([0, 0, -WHEEL_R - 0.01]), P(self.p(f"wheel_{name}", "liftoff"))))
            if not self.moving_road:
                obj(self.p(f"plate_{name}", "box"), g.Box([0.8, max(0.6, TIRE_W + 0.4), 0.02]),
                    lam(color=0x555559), pose_matrix([0, (self.spring_y[c] - y) / 2, -0.01]))
        if self.moving_road:
            out.extend(self._road_commands())
        if self.show_label and self.label:
            # a name plate above the car, facing the front camera (+x)
            geom, mat = text_object(self.label, font_size=40)
            obj(self.p("label"), geom, mat,
                pose_matrix([0, 0, BODY_Z + 0.9], _quat_xyzw_axis("z", np.pi / 2), [1.4, 1, 1.4]))
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
                          g.MeshLambertMaterial(vertexColors=True), meshcat_path(self.p("road", "surface")))]

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


def meshcat_path(s: str):
    from meshcat.path import Path as MPath

    return MPath(("meshcat",)).append(s)


def text_object(text: str, font_size: int = 64):
    import meshcat.geometry as g

    tex = g.GenericTexture({"type": "_text", "text": text, "font_size": font_size, "font_face": "monospace"})
    return g.Box([1.6, 0.001, 1.6]), g.MeshBasicMaterial(map=tex, transparent=True, opacity=1.0, color=0xFFFFFF, side=0)
