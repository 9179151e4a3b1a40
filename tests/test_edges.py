"""Safe at the edges: reproducible outputs, no silent overwrites, divergence that costs nothing finished,
processes that die with their parent, loopback-only servers, batches that survive SIGKILL, the Python-loop
logger on durations that are not a multiple of log_dt, and plausibility checks before diagnose fits."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from suspension_sim.cli import app

REPO = Path(__file__).resolve().parents[1]

SC = {
    "name": "edges",
    "vehicle": {"model": "quarter_car"},
    "road": {"type": "sine", "params": {"frequency": 2.0}},
    # a noisy sensor (as quickstart's and the sweep example's): the skyhook and passive runs here then share
    # the compiled loops those compile (one per controller and sensor structure, 7-14 s each on an empty cache)
    "sensors": [{"type": "corner_body_vel", "noise_std": 0.002}],
    "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
    "sim": {"duration": 0.2},
    "outputs": {"plots": False},
    "variants": {"passive": {"controller": {"type": "passive"}}, "sky": {}},
}
# a variant that diverges within a few steps (huge gain, coarse step)
DIVERGING = {"controller": {"params": {"c_sky": 1e8}}, "sim": {"dt": 0.01, "control_dt": 0.01, "log_dt": 0.01,
                                                                 "duration": 1.0}}


def _write(tmp_path, d, name="scenario.yaml") -> Path:
    p = tmp_path / name
    p.write_text(yaml.safe_dump(d, sort_keys=False))
    return p


def _cli(args, env=None):
    return CliRunner().invoke(app, [str(a) for a in args], env=env)


def _err(res):
    return (res.stderr or "").strip()


# ---------------------------------------------------------------------------------------------- the logger
def test_python_loop_logs_a_duration_that_is_not_a_multiple_of_log_dt(monkeypatch):
    """n_steps = 2003, log every 2 steps: steps 0..2002 are logged, 1002 instants (n_steps // log_every = 1001
    made the Python loop index past the end); the compiled loop logs the same instants, bit for bit."""
    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    d = {k: v for k, v in SC.items() if k != "variants"}
    d["sim"] = {"duration": 1.0015, "dt": 0.0005, "log_dt": 0.001}
    sc = parse_scenario(d)
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    sim = Simulation([sc])
    py = sim.run()[0]
    assert sim.loop == "python"
    assert len(py.ts) == 1002 and py.ts["t"].iloc[-1] == pytest.approx(1.001)
    assert np.all(np.isfinite(py.ts["body_acc"]))
    monkeypatch.delenv("SUSPENSION_SIM_COMPILED")
    sim2 = Simulation([sc])
    comp = sim2.run()[0]
    assert sim2.loop != "python"
    pd.testing.assert_frame_equal(py.ts, comp.ts, check_exact=True)


# --------------------------------------------------------------------------------------- reproducible runs
def test_same_seed_gives_byte_identical_outputs_and_timings_go_elsewhere(tmp_path):
    d = {**SC, "road": {"type": "iso8608", "params": {"road_class": "C"}, "speed": 20},
         "sensors": [{"type": "corner_body_vel", "noise_std": 0.01}]}
    p = _write(tmp_path, d)
    for o in ("a", "b"):
        res = _cli(["run", p, "-q", "--out", tmp_path / o])
        assert res.exit_code == 0, res.output
    for v in ("passive", "sky"):
        for f in ("summary.json", "timeseries.parquet"):
            assert (tmp_path / "a" / v / f).read_bytes() == (tmp_path / "b" / v / f).read_bytes(), (v, f)
        body = [(tmp_path / o / v / "scenario.resolved.yaml").read_text().split("\n", 1)[1] for o in "ab"]
        assert body[0] == body[1]  # (its first line names the folder it is in)
        s = json.loads((tmp_path / "a" / v / "summary.json").read_text())
        assert "wall_time_s" not in json.dumps(s)
        assert json.loads((tmp_path / "a" / v / "timing.json").read_text())["wall_time_s"] > 0
    assert (tmp_path / "a" / "summary.json").read_bytes() == (tmp_path / "b" / "summary.json").read_bytes()
    # a different seed changes the result (the comparison above can fail)
    res = _cli(["run", p, "-q", "--out", tmp_path / "c", "--set", "sim.seed=7"])
    assert res.exit_code == 0
    assert (tmp_path / "a" / "sky" / "summary.json").read_bytes() != (tmp_path / "c" / "sky" / "summary.json").read_bytes()


# ------------------------------------------------------------------------------------------ output folders
def test_existing_out_folder_is_refused_unless_overwrite(tmp_path):
    p = _write(tmp_path, SC)
    out = tmp_path / "out"
    assert _cli(["run", p, "-q", "--out", out]).exit_code == 0
    (out / "mine.txt").write_text("keep me")
    before = (out / "sky" / "summary.json").read_bytes()
    res = _cli(["run", p, "-q", "--out", out])
    assert res.exit_code == 2 and "--overwrite" in _err(res) and str(out) in _err(res)
    assert (out / "sky" / "summary.json").read_bytes() == before
    # --overwrite with a scenario whose variants differ: no stale variant folder is left; other files stay
    d = {**SC, "variants": {"soft": {"controller": {"params": {"c_sky": 500.0}}}}}
    p2 = _write(tmp_path, d, "other.yaml")
    res = _cli(["run", p2, "-q", "--out", out, "--overwrite"])
    assert res.exit_code == 0, res.output
    assert sorted(x.name for x in out.iterdir() if x.is_dir()) == ["soft"]
    assert (out / "mine.txt").read_text() == "keep me"


@pytest.mark.parametrize("cmd", ["diagnose", "compare", "batch"])
def test_other_commands_refuse_an_existing_out_folder(tmp_path, cmd):
    out = tmp_path / "out"
    out.mkdir()
    (out / "x.txt").write_text("x")
    run = tmp_path / "run"
    p = _write(tmp_path, {k: v for k, v in SC.items() if k != "variants"})
    if cmd == "compare":
        assert _cli(["run", p, "-q", "--out", run]).exit_code == 0
        args = ["compare", run, "--out", out, "--no-viewer"]
    elif cmd == "batch":
        sw = tmp_path / "sweep.yaml"
        sw.write_text(yaml.safe_dump({"base": "scenario.yaml", "grid": {"sim.seed": [1, 2]}}))
        args = ["batch", sw, "--out", out, "-q", "--workers", "1"]
    else:
        csv = tmp_path / "d.csv"
        t = np.arange(2000) / 500
        pd.DataFrame({"time": t, "road": 0.01 * np.sin(3 * t), "body_acc": 0.1 * np.sin(3 * t)}).to_csv(csv, index=False)
        m = tmp_path / "m.yaml"
        m.write_text("model: quarter_car\n")
        args = ["diagnose", csv, "--model", m, "--out", out, "--no-confirm"]
    res = _cli(args)
    assert res.exit_code == 2 and "already exists" in _err(res) and "--overwrite" in _err(res), res.output
    assert sorted(x.name for x in out.iterdir()) == ["x.txt"]


def test_batch_resumes_into_its_own_folder(tmp_path):
    p = _write(tmp_path, {k: v for k, v in SC.items() if k != "variants"})
    sw = tmp_path / "sweep.yaml"
    sw.write_text(yaml.safe_dump({"base": p.name, "grid": {"sim.seed": [1, 2]}}))
    out = tmp_path / "b"
    assert _cli(["batch", sw, "--out", out, "-q", "--workers", "1"]).exit_code == 0
    res = _cli(["batch", sw, "--out", out, "-q", "--workers", "1"])
    assert res.exit_code == 0 and "0 computed, 2 already done" in res.stdout


# ------------------------------------------------------------------------------------------------ divergence
def test_a_diverged_variant_costs_nothing_finished(tmp_path):
    d = {**SC, "variants": {"passive": {"controller": {"type": "passive"}}, "wild": DIVERGING, "sky": {}}}
    p = _write(tmp_path, d)
    out = tmp_path / "out"
    res = _cli(["run", p, "-q", "--out", out])
    err = _err(res)
    assert res.exit_code == 3 and len(err.splitlines()) == 1 and "Traceback" not in res.output
    assert err.startswith(f"error: {p}: edges/wild: simulation diverged at t="), err
    assert "body_z=" in err and "Hint:" in err
    for v in ("passive", "sky"):  # before and after the diverging one
        assert (out / v / "summary.json").exists() and (out / v / "timeseries.parquet").exists()
    assert not (out / "wild").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["wild"]["status"] == "diverged" and "metrics" in summary["sky"]


def test_nan_divergence_names_the_non_finite_state():
    """When MuJoCo meets a NaN it resets the state: the message then lists the non-finite forces instead of an
    empty state."""
    from suspension_sim.divergence import nonfinite_state
    from suspension_sim.errors import SimulationDiverged

    class P:
        suffixes = [""]

    class Sim:
        plant = P()
        last_forces = (np.array([[np.nan]]), np.array([[0.0]]), np.array([[np.inf]]))

    st = nonfinite_state(Sim(), "ctrl")
    assert np.isnan(st["actuator_force"]) and st["tire_effect_force"] == np.inf and st["mujoco_bad_value_in"] == "ctrl"
    e = SimulationDiverged(0.5, st, "NaN: ...").locate("x.yaml", "car/v")
    assert str(e).startswith("x.yaml: car/v: simulation diverged at t=0.5000 s: actuator_force=nan")
    assert "no state recorded" in str(SimulationDiverged(0.1, {}, "h"))
    import pickle

    assert str(pickle.loads(pickle.dumps(e))) == str(e)


# --------------------------------------------------------------------------------------------- validate
def test_validate_builds_every_variant_without_stepping(tmp_path, monkeypatch):
    from suspension_sim import simulation

    calls = []
    monkeypatch.setattr(simulation.Simulation, "run", lambda self, *a, **k: calls.append(1))
    d = {**SC, "variants": {"ok": {}, "bad": {"sim": {"integrator": "trapezoidal", "dt": 0.01, "control_dt": 0.01,
                                                      "log_dt": 0.01},
                                              "vehicle": {"params": {"damping": 1e6}}}}}
    p = _write(tmp_path, d)
    res = _cli(["validate", p])
    assert res.exit_code == 2 and f"{p}: variants.bad:sim.integrator: " in _err(res), _err(res)
    assert "damping*dt/mass" in _err(res) and not calls


def test_fail_prints_brackets(capsys):
    import typer

    from suspension_sim import cli

    with pytest.raises(typer.Exit):
        cli.fail("the Dask engine needs dask[distributed]: pip install 'suspension-sim[batch]'")
    err = capsys.readouterr().err
    assert "'suspension-sim[batch]'" in err and "dask[distributed]" in err


# ------------------------------------------------------------------------------------------ servers, orphans
def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


def _wait_dead(pids, timeout=10.0) -> list:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        alive = [p for p in pids if _alive(p)]
        if not alive:
            return []
        time.sleep(0.1)
    return [p for p in pids if _alive(p)]


POOL_SCRIPT = textwrap.dedent("""
    import os, sys, time
    from suspension_sim.batch import LocalEngine

    def task(i):
        print("child", os.getpid(), flush=True)
        time.sleep(600)
        return []

    if sys.argv[1] == "baseline":  # a plain pool, as the batch engine had it
        from concurrent.futures import ProcessPoolExecutor
        import multiprocessing as mp
        ex = ProcessPoolExecutor(2, mp_context=mp.get_context("fork"))
        [ex.submit(task, i) for i in range(2)]
        time.sleep(600)
    else:
        from suspension_sim.lifecycle import install_signal_handlers
        install_signal_handlers()
        LocalEngine(2).map(task, [0, 1], lambda i, r: None, lambda i, e: None)
