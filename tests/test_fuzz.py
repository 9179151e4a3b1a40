"""A corpus of bad inputs: scenario files, ``--set`` values, sweep files, measured-data files, model files and
command-line options.  Every one must end with exit status 2 and one ``error:`` line on stderr that names the
file (or the option), the field where there is one, and the problem: never a traceback, never a hang, never a
run started.  (Issue: "no traceback at the edges"; limits in suspension_sim/limits.py.)
"""
from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from suspension_sim.cli import app

BASE = {
    "name": "fuzz",
    "vehicle": {"model": "quarter_car", "params": {"sprung_mass": 290.0}},
    "road": {"type": "sine", "params": {"frequency": 1.0}},
    "sensors": [{"type": "corner_body_vel"}],
    "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
    "sim": {"duration": 0.05},
    "outputs": {"plots": False},
}


def _set(d: dict, path: str, value):
    keys = path.split(".")
    node = d
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if isinstance(node, list):
        node[int(keys[-1])] = value
    else:
        node[keys[-1]] = value
    return d


def _scenario(path: str, value, drop: bool = False) -> str:
    import copy

    d = copy.deepcopy(BASE)
    if drop:
        keys = path.split(".")
        node = d
        for k in keys[:-1]:
            node = node[k]
        del node[keys[-1]]
    else:
        _set(d, path, value)
    return yaml.safe_dump(d, sort_keys=False)


