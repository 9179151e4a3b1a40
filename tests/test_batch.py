"""Batch runs (suspension_sim.batch): sweep expansion, identical results on every engine and worker count,
faults recorded per run without losing the others, resume, and a car's result alone equal to its result
inside an ensemble."""
from __future__ import annotations

import time

import numpy as np
import pandas as pd
import pytest
import yaml

from suspension_sim.controllers.base import Controller
from suspension_sim.batch import LocalEngine, combinations, load_sweep, plan, run_batch
from suspension_sim.components import Params
from suspension_sim.config import parse_scenario
from suspension_sim.errors import ScenarioError
from suspension_sim.registry import CONTROLLERS
from suspension_sim.simulation import Simulation

BASE = {
    "name": "qc",
    "vehicle": {"model": "quarter_car", "effects": [{"type": "quadratic_damping", "params": {"c_v": 300}}]},
    "road": {"type": "sine", "params": {"amplitude": 0.02, "frequency": 1.5}, "speed": 20},
    "sensors": [{"type": "corner_body_vel", "noise_std": 0.002}],
    "controller": {"type": "skyhook", "params": {"c_sky": 1500}},
    "sim": {"duration": 1.0},
}


def write_sweep(tmp_path, **kw) -> str:
    sw = {"name": "t", "base": BASE, **kw}
    p = tmp_path / "sweep.yaml"
    p.write_text(yaml.safe_dump(sw, sort_keys=False))
    return str(p)


def rows(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["wall_time_s"]).sort_values("run_id").reset_index(drop=True)


# -- expansion ------------------------------------------------------------------------------------------
def test_expansion_grid_lists_random_seeds(tmp_path):
    path = write_sweep(tmp_path, grid={"vehicle.params.damping": [800, 1200], "controller.params.c_sky": [0, 1000, 2000]},
                       lists={"vehicle.params.sprung_mass": [250, 300], "vehicle.params.unsprung_mass": [50, 60]},
                       random={"n": 3, "seed": 1, "method": "lhs",
                               "params": {"vehicle.params.spring_stiffness": {"dist": "uniform", "low": 14000, "high": 20000},
                                          "sim.seed": {"dist": "randint", "low": 0, "high": 1000}}},
                       seeds={"count": 2, "start": 5})
    sw, _ = load_sweep(path)
    combos = combinations(sw)
    assert len(combos) == 2 * 3 * 2 * 3 * 2
    ks = {c["vehicle.params.spring_stiffness"] for c in combos}
    assert len(ks) == 3 and all(14000 <= k <= 20000 for k in ks)
    # lists are zipped, not crossed
    assert {(c["vehicle.params.sprung_mass"], c["vehicle.params.unsprung_mass"]) for c in combos} == {(250, 50), (300, 60)}
    assert {c["road.seed"] for c in combos} == {5, 6}
    assert all(isinstance(c["sim.seed"], int) for c in combos)
    pl = plan(path)
    assert len({r.hash for r in pl.runs}) == len(combos)
    assert sorted(i for g in pl.groups for i in g) == list(range(len(combos)))


def test_bad_sweep_gives_one_line_error(tmp_path):
    with pytest.raises(ScenarioError, match="vehicle.params.sprung_mass"):
        plan(write_sweep(tmp_path, grid={"vehicle.params.sprung_mass": [290, -1]}))
    with pytest.raises(ScenarioError, match="random"):
        plan(write_sweep(tmp_path, random={"n": 2, "params": {"sim.seed": {"dist": "nosuchdist"}}}))


