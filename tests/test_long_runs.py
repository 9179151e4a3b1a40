"""Long runs: a run whose time series would not fit on the disk stops before its first step."""
from __future__ import annotations

import shutil
from collections import namedtuple

import yaml
from typer.testing import CliRunner

from suspension_sim.cli import app

SC = {"name": "long", "vehicle": {"model": "quarter_car"}, "road": {"type": "sine", "params": {"frequency": 2.0}},
      "sim": {"duration": 100.0}, "outputs": {"plots": False}}


def _run(tmp_path, sc, out):
    p = tmp_path / "scenario.yaml"
    p.write_text(yaml.safe_dump(sc))
    return CliRunner().invoke(app, ["run", str(p), "--out", str(out), "--quiet"])


def test_a_log_that_would_not_fit_on_the_disk_stops_before_the_run(tmp_path, monkeypatch):
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda p: usage(10**9, 10**9 - 10**6, 10**6))  # 1 MB free
    out = tmp_path / "run"
    res = _run(tmp_path, SC, out)  # 100 s at 1 kHz: ~5 MB of log
    err = (res.stderr or "").strip()
    assert res.exit_code == 2, res.output
    assert len(err.splitlines()) == 1 and "sim.duration" in err and "would not fit on the disk" in err, err
    assert not out.exists()  # nothing started, nothing written
    # the same 1 MB is enough for a 0.2 s run (~50 kB of log): it runs and writes its time series
    res = _run(tmp_path, dict(SC, sim={"duration": 0.2}), out)
    assert res.exit_code == 0, res.output
    assert (out / "summary.json").exists() and (out / "timeseries.parquet").exists()


# ----------------------------------------------------------------------------------------------------------
# streamed logs (flat memory): a log longer than the buffer goes to Parquet row groups and streaming metrics
# ----------------------------------------------------------------------------------------------------------
import math  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402
import pytest  # noqa: E402

from suspension_sim.config import parse_scenario  # noqa: E402
from suspension_sim.metrics.base import EnsembleView  # noqa: E402
from suspension_sim.registry import METRICS  # noqa: E402
from suspension_sim.simulation import Simulation  # noqa: E402

QUARTER = {"name": "q", "vehicle": {"model": "quarter_car", "effects": [
    {"type": "bump_stop", "corners": "all", "params": {"gap": 0.01, "stiffness": 40000.0}}]},
    "road": {"type": "iso8608", "params": {"road_class": "D"}, "speed": 20.0, "seed": 4},
    "sensors": [{"name": "corner_body_vel", "type": "corner_body_vel", "noise_std": 0.002}],
    "actuator": {"type": "ideal", "params": {"max_force": 3000.0, "time_constant": 0.005}},
    "controller": {"type": "skyhook", "params": {"c_sky": 2500.0}},
    "sim": {"duration": 4.0, "seed": 2}, "outputs": {"plots": False}}


def _chunked(monkeypatch, chunk_s="0.7"):
    """Force streaming on short runs: a tiny buffer budget and ~0.7 s chunks (not a multiple of 2000 steps)."""
    monkeypatch.setenv("SUSPENSION_SIM_LOG_BUFFER_MB", "0.02")
    monkeypatch.setenv("SUSPENSION_SIM_LOG_CHUNK_S", chunk_s)


def _whole(monkeypatch):
    monkeypatch.delenv("SUSPENSION_SIM_LOG_BUFFER_MB", raising=False)
    monkeypatch.delenv("SUSPENSION_SIM_LOG_CHUNK_S", raising=False)


def _close(a: dict, b: dict, rel=1e-12):
    assert list(a) == list(b)
    bad = {k: (a[k], b[k]) for k in a
           if not (math.isnan(a[k]) and math.isnan(b[k])) and abs(a[k] - b[k]) > rel * max(abs(b[k]), 1e-300)}
    assert not bad