BOMB = "a: &a [x,x,x,x,x,x,x,x,x,x]\n" + "".join(
    f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n" for p, c in zip("abcdefgh", "bcdefghi")) + \
    "road: {type: flat}\n"

# (id, scenario text or bytes, the field named in the message (or None), a text of the message)
SCENARIO_FILES = [
    ("empty", "", None, "must be a YAML mapping"),
    ("list_top", "- 1\n- 2\n", None, "must be a YAML mapping"),
    ("scalar_top", "42\n", None, "must be a YAML mapping"),
    ("syntax", "road: {type: flat\nsim: [1\n", None, "not valid YAML at line"),
    ("tab_indent", "road:\n\ttype: flat\n", None, "not valid YAML"),
    ("binary", b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), None, "binary file"),
    ("latin1", "name: caf\xe9\nroad: {type: flat}\n".encode("latin-1"), None, "not UTF-8"),
    ("alias_bomb", BOMB, None, "alias expansion"),
    ("recursive_alias", "road: &r {type: flat, x: *r}\n", None, "recursive alias"),
    ("deep", "road: {type: flat}\nnotes: " + "[" * 200 + "]" * 200 + "\n", None, "nested deeper"),
    ("python_tag", "road: !!python/object/apply:os.system ['echo hi']\n", None, "not valid YAML"),
    ("duplicate_key", "road: {type: flat}\nsim: {duration: 1}\nsim: {duration: 2}\n", None, "duplicate key 'sim'"),
    ("duplicate_nested", "road: {type: flat, type: sine}\n", None, "duplicate key 'type'"),
    ("unknown_top", _scenario("bogus", 1), "bogus", "unknown key"),
    ("no_road", _scenario("road", None, drop=True), "road", "required field is missing"),
    ("mass_true", _scenario("vehicle.params.sprung_mass", True), "vehicle.params.sprung_mass", "boolean"),
    ("mass_string", _scenario("vehicle.params.sprung_mass", "290"), "vehicle.params.sprung_mass", "string"),
    ("mass_nan", _scenario("vehicle.params.sprung_mass", float("nan")), "vehicle.params.sprung_mass", "finite"),
    ("mass_inf", _scenario("vehicle.params.sprung_mass", float("inf")), "vehicle.params.sprung_mass", "finite"),
    ("mass_negative", _scenario("vehicle.params.sprung_mass", -5), "vehicle.params.sprung_mass", "greater than 0"),
    ("mass_zero", _scenario("vehicle.params.sprung_mass", 0), "vehicle.params.sprung_mass", "greater than 0"),
    ("mass_list", _scenario("vehicle.params.sprung_mass", [1, 2]), "vehicle.params.sprung_mass", ""),
    ("params_not_mapping", _scenario("vehicle.params", 5), "vehicle.params", ""),
    ("duration_inf", _scenario("sim.duration", float("inf")), "sim.duration", "finite"),
    ("duration_nan", _scenario("sim.duration", float("nan")), "sim.duration", "nan"),
    ("duration_huge", _scenario("sim.duration", 1e12), "sim", "SUSPENSION_SIM_LIMIT_STEPS"),
    ("duration_1e9", _scenario("sim.duration", 1e9), "sim", "SUSPENSION_SIM_LIMIT_"),
    ("duration_below_dt", _scenario("sim.duration", 1e-6), "sim", "shorter than one physics step"),
    ("duration_negative", _scenario("sim.duration", -1), "sim.duration", "greater than 0"),
    ("duration_zero", _scenario("sim.duration", 0), "sim.duration", "greater than 0"),
    ("duration_bool", _scenario("sim.duration", True), "sim.duration", "boolean"),
    ("dt_zero", _scenario("sim.dt", 0), "sim.dt", "greater than 0"),
    ("dt_string", _scenario("sim.dt", "fast"), "sim.dt", "'fast'"),
    ("dt_too_big", _scenario("sim.dt", 1.0), "sim.dt", "less than or equal"),
    ("control_dt_not_multiple", _scenario("sim.control_dt", 0.0007), "sim.control_dt", "multiple of dt"),
    ("log_dt_nan", _scenario("sim.log_dt", float("nan")), "sim.log_dt", ""),
    ("seed_negative", _scenario("sim.seed", -1), "sim.seed", "greater than or equal to 0"),
    ("seed_float", _scenario("sim.seed", 1.5), "sim.seed", "integer"),
    ("road_seed_negative", _scenario("road.seed", -3), "road.seed", "greater than or equal to 0"),
    ("integrator_unknown", _scenario("sim.integrator", "Euler"), "sim.integrator", ""),
    ("unknown_model", _scenario("vehicle.model", "tank"), "vehicle.model", "tank"),
    ("unknown_effect", _scenario("vehicle.effects", [{"type": "warp_drive"}]), "vehicle.effects.0.type", "warp_drive"),
    ("unknown_effect_param", _scenario("vehicle.effects", [{"type": "bump_stop", "params": {"gapp": 1}}]),
     "vehicle.effects.0.params.gapp", "unknown key"),
    ("effects_not_list", _scenario("vehicle.effects", "bump_stop"), "vehicle.effects", ""),
    ("unknown_corner", _scenario("vehicle.effects", [{"type": "bump_stop", "corners": ["fl"]}]),
     "vehicle.effects.0.corners", "unknown corner"),
    ("unknown_road", _scenario("road.type", "moon"), "road.type", "moon"),
    ("road_param_nan", _scenario("road.params.frequency", float("nan")), "road.params.frequency", "finite"),
    ("speed_negative", _scenario("road.speed", -20), "road.speed", ">= 0"),
    ("speed_table_back", _scenario("road.speed", [[0, 10], [0, 20]]), "road.speed", "increase"),
    ("unknown_controller", _scenario("controller.type", "magic"), "controller.type", "magic"),
    ("controller_param_type", _scenario("controller.params.c_sky", {"a": 1}), "controller.params.c_sky", ""),
    ("full_state_string", _scenario("controller.full_state", "yes"), "controller.full_state", "true or false"),
    ("plots_int", _scenario("outputs.plots", 1), "outputs.plots", "true or false"),
    ("unknown_sensor", _scenario("sensors.0.type", "xray"), "sensors.0.type", "xray"),
    ("sensor_rate_zero", _scenario("sensors.0.rate", 0), "sensors.0.rate", "greater than 0"),
    ("duplicate_sensor", _scenario("sensors", [{"type": "corner_body_vel"}, {"type": "corner_body_vel"}]),
     "sensors.1.name", "duplicate sensor"),
    ("unknown_actuator", _scenario("actuator", {"type": "rocket"}), "actuator.type", "rocket"),
    ("variation_unknown_param", _scenario("vehicle.variations", [{"param": "colour", "values": [1], "times": [0]}]),
     "vehicle.variations.0.param", "unknown vehicle parameter"),
    ("variants_not_mapping", _scenario("variants", [1, 2]), "variants", ""),
    ("variant_bad_value", _scenario("variants", {"ok": {}, "sky": {"sim": {"dt": -1}}}), "variants.sky:sim.dt",
     "greater than 0"),
    # checks that used to surface only in `run` (validate now builds every variant's model)
    ("tire_effect_without_tire", yaml.safe_dump({**BASE, "vehicle": {"model": "sdof", "effects": [
        {"type": "tire_liftoff"}]}, "sensors": [], "controller": {"type": "passive"}}),
     "vehicle.effects.0.type", "has none"),
    ("trapezoidal_no_tire", yaml.safe_dump({**BASE, "vehicle": {"model": "sdof"}, "sensors": [],
                                            "controller": {"type": "passive"},
                                            "sim": {"duration": 0.05, "integrator": "trapezoidal"}}),
     "sim.integrator", "needs a model with tires"),
]

