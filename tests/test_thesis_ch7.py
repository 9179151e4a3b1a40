"""Thesis Ch. 7: discrete MIMO MRAC of the half car in the acceleration/braking manoeuvre."""
from __future__ import annotations

import numpy as np
import pytest

from suspension_sim.config import parse_scenario, read_yaml
from suspension_sim.errors import SimulationDiverged
from suspension_sim.simulation import Simulation


@pytest.fixture(scope="module")
def braking(request):
    """Every variant's time series; a run that stops on the divergence check maps to its SimulationDiverged (the
    printed κ = 1 law, the scenario default, runs away: a result)."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_braking.yaml"))
    out = {}
    for v, s in sc.expand():
        try:
            out[v] = Simulation([s]).run()[0].ts
        except SimulationDiverged as e:
            out[v] = e
    return out


def test_printed_law_runs_away_in_the_squat(braking):
    """Literal first: the scenario default (variant mimo_mrac_thesis) is the thesis's pure d-step-ahead law, κ = 1,
    with the printed regressor (no constant).  It cancels the sampling zero near z = −1, rings at the Nyquist
    frequency and runs away during the acceleration (measured stop 2.91 s); with our bias parameter
    (mimo_mrac_thesis_bias) it runs away too (4.02 s); our κ = 0.2 with the bias (variant mimo_mrac, the baseline
    here) runs the whole manoeuvre."""
    for k in ("mimo_mrac_thesis", "mimo_mrac_thesis_bias"):
        e = braking[k]
        assert isinstance(e, SimulationDiverged) and 1.0 < e.time < 9.0, (k, e)
    assert not isinstance(braking["mimo_mrac"], SimulationDiverged) and braking["mimo_mrac"].t.iloc[-1] > 13.9


def deg(ts, t0=0.0, t1=99.0):
    return np.degrees(ts.pitch[(ts.t >= t0) & (ts.t < t1)].to_numpy())


def test_passive_noses_down_in_braking(braking):
    """Thesis: about 6° of nose dive.  Ours (h = 1.25 m, 45 kg unsprung, velocity-squared dampers): the
    static pitch under 7 m/s² is M·a·h/(2·K·d²) = 3.3°, overshooting in the switch from +4 to −7 m/s²."""
    p = deg(braking["passive"])
    static = np.degrees(500 * 7 * 1.25 / (2 * 17000 * 1.5 ** 2))
    assert p.max() > 1.3 * static  # the 11 m/s² jump overshoots the static dive
    assert 4.0 < p.max() < 8.0  # of the thesis's order (≈ 6°)
    t_peak = float(braking["passive"].t.iloc[int(np.argmax(p))])
    assert 9.0 <= t_peak < 11.5  # nose down (positive pitch) during the braking phase (9–11 s)


def test_mimo_mrac_removes_most_of_the_dive(braking):
    pa, pm = deg(braking["passive"]), deg(braking["mimo_mrac"])
    assert np.max(np.abs(pm)) <= 0.2 * np.max(np.abs(pa))  # ≥ 80 % less peak pitch
    # bounce and pitch adapt within a few seconds of the manoeuvre start (1 s) and of the braking (9 s)
    assert np.max(np.abs(deg(braking["mimo_mrac"], 4.0, 9.0))) < 0.2
    assert np.max(np.abs(deg(braking["mimo_mrac"], 12.0, 14.0))) < 0.2
    # the passive baseline fails the settle bound: it holds its squat through the acceleration (4 m/s², static
    # M·a·h/(2·K·d²) = 1.9°)
    assert np.max(np.abs(deg(braking["passive"], 4.0, 9.0))) > 5 * 0.2
    # … and so does the same MRAC with adaptation off (variant mimo_fixed, the nominal design held: measured 0.83° at
    # 4–9 s, peak 1.26°): the settled squat is the adaptation's (the bias estimate carries the manoeuvre moment)
    assert np.max(np.abs(deg(braking["mimo_fixed"], 4.0, 9.0))) > 0.2
    assert np.max(np.abs(deg(braking["mimo_fixed"]))) > np.max(np.abs(pm))
    # (bounce is not tested here: on the thesis's symmetric car a pitch moment moves no c.g. height, so the
    # bounce of both cars is identically zero; see test_bounce_on_the_asymmetric_car)


def test_without_the_bias_the_loop_bursts_after_the_braking(braking):
    """The printed regressor has no constant (our bias parameter, the operating-point force, is in every κ = 0.2
    variant but this one).  Without it (bias: false) our κ = 0.2 law still holds the squat (its increment blend acts
    as an integrator: measured 0.015° at 4–9 s), but after the braking the loop bursts (measured 20.9° at 12–14 s),
    while with the bias (variant mimo_mrac, the baseline here) it stays below 0.2°; the fully printed law (κ = 1,
    no bias) runs away (test_printed_law_runs_away_in_the_squat)."""
    nb, mb = braking["mimo_mrac_no_bias"], braking["mimo_mrac"]
    assert np.max(np.abs(deg(nb, 4.0, 9.0))) < 0.2
    assert np.max(np.abs(deg(nb, 12.0, 14.0))) > np.max(np.abs(deg(braking["passive"])))  # worse than the dive
    assert np.max(np.abs(deg(mb, 12.0, 14.0))) < 0.2


def test_bounce_on_the_asymmetric_car(request):
    """Thesis: bounce (and pitch) adapt within 4 s.  On a car with the c.g. off centre (a = 1.2 m, b = 1.8 m,
    not the thesis's) the braking moment moves the passive c.g. by ≈ 1.5 cm (static (b − a)/L · M·a_x·h/(L·K)
    = 1.7 cm); the MIMO MRAC must keep the bounce a fraction of it.  The nominal design does that too with
    adaptation off (pinned below): the bounce here is the design's, the settled pitch the adaptation's
    (test_mimo_mrac_removes_most_of_the_dive)."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_braking.yaml"))
    runs = {v: s for v, s in sc.expand() if v in ("asym_passive", "asym_mimo_mrac", "asym_mimo_fixed")}
    for s in runs.values():
        s.sim.duration = 12.0
    ts = {v: Simulation([s]).run()[0].ts for v, s in runs.items()}
    brk = {v: r[(r.t > 9.0) & (r.t < 11.5)].body_z.to_numpy() for v, r in ts.items()}
    static = 0.6 / 3.0 * 500 * 7 * 1.25 / (3.0 * 17000)
    assert -np.mean(brk["asym_passive"]) > 0.5 * static  # the baseline bounces (it fails the claim)
    assert np.max(np.abs(brk["asym_passive"])) > 0.01
    assert np.max(np.abs(brk["asym_mimo_mrac"])) < 0.1 * np.max(np.abs(brk["asym_passive"]))
    assert np.max(np.abs(ts["asym_mimo_mrac"].body_z)) < 0.003
    # not a test of adaptation (page: "the nominal design's"): the same MRAC with adaptation off keeps the bounce
    # below the same bound (measured 1.26 mm against 0.74 adaptive, 41.5 passive); a car on which only the adaptive
    # law held the bounce would fail this
    assert np.max(np.abs(brk["asym_mimo_fixed"])) < 0.1 * np.max(np.abs(brk["asym_passive"]))