""")


def _damping_sweep(tmp_path, n: int, duration: float) -> Path:
    """``sweep.yaml`` in tmp_path: n runs of the sweep scenario (``duration`` s each) over the damping."""
    _write(tmp_path, {**SWEEP_SCENARIO, "sim": {"duration": duration}}, "base.yaml")
    sw = tmp_path / "sweep.yaml"
    sw.write_text(yaml.safe_dump({"base": "base.yaml", "grid": {"vehicle.params.damping": [800 + 50 * i for i in range(n)]},
                                  "ensemble_size": 1}))
    return sw


def _sigint_default():
    """The child starts with SIGINT at its default (Python's KeyboardInterrupt): a test run launched in the
    background (``cmd &`` in a script, nohup) ignores SIGINT, and the child would inherit that."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start_pool(tmp_path, mode):
    s = tmp_path / "pool.py"
    s.write_text(POOL_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(s), mode], stdout=subprocess.PIPE, text=True, cwd=REPO,
                            start_new_session=True, preexec_fn=_sigint_default)
    line = proc.stdout.readline()  # a worker runs a task (so the pool is up)
    assert line.startswith("child"), line
    t0 = time.monotonic()
    kids = _children(proc.pid)
    while len(kids) < 2 and time.monotonic() - t0 < 60:
        time.sleep(0.2)
        kids = _children(proc.pid)
    assert len(kids) >= 2, kids
    return proc, kids


