"""The 3D viewer's scene follows the run (no browser needed): springs stretch with the logged travel, the road
drawn under every wheel is the road height the simulation used there (so the rear wheels meet a bump later),
the lift-off marker shows exactly when the total tire force is <= 0, the recorded page is self-contained, the
live viewer is bound to 127.0.0.1 and paced; reports and the view/compare commands write their files."""
from __future__ import annotations

import base64
import json
import re
import time

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("meshcat")

from suspension_sim.config import parse_scenario  # noqa: E402
from suspension_sim.outputs import write_result  # noqa: E402
from suspension_sim.results import Result  # noqa: E402
from suspension_sim.simulation import Simulation, simulate  # noqa: E402
from suspension_sim import viewer as V  # noqa: E402


def bump_scenario(model="quarter_car", height=0.08, length=2.0, speed=10.0, duration=1.2, **extra):
    raw = {"name": f"bump_{model}", "vehicle": {"model": model},
           "road": {"type": "bump", "params": {"height": height, "length": length, "start": 3.0}, "speed": speed},
           "sim": {"duration": duration, "log_dt": 0.002}}
    raw.update(extra)
    return parse_scenario(raw)


@pytest.fixture(scope="module")
def quarter():
    return simulate(bump_scenario("quarter_car"))


@pytest.fixture(scope="module")
def half():
    return simulate(bump_scenario("half_car"))


def poses_at_log(result):
    scene = V.scene_from_result(result)
    ts = result.timeseries
    cols = {c: ts[c].to_numpy() for c in ts.columns if c != "t"}
    return scene, scene.poses(cols, ts["t"].to_numpy())


@pytest.mark.parametrize("which", ["quarter", "half"])
def test_springs_stretch_with_travel_and_road_matches_the_log_under_every_wheel(which, request):
    r = request.getfixturevalue(which)
    scene, poses = poses_at_log(r)
    ts = r.timeseries
    road_x = poses[scene.p("road")]["position"][:, 0]
    for c, s in enumerate(scene.sfx):
        name = s.lstrip("_") or "single"
        # spring length = display length + suspension travel, its foot on the wheel
        length = poses[scene.p(f"spring_{name}")]["scale"][:, 2] * scene.spring_len0
        np.testing.assert_allclose(length, scene.spring_len0 + ts[f"travel{s}"].to_numpy(), atol=1e-9)
        np.testing.assert_allclose(poses[scene.p(f"spring_{name}")]["position"][:, 2],
                                   scene.base_z + ts[f"wheel_z{s}"].to_numpy(), atol=1e-9)
        # the road surface under the wheel (world x = corner x) is the height the simulation applied there
        d = scene.cx[c] - road_x
        drawn = scene.road.height(d, 0)
        logged = ts[f"road{s}"].to_numpy()
        assert np.max(np.abs(drawn - logged)) < 2e-3 * max(1.0, np.max(np.abs(logged)) / 0.08)
    if which == "half":
        # the rear wheel meets the bump (wheelbase / speed) later, on the drawn road as in the log
        t = ts["t"].to_numpy()
        first = {s: t[np.argmax(scene.road.height(scene.cx[c] - road_x, 0) > 0.01)]
                 for c, s in enumerate(scene.sfx)}
        wb = scene.cx.max() - scene.cx.min()
        assert first["_rear"] - first["_front"] == pytest.approx(wb / 10.0, abs=0.01)


