"""The live view: a meshcat server on 127.0.0.1 fed by a running simulation's log hooks, or a finished run
replayed (see :mod:`suspension_sim.viewer`)."""
from __future__ import annotations

import os
import subprocess
import sys
import time as _time
from typing import Mapping

import numpy as np

from .scene import BODY_Z, CarScene, ROOT, meshcat_path, pose_matrix, text_object
from .sources import frame_times, road_profile_from_sim, sample_columns, scene_from_result
from .recording import base_commands, camera_commands


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
        from ..lifecycle import child_preexec

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

        self._send_all([Delete(meshcat_path(ROOT))])  # a previous run's scene (variants share one server)
        self._send_all(base_commands(scene.size))
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
            p = meshcat_path(path)
            if "position" in props or "quaternion" in props or "scale" in props:
                pos = props.get("position", np.zeros((1, 3)))[0]
                q = props.get("quaternion", np.array([[0, 0, 0, 1.0]]))[0]
                sc = props.get("scale", np.ones((1, 3)))[0]
                self.vis.window.send(SetTransform(pose_matrix(pos, q, sc), p))
            if "color" in props:
                self.vis.window.send(SetProperty("color", [float(v) for v in props["color"][0]] + [1.0], p))
            if "visible" in props:
                self.vis.window.send(SetProperty("visible", bool(props["visible"][0]), p))
        if t - self._last_text >= 0.1 - 1e-9 or force:
            self._last_text = t
            geom, mat = text_object(f"{t:.2f} s")
            self.vis.window.send(SetObject(geom, mat, meshcat_path(f"{ROOT}/clock")))
            self.vis.window.send(SetTransform(pose_matrix([0, 0, BODY_Z + 0.6], None, [self.scene.size / 1.5] * 3),
                                              meshcat_path(f"{ROOT}/clock")))
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
        from ..log import stop_gaps_all

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