def _children(pid: int) -> list:
    out = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as fh:
                    if int(fh.read().rsplit(")", 1)[1].split()[1]) == pid:
                        out.append(int(d))
            except (OSError, ValueError, IndexError):
                pass
    return out


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM, signal.SIGINT])
def test_batch_workers_die_with_their_parent(tmp_path, sig):
    proc, kids = _start_pool(tmp_path, "engine")
    os.kill(proc.pid, sig)
    proc.wait(30)
    assert _wait_dead(kids) == [], f"workers left behind after {sig!r}"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
def test_baseline_pool_workers_outlive_a_killed_parent(tmp_path):
    """Without die_with_parent the workers of a SIGKILLed parent sleep on (what the test above guards)."""
    proc, kids = _start_pool(tmp_path, "baseline")
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    time.sleep(1.0)
    left = [p for p in kids if _alive(p)]
    for p in left:
        os.kill(p, signal.SIGKILL)
    assert left, "the baseline pool's workers died too: the test above would prove nothing"


INTERRUPT_SCRIPT = textwrap.dedent("""
    # SIGINT delivered at the worst moment: just after the main thread took a future's condition lock inside
    # concurrent.futures.wait() (signal.raise_signal: Python raises KeyboardInterrupt at the next bytecode)
    import os, signal, sys, time
    from concurrent.futures import _base
    from suspension_sim import lifecycle
    from suspension_sim.batch import LocalEngine

    def task(i):
        print("child", os.getpid(), flush=True)
        time.sleep(600)
        return []

    def enter(self):
        for future in self.futures:
            future._condition.acquire()
            if getattr(sys, "_armed", False):
                sys._armed = False
                signal.raise_signal(signal.SIGINT)

    _base._AcquireFutures.__enter__ = enter
    if sys.argv[1] == "baseline":  # the engine without deferred signals (as it was): KeyboardInterrupt lands there
        lifecycle.DeferredSignals.__enter__ = lambda self: self
    lifecycle.install_signal_handlers()
    signal.signal(signal.SIGUSR1, lambda *a: setattr(sys, "_armed", True))
    print("parent", flush=True)
    LocalEngine(2).map(task, [0, 1], lambda i, r: None, lambda i, e: None)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("mode", ["engine", "baseline"])
def test_ctrl_c_inside_a_pool_lock_still_ends_the_batch(tmp_path, mode):
    """The flaky hang of test_batch_workers_die_with_their_parent[SIGINT] made deterministic: a KeyboardInterrupt
    raised while the main thread holds a future's condition lock leaves it held; the pool's manager thread
    blocks on it when it cancels the future, and interpreter exit joins that thread forever.  The engine defers
    the signal to a point outside the pool's locks (lifecycle.DeferredSignals) and exits; without that (the
    baseline) the parent hangs, its workers already dead."""
    s = tmp_path / "intr.py"
    s.write_text(INTERRUPT_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(s), mode], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                            text=True, cwd=REPO, start_new_session=True, preexec_fn=_sigint_default)
    try:
        assert proc.stdout.readline().startswith("parent")
        assert proc.stdout.readline().startswith("child")
        kids = _children(proc.pid)
        os.kill(proc.pid, signal.SIGUSR1)  # armed: the next lock taken in wait() (every 0.2 s at most) raises SIGINT
        if mode == "engine":
            assert proc.wait(30) == -signal.SIGINT  # KeyboardInterrupt uncaught: Python ends by SIGINT
            assert _wait_dead(kids) == []
        else:
            with pytest.raises(subprocess.TimeoutExpired):
                proc.wait(4)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


def test_batch_ctrl_c_prints_one_line_and_keeps_a_readable_summary(tmp_path):
    """Ctrl-C in the middle of a batch on two workers: exit 130 with one line (no traceback), no worker left,
    and summary.parquet holds the runs finished so far (those a resumed batch skips)."""
    n = 24
    sw = _damping_sweep(tmp_path, n, 100.0)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "suspension_sim.cli", "batch", str(sw), "--out", str(out), "-q",
                             "--workers", "2"], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=_sigint_default)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 180:
        if (out / "parts").exists() and len(list((out / "parts").glob("part-*.parquet"))) >= 2:
            break
        time.sleep(0.05)
    kids = _children(proc.pid)
    os.kill(proc.pid, signal.SIGINT)
    try:
        err = proc.communicate(timeout=30)[1]
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: interrupted: ") and "summary.parquet" in lines[0], err
    assert _wait_dead(kids) == []
    df = pd.read_parquet(out / "summary.parquet")  # what a resumed batch skips (test above)
    assert 2 <= len(df) < n and (df["status"] == "ok").all()
    assert not list((out / "parts").glob("part-*.parquet"))  # consolidated into the summary


VIEWER_SCRIPT = textwrap.dedent("""
    import time
    from suspension_sim.lifecycle import install_signal_handlers
    from suspension_sim.viewer import LiveServer
    install_signal_handlers()
    s = LiveServer()
    print("server", s.proc.pid, s.web_url, flush=True)
    time.sleep(120)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL, signal.SIGINT])
