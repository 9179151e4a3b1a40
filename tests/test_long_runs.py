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
