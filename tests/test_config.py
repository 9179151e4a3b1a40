"""Bad scenarios give one-line ScenarioError messages naming the file and the field, through the Python API and
through the CLI (exit status 2, one line on stderr, no traceback); a diverging run exits with 3 naming the
time, the state and a hint."""
import copy
import os
import subprocess
import sys

import pytest
import yaml
from typer.testing import CliRunner

from suspension_sim.cli import app
from suspension_sim.config import apply_set, load_scenario, parse_scenario
from suspension_sim.errors import ScenarioError, SimulationDiverged

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

GOOD = {
    "name": "cfg_test",
    "vehicle": {"model": "quarter_car", "params": {"sprung_mass": 300.0}},
    "road": {"type": "sine", "params": {"frequency": 1.0}},
    "sensors": [{"type": "corner_body_vel"}],
    "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
    "sim": {"duration": 0.2},
}


def _with(path: str, value):
    """GOOD with ``path`` (dotted, list indices as numbers) set to value, or deleted when value is DELETE."""
    raw = copy.deepcopy(GOOD)
    keys = path.split(".")
    node = raw
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if value is DELETE:
        del node[keys[-1]]
    elif isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value
    return raw


class _Delete:
    """Marks a key to remove (a stable repr keeps test ids equal across pytest-xdist workers)."""

    def __repr__(self):
        return "DELETE"


DELETE = _Delete()

# (path, value, field the message must name, text it must contain)
BAD = [
    ("bogus", 1, "bogus", "unknown key"),
    ("vehicle.bogus", 1, "vehicle.bogus", "unknown key"),
    ("sim.dtt", 0.001, "sim.dtt", "unknown key"),
    ("sensors.0.nois_std", 0.1, "sensors.0.nois_std", "unknown key"),
    ("vehicle.params.sprung_mas", 300.0, "vehicle.params.sprung_mas", "unknown key"),
    ("vehicle.params.sprung_mass", -290.0, "vehicle.params.sprung_mass", "greater than 0"),
    ("vehicle.params.sprung_mass", "heavy", "vehicle.params.sprung_mass", "valid number"),
    ("sim.duration", "long", "sim.duration", "valid number"),
    ("sim.dt", [0.001], "sim.dt", "valid number"),
    ("road", DELETE, "road", "required field is missing"),
    ("road.type", "moon", "road.type", "unknown road 'moon'"),
    ("road.params.frequency", -1.0, "road.params.frequency", "greater than 0"),
    ("road.speed", -3.0, "road.speed", "speed must be >= 0"),
    ("vehicle.model", "truck", "vehicle.model", "unknown vehicle model 'truck'"),
    ("controller.type", "fuzzy", "controller.type", "unknown controller 'fuzzy'"),
    ("controller.params.c_sky", -5.0, "controller.params.c_sky", "greater than or equal to 0"),
    ("controller.params.c_skyy", 5.0, "controller.params.c_skyy", "unknown key"),
    ("actuator", {"type": "pneumatic"}, "actuator.type", "unknown actuator 'pneumatic'"),
    ("actuator", {"type": "ideal", "params": {"max_force": -1}}, "actuator.params.max_force", "greater than 0"),
    ("sensors.0.type", "gps", "sensors.0.type", "unknown sensor 'gps'"),
    ("sensors.0.noise_std", -0.1, "sensors.0.noise_std", "greater than or equal to 0"),
    ("vehicle.effects", [{"type": "warp_drive"}], "vehicle.effects.0.type", "unknown effect 'warp_drive'"),
    ("vehicle.effects", [{"type": "quadratic_damping", "params": {"c_v": -1.0}}], "vehicle.effects.0.params.c_v", ""),
    ("vehicle.effects", [{"type": "quadratic_damping", "params": {"c": 1.0}}], "vehicle.effects.0.params.c", "unknown key"),
    ("vehicle.effects", [{"type": "coulomb_friction", "corners": ["front"]}], "vehicle.effects.0.corners", "unknown corner"),
    ("vehicle.variations", [{"param": "mass", "values": [1.0]}], "vehicle.variations.0.param", "unknown vehicle parameter"),
    ("vehicle.levelled_with", {"damping": 900.0}, "vehicle.levelled_with.damping", "not a mass or inertia"),
    ("vehicle.levelled_with", {"sprung_mass": -1.0}, "vehicle.levelled_with.sprung_mass", "greater than 0"),
    ("sim.control_dt", 0.00075, "sim.control_dt", "whole multiple of dt"),
    ("sim.log_dt", 0.0002, "sim.log_dt", "whole multiple of dt"),
    ("sensors", [], "sensors", "needs sensor(s) corner_body_vel"),
    ("controller.params.semi_active", True, "sensors", "needs sensor(s) travel_rate"),
    ("variants", {"soft": {"vehicle": {"params": {"damping": -1.0}}}}, "variants.soft:vehicle.params.damping", "greater"),
    ("variants", {"x": {"bogus": 1}}, "variants.x:bogus", "unknown key"),
    ("variants", {"x": {"controller": {"type": "nope"}}}, "variants.x:controller.type", "unknown controller"),
    ("variants", {"x": {"sensors": []}}, "variants.x:sensors", "needs sensor(s)"),
]


