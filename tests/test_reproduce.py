"""``suspension-sim reproduce``: the framework on a tiny source (fast), and the Kim and Lin reproductions in
full (slow, ``python -m pytest -m slow tests/test_reproduce.py``)."""
from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from suspension_sim.cli import app
from suspension_sim.reproductions import framework as fw

runner = CliRunner()


def _tiny(ctx):
    """A passive quarter car on the quick-start road for 1 s: its body RMS acceleration is the key number."""
    import matplotlib.pyplot as plt

    sc = ctx.scenario("quickstart", ["sim.duration=1.0"])
    res = ctx.run({k: v for k, v in sc.expand("quickstart") if k == "passive"}, label="tiny")
    a = float(np.sqrt(np.mean(res["passive"].ts.body_acc ** 2)))
    fig, ax = plt.subplots(figsize=(3, 2))
    ax.plot(res["passive"].ts.t, res["passive"].ts.body_acc)
    return fw.ItemOutput([fw.Claim("body acc", "—", f"{a:.3f}", "n.a.")], key={"acc": (a, 0.01)}, figure=fig)


@pytest.fixture
def tiny_source():
    fw.sources()
    src = fw.Source("tiny_test", "A tiny source", "docs/none.md", [fw.Item("one", "One item", _tiny)])
    fw.SOURCES._items["tiny_test"] = src
    yield src
    fw.SOURCES._items.pop("tiny_test", None)


