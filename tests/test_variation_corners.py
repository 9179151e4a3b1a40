"""``corners`` on a vehicle-parameter variation: the parameter changes on the chosen corners only (it was
silently applied to every corner before), and a parameter that does not act on the chosen corners is a
one-line error naming the field."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from suspension_sim.config import load_scenario, parse_scenario
from suspension_sim.errors import ScenarioError
from suspension_sim.simulation import Simulation


def _full_car(corners):
    v = {"param": "spring_stiffness_front", "kind": "step", "mode": "scale", "times": [0.2], "values": [0.3]}
    if corners is not None:
        v["corners"] = corners
    return {"name": "vc", "vehicle": {"model": "full_car", "variations": [v]},
            "road": {"type": "sine", "params": {"amplitude": 0.02, "frequency": 1.5}},
            "sim": {"duration": 1.5, "dt": 5e-4, "control_dt": 1e-3, "log_dt": 1e-3}}


@pytest.mark.parametrize("compiled", [True, False], ids=["compiled", "python"])
def test_a_vehicle_variation_on_one_corner_leaves_the_other(monkeypatch, compiled):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    one = Simulation([parse_scenario(_full_car(["fl"]))]).run()[0].ts
    both = Simulation([parse_scenario(_full_car(None))]).run()[0].ts
    # the road is the same under both front wheels, so the car stays symmetric unless one side changes
    lr_one = np.max(np.abs(one.travel_fl.to_numpy() - one.travel_fr.to_numpy()))
    lr_both = np.max(np.abs(both.travel_fl.to_numpy() - both.travel_fr.to_numpy()))
    assert lr_both < 1e-9  # the baseline (every front corner softened) keeps left = right
    assert lr_one > 1e-3  # softening fl alone makes it sag and move more than fr
    # fl softened in both runs; fr only in the second: fr's travel differs between the runs
    assert np.max(np.abs(one.travel_fr.to_numpy() - both.travel_fr.to_numpy())) > 1e-3


@pytest.mark.parametrize("param, corners, text", [
    ("spring_stiffness_front", ["rl"], "parameter 'spring_stiffness_front' does not act on corner(s) ['rl']"),
    ("sprung_mass", ["fl"], "parameter 'sprung_mass' does not act on corner(s) ['fl']"),
    ("spring_stiffness_front", ["xx"], "unknown corner(s) ['xx']"),
])
def test_a_parameter_not_on_the_chosen_corners_is_a_one_line_error(tmp_path, param, corners, text):
    raw = _full_car(corners)
    raw["vehicle"]["variations"][0]["param"] = param
    p = tmp_path / "s.yaml"
    p.write_text(yaml.safe_dump(raw))
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{p}: vehicle.variations.0.corners: "), msg
    assert text in msg


def test_every_corner_named_is_the_same_as_all(monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    a = Simulation([parse_scenario(_full_car(["fl", "fr", "rl", "rr"]))]).run()[0].ts
    b = Simulation([parse_scenario(_full_car(None))]).run()[0].ts
    assert np.array_equal(a.body_z.to_numpy(), b.body_z.to_numpy())
