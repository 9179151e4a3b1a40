"""`suspension-sim run` end to end on the quick-start scenario: the run folder's files, skyhook against
passive on the quick-start road, and a rerun of scenario.resolved.yaml reproducing the metrics."""
import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from suspension_sim.cli import app

runner = CliRunner()


@pytest.fixture(scope="module")
def quickstart(tmp_path_factory, ):
    from pathlib import Path

    repo = Path(__file__).resolve().parents[1]
    out = tmp_path_factory.mktemp("qs")
    res = runner.invoke(app, ["run", str(repo / "scenarios" / "quickstart.yaml"), "--out", str(out), "-q"])
    assert res.exit_code == 0, res.output
    return out


def test_run_folder(quickstart):
    for v in ("passive", "skyhook"):
        d = quickstart / v
        ts = pd.read_parquet(d / "timeseries.parquet")
        assert {"t", "body_acc", "travel", "tire_force", "actuator_force"} <= set(ts.columns)
        assert len(ts) == 20000  # 20 s at log_dt = 1 ms
        summary = json.loads((d / "summary.json").read_text())
        assert summary["metrics"]["body_acc_rms"] > 0
        assert (d / "scenario.resolved.yaml").exists()
        for png in ("body_acceleration", "suspension_travel", "tire_load", "actuator_force", "body_acc_psd"):
            assert (d / "plots" / f"{png}.png").stat().st_size > 10_000
    assert (quickstart / "plots" / "body_acc_psd.png").exists()  # the overlay


def test_skyhook_beats_passive_on_quickstart_road(quickstart):
    m = {v: json.loads((quickstart / v / "summary.json").read_text())["metrics"] for v in ("passive", "skyhook")}
    print({v: round(m[v]["body_acc_rms"], 4) for v in m})
    assert m["skyhook"]["body_acc_rms"] < 0.9 * m["passive"]["body_acc_rms"]
    assert m["skyhook"]["body_acc_wk_rms"] < m["passive"]["body_acc_wk_rms"]
    assert m["passive"]["actuator_force_rms"] == 0 and m["skyhook"]["actuator_force_rms"] > 0


def test_resolved_scenario_reruns_identically(quickstart, tmp_path):
    res = runner.invoke(app, ["run", str(quickstart / "skyhook" / "scenario.resolved.yaml"), "--out",
                              str(tmp_path), "-q"])
    assert res.exit_code == 0, res.output
    a = json.loads((quickstart / "skyhook" / "summary.json").read_text())["metrics"]
    b = json.loads((tmp_path / "summary.json").read_text())["metrics"]
    assert a == b


def test_validate_and_list(repo):
    res = runner.invoke(app, ["validate", str(repo / "scenarios" / "quickstart.yaml")])
    assert res.exit_code == 0 and "ok" in res.output
    res = runner.invoke(app, ["list"])
    assert res.exit_code == 0
    for word in ("quarter_car", "half_car", "sdof", "bump_stop", "iso8608", "accel_brake", "skyhook", "ideal", "travel"):
        assert word in res.output
