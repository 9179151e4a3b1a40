"""Thesis Ch. 5: stochastic optimal control (LQR with Hac shaping-filter states + Kalman road estimate)
against the continuous MRAC, nominal and with time-varying load and stiffness."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_continuous_are
from scipy.signal import welch

from suspension_sim.controllers.thesis_soc_lqg import lqr_gain
from suspension_sim.roads.hac import hac_shaping_filter
from scenario_runs import run_variants


def test_cross_term_riccati_equals_the_transformed_problem():
    """The gain from solve_continuous_are(..., s=N) equals the classical elimination of the cross term
    (A − B R⁻¹Nᵀ, Q − N R⁻¹ Nᵀ) and is stabilising."""
    Md, _, _ = hac_shaping_filter("dirt", 20.0)
    A, B, K1 = lqr_gain(250.0, 5000.0, 250.0, Md, 10.0, 1e-7)
    Ca, Da = A[1:2], 1 / 250.0
    er = np.array([[1.0, 0, -1.0, 0, 0]])
    Q = Ca.T @ Ca + 10.0 * er.T @ er
    N = Ca.T * Da
    R = np.array([[Da * Da + 1e-7]])
    Ri = np.linalg.inv(R)
    P = solve_continuous_are(A - B @ Ri @ N.T, B, Q - N @ Ri @ N.T, R)
    K2 = Ri @ (B.T @ P + N.T)
    assert np.allclose(K1, K2, rtol=1e-6)
    assert np.all(np.linalg.eigvals(A - B @ K1).real < 0)
    # comfort weights: the gain on x cancels most of the spring (so a 25 % softer spring destabilises)
    assert -5000 < K1[0, 0] < -3750


@pytest.fixture(scope="module")
def nominal(request):
    def edit(raw):
        raw["sim"]["duration"] = 24.0

    return run_variants(request.config.rootpath, "thesis_ch5_nominal", edit)


def band(ts, col, lo, hi, t0=6.0):
    s = ts[ts.t > t0]
    f, P = welch(s[col].to_numpy(), fs=1.0 / (s.t.iloc[1] - s.t.iloc[0]), nperseg=4096)
    return float(np.mean(P[(f >= lo) & (f < hi)]))


def test_nominal_mrac_better_than_soc_at_and_above_resonance(nominal):
    """Thesis: MRAC better at and above resonance.  Both active laws beat passive near resonance."""
    for lo, hi in ((0.5, 1.0), (1.0, 2.0), (2.0, 4.0)):
        assert band(nominal["mrac"], "body_acc", lo, hi) < band(nominal["soc"], "body_acc", lo, hi), (lo, hi)
        # the baseline fails the same comparison: the passive car is worse than the SOC in every band
        assert band(nominal["passive"], "body_acc", lo, hi) > band(nominal["soc"], "body_acc", lo, hi), (lo, hi)
    for name in ("soc", "mrac"):
        assert band(nominal[name], "body_acc", 0.5, 1.0) < 0.2 * band(nominal["passive"], "body_acc", 0.5, 1.0)


@pytest.fixture(scope="module")
def varying(request):
    """Thesis timing compressed: +150 kg from 2 s to 12 s, stiffness −25 % from 7 s; 20 s."""

    def edit(raw):
        raw["sim"]["duration"] = 20.0
        raw["vehicle"]["variations"][0]["times"] = [2.0, 12.0]
        raw["vehicle"]["variations"][1]["times"] = [7.0]
        for v in ("soc_rescheduled_5s", "soc_rescheduled_10s"):
            sch = raw["variants"][v]["controller"]["params"]["schedule"]
            for e, t in zip(sch, (0.0, 2.0, 7.0, 12.0)):
                e["time"] = t

    return run_variants(request.config.rootpath, "thesis_ch5_varying", edit,
                        variants=("passive", "soc_fixed", "soc_rescheduled_5s", "mrac", "mrac_thetad",
                                  "mrac_thetad_nonadaptive"))


def test_fixed_gain_soc_goes_unstable_rescheduled_and_mrac_do_not(varying):
    """Thesis: the fixed-gain SOC goes unstable under time-varying stiffness, recomputing its gains with
    perfect knowledge restores stability, the MRAC keeps its behaviour."""
    def win(name, col, t0=16.0, t1=20.0):
        ts = varying[name]
        return ts[col][(ts.t >= t0) & (ts.t < t1)].to_numpy()

    # linear analysis: the nominal gains with the softened spring have an unstable pole; recomputed ones don't
    Md, _, _ = hac_shaping_filter("dirt", 20.0)
    A_true, B, _ = lqr_gain(250.0, 3750.0, 250.0, Md, 10.0, 1e-7)
    _, _, K_fixed = lqr_gain(250.0, 5000.0, 250.0, Md, 10.0, 1e-7)
    _, _, K_new = lqr_gain(250.0, 3750.0, 250.0, Md, 10.0, 1e-7)
    assert np.max(np.linalg.eigvals(A_true - B @ K_fixed).real) > 0
    assert np.max(np.linalg.eigvals(A_true - B @ K_new).real) < 0
    # simulation: the fixed-gain loop runs away into the 5 kN actuator limit and stays there
    F_fixed = np.abs(win("soc_fixed", "actuator_force"))
    assert np.mean(F_fixed > 0.99 * 5000) > 0.5
    assert np.mean(np.abs(win("soc_fixed", "body_z"))) > 0.5
    # rescheduled (gains recomputed at 15 s from the true parameters): no longer saturated.  It holds no
    # static level: the softer spring carries less of the static load (thesis Eq. 3.1, K(t)·δ_st), so the
    # body sits lower, but it is a stable equilibrium
    assert np.max(np.abs(win("soc_rescheduled_5s", "actuator_force"))) < 0.99 * 5000
    assert np.mean(np.abs(win("soc_rescheduled_5s", "body_z"))) < np.mean(np.abs(win("soc_fixed", "body_z")))
    # the MRAC with our static-load parameter θ_d and P1 = (s + 20)² (named variant `mrac_thetad`, not in the
    # thesis) keeps its level through the load and the stiffness change
    assert abs(np.mean(win("mrac_thetad", "body_z"))) < 0.05
    assert abs(np.mean(win("mrac_thetad", "body_z", 9.0, 12.0))) < 0.05  # under load and with the soft spring
    # … which the passive car fails: it sags under the load with the softened spring (≈ 0.39 m + the lost
    # K·δ_st share) and still sits low once the load is gone
    assert np.mean(win("passive", "body_z", 9.0, 12.0)) < -0.2
    assert np.mean(win("passive", "body_z")) < -0.05


def test_no_weights_give_the_thesis_placement_of_the_soc(request, nominal):
    """The thesis (no weights given) puts the SOC better than the MRAC at low frequency but with more rattle space
    and more actuator work.  The two ends of the weight range each give part of it, never all: a large ρ1 wins at
    low frequency with less rattle and less work than the MRAC; tiny ρ1, ρ2 buy more rattle and more work at a
    far worse low-frequency response (the cost's ẍ² term already prices F)."""
    def edit(raw):
        raw["sim"]["duration"] = 24.0
        raw["variants"] = {"stiff": {"controller": {"params": {"rho1": 1.0e4}}},
                           "cheap": {"controller": {"params": {"rho1": 0.01, "rho2": 1.0e-9}}}}

    out = run_variants(request.config.rootpath, "thesis_ch5_nominal", edit)
    m = nominal["mrac"]

    def rattle(ts):
        return float(np.sqrt(np.mean(ts.travel[ts.t > 6] ** 2)))

    def work(ts):
        s = ts[ts.t > 6]
        return float(np.mean(np.abs(s.actuator_force * s.travel_rate)))

    low = {k: band(t, "body_z", 0.1, 0.5) for k, t in (("stiff", out["stiff"]), ("cheap", out["cheap"]), ("mrac", m))}
    assert low["stiff"] < low["mrac"] and rattle(out["stiff"]) < rattle(m) and work(out["stiff"]) < work(m)
    assert rattle(out["cheap"]) > rattle(m) and work(out["cheap"]) > work(m) and low["cheap"] > 10 * low["mrac"]


def test_printed_mrac_does_not_keep_its_level_under_the_load(varying):
    """The literal result the page reports for "the MRAC keeps its behaviour": the Ch. 3 law as printed (variant
    `mrac`: P1 = A_m, no static-load term) has no constant term, so the load and the softer spring's lost share of
    the static load are carried by its static gain (thesis_ch3_load_step: −2.96 m without a force limit); here it
    pushes down into the 5 kN limit and sinks more than a metre (measured at thesis timing: −1.23 m under the load,
    −1.88 m with the soft spring, still −1.50 m after the load is gone).  The variant `mrac_thetad` holds the level
    on the same run (test above), so this is the law, not the scenario."""
    def win(name, col, t0, t1):
        ts = varying[name]
        return ts[col][(ts.t >= t0) & (ts.t < t1)].to_numpy()

    assert abs(np.mean(win("mrac", "body_z", 0.5, 2.0))) < 0.01  # before the load it holds the level
    assert np.mean(win("mrac", "body_z", 9.0, 12.0)) < -1.0
    assert np.mean(np.abs(win("mrac", "actuator_force", 9.0, 12.0)) > 0.99 * 5000) > 0.5
    assert abs(np.mean(win("mrac_thetad", "body_z", 9.0, 12.0))) < 0.05


def test_mrac_level_under_the_changes_is_theta_d_not_the_adaptation(varying):
    """A skeptical check of "the MRAC keeps its behaviour" (Ch. 5, time-varying load and stiffness): the named variant
    `mrac_thetad` holds the level (test above), but so does its baseline with the Θ adaptation off (γ = 0, nominal Θ,
    our θ_d kept): under the load with the soft spring and after the load is gone its offset is not 0.8× the
    baseline's or less, the margin an adaptation claim must reach.  This pins the page's verdict (Ch. 5: "reproduced,
    but not by adaptation"); an adaptation that mattered would fail it."""
    def lvl(name, t0, t1):
        ts = varying[name]
        return float(np.mean(ts.body_z[(ts.t >= t0) & (ts.t < t1)]))

    n = varying["mrac_thetad_nonadaptive"]
    assert n["ctrl.theta.1"].iloc[-1] == n["ctrl.theta.1"].iloc[0]  # Θ frozen
    for t0, t1 in ((9.0, 12.0), (16.0, 20.0)):  # under load with the soft spring, after the load
        a, b = lvl("mrac_thetad", t0, t1), lvl("mrac_thetad_nonadaptive", t0, t1)
        assert abs(b) < 0.05, (t0, b)  # the baseline keeps the level too (the bound of the test above)
        assert not abs(a) < 0.8 * abs(b), (t0, a, b)
    ref = varying["mrac_thetad"]["ctrl.ref_x"].to_numpy()

    def follow(name):
        ts = varying[name]
        m = ts.t.to_numpy() > 2.0
        return float(np.sqrt(np.mean((ts.body_z.to_numpy() - ref)[m] ** 2)))

    assert not follow("mrac_thetad") < 0.8 * follow("mrac_thetad_nonadaptive")  # measured 51.5 vs 52.0 mm


def _work(ts, t0=6.0):
    s = ts[ts.t > t0]
    return float(np.mean(np.abs(s.actuator_force * s.travel_rate)))


def test_nominal_mrac_numbers_are_the_nominal_design_not_the_adaptation(nominal):
    """Ch. 5 makes no claim about the Θ adaptation, and it never matters here: on the nominal run the printed MRAC
    and its baseline with the Θ adaptation off (`mrac_nonadaptive`, γ = 0) give the same acceleration PSD per band,
    rattle space and work within 3 % (measured ≤ 1.2 % over 60 s; Θ moves < 1 %).  An adaptation that mattered on
    this run would fail it; the page says every Ch. 5 MRAC number is the nominal design's."""
    a, n = nominal["mrac"], nominal["mrac_nonadaptive"]
    assert n["ctrl.theta.1"].iloc[-1] == n["ctrl.theta.1"].iloc[0]  # Θ frozen in the baseline
    for lo, hi in ((0.25, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 4.0)):
        assert band(a, "body_acc", lo, hi) == pytest.approx(band(n, "body_acc", lo, hi), rel=0.03), (lo, hi)
    assert float(np.sqrt(np.mean(a.travel[a.t > 6] ** 2))) == pytest.approx(
        float(np.sqrt(np.mean(n.travel[n.t > 6] ** 2))), rel=0.03)
    assert _work(a) == pytest.approx(_work(n), rel=0.03)


def test_mrac_work_is_not_set_by_its_reference_damping(request, nominal):
    """Why no SOC weights give the thesis's placement (the SOC doing more work than the MRAC): not the MRAC's heavily
    damped skyhook reference.  With D_m = 750 instead of 6000 N·s/m the MRAC's ⟨|F·ż|⟩ stays within 5 % (measured
    1016 vs 999 W) and above 2× the SOC's (276 W): its force lies above 5 Hz (measured RMS 524 N above, 119 N
    below), working against the dirt road's white travel rate, while the SOC's lies below (45 / 158 N)."""
    from scipy.signal import butter, sosfiltfilt

    def edit(raw):
        raw["sim"]["duration"] = 24.0
        raw["variants"] = {"light": {"controller": {"type": "thesis_mrac_continuous", "params": {
            "gamma": 1.0, "k_v": 0.1, "alpha": 1.0e-6, "static_level": False, "ref_damping": 750.0}}}}

    light = run_variants(request.config.rootpath, "thesis_ch5_nominal", edit)["light"]
    heavy, soc = nominal["mrac"], nominal["soc"]
    assert _work(light) == pytest.approx(_work(heavy), rel=0.05)
    assert min(_work(light), _work(heavy)) > 2 * _work(soc)

    def split(ts):
        s = ts[ts.t > 6]
        F = s.actuator_force.to_numpy()
        lo = sosfiltfilt(butter(4, 5.0, fs=1.0 / float(s.t.iloc[1] - s.t.iloc[0]), output="sos"), F)
        return float(np.sqrt(np.mean(lo ** 2))), float(np.sqrt(np.mean((F - lo) ** 2)))
    (ml, mh), (sl, sh) = split(heavy), split(soc)
    assert mh > 3 * ml and sl > 2 * sh