@pytest.mark.parametrize("loop", ["compiled", "python", "hybrid"])
def test_a_streamed_run_equals_the_run_held_whole(monkeypatch, loop):
    raw = dict(QUARTER)
    if loop == "hybrid":
        raw = dict(raw, controller={"type": "skyhook", "params": {"c_sky": 2500.0}, "full_state": True})
    if loop == "python":
        monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    sc = parse_scenario(raw)
    _whole(monkeypatch)
    whole_sim = Simulation([sc])
    whole = whole_sim.run()[0]
    assert "streamed_log" not in whole.info
    _chunked(monkeypatch)
    sim = Simulation([sc])
    res = sim.run()[0]
    assert sim.loop == whole_sim.loop == {"compiled": "full", "python": "python", "hybrid": "hybrid"}[loop]
    note = res.info["streamed_log"]
    assert note["chunk_rows"] < 1000 and res.timeseries_file is not None  # really chunked, into a file
    assert "metrics_from_preview" not in note  # every built-in metric streams
    # the time series read back from the file: the same frame (columns, dtypes, values) as the one held whole
    pd.testing.assert_frame_equal(res.ts, whole.ts, check_exact=True)
    assert pq.ParquetFile(res.timeseries_file).metadata.num_row_groups == math.ceil(len(whole.ts) / note["chunk_rows"])
    _close(res.metrics, whole.metrics)
    assert res.metrics["travel_stop_fraction"] > 0.01  # the stop is hit, so the fraction is tested


def test_streamed_metrics_of_an_ensemble_without_files(monkeypatch):
    """A batch without time series (log_channels="metrics"): two half cars (multi-corner totals, stop
    fractions) streamed with no file, against the same ensemble held whole."""
    raw = dict(QUARTER, vehicle={"model": "half_car", "effects": QUARTER["vehicle"]["effects"]},
               sensors=[{"name": "corner_body_vel", "type": "corner_body_vel"}])
    scs = [parse_scenario(dict(raw, name=f"h{i}", road=dict(raw["road"], seed=5 + i))) for i in range(2)]
    _whole(monkeypatch)
    whole = Simulation(scs, log_channels="metrics").run()
    _chunked(monkeypatch, "0.31")
    res = Simulation(scs, log_channels="metrics").run()
    for r, w in zip(res, whole):
        assert r.timeseries_file is None and r.info["streamed_log"]["chunk_rows"] < 400
        _close(r.metrics, w.metrics)
        assert "actuator_energy_total" in r.metrics


def test_a_streamed_run_logging_a_set_of_channels_keeps_their_whole_log(monkeypatch):
    """log_channels={...}: the time series of those channels, whole, also when the log is streamed (it went to
    no file and ``timeseries`` silently returned the preview, every q-th instant).  A metrics-only streamed run
    keeps no time series: its ``timeseries`` is the preview, with a warning."""
    sc = parse_scenario(QUARTER)
    _whole(monkeypatch)
    whole = Simulation([sc], log_channels={"body_acc", "travel"}).run()[0]
    _chunked(monkeypatch)
    monkeypatch.setattr("suspension_sim.stream.PREVIEW_MB", 0.001)  # a preview of 1000 of the 4000 rows
    res = Simulation([sc], log_channels={"body_acc", "travel"}).run()[0]
    assert res.info["streamed_log"]["chunk_rows"] < 1000 and res.info["streamed_log"]["preview_every"] > 1
    assert res.timeseries_file is not None
    for c in ("t", "body_acc", "travel"):
        np.testing.assert_array_equal(res.ts[c].to_numpy(), whole.ts[c].to_numpy())
    only = Simulation([sc], log_channels="metrics").run()[0]
    assert only.timeseries_file is None
    with pytest.warns(UserWarning, match="preview"):
        prev = only.ts
    assert len(prev) < len(whole.ts)  # what the set of channels got before, silently