SET_VALUES = [
    ("set_no_equals", ["novalue"], None, "expects path.to.key=value"),
    ("set_empty_key", ["sim..dt=1"], None, "empty key"),
    ("set_inf", ["sim.duration=.inf"], "sim.duration", "finite"),
    ("set_nan", ["vehicle.params.damping=.nan"], "vehicle.params.damping", "finite"),
    ("set_bool", ["vehicle.params.damping=true"], "vehicle.params.damping", "boolean"),
    ("set_1e300_steps", ["sim.duration=1e300"], "sim", "SUSPENSION_SIM_LIMIT_STEPS"),
    ("set_negative", ["vehicle.params.damping=-1"], "vehicle.params.damping", ""),
    ("set_no_list_item", ["sensors.7.type=x"], "sensors.7", "no list item"),
    ("set_not_mapping", ["sim.duration.x=1"], "sim.duration", "not a mapping"),
    ("set_misspelt_variant", ["variants.skyy.controller.params.c_sky=1"], "variants.skyy.controller.params.c_sky",
     "unknown variant 'skyy'"),
    ("set_alias_bomb", ["notes={a: &a [x,x,x,x,x,x,x,x,x,x], " + ", ".join(
        f"{c}: &{c} [" + ",".join([f"*{p}"] * 10) + "]" for p, c in zip("abcdefgh", "bcdefghi")) + "}"],
     "--set notes", "alias expansion"),
    ("set_tag", ["notes=!!python/name:os.system"], None, ""),
    ("set_unknown_key", ["sim.bogus=1"], "sim.bogus", "unknown key"),
]


def _sweep(d: dict) -> str:
    return yaml.safe_dump({"base": "scenario.yaml", **d}, sort_keys=False)


