"""Thesis Ch. 3 (continuous direct MRAC, SDOF rig): load step and dirt-road model following.

The scenario files use the thesis's timing (+150 kg at 20 s, removed at 40 s); the tests run the same
files with the load step at 2 s (and a shorter dirt-road run) to stay fast."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import welch

from scenario_runs import run_variants

G = 9.81


def window(ts, t0, t1, col):
    return ts[col][(ts.t >= t0) & (ts.t < t1)].to_numpy()


@pytest.fixture(scope="module")
def load_step(request):
    repo = request.config.rootpath

    def edit(raw):
        raw["vehicle"]["variations"][0]["times"] = [2.0, 14.0]
        raw["sim"]["duration"] = 14.0

    return run_variants(repo, "thesis_ch3_load_step", edit, variants=("passive", "mrac_thetad", "mrac_thesis"))


def test_passive_sags_by_mg_over_k(load_step):
    sag = -np.mean(window(load_step["passive"], 8, 14, "body_z"))
    assert sag == pytest.approx(150 * G / 5000, rel=0.05)  # 0.294 m


def test_mrac_returns_to_level_with_the_static_force(load_step):
    """The named variant `mrac_thetad` (our static-load parameter θ_d and P1 = (s + 20)², not in the thesis)."""
    ts = load_step["mrac_thetad"]
    z = window(ts, 8, 14, "body_z")  # 6–12 s after the step
    passive_sag = -np.mean(window(load_step["passive"], 8, 14, "body_z"))
    assert abs(np.mean(z)) < 0.1 * passive_sag  # level within a few seconds (thesis: "keeps its level")
    assert abs(np.mean(z)) < 0.03
    force = np.mean(window(ts, 8, 14, "actuator_force"))
    assert force == pytest.approx(150 * G, rel=0.10)  # thesis: mean upward force ≈ 1500 N
    # before the step the actuator carries no static load and the error to the reference is small
    assert abs(np.mean(window(ts, 0.5, 2, "actuator_force"))) < 100
    assert np.sqrt(np.mean(window(ts, 0.5, 2, "ctrl.err") ** 2)) < 0.005
    # the passive car fails both: it sags, and it does not follow the skyhook reference (RMS ≈ 3–4 cm)
    p = load_step["passive"]
    assert np.sqrt(np.mean((window(p, 0.5, 2, "body_z") - window(ts, 0.5, 2, "ctrl.ref_x")) ** 2)) > 0.01


def test_thesis_structure_sags_by_its_static_gain(load_step):
    """The thesis's regulator as printed (P1 = A_m, no static-load term) has the closed loop
    A·R + b0·S = A0·A_m, so a constant load d = −ΔM·g on F_cont leaves x = b0·R(0)·d/(A0·A_m)(0)
    = r1·d/(M·a0·ω_m²) = −3.68 m (r1 = 25 s⁻¹, a0 = 2, ω_m² = 20): the literal law carries the load ≈ 10× worse
    than the passive spring (0.294 m).  Measured ≈ −2.96 m (the adapted gains move r1 a little); the
    variant `mrac_thetad` (θ_d, P1 = (s + 20)²: ours) holds the level.  This pins the page's "not reproduced"
    for the scenario's default (the printed law): a printed law that held its level would fail it."""
    z = np.mean(window(load_step["mrac_thesis"], 8, 14, "body_z"))
    assert -4.0 < z < -2.0
    assert z < 5 * np.mean(window(load_step["passive"], 8, 14, "body_z"))
    assert np.sqrt(np.mean(window(load_step["mrac_thesis"], 0.5, 2, "ctrl.err") ** 2)) < 0.002  # follows before


def test_load_step_body_acceleration_is_low_against_passive_before_the_load(load_step):
    """Fig. 3.7 on the load-step run (page: Ch. 3 load step, "partly"): before the load both laws keep the body
    acceleration below 0.2× the passive car's (the bound of the ch3_adaptation acceleration test; measured 0.12× and
    0.11×, 10 ms samples), which the passive baseline fails.  Under the load only our θ_d variant stays low: the
    printed law's sink to −2.96 m shakes the body at more than half the passive car's acceleration in the 6 s after
    the step (measured 0.60×; `mrac_thetad` 0.20×)."""
    def acc(k, a, b):
        return float(np.sqrt(np.mean(window(load_step[k], a, b, "body_acc") ** 2)))

    p0, p1 = acc("passive", 0.5, 2), acc("passive", 2, 8)
    for k in ("passive", "mrac_thesis", "mrac_thetad"):
        assert (acc(k, 0.5, 2) < 0.2 * p0) == (k != "passive"), k  # the passive baseline fails the bound
    assert acc("mrac_thesis", 2, 8) > 0.5 * p1
    assert acc("mrac_thetad", 2, 8) < 0.25 * p1


