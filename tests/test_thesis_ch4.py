"""Thesis Ch. 4 (discrete MRAC with 0.05 s loop delay and RLS, nonlinear fail-safe SDOF plant).

Also checks the DARMA/predictor construction the Ch. 4 and Ch. 7 controllers share against a simulated
ZOH plant."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import cont2discrete, welch

from suspension_sim.controllers.thesis_common import am_poly, darma, predictor
from scenario_runs import run_variants

G = 9.81
# the load-step property tests run at the scenario's former step (implicitfast, 0.125 ms): the verdicts they check
# hold at every step (page); the scenario's converged setting (RK4 at 0.0625 ms) passes them too but takes ~6× as
# long, and its numbers are checked by the slow `reproduce thesis` test
FAST_STEP = {"dt": 0.000125, "integrator": "implicitfast"}


def window(ts, t0, t1, col):
    return ts[col][(ts.t >= t0) & (ts.t < t1)].to_numpy()


@pytest.mark.parametrize("d", [0, 1, 5])
def test_predictor_is_exact_for_the_zoh_plant(d):
    """a_m(q⁻¹)Y[k+D] = α(q⁻¹)Y[k] + β(q⁻¹)U[k] holds exactly for the sampled plant with d extra delays."""
    M, C, K, h = 250.0, 500.0, 5000.0, 0.01
    Ac = np.array([[0, 1], [-K / M, -C / M]])
    Bc = np.array([[0.0], [1 / M]])
    Cc = np.array([[1.0, 0.0]])
    A, B = darma(Ac, Bc, Cc, h)
    am = am_poly(np.sqrt(20.0), 24 / (2 * np.sqrt(20.0)), h)
    D, al, be = predictor(A, B, am, d)
    Phi, Gam, _, _, _ = cont2discrete((Ac, Bc, Cc, np.zeros((1, 1))), h)
    rng = np.random.default_rng(0)
    u = rng.standard_normal(400)
    x, y = np.zeros(2), []
    for k in range(400):
        y.append(x[0])
        x = Phi @ x + Gam[:, 0] * (u[k - d] if k >= d else 0.0)
    y = np.array(y)
    for k in (50, 200, 300):
        lhs = y[k + D] + am[1] * y[k + D - 1] + am[2] * y[k + D - 2]
        rhs = sum(al[i][0, 0] * y[k - i] for i in range(2)) + sum(be[j][0, 0] * u[k - j] for j in range(len(be)))
        assert lhs == pytest.approx(rhs, rel=1e-8, abs=1e-14)


def _sampled_zero(integrator, dt, T=0.01, M=250.0, K=5000.0, F=1000.0):
    """The zero of the rig's sampled response to one held force pulse (one control step T): y[k] = x(kT) after
    a pulse F over [0, T), body on its spring (no effects, flat base); b1 = y[1]/F, b2 = (y[2] + a1·y[1])/F with
    a1 = −2·cos(ωT) (the ZOH model's denominator), zero = −b2/b1."""
    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    raw = dict(vehicle=dict(model="sdof", params=dict(sprung_mass=M, spring_stiffness=K, damping=0.0)),
               road=dict(type="flat"),
               controller=dict(type="open_loop", params=dict(signal="step", amplitude=F, start=0.0, stop=T)),
               sim=dict(duration=3 * T, dt=dt, control_dt=T, log_dt=T, integrator=integrator))
    ts = Simulation([parse_scenario(raw)]).run()[0].ts
    y1, y2 = ts.body_z.to_numpy()[1:3]
    a1 = -2.0 * np.cos(np.sqrt(K / M) * T)
    return -(y2 + a1 * y1) / y1


def test_held_force_is_integrated_exactly_by_rk4_not_by_the_first_order_step():
    """Why thesis_ch4_load_step runs RK4 (page, Ch. 4 step halving): the printed law (κ = 1) cancels the sampling
    zero of its ZOH design model (−0.987 for M* = 250, K* = 5000, C0 = 1000) at the Nyquist frequency.  The
    plant's own sampling zero is −1 (undamped rig); implicitfast (semi-implicit Euler) integrates a force held
    over the control step with a position error ∝ dt, which moves that zero to −(T − dt)/(T + dt): −0.975 at
    0.125 ms, −0.988 at 0.0625 ms, crossing the design's zero as the step shrinks.  That made the wrong design's
    level and following wander with the step (−50.4, −49.1, −48.7, −49.3 mm; limit ≈ −52.5).  RK4 integrates the
    held force exactly: its zero is −1 at any step."""
    for dt in (1.25e-4, 6.25e-5):
        z_if = _sampled_zero("implicitfast", dt)
        z_rk = _sampled_zero("RK4", dt)
        assert z_if == pytest.approx(-(0.01 - dt) / (0.01 + dt), abs=2e-4)  # the first-order step moves the zero
        assert abs(z_if + 1.0) > 0.01
        assert z_rk == pytest.approx(-1.0, abs=1e-4)


@pytest.fixture(scope="module")
def load_step(request):
    def edit(raw):
        raw["vehicle"]["variations"][0]["times"] = [4.0, 16.0]
        raw["sim"]["duration"] = 16.0
        raw["sim"].update(FAST_STEP)

    return run_variants(request.config.rootpath, "thesis_ch4_load_step", edit,
                        variants=("passive", "mrac_off", "mrac_bias", "wrong_design_bias", "wrong_design_bias_off"))


@pytest.fixture(scope="module")
def printed(request):
    """The printed law (no bias) at the scenario's own step (RK4 at 0.0625 ms): at FAST_STEP it sat on the stops
    for 4–12 s after the load (−13 cm, 8–16 s), at its converged step it is back to −5 cm within 8 s (cf. the
    page's 2-s means); the load held for 20 s as in the thesis (4–24 s), 9 CPU-s for the first three runs; the
    printed law from the stated wrong design and its adaptation-off baseline besides."""
    def edit(raw):
        raw["vehicle"]["variations"][0]["times"] = [4.0, 24.0]
        raw["sim"]["duration"] = 24.0

    return run_variants(request.config.rootpath, "thesis_ch4_load_step", edit,
                        variants=("passive", "mrac", "mrac_off", "wrong_design", "wrong_design_off"))


def theta(ts):
    return ts[[c for c in ts.columns if c.startswith("ctrl.theta.")]].to_numpy()


def theta_gap(run, right, wrong):
    """Scaled Θ distance (per row by the right start's initial |Θ|, bias row left out) over time (the item's)."""
    r = theta(run[right])
    sc = np.abs(r[0])
    sc[sc == 0] = 1000.0
    keep = np.ones(len(sc), bool)
    keep[-2] = False
    return np.linalg.norm(((theta(run[wrong]) - r) / sc)[:, keep], axis=1)


def theta_held(ts):
    """Largest relative change of a non-zero Θ entry over the run."""
    th = theta(ts)
    nz = np.abs(th[0]) > 0
    return float(np.max(np.abs(th[:, nz] - th[0, nz]) / np.abs(th[0, nz])))


def test_passive_sags_onto_the_stops(load_step):
    """+150 kg: K·s + K_es·(s − D/2) = ΔM·g for s > D/2 → 0.144 m (thesis ≈ 15 cm), within the friction
    dead band ±F/(K + K_es)."""
    K, Kes, gap, F = 5000.0, 40000.0, 0.125, 1000.0
    expected = (150 * G + Kes * gap) / (K + Kes)
    sag = -np.mean(window(load_step["passive"], 10, 16, "body_z"))
    assert abs(sag - expected) < F / (K + Kes)
    assert sag > gap  # on the stops


def test_printed_law_carries_the_load_but_does_not_hold_the_level(printed):
    """The printed law (κ = 1, Q = 0, the printed φ without a constant: the scenario default) supplies the static
    force (thesis ≈ 1500 N) through Θᵀφ's output and input terms, which the non-adaptive baseline does not (measured
    1450 N, 14–24 s; the baseline 794 N with the former P0 = 1e-12, whose Θ still moved).  But the level is not held (thesis: it is): the body sticks where the 1000 N
    friction catches it, ≈ 4 cm low (measured −4.3 cm); it recovers more than half of the baseline's sag."""
    z = {k: np.mean(window(printed[k], 14, 24, "body_z")) for k in ("mrac", "mrac_off", "passive")}
    force = {k: np.mean(window(printed[k], 14, 24, "actuator_force")) for k in ("mrac", "mrac_off")}
    assert force["mrac"] == pytest.approx(150 * G, rel=0.15)
    assert force["mrac_off"] != pytest.approx(150 * G, rel=0.15)  # the baseline fails the force claim
    assert abs(z["mrac"]) < 0.5 * abs(z["mrac_off"])
    assert z["mrac_off"] < -0.1 and z["passive"] < -0.1  # the baselines sit on (or near) the stops
    assert abs(z["mrac"]) > 0.02  # the thesis's "maintains the static level" is not reproduced (pinned)


def test_with_our_bias_the_law_carries_the_load_but_does_not_hold_the_level(load_step):
    """The same law with our bias parameter (`mrac_bias`: the constant −1 in φ with the operating-point force): the
    bias estimate supplies the static force, which the non-adaptive baseline does not; the level is not held
    either, ≈ 5 cm low.  It recovers more than half of the baseline's sag, and never reaches the stop the
    passive car rests on."""
    z = {k: np.mean(window(load_step[k], 8, 16, "body_z")) for k in ("mrac_bias", "mrac_off", "passive")}
    force = {k: np.mean(window(load_step[k], 8, 16, "actuator_force")) for k in ("mrac_bias", "mrac_off")}
    assert force["mrac_bias"] == pytest.approx(150 * G, rel=0.15)
    assert force["mrac_off"] != pytest.approx(150 * G, rel=0.15)  # the baseline fails the force claim
    assert abs(z["mrac_bias"]) < 0.5 * abs(z["mrac_off"])
    assert np.min(window(load_step["mrac_bias"], 4, 16, "body_z")) > -0.125
    assert z["mrac_off"] < -0.1 and z["passive"] < -0.1  # the baselines sit on (or near) the stops
    assert abs(z["mrac_bias"]) > 0.02  # the thesis's "maintains the static level" is not reproduced (pinned)


def test_model_following_is_not_reproduced_friction_locks_the_body(load_step, printed):
    """Thesis: model following within 1.5 s.  Not reproduced: the 1000 N Coulomb friction is far above the
    road's spring force (K·|w| ≈ 150 N), so the passive body and the non-adaptive one are locked to the
    base, and the printed law does not follow either (nor does it with our bias): RMS(body − reference) is at or
    above the passive car's while the reference itself moves 4 mm.  This test pins the failure so that a fix shows
    up here."""
    for run, law in ((printed, "mrac"), (load_step, "mrac_bias")):  # each against its own step's baselines
        e = {}
        ref = run[law]["ctrl.ref_x"]
        for v in ("passive", "mrac_off", law):
            ts = run[v]
            m = (ts.t >= 1.5) & (ts.t < 4.0)
            e[v] = np.sqrt(np.mean((ts.body_z[m] - ref[m]) ** 2))
        for v in ("passive", "mrac_off"):
            ts = run[v]
            assert ts["effect.coulomb_friction.stuck.0"][(ts.t >= 1.5) & (ts.t < 4.0)].mean() > 0.9
        assert e[law] > 0.8 * e["passive"], law


def test_estimates_from_a_wrong_design_merge_with_the_right_start(load_step):
    """Adaptation from a stated wrong design (M* +30 %, K* −30 %, C0 +30 %) with our bias (`wrong_design_bias`): the
    estimates forget the initial design and join those of the run started from the right design (`mrac_bias`; scaled
    Θ distance, bias row left out), and the level then matches the right start's; with adaptation off
    (`wrong_design_bias_off`, P0 = 1e-18: Θ held) the wrong design keeps its distance (it grows, as the right start's
    estimates move) and sags (baseline fails both)."""
    g, g_off = theta_gap(load_step, "mrac_bias", "wrong_design_bias"), theta_gap(load_step, "mrac_bias",
                                                                                  "wrong_design_bias_off")
    assert g[0] > 0.3 and g_off[0] == pytest.approx(g[0])
    assert g[-1] < 0.25 * g[0]
    assert g_off[-1] > g[0]
    z = {k: np.mean(window(load_step[k], 8, 16, "body_z"))
         for k in ("mrac_bias", "wrong_design_bias", "wrong_design_bias_off")}
    assert abs(z["wrong_design_bias"] - z["mrac_bias"]) < 0.01
    assert abs(z["wrong_design_bias_off"] - z["mrac_bias"]) > 0.03


def test_adaptation_off_holds_theta(load_step, printed):
    """The baselines are truly non-adaptive: with P0 = 1e-18 no Θ entry moves by 0.1 % (with the former 1e-12 the
    first entry of `mrac_off` moved 1.9 % over the 60 s run), while the adaptive runs move theirs by far more."""
    for run, k in ((load_step, "mrac_off"), (load_step, "wrong_design_bias_off"), (printed, "mrac_off"),
                   (printed, "wrong_design_off")):
        assert theta_held(run[k]) < 1e-3, k
    for run, k in ((load_step, "mrac_bias"), (printed, "mrac"), (printed, "wrong_design")):
        assert theta_held(run[k]) > 0.1, k


def test_printed_law_from_a_wrong_design_does_not_join_the_right_start(printed):
    """The printed law (no constant in φ) from the same stated wrong design (`wrong_design`): its estimates do not
    join the right start's (`mrac`): the scaled Θ gap does not close to half its initial value (the item's rule for
    "partly"; measured, the gap grows), and the level it settles at under the load differs from the right start's by
    more than the bias law's 1 cm.  Not reproduced (pinned, so that a fix shows up here)."""
    g = theta_gap(printed, "mrac", "wrong_design")
    assert g[0] > 0.3
    assert g[-1] > 0.5 * g[0], (g[0], g[-1])
    z = {k: np.mean(window(printed[k], 14, 24, "body_z")) for k in ("mrac", "wrong_design")}
    assert abs(z["wrong_design"] - z["mrac"]) > 0.01, z


def _dirt_psd(ts0):
    """The Ch. 4 dirt-road tests' PSD over 8 s on: of a logged column, or (no column) of the body acceleration
    averaged over each log step (the difference of the logged body velocity), at the log rate of `ts0`."""
    fs = 1.0 / (ts0.t[1] - ts0.t[0])

    def psd(ts, col=None):
        t = ts.t.to_numpy()
        x = ts[col].to_numpy()[t > 8] if col else (np.diff(ts.body_vel.to_numpy()) * fs)[t[1:] > 8]
        return welch(x, fs=fs, nperseg=4096)
    return psd


def test_dirt_road_without_loop_delay_ours_follows_reference_printed_law_overattenuates(request):
    """The Ch. 4 laws on the dirt road (exact stick-slip friction) without the 0.05 s loop delay.  Body-acceleration
    PSDs of the acceleration averaged over each 1 ms log step (from the logged velocity): ours (κ = 0.1, Q = 1e-4)
    is closer to the reference than passive from 0.5 to 4 Hz; the printed law (κ = 1, no bias: the default) is
    closer at 1–4 Hz but attenuates far below the reference at 0.5–1 Hz (measured 0.0053 over 8–24 s: still farther
    from it than passive here; over the item's 12–60 s 0.035, marginally closer than passive's 50, the page's
    partly); the same law with our bias (`mrac_bias_no_delay`) is closer at 2–4 Hz but attenuates far below the
    reference at 0.5–1 Hz, farther from it than passive (verdict: not).  The logged instantaneous body_acc (the
    last physics step's) reads that band ≥ 10× higher: the friction's ±1000 N switching, sampled at 1 kHz,
    aliases into it (that sample made the law with the bias look closer than passive)."""

    def edit(raw):
        raw["sim"]["duration"] = 24.0

    out = run_variants(request.config.rootpath, "thesis_ch4_dirt", edit,
                       variants=("passive", "mrac_no_delay", "mrac_bias_no_delay", "mrac_kappa_q_no_delay"))
    psd = _dirt_psd(out["passive"])

    f, Pref = psd(out["mrac_no_delay"], "ctrl.ref_acc")
    _, Pp = psd(out["passive"])

    def band(P, lo, hi):
        s = (f >= lo) & (f < hi)
        return np.mean(P[s]) / np.mean(Pref[s])

    _, Pk = psd(out["mrac_kappa_q_no_delay"])
    for lo, hi in ((0.5, 1.0), (1.0, 2.0), (2.0, 4.0)):  # ours: closer than passive in every band
        assert abs(np.log10(band(Pk, lo, hi))) < abs(np.log10(band(Pp, lo, hi))), (lo, hi)
    _, Pm = psd(out["mrac_no_delay"])  # the printed law: closer at 1–4 Hz, far below the reference at 0.5–1 Hz
    for lo, hi in ((1.0, 2.0), (2.0, 4.0)):
        assert abs(np.log10(band(Pm, lo, hi))) < abs(np.log10(band(Pp, lo, hi))), (lo, hi)
    assert band(Pm, 0.5, 1.0) < 0.1
    _, Pb = psd(out["mrac_bias_no_delay"])  # with our bias
    assert abs(np.log10(band(Pb, 2.0, 4.0))) < abs(np.log10(band(Pp, 2.0, 4.0)))
    assert band(Pb, 0.5, 1.0) < 0.1 and abs(np.log10(band(Pb, 0.5, 1.0))) > abs(np.log10(band(Pp, 0.5, 1.0)))
    _, Pi = psd(out["mrac_bias_no_delay"], "body_acc")
    assert band(Pi, 0.5, 1.0) > 10 * band(Pb, 0.5, 1.0)


def test_dirt_road_adaptation_moves_the_printed_law_away_from_the_reference(request):
    """Is the Ch. 4 dirt road's "partly" the adaptation's?  The same printed law with adaptation off (`mrac_off`,
    `mrac_off_no_delay`: Θ held at the nominal design) is the baseline.  Body-acceleration PSD over the reference's
    (acceleration averaged over each 1 ms log step), 8–24 s: with the 0.05 s delay the nominal design held is closer
    to the reference than the adaptive law at 0.5–2 Hz (measured 3.6, 6.2 against 426, 65: the estimates still
    moving); without the delay it is closer at 0.25–2 Hz (1.2, 1.7, 1.9 against 0.0008, 0.005, 0.025: the adaptive
    law over-attenuates) and already closer than passive in every band from 0.5 to 4 Hz, the item's rule for
    "partly".  So the thesis's "adapts, then follows" is not shown: adaptation moves the law away from the reference
    at low frequency (page, Ch. 4 dirt road; over the item's 12–60 s the same, the adaptive law closer only at 2–8 Hz
    with the delay)."""
    def edit(raw):
        raw["sim"]["duration"] = 24.0

    out = run_variants(request.config.rootpath, "thesis_ch4_dirt", edit,
                       variants=("passive", "mrac", "mrac_off", "mrac_no_delay", "mrac_off_no_delay"))
    psd = _dirt_psd(out["passive"])

    f, Pref = psd(out["mrac"], "ctrl.ref_acc")

    def dist(k, lo, hi):  # log distance of the band ratio to the reference's
        P = psd(out[k])[1]
        s = (f >= lo) & (f < hi)
        return abs(np.log10(np.mean(P[s]) / np.mean(Pref[s])))

    for lo, hi in ((0.5, 1.0), (1.0, 2.0)):
        assert dist("mrac_off", lo, hi) < dist("mrac", lo, hi), (lo, hi)
    for lo, hi in ((0.25, 0.5), (0.5, 1.0), (1.0, 2.0)):
        assert dist("mrac_off_no_delay", lo, hi) < dist("mrac_no_delay", lo, hi), (lo, hi)
    for lo, hi in ((0.5, 1.0), (1.0, 2.0), (2.0, 4.0)):
        assert dist("mrac_off_no_delay", lo, hi) < dist("passive", lo, hi), (lo, hi)
    th = [c for c in out["mrac_off"].columns if c.startswith("ctrl.theta.")]
    assert all(np.ptp(out["mrac_off"][c]) <= 1e-4 * abs(out["mrac_off"][c].iloc[0]) for c in th)  # Θ held


def test_stiffness_drift_printed_law_holds_level_after_the_load_passive_sags(request):
    """Parameter variations mode I (K −20 % as a ramp over 10–50 s, C_v −50 % at 30 s) with the load step (+150 kg
    at 20–40 s), at the thesis's timing and the scenario's own step (RK4 at 0.0625 ms: the printed law cancels its
    design's sampling zero, page), run to 50 s: after the load is removed (42–50 s) the softer spring carries less of
    the static load (Eq. 4.1, K(t)·δ_st), and the passive rig stays down where the 1000 N friction catches it
    (anywhere within ±F/K = ±0.2 m of its spring equilibrium: the exact stick-slip friction does not creep, so the
    drift alone, 0.2·M*·g = 490 N < F, would not move it).  The printed law (κ = 1, Q = 0, no bias: `drift_mrac`, the
    default) and the law with our bias (`drift_mrac_bias`) are each back within the page's 2 cm, which the passive rig
    and the printed law with adaptation off fail; under the load (30–40 s) neither law holds the 2 cm (the page's
    "partly", pinned).  Not chaotic (the Ch. 4 ensemble table); compressed to 20 s the printed law had not yet
    recovered (−2.8 cm 2–10 s after the load)."""
    def edit(raw):
        raw["sim"]["duration"] = 50.0
        # the non-adaptive baseline on the same drifts: the printed law with adaptation off (as `mrac_off`; a bias
        # parameter would stay at its initial 0)
        raw["variants"]["drift_mrac_off"] = {"vehicle": raw["variants"]["drift_passive"]["vehicle"],
                                             "controller": {"params": {"p0": 1.0e-18}}}

    names = ("drift_passive", "drift_mrac", "drift_mrac_bias", "drift_mrac_off")
    out = run_variants(request.config.rootpath, "thesis_ch4_load_step", edit, variants=names)
    after = {k: np.mean(window(out[k], 42, 50, "body_z")) for k in names}
    under = {k: np.mean(window(out[k], 30, 40, "body_z")) for k in names}
    for law in ("drift_mrac", "drift_mrac_bias"):
        assert abs(after[law]) < 0.02, after
        assert abs(under[law]) > 0.02, under  # the level under the load is not held (pinned: partly)
    assert after["drift_passive"] < -0.05, after  # the baselines fail the 2 cm bound after the load
    assert abs(after["drift_mrac_off"]) > 0.02, after


@pytest.mark.slow
def test_covariance_addition_makes_the_loop_chaotic_the_printed_law_is_not(request):
    """Why Q = 1e-4 is a named variant and its page numbers are ensemble means: four runs whose first sine
    amplitude differs by at most 6 µm (3e-4 of it).  The printed law (Q = 0), with or without our bias, moves its
    level by about as much as the road (≈ 0.01 mm) and its force by < 1 N; our covariance addition with κ = 0.1 (`mrac_kappa_q`)
    spreads the level over millimetres and the force over ≈ 100 N: the estimates wander while friction locks
    the body, and the body ends where that loop lets friction catch it."""
    lv, fo = {}, {}
    for k in range(4):
        def edit(raw, k=k):
            raw["vehicle"]["variations"][0]["times"] = [4.0, 16.0]
            raw["sim"]["duration"] = 16.0
            raw["road"]["params"]["amplitudes"][0] *= 1 + k * 1e-4

        out = run_variants(request.config.rootpath, "thesis_ch4_load_step", edit, variants=("mrac", "mrac_bias", "mrac_kappa_q"))
        for v, ts in out.items():
            lv.setdefault(v, []).append(np.mean(window(ts, 8, 16, "body_z")))
            fo.setdefault(v, []).append(np.mean(window(ts, 8, 16, "actuator_force")))
    spread = {v: (np.ptp(lv[v]), np.ptp(fo[v])) for v in lv}
    for v in ("mrac", "mrac_bias"):
        assert spread[v][0] < 1e-4 and spread[v][1] < 5.0, spread
    assert spread["mrac_kappa_q"][0] > 1e-3 or spread["mrac_kappa_q"][1] > 50.0, spread