SWEEPS = [
    ("sweep_empty", "", None, "must be a YAML mapping"),
    ("sweep_no_base", yaml.safe_dump({"grid": {"sim.seed": [1, 2]}}), "base", "required"),
    ("sweep_base_missing", _sweep({"base": "nope.yaml"}), "base", "not found"),
    ("sweep_grid_1e9", _sweep({"grid": {f"vehicle.params.p{i}": list(range(10)) for i in range(9)}}), None,
     "SUSPENSION_SIM_LIMIT_SWEEP_RUNS"),
    ("sweep_random_huge", _sweep({"random": {"n": 10 ** 12, "params": {"sim.seed": {"dist": "randint", "low": 0,
                                                                                       "high": 9}}}}),
     None, "SUSPENSION_SIM_LIMIT_SWEEP_RUNS"),
    ("sweep_seeds_huge", _sweep({"seeds": {"count": 10 ** 10}}), None, "SUSPENSION_SIM_LIMIT_SWEEP_RUNS"),
    ("sweep_grid_empty", _sweep({"grid": {"sim.seed": []}}), None, "has no values"),
    ("sweep_lists_unequal", _sweep({"lists": {"sim.seed": [1, 2], "road.seed": [1]}}), None, "same length"),
    ("sweep_unknown_dist", _sweep({"random": {"n": 2, "params": {"vehicle.params.damping": {"dist": "zorg"}}}}),
     None, "unknown distribution"),
    ("sweep_unknown_key", _sweep({"gird": {"sim.seed": [1]}}), "gird", "unknown key"),
    ("sweep_time_limit_negative", _sweep({"time_limit": -1, "grid": {"sim.seed": [1]}}), "time_limit", ""),
    ("sweep_bad_path", _sweep({"grid": {"vehicle.params.bogus": [1, 2]}}), None, "bogus"),
    ("sweep_bad_value", _sweep({"grid": {"vehicle.params.damping": [1000, "soft"]}}), None, "damping"),
    ("sweep_alias_bomb", BOMB.replace("road: {type: flat}\n", "base: scenario.yaml\n"), None, "alias expansion"),
    ("sweep_n_zero", _sweep({"random": {"n": 0, "params": {"sim.seed": {"dist": "choice", "values": [1]}}}}),
     "random.n", "greater than or equal to 1"),
    ("sweep_seed_inf", _sweep({"seeds": {"count": 2, "start": float("inf")}}), "seeds.start", ""),
]

MODEL_OK = {"model": "quarter_car", "params": {"sprung_mass": 290.0, "unsprung_mass": 59.0}}


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    """A small synthetic quarter-car record (road in, body acceleration and travel out) and broken copies."""
    from suspension_sim.diagnose import truth

    d = tmp_path_factory.mktemp("data")
    rec = truth.simulate_truth("quarter_car", 4, 500, {}, seed=5, road_rms=0.01, noise=0.01,
                               outputs=["body_acc", "susp_travel"])
    df = pd.DataFrame({k: rec[k] for k in ("time", "road", "body_acc", "susp_travel")})
    df.to_csv(d / "ok.csv", index=False)
    (d / "model.yaml").write_text(yaml.safe_dump(MODEL_OK))

    def variant(name, fn, ext="csv"):
        x = df.copy()
        x = fn(x)
        if ext == "csv":
            x.to_csv(d / f"{name}.csv", index=False)
        else:
            x.to_parquet(d / f"{name}.parquet", index=False)

    variant("acc_in_g", lambda x: x.assign(body_acc=x.body_acc / 9.81))
    variant("road_mm", lambda x: x.assign(road=x.road * 1000))
    variant("travel_mm", lambda x: x.assign(susp_travel=x.susp_travel * 1000))
    variant("time_ms", lambda x: x.assign(time=x.time * 1000))
    variant("acc_1e30", lambda x: x.assign(body_acc=x.body_acc * 1e30))
    variant("acc_1e300", lambda x: x.assign(body_acc=x.body_acc * 1e300))
    variant("gravity_in_acc", lambda x: x.assign(body_acc=x.body_acc + 9.81))
    variant("nan", lambda x: x.assign(body_acc=np.where(np.arange(len(x)) == 50, np.nan, x.body_acc)))
    variant("inf", lambda x: x.assign(road=np.where(np.arange(len(x)) == 7, np.inf, x.road)), ext="parquet")
    variant("few_rows", lambda x: x.iloc[:5])
    variant("no_road", lambda x: x.drop(columns=["road"]))
    variant("no_outputs", lambda x: x[["time", "road"]])
    variant("unsorted", lambda x: x.iloc[::-1])
    variant("word", lambda x: x.assign(body_acc=x.body_acc.astype(object).where(np.arange(len(x)) != 9, "n/a?")))
    (d / "decimal_comma.csv").write_text("time;road;body_acc;susp_travel\n" + "".join(
        f"{t:.3f};{r:.6f};{a:.6f};{s:.6f}\n".replace(".", ",") for t, r, a, s in df.itertuples(index=False)))
    (d / "latin1.csv").write_bytes("time,road,body_acc,susp_travel,caf\xe9\n".encode("latin-1") +
                                   df.assign(x=1).to_csv(index=False, header=False).encode())
    (d / "empty.csv").write_text("")
    (d / "binary.csv").write_bytes(b"\x00\x01\x02" * 100)
    (d / "garbage.parquet").write_bytes(b"not parquet at all")
    (d / "garbage.mat").write_bytes(b"MATLAB 5.0 but not really")
    (d / "a_dir.csv").mkdir()
    (d / "model_negative_mass.yaml").write_text(yaml.safe_dump({"model": "quarter_car",
                                                                 "params": {"sprung_mass": -290.0}}))
    (d / "model_bomb.yaml").write_text(BOMB.replace("road: {type: flat}\n", "model: quarter_car\n"))
    (d / "model_latin1.yaml").write_bytes("model: quarter_car\n# caf\xe9\n".encode("latin-1"))
    (d / "model_dup.yaml").write_text("model: quarter_car\nmodel: sdof\n")
    (d / "model_unknown.yaml").write_text(yaml.safe_dump({"model": "tank"}))
    return d