# -- ensemble = alone -----------------------------------------------------------------------------------
def test_car_alone_equals_car_in_ensemble():
    scs = []
    for k, c, seed in [(15000, 2500, 1), (18000, 800, 2), (16812, 1500, 3)]:
        raw = {**BASE, "vehicle": {**BASE["vehicle"], "params": {"spring_stiffness": k}},
               "controller": {"type": "skyhook", "params": {"c_sky": c}}, "sim": {"duration": 0.5, "seed": seed}}
        scs.append(parse_scenario(raw))
    ens = Simulation(scs).run()
    alone = Simulation([scs[1]]).run()[0]
    a, b = ens[1].ts, alone.ts
    assert list(a.columns) == list(b.columns)
    assert np.nanmax(np.abs(a.to_numpy() - b.to_numpy())) <= 1e-12
    assert ens[1].metrics == pytest.approx(alone.metrics, rel=1e-12, abs=1e-12)
    # and the cars really differ (the comparison is not vacuous)
    assert np.max(np.abs(ens[0].ts["body_z"].to_numpy() - a["body_z"].to_numpy())) > 1e-4


# -- engines ----------------------------------------------------------------------------------------------
def test_identical_rows_on_every_engine(tmp_path):
    path = write_sweep(tmp_path, grid={"vehicle.params.damping": [800, 1300, 1800], "controller.params.c_sky": [0, 2000]},
                       ensemble_size=4)
    one = run_batch(path, out=tmp_path / "w1", workers=1).summary
    two = run_batch(path, out=tmp_path / "w2", workers=2).summary
    assert len(one) == 6 and (one["status"] == "ok").all()
    assert one["metric.body_acc_rms"].nunique() == 6
    pd.testing.assert_frame_equal(rows(one), rows(two))
    pytest.importorskip("dask.distributed")
    dk = run_batch(path, out=tmp_path / "dask", dask_local=2).summary
    pd.testing.assert_frame_equal(rows(one), rows(dk))


# -- faults -----------------------------------------------------------------------------------------------
class FaultParams(Params):
    mode: float = 0.0  # 0 ok (skyhook), 1 raise, 2 diverge, 3 NaN, 4 slow


@CONTROLLERS.register("_test_fault")
class FaultController(Controller):
    """Test-only: a skyhook that raises, diverges, returns NaN or is slow, by parameter."""

    Params = FaultParams
    requires = ("corner_body_vel",)

    def step(self, t, y):
        mode = int(np.max(self.p.mode))
        f = -1500.0 * y["corner_body_vel"]
        if t > 0.2:
            f = np.where(self.p.mode == 2, 1e5 * y["corner_body_vel"], f)  # unstable positive feedback
            f = np.where(self.p.mode == 3, np.nan, f)
            if np.any(self.p.mode == 1):
                raise RuntimeError("controller exploded on purpose")
        if mode == 4 and np.all(self.p.mode == 4):
            time.sleep(0.02)  # 1000 control steps: 20 s, far beyond the limit
        return f


def test_faults_are_recorded_and_spare_the_others(tmp_path):
    path = write_sweep(tmp_path, grid={"controller.params.mode": [0, 1, 2, 3, 4]},
                       lists={"vehicle.params.damping": [900, 1100]},
                       set={"controller.type": "_test_fault", "controller.params": {"mode": 0}},
                       ensemble_size=10, time_limit=4.0)  # room for a cold kernel compile on a loaded machine
    rep = run_batch(path, out=tmp_path / "f", workers=2)
    df = rep.summary.set_index("run_id")
    assert len(df) == 10
    status = dict(zip(df["controller.params.mode"].astype(int).astype(str) + "/" + df["vehicle.params.damping"].astype(str),
                      df["status"]))
    for d in (900, 1100):
        assert status[f"0/{d}"] == "ok"
        assert status[f"1/{d}"] == "error"
        assert status[f"2/{d}"] == "diverged"
        assert status[f"3/{d}"] == "nan"
        assert status[f"4/{d}"] == "timeout"
    assert df.loc[df["status"] == "error", "error"].str.contains("exploded on purpose").all()
    assert df.loc[df["status"] != "ok", "metric.body_acc_rms"].isna().all()
    # the good runs are intact: equal to the same scenarios simulated directly
    sw, base = load_sweep(path)
    from suspension_sim.batch import build_raw

    for rid in df.index[df["status"] == "ok"]:
        vals = plan(path).combos[rid]
        r = Simulation([parse_scenario(build_raw(base, sw, vals))]).run()[0]
        assert df.loc[rid, "metric.body_acc_rms"] == pytest.approx(r.metrics["body_acc_rms"], rel=1e-12)