def band_ratio(f, P, Pref, lo, hi):
    s = (f >= lo) & (f < hi)
    return float(np.mean(P[s]) / np.mean(Pref[s]))


@pytest.fixture(scope="module")
def dirt(request):
    repo = request.config.rootpath

    def edit(raw):
        raw["sim"]["duration"] = 30.0

    return run_variants(repo, "thesis_ch3_dirt", edit, results=True,
                        variants=("passive", "mrac_thetad", "mrac_thetad_nonadaptive"))


def test_dirt_road_follows_reference_psd_better_than_passive(dirt):
    """Near the 0.71 Hz resonance (0.5–1 Hz) and above it (1–2 Hz) the adaptive body-acceleration PSD is
    closer to the reference model's than the passive one (Parameter variations mode II: +40 % mass,
    −10 % stiffness and damping, unknown to the controller); from 2 to 8 Hz it lies below both the
    passive PSD and (by ≈ 2×) the reference's — better isolation than the reference, reported in
    docs/reproductions/vallurupalli_thesis_1996.md."""
    ts_a, ts_p = dirt["mrac_thetad"].ts, dirt["passive"].ts
    fs = 1.0 / (ts_a.t[1] - ts_a.t[0])
    sel_a, sel_p = ts_a[ts_a.t > 8], ts_p[ts_p.t > 8]
    f, Pref = welch(sel_a["ctrl.ref_acc"].to_numpy(), fs=fs, nperseg=8192)
    _, Pa = welch(sel_a["body_acc"].to_numpy(), fs=fs, nperseg=8192)
    _, Pp = welch(sel_p["body_acc"].to_numpy(), fs=fs, nperseg=8192)
    for lo, hi in ((0.5, 1.0), (1.0, 2.0)):
        da = abs(np.log10(band_ratio(f, Pa, Pref, lo, hi)))
        dp = abs(np.log10(band_ratio(f, Pp, Pref, lo, hi)))
        assert da < dp, (lo, hi, da, dp)
    for lo, hi in ((0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 8.0)):
        assert band_ratio(f, Pa, Pp, lo, hi) < 0.5, (lo, hi)
    # near resonance within a factor 3 of the reference in power (the passive is ≫ 10×)
    assert abs(np.log10(band_ratio(f, Pa, Pref, 0.5, 1.0))) < np.log10(3.0)


def test_frequency_plots_written(dirt, tmp_path, monkeypatch):
    """The run folder's plots (plot_run, as `suspension-sim run` writes them) include the gain factors and
    PSDs against the reference model, one panel per (response, reference) pair; a run without a reference model
    gets none.  The time-domain figures plot_run also builds are not rendered here (``_save`` stubbed:
    ~3/4 of the test's time went to laying out their 20-odd panels; test_plots.py renders and checks them)."""
    from matplotlib.image import imread

    from suspension_sim import plots
    from suspension_sim.plots import plot_run
    from suspension_sim.plots_frequency import frequency_pairs

    pairs = frequency_pairs(dirt)
    assert ("body acceleration", "body_acc", "ctrl.ref_acc", "m/s²") in pairs
    assert ("relative displacement", "travel", "ctrl.ref_travel", "m") in pairs
    monkeypatch.setattr(plots, "_save", lambda fig, path: path)
    names = {p.name: p for p in plot_run(dirt, tmp_path / "both")}
    assert {"gain_factors.png", "psd_reference.png", "controller_signals.png"} <= set(names)
    for k in ("gain_factors.png", "psd_reference.png"):
        assert names[k].stat().st_size > 10000
        assert imread(names[k]).shape[:2] == (round(2.6 * len(pairs) * 110), 1100)  # a 2.6-inch panel per pair
    alone = {p.name for p in plot_run({"passive": dirt["passive"]}, tmp_path / "passive")}
    assert "gain_factors.png" not in alone and "psd_reference.png" not in alone