# (id, data file(s), extra options, model file, what the message names, a text of the message)
DATA = [
    ("data_missing", ["nope.csv"], [], "model.yaml", "nope.csv", "not found"),
    ("data_dir", ["a_dir.csv"], [], "model.yaml", "a_dir.csv", "directory"),
    ("data_empty", ["empty.csv"], [], "model.yaml", "empty.csv", "empty"),
    ("data_binary", ["binary.csv"], [], "model.yaml", "binary.csv", "binary"),
    ("data_garbage_parquet", ["garbage.parquet"], [], "model.yaml", "garbage.parquet", "cannot read"),
    ("data_garbage_mat", ["garbage.mat"], [], "model.yaml", "garbage.mat", "cannot read"),
    ("data_latin1", ["latin1.csv"], [], "model.yaml", "latin1.csv", ""),
    ("data_decimal_comma", ["decimal_comma.csv"], [], "model.yaml", "decimal_comma.csv", "decimal comma"),
    ("data_word", ["word.csv"], [], "model.yaml", "word.csv", "is not a number"),
    ("data_nan", ["nan.csv"], [], "model.yaml", "nan.csv", "--nan"),
    ("data_inf", ["inf.parquet"], [], "model.yaml", "inf.parquet", ""),
    ("data_1e30", ["acc_1e30.csv"], [], "model.yaml", "acc_1e30.csv", "body_acc"),
    ("data_1e300", ["acc_1e300.csv"], [], "model.yaml", "acc_1e300.csv", "body_acc"),
    ("data_acc_in_g", ["acc_in_g.csv"], [], "model.yaml", "acc_in_g.csv", "body_acc looks like g, not m/s²"),
    ("data_road_mm", ["road_mm.csv"], [], "model.yaml", "road_mm.csv", "road"),
    ("data_travel_mm", ["travel_mm.csv"], [], "model.yaml", "travel_mm.csv", "looks like mm"),
    ("data_time_ms", ["time_ms.csv"], [], "model.yaml", "time_ms.csv", "ms"),
    ("data_gravity", ["gravity_in_acc.csv"], [], "model.yaml", "gravity_in_acc.csv", "gravity"),
    ("data_few_rows", ["few_rows.csv"], [], "model.yaml", "few_rows.csv", "only 5 samples"),
    ("data_no_road", ["no_road.csv"], [], "model.yaml", "no_road.csv", "missing required column"),
    ("data_no_outputs", ["no_outputs.csv"], [], "model.yaml", "no_outputs.csv", "no output channel"),
    ("data_unsorted", ["unsorted.csv"], [], "model.yaml", "unsorted.csv", "--sort"),
    ("opt_split_zero", ["ok.csv"], ["--split", "0"], "model.yaml", "--split", "between 0 and 1"),
    ("opt_split_big", ["ok.csv"], ["--split", "1.5"], "model.yaml", "--split", "between 0 and 1"),
    ("opt_rows_word", ["ok.csv"], ["--rows", "abc"], "model.yaml", "--rows", "'abc'"),
    ("opt_rows_backwards", ["ok.csv"], ["--rows", "500:100"], "model.yaml", "--rows", "a < b"),
    ("opt_candidates_unknown", ["ok.csv"], ["--candidates", "magic_friction"], "model.yaml", "--candidates",
     "magic_friction"),
    ("opt_map_no_equals", ["ok.csv"], ["--map", "body_acc"], "model.yaml", "--map", "SRC=NAME"),
    ("opt_map_bad_scale", ["ok.csv"], ["--map", "body_acc=body_acc*x"], "model.yaml", "--map", "not a number"),
    ("opt_map_zero_scale", ["ok.csv"], ["--map", "body_acc=body_acc*0"], "model.yaml", "--map", "other than 0"),
    ("opt_map_unknown_column", ["ok.csv"], ["--map", "zz=body_acc"], "model.yaml", "--map", "'zz'"),
    ("opt_fs_negative", ["ok.csv"], ["--fs", "-5"], "model.yaml", "--fs", "> 0"),
    ("opt_nan_word", ["ok.csv"], ["--nan", "maybe"], "model.yaml", "--nan", "error, drop or interp"),
    ("opt_floor_bad", ["ok.csv"], ["--floor", "body_acc=lots"], "model.yaml", "--floor", "CHANNEL=value"),
    ("model_missing", ["ok.csv"], [], "nope.yaml", "nope.yaml", "not found"),
    ("model_negative_mass", ["ok.csv"], [], "model_negative_mass.yaml", "model_negative_mass.yaml",
     "params.sprung_mass: a mass must be > 0"),
    ("model_alias_bomb", ["ok.csv"], [], "model_bomb.yaml", "model_bomb.yaml", "alias expansion"),
    ("model_latin1", ["ok.csv"], [], "model_latin1.yaml", "model_latin1.yaml", "not UTF-8"),
    ("model_duplicate_key", ["ok.csv"], [], "model_dup.yaml", "model_dup.yaml", "duplicate key 'model'"),
    ("model_unknown", ["ok.csv"], [], "model_unknown.yaml", "model_unknown.yaml", "unknown model"),
]