def test_body_pose_wheel_spin_and_arrows(half):
    scene, poses = poses_at_log(half)
    ts = half.timeseries
    body = poses[scene.p("body")]
    np.testing.assert_allclose(body["position"][:, 2], V.BODY_Z + ts["body_z"].to_numpy())
    # quaternion about +y by the pitch angle (positive = nose down)
    q = body["quaternion"]
    np.testing.assert_allclose(2 * np.arctan2(q[:, 1], q[:, 3]), ts["pitch"].to_numpy(), atol=1e-9)
    # the wheel turns by distance / radius: 10 m/s over 1 frame of 2 ms
    spin = poses[scene.p("wheel_front", "spin")]["quaternion"]
    ang = 2 * np.arctan2(spin[:, 1], spin[:, 3])
    assert np.angle(np.exp(1j * (ang[1] - ang[0]))) == pytest.approx(10.0 * 0.002 / V.WHEEL_R, rel=1e-6)
    # passive run: no actuator force, so the arrows are hidden
    assert not poses[scene.p("body", "arrow_front")]["visible"].any()


def test_arrow_scales_with_actuator_force_and_flips_sign():
    info = {"suffixes": [""], "corner_x": [0.0], "corner_y": [0.0], "static_tire_force": {"": 3000.0},
            "static_suspension_force": {"": 2800.0}}
    t = np.array([0.0, 0.1, 0.2])
    cols = {"actuator_force": np.array([1000.0, -500.0, 0.0]), "wheel_z": np.zeros(3), "travel": np.zeros(3),
            "road": np.zeros(3), "tire_force": np.zeros(3)}
    scene = V.CarScene(info, cols, lambda t: 0 * t, None)
    arrow = scene.poses(cols, t)[scene.p("body", "arrow_single")]
    length = arrow["scale"][:, 2] * V.ARROW_LENGTH
    assert length[0] == pytest.approx(1000 * V.ARROW_PER_N)
    assert length[1] == pytest.approx(-500 * V.ARROW_PER_N)
    assert list(arrow["visible"]) == [True, True, False]


def test_spring_colour_goes_red_at_the_bump_stop_gap():
    green, mid, red = V.usage_color(np.array([0.0, 0.5, 1.2]))
    assert green[1] > 0.6 and green[0] < 0.2
    assert red[0] > 0.9 and red[1] < 0.1
    assert mid[0] > 0.9 and mid[1] > 0.7  # yellow half-way
    sc = bump_scenario("quarter_car", duration=0.8, vehicle={
        "model": "quarter_car", "effects": [{"type": "bump_stop", "params": {"gap": 0.02}}]})
    r = simulate(sc)
    assert r.info["stop_gap"] == {"": pytest.approx(0.02)}
    scene, poses = poses_at_log(r)
    col = poses[scene.p("spring_single", "<object>")]["color"]
    usage = np.abs(r.timeseries["travel"].to_numpy()) / 0.02
    assert usage.max() >= 1.0 and usage.min() < 0.2  # the run does reach the stop
    np.testing.assert_allclose(col, V.usage_color(usage))
    assert scene.gap_from_run


def test_liftoff_marker_shows_exactly_when_total_tire_force_is_not_positive():
    r = simulate(bump_scenario("quarter_car", height=0.12, length=0.6, speed=20.0, duration=0.5))
    scene, poses = poses_at_log(r)
    vis = poses[scene.p("wheel_single", "liftoff")]["visible"]
    total = r.info["static_tire_force"][""] + r.timeseries["tire_force"].to_numpy()
    np.testing.assert_array_equal(vis, total <= 0)
    assert vis.any() and not vis.all()


