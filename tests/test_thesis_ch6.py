"""Thesis Ch. 6: MDOF continuous adaptive control of the 2-DOF bounce model (two actuators): tracking of
the dual-skyhook reference's two rattle spaces on bumps and on a random road; the two_dof model's
actuator polarity."""
from __future__ import annotations

import numpy as np
import pytest

from suspension_sim.config import parse_scenario, read_yaml
from suspension_sim.simulation import Simulation
from scenario_runs import run_variants


def rms_err(ts, ref, col):
    return float(np.sqrt(np.mean((ts[col] - ref) ** 2)))


def _hold(level):
    """A constant command on the rig, in the Python loop: static loads and polarities are the plant's, and the
    compiled loop would compile a loop (two-DOF rig, open loop) no other test uses, 10-15 CPU-s on a cold
    compile cache against ~1 CPU-s for these 3 s in the Python loop."""
    sc = parse_scenario({"name": "t", "vehicle": {"model": "two_dof"}, "road": {"type": "flat"},
                         "controller": {"type": "open_loop", "params": {"signal": "constant", "amplitude": level}},
                         "sim": {"duration": 3.0, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001}})
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SUSPENSION_SIM_COMPILED", "0")
        return Simulation([sc]).run()[0]


def test_two_dof_static_loads_and_actuator_polarity():
    """Static loads of the two stages and the sign of each actuator: u_s > 0 lifts the body off the primary
    mass (an internal force: the primary stage's load is unchanged), u_p > 0 lifts the primary mass (and
    the body riding on it) off the ground."""
    r = _hold([100.0, 0.0])
    assert r.info["static_suspension_force"]["_secondary"] == pytest.approx(85 * 9.81, rel=1e-6)
    assert r.info["static_suspension_force"]["_primary"] == pytest.approx(89.5 * 9.81, rel=1e-6)
    late = r.ts[r.ts.t > 1.0]
    assert late.travel_secondary.mean() == pytest.approx(100 / 31500, rel=0.2)
    assert abs(late.travel_primary.mean()) < 0.1 * 100 / 8700
    late = _hold([0.0, 100.0]).ts
    late = late[late.t > 1.0]
    assert late.travel_primary.mean() == pytest.approx(100 / 8700, rel=0.2)
    assert abs(late.travel_secondary.mean()) < 0.1 * 100 / 31500


def _sine_only_passive_and_adaptive(raw):
    raw["sim"].update(duration=8.0)
    raw["variants"] = {k: raw["variants"][k] for k in ("passive", "adaptive")}


@pytest.mark.parametrize("name,edit", [
    ("thesis_ch6_bump", None),
    ("thesis_ch6_sine", _sine_only_passive_and_adaptive),
    ("thesis_ch6_random", lambda raw: raw["sim"].update(duration=8.0)),
])
def test_adaptive_tracks_both_reference_rattle_spaces(request, name, edit):
    """The MDOF law follows both reference rattle spaces better than the passive car (the baseline that fails).
    This is a property of the law's structure, not of its adaptation: with α = β = 0 (nominal gains) the bump and
    sine runs pass it too (page, Ch. 6 table); the adaptation claim is tested through the drifts in
    test_sine_adaptation_holds_the_tracking_through_the_mode_i_drifts, where the non-adaptive law fails."""
    out = run_variants(request.config.rootpath, name, edit, variants=("passive", "adaptive"))
    ad, pa = out["adaptive"], out["passive"]
    for k, col in enumerate(("travel_secondary", "travel_primary")):
        ref = ad[f"ctrl.ref_z.{k}"]
        e_ad, e_pa = rms_err(ad, ref, col), rms_err(pa, ref, col)
        assert e_ad < 0.7 * e_pa, (name, col, e_ad, e_pa)


def test_printed_laws_run_away_at_the_first_bump_edge(request):
    """Literal first: the scenario default (variant adaptive_thesis) is the thesis's laws as printed (Eq. 6.67: no
    normalisation, no σ-leakage, no gain bound).  The ẅ impulse at the first bump's edge (1.0 s) drives them away
    within a few control steps (measured stop 1.003 s); our variant adaptive (normalised, σ = 0.2 s⁻¹, bound 1×),
    the baseline here, runs through the same bump."""
    from suspension_sim.errors import SimulationDiverged

    runs = {k: s for k, s in parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch6_bump.yaml"))
            .expand() if k in ("adaptive_thesis", "adaptive")}
    for s in runs.values():
        s.sim.duration = 1.5
    with pytest.raises(SimulationDiverged) as ei:
        Simulation([runs["adaptive_thesis"]]).run()
    assert 1.0 <= ei.value.time < 1.05, ei.value.time
    ts = Simulation([runs["adaptive"]]).run()[0].ts  # ours runs through the bump
    assert ts.t.iloc[-1] > 1.45 and float(np.max(np.abs(ts.body_z))) < 0.1