def test_braking_from_a_wrong_design(braking):
    """Thesis: "the initial controller parameters can be chosen to be of any arbitrary values"; dive eliminated,
    pitch adapts within 4 s.  From the stated wrong design (variant wrong_design, ours: nominal M_s +20 %, I −20 %,
    K0 −30 %, C0 +30 %; the reference keeps the thesis's M_s, I) the MRAC keeps the peak pitch ≤ 0.2× the passive
    dive and |pitch| < 0.2° at 4–9 s (the bounds of test_mimo_mrac_removes_most_of_the_dive; measured 0.79°,
    0.039°); the same wrong design with adaptation off fails both (1.63°, 0.95°)."""
    pa = np.max(np.abs(deg(braking["passive"])))
    for k, ok in (("wrong_design", True), ("wrong_design_fixed", False)):
        peak, settle = np.max(np.abs(deg(braking[k]))), np.max(np.abs(deg(braking[k], 4.0, 9.0)))
        assert (peak <= 0.2 * pa) == ok, (k, peak, pa)
        assert (settle < 0.2) == ok, (k, settle)


def test_actuator_polarities(braking):
    """Thesis: in squat the leading (front) actuator compresses and the trailing one extends; the
    polarities reverse in braking.  Positive force pushes the body up (extends the suspension)."""
    ts = braking["mimo_mrac"]
    acc = ts[(ts.t > 4) & (ts.t < 9)]
    brk = ts[(ts.t > 9.5) & (ts.t < 11)]
    assert acc.actuator_force_front.mean() < -500 and acc.actuator_force_rear.mean() > 500
    assert brk.actuator_force_front.mean() > 500 and brk.actuator_force_rear.mean() < -500
    # the pair balances the manoeuvre moment M·a_x·h: |F| ≈ M·|a_x|·h/(a + b) per axle
    assert acc.actuator_force_rear.mean() == pytest.approx(500 * 4 * 1.25 / 3.0, rel=0.25)
    assert brk.actuator_force_front.mean() == pytest.approx(500 * 7 * 1.25 / 3.0, rel=0.25)