def _check(res, names: list[str], text: str):
    out = res.output if res.stderr is None else res.stderr
    err = (res.stderr or "").strip()
    assert res.exception is None or isinstance(res.exception, SystemExit), repr(res.exception)
    assert "Traceback" not in res.output and "Traceback" not in out
    assert res.exit_code == 2, (res.exit_code, res.output, err)
    assert len(err.splitlines()) == 1, err
    assert err.startswith("error: "), err
    for n in names:
        if n:
            assert n in err, (n, err)
    assert text in err, (text, err)
    return err


class RunStarted(BaseException):
    """Raised by a simulation run inside a fuzz case: a bad input must stop before a run starts.  A BaseException,
    so no ``except Exception`` in the CLI can turn it into an error line.  (diagnose may simulate the nominal model
    to judge a record's units: that is its check, not a run, so the data cases do not use this.)"""


@pytest.fixture
def no_run_starts(monkeypatch):
    """Bad input stops before anything is stepped: a simulation's run raises (no wall-time bound: the machines are
    shared, and a hang is what CI's own time limit catches)."""
    from suspension_sim.simulation import Simulation

    def refuse(*a, **k):
        raise RunStarted("a run started on bad input")

    monkeypatch.setattr(Simulation, "run", refuse)


def _invoke(args, env=None):
    return CliRunner().invoke(app, [str(a) for a in args], env=env)