def test_sine_adaptation_holds_the_tracking_through_the_mode_i_drifts(request):
    """Thesis Sec. 6.8: the reference response is achieved irrespective of the parameter variations.  On the
    sines with the mode I drifts (springs −20 % from 4 to 20 s, the secondary damper −50 % at 12 s) the adaptive
    law's secondary rattle-space error does not grow, while with adaptation off (α = β = 0, the baseline) it
    grows by more than 20 %, and the passive car's error is larger still."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch6_sine.yaml"))
    runs = {k: v for k, v in sc.expand() if k in ("passive", "adaptive")}
    runs["nonadaptive"] = runs["adaptive"].model_copy(deep=True)
    runs["nonadaptive"].controller.params.update({"alpha": 0.0, "beta": 0.0})
    ts = {k: Simulation([s]).run()[0].ts for k, s in runs.items()}
    ref = ts["adaptive"]["ctrl.ref_z.0"]

    def err(k, t0, t1):
        t = ts[k]
        m = (t.t >= t0) & (t.t < t1)
        return rms_err(t[m], ref[m], "travel_secondary")

    b = {k: err(k, 1, 4) for k in ts}
    a = {k: err(k, 14, 24) for k in ts}
    assert a["adaptive"] < 1.1 * b["adaptive"], (b, a)
    assert a["nonadaptive"] > 1.2 * b["nonadaptive"], (b, a)  # the baseline fails the claim
    assert a["adaptive"] < 0.5 * a["nonadaptive"] and a["passive"] > 2 * a["adaptive"]


def test_random_road_acceleration_comes_from_the_kv_drift(request):
    """Why the random-road body acceleration is ~20× the reference (page, Ch. 6): with the nominal gains the
    secondary force cancels the primary mass's motion (row 0 of K_v is [M_s·2ζω − C_s, M_s·2ζω], so a primary
    motion δ gives u_s = −C_s·δ̇, the secondary damper's own change); the integral K_v law rectifies the primary's
    50–80 Hz rattle (Θ and Ė at the same frequency) into a drift of K_v,00 − K_v,01 that breaks the cancellation,
    and the secondary actuator passes the rattle to the body.  Adaptation off (the baseline) keeps −C_s exactly
    and the reference's acceleration."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch6_random.yaml"))
    runs = dict(sc.expand())
    runs["nonadaptive"] = runs["adaptive"].model_copy(deep=True)
    runs["nonadaptive"].controller.params.update({"alpha": 0.0, "beta": 0.0})
    out = {}
    for k in ("adaptive", "nonadaptive"):
        runs[k].sim.duration = 6.0
        out[k] = Simulation([runs[k]]).run()[0].ts
    cs = 100.0
    for k, ts in out.items():
        late = ts[ts.t > 4]
        out[k] = (float((late["ctrl.kv.0"] - late["ctrl.kv.1"]).mean()),
                  float(np.sqrt(np.mean(late.body_acc ** 2))), float(np.sqrt(np.mean(late["ctrl.ref_acc"] ** 2))))
    d_ad, acc_ad, ref = out["adaptive"]
    d_na, acc_na, _ = out["nonadaptive"]
    assert d_na == pytest.approx(-cs, abs=1e-6) and acc_na < 1.5 * ref
    assert d_ad > 30 * cs and acc_ad > 10 * ref