def test_reproduce_writes_figure_table_and_step_halving(tiny_source, tmp_path):
    r = runner.invoke(app, ["reproduce", "tiny_test", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    d = tmp_path / "tiny_test"
    assert (d / "one.png").stat().st_size < 150_000
    md = (d / "README.md").read_text()
    assert "| body acc |" in md and "Step halving" in md
    s = json.loads((d / "summary.json").read_text())["one"]
    conv = s["convergence"]["acc"]
    assert conv["step"] != conv["half_step"]  # the half-step run really ran with another step
    assert conv["converged"] == (conv["change"] < fw.CONVERGENCE_TOL)
    index = (tmp_path / "README.md").read_text()
    assert "[tiny_test](tiny_test/README.md)" in index and "[one](tiny_test/one.md)" in index


def test_step_halving_flags_a_step_dependent_number():
    """A key number that moves by 5 % when the step is halved is reported as not converged."""
    def item(ctx):
        return fw.ItemOutput([], key={"x": (1.0 + 0.1 * ctx.step_factor, 0.01)})

    r = fw.run_item(fw.Item("x", "x", item), converge=True)
    (name, a, b, change), = r["conv"]
    assert change == pytest.approx(0.05 / 1.1) and change > fw.CONVERGENCE_TOL


def test_a_mean_whose_spread_spans_the_bound_is_undecided_not_converged():
    """A statistical key number (value, floor, standard error): Fallah's 5 m near-sgn ideal mean moved 1.9 % with
    0.8 % s.e. of the change (512 realisations) -> "undecided", not a pass; with a small s.e. the same change
    passes, and a change whose whole 1-s.e. band lies above 2 % fails.  A plain key number keeps its rule."""
    def item(se_rel, change):
        def run(ctx):
            v = 2.183 * (1 + change * (ctx.step_factor == 0.5))
            se = se_rel * 2.183 / np.sqrt(2)
            return fw.ItemOutput([], key={"m": (v, 0.05, se), "plain": (1.0 + 0.001 * ctx.step_factor, 0.01)})
        return fw.Item("x", "x", run)

    for se_rel, change, status in ((0.008, 0.019, "undecided"), (0.001, 0.019, "converged"),
                                   (0.004, 0.025, "not converged")):
        r = fw.run_item(item(se_rel, change), converge=True)
        assert r["conv_se"]["m"] == pytest.approx(se_rel, rel=1e-9)
        s = fw.summary(r)["convergence"]
        assert s["m"]["status"] == status and s["m"]["converged"] == (status == "converged")
        assert s["plain"]["converged"] and "status" not in s["plain"]
        md = fw.item_markdown(fw.Source("s", "s", "p", []), fw.Item("x", "x", None), r)
        assert f"Step halving: {'NOT converged' if status == 'not converged' else status}" in md
        assert f"({status})" in md

def test_step_halving_line_names_the_key_that_decides_it():
    """The summary names the worst key by status first: an undecided ensemble mean that moved 27 % (Ch. 4's
    Q ensemble) must not hide a deterministic key that moved 2.5 % and is not converged (the old rule, the largest
    change, named the mean)."""
    def run(ctx):
        return fw.ItemOutput([], key={"mean": (1.0 + 0.54 * (ctx.step_factor == 0.5), 0.01, 1.0),
                                      "level": (1.0 + 0.05 * ctx.step_factor, 0.01)})

    r = fw.run_item(fw.Item("x", "x", run), converge=True)
    line = fw.verdict_row(r)[1]
    assert line.startswith("NOT converged (worst level:"), line
    assert fw.status_summary([("a", 0.3, "undecided"), ("b", 0.01, "converged")]) == "undecided (worst a: 30.0 %)"


def test_half_step_run_halves_the_step_of_every_variant():
    """The convergence run uses exactly half the scenario's physics and control step, variants included."""
    def item(ctx):
        v = ctx.variants("kim_fig2")
        sc = ctx.scenario("lin_fig4")
        return fw.ItemOutput([], key={"dt_kim": (v["kim"].sim.dt, 0.0), "cdt_known": (v["known"].sim.control_dt, 0.0),
                                      "dt_lin": (sc.sim.dt, 0.0)})

    r = fw.run_item(fw.Item("x", "x", item), converge=True)
    for name, a, b, change in r["conv"]:
        assert b == pytest.approx(0.5 * a, rel=1e-12), name
    assert r["out"].key["dt_kim"][0] == pytest.approx(2.5e-5)


def test_reproduce_lists_sources_and_rejects_unknown_ones():
    r = runner.invoke(app, ["reproduce", "--list"])
    assert r.exit_code == 0 and "kim" in r.output and "lin" in r.output
    r = runner.invoke(app, ["reproduce", "nosuch"])
    assert r.exit_code == 2 and "unknown source 'nosuch'" in r.output
    assert "Traceback" not in r.output
    r = runner.invoke(app, ["reproduce", "kim", "--only", "nosuch"])
    assert r.exit_code == 2 and "--only" in r.output


def _verdicts(folder, item):
    return {c["quantity"]: c["verdict"] for c in json.loads((folder / "summary.json").read_text())[item]["claims"]}


@pytest.mark.slow
def test_reproduce_kim(tmp_path):
    r = runner.invoke(app, ["reproduce", "kim", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    d = tmp_path / "kim"
    for png in d.glob("*.png"):
        assert png.stat().st_size < 150_000, png
    s = json.loads((d / "summary.json").read_text())
    # Fig. 3 (k_d = 10, no dF_d/dt) has the large error, Figs. 4–5 track to < 1 %, estimates converge
    assert s["fig3"]["key"]["force_error_adaptive_N"] > 100
    for f in ("fig4", "fig5"):
        assert s[f]["key"]["force_error_adaptive_N"] < 3 and s[f]["key"]["param_error_end"] < 0.02
    # the k_d claim: holds at the scenarios' gain, fails at the 100x smaller one
    k = s["kd_claim"]["key"]
    assert k["a2_error_end_g1e-08_kd10"] < 0.01 and k["a2_error_end_g1e-10_kd10"] > 0.04
    for f in ("fig2", "fig3", "fig4", "fig5", "kd_claim"):  # every key number, Fig. 2's k_d = 10 force error too
        assert all(c["converged"] for c in s[f]["convergence"].values()), f


@pytest.mark.slow
def test_reproduce_lin(tmp_path):
    r = runner.invoke(app, ["reproduce", "lin", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    d = tmp_path / "lin"
    for png in d.glob("*.png"):
        assert png.stat().st_size < 150_000, png
    s = json.loads((d / "summary.json").read_text())
    # the filter reading: the default stays under Fig. 2's 12 m/s² axis, the earlier ε1 = ε = 1.5 spikes past it
    h = s["harshness"]
    assert h["key"]["peak_acc_default"] < 12 and h["key"]["peak_acc_earlier"] > 40
    for f in ("fig2", "fig3", "harshness", "fig4", "fig5", "repeat", "table1"):  # every key number converged (< 2 %)
        assert all(c["converged"] for c in s[f]["convergence"].values()), f
    for f in ("fig4", "fig5"):
        assert s[f]["key"]["dev_adaptive"] < 0.6 * s[f]["key"]["dev_nonadaptive"]
        # three bumps: the adaptive run approaches the known one as θ̂ converges, the non-adaptive one does not
        k = s["repeat"]["key"]
        assert k[f"{f}_dev_adaptive_bump3"] < 0.5 * k[f"{f}_dev_adaptive_bump1"]
        assert k[f"{f}_dev_adaptive_bump3"] < 0.5 * k[f"{f}_dev_nonadaptive_bump3"]


def _reproduce_thesis(tmp_path, items):
    r = runner.invoke(app, ["reproduce", "thesis", "--out", str(tmp_path), "-q"]
                      + [a for it in items for a in ("--only", it)])
    assert r.exit_code == 0, r.output
    d = tmp_path / "thesis"
    for png in d.glob("*.png"):
        assert png.stat().st_size < 150_000, png
    return d, json.loads((d / "summary.json").read_text())


# the thesis in two tests: the Ch. 4 load step (RK4 at 0.0625 ms with its ensemble at both steps) costs as
# much as every other item together, and either half can be run on its own
THESIS_CH4_LOAD_STEP = "ch4_load_step"


@pytest.mark.slow
def test_reproduce_thesis(tmp_path):
    items = [it.name for it in fw.sources()["thesis"].items if it.name != THESIS_CH4_LOAD_STEP]
    d, s = _reproduce_thesis(tmp_path, items)
    assert set(s) == set(items)
    k3 = s["ch3_load_step"]["key"]
    # the printed structure sags metres; the θ_d variant holds the level; passive sags m·g/K
    assert k3["thesis_sag"] < -2.0 and abs(k3["mrac_level"]) < 0.01 and k3["passive_sag"] < -0.28
    # Ch. 3 adaptation: from 30 % wrong gains the printed law follows to < 0.2 mm, adaptation off stays ≈ 3 mm
    ka = s["ch3_adaptation"]["key"]
    assert ka["follow_adaptive_40_60"] < 2e-4 < 2e-3 < ka["follow_nonadaptive_40_60"]
    assert s["ch3_dirt"]["key"]["passive_level"] < -0.2 and abs(s["ch3_dirt"]["key"]["mrac_level"]) < 0.01
    # Ch. 5: no pair of SOC weights gives all of the thesis's nominal sub-claims
    assert s["ch5"]["key"]["sweep_all_hits"] == 0
    # Ch. 4 dirt road: every key number converged with RK4 and the friction's mean over each step, the bias estimate
    # of the law with our bias without the delay included (with implicitfast it drifted with the step, the page);
    # without the delay the printed law (no bias) is closer to the reference than passive at 0.5–4 Hz (partly), the
    # law with our bias is not (it attenuates far below the reference at 0.25–1 Hz)
    cd = s["ch4_dirt"]["convergence"]
    assert all(c["converged"] for c in cd.values()), cd
    vd = _verdicts(d, "ch4_dirt")
    assert vd[next(k for k in vd if k.startswith("without the loop delay"))] == "partly"
    assert vd[next(k for k in vd if "mrac_bias_no_delay" in k)] == "not"
    k7 = s["ch7_braking"]["key"]
    assert k7["asym_mrac_bounce"] < 0.1 * k7["asym_passive_bounce"]
    assert k7["mrac_pitch_deg"] < 0.2 * k7["passive_dive_deg"]
    k6 = s["ch6"]["key"]
    assert k6["random_acc"] > 2.0 * 0.47  # body acceleration ≈ 4× passive on the random road (not reproduced)
    for item in ("ch3_load_step", "ch3_adaptation", "ch3_dirt", "ch5", "ch6", "ch7_braking", "ch7_road", "ch7_dirt"):
        assert all(c["converged"] for c in s[item]["convergence"].values()), item


@pytest.mark.slow
def test_reproduce_thesis_ch4_load_step(tmp_path):
    d, s = _reproduce_thesis(tmp_path, [THESIS_CH4_LOAD_STEP])
    # Ch. 4, the printed law: the static force is carried, the level only partly recovered (friction lock); the
    # estimates from a wrong design join the right start's with our bias, not with the printed law
    k4 = s["ch4_load_step"]["key"]
    assert 0.02 < abs(k4["mrac_level"]) < 0.5 * abs(k4["off_level"])
    assert abs(k4["mrac_force"] - 150 * 9.81) < 200 and k4["wrong_bias_theta_gap_60s"] < 0.25
    assert k4["wrong_theta_gap_60s"] > 0.3  # the printed law's: not even half of the initial 0.59 closed
    # Ch. 4 step halving (RK4 at 0.0625 ms): every deterministic key converged, the wrong design's level and following
    # too (they wandered with implicitfast's step, the page), the remaining Θ gap compared against its initial value.
    # The chaotic Q variant's ensemble means, medians and fraction past the stops are statistical keys (with the
    # standard error of their change); only the medians of force and following are decided at 256 runs per step:
    # with the stops and orifice damper held over each step the force's whole distribution moved up ≈ 100 N on
    # halving (median 1438 ± 27 -> 1561 ± 22 N, 64 runs); with their means (the scenario's setting) 1469 ± 9 -> 1465 ±
    # 15 N and 19.22 -> 19.10 mm, converged (measured in chunks, the page); the means, the level median and the stop
    # fraction stay undecided (≈ 10³–10⁵ runs would bound them)
    c4 = s["ch4_load_step"]["convergence"]
    q = [k for k in c4 if k.startswith("q_ensemble_")]  # means, medians and the fraction past the stops
    assert len(q) == 7
    assert all(c["converged"] for k, c in c4.items() if k not in q), c4
    assert all(c4[k]["change_se"] > 0 and "status" in c4[k] for k in q), c4
    assert c4["q_ensemble_median_force"]["status"] == "converged", c4["q_ensemble_median_force"]


def test_run_keeps_each_scenarios_sensor_noise():
    """Scenarios that differ only in sensor noise must not share an ensemble (the loop takes the sensor
    pipeline from the first car): the noisy run equals the same scenario run alone, and differs from the
    clean one."""
    from suspension_sim.simulation import Simulation

    ctx = fw.Context()
    clean = ctx.variants("quickstart", ["sim.duration=0.3"], only=["skyhook"])["skyhook"]
    noisy = clean.model_copy(deep=True)
    for s in noisy.sensors:
        s.noise_std = 0.5
    res = ctx.run({"clean": clean, "noisy": noisy})
    alone = Simulation([noisy]).run()[0]
    np.testing.assert_allclose(res["noisy"].ts.body_acc, alone.ts.body_acc, rtol=0, atol=1e-12)
    assert np.abs(res["noisy"].ts.body_acc - res["clean"].ts.body_acc).max() > 1e-3


@pytest.mark.slow
def test_reproduce_fallah(tmp_path):
    r = runner.invoke(app, ["reproduce", "fallah", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "fallah" / "summary.json").read_text())
    dlc = {c["quantity"].split(",")[0]: c["verdict"] for c in s["dlc"]["claims"]}
    assert any(v == "not" for k, v in dlc.items() if "total lateral" in k)
    # the paper's ±10 % sprung mass with the nominal design: the comfort gain holds (each mass against its passive car)
    assert s["mass"]["claims"][0]["verdict"] == "reproduced"
    assert all(v < 0.8 for k, v in s["mass"]["key"].items() if k.endswith(("_0.9", "_1.1")))
    for item in ("bump", "dlc", "mass", "bang_bang"):
        assert (tmp_path / "fallah" / f"{item}.png").stat().st_size < 150_000
        # issue 12 item 3: every key number changes by < 2 % on halving (a mean over realisations: change + 1 s.e.)
        bad = {k: c for k, c in s[item]["convergence"].items() if not c["converged"]}
        assert not bad, (item, bad)
    # the near-sgn rows at their converged 0.25 ms physics step (at 0.5 ms the 5 m ideal mean moved 2.3 %)
    assert [0.00025, 0.001] in s["bang_bang"]["steps"] and [0.0005, 0.001] in s["bang_bang"]["steps"]


@pytest.mark.slow
def test_reproduce_toscano(tmp_path):
    r = runner.invoke(app, ["reproduce", "toscano", "--out", str(tmp_path), "-q"])
    assert r.exit_code == 0, r.output
    s = json.loads((tmp_path / "toscano" / "summary.json").read_text())
    for item in ("constant", "varying", "nonlinear"):  # every key number converged (< 2 %)
        assert all(c["converged"] for c in s[item]["convergence"].values()), item
    assert s["varying"]["claims"][0]["verdict"] in ("partly", "not")
    # the baselines fail: adaptation off (constant) and frozen at the true means (varying) do not follow
    assert all(c["verdict"] == "reproduced" for c in s["constant"]["claims"] + s["varying"]["claims"]
               if c["quantity"].startswith("the adaptation is what"))
    for item in ("constant", "varying"):
        assert (tmp_path / "toscano" / f"{item}.png").stat().st_size < 150_000


def test_step_halving_text_says_what_was_halved():
    """The page's step-halving line is read from the steps both runs used: both halved, or the physics step only
    when an item holds its control step (the thesis's discrete laws)."""
    def item(held):
        def run(ctx):
            sc = ctx.scenario("toscano_constant", ["sim.duration=0.01"])
            if held:
                sc.sim.control_dt = sc.sim.control_dt / ctx.step_factor
            ctx.run({"c": sc})
            return fw.ItemOutput([], key={"one": (1.0, 1.0)})
        return run

    for held, text in ((False, "physics and control steps are both halved"),
                       (True, "physics step is halved (the control step is held)")):
        it = fw.Item("x", "x", item(held))
        r = fw.run_item(it, converge=True)
        md = fw.item_markdown(fw.Source("s", "s", "p", [it]), it, r)
        assert text in md, md