def _variants(root, name, only=None, duration=None):
    sc = parse_scenario(read_yaml(root / "scenarios" / f"{name}.yaml"))
    runs = {v: s for v, s in sc.expand() if only is None or v in only}
    for s in runs.values():
        if duration:
            s.sim.duration = duration
    return {v: Simulation([s]).run()[0].ts for v, s in runs.items()}


def _err(ts, ref, col, t0, t1):
    m = ((ts.t >= t0) & (ts.t < t1)).to_numpy()
    return float(np.sqrt(np.mean((ts[col].to_numpy() - ref[col].to_numpy())[m] ** 2)))


@pytest.fixture(scope="module")
def road(request):
    return _variants(request.config.rootpath, "thesis_ch7_road", only=("passive", "mimo_mrac", "mimo_fixed"))


def test_road_excited_bounce_and_pitch_follow_the_reference(road):
    """Thesis Sec. 7.5.1 (Figs. 7.4–7.5): on sines reaching the rear wheel τ = L/v later (bounce and pitch both
    excited), with the spring drift and the manoeuvre at 20/40 s, the MRAC follows the two-tier skyhook
    reference after 4 s.  Both baselines fail the same bound: the passive car (error ≥ 5×) and the MRAC with
    adaptation off (the nominal Θ held: error ≥ 2×)."""
    m = road["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"], pitch=m["ctrl.ref_pitch"])
    pa = road["passive"]
    assert np.sqrt(np.mean(pa.body_z[(pa.t > 4) & (pa.t < 20)] ** 2)) > 0.005  # bounce is excited
    for col in ("body_z", "pitch"):
        e = {k: _err(road[k], ref, col, 4, 60) for k in ("mimo_mrac", "mimo_fixed", "passive")}
        assert e["mimo_mrac"] < 0.2 * e["passive"], (col, e)
        assert e["mimo_mrac"] < 0.5 * e["mimo_fixed"], (col, e)  # adaptation is what does it
    dive = {k: np.degrees(np.max((road[k].pitch - ref.pitch)[(road[k].t >= 40) & (road[k].t < 43)]))
            for k in road}
    assert dive["passive"] > 4.0 and dive["mimo_mrac"] < 0.2 * dive["passive"]
    assert dive["mimo_fixed"] > 2 * dive["mimo_mrac"]