def synthetic_full_car(n=200, speed=8.0):
    """A four-corner log (left track has a bump, right track flat) to check the layout without a full-car model."""
    t = np.arange(n) * 0.01
    sfx = ["_fl", "_fr", "_rl", "_rr"]
    cx, cy = [1.3, 1.3, -1.4, -1.4], [0.8, -0.8, 0.8, -0.8]
    x = speed * t
    cols = {"t": t, "body_z": 0.01 * np.sin(t), "pitch": 0.01 * np.sin(2 * t), "roll": 0.02 * np.sin(3 * t)}
    bump = lambda d: np.where((d > 5) & (d < 6), 0.05 * np.sin(np.pi * (d - 5)) ** 2, 0.0)  # noqa: E731
    for s, xc, yc in zip(sfx, cx, cy):
        d = x - (1.3 - xc)
        cols[f"road{s}"] = bump(d) if yc > 0 else np.zeros(n)
        cols[f"wheel_z{s}"] = cols[f"road{s}"] * 0.9
        cols[f"travel{s}"] = -cols[f"road{s}"] * 0.5
        cols[f"tire_force{s}"] = np.zeros(n)
        cols[f"actuator_force{s}"] = np.zeros(n)
    info = {"model": "full_car", "suffixes": sfx, "corner_x": cx, "corner_y": cy,
            "static_tire_force": {s: 3500.0 for s in sfx}, "static_suspension_force": {s: 3000.0 for s in sfx},
            "stop_gap": {}}
    sc = {"name": "synthetic_full", "road": {"speed": speed}, "sim": {"duration": float(t[-1]), "dt": 0.0005}}
    return Result(scenario=sc, timeseries=pd.DataFrame(cols), info=info)


def test_full_car_layout_two_tracks_and_html(tmp_path):
    r = synthetic_full_car()
    scene, poses = poses_at_log(r)
    assert len(scene.road.track_y) == 2 and scene.road.track_y[0] > 0 > scene.road.track_y[1]
    assert np.max(scene.road.z[0]) == pytest.approx(0.05, abs=1e-3) and np.max(np.abs(scene.road.z[1])) == 0
    # the springs sit inboard of their wheels and outboard of the body (in sight), the arrows beside them
    for c, s in enumerate(scene.sfx):
        assert scene.body_w / 2 < abs(scene.spring_y[c]) < abs(scene.cy[c]) and abs(scene.arrow_y[c]) > scene.body_w / 2
        assert scene.p(f"wheel_{s.lstrip('_')}") in poses
    p = V.write_viewer(r, tmp_path / "viewer.html")
    assert p.stat().st_size > 500_000


def test_sdof_rig_without_travel_uses_moving_plates():
    r = simulate(parse_scenario({"name": "rig", "vehicle": {"model": "sdof"},
                                 "road": {"type": "sine", "params": {"amplitude": 0.01, "frequency": 2.0}, "speed": 0},
                                 "sim": {"duration": 0.5, "log_dt": 0.002}}))
    scene, poses = poses_at_log(r)
    assert scene.road is None and not scene.has_tire
    plate = poses[scene.p("plate_single")]["position"][:, 2]
    np.testing.assert_allclose(plate, r.timeseries["road"].to_numpy())
    spring = poses[scene.p("spring_single")]
    np.testing.assert_allclose(spring["position"][:, 2], scene.base_z + r.timeseries["road"].to_numpy())


def decode_commands(html: str) -> list[dict]:
    import umsgpack

    blob = re.search(r"var CMDS = (\[.*?\]);", html, re.S).group(1)
    return [umsgpack.unpackb(base64.b64decode(s)) for s in json.loads(blob)]


def test_viewer_html_is_self_contained_and_holds_the_whole_animation(quarter, tmp_path):
    html = V.write_viewer(quarter, tmp_path / "viewer.html").read_text()
    # nothing to fetch: no external script, stylesheet or image
    assert not re.search(r"""(src|href)\s*=\s*["']?(https?:)?//""", html)
    assert "<script src" not in html.replace(" ", "")
    assert "MeshCat" in html and len(html) > 800_000  # meshcat's bundle is embedded
    cmds = decode_commands(html)
    anim = [c for c in cmds if c["type"] == "set_animation"]
    assert len(anim) == 1
    clips = {a["path"]: a["clip"] for a in anim[0]["animations"]}
    body = clips[f"/meshcat/{V.ROOT}/car/body"]
    pos = next(tr for tr in body["tracks"] if tr["name"] == ".position")
    times = [k["time"] for k in pos["keys"]]
    assert times[0] == 0 and times[-1] == pytest.approx(quarter.timeseries["t"].iloc[-1], abs=1 / 30)
    # the animated heave is the logged one
    ts = quarter.timeseries
    z = np.array([k["value"][2] for k in pos["keys"]]) - V.BODY_Z
    np.testing.assert_allclose(z, np.interp(times, ts["t"], ts["body_z"]), atol=1e-6)