@pytest.mark.usefixtures("no_run_starts")
@pytest.mark.parametrize("case", SCENARIO_FILES, ids=[c[0] for c in SCENARIO_FILES])
def test_bad_scenario_file(tmp_path, case):
    name, text, field, msg = case
    p = tmp_path / "scenario.yaml"
    (p.write_bytes if isinstance(text, bytes) else p.write_text)(text)
    err = _check(_invoke(["validate", p]), [str(p), f": {field}: " if field else ""], msg)
    assert err


@pytest.mark.usefixtures("no_run_starts")
@pytest.mark.parametrize("case", SET_VALUES, ids=[c[0] for c in SET_VALUES])
def test_bad_set(tmp_path, case):
    name, sets, field, msg = case
    p = tmp_path / "scenario.yaml"
    p.write_text(yaml.safe_dump(BASE))
    args = ["validate", p]
    for s in sets:
        args += ["--set", s]
    res = _invoke(args)
    if name == "set_tag":  # not a safe tag: taken as the text it is, and notes must be text: one line either way
        assert res.exit_code in (0, 2) and "Traceback" not in res.output
        return
    _check(res, [str(p), f": {field}: " if field else ""], msg)


@pytest.mark.usefixtures("no_run_starts")
@pytest.mark.parametrize("case", SWEEPS, ids=[c[0] for c in SWEEPS])
def test_bad_sweep(tmp_path, case):
    name, text, field, msg = case
    (tmp_path / "scenario.yaml").write_text(yaml.safe_dump(BASE))
    p = tmp_path / "sweep.yaml"
    p.write_text(text)
    _check(_invoke(["batch", p, "--out", tmp_path / "out", "-q", "--workers", "1"]),
           [str(p), f": {field}: " if field else ""], msg)
    assert not (tmp_path / "out" / "summary.parquet").exists()


@pytest.mark.parametrize("case", DATA, ids=[c[0] for c in DATA])
def test_bad_data_and_options(data_dir, tmp_path, case):
    name, files, opts, model, names, msg = case
    args = ["diagnose", *[data_dir / f for f in files], "--model", data_dir / model, "--out", tmp_path / "o",
            "--no-confirm", *opts]
    _check(_invoke(args), [names], msg)
    assert not (tmp_path / "o" / "report.json").exists()


OTHER = [
    ("run_directory", lambda t: ["run", t], "directory"),
    ("validate_directory", lambda t: ["validate", t], "directory"),
    ("run_missing", lambda t: ["run", t / "nope.yaml"], "file not found"),
    ("batch_directory", lambda t: ["batch", t, "--out", t / "o"], "directory"),
    ("list_unknown", lambda t: ["list", "gizmos"], "unknown kind"),
    ("view_not_run", lambda t: ["view", t, "--write-only"], "not a run folder"),
    ("compare_not_run", lambda t: ["compare", t, "--out", t / "c"], "not a run folder"),
    ("file_limit", lambda t: ["validate", _big(t)], "SUSPENSION_SIM_LIMIT_FILE_MB"),
]


def _big(t):
    p = t / "big.yaml"
    p.write_text(yaml.safe_dump(BASE) + "# " + "x" * 5_000_000 + "\n")
    return p


@pytest.mark.usefixtures("no_run_starts")
@pytest.mark.parametrize("case", OTHER, ids=[c[0] for c in OTHER])
def test_other_bad_inputs(tmp_path, case):
    name, args, msg = case
    _check(_invoke(args(tmp_path)), [], msg)


def test_corpus_size():
    n = len(SCENARIO_FILES) + len(SET_VALUES) + len(SWEEPS) + len(DATA) + len(OTHER)
    assert n >= 60, n


def test_limits_can_be_raised(tmp_path):
    """The refusal names the environment variable, and setting it lets the input through."""
    p = _big(tmp_path)
    assert _invoke(["validate", p]).exit_code == 2
    res = _invoke(["validate", p], env={"SUSPENSION_SIM_LIMIT_FILE_MB": "50"})
    assert res.exit_code == 0, res.output
    os.environ.pop("SUSPENSION_SIM_LIMIT_FILE_MB", None)