def test_adaptation_from_a_wrong_design_within_4_s(request):
    """Thesis: bounce and pitch adapt within the first 4 s from arbitrary initial parameters.  From a stated wrong
    design (variant wrong_design, ours: nominal M_s +20 %, I −20 %, K0 −30 %, C0 +30 %; the reference keeps the
    thesis's M_s, I; first 20 s, before the manoeuvre and the drift's effect matter) the MRAC's bounce and pitch
    errors at 4–20 s are below half those of the same wrong design with adaptation off, and already in 0–4 s below
    0.6× the baseline's: the baseline fails both."""
    ts = _variants(request.config.rootpath, "thesis_ch7_road", only=("wrong_design", "wrong_design_fixed"), duration=20.0)

    def own(t, col, t0, t1):
        return _err(t, t.assign(body_z=t["ctrl.ref_z"], pitch=t["ctrl.ref_pitch"]), col, t0, t1)

    for col in ("body_z", "pitch"):
        ad, off = ts["wrong_design"], ts["wrong_design_fixed"]
        assert own(ad, col, 4, 20) < 0.5 * own(off, col, 4, 20), col
        assert own(ad, col, 0, 4) < 0.6 * own(off, col, 0, 4), col


@pytest.fixture(scope="module")
def dirt(request):
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_dirt.yaml"))
    # the probing variants: their own 20-s test below; the κ = 1 laws (the printed default, and with our bias): the
    # next test
    only = [v for v, _ in sc.expand() if "probe" not in v and not v.startswith("mimo_mrac_thesis")]
    return _variants(request.config.rootpath, "thesis_ch7_dirt", only=only)


def test_printed_law_runs_away_on_the_dirt_road(request):
    """The scenario default (variant mimo_mrac_thesis: κ = 1, the printed regressor without a constant) runs away on
    the dirt road within the first seconds (measured stop 2.04 s), and so does κ = 1 with our bias
    (mimo_mrac_thesis_bias, 1.05 s); the fixture's runs (ours, κ = 0.2) cover the whole 60 s."""
    sc = dict(parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_dirt.yaml")).expand())
    for k in ("mimo_mrac_thesis", "mimo_mrac_thesis_bias"):
        s = sc[k]
        s.sim.duration = 4.0
        with pytest.raises(SimulationDiverged) as ei:
            Simulation([s]).run()
        assert ei.value.time < 4.0, k


def test_dirt_road_following_is_not_reproduced(dirt):
    """Thesis Sec. 7.5.2 (Fig. 7.8): on the dirt road the active car follows the reference closely.  Ours does
    not: with the braking tuning (covariance addition Q = 1e-6) the estimates drift and the bounce error grows
    past the passive car's; with Q = 0 it stays bounded but no better than the nominal design held fixed, and
    the body acceleration of every controlled car is above passive.  This pins that (see the page)."""
    ts = dirt
    m = ts["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"])
    e = {k: _err(t, ref, "body_z", 4, 60) for k, t in ts.items()}
    acc = {k: float(np.sqrt(np.mean(t.body_acc[t.t > 4] ** 2))) for k, t in ts.items()}
    assert e["mimo_mrac"] > e["passive"]
    assert e["mimo_mrac_q0"] > 0.8 * e["mimo_fixed"]
    assert e["mimo_mrac_q0"] < 0.7 * e["passive"]
    assert min(acc["mimo_mrac_q0"], acc["mimo_fixed"], acc["mimo_mrac"]) > acc["passive"]


def test_dirt_road_from_a_wrong_design(dirt):
    """From the stated wrong design (ours: nominal M_s +20 %, I −20 %, K0 −30 %, C0 +30 %; the reference keeps the
    thesis's M_s, I) the dirt road does not show the claim either.  "Follows the reference very closely" (Fig. 7.8),
    read as an error below half the reference's own motion (7.7 mm RMS), fails for the wrong start with q0 (measured
    8.6 mm), for the wrong design held fixed (10.6 mm) and for the braking tuning, which drifts as from the nominal
    start (162 mm, above passive).  The q0 estimator buys ≈ 20 % over the wrong design held (at the 0.8× line an
    adaptation claim must reach; the ratio moves by 1.7 % under step halving, so no verdict rests on it).  This pins
    the "not"."""
    m = dirt["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"])
    e = {k: _err(t, ref, "body_z", 4, 60) for k, t in dirt.items()}
    motion = float(np.sqrt(np.mean(m["ctrl.ref_z"][(m.t >= 4) & (m.t < 60)] ** 2)))
    assert np.max(np.abs(dirt["wrong_design"]["ctrl.ref_z"] - m["ctrl.ref_z"])) < 1e-12  # one reference for all
    for k in ("wrong_design_q0", "wrong_design_fixed", "wrong_design"):
        assert not e[k] < 0.5 * motion, (k, e[k], motion)
    assert e["wrong_design_q0"] < 0.5 * e["passive"]  # bounded, unlike the braking tuning
    assert e["wrong_design"] > e["passive"]