def test_viewer_server_dies_with_its_parent(tmp_path, sig):
    pytest.importorskip("meshcat")
    s = tmp_path / "v.py"
    s.write_text(VIEWER_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(s)], stdout=subprocess.PIPE, text=True, cwd=REPO,
                            start_new_session=True, preexec_fn=_sigint_default)
    line = ""
    t0 = time.monotonic()
    while not line.startswith("server") and time.monotonic() - t0 < 180:
        line = proc.stdout.readline()
    _, pid, url = line.split()
    assert "127.0.0.1" in url
    os.kill(proc.pid, sig)
    proc.wait(30)
    assert _wait_dead([int(pid)]) == []


def test_dask_local_cluster_listens_on_loopback_only():
    pytest.importorskip("distributed")
    from suspension_sim.batch import DaskEngine

    eng = DaskEngine(n_local=1)
    try:
        assert "127.0.0.1" in eng.cluster.scheduler_address
        assert eng.cluster.dashboard_link.startswith("http://127.0.0.1:")
        workers = eng.client.scheduler_info()["workers"]
        assert workers and all("127.0.0.1" in w for w in workers)
    finally:
        eng.close()


# ------------------------------------------------------------------------------------------------- batches
SWEEP_SCENARIO = {"name": "k", "vehicle": {"model": "quarter_car"}, "road": {"type": "sine", "params": {"frequency": 2.0}},
                  "controller": {"type": "passive"}, "sim": {"duration": 20.0}}