@pytest.fixture(scope="module")
def adaptation(request):
    def edit(raw):
        raw["sim"]["duration"] = 20.0
        # baseline of test_fast_static_load_law_follows_with_any_gains: thetad_only without θ_d (the printed
        # structure, P1 = (s + 20)², every gain zero, adaptation off)
        raw["variants"]["zero_gains_printed"] = {"controller": {"params": {"p1": 20, "gamma": 0.0,
                                                                           "theta0": [0.0] * 6}}}

    return run_variants(request.config.rootpath, "thesis_ch3_adaptation", edit,
                        variants=("passive", "adaptive", "nonadaptive", "known", "thetad_only", "blowoff_adaptive",
                                  "blowoff_nonadaptive", "zero_gains_printed"))


def rms_follow(ts, ref, a, b):
    m = (ts.t >= a) & (ts.t < b)
    return float(np.sqrt(np.mean((ts.body_z[m].to_numpy() - ref[m.to_numpy()]) ** 2)))


def test_adaptation_from_wrong_gains_reaches_the_reference(adaptation):
    """Thesis Figs. 3.6–3.8: from gains 30 % off, the printed structure and normalised law (γφε/(α + φᵀφ),
    γ = 300) follow the reference within ≈ 15 s (3.0 mm → < 0.2 mm RMS), and Θ moves toward the matching
    line Θ*(a0); the same controller with adaptation off (same start) stays at 3 mm, passive at 40 mm; the
    known-parameter case (the matching design, adaptation off) follows to ≈ 0.51 mm."""
    from suspension_sim.reproductions.thesis import nearest_star, theta_star

    ref = adaptation["adaptive"]["ctrl.ref_x"].to_numpy()
    e = {k: (rms_follow(adaptation[k], ref, 0, 5), rms_follow(adaptation[k], ref, 15, 20))
         for k in ("adaptive", "nonadaptive", "passive", "known")}
    assert e["adaptive"][1] < 0.0003 and e["adaptive"][1] < 0.15 * e["adaptive"][0]
    assert e["nonadaptive"][1] > 0.002 and e["nonadaptive"][1] > 0.8 * e["nonadaptive"][0]  # baseline fails
    assert e["passive"][1] > 0.01
    # performance reaches the known-parameter case (the matching design, adaptation off: ≈ 0.51 mm; the adaptive
    # law goes below it, measured 0.19 mm at 15–20 s), which the non-adaptive baseline does not (≈ 3 mm)
    assert e["adaptive"][1] < e["known"][1] < 0.001
    assert e["nonadaptive"][1] > 3 * e["known"][1]
    star, v = theta_star(250.0, 5000.0, 250.0)
    th = {k: np.array([adaptation[k][f"ctrl.theta.{j}"].iloc[-1] for j in range(5)]) for k in ("adaptive", "nonadaptive")}
    th0 = np.array([adaptation["adaptive"][f"ctrl.theta.{j}"].iloc[0] for j in range(5)])
    d0 = nearest_star(th0, star, v, np.abs(star))[0]
    assert nearest_star(th["adaptive"], star, v, np.abs(star))[0] < 0.8 * d0
    assert nearest_star(th["nonadaptive"], star, v, np.abs(star))[0] == pytest.approx(d0)


def test_body_acceleration_from_wrong_gains_is_low_but_shows_no_pre_adaptation_excess(adaptation):
    """Fig. 3.7's row (page: "partly"): the body acceleration is very low against passive (total, 1 ms log, 5–20 s:
    measured 0.065 against 0.704 m/s²), the passive baseline failing a 0.2× bound; but the thesis's higher
    acceleration before adaptation is not seen: with adaptation off from the same 30 % wrong gains it is higher,
    not lower (0.105 m/s²), in the first 5 s as later, so the low level is the wrong gains' isolation and the
    adaptation only lowers it further.  A run with a pre-adaptation excess (adaptive above adaptation off at 0–5 s)
    would fail it."""
    def acc(k, a, b):
        ts = adaptation[k]
        m = ((ts.t >= a) & (ts.t < b)).to_numpy()
        return float(np.sqrt(np.mean(ts.body_acc.to_numpy()[m] ** 2)))

    pas = acc("passive", 5, 20)
    assert acc("adaptive", 5, 20) < 0.2 * pas and acc("nonadaptive", 5, 20) < 0.2 * pas
    assert acc("adaptive", 0, 5) <= acc("nonadaptive", 0, 5)
    assert acc("adaptive", 5, 20) < 0.8 * acc("nonadaptive", 5, 20)