def test_dirt_road_drives_the_beta0_inverse_estimate_to_its_bound(request, dirt):
    """Why the Ch. 7 estimator does not adapt usefully on the dirt road (page): it regresses U[k−D] on the filtered
    measured output a_m(q⁻¹)Y[k], which carries the road's disturbance; least squares then shrinks the coefficient of
    that regressor, the (β0)⁻¹ diagonal that scales the whole regulator, onto its projection bound (0.2× nominal)
    within the first 20 s, with and without covariance addition.  On the road-excited sines (little unmodelled
    disturbance) it stays near nominal (checked on the first 20 s of thesis_ch7_road)."""
    for k in ("mimo_mrac", "mimo_mrac_q0"):
        t = dirt[k]
        for c in ("ctrl.theta.14", "ctrl.theta.17"):
            v0, v = t[c].iloc[0], t[c][t.t > 20].to_numpy()
            assert np.all(np.abs(v / v0 - 0.2) < 0.01), (k, c)  # at the 0.2× bound (within 1 % of it)
    road = _variants(request.config.rootpath, "thesis_ch7_road", only=("mimo_mrac",), duration=20.0)["mimo_mrac"]
    for c in ("ctrl.theta.14", "ctrl.theta.17"):
        assert abs(road[c].iloc[-1] / road[c].iloc[0] - 1) < 0.5, c


def test_the_pull_on_beta0_inverse_is_the_direct_form_estimators():
    """Whose is the dirt road's pull on (β0)⁻¹ (page, Ch. 7 dirt road)?  Without feedback (a random 1 kN force on each
    actuator, 12 s here, 30 s on the page) batch least squares of the estimator's own identity (the direct form, the
    measured output a_m(q⁻¹)Y[k] in the regressor) gives (β0)⁻¹ ≈ 0.16× nominal on the dirt road (measured 0.16 /
    0.15) but ≈ 0.78× on a flat road (the baseline, where little disturbance enters the regressor): the pull is the
    estimator form's errors-in-variables bias, not the feedback.  The thesis's printed regressor (Eq. 7.44, the road
    terms ΔW added) does not remove it (0.13 / 0.19); the forward (predictor) form, with the disturbance in the
    regressed variable, is not pulled down (1.33 / 1.47)."""
    from suspension_sim.reproductions import framework as fw
    from suspension_sim.reproductions.thesis import ch7_regression

    ol, _, _ = ch7_regression(fw.Context(), duration=12.0)
    assert min(ol["flat"]["direct"]) > 0.6, ol["flat"]  # the baseline is not pulled down
    assert max(ol["dirt"]["direct"]) < 0.3, ol["dirt"]
    assert max(ol["dirt"]["direct_w"]) < 0.3, ol["dirt"]  # the thesis's road terms do not cure it
    assert min(ol["dirt"]["forward"]) > 0.8, ol["dirt"]