def test_batch_killed_halfway_resumes_without_losing_or_redoing_runs(tmp_path):
    """SIGKILL in the middle of a sweep: every finished run is on disk, summary.parquet (if any) reads, and the
    resumed batch computes only the missing runs; the final summary equals an uninterrupted batch's."""
    from suspension_sim.batch import Store, run_batch

    # 5 s runs (not 20): resuming does not depend on the length of a run, and 37 runs still to do after the
    # third part leave the kill seconds of margin
    n = 40
    sw = _damping_sweep(tmp_path, n, 5.0)
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "suspension_sim.cli", "batch", str(sw), "--out", str(out), "-q",
                             "--workers", "1"], cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    t0 = time.monotonic()
    while time.monotonic() - t0 < 120:
        parts = list((out / "parts").glob("part-*.parquet")) if (out / "parts").exists() else []
        if len(parts) >= 3:
            break
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    prev = Store(out).previous()
    assert prev is not None
    done = set(prev.loc[prev["status"] == "ok", "hash"])
    assert 3 <= len(done) < n, len(done)
    if (out / "summary.parquet").exists():
        pd.read_parquet(out / "summary.parquet")
    rep = run_batch(sw, out=out, workers=1)
    assert rep.n_run == n - len(done) and rep.n_skipped == len(done)
    assert len(rep.summary) == n and (rep.summary["status"] == "ok").all()
    ref = run_batch(sw, out=tmp_path / "ref", workers=1)
    cols = [c for c in ref.summary.columns if c != "wall_time_s"]
    pd.testing.assert_frame_equal(rep.summary[cols], ref.summary[cols])


# ---------------------------------------------------------------------------------------------- diagnose
@pytest.fixture(scope="module")
def record(tmp_path_factory):
    from suspension_sim.diagnose import truth

    d = truth.simulate_truth("quarter_car", 4, 500, {}, seed=3, road_rms=0.01, noise=0.01,
                             outputs=["body_acc", "susp_travel"])
    return pd.DataFrame({k: d[k] for k in ("time", "road", "body_acc", "susp_travel")})


