"""The ``policy`` controller: a trained policy file (.npz MLP built here, stable-baselines3 .zip when SB3 is
installed) runs in a scenario, in an ensemble (the batch engine's path), in a sweep, and in `run` + `compare`."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from suspension_sim.batch import run_batch
from suspension_sim.cli import app
from suspension_sim.config import parse_scenario
from suspension_sim.controllers.policy import save_npz
from suspension_sim.errors import ScenarioError
from suspension_sim.simulation import Simulation

BASE = {
    "name": "pol",
    "vehicle": {"model": "quarter_car"},
    "road": {"type": "iso8608", "params": {"road_class": "C"}, "speed": 20, "seed": 4},
    "sensors": [{"name": "corner_body_vel", "type": "corner_body_vel", "noise_std": 0.002},
                {"name": "travel_rate", "type": "travel_rate"}],
    "actuator": {"type": "ideal", "params": {"max_force": 3000, "time_constant": 0.005}},
    "controller": {"type": "skyhook", "params": {"c_sky": 2500}},
    "sim": {"duration": 2.0},
}


def _scenario(**ctrl):
    raw = json.loads(json.dumps(BASE))
    if ctrl:
        raw["controller"] = ctrl
    return parse_scenario(raw)


@pytest.fixture(scope="module")
def skyhook_npz(tmp_path_factory):
    """A one-layer 'network' that is skyhook: a = -2500/3000 · v_body (+ 0 · travel rate)."""
    p = tmp_path_factory.mktemp("pol") / "sky.npz"
    save_npz(p, [(np.array([[-2500.0 / 3000.0], [0.0]]), np.zeros(1))])
    return p


def test_linear_policy_equals_skyhook_and_differs_from_passive(skyhook_npz):
    pol = Simulation([_scenario(type="policy", params={"path": str(skyhook_npz)})])
    r_pol = pol.run()[0]
    assert pol.loop == "hybrid"  # the compiled loop, the policy called in Python at control instants
    r_sky = Simulation([_scenario()]).run()[0]
    r_pas = Simulation([_scenario(type="passive")]).run()[0]
    a, b, c = (r.ts["command"].to_numpy() for r in (r_pol, r_sky, r_pas))
    assert np.max(np.abs(a - b)) < 1e-6 * np.max(np.abs(b))
    assert np.max(np.abs(b)) > 100 and np.all(c == 0)
    assert r_pol.metrics["body_acc_rms"] == pytest.approx(r_sky.metrics["body_acc_rms"], rel=1e-9)
    assert r_pol.metrics["body_acc_rms"] < 0.95 * r_pas.metrics["body_acc_rms"]


def test_mlp_forward_in_an_ensemble_with_per_car_files(tmp_path, skyhook_npz):
    """A 2-layer tanh MLP with input normalisation: the logged command is the MLP of the logged sensors, and
    in an ensemble of two files each car gets its own policy."""
    rng = np.random.default_rng(0)
    w0, b0, w1, b1 = rng.normal(size=(2, 8)), rng.normal(size=8), rng.normal(size=(8, 1)), rng.normal(size=1) * 0.1
    mean, std = np.array([0.0, 0.01]), np.array([0.2, 0.3])
    mlp = tmp_path / "mlp.npz"
    save_npz(mlp, [(w0, b0), (w1, b1)], obs_mean=mean, obs_std=std)
    scs = [_scenario(type="policy", params={"path": str(mlp), "action_scale": 1000}),
           _scenario(type="policy", params={"path": str(skyhook_npz), "action_scale": 1000})]
    r_mlp, r_sky = Simulation(scs).run()
    ts = r_mlp.ts
    obs = np.stack([ts["sensor.corner_body_vel.value"], ts["sensor.travel_rate.value"]], axis=1)
    expect = np.clip(np.tanh(((obs - mean) / std) @ w0 + b0) @ w1 + b1, -1, 1)[:, 0] * 1000
    got = ts["command"].to_numpy()
    assert np.max(np.abs(got - expect)) < 1e-9 * 1000 and np.std(got) > 10
    v = r_sky.ts["sensor.corner_body_vel.value"].to_numpy()
    assert np.allclose(r_sky.ts["command"], np.clip(-2500 / 3000 * v, -1, 1) * 1000, atol=1e-9)


def test_policy_in_a_sweep_and_in_compare(tmp_path, skyhook_npz):
    base = json.loads(json.dumps(BASE))
    base["controller"] = {"type": "policy", "params": {"path": str(skyhook_npz)}}
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text(yaml.safe_dump({"name": "s", "base": base, "grid": {"vehicle.params.sprung_mass": [250, 330]}}))
    rep = run_batch(str(sweep), out=tmp_path / "batch", workers=1)
    assert list(rep.summary["status"]) == ["ok", "ok"]
    base["variants"] = {"passive": {"controller": {"type": "passive"}}, "policy": {}}
    base["outputs"] = {"plots": False}
    sc = tmp_path / "sc.yaml"
    sc.write_text(yaml.safe_dump(base))
    runner = CliRunner()
    res = runner.invoke(app, ["run", str(sc), "--out", str(tmp_path / "run"), "-q"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["compare", str(tmp_path / "run" / "passive"), str(tmp_path / "run" / "policy"),
                              "--out", str(tmp_path / "cmp"), "--no-viewer"])
    assert res.exit_code == 0, res.output
    assert "policy" in (tmp_path / "cmp" / "report.html").read_text()


def test_bad_policy_files_one_line_errors(tmp_path, skyhook_npz):
    with pytest.raises(ScenarioError, match="not found"):
        Simulation([_scenario(type="policy", params={"path": str(tmp_path / "none.npz")})])
    wrong = tmp_path / "wrong.npz"
    save_npz(wrong, [(np.zeros((3, 1)), np.zeros(1))])
    with pytest.raises(ScenarioError, match="takes 3 observations"):
        Simulation([_scenario(type="policy", params={"path": str(wrong)})])
    bad = tmp_path / "policy.txt"
    bad.write_text("x")
    with pytest.raises(ScenarioError, match="unknown format"):
        Simulation([_scenario(type="policy", params={"path": str(bad)})])


def test_sb3_zip_policy(tmp_path):
    """A stable-baselines3 PPO model (untrained; saved here) runs as a controller, and its .npz export gives
    the same commands without torch."""
    sb3 = pytest.importorskip("stable_baselines3")
    from suspension_sim.controllers.policy import export_sb3
    from suspension_sim.rl.env import SuspensionEnv

    env = SuspensionEnv(BASE)
    model = sb3.PPO("MlpPolicy", env, seed=0, device="cpu")
    model.save(tmp_path / "ppo.zip")
    export_sb3(model, tmp_path / "ppo.npz")
    r_zip = Simulation([_scenario(type="policy", params={"path": str(tmp_path / "ppo.zip")})]).run()[0]
    r_npz = Simulation([_scenario(type="policy", params={"path": str(tmp_path / "ppo.npz")})]).run()[0]
    a, b = r_zip.ts["command"].to_numpy(), r_npz.ts["command"].to_numpy()
    assert np.std(a) > 1.0 and np.max(np.abs(a - b)) < 1e-3 * 3000  # float32 torch vs float64 numpy


def test_onnx_policy_equals_npz(tmp_path):
    """The same 2-layer MLP as an ONNX graph (built with the onnx package here; skipped without onnxruntime)
    and as .npz gives the same commands."""
    pytest.importorskip("onnxruntime")
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper, numpy_helper

    rng = np.random.default_rng(3)
    w0, b0, w1, b1 = rng.normal(size=(2, 8)), rng.normal(size=8), rng.normal(size=(8, 1)), rng.normal(size=1)
    inits = [numpy_helper.from_array(a.astype(np.float32), name) for a, name in
             ((w0, "w0"), (b0, "b0"), (w1, "w1"), (b1, "b1"))]
    nodes = [helper.make_node("MatMul", ["obs", "w0"], ["h0"]), helper.make_node("Add", ["h0", "b0"], ["h1"]),
             helper.make_node("Tanh", ["h1"], ["h2"]), helper.make_node("MatMul", ["h2", "w1"], ["h3"]),
             helper.make_node("Add", ["h3", "b1"], ["act"])]
    graph = helper.make_graph(nodes, "mlp", [helper.make_tensor_value_info("obs", TensorProto.FLOAT, [None, 2])],
                              [helper.make_tensor_value_info("act", TensorProto.FLOAT, [None, 1])], inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    onnx.save(model, tmp_path / "mlp.onnx")
    save_npz(tmp_path / "mlp.npz", [(w0, b0), (w1, b1)])
    r_onnx = Simulation([_scenario(type="policy", params={"path": str(tmp_path / "mlp.onnx")})]).run()[0]
    r_npz = Simulation([_scenario(type="policy", params={"path": str(tmp_path / "mlp.npz")})]).run()[0]
    a, b = r_onnx.ts["command"].to_numpy(), r_npz.ts["command"].to_numpy()
    assert np.std(b) > 10 and np.max(np.abs(a - b)) < 1e-4 * 3000  # float32 vs float64