def test_every_streaming_metric_equals_its_one_shot_version_on_one_chunk_and_across_chunks():
    rng = np.random.default_rng(3)
    n, N, dt, sfx = 3, 5003, 0.001, ["_front", "_rear"]
    t = np.arange(N) * dt
    ch = {"body_acc": rng.normal(size=(n, N)), "pitch": 0.01 * rng.normal(size=(n, N)),
          "pitch_acc": rng.normal(size=(n, N))}
    for s in sfx:
        ch[f"travel{s}"] = 0.02 * rng.normal(size=(n, N))
        ch[f"travel_rate{s}"] = 0.2 * rng.normal(size=(n, N))
        ch[f"tire_force{s}"] = 2000.0 * rng.normal(size=(n, N))
        ch[f"actuator_force{s}"] = 300.0 * rng.normal(size=(n, N))
        ch[f"wheel_acc{s}"] = 10.0 * rng.normal(size=(n, N))
    meta = dict(suffixes=sfx, static_tire_force={s: np.array([2500.0, 3000.0, 0.0]) for s in sfx},
                stop_gaps=[{s: 0.02 for s in sfx}] * n,
                infos=[{"stop_gap_sides": {s: [0.015, 0.03] for s in sfx}}] * n)
    one = {}
    streamed = 0
    for name, fn in METRICS.items():
        if getattr(fn, "ensemble", None) is None:
            continue
        try:
            one = fn.ensemble(EnsembleView(channels=dict(ch), t=t, **meta))
        except KeyError:
            continue
        assert hasattr(fn, "stream"), name  # every built-in metric with an ensemble version streams
        streamed += 1
        for size in (N, 1000, 997, 7):
            s = fn.stream(EnsembleView(channels={}, t=t[:0], **meta))
            for a in range(0, N, size):
                s.update(EnsembleView(channels={k: np.ascontiguousarray(v[:, a:a + size]) for k, v in ch.items()},
                                      t=t[a:a + size], **meta))
            got = s.result()
            assert list(got) == list(one), name
            for k in one:
                ref, val = np.asarray(one[k], dtype=float), np.asarray(got[k], dtype=float)
                assert np.allclose(val, ref, rtol=1e-12, atol=0, equal_nan=True), (name, k, size, val - ref)
    assert streamed >= 9


def test_a_long_run_holds_one_chunk_not_the_whole_log():
    """1e5 s at 1 kHz logging (1e8 instants): the logger holds ~30 s, and the pre-run memory check passes."""
    from suspension_sim.preflight import check_log_memory

    sc = parse_scenario(dict(QUARTER, sim={"duration": 1e5}))
    sim = Simulation([sc])
    check_log_memory(sim)
    lg = sim.new_logger()
    assert lg.n_log == 10**8 and lg.streamed and lg.cap == 30_000
    assert lg.sink.q * 1000 >= lg.n_log / 1000  # the preview is bounded too
    del lg