def test_road_no_bias_bounce_error_converges_on_halving(request):
    """Issue 12 item 3: the road-excited no-bias variant (κ = 0.2, the printed φ) at the scenario's discretisation
    (RK4 at 0.25 ms, friction/damper/stop forces as their means over each step) changes its bounce error 4–20 s by
    < 2 % when the physics step is halved (measured 3.866 → 3.868 mm).  The former discretisation (`auto`, i.e.
    trapezoidal = implicitfast on this car without linear dampers, 0.5 → 0.25 ms, forces held from the step's
    start) fails the same check: 3.600 → 3.724 mm (3.5 %), first order through the stiff tanh friction."""
    sc = parse_scenario(read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_road.yaml"))
    base = dict(sc.expand())["mimo_mrac_no_bias"]

    def err(dt, former=False):
        s = base.model_copy(deep=True)
        s.sim.duration, s.sim.dt = 20.0, dt
        if former:
            s.sim.integrator = "auto"
            for e in s.vehicle.effects:
                e.params["step_force"] = "start"
        t = Simulation([s]).run()[0].ts
        return _err(t, t.assign(body_z=t["ctrl.ref_z"]), "body_z", 4, 20)

    dt = base.sim.dt
    a, b = err(dt), err(dt / 2)
    assert abs(b - a) / a < 0.02, (a, b)
    fa, fb = err(0.0005, True), err(0.00025, True)
    assert abs(fb - fa) / fa > 0.02, (fa, fb)  # the former discretisation: first order, fails the check


@pytest.mark.slow
def test_road_excited_full_run_from_a_wrong_design(request):
    """The whole road-excited run (manoeuvre at 20/40 s, drifts) from the stated wrong design, the page's "partly":
    after 4 s the bounce error stays within 1.2× the right design's in 4–20, 20–40 and 44–60 s (measured 0.20, 0.23,
    0.16 vs 0.23, 0.32, 0.31 mm) and the dive (40–43 s) is ≤ 0.2× passive (0.50° vs 6.58°); the same wrong design with
    adaptation off fails it (bounce 1.43, 5.39, 8.66 mm).  The pitch error stays 1.3–1.4× the right design's in 4–40 s
    (0.019, 0.030 vs 0.014, 0.023°; a tenth of the reference's 0.18° RMS), below the baseline's in every window."""
    ts = _variants(request.config.rootpath, "thesis_ch7_road",
                   only=("passive", "mimo_mrac", "wrong_design", "wrong_design_fixed"))
    m = ts["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"], pitch=m["ctrl.ref_pitch"])
    dive = {k: np.degrees(np.max((t.pitch - ref.pitch)[(t.t >= 40) & (t.t < 43)])) for k, t in ts.items()}

    wins = ((4, 20), (20, 40), (44, 60))

    def ok(k):
        return all(_err(ts[k], ref, "body_z", a, b) <= 1.2 * _err(m, ref, "body_z", a, b)
                   for a, b in wins) and dive[k] < 0.2 * dive["passive"]

    assert ok("wrong_design")
    assert not ok("wrong_design_fixed")
    for a, b in wins:
        assert _err(ts["wrong_design"], ref, "pitch", a, b) < 0.5 * _err(ts["wrong_design_fixed"], ref, "pitch", a, b)


IV = {"probe_amplitude": 300.0, "estimator": "iv_probe", "p0": 1e-10, "p0_bias": 1e-12, "q_bias": 0.0}


def _dirt_run(root, variant, params, duration):
    raw = read_yaml(root / "scenarios" / "thesis_ch7_dirt.yaml")
    sc = dict(parse_scenario(raw).expand())[variant]
    sc.sim.duration = duration
    sc.controller.params.update(params)
    return Simulation([sc]).run()[0].ts