def test_fast_static_load_law_follows_with_any_gains(adaptation):
    """Why thesis_ch3_load_step's wrong start does not adapt: its fast θ_d law (γ_d = 20000, ours) is a high-gain
    integral action on the augmented error; with every gain zero and adaptation off the loop still follows
    the reference to ≈ 0.1 mm.  Baseline that must fail: the same zero gains without θ_d (measured 4.5 mm, 50×;
    passive 41 mm)."""
    ref = adaptation["adaptive"]["ctrl.ref_x"].to_numpy()
    assert rms_follow(adaptation["thetad_only"], ref, 5, 20) < 0.0003
    assert all(adaptation["thetad_only"][f"ctrl.theta.{j}"].abs().max() == 0 for j in range(5))
    assert rms_follow(adaptation["zero_gains_printed"], ref, 5, 20) > 0.0003  # the baseline fails


def test_adaptation_to_a_plant_that_differs_from_the_design(adaptation):
    """Parameter change unknown to the controller, nominal start: the damper's valve has blown off (C halved from
    0 s; Fig. 2.8's end point).  The printed law moves Θ most of the way to the matching design for C = 125 N·s/m
    and the following error falls ≈ 10×; with adaptation off it stays at ≈ 1.8 mm (run at 0.25 ms physics)."""
    from suspension_sim.reproductions.thesis import nearest_star, theta_star

    ref = adaptation["blowoff_adaptive"]["ctrl.ref_x"].to_numpy()
    ea = rms_follow(adaptation["blowoff_adaptive"], ref, 15, 20)
    en = rms_follow(adaptation["blowoff_nonadaptive"], ref, 15, 20)
    assert en > 0.0015 and ea < 0.2 * en
    star, v = theta_star(250.0, 5000.0, 125.0)
    s = np.abs(theta_star(250.0, 5000.0, 250.0)[0])
    th = adaptation["blowoff_adaptive"]
    d0, d1 = (nearest_star(np.array([th[f"ctrl.theta.{j}"].iloc[i] for j in range(5)]), star, v, s)[0] for i in (0, -1))
    assert d1 < 0.5 * d0


def test_dirt_road_mode_two_passive_sags_adaptive_keeps_level(dirt):
    """Fig. 3.11: with mode II (applied from 0 s, not re-levelled) the passive rig has a static deflection of
    (100·g + 0.1·K*·δ_st)/(0.9·K*) = 0.27 m; the adaptive one keeps its level (through our θ_d)."""
    a, p = dirt["mrac_thetad"].ts, dirt["passive"].ts
    expected = (100 * G + 0.1 * 250 * G) / (0.9 * 5000)
    assert -np.mean(p.body_z[p.t > 8]) == pytest.approx(expected, rel=0.05)
    assert abs(np.mean(a.body_z[a.t > 8])) < 0.01


def test_dirt_road_following_is_the_nominal_design_not_the_adaptation(dirt):
    """A skeptical check of Sec. 3.4 ("adapts to the unknown mode II parameters"): the same controller with the
    Θ adaptation off (γ = 0, nominal Θ, our θ_d kept) keeps the level and follows the reference PSD as closely as
    the adaptive one near resonance (measured 0.66 vs 0.67 of the reference at 0.5–1 Hz, following 1.24 vs
    1.11 mm).  This pins the finding (page: Ch. 3 dirt road); an adaptation that mattered would fail it."""
    ts_a, ts_n = dirt["mrac_thetad"].ts, dirt["mrac_thetad_nonadaptive"].ts
    assert ts_n["ctrl.theta.1"].iloc[-1] == ts_n["ctrl.theta.1"].iloc[0]  # Θ frozen
    fs = 1.0 / (ts_a.t[1] - ts_a.t[0])
    sa, sn = ts_a[ts_a.t > 8], ts_n[ts_n.t > 8]
    f, Pref = welch(sa["ctrl.ref_acc"].to_numpy(), fs=fs, nperseg=8192)
    _, Pa = welch(sa["body_acc"].to_numpy(), fs=fs, nperseg=8192)
    _, Pn = welch(sn["body_acc"].to_numpy(), fs=fs, nperseg=8192)
    for lo, hi in ((0.5, 1.0), (1.0, 2.0)):
        assert abs(np.log10(band_ratio(f, Pn, Pref, lo, hi) / band_ratio(f, Pa, Pref, lo, hi))) < np.log10(1.5)
    assert abs(np.mean(sn.body_z)) < 0.01
    ref = sa["ctrl.ref_x"].to_numpy()
    fa = np.sqrt(np.mean((sa.body_z.to_numpy() - ref) ** 2))
    fn = np.sqrt(np.mean((sn.body_z.to_numpy() - ref) ** 2))
    assert fn < 1.5 * fa