def test_structure_preserving_law_gives_the_reference_acceleration(request):
    """Ours, not the thesis's (variant adaptive_structured): adapting row 0 of K_p and K_v as one keeps the
    nominal cancellation of the primary's motion; on the random road the body acceleration is then the
    reference's while the secondary rattle-space error is still below the non-adaptive one (adaptation
    exercised).  The entry-wise laws of variant adaptive (ours normalised) fail the acceleration bound."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch6_random.yaml"))
    runs = dict(sc.expand())
    runs["nonadaptive"] = runs["adaptive"].model_copy(deep=True)
    runs["nonadaptive"].controller.params.update({"alpha": 0.0, "beta": 0.0})
    res = {}
    for k in ("adaptive_structured", "adaptive", "nonadaptive"):
        runs[k].sim.duration = 8.0
        ts = Simulation([runs[k]]).run()[0].ts
        ts = ts[ts.t > 0.5]
        res[k] = (float(np.sqrt(np.mean(ts.body_acc ** 2))), rms_err(ts, ts["ctrl.ref_z.0"], "travel_secondary"),
                  float(np.sqrt(np.mean(ts["ctrl.ref_acc"] ** 2))))
    acc_st, e_st, ref = res["adaptive_structured"]
    assert acc_st < 1.5 * ref and res["adaptive"][0] > 5 * ref
    assert e_st < 0.8 * res["nonadaptive"][1]


def test_adaptation_from_a_wrong_design_improves_the_following(request):
    """Adaptation exercised from a stated wrong start (ours; the thesis gives no initial gains): the controller's
    nominal K_s −30 %, K_p +30 %, C_s +30 %, C0_p −30 % on the sine rig without drifts (variants wrong_design*; the
    reference keeps the thesis's K_ms, K_mp).  Both rattle-space errors fall by more than 15 % from 1–4 s to 14–24 s
    (measured 2.51 → 1.91, 2.75 → 2.20 mm) and end below 0.7× the same wrong design with adaptation off, which does
    not improve (3.57 → 3.49, 3.64 → 3.56 mm: the baseline fails)."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch6_sine.yaml"))
    ts = {k: Simulation([s]).run()[0].ts for k, s in sc.expand() if k in ("wrong_design", "wrong_design_nonadaptive")}

    def err(t, j, a, b):
        m = ((t.t >= a) & (t.t < b)).to_numpy()
        col = ("travel_secondary", "travel_primary")[j]
        return float(np.sqrt(np.mean((t[col].to_numpy() - t[f"ctrl.ref_z.{j}"].to_numpy())[m] ** 2)))

    for j in (0, 1):
        ad0, ad1 = err(ts["wrong_design"], j, 1, 4), err(ts["wrong_design"], j, 14, 24)
        na0, na1 = err(ts["wrong_design_nonadaptive"], j, 1, 4), err(ts["wrong_design_nonadaptive"], j, 14, 24)
        assert ad1 < 0.85 * ad0, (j, ad0, ad1)
        assert not na1 < 0.85 * na0, (j, na0, na1)  # the baseline fails the same bound
        assert ad1 < 0.7 * na1, (j, ad1, na1)


def _errs(ts, a, b):
    """(secondary, primary) rattle-space error RMS in [a, b) to the run's reference (the same reference in every
    run: the wrong design keeps the thesis's K_ms, K_mp through ref_*)."""
    m = ((ts.t >= a) & (ts.t < b)).to_numpy()
    return tuple(float(np.sqrt(np.mean((ts[c].to_numpy() - ts[f"ctrl.ref_z.{j}"].to_numpy())[m] ** 2)))
                 for j, c in enumerate(("travel_secondary", "travel_primary")))


WITHIN = 1.2  # "convergence independent of the initial values" (Sec. 6.9): late error within 20 % of the right design's


def _wrong_start(root, name, wrong, edit=None):
    def ed(raw):
        if edit:
            edit(raw)
    return run_variants(root, name, ed, variants=("adaptive", wrong, wrong + "_nonadaptive"))


def test_wrong_start_on_the_random_road_reaches_the_right_design(request):
    """Thesis Sec. 6.9: "the convergence of the adaptive scheme is independent of the initial values".  On the
    random road (the scenario's 20 s) from the stated wrong design (K_s −30 %, K_p +30 %, C_s +30 %, C0_p −30 %) the
    secondary rattle-space error at 12–20 s is within 20 % of the right design's (measured 0.42 vs 0.36 mm), while
    the same wrong design with adaptation off (the baseline) is not (0.88 mm).  (The primary error sits at 1.2× the
    right design's, the page's "partly"; the body acceleration is the entry-wise laws' K_v drift,
    test_random_road_acceleration_comes_from_the_kv_drift.)"""
    ts = _wrong_start(request.config.rootpath, "thesis_ch6_random", "wrong_design")
    e = {k: _errs(t, 12, 20) for k, t in ts.items()}
    assert e["wrong_design"][0] <= WITHIN * e["adaptive"][0], e
    assert e["wrong_design_nonadaptive"][0] > WITHIN * e["adaptive"][0], e  # the baseline fails it
    assert e["wrong_design"][1] < 0.8 * e["wrong_design_nonadaptive"][1], e


