"""Half-car diagnosis (suspension_sim.diagnose with ``model: half_car``) on synthetic records from the
independent half-car truth generator (truth.simulate_truth_half: scipy solve_ivp, its own rigid-body
equations and effect laws).  Nominal parameters are per corner; an added effect acts at both corners with
shared parameters."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
import yaml

from suspension_sim.diagnose import diagnose, truth
from suspension_sim.diagnose.calibrate import Problem
from suspension_sim.diagnose.io import record_from_arrays
from suspension_sim.diagnose.model import load_model

warnings.filterwarnings("ignore", category=RuntimeWarning)

OUTS = ["body_acc_front", "body_acc_rear", "susp_travel_front", "susp_travel_rear", "pitch_rate"]
HC = {"model": "half_car", "params": {**truth.HC_NOMINAL, "damping_front": "free", "damping_rear": "free"}}


def _rec(d, outs):
    return record_from_arrays("half_car", d["time"], {"road_front": d["road_front"], "road_rear": d["road_rear"]},
                              {k: d[k] for k in outs})


def _shrink(rep):
    b = np.sqrt(np.mean(np.square(list(rep["nrmse"]["before"]["test"].values()))))
    a = np.sqrt(np.mean(np.square(list(rep["nrmse"]["after"]["test"].values()))))
    return 1 - a / b


def test_half_car_engine_matches_independent_truth():
    # an asymmetric car (a ≠ b, different corners) so that a sign or lever-arm error would show
    params = {"a": 1.2, "b": 1.6, "spring_stiffness_rear": 21000.0, "unsprung_mass_rear": 50.0, "damping_rear": 1500.0}
    d = truth.simulate_truth_half(3.0, 1000.0, {"quadratic_damping": {"c_v": 3000.0}}, params=params, seed=2,
                                  noise=0.0)
    rec = _rec(d, truth.HC_OUTPUTS)
    spec = load_model({"model": "half_car", "params": {**truth.HC_NOMINAL, **params},
                       "effects": [{"type": "quadratic_damping", "params": {"c_v": 3000.0}}]})
    prob = Problem(rec, spec)
    err = prob.nrmse(prob.simulate(spec, spec.P), 0, len(rec), offsets=np.zeros(len(prob.channels)))
    assert max(err.values()) < 0.01, err


@pytest.mark.slow  # minutes on a loaded 2-core machine (MuJoCo ensemble fits)
def test_half_car_bump_stop_named_and_confirmed_in_mujoco(tmp_path):
    d = truth.simulate_truth_half(6.0, 400.0, {"bump_stop": {"gap": 0.012, "stiffness": 8e4}}, seed=3, noise=0.02,
                                  outputs=OUTS)
    rep = diagnose(_rec(d, OUTS), HC, tmp_path, confirm=True, plots=False)
    assert [e["name"] for e in rep["effects"]] == ["bump_stop"]
    p = rep["effects"][0]["parameters"]
    # the gaps are fitted per side (the truth's stop is symmetric: both sides at 12 mm)
    assert abs(p["gap_compression"] / 0.012 - 1) < 0.1 and abs(p["gap_extension"] / 0.012 - 1) < 0.1, p
    assert abs(p["stiffness"] / 8e4 - 1) < 0.3, p
    assert not rep["effects"][0]["notes"], rep["effects"][0]
    assert _shrink(rep) >= 0.8
    mj = rep["mujoco_confirmation"]
    assert mj["status"] == "ok", mj
    assert max(c["nrmse_replay_vs_search"] for c in mj["channels"].values()) < 0.05
    fitted = yaml.safe_load((tmp_path / "model.fitted.yaml").read_text())
    assert fitted["vehicle"]["model"] == "half_car"
    assert [e["type"] for e in fitted["vehicle"]["effects"]] == ["bump_stop"]
    assert json.loads((tmp_path / "report.json").read_text())["effects"][0]["name"] == "bump_stop"


@pytest.mark.slow  # minutes on a loaded 2-core machine (MuJoCo ensemble fits)
def test_half_car_no_hidden_effect_names_nothing(tmp_path):
    d = truth.simulate_truth_half(6.0, 400.0, {}, seed=4, noise=0.02, outputs=OUTS)
    rep = diagnose(_rec(d, OUTS), HC, tmp_path, confirm=False, plots=False)
    assert rep["effects"] == []