def test_scenario_defaults_are_the_printed_law(request):
    """Issue 12, "literal first": every Ch. 3 and Ch. 5 MRAC runs the thesis's law as printed (P1 = A_m, no
    static-load parameter θ_d) unless a variant named `*thetad*` adds ours."""
    from suspension_sim.config import load_scenario

    repo = request.config.rootpath
    for name in ("thesis_ch3_load_step", "thesis_ch3_dirt", "thesis_ch3_adaptation", "thesis_ch5_nominal",
                 "thesis_ch5_varying"):
        path = repo / "scenarios" / f"{name}.yaml"
        sc = load_scenario(path, [])
        seen = 0
        for vname, v in sc.expand(str(path)):
            if v.controller.type != "thesis_mrac_continuous":
                continue
            prm = v.controller.params
            ours = bool(prm.get("static_level", False)) or prm.get("p1") is not None
            assert ours == ("thetad" in vname), (name, vname, prm)
            seen += not ours
        assert seen, name  # each scenario has the printed law
        if name.startswith("thesis_ch3"):
            assert not sc.controller.params.get("static_level", False) and sc.controller.params.get("p1") is None


def test_dirt_road_printed_law_sinks_and_stops_cleanly(request):
    """Ch. 3 dirt road, the scenario's default (the printed law): under the unknown +100 kg (mode II) it sinks
    past the 5 m displacement limit within ≈ 3 s; the run stops on the divergence check with the time, the state
    and a hint (no crash, no NaN).  The page reports this as the literal result; the variant `mrac_thetad`
    (test_dirt_road_mode_two_passive_sags_adaptive_keeps_level) holds the level on the same road."""
    from suspension_sim.errors import SimulationDiverged

    def edit(raw):
        raw["sim"]["duration"] = 8.0

    for v in ("mrac_thesis", "mrac_thesis_nonadaptive"):
        with pytest.raises(SimulationDiverged) as e:
            run_variants(request.config.rootpath, "thesis_ch3_dirt", edit, variants=(v,))
        assert 1.0 < e.value.time < 6.0, v
        msg = str(e.value)
        assert "diverged at t=" in msg and "Hint:" in msg and "nan" not in msg.lower()
    # (the printed law with the Θ adaptation off, its baseline, sinks the same way: measured 2.89 s against 3.17 s;
    # no Θ of a regulator without a constant term holds the unknown constant load)


@pytest.fixture(scope="module")
def drifts(request):
    """thesis_ch3_adaptation's mode I drift variants at the thesis's timing (60 s; K −20 % over 10–50 s, C halved at
    30 s)."""
    from suspension_sim.errors import SimulationDiverged

    out = run_variants(request.config.rootpath, "thesis_ch3_adaptation", None,
                       variants=("drift_passive", "drift_adaptive_thetad", "drift_nonadaptive_thetad"))
    try:
        out.update(run_variants(request.config.rootpath, "thesis_ch3_adaptation", None, variants=("drift_adaptive",)))
    except SimulationDiverged:  # the printed law's runaway may reach the divergence stop (it does at half the step)
        out["drift_adaptive"] = None
    return out


def test_mode_one_drifts_printed_law_fails_theta_d_holds_but_not_by_adaptation(drifts):
    """Figs. 2.7–2.8 / 3.6, "robust to K(t), C(t)", three findings pinned (page: Ch. 3 adaptation):
    (1) the printed law (P1 = A_m, no static-load term) is not robust: it follows the reference worse than the
    passive car follows it (measured 276 mm against 93.5 mm, 10–60 s) or runs away;
    (2) with our θ_d (named variant) the following is an order of magnitude better than passive (2.27 mm), the
    baseline passive car failing that bound;
    (3) the same with the Θ adaptation off does as well (2.15 mm): the robustness is θ_d's, not the adaptation's
    (the adaptive error is not 0.8× the non-adaptive one or less)."""
    ref = drifts["drift_adaptive_thetad"]["ctrl.ref_x"].to_numpy()
    e = {k: rms_follow(ts, ref, 10, 60) for k, ts in drifts.items() if ts is not None}
    assert "drift_adaptive" not in e or e["drift_adaptive"] > e["drift_passive"], e
    assert e["drift_adaptive_thetad"] < 0.1 * e["drift_passive"], e
    assert e["drift_nonadaptive_thetad"] < 0.1 * e["drift_passive"], e
    assert not e["drift_adaptive_thetad"] < 0.8 * e["drift_nonadaptive_thetad"], e