def test_wrong_start_on_the_bump_is_not_a_test_of_adaptation(request):
    """Bump run (mode I drifts): from the stated wrong design the adaptive errors at the last bump (9–12 s) are
    within 20 % of the right design's (measured 1.85 / 1.81 vs 2.62 / 2.32 mm), but the same wrong design with
    adaptation off is at 1.10× / 1.21× (2.87 / 2.79 mm): on the bump the error is set by the primary's friction and
    the drifts, not by the initial design, so the baseline passes the secondary bound too and the bump cannot show
    the claim.  This pins the page's "not shown"; a bump on which the wrong design mattered would fail the last
    assertion."""
    ts = _wrong_start(request.config.rootpath, "thesis_ch6_bump", "wrong_design")
    e = {k: _errs(t, 9, 12) for k, t in ts.items()}
    for j in (0, 1):
        assert e["wrong_design"][j] <= WITHIN * e["adaptive"][j], e
    assert e["wrong_design_nonadaptive"][0] <= WITHIN * e["adaptive"][0], e


def _bump_fall(ts, k):
    """(secondary, primary) error at the fifth bump (9–11 s) / at the first (1–3 s), to the adaptive run's reference
    (the same in every run)."""
    ref = ts["adaptive"]

    def e(a, b):
        m = ((ts[k].t >= a) & (ts[k].t < b)).to_numpy()
        return np.array([float(np.sqrt(np.mean((ts[k][c].to_numpy() - ref[f"ctrl.ref_z.{j}"].to_numpy())[m] ** 2)))
                         for j, c in enumerate(("travel_secondary", "travel_primary"))])
    return e(9, 11) / e(1, 3)


def _edge_peak(t, b):
    """max |body acceleration| at the edge of bump b (it starts at 1 + 2b s): −0.02 … +0.5 s."""
    m = ((t.t >= 1 + 2 * b - 0.02) & (t.t < 1 + 2 * b + 0.5)).to_numpy()
    return float(np.max(np.abs(t.body_acc.to_numpy()[m])))


def test_a_second_bump_after_adaptation_is_followed_more_closely(request):
    """Where adaptation matters on the bump (thesis Sec. 6.8: "as the time of adaptation increases, the adaptive
    controlled system follows the reference model more closely"): the five bumps without the drifts, from the stated
    wrong design (variant wrong_design_nodrift).  Both rattle-space errors at the fifth bump are ≤ 0.9× the first's
    (measured 0.85× / 0.86×) while the same wrong design with adaptation off (the baseline) fails it (1.00×).  The
    price (the page's "partly"): the adapted feedforward laws sharpen the bump edges, the body-acceleration peak at
    the fifth edge is above 5× the baseline's (measured ≈ 22 vs 1.8 m/s²; the reference's 1.84)."""
    ts = run_variants(request.config.rootpath, "thesis_ch6_bump",
                      variants=("adaptive", "wrong_design_nodrift", "wrong_design_nodrift_nonadaptive"))
    fall, base = _bump_fall(ts, "wrong_design_nodrift"), _bump_fall(ts, "wrong_design_nodrift_nonadaptive")
    assert np.all(fall <= 0.9), fall
    assert np.any(base > 0.9), base  # the baseline fails it
    assert _edge_peak(ts["wrong_design_nodrift"], 4) > 5 * _edge_peak(ts["wrong_design_nodrift_nonadaptive"], 4)


def test_bump_error_grows_through_the_drifts_with_and_without_adaptation(request):
    """Fig. 6.13 (the bump with the mode I drifts): the drift claim the sines reproduce (error growth < 10 % while
    the baseline's grows > 20 %) is not reproduced on the bump: the adaptive secondary error grows from the first to
    the fifth bump by more than 50 % (measured 1.73 → 3.18 mm, ×1.84), the baseline's (adaptation off) by more
    (×2.19); adaptation only lowers the fifth bump's error (below 0.85× the baseline's).  Pins the page's "not"."""
    ts = run_variants(request.config.rootpath, "thesis_ch6_bump", variants=("adaptive",))
    ts["nonadaptive"] = run_variants(request.config.rootpath, "thesis_ch6_bump", variants=("adaptive",),
                                     edit=lambda raw: raw["controller"]["params"].update(alpha=0.0, beta=0.0))["adaptive"]
    g_ad, g_na = _bump_fall(ts, "adaptive")[0], _bump_fall(ts, "nonadaptive")[0]
    assert g_ad > 1.5 and g_na > g_ad, (g_ad, g_na)
    late = {k: _errs(ts[k], 9, 11)[0] for k in ts}
    assert late["adaptive"] < 0.85 * late["nonadaptive"], late


