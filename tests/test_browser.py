"""The 3D viewer and the reports in a real browser: headless Chromium (Debian ``chromium`` + ``chromium-driver``,
installed by ``.ci/install_browser.sh``) driven with selenium opens ``viewer.html`` and ``report.html`` from disk
(and the live meshcat server), screenshots are taken at two animation times, and the pictures are checked: the
canvas is not blank, the car's body (its blue) is in the middle of the view, and the picture changes between
two times at which the car moved, by the amount and in the direction the body moved.

Screenshots are written to ``$SUSPENSION_SIM_SCREENSHOTS`` (default: pytest's temporary folder) for a look.
Skips with the reason when selenium, chromium or chromedriver is missing.
"""
from __future__ import annotations

import io
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("meshcat")
selenium = pytest.importorskip("selenium", reason="selenium not installed (pip install -e '.[test]')")

from suspension_sim.config import parse_scenario  # noqa: E402
from suspension_sim.report import write_report  # noqa: E402
from suspension_sim.outputs import write_result  # noqa: E402
from suspension_sim.simulation import Simulation, simulate  # noqa: E402

FLAGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-unsafe-swiftshader",  # software WebGL (no GPU here)
         "--window-size=800,560", "--hide-scrollbars"]


def _browser_paths():
    chrome = os.environ.get("CHROME_BIN") or next(
        (p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
    driver = os.environ.get("CHROMEDRIVER") or shutil.which("chromedriver")
    return chrome, driver


@pytest.fixture(scope="module")
def driver():
    chrome, drv = _browser_paths()
    if not chrome or not drv:
        pytest.skip("no headless browser: install the Debian packages chromium and chromium-driver "
                    "(.ci/install_browser.sh)")
    os.environ.setdefault("SE_OFFLINE", "true")  # never let selenium look for drivers on the network
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = chrome
    profile = tempfile.mkdtemp(prefix="ss-chromium-")
    for f in FLAGS + [f"--user-data-dir={profile}"]:
        opts.add_argument(f)
    try:
        d = webdriver.Chrome(service=Service(drv), options=opts)
    except Exception as e:  # pragma: no cover - depends on the machine
        shutil.rmtree(profile, ignore_errors=True)
        pytest.skip(f"chromium could not be started: {str(e).splitlines()[0]}")
    d.set_page_load_timeout(60)
    yield d
    d.quit()
    shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture(scope="module")
def shots(tmp_path_factory) -> Path:
    d = Path(os.environ.get("SUSPENSION_SIM_SCREENSHOTS") or tmp_path_factory.mktemp("screenshots"))
    d.mkdir(parents=True, exist_ok=True)
    return d


def bump_run(model: str, tmp: Path, report: bool = False):
    """A passive run over a bump with its viewer, in the Python loop: what the browser shows does not depend on
    the loop, and the compiled loop would compile the passive cars without sensors for these tests alone (10-15
    CPU-s a model on a cold compile cache against ~1 CPU-s for 1.6 s in the Python loop)."""
    sc = parse_scenario({"name": f"bump_{model}", "vehicle": {"model": model},
                         "road": {"type": "bump", "params": {"height": 0.08, "length": 2.0, "start": 3.0},
                                  "speed": 10},
                         "sim": {"duration": 1.6, "log_dt": 0.002},
                         "outputs": {"plots": False, "viewer": True, "report": report}})
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SUSPENSION_SIM_COMPILED", "0")
        r = simulate(sc)
    d = write_result(r, tmp / model, plots=False)
    return r, d


@pytest.fixture(scope="module")
def quarter_run(tmp_path_factory):
    return bump_run("quarter_car", tmp_path_factory.mktemp("quarter_car"), report=True)


@pytest.fixture(scope="module", params=["quarter_car", "half_car", "full_car"])
def run(request, tmp_path_factory):
    if request.param == "quarter_car":
        return request.getfixturevalue("quarter_run")
    return bump_run(request.param, tmp_path_factory.mktemp(request.param))


# ---------------------------------------------------------------------------------------------------------
def png_array(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def central(img: np.ndarray, frac: float = 0.5) -> np.ndarray:
    h, w, _ = img.shape
    y0, x0 = int(h * (1 - frac) / 2), int(w * (1 - frac) / 2)
    return img[y0:h - y0, x0:w - x0]


def body_mask(img: np.ndarray) -> np.ndarray:
    """Pixels of the body's blue (0x3366CC lit by the scene's lights); nothing else in the scene is that blue."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b > 110) & (b > r + 50) & (b > g + 25)


def wait_ready(d, timeout=40.0):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if d.execute_script("return !!(window.suspensionSim && window.suspensionSim.ready)"):
            return
        time.sleep(0.1)
    raise AssertionError("the viewer page did not become ready: " + str(d.get_log("browser")[-5:]))


def show_time(d, t: float):
    d.execute_script("window.suspensionSim.seek(arguments[0]);", float(t))
    # let the compositor show the rendered frame
    d.execute_async_script("var cb = arguments[0]; requestAnimationFrame(() => requestAnimationFrame(cb));")


def assert_not_blank(img: np.ndarray, what: str):
    c = central(img)
    assert c.std() > 8, f"{what}: the canvas looks blank (std {c.std():.1f})"
    assert len(np.unique(c.reshape(-1, 3), axis=0)) > 50, f"{what}: too few colours in the picture"


def assert_car_in_view(img: np.ndarray, what: str):
    n = int(body_mask(central(img, 0.6)).sum())
    assert n > 400, f"{what}: the car body is not in the middle of the view ({n} body pixels)"


def times_where_body_moved(result):
    """A time before the bump and the time of the highest body position (the car moved between them)."""
    ts = result.timeseries
    t, z = ts["t"].to_numpy(), ts["body_z"].to_numpy()
    t1 = 0.1
    t2 = float(t[np.argmax(z)])
    dz = float(z.max() - np.interp(t1, t, z))
    assert dz > 0.02, "the run should lift the body by centimetres"
    return t1, t2, dz


def test_viewer_html_from_disk(driver, run, shots):
    result, d = run
    model = result.info["model"]
    driver.get((d / "viewer.html").resolve().as_uri())
    wait_ready(driver)
    dur = driver.execute_script("return window.suspensionSim.duration")
    assert dur == pytest.approx(result.timeseries["t"].iloc[-1], abs=0.05)
    assert driver.execute_script("return window.suspensionSim.camera('side')")
    t1, t2, dz = times_where_body_moved(result)
    imgs = {}
    for t in (t1, t2):
        show_time(driver, t)
        txt = driver.execute_script("return document.getElementById('ss-time').textContent")
        assert txt == f"t = {t:.3f} s"  # the time on screen
        png = driver.get_screenshot_as_png()
        (shots / f"viewer_{model}_t{t:.3f}.png").write_bytes(png)
        imgs[t] = png_array(png)
        assert_not_blank(imgs[t], f"{model} t={t}")
        assert_car_in_view(imgs[t], f"{model} t={t}")
    a, b = central(imgs[t1], 0.8), central(imgs[t2], 0.8)
    changed = (np.abs(a - b).sum(axis=2) > 30).mean()
    assert changed > 0.002, f"the picture did not change between t={t1} and t={t2} ({changed:.4f} of pixels)"
    # the body moved up on screen (side camera, z up = image rows decreasing)
    rows = [np.nonzero(body_mask(central(imgs[t], 0.8)))[0].mean() for t in (t1, t2)]
    assert rows[1] < rows[0] - 1.0, f"body centroid rows {rows} should move up by a body lift of {dz * 100:.1f} cm"
    # the picture is a function of the animation time: back to t1 gives the first picture again
    show_time(driver, t1)
    again = central(png_array(driver.get_screenshot_as_png()), 0.8)
    assert np.abs(again - a).mean() < 1.0
    # play advances the animation time, pause holds it
    driver.execute_script("window.suspensionSim.play()")
    time.sleep(0.4)
    driver.execute_script("window.suspensionSim.pause()")
    t_paused = driver.execute_script("return window.suspensionSim.time()")
    assert t_paused > t1 + 0.05
    time.sleep(0.2)
    assert driver.execute_script("return window.suspensionSim.time()") == t_paused
    errors = [e for e in driver.get_log("browser") if e.get("level") == "SEVERE"]
    assert not errors, errors


def test_report_html_from_disk(driver, quarter_run, shots):
    from selenium.webdriver.common.by import By

    result, d = quarter_run
    model = result.info["model"]
    driver.get((d / "report.html").resolve().as_uri())
    n_rows = driver.execute_script("return document.querySelectorAll('table.metrics tr').length")
    assert n_rows > 5
    assert "body_acc_rms" in driver.find_element(By.CSS_SELECTOR, "table.metrics").text
    imgs_ok = driver.execute_script(
        "return Array.from(document.querySelectorAll('.plots img')).map(i => i.complete && i.naturalWidth > 100)")
    assert imgs_ok and all(imgs_ok)
    frame = driver.find_element(By.ID, "viewer")
    driver.execute_script("arguments[0].scrollIntoView();", frame)
    driver.switch_to.frame(frame)
    try:
        wait_ready(driver)
        driver.execute_script("window.suspensionSim.camera('side')")
        t1, t2, _ = times_where_body_moved(result)
        pics = []
        for t in (t1, t2):
            show_time(driver, t)
            driver.switch_to.default_content()
            png = driver.find_element(By.ID, "viewer").screenshot_as_png
            (shots / f"report_{model}_t{t:.3f}.png").write_bytes(png)
            img = png_array(png)
            assert_not_blank(img, f"report {model} t={t}")
            assert_car_in_view(img, f"report {model} t={t}")
            pics.append(central(img, 0.8))
            driver.switch_to.frame(driver.find_element(By.ID, "viewer"))
        assert (np.abs(pics[0] - pics[1]).sum(axis=2) > 30).mean() > 0.002
    finally:
        driver.switch_to.default_content()
    full = driver.get_screenshot_as_png()
    (shots / f"report_{model}_page.png").write_bytes(full)


def settled_screenshot(d, timeout: float = 30.0) -> bytes:
    """A screenshot once the page has stopped changing (two in a row alike): the frame last sent is drawn."""
    png = d.get_screenshot_as_png()
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        time.sleep(0.2)
        again = d.get_screenshot_as_png()
        if np.abs(central(png_array(again), 0.8) - central(png_array(png), 0.8)).mean() < 0.5:
            return again
        png = again
    return png


def test_live_viewer_streams_to_the_browser(driver, shots):
    """A run streams its frames to the browser while it runs.  The run is held (a log hook after the viewer's)
    at two simulated times, before the bump and on it, until the browser shows the frame last sent, so the two
    pictures are of known times whatever the machine's load (screenshots 0.15 s and 0.45 s of wall time after
    the start failed under load: the run, which may first compile its loop, had not begun, or had ended)."""
    from suspension_sim.viewer import attach_live_viewer

    sc = parse_scenario({"name": "live", "vehicle": {"model": "quarter_car"},
                         "road": {"type": "bump", "params": {"height": 0.08, "length": 2.0, "start": 3.0},
                                  "speed": 10}, "sim": {"duration": 1.2, "log_dt": 0.002}})
    sim = Simulation([sc])
    view = attach_live_viewer(sim, rate=1.0, fps=30)
    stops = [(t, threading.Event(), threading.Event()) for t in (0.1, 0.5)]  # (time, reached, go on)

    def hold(logger, j, t):
        if stops and view._last_t >= stops[0][0]:
            _, reached, go = stops.pop(0)
            reached.set()
            go.wait(300)

    sim.log_hooks.append(hold)
    events = list(stops)
    out: dict = {}

    def run():
        try:
            out["result"] = sim.run()[0]
        except BaseException as e:  # pragma: no cover - reported below
            out["error"] = e

    th = threading.Thread(target=run)
    try:
        assert view.server.clients() == 0
        driver.get(view.server.web_url)
        assert view.server.wait_for_browser(60), "the browser did not connect to the live viewer"
        t0 = time.monotonic()
        while time.monotonic() - t0 < 60:  # the scene arrives over the websocket
            if body_mask(central(png_array(driver.get_screenshot_as_png()), 0.6)).sum() > 400:
                break
            time.sleep(0.2)
        th.start()
        pics, shown = [], []
        for k, (_, reached, go) in enumerate(events):
            assert reached.wait(600), f"the run did not reach t = {events[k][0]} s: {out.get('error')!r}"
            shown.append(view._last_t)  # simulated time of the last frame sent
            png = settled_screenshot(driver)
            (shots / f"live_{k}.png").write_bytes(png)
            img = png_array(png)
            assert_not_blank(img, "live")
            assert_car_in_view(img, "live")
            pics.append(central(img, 0.8))
            go.set()
        th.join(300)
        assert not th.is_alive() and "error" not in out, out.get("error")
        assert view.sent_frames >= 30 and shown[1] > shown[0]
        ts = out["result"].ts
        z = np.interp(shown, ts["t"].to_numpy(), ts["body_z"].to_numpy())
        assert z[1] - z[0] > 0.02, z  # the body moved between the two frames shown...
        assert (np.abs(pics[0] - pics[1]).sum(axis=2) > 30).mean() > 0.002  # ...and the picture with it
    finally:
        for _, _, go in events:
            go.set()
        th.join(60) if th.is_alive() else None
        view.server.close()