def test_live_viewer_binds_localhost_streams_frames_and_paces(tmp_path):
    sc = bump_scenario("quarter_car", duration=0.6)
    sim = Simulation([sc])
    view = V.attach_live_viewer(sim, rate=1.0, fps=20)
    try:
        assert view.server.web_url.startswith("http://127.0.0.1:")
        port = view.server.port
        listening = []
        for line in open("/proc/net/tcp").read().splitlines()[1:] + open("/proc/net/tcp6").read().splitlines()[1:]:
            f = line.split()
            addr, p = f[1].split(":")
            if int(p, 16) == port and f[3] == "0A":  # LISTEN
                listening.append(addr)
        assert listening and all(a == "0100007F" for a in listening), listening
        w0 = time.perf_counter()
        sim.run()
        wall = time.perf_counter() - w0
        assert wall >= 0.6 * 0.9  # paced at real time
        assert abs(view.sent_frames - 0.6 * 20) <= 2
    finally:
        view.server.close()


def test_write_result_outputs_and_commands(tmp_path):
    from typer.testing import CliRunner

    from suspension_sim.cli import app

    runs = []
    for ctrl in ("passive", "skyhook"):
        sc = bump_scenario("quarter_car", duration=0.6, outputs={"plots": False, "viewer": True, "report": True},
                           controller={"type": ctrl, **({"params": {"c_sky": 2000}} if ctrl == "skyhook" else {})},
                           sensors=[{"name": "corner_body_vel", "type": "corner_body_vel"}] if ctrl == "skyhook" else [])
        d = write_result(simulate(sc), tmp_path / ctrl, plots=False)
        assert (d / "viewer.html").exists() and (d / "report.html").exists()
        rep = (d / "report.html").read_text()
        assert "body_acc_rms" in rep and "viewer.html" in rep and "data:image/png;base64," in rep
        runs.append(d)
    res = CliRunner().invoke(app, ["compare", str(runs[0]), str(runs[1]), "--out", str(tmp_path / "cmp"),
                                   "--labels", "passive,skyhook"])
    assert res.exit_code == 0, res.output
    rep = (tmp_path / "cmp" / "report.html").read_text()
    assert "passive" in rep and "skyhook" in rep and (tmp_path / "cmp" / "viewer.html").exists()
    m = [json.loads((d / "summary.json").read_text())["metrics"]["body_acc_rms"] for d in runs]
    assert f"({100 * (m[1] - m[0]) / m[0]:+.0f}%)" in rep  # change against the first run
    (runs[0] / "viewer.html").unlink()
    res = CliRunner().invoke(app, ["view", str(runs[0]), "--write-only"])
    assert res.exit_code == 0, res.output
    assert (runs[0] / "viewer.html").exists()
    res = CliRunner().invoke(app, ["view", str(tmp_path)])  # holds two runs: a one-line error naming them
    assert res.exit_code == 2 and "give one of its variant folders (passive, skyhook)" in res.output
    (tmp_path / "empty").mkdir()
    res = CliRunner().invoke(app, ["view", str(tmp_path / "empty")])
    assert res.exit_code == 2 and "not a run folder" in res.output


def test_replay_of_a_finished_run_streams_every_frame(quarter):
    view = V.replay_live(quarter, rate=0.0, fps=25)
    try:
        n = len(V.frame_times(float(quarter.timeseries["t"].iloc[-1]), 25))
        assert view.sent_frames == n
        assert view._last_t == pytest.approx(quarter.timeseries["t"].iloc[-1], abs=1 / 25)
    finally:
        view.server.close()
