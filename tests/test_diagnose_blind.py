"""Findings of the blind battery (benchmarks/blind_battery.py: records from an independent quarter-car truth,
benchmarks/blind_truth.py), kept as fast checks of the search's engine against a truth written here."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from suspension_sim.diagnose.calibrate import Problem
from suspension_sim.diagnose.io import record_from_arrays
from suspension_sim.diagnose.model import load_model
from suspension_sim.errors import ScenarioError

G = 9.81
CAR = {"sprung_mass": 560.0, "unsprung_mass": 68.0, "spring_stiffness": 36000.0, "damping": 2950.0,
       "tire_stiffness": 320000.0, "tire_damping": 0.0}


def _loaded_car(m_true, gap_c, k_stop, k3, duration=3.0, fs=1000.0):
    """A car stated at 560 kg carrying m_true, travel zeroed at the nominal ride height, with a compression
    stop ``gap_c`` below that ride height and a cubic spring term about it (places on the car): scipy, its
    own equations."""
    t = np.arange(int(duration * fs)) / fs
    f = np.array([0.7, 1.3, 2.9, 6.1, 11.0])
    a = 0.012 / np.sqrt(f)

    def road(tt):
        e = min(tt / 0.5, 1.0)
        return e * float(np.sum(a * np.sin(2 * np.pi * f * tt + f))), \
            e * float(np.sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * tt + f)))

    ms0, mu, k, c, kt = (CAR[x] for x in ("sprung_mass", "unsprung_mass", "spring_stiffness", "damping",
                                          "tire_stiffness"))

    def fsusp(s, v):
        return ms0 * G - k * s - c * v - k3 * s ** 3 + (k_stop * (-gap_c - s) if s < -gap_c else 0.0)

    from scipy.optimize import brentq

    s_eq = brentq(lambda s: fsusp(s, 0.0) - m_true * G, -0.5, 0.5)
    zu0 = -(m_true - ms0) * G / kt

    def rhs(tt, x):
        zs, vs, zu, vu = x
        r, rd = road(tt)
        F = fsusp(zs - zu, vs - vu)
        Ft = (ms0 + mu) * G - kt * (zu - r)
        return [vs, F / m_true - G, vu, (Ft - F) / mu - G]

    sol = solve_ivp(rhs, (0, t[-1]), [zu0 + s_eq, 0, zu0, 0], t_eval=t, method="DOP853", rtol=1e-10, atol=1e-12,
                    max_step=1.0 / fs)
    acc = np.array([rhs(tt, sol.y[:, i]) for i, tt in enumerate(t)])
    out = {"body_acc": acc[:, 1], "wheel_acc": acc[:, 3], "susp_travel": sol.y[0] - sol.y[2]}
    return t, np.array([road(tt)[0] for tt in t]), out, s_eq


def _engine_error(t, r, out, effects, m):
    rec = record_from_arrays("quarter_car", t, {"road": r}, out)
    spec = load_model({"model": "quarter_car", "params": dict(CAR), "effects": effects})
    prob = Problem(rec, spec)
    y = prob.simulate(spec, {**spec.P, "sprung_mass": m})
    return {c: float(np.sqrt(np.mean((y[:, i] - out[c]) ** 2)) / np.std(out[c])) for i, c in enumerate(prob.channels)}


def test_a_loaded_car_resting_on_its_stop_is_reproduced_by_the_true_model():
    """A car 25 % heavier than stated sags 38 mm, past its 30 mm compression stop: it rests on the stop.  The
    search's engine with the true mass and the true stop (gap measured from the nominal ride height, where the
    stop is on the car) reproduces the record within 0.5 % on every channel.  Before, a changed mass was
    re-levelled (the run started at the new equilibrium as if it were the nominal ride height), so every
    effect acted about the sagged position: the stop sat 30 mm below the sagged car, and the true model missed
    the record by 25–70 % (blind battery two_heavier_stops: a 0 mm stop, a freed spring and a cubic spring
    named in its place)."""
    m = 1.25 * CAR["sprung_mass"]
    t, r, out, s_eq = _loaded_car(m, 0.030, 150000.0, 0.0)
    assert s_eq < -0.030  # on the stop
    err = _engine_error(t, r, out, [{"type": "bump_stop", "params": {"gap_compression": 0.030, "gap_extension": 1.0,
                                                                      "stiffness": 150000.0}}], m)
    assert max(err.values()) < 0.005, err
    # and without the stop the same car is clearly wrong (the stop matters on this record)
    assert max(_engine_error(t, r, out, [], m).values()) > 0.1


def test_a_loaded_car_with_a_progressive_spring_is_reproduced_by_the_true_model():
    """The same for a cubic spring term written about the nominal ride height: a heavier car sits where the
    spring is stiffer (3·k3·s_eq² more), which the true model now shows (within 0.5 %)."""
    m = 1.25 * CAR["sprung_mass"]
    k3 = 8e6
    t, r, out, s_eq = _loaded_car(m, 10.0, 0.0, k3)
    assert 3 * k3 * s_eq ** 2 > 0.2 * CAR["spring_stiffness"]
    err = _engine_error(t, r, out, [{"type": "cubic_stiffness", "params": {"k3": k3}}], m)
    assert max(err.values()) < 0.005, err


def test_every_engine_of_a_record_levels_the_car_at_the_nominal_masses():
    """A record's engines are built per model structure, the first time a model of that structure is simulated.
    In the search that model often carries fitted masses (a candidate after a round that fitted the mass, or a
    stiff law's finer step): the car was then levelled with the fitted masses, so that structure's models showed
    no sag, and the true model missed this loaded car by 0.55 / 0.39 / 2.67 NRMSE (body acc / wheel acc /
    travel).  The car is levelled with the masses of the model the record was prepared with (the nominal ride
    height), whichever model comes first."""
    m = 1.25 * CAR["sprung_mass"]
    t, r, out, _ = _loaded_car(m, 0.030, 150000.0, 0.0, duration=1.5)
    rec = record_from_arrays("quarter_car", t, {"road": r}, out)
    spec = load_model({"model": "quarter_car", "params": dict(CAR), "effects": [
        {"type": "bump_stop", "params": {"gap_compression": 0.030, "gap_extension": 1.0, "stiffness": 150000.0}}]})
    fitted = spec.copy()
    fitted.P["sprung_mass"] = m
    prob = Problem(rec, spec)
    y = prob.simulate(fitted, fitted.P)  # the first model this record simulates carries the fitted mass
    err = {c: float(np.sqrt(np.mean((y[:, i] - out[c]) ** 2)) / np.std(out[c])) for i, c in enumerate(prob.channels)}
    assert max(err.values()) < 0.005, err


def test_the_replay_of_a_loaded_car_on_its_stop_follows_the_search(tmp_path):
    """``scenario.fitted.yaml`` replays the fitted model through ``suspension-sim run``.  A fitted mass 25 % above
    the stated one, with a known compression stop 30 mm below the nominal ride height: the search starts the car
    at rest on its stop (sagged from the nominal ride height, not re-levelled).  The replay states the masses the
    car was levelled with (``vehicle.levelled_with``), so the CLI run starts there too and follows the search's
    simulated channels within 0.2 %.  Before, the replay gave the fitted mass as a plain parameter and ``run``
    re-levelled the car (the stop 30 mm below the heavier car): 0.57 / 0.34 / 2.37 NRMSE from the search."""
    import pandas as pd
    import yaml
    from typer.testing import CliRunner

    from suspension_sim.cli import app
    from suspension_sim.diagnose.report import build_report
    from suspension_sim.diagnose.select import Selector

    m = 1.25 * CAR["sprung_mass"]
    t, r, out, _ = _loaded_car(m, 0.030, 150000.0, 0.0, duration=2.0)
    rec = record_from_arrays("quarter_car", t, {"road": r}, out)
    spec = load_model({"model": "quarter_car", "params": {**CAR, "sprung_mass": {"value": CAR["sprung_mass"], "free": True}},
                       "effects": [{"type": "bump_stop", "params": {"gap_compression": 0.030, "gap_extension": 1.0,
                                                                     "stiffness": 150000.0}}]})
    D = Selector(rec, spec, max_effects=0).run()
    assert abs(D.final.P["sprung_mass"] - m) < 0.01 * m
    build_report(D, tmp_path / "diag", confirm=True, plots=False)
    sc = yaml.safe_load((tmp_path / "diag" / "scenario.fitted.yaml").read_text())
    assert sc["vehicle"]["levelled_with"]["sprung_mass"] == CAR["sprung_mass"]
    # model.fitted.yaml carries it too, and reads back as a model levelled at the nominal masses
    assert load_model(tmp_path / "diag" / "model.fitted.yaml").level == {"sprung_mass": CAR["sprung_mass"]}
    with pytest.raises(ScenarioError, match="is not a mass or inertia of .quarter_car."):
        load_model({"model": "quarter_car", "levelled_with": {"damping": 1.0}})
    res = CliRunner().invoke(app, ["run", str(tmp_path / "diag" / "scenario.fitted.yaml"), "--out",
                                   str(tmp_path / "run"), "-q", "--set", "outputs.timeseries=true"])
    assert res.exit_code == 0, res.output
    ts = pd.read_parquet(next((tmp_path / "run").rglob("timeseries.parquet")))
    search = D.prob.simulate(D.final.spec, D.final.P)
    for i, c in enumerate(D.prob.channels):
        replay = ts[{"susp_travel": "travel"}.get(c, c)].to_numpy()
        assert len(replay) >= len(search) - 1
        n = min(len(replay), len(search))
        err = np.sqrt(np.mean((replay[:n] - search[:n, i]) ** 2)) / np.std(search[:n, i])
        assert err < 0.002, (c, err)


# ---------------------------------------------------------------------------------------------------------------
# the search on records from the project's own truth generator (diagnose/truth.py)
QC_FREE = {"model": "quarter_car", "params": {"sprung_mass": 290, "unsprung_mass": 59, "spring_stiffness": 16812,
                                              "damping": "free", "tire_stiffness": 190000, "tire_damping": 0}}
QC_OUT = ["body_acc", "wheel_acc", "susp_travel"]


def _truth_record(effects, seed, road_rms, duration=4.0, noise=0.01):
    from suspension_sim.diagnose import truth

    d = truth.simulate_truth("quarter_car", duration, 1000, effects, seed=seed, road_rms=road_rms, noise=noise,
                             outputs=QC_OUT)
    return record_from_arrays("quarter_car", d["time"], {"road": d["road"]}, {c: d[c] for c in QC_OUT}), d


def _test_floor(d):
    """The true noise NRMSE of a record (noisy less clean, over the channel's std), RMS over channels."""
    return float(np.sqrt(np.mean([(np.std(d[c] - d["_clean"][c]) / np.std(d[c])) ** 2 for c in QC_OUT])))


def test_a_stop_the_training_data_never_reach_does_not_act_on_held_out_data():
    """A compression stop only, fitted on a record that never reaches 1.5× its largest extension, and judged on
    a rougher record that does.  The fitted compression stop is right; the extension gap, which the training
    data do not determine, goes to the declared "unseen" place (no stop), so the held-out error reaches the
    noise.  Before, the extension gap stayed where its start put it (1.5× the largest training extension), the
    held-out record ran into that stop, and the true effect was judged no better than the nominal model
    (blind battery stops_suv_comp_only: 0.117 → 0.110 held-out with the stop within 0.3 % of the truth)."""
    from suspension_sim.diagnose.model import load_model
    from suspension_sim.diagnose.select import Selector

    stop = {"bump_stop": {"gap_compression": 0.017, "gap_extension": None, "stiffness": 84000.0}}
    rec, _ = _truth_record(stop, 3, 0.01)
    test, dt = _truth_record(stop, 4, 0.025)
    assert np.max(test.outputs["susp_travel"]) > 1.5 * np.max(rec.outputs["susp_travel"])
    D = Selector(rec, load_model(QC_FREE), test_record=test, candidates=["bump_stop"], max_effects=1,
                 workers=1).run()
    assert [c.name for c, _, _ in D.added] == ["bump_stop"], [(t.name, t.reason) for t in D.trials]
    P = D.final.P
    assert abs(P["bump_stop.gap_compression"] / 0.017 - 1) < 0.05 and abs(P["bump_stop.stiffness"] / 84000 - 1) < 0.1
    assert P["bump_stop.gap_extension"] > np.max(test.outputs["susp_travel"])
    after = np.sqrt(np.mean(np.square(list(D.nrmse(D.final)["test"].values()))))
    assert after < 1.5 * _test_floor(dt), (after, _test_floor(dt))


def test_asymmetric_damping_beside_a_free_damping_is_fitted_as_one_difference():
    """Asymmetric damping adds c_comp / c_reb to the linear damping c: beside a free c the record shows only
    c + c_comp and c + c_reb, so moving all three by the same amount changes nothing (the fit is singular along
    that line).  Before, the three were fitted side by side: each rate's error was inflated far beyond its
    value ("indistinguishable from zero", blind battery two_asym_cubic), or the damping was read as "driven to
    zero" by a stand-in at correlation 1.000 (asym_van_sweep: 0.45 → 0.0225 held-out against a floor of
    0.019, blocked, and a sprung mass named instead, 37× the floor).  The effect declares that it contains
    the linear damping, and beside it the two rates are fitted as one signed difference c_reb − c_comp: the
    damping and the difference are both sharp, and the difference is the effect's size."""
    from suspension_sim.diagnose.calibrate import fit
    from suspension_sim.diagnose.candidates import library
    from suspension_sim.diagnose.model import load_model
    from suspension_sim.diagnose.select import NOT_SEPARABLE, Selector, Trial, _scales, _with_fit

    rec, _ = _truth_record({"asymmetric_damping": {"c_comp": 300.0, "c_reb": 1500.0},
                            "cubic_stiffness": {"k3": 3e7}}, 5, 0.01, duration=3.0)
    sel = Selector(rec, load_model(QC_FREE), max_effects=1, workers=1)
    a, b = sel.train
    nominal = fit(sel.prob, sel.spec, a, b)
    cand = next(c for c in library(sel.spec) if c.name == "asymmetric_damping")
    spec_c, starts = cand.augment(_with_fit(sel.spec, nominal), _scales(sel.prob, sel.spec, nominal.P, b))
    d = "asymmetric_damping.c_reb_minus_c_comp"
    assert "damping" in spec_c.names() and cand.size_names == [d] and cand.contains_free == ["damping"]
    fr = fit(sel.prob, spec_c, a, b, starts=[np.array(x0) for x0 in starts], max_nfev=25)
    P = fr.P
    # both determined while the cubic spring is still missing (before: the damping 0 ± 10 953, each rate ± its
    # value; here 1580 ± 127 and 785 ± 163 N·s/m)
    assert P["damping"] > 4 * fr.std["damping"] and P[d] > 4 * fr.std[d], (P, fr.std)
    assert P[d] > 500 and P["asymmetric_damping.c_reb"] == P[d] and P["asymmetric_damping.c_comp"] == 0.0
    floors = sel.floors()
    tr = Trial("asymmetric_damping", 1, True)
    sel._judge(tr, fr, nominal, sel._test_errors(nominal), np.array([floors[c]["nrmse"] for c in sel.prob.channels]),
               cand.size_names, cand.contains_free)
    assert tr.d_bic < 0 and tr.test_after < 0.9 * tr.test_before
    assert not tr.replaces and not tr.zero_size and NOT_SEPARABLE not in tr.reason, tr.reason


def test_a_damped_bump_stop_is_fitted_with_its_damping():
    """A stop with contact damping (the project's truth, diagnose/truth.py: 50 kN/m and 400 N·s/m while
    engaged, gaps at the 97 % travel quantiles).  Before, the stop's damping was not a fitted parameter: the
    stop came out 14 % soft, its dissipation went into the linear damping, and the held-out error stayed at
    3.4× the floor (blind battery stops_truck_damped: no held-out gain at all, nothing named).  With the
    damping free the stop is found to within a few per cent and the held-out error reaches the noise."""
    from suspension_sim.diagnose.model import load_model
    from suspension_sim.diagnose.select import Selector

    _, d0 = _truth_record({}, 3, 0.012)
    s0 = d0["_clean"]["susp_travel"]
    gc, ge = float(np.quantile(-s0, 0.97)), float(np.quantile(s0, 0.97))
    rec, d = _truth_record({"bump_stop": {"gap_compression": gc, "gap_extension": ge, "stiffness": 50000.0,
                                          "damping": 400.0}}, 3, 0.012)
    D = Selector(rec, load_model(QC_FREE), candidates=["bump_stop"], max_effects=1, workers=1, max_swaps=0).run()
    assert [c.name for c, _, _ in D.added] == ["bump_stop"], [(t.name, t.reason) for t in D.trials]
    after = np.sqrt(np.mean(np.square(list(D.nrmse(D.final)["test"].values()))))
    assert after < 2.0 * _test_floor(d), (after, _test_floor(d))  # before: 0.0339 against 0.0099
    P = D.final.P
    assert abs(P["bump_stop.stiffness"] / 50000 - 1) < 0.05 and abs(P["bump_stop.damping"] / 400 - 1) < 0.1, P
    assert abs(P["bump_stop.gap_compression"] / gc - 1) < 0.02 and abs(P["bump_stop.gap_extension"] / ge - 1) < 0.02


@pytest.mark.slow
def test_an_effect_that_stood_in_for_another_is_exchanged():
    """Asymmetric damping (rebound 2500 N·s/m above a linear 1000, none in compression) and a cubic spring
    (6·10⁷ N/m³), with the damping free.  A bump stop with its extension gap at 0 (an asymmetric spring)
    explains most (round 1's lowest BIC) and is added first.

    With asymmetric damping in the library (fitted beside the free damping as a signed difference), it comes in
    in round 2, the cubic spring in round 3, and the backward check drops the stop: the hidden pair exactly,
    at the noise.  (Before the signed difference, the asymmetric damping could not come in beside the free
    damping and only the exchange step below recovered the pair.)

    Without asymmetric damping in the library (an effect beyond it, as on a blind record), the stop stays the
    best stand-in and the cubic spring no longer improves on it: the forward search ends with the stop and a
    heavier sprung mass.  The exchange step puts the cubic spring in place of the stop (it passes the gate
    against the current model): the hidden spring is named, the stand-in is gone, and the held-out error is
    lower than the search without the exchange leaves it.  About 3 min on an idle 2-core machine: slow."""
    from suspension_sim.diagnose.model import load_model
    from suspension_sim.diagnose.select import Selector

    rec, d = _truth_record({"asymmetric_damping": {"c_comp": 0.0, "c_reb": 2500.0},
                            "cubic_stiffness": {"k3": 6e7}}, 5, 0.015, duration=5.0)

    def test_err(D):
        return float(np.sqrt(np.mean(np.square(list(D.nrmse(D.final)["test"].values())))))

    cands = ["asymmetric_damping", "cubic_stiffness", "bump_stop", "parameter"]
    D = Selector(rec, load_model(QC_FREE), candidates=cands, workers=2).run()
    assert sorted(c.name for c, _, _ in D.added) == ["asymmetric_damping", "cubic_stiffness"], \
        [(t.name, t.reason) for t in D.trials]
    assert test_err(D) < 1.5 * _test_floor(d)
    assert abs(D.final.P["cubic_stiffness.k3"] / 6e7 - 1) < 0.05

    beyond = ["cubic_stiffness", "bump_stop", "parameter"]
    D1 = Selector(rec, load_model(QC_FREE), candidates=beyond, workers=2).run()
    named = {c.name for c, _, _ in D1.added}
    assert any(" in place of bump_stop" in t.name and t.kept for t in D1.trials), \
        [(t.name, t.reason) for t in D1.trials]
    assert "cubic_stiffness" in named and "bump_stop" not in named, named
    # the baseline: the same search without the exchange keeps the stand-in and not the spring
    D0 = Selector(rec, load_model(QC_FREE), candidates=beyond, workers=2, max_swaps=0).run()
    named0 = {c.name for c, _, _ in D0.added}
    assert "bump_stop" in named0 and "cubic_stiffness" not in named0, named0
    assert test_err(D1) < test_err(D0), (test_err(D1), test_err(D0))

@pytest.mark.slow
@pytest.mark.parametrize("name", ["null_sedan_drift", "dahl_sedan_iso", "lag_sedan_jitter_drops"])
def test_blind_battery_sensor_faults_and_a_law_beyond_the_library(name, tmp_path):
    """Records of the blind battery (benchmarks/blind_battery.py, its own truth ODE) that stress what the user's
    model does not state: an accelerometer that drifts (a ramp and a 0.07 Hz wander of 20 % / 10 % of the
    signal's std; the right answer is no effect, the drift left as "unexplained"), a Dahl friction element (a
    hysteretic damper the library does not hold: at most its closest library effect, with the held-out error
    near the noise), and an actuator lag recorded with sample-time jitter (5 % of the step, stamped nominal) and
    six rows lost by the logger (read with ``resample``).  The three: 5 min 10 s at load ~8: slow."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_battery as bb

    r = bb.run_one(name, tmp_path)
    assert r["ok"], (r["named"], r["verdict"])
    if name == "null_sedan_drift":
        assert r["named"] == [] and r["unexplained"], r["verdict"]  # the drift is not explained by any effect
    elif name == "dahl_sedan_iso":
        assert r["named"] in ([], ["hysteresis"], ["coulomb_friction"]), r["named"]
        assert r["after"] < 1.3 * r["floor_true"], (r["after"], r["floor_true"])
    else:
        assert r["named"] == ["actuator_lag"], r["named"]
        # judged on the samples as measured: not below the noise (resampled onto the mean step, the
        # interpolation averaged the noise down and the final error read 0.0166 against a true 0.0199)
        assert 0.9 * r["floor_true"] < r["after"] < 1.3 * r["floor_true"], (r["after"], r["floor_true"])
        assert abs(r["fitted"]["actuator.time_constant"] / r["truth"]["actuator.time_constant"] - 1) < 0.05


_SLOW = pytest.mark.slow


@pytest.mark.parametrize("name", ["coulomb_sedan_short"] + [pytest.param(n, marks=_SLOW) for n in (
    "two_heavier_cubic_own", "stops_sedan_decimated", "asym_sedan_band_body", "null_sedan_scale")])
def test_blind_battery_records_are_named_exactly(name, tmp_path):
    """Records of the blind battery (benchmarks/blind_battery.py, its own truth ODE) named exactly, with the
    held-out error near the true noise: a 3 s record (Coulomb friction, 197 N; 66 s at load 14: the default
    suite's one), and behind ``slow`` a heavier car with a cubic spring whose travel was zeroed where it settled
    (two_heavier_cubic_own: the own zero asked again when the spring joins the freed mass, select._joint_applies;
    before, a 5 / 42 mm stop stood in for the spring at 6.4× the floor), stops on a record its logger decimated
    from 2 kHz to 250 Hz, asymmetric damping under band-limited noise on the body accelerometer only, and a null
    record whose body accelerometer reads 4 % high and travel sensor 3 % low (nothing named; its two gains
    reported as a sensor finding, rule (h))."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_battery as bb

    r = bb.run_one(name, tmp_path)
    assert r["exact"], (r["named"], r["verdict"])
    if name != "null_sedan_scale":  # there the "true floor" (record less truth) holds the gain errors too
        assert r["after"] < 1.3 * r["floor_true"], (r["after"], r["floor_true"])
    else:  # the gains, tried alone for the remainder (rule (h)), are the sensor finding: 1.04 and 0.97
        assert "body_acc reads 4.0 % high" in r["verdict"] and "susp_travel reads 3.0 % low" in r["verdict"] \
            and "wheel_acc reads" not in r["verdict"], r["verdict"]


@pytest.mark.slow
def test_a_wheel_accelerometer_reading_low_beside_a_cubic_spring_is_a_sensor_finding(tmp_path, monkeypatch):
    """Blind battery cubic_sedan_scale_bias: a cubic spring (k3 1.096·10⁷ N/m³) on a sedan whose wheel
    accelerometer reads 4 % low (and is biased).  Without rule (h) (the baseline) the tire stiffness, freed in
    round 2, takes up the gain (235 → 232.2 kN/m) and is named beside the spring.  With it, the tire stiffness
    loses to the same model with a free gain on every output channel by training BIC, the gains are adopted,
    and the spring is named alone, with the wheel channel's gain (0.96) in the verdict as a sensor finding.
    About 1 min per run at load 1, 3.5 min at load 14: slow."""
    import sys
    from pathlib import Path

    from suspension_sim.diagnose.select import Selector

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_battery as bb

    name = "cubic_sedan_scale_bias"
    r = bb.run_one(name, tmp_path / "rule")
    assert r["exact"], (r["named"], r["verdict"])
    assert "wheel_acc reads" in r["verdict"] and "body_acc reads" not in r["verdict"] \
        and "susp_travel reads" not in r["verdict"], r["verdict"]
    assert abs(r["fitted"]["cubic_stiffness.k3"] / r["truth"]["cubic_stiffness.k3"] - 1) < 0.01
    import json

    g = json.loads((tmp_path / "rule" / f"{name}.out" / "report.json").read_text())["sensor_gain"]["gains"]
    assert abs(g["wheel_acc"] - 0.96) < 0.002, g
    monkeypatch.setattr(Selector, "sensor_gain_rule", False)
    r0 = bb.run_one(name, tmp_path / "base")
    assert not r0["exact"] and "parameter:tire_stiffness" in r0["named"], r0["named"]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["digressive_van_iso", "digressive_suv_bumps"])
def test_a_digressive_damper_is_named_with_its_knees_and_ratios(name, tmp_path):
    """Blind battery records with a blow-off damper (benchmarks/blind_truth.py's own law): a van on an ISO D road
    (one knee and ratio for both sides) and an SUV on bumps over a class-B road, its bump valve opening lower and
    softer than its rebound valve (a record the candidate was not shaped on).  digressive_damping is named alone,
    the held-out error is at the noise, each side's knee within 5 % and post-knee ratio within 0.05 of the truth.
    Baseline, the library without the effect: before it, digressive_van_iso named a wide-tanh Coulomb friction
    (1125 N over 0.27 m/s) with the damping cut to 1801 N·s/m, 2.8× the floor; it must not be named exactly and
    must end far above the effect's error."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_battery as bb
    from suspension_sim.diagnose import diagnose
    from suspension_sim.diagnose.candidates import names

    r = bb.run_one(name, tmp_path)
    assert r["named"] == ["digressive_damping"] and r["exact"], (r["named"], r["verdict"])
    assert r["after"] < 1.3 * r["floor_true"], (r["after"], r["floor_true"])
    for side in ("comp", "reb"):
        k, q = f"digressive_damping.v_knee_{side}", f"digressive_damping.ratio_{side}"
        assert abs(r["fitted"][k] / r["truth"][k] - 1) < 0.05, (k, r["fitted"][k], r["truth"][k])
        assert abs(r["fitted"][q] - r["truth"][q]) < 0.05, (q, r["fitted"][q], r["truth"][q])
    # the library without it
    csv, yml, sc = bb.write(name, tmp_path / "without")
    others = [n for n in names() if n != "digressive_damping"] + ["parameter"]
    rep = diagnose(str(csv), str(yml), str(tmp_path / "without" / "out"), confirm=False, plots=False,
                   candidates=others)
    r0 = bb.score(name, rep, sc)
    assert not r0["exact"] and r0["after"] > 1.5 * r["after"], (r0["named"], r0["after"], r["after"])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["stops_sedan_rare_bumps", "stops_suv_rare_potholes"])
def test_rare_events_are_judged_on_a_held_out_part_that_holds_one(name, tmp_path, monkeypatch):
    """A bump stop met only on two bumps (stops_sedan_rare_bumps: at 0.8 and 4.0 s of 8 s) or two potholes
    (stops_suv_rare_potholes: an SUV with Coulomb friction besides) of an otherwise smooth road.  Split by events
    (split.py) the start piece is held out, holding the first event, and every hidden effect is named with the
    held-out error near the noise.  With the last 30 % held out (the old split) neither event is held out and
    nothing is named on the bumps (the baseline); on the potholes the old split named nothing on main 062a0ef
    ("unexplained 6.8×") but names the pair since main cb39a7e (0.0230 held out against 0.0212), so it is no
    baseline there.  Two runs of 2–4 min each per
    record at load ~10–25."""
    import sys
    from pathlib import Path

    from suspension_sim.diagnose.select import Selector

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    import blind_battery as bb

    r = bb.run_one(name, tmp_path / "events")
    assert r["exact"], (r["named"], r["verdict"])
    assert r["after"] < 1.3 * r["floor_true"], (r["after"], r["floor_true"])
    for k in ("gap_compression", "gap_extension"):
        assert abs(r["fitted"][f"bump_stop.{k}"] / r["truth"][f"bump_stop.{k}"] - 1) < 0.05
    if name == "stops_sedan_rare_bumps":
        monkeypatch.setattr(Selector, "event_split", False)
        r0 = bb.run_one(name, tmp_path / "old")
        assert r0["named"] == [], (r0["named"], r0["verdict"])