def _findings(df):
    from suspension_sim.diagnose.io import record_from_arrays
    from suspension_sim.diagnose.model import load_model
    from suspension_sim.diagnose.plausibility import findings

    rec = record_from_arrays("quarter_car", df["time"], {"road": df["road"]},
                             {"body_acc": df["body_acc"], "susp_travel": df["susp_travel"]})
    return findings(rec, load_model({"model": "quarter_car"}))


def test_plausibility_passes_a_good_record_and_names_what_it_suspects(record):
    assert _findings(record) == []
    f = _findings(record.assign(body_acc=record.body_acc / 9.81))
    assert f[0][0] == "body_acc" and "body_acc looks like g, not m/s²" in f[0][1]
    f = _findings(record.assign(road=record.road * 1000))
    assert f[0][0] == "road" and "mm" in f[0][1]
    f = _findings(record.assign(susp_travel=record.susp_travel * 1000))
    assert f[0][0] == "susp_travel" and "looks like mm, not m" in f[0][1]
    f = _findings(record.assign(time=record.time * 1000))
    assert f[0][0] == "time" and "ms" in f[0][1]
    f = _findings(record.assign(body_acc=record.body_acc + 9.81))
    assert f[0][0] == "body_acc" and "gravity" in f[0][1]
    f = _findings(record.assign(body_acc=record.body_acc * 1e30))
    assert f[0][0] == "body_acc"


def test_plausibility_override_flag_fits_anyway(record, tmp_path):
    csv = tmp_path / "g.csv"
    record.assign(body_acc=record.body_acc / 9.81).to_csv(csv, index=False)
    m = tmp_path / "m.yaml"
    m.write_text("model: quarter_car\n")
    res = _cli(["diagnose", csv, "--model", m, "--out", tmp_path / "o", "--no-confirm"])
    assert res.exit_code == 2 and "--no-plausibility" in _err(res) and "looks like g" in _err(res)
    res = _cli(["diagnose", csv, "--model", m, "--out", tmp_path / "o2", "--no-confirm", "--no-plausibility",
                "--candidates", "coulomb_friction", "--max-effects", "1"])
    assert res.exit_code == 0, res.output
    assert "warning: plausibility: body_acc" in res.stdout


def test_strict_values_refuse_lax_conversions_but_take_numpy_scalars():
    from suspension_sim.config import parse_scenario
    from suspension_sim.errors import ScenarioError

    d = {k: v for k, v in SC.items() if k != "variants"}
    sc = parse_scenario({**d, "controller": {**d["controller"], "full_state": np.True_},
                         "vehicle": {"model": "quarter_car", "params": {"sprung_mass": np.float64(300.0)}}})
    assert sc.controller.full_state is True
    for path, bad, text in ((("controller", "full_state"), 1, "true or false"),
                            (("vehicle", "params"), {"sprung_mass": True}, "boolean"),
                            (("sim",), {"duration": "2"}, "string")):
        raw = {**d, path[0]: {**d.get(path[0], {}), **({path[1]: bad} if len(path) > 1 else bad)}}
        with pytest.raises(ScenarioError, match=text):
            from suspension_sim.config import check_components

            check_components(parse_scenario(raw))


DASK_SCRIPT = textwrap.dedent("""
    import os, time
    from suspension_sim.batch import DaskEngine
    if __name__ == "__main__":
        e = DaskEngine(n_local=1)
        pids = list(e.client.run(os.getpid).values()) + list(e.client.run(os.getpid, nanny=True).values())
        print("pids", *pids, flush=True)
        time.sleep(600)
""")


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="PR_SET_PDEATHSIG is Linux")
def test_dask_local_workers_and_nannies_die_with_a_killed_parent(tmp_path):
    pytest.importorskip("distributed")
    s = tmp_path / "d.py"
    s.write_text(DASK_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(s)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                            cwd=REPO, start_new_session=True, preexec_fn=_sigint_default)
    line = proc.stdout.readline()
    pids = [int(x) for x in line.split()[1:]]
    assert len(pids) == 2 and all(_alive(p) for p in pids), line
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait(30)
    assert _wait_dead(pids, 20) == []