def test_smaller_leakage_sharpens_the_bump_edges(request):
    """Why the scenarios keep σ = 0.2 s⁻¹ (ours; the thesis prints no leakage) although σ = 0.02 closes the wrong
    start's gap on the sines (test_leakage_holds_the_gap_to_the_right_design): on the bump with the drifts, from the
    wrong start, σ = 0.02 lowers the fifth bump's secondary error (measured 1.91 vs 2.26 mm) but raises the
    body-acceleration peak at the fifth bump edge by more than 1.4× (measured 44 vs 26 m/s², the reference's 1.84)."""
    ts = run_variants(request.config.rootpath, "thesis_ch6_bump",
                      variants=("adaptive", "wrong_design", "wrong_design_sigma002"))
    late = {k: _errs(ts[k], 9, 11)[0] for k in ("wrong_design", "wrong_design_sigma002")}
    assert late["wrong_design_sigma002"] < 0.9 * late["wrong_design"], late
    assert _edge_peak(ts["wrong_design_sigma002"], 4) > 1.4 * _edge_peak(ts["wrong_design"], 4)


def test_wrong_start_through_the_drifts_on_the_sines(request):
    """Sines with the mode I drifts from the stated wrong design (variant wrong_design_drift): the adaptive
    secondary error does not grow through the drifts (1–4 s → 14–24 s: measured 2.51 → 2.43 mm, bound 1.1×, the
    drift claim's) while the baseline's (adaptation off, same start) grows by more than 20 % (3.57 → 5.41 mm), and
    the adaptive ends below 0.6× the baseline.  It does not reach the right design's 2.00 mm within 1.2× (1.22×):
    the page's "partly" (σ-leakage holds the gap, test_leakage_holds_the_gap_to_the_right_design)."""
    ts = _wrong_start(request.config.rootpath, "thesis_ch6_sine", "wrong_design_drift")
    w, n = ts["wrong_design_drift"], ts["wrong_design_drift_nonadaptive"]
    assert _errs(w, 14, 24)[0] < 1.1 * _errs(w, 1, 4)[0]
    assert _errs(n, 14, 24)[0] > 1.2 * _errs(n, 1, 4)[0]  # the baseline fails the drift claim
    assert _errs(w, 14, 24)[0] < 0.6 * _errs(n, 14, 24)[0]


@pytest.mark.slow
def test_leakage_holds_the_gap_to_the_right_design(request):
    """Why the wrong start stays above the right design on the sines (page, Ch. 6): the σ-leakage (ours, 0.2 s⁻¹)
    pulls the integral parts of the gains back to their *initial* values, so a correction of the wrong design is
    held only by a standing error.  No drifts, 72 s: at σ = 0.2 the wrong start's secondary error at 60–72 s stays
    above 1.2× the right design's (measured 1.89 vs 1.54 mm); at σ = 0.02 it is within (0.99 vs 0.86 mm)."""
    def ratio(sigma):
        def ed(raw):
            raw["sim"]["duration"] = 72.0
            for v in ("wrong_design", "adaptive_nodrift"):
                raw["variants"][v].setdefault("controller", {}).setdefault("params", {})["sigma"] = sigma
        ts = run_variants(request.config.rootpath, "thesis_ch6_sine", ed, variants=("wrong_design", "adaptive_nodrift"))
        return _errs(ts["wrong_design"], 60, 72)[0] / _errs(ts["adaptive_nodrift"], 60, 72)[0]

    assert ratio(0.2) > WITHIN
    assert ratio(0.02) < WITHIN


def test_actuator_forces_primary_is_larger_but_the_secondary_is_not_the_faster_on_the_bump(request):
    """Figs. 6.12 (sine) and 6.14 (bump): "the secondary force u_s is low in magnitude but has higher frequency
    components; the primary force u_p is larger in magnitude but less oscillatory".  Ours (`adaptive`, the
    scenarios' drifts): u_p is the larger on both roads (RMS, measured 154 vs 128 N on the sine, 123 vs 80 N on the
    bump), but on the bump u_s is not the higher-frequency one: the mean frequency of its PSD is below u_p's
    (measured 4.9 vs 6.5 Hz; on the sine 2.1 vs 1.9 Hz).  Pins the page's "partly"; a run in which u_s carried the
    higher frequencies on the bump would fail the last assertion."""
    from suspension_sim.reproductions.thesis import _force_share

    share = {}
    for name in ("thesis_ch6_sine", "thesis_ch6_bump"):
        ts = run_variants(request.config.rootpath, name, variants=("adaptive",))["adaptive"]
        share[name] = _force_share(ts, (ts.t > 0.5).to_numpy())
    for name, sh in share.items():
        assert sh["primary"][0] > sh["secondary"][0], (name, sh)
    bump = share["thesis_ch6_bump"]
    assert bump["secondary"][1] < bump["primary"][1], bump