def _write(tmp_path, raw, name="scenario.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(raw))
    return p


def test_good_scenario_is_valid(tmp_path):
    sc = load_scenario(_write(tmp_path, GOOD))
    assert sc.vehicle.params["sprung_mass"] == 300.0 and sc.controller.type == "skyhook"


@pytest.mark.parametrize("path, value, field, text", BAD, ids=[f"{b[0]}={b[1]!r}"[:60] for b in BAD])
def test_bad_scenario_one_line_error(tmp_path, path, value, field, text):
    p = _write(tmp_path, _with(path, value))
    with pytest.raises(ScenarioError) as e:
        load_scenario(p)
    msg = str(e.value)
    assert "\n" not in msg
    assert msg.startswith(f"{p}: {field}: "), msg
    assert text in msg
    assert "Value error" not in msg and "constrained" not in msg  # no pydantic internals


@pytest.mark.parametrize("model, level", [
    ("quarter_car", {"damping": 900.0}), ("quarter_car", {"sprung_mass": -1.0}), ("quarter_car", {"sprung_mass": True}),
    ("quarter_car", {"sprung_mass": "290"}), ("quarter_car", {"unsprung_mass": 0.0}),
    ("half_car", {"pitch_inertia": -5.0}), ("half_car", {"roll_inertia": 100.0})])
def test_levelled_with_one_check_for_a_scenario_and_a_model_file(tmp_path, model, level):
    """``vehicle.levelled_with`` of a scenario (run, validate) and ``levelled_with`` of a model file (diagnose
    --model; a scenario's vehicle block is one) go through one check: the same file gives the same one-line error,
    naming the file and the field.  Before, the model file took any positive number (a boolean ``true``, a zero
    unsprung mass and a negative inertia gave other messages, or none)."""
    from suspension_sim.diagnose.model import load_model

    raw = copy.deepcopy(GOOD)
    raw["vehicle"] = {"model": model, "levelled_with": level}
    p = _write(tmp_path, raw)
    with pytest.raises(ScenarioError) as run_err:
        load_scenario(p)
    with pytest.raises(ScenarioError) as diag_err:
        load_model(p)
    msg = str(run_err.value)
    assert "\n" not in msg and msg.startswith(f"{p}: vehicle.levelled_with."), msg
    assert str(diag_err.value) == msg


@pytest.mark.parametrize("text, expect", [
    ("road: {type: flat\nsim: [1\n", "not valid YAML at line"),
    ("- 1\n- 2\n", "must be a YAML mapping"),
])
def test_unreadable_files(tmp_path, text, expect):
    p = tmp_path / "s.yaml"
    p.write_text(text)
    with pytest.raises(ScenarioError, match=expect):
        load_scenario(p)
    with pytest.raises(ScenarioError, match="file not found"):
        load_scenario(tmp_path / "missing.yaml")


def test_set_overrides(tmp_path):
    p = _write(tmp_path, GOOD)
    sc = load_scenario(p, ["vehicle.params.sprung_mass=350", "sim.duration=0.5", "sensors.0.noise_std=0.01",
                           "road={type: flat}", "controller.params.c_sky=1500", "sim.dt=1e-4"])
    assert sc.vehicle.params["sprung_mass"] == 350 and sc.sim.duration == 0.5
    assert sc.sensors[0].noise_std == 0.01 and sc.road.type == "flat" and sc.controller.params["c_sky"] == 1500
    assert sc.sim.dt == 1e-4  # YAML 1.1 reads 1e-4 as a string; the schema converts it


@pytest.mark.parametrize("override, field, text", [
    ("vehicle.params.sprung_mass=-1", "vehicle.params.sprung_mass", "greater than 0"),
    ("vehicle.params.sprung_mass=abc", "vehicle.params.sprung_mass", "valid number"),
    ("sim.bogus=1", "sim.bogus", "unknown key"),
    ("novalue", None, "expects path.to.key=value"),
    ("sim..dt=1", None, "empty key"),
    ("sensors.7.type=x", "sensors.7", "no list item"),
    ("sim.duration.x=1", "sim.duration", "not a mapping"),
    ("variants.a.sim.dt=-1", "variants.a.sim.dt", "unknown variant 'a'"),  # a misspelt name is no new variant
    ("variants.a={sim: {dt: -1}}", "variants.a:sim.dt", "greater than 0"),  # a new variant is set whole
])
def test_bad_set_overrides(tmp_path, override, field, text):
    p = _write(tmp_path, GOOD)
    with pytest.raises(ScenarioError) as e:
        load_scenario(p, [override])
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{p}: ") and text in msg
    if field:
        assert f": {field}: " in msg


def test_apply_set_parses_yaml_values():
    raw = copy.deepcopy(GOOD)
    apply_set(raw, "sim.seed=7")
    apply_set(raw, "outputs.plots=false")
    apply_set(raw, "vehicle.effects=[{type: quadratic_damping}]")
    assert raw["sim"]["seed"] == 7 and raw["outputs"]["plots"] is False
    assert raw["vehicle"]["effects"] == [{"type": "quadratic_damping"}]
    sc = parse_scenario(raw)
    assert sc.vehicle.effects[0].type == "quadratic_damping"


def test_variants_expand_and_validate(tmp_path):
    raw = _with("variants", {"passive": {"controller": {"type": "passive"}}, "firm": {"vehicle": {"params": {"damping": 2000.0}}}})
    sc = load_scenario(_write(tmp_path, raw))
    v = dict(sc.expand())
    assert set(v) == {"passive", "firm"}
    assert v["passive"].controller.type == "passive" and v["passive"].controller.params == {}
    assert v["firm"].vehicle.params == {"sprung_mass": 300.0, "damping": 2000.0}  # params merge


# -- the CLI --------------------------------------------------------------------------------------------

def _cli(args):
    return CliRunner().invoke(app, [str(a) for a in args])


def _one_line_error(res, code):
    assert res.exit_code == code, (res.exit_code, res.output)
    err = res.stderr.strip()
    assert "Traceback" not in res.output and "Traceback" not in err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("error: ")
    return err


@pytest.mark.parametrize("path, value, field, text", [BAD[i] for i in (0, 1, 5, 6, 9, 10, 14, 22, 26, 28, 30)])
def test_cli_validate_bad_scenarios(tmp_path, path, value, field, text):
    p = _write(tmp_path, _with(path, value))
    err = _one_line_error(_cli(["validate", p]), 2)
    assert f"{p}: {field}: " in err and text in err
    err = _one_line_error(_cli(["run", p, "--out", tmp_path / "out", "-q"]), 2)
    assert f"{p}: {field}: " in err
    assert not (tmp_path / "out").exists()


def test_cli_bad_set_and_missing_file(tmp_path):
    p = _write(tmp_path, GOOD)
    err = _one_line_error(_cli(["validate", p, "--set", "sim.dt=fast"]), 2)
    assert "sim.dt" in err and "'fast'" in err
    err = _one_line_error(_cli(["run", p, "-q", "--set", "vehicle.params.sprung_mass=-1"]), 2)
    assert "vehicle.params.sprung_mass" in err
    err = _one_line_error(_cli(["validate", tmp_path / "nope.yaml"]), 2)
    assert "nope.yaml: file not found" in err
    res = _cli(["validate", p, "--set", "sim.duration=1"])
    assert res.exit_code == 0 and "ok" in res.stdout


DIVERGE = ["--set", "controller.params.c_sky=1e8", "--set", "sim.dt=0.01", "--set", "sim.control_dt=0.01",
           "--set", "sim.log_dt=0.01", "--set", "sim.duration=1"]


def test_diverging_run_python_api(tmp_path):
    import suspension_sim as ss

    sc = load_scenario(_write(tmp_path, GOOD), DIVERGE[1::2])
    with pytest.raises(SimulationDiverged) as e:
        ss.simulate(sc)
    err = e.value
    assert 0 < err.time < 1.0
    assert "body_z" in err.state and "travel" in err.state
    assert "sim.dt" in err.hint


def test_cli_diverging_run_exits_3(tmp_path):
    p = _write(tmp_path, GOOD)
    err = _one_line_error(_cli(["run", p, "--out", tmp_path / "out", "-q", *DIVERGE]), 3)
    assert "diverged at t=" in err and "body_z=" in err and "Hint:" in err


def test_cli_subprocess_end_to_end(tmp_path):
    """The real command line (python -m suspension_sim.cli): exit 2 and 3, one stderr line, no traceback."""
    p = _write(tmp_path, _with("vehicle.params.sprung_mass", -290.0))
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    r = subprocess.run([sys.executable, "-m", "suspension_sim.cli", "validate", str(p)], capture_output=True,
                       text=True, cwd=REPO, env=env, timeout=120)
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("error:")]
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert lines == [f"error: {p}: vehicle.params.sprung_mass: Input should be greater than 0 (got -290.0)"]
    p2 = _write(tmp_path, GOOD, "good.yaml")
    r = subprocess.run([sys.executable, "-m", "suspension_sim.cli", "run", str(p2), "-q", "--out",
                        str(tmp_path / "o"), *DIVERGE], capture_output=True, text=True, cwd=REPO, env=env, timeout=120)
    assert r.returncode == 3 and "Traceback" not in r.stderr
    # the message names the file and the run (variant) that diverged
    assert len([ln for ln in r.stderr.splitlines() if ln.startswith(f"error: {p2}: ")
                and ": simulation diverged at t=" in ln]) == 1