def test_iv_probe_estimator_is_the_recursive_iv_of_its_docstring(request):
    """The named variant ``estimator: iv_probe`` (ours): replaying the run's own log through a plain numpy
    recursive IV (instrument = the estimator's regressor built from the nominal DARMA model's response to the probe
    alone) gives the kernel's Θ to round-off, 1 s from the right design."""
    from suspension_sim.controllers.thesis_common import am_poly, darma

    ts = _dirt_run(request.config.rootpath, "mimo_mrac_q0", {**IV, "p0": 1e-8, "p0_bias": 1e-8}, 1.0)
    TH = ts[[f"ctrl.theta.{i}" for i in range(18)]].to_numpy()
    th0 = TH[0].reshape(-1, 2)
    am = am_poly(2 * np.pi * 2.0, 1.0, 0.01)

    def pad(a):
        return np.vstack([np.zeros((3, a.shape[1])), a])

    W = ts[["road_front", "road_rear"]].to_numpy()
    Y = pad(ts[["body_z", "pitch"]].to_numpy())
    U = pad(ts[["command_front", "command_rear"]].to_numpy() + 17000 * W
            + 500 * ts[["road_vel_front", "road_vel_rear"]].to_numpy())
    E = pad(ts[["ctrl.probe.0", "ctrl.probe.1"]].to_numpy())
    assert set(np.unique(np.abs(E[3:]))) == {300.0}
    T = np.array([[1.0, -1.5], [1.0, 1.5]])
    Mi = np.linalg.inv(np.diag([500.0, 1125.0]))
    Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-Mi @ T.T @ (17000 * T), -Mi @ T.T @ (500 * T)]])
    A, B = darma(Ac, np.vstack([np.zeros((2, 2)), Mi @ T.T]), np.hstack([np.eye(2), np.zeros((2, 2))]), 0.01)
    Ye = np.zeros_like(E)
    for i in range(2, len(E)):
        Ye[i] = -A[1] @ Ye[i - 1] - A[2] @ Ye[i - 2] + B[1] @ E[i - 1] + B[2] @ E[i - 2]

    def yb(X, i):
        return am[0] * X[i] + am[1] * X[i - 1] + am[2] * X[i - 2]

    sc = np.max(np.abs(th0), axis=1)
    sc[sc == 0] = 1000.0
    th, P = th0 / sc[:, None], np.eye(9) * 1e-8
    moved = 0.0
    for k in range(4, len(Y)):
        f = np.concatenate([-Y[k - 1], -Y[k - 2], -U[k - 2], [-1.0], yb(Y, k)]) * sc
        z = np.concatenate([-Ye[k - 1], -Ye[k - 2], -E[k - 2], [-1.0], yb(Ye, k)]) * sc
        Pz = P @ z
        d = 1 + f @ Pz
        th += np.outer(Pz, U[k - 1] - th.T @ f) / d
        P -= np.outer(Pz, P.T @ f) / d
        got = TH[k - 3]
        assert np.max(np.abs((th * sc[:, None]).ravel() - got)) < 1e-12 * np.max(np.abs(got)), k
        moved = max(moved, np.max(np.abs(got - TH[0])) / np.max(np.abs(TH[0])))
    assert moved > 0.01  # the estimate did move (the check is not of a frozen Θ)


def test_dirt_road_probe_and_iv_remove_the_pull_on_beta0_inverse_least_squares_does_not(request):
    """Issue 12, Ch. 7 dirt road: the pull of the (β0)⁻¹ estimate is the direct-form estimator's errors-in-variables
    bias.  With closed-loop probing (a ±300 N random force per actuator, ours) and the instrumental-variable
    estimator (variant ``wrong_design_iv_probe``, ours), from the stated wrong design, the (β0)⁻¹ diagonal is not
    pulled down in 20 s (measured 1.01 / 1.01 × its start); the baseline, the thesis's least squares with the same
    probe (``wrong_design_ls_probe``), is pulled to its 0.2× bound (0.20 / 0.21).  The page: the claim is still not
    reproduced (60 s: bounce error 10.8 mm against a 7.7 mm reference motion, the wrong design held fixed with the
    probe 10.7 mm), and the IV loop diverges on 2 of 5 road realisations."""
    ts = _variants(request.config.rootpath, "thesis_ch7_dirt", only=("wrong_design_iv_probe", "wrong_design_ls_probe"),
                   duration=20.0)

    def diag(t):
        th = t[["ctrl.theta.14", "ctrl.theta.17"]].to_numpy()
        return th[-1] / th[0]

    assert np.all(np.abs(diag(ts["wrong_design_iv_probe"]) - 1) < 0.1), diag(ts["wrong_design_iv_probe"])
    assert np.all(diag(ts["wrong_design_ls_probe"]) < 0.3), diag(ts["wrong_design_ls_probe"])


def test_iv_probe_without_a_probe_is_a_one_line_error(request):
    from suspension_sim.errors import ScenarioError

    raw = read_yaml(request.config.rootpath / "scenarios" / "thesis_ch7_dirt.yaml")
    raw.pop("variants")
    raw["controller"]["params"]["estimator"] = "iv_probe"
    with pytest.raises(ScenarioError, match="probe_amplitude > 0"):
        parse_scenario(raw)
