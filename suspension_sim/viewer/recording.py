"""The recorded view: a meshcat animation in a self-contained ``viewer.html`` (see
:mod:`suspension_sim.viewer`)."""
from __future__ import annotations

import base64
import json
from pathlib import Path
from typing import Mapping

import numpy as np

from .scene import (ARROW_PER_N, BACKGROUND, CAMERAS, DEFAULT_GAP, GROUND_COLOR, ROAD_DEPTH, ROOT, TARGET_Z, meshcat_path,
                    pose_matrix)
from .sources import choose_fps, frame_times, sample_columns, scene_from_result


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
            anim.clips[meshcat_path(path)] = AnimationClip(tracks=tracks, fps=1)
    return SetAnimation(anim, play=True, repetitions=repetitions), t


def base_commands(size: float) -> list:
    """Hide meshcat's default grid and axes, set a light background, a ground plane and the camera."""
    import meshcat.geometry as g
    from meshcat.commands import SetObject, SetProperty, SetTransform

    out = [SetProperty("visible", False, meshcat_path("/Grid")), SetProperty("visible", False, meshcat_path("/Axes")),
           SetProperty("top_color", list(BACKGROUND[0]), meshcat_path("/Background")),
           SetProperty("bottom_color", list(BACKGROUND[1]), meshcat_path("/Background")),
           SetTransform(pose_matrix([0, 0, -TARGET_Z]), meshcat_path(ROOT)),
           SetObject(g.Box([120.0, 60.0, 0.02]), g.MeshLambertMaterial(color=GROUND_COLOR), meshcat_path(f"{ROOT}/ground")),
           SetTransform(pose_matrix([0, 0, -ROAD_DEPTH - 0.012]), meshcat_path(f"{ROOT}/ground"))]
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

    return [SetTransform(np.eye(4), meshcat_path("/Cameras/default")),
            SetProperty("position", camera_position(name, size), meshcat_path("/Cameras/default/rotated/<object>"))]


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
    cmds = base_commands(size)
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