def test_streamed_cli_run_is_byte_identical_when_rerun_and_reads_like_a_whole_one(tmp_path, monkeypatch):
    sc = dict(QUARTER, sim={"duration": 3.0, "seed": 2})
    _chunked(monkeypatch)
    for out in ("a", "b"):
        res = _run(tmp_path, sc, tmp_path / out)
        assert res.exit_code == 0, res.output
    for f in ("summary.json", "timeseries.parquet"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    assert not list(tmp_path.glob("a/.*tmp"))  # the spool file became timeseries.parquet
    _whole(monkeypatch)
    res = _run(tmp_path, sc, tmp_path / "w")
    assert res.exit_code == 0, res.output
    a, w = pd.read_parquet(tmp_path / "a" / "timeseries.parquet"), pd.read_parquet(tmp_path / "w" / "timeseries.parquet")
    pd.testing.assert_frame_equal(a, w, check_exact=True)
    sa = pq.read_schema(tmp_path / "a" / "timeseries.parquet")
    sw = pq.read_schema(tmp_path / "w" / "timeseries.parquet")
    assert sa.equals(sw, check_metadata=True)  # same columns, types and pandas metadata
    import json

    ma = json.loads((tmp_path / "a" / "summary.json").read_text())
    mw = json.loads((tmp_path / "w" / "summary.json").read_text())
    _close(ma["metrics"], mw["metrics"])


@pytest.mark.parametrize("by_path", [False, True])
def test_a_streamed_batch_keeps_its_time_series_and_metrics(tmp_path, monkeypatch, by_path):
    """A sweep whose runs stream (ensembles of 2 cars, chunks of 0.31 s) keeps each run's time series and
    metrics as the same sweep with the logs held whole; large files go to the batch folder by path."""
    import suspension_sim.batch as batch
    from suspension_sim.batch import run_batch

    if by_path:
        monkeypatch.setattr(batch, "KEEP_BY_PATH_BYTES", 0)

    base = dict(QUARTER, sim={"duration": 1.5, "seed": 2})
    sw = {"name": "s", "base": base, "lists": {"controller.params.c_sky": [1500.0, 2500.0, 3500.0]},
          "keep_timeseries": True, "ensemble_size": 2}
    path = tmp_path / "sweep.yaml"
    path.write_text(yaml.safe_dump(sw, sort_keys=False))
    _whole(monkeypatch)
    whole = run_batch(str(path), out=tmp_path / "w", workers=1).summary
    _chunked(monkeypatch, "0.31")
    streamed = run_batch(str(path), out=tmp_path / "s", workers=1).summary
    assert list(streamed["status"]) == ["ok"] * 3
    for (_, a), (_, b) in zip(streamed.iterrows(), whole.iterrows()):
        _close({k: a[k] for k in a.index if k.startswith("metric.")}, {k: b[k] for k in b.index if k.startswith("metric.")})
        fa, fb = (tmp_path / d / "timeseries" / f"{a['hash']}.parquet" for d in ("s", "w"))
        assert pq.ParquetFile(fa).metadata.num_row_groups > 1
        pd.testing.assert_frame_equal(pd.read_parquet(fa), pd.read_parquet(fb), check_exact=True)
    assert not list((tmp_path / "s" / "timeseries").glob(".*")) and list(streamed["error"]) == [""] * 3


def test_plots_of_a_long_run_come_from_its_bounded_preview(tmp_path, monkeypatch):
    """The preview keeps every q-th log instant (q = 3 here): time plots are drawn from it, spectra (which
    it would alias) are left out, and the metrics still come from every sample."""
    import suspension_sim.stream as stream
    from suspension_sim.plots import plot_run

    monkeypatch.setattr(stream, "PREVIEW_MB", 1e-6)  # the preview's floor: 1000 instants
    _chunked(monkeypatch)
    sc = parse_scenario(dict(QUARTER, sim={"duration": 3.0, "seed": 2}))
    res = Simulation([sc]).run()[0]
    assert res.info["streamed_log"]["preview_every"] == 3
    pv = res.preview_frame()
    assert len(pv) == 1000 and np.allclose(np.diff(pv["t"]), 0.003) and list(pv.columns) == list(res.ts.columns)
    names = {p.name for p in plot_run(res, tmp_path / "plots")}
    assert {"body_acceleration.png", "suspension_travel.png", "tire_load.png"} <= names
    assert "body_acc_psd.png" not in names
    _whole(monkeypatch)
    _close(res.metrics, Simulation([sc]).run()[0].metrics)


def test_a_long_run_drives_a_periodic_iso8608_road_of_bounded_size():
    """The road's memory does not grow with the duration either: past 20 km the ISO 8608 profile is one
    20 km period of the inverse FFT (periodic by construction), repeated without a seam; a shorter road is
    generated as before."""
    from suspension_sim.roads._common import GriddedProfile, PeriodicProfile
    from suspension_sim.roads.base import RoadContext
    from suspension_sim.roads.iso8608 import MAX_LENGTH, Iso8608, Iso8608Params, iso8608_psd

    p = Iso8608Params(road_class="C")
    ctx = dict(wheelbase=0.0, mean_speed=20.0, dt=5e-4)
    short = Iso8608(p, np.random.default_rng(1), RoadContext(duration=100.0, distance=2000.0, **ctx))
    assert type(short.profiles[0]) is GriddedProfile
    sizes = []
    for dur in (1e4, 1e5):
        road = Iso8608(p, np.random.default_rng(1), RoadContext(duration=dur, distance=20.0 * dur, **ctx))
        prof = road.profiles[0]
        assert isinstance(prof, PeriodicProfile) and MAX_LENGTH <= prof.period < 1.2 * MAX_LENGTH
        sizes.append(prof.z.size)
        x = np.linspace(10.0, 3 * prof.period, 1_500_001)
        z = road.height(0.0, x)
        assert np.allclose(road.height(0.0, x + prof.period), z, rtol=0, atol=1e-12)  # periodic
        assert np.abs(road.height(0.0, prof.x0 + prof.period + np.array([-1e-7, 1e-7])) - prof.z[0]).max() < 1e-6
        from scipy import signal

        f, P = signal.welch(z, fs=1 / (x[1] - x[0]), nperseg=2**14)
        band = (f > 0.05) & (f < 2.0)
        ratio = P[band] / iso8608_psd(f[band], p.gd, p.waviness)
        assert 0.8 < np.median(ratio) < 1.25  # still the class-C road
    assert sizes[0] == sizes[1]  # 1e4 s and 1e5 s: the same profile size