def test_resume_recomputes_only_missing_and_failed(tmp_path):
    path = write_sweep(tmp_path, grid={"controller.params.mode": [0, 1]}, lists={"vehicle.params.damping": [800, 1000, 1200]},
                       set={"controller.type": "_test_fault", "controller.params": {"mode": 0}}, ensemble_size=6)
    out = tmp_path / "r"
    first = run_batch(path, out=out, workers=1)
    assert first.n_run == 6 and first.counts == {"ok": 3, "error": 3}
    # lose one good row (as if the sweep had been cut short)
    s = pd.read_parquet(out / "summary.parquet")
    lost = s[s["status"] == "ok"].iloc[0]["hash"]
    s[s["hash"] != lost].to_parquet(out / "summary.parquet", index=False)
    again = run_batch(path, out=out, workers=1)
    assert again.n_run == 1 + 3  # the lost run and the failed ones
    both = first.summary.merge(again.summary, on="hash", suffixes=("_a", "_b"))
    kept = both[(both["status_a"] == "ok") & (both["hash"] != lost)]
    assert len(kept) == 2 and (kept["wall_time_s_a"] == kept["wall_time_s_b"]).all()  # not recomputed
    fresh = run_batch(path, out=out, workers=1, resume=False)
    assert fresh.n_run == 6


def test_local_engine_survives_a_dead_task():
    seen = {}
    LocalEngine(1).map(lambda t: 1 / t, [1, 0, 2], lambda i, r: seen.__setitem__(i, r),
                       lambda i, e: seen.__setitem__(i, type(e).__name__))
    assert seen == {0: 1.0, 1: "ZeroDivisionError", 2: 0.5}


def test_cli_batch(tmp_path, repo):
    from typer.testing import CliRunner

    from suspension_sim.cli import app

    sw = yaml.safe_load((repo / "scenarios" / "sweep_example.yaml").read_text())
    sw["grid"] = {"vehicle.params.damping": [800, 1600]}
    sw["random"]["n"] = 2
    sw["base"]["sim"]["duration"] = 0.5
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(sw))
    res = CliRunner().invoke(app, ["batch", str(p), "--out", str(tmp_path / "o"), "--workers", "1"])
    assert res.exit_code == 0, res.output
    assert "8 runs" in res.output and "ok 8" in res.output
    df = pd.read_parquet(tmp_path / "o" / "summary.parquet")
    assert len(df) == 8 and {"seed", "status", "error", "wall_time_s", "vehicle.params.damping"} <= set(df.columns)


class CrashParams(Params):
    crash: float = 0.0


@CONTROLLERS.register("_test_crash")
class CrashController(Controller):
    """Test-only: kills its worker process (as a segfault in native code would)."""

    Params = CrashParams

    def step(self, t, y):
        if np.any(self.p.crash > 0):
            import os

            os._exit(1)
        return self.zeros()


def test_a_crashing_worker_does_not_stop_the_sweep(tmp_path):
    path = write_sweep(tmp_path, grid={"controller.params.crash": [0, 1]}, lists={"sim.seed": [1, 2, 3]},
                       set={"controller.type": "_test_crash", "controller.params": {"crash": 0}}, ensemble_size=1)
    df = run_batch(path, out=tmp_path / "c", workers=2).summary
    assert len(df) == 6
    crashed = df["controller.params.crash"] == 1
    assert (df.loc[crashed, "status"] == "error").all() and df.loc[crashed, "error"].str.contains("worker").all()
    assert (df.loc[~crashed, "status"] == "ok").all()
