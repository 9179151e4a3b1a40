"""Fallah, Sorniotti & Gruber robust bang-bang controller (controllers/fallah.py).

- the LMI solution: P(θ) > 0 and A(θ)ᵀP(θ) + P(θ)A(θ) < 0 on a fine θ grid (not only the two vertices the
  LMIs constrain: multi-convexity must carry them over), the affine model is exact in 1/m_s; an unstable
  corner model gives a one-line ScenarioError;
- the reconstructed hybrid differentiator (19) is a derivative (exact on quadratics);
- closed loop on the full car, bump at 35 km/h and the ISO 3888-1 double lane change, against passive:
  forces within ±f_max; controlled beats passive on the comfort metrics (bump: RMS heave acceleration,
  RMS and peak pitch; DLC: RMS roll acceleration and RMS vertical acceleration of the body above the
  corners); the estimator tracks the truth: Δ̇ within 1 % (RMS, relative), and the corner body velocity
  estimate equals what the paper's method must give — true corner velocity minus the running mean of the
  true c.g. velocity since t = 0 (the default, the paper as printed) or over the 2 s window (variant
  fallah_window, ours) — within 2 % (the mean removal itself is the method's error, stated in
  docs/reproductions/fallah_sorniotti_gruber.md);
- Eq. (18) as printed (variant fallah_printed_sigmoid) is one-sided: it only pushes up and lifts the car before
  the bump, which our symmetric reconstruction (the default) does not.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from suspension_sim.controllers.fallah import HYBRID_COEFS, affine_model, quarter_car_matrices, solve_lmis
from suspension_sim.config import load_scenario
from suspension_sim.errors import ScenarioError
from suspension_sim.simulation import Simulation

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
SCALES = np.array([0.05, 0.2, 0.05, 0.5])
Q = np.diag([1.0, 4.0, 1.0, 0.1])


def _solve(ms=416.5, mu=40.0, ks=20000.0, bs=1700.0, kt=200000.0, rel=0.1):
    A0, A1 = affine_model(ms, mu, ks, bs, kt, rel)
    Sc, Si = np.diag(SCALES), np.diag(1 / SCALES)
    P0, P1 = solve_lmis(Si @ A0 @ Sc, Si @ A1 @ Sc, Q)
    return A0, A1, Si @ P0 @ Si, Si @ P1 @ Si


def test_lmi_solution_holds_over_the_whole_uncertainty_range():
    ms, rel = 416.5, 0.1
    A0, A1, P0, P1 = _solve(ms=ms, rel=rel)
    for th in np.linspace(-1, 1, 41):
        A, P = A0 + th * A1, P0 + th * P1
        assert np.linalg.eigvalsh(P).min() > 0
        assert np.linalg.eigvalsh(A.T @ P + P @ A).max() < 0
    assert np.linalg.eigvalsh(A1.T @ P1 + P1 @ A1).min() > -1e-6 * np.abs(P1).max()
    # θ = ±1 are the mass bounds (A is affine in 1/m_s)
    Alo, _, _ = quarter_car_matrices((1 + rel) * ms, 40.0, 20000.0, 1700.0, 200000.0)
    Ahi, _, _ = quarter_car_matrices((1 - rel) * ms, 40.0, 20000.0, 1700.0, 200000.0)
    np.testing.assert_allclose(A0 - A1, Alo, rtol=1e-12)
    np.testing.assert_allclose(A0 + A1, Ahi, rtol=1e-12)


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")
def test_infeasible_lmis_give_a_clear_error():
    with pytest.raises(ScenarioError, match="infeasible"):
        _solve(ks=-20000.0)  # a negative spring: no quadratic Lyapunov function exists


def test_hybrid_differentiator_is_exact_on_quadratics():
    dt = 1e-3
    t = -dt * np.arange(6)
    for f, df in ((lambda x: 3 + 2 * x, 2.0), (lambda x: 1 - 4 * x + 7 * x ** 2, -4.0)):
        assert HYBRID_COEFS @ f(t) / dt == pytest.approx(df, rel=1e-9)


def _pair(path, duration):
    sc = load_scenario(path, overrides=[f"sim.duration={duration}"])
    out = {}
    for name, s in sc.expand(path):
        if name in ("passive", "fallah", "fallah_window", "fallah_printed_sigmoid"):
            out[name] = Simulation([s], path).run()[0]
    return out


@pytest.fixture(scope="module")
def bump():
    return _pair(str(SCENARIOS / "fallah_bump.yaml"), 3.0)


@pytest.fixture(scope="module")
def dlc():
    return _pair(str(SCENARIOS / "fallah_dlc.yaml"), 6.5)


def _forces(r):
    ts = r.ts
    return np.stack([ts[f"actuator_force{s}"] for s in r.info["suffixes"]])


def _corner_truth(r):
    ts, info = r.ts, r.info
    v = np.stack([ts.body_vel + y * ts.roll_rate - x * ts.pitch_rate for x, y in zip(info["corner_x"], info["corner_y"])])
    acc = np.stack([ts.body_acc + y * ts.roll_acc - x * ts.pitch_acc for x, y in zip(info["corner_x"], info["corner_y"])])
    return v, acc


def _rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


@pytest.mark.parametrize("case", ["bump", "dlc"])
def test_forces_within_bounds(case, request):
    r = request.getfixturevalue(case)["fallah"]
    F = _forces(r)
    assert np.abs(F).max() <= 6000.0 + 1e-9
    assert np.abs(F).max() > 100.0  # the controller does act


def test_bump_controlled_beats_passive(bump):
    p, c = bump["passive"].metrics, bump["fallah"].metrics
    for k in ("body_acc_rms", "pitch_rms", "pitch_peak", "pitch_acc_rms"):
        assert c[k] < p[k], k


def test_dlc_controlled_beats_passive(dlc):
    p, c = dlc["passive"], dlc["fallah"]
    assert c.metrics["roll_acc_rms"] < p.metrics["roll_acc_rms"]
    assert _rms(_corner_truth(c)[1]) < _rms(_corner_truth(p)[1])  # vertical acceleration above the corners
    assert c.metrics["roll_rms"] < p.metrics["roll_rms"]


def test_dlc_roll_acceleration_halved_total_lateral_acceleration_not(dlc):
    """Fig. 8's "c.g. acceleration reduced by more than 50 %" (page: reproduced only on roll-derived components).
    The roll acceleration meets the paper's 50 % bound (measured 0.31× passive over the 6.5 s run) and the passive
    car (1.0×) fails it; the total lateral c.g. acceleration a_y + h·φ̈ does not (measured 1.01×, 2.61 → 2.63 m/s²:
    the imposed a_y dominates), which pins the page's "not" for the total."""
    from suspension_sim.maneuvers_dlc import DLCParams, DoubleLaneChange

    p, c = dlc["passive"], dlc["fallah"]
    for r, ok in ((c, True), (dlc["fallah_window"], True), (p, False)):
        assert (r.metrics["roll_acc_rms"] < 0.5 * p.metrics["roll_acc_rms"]) == ok
    mp = load_scenario(str(SCENARIOS / "fallah_dlc.yaml")).vehicle.maneuver.params
    _, ay = DoubleLaneChange(DLCParams(**mp)).accel(p.ts.t.to_numpy())
    lat = {k: _rms(ay + float(mp["cg_height"]) * r.ts.roll_acc.to_numpy()) for k, r in (("p", p), ("c", c))}
    assert lat["c"] > 0.9 * lat["p"], lat


def _moving_mean(x, n):
    c = np.concatenate([[0.0], np.cumsum(x)])
    k = np.arange(1, len(x) + 1)
    lo = np.maximum(k - n, 0)
    return (c[k] - c[lo]) / (k - lo)


@pytest.mark.parametrize("case", ["bump", "dlc"])
@pytest.mark.parametrize("variant, window", [("fallah", None), ("fallah_window", 2000)])
def test_estimator_tracks_truth(case, variant, window, request):
    r = request.getfixturevalue(case)[variant]
    ts = r.ts
    v_true, _ = _corner_truth(r)
    for c, s in enumerate(r.info["suffixes"]):
        dv = ts[f"travel_rate{s}"].to_numpy()
        assert _rms(ts[f"ctrl.dv_hat.{c}"] - dv) < 0.01 * _rms(dv)
    # the c.g. velocity by integration with the mean removal: v − mean(v) since t = 0 (the paper as printed) or
    # over the last 2 s at 1 kHz (fallah_window); the gyros map it to the corners exactly
    v_cg = ts.body_vel.to_numpy()
    expected = v_true - _moving_mean(v_cg, window or len(v_cg))
    est = np.stack([ts[f"ctrl.vs_hat.{c}"] for c in range(4)])
    assert _rms(est - expected) < 0.02 * _rms(v_true)


def test_bump_comfort_bound_holds_and_passive_fails_it(bump):
    """RMS heave acceleration and RMS pitch at most 0.7× the passive car's with the estimation as printed (the
    default: running velocity mean since t = 0, z_s the plain integral of (21); measured 0.46×, 0.49× over the 4 s
    run): the passive car itself (1.0×) fails the same bound.  Our additions to the estimation (variant
    fallah_window: a 2 s moving window, the mean also removed from z_s) keep it too (measured 0.47×, 0.49×)."""
    p = bump["passive"].metrics
    for name in ("fallah", "fallah_window", "passive"):
        m = bump[name].metrics
        ok = m["body_acc_rms"] < 0.7 * p["body_acc_rms"] and m["pitch_rms"] < 0.7 * p["pitch_rms"]
        assert ok == (name != "passive"), name


def test_near_sign_law_saturates_and_loses_to_passive():
    """The bang-bang regime (sigmoid slope 1000 s/m, ≈ sgn of Eq. 17) on the bump: the force sits at ±f_max
    most of the time and flips sign every few samples, and the heave acceleration exceeds the passive car's
    (documented in docs/reproductions/fallah_sorniotti_gruber.md); the smooth default (a = 4) on the same
    bump saturates never and beats passive."""
    path = str(SCENARIOS / "fallah_bump.yaml")
    sc = load_scenario(path, overrides=["sim.duration=3.0"])
    runs = dict(sc.expand(path))
    steep = load_scenario(path, overrides=["sim.duration=3.0", "controller.params.a=1000"])
    steep = dict(steep.expand(path))["fallah"]
    rp, r4, r1000 = (Simulation([s], path).run()[0] for s in (runs["passive"], runs["fallah"], steep))
    F = _forces(r1000)
    assert np.mean(np.abs(F) > 0.95 * 6000.0) > 0.5
    assert np.mean(np.sign(F[:, 1:]) != np.sign(F[:, :-1])) > 0.2  # chatter: flips in > 20 % of the samples
    assert r1000.metrics["body_acc_rms"] > rp.metrics["body_acc_rms"]
    F4 = _forces(r4)
    assert np.abs(F4).max() < 0.95 * 6000.0 and r4.metrics["body_acc_rms"] < rp.metrics["body_acc_rms"]


def test_near_sign_law_is_chaotic_the_smooth_law_is_not():
    """Why the near-sgn rows of reproduce fallah's bang_bang item are means over realisations: with ideal
    sensors, bump heights 1e-6 apart (relative, 0.1 µm) change the a = 1000 law's RMS heave acceleration by
    tens of per cent at one step (reproduce fallah, 1024 realisations, 4 s: 1.69–7.59× passive), while the smooth
    law (a = 4), the baseline, does not move (< 1e-4 relative)."""
    path = str(SCENARIOS / "fallah_bump.yaml")

    def spread(a):
        base = dict(load_scenario(path, overrides=["sim.duration=3.0", f"controller.params.a={a}"]).expand(path))["fallah"]
        scs = []
        for k in range(8):
            s = base.model_copy(deep=True)
            s.road.params["height"] = 0.1 * (1.0 + 1e-6 * k)
            scs.append(s)
        x = np.array([r.metrics["body_acc_rms"] for r in Simulation(scs, path).run()])
        return (x.max() - x.min()) / x.mean()

    assert spread(1000.0) > 0.05
    assert spread(4.0) < 1e-4


def test_noisy_sensors_keep_the_comfort_bound_that_passive_fails():
    """With the project's noisy IMU and LVDTs (variant fallah_noisy: 0.05 m/s², 0.005 rad/s, 0.2 mm) the smooth
    law still keeps the RMS heave acceleration below 0.7× the passive car's (measured 0.47×); the passive car
    (1.0×) fails the same bound.  In the bang-bang regime (a = 1000 s/m) the same noisy sensors make the law
    worse than passive (measured 6×)."""
    path = str(SCENARIOS / "fallah_bump.yaml")
    runs = dict(load_scenario(path, overrides=["sim.duration=3.0"]).expand(path))
    steep = dict(load_scenario(path, overrides=["sim.duration=3.0", "controller.params.a=1000"]).expand(path))
    rp, rn, rn1000 = (Simulation([s], path).run()[0]
                      for s in (runs["passive"], runs["fallah_noisy"], steep["fallah_noisy"]))
    p = rp.metrics["body_acc_rms"]
    for r, ok in ((rn, True), (rp, False)):
        assert (r.metrics["body_acc_rms"] < 0.7 * p) == ok
    assert rn1000.metrics["body_acc_rms"] > 2.0 * p
    assert np.abs(_forces(rn)).max() < 0.95 * 6000.0 and np.abs(_forces(rn1000)).max() > 0.95 * 6000.0
    # run length (page: the noisy near-sgn ratio to passive is a property of the window): after the bump, on the flat
    # road, the noisy near-sgn law keeps chattering (measured 5.5 m/s² RMS at 3–4 s) while the smooth noisy law is
    # nearly still (0.08 m/s²), so a whole-run RMS ratio to the settling passive car grows with the run length
    def tail(r):
        a = r.ts.body_acc.to_numpy()
        return float(np.sqrt(np.mean(a[r.ts.t.to_numpy() > 2.5] ** 2)))
    assert tail(rn1000) > 2.0 and tail(rn1000) > 10 * tail(rn)


def test_sprung_mass_off_by_ten_percent_keeps_the_comfort_bound_with_the_nominal_design(bump):
    """The paper's robustness claim (LMIs 14–16: sprung mass uncertain by ±10 %, the law at the nominal θ = 0): cars
    of sprung mass × 0.9 and × 1.1 driven with the design left at the nominal car's corner masses keep the bump's
    comfort bound (RMS heave acceleration and RMS pitch < 0.7× the passive car of the same mass; measured
    0.46–0.50×, reproduce fallah's item ``mass``); the passive car of each mass (1.0×) fails it."""
    path = str(SCENARIOS / "fallah_bump.yaml")
    info = bump["passive"].info
    ms0 = [float(info["static_suspension_force"][s]) / 9.81 for s in info["suffixes"]]
    v = dict(load_scenario(path, overrides=["sim.duration=3.0"]).expand(path))
    scs = {}
    for f in (0.9, 1.1):
        for k in ("passive", "fallah"):
            s = v[k].model_copy(deep=True)
            s.vehicle.params["sprung_mass"] = 1413.0 * f  # the full car's default, ± 10 %
            if k == "fallah":
                s.controller.params["sprung_mass"] = ms0
            scs[(f, k)] = s
    res = {k: Simulation([s], path).run()[0] for k, s in scs.items()}
    for f in (0.9, 1.1):
        p = res[(f, "passive")].metrics
        assert res[(f, "passive")].info["static_suspension_force"][info["suffixes"][0]] == pytest.approx(
            9.81 * ms0[0] * f, rel=1e-6)  # the car driven really is off-nominal
        for k in ("fallah", "passive"):
            m = res[(f, k)].metrics
            ok = m["body_acc_rms"] < 0.7 * p["body_acc_rms"] and m["pitch_rms"] < 0.7 * p["pitch_rms"]
            assert ok == (k == "fallah"), (f, k)


def test_printed_one_sided_sigmoid_only_pushes_up_and_lifts_the_car_before_the_bump(bump):
    """Eq. (18) as printed, f = −f_max/(1 + e^(−a·B1ᵀPx + c)) (variant fallah_printed_sigmoid), is one-sided: in our
    convention F = f_max/(1 + e^(a·s + c)) ∈ (0, f_max), f_max/2 = 3 kN per corner at s = 0, so it throws the car up at
    t = 0, before the bump arrives at 0.53 s (measured: the body 11 cm up at 0.5 s, never a downward force).  Our
    symmetric reconstruction (the default), the baseline, fails both: it pulls down as well and leaves the car
    at rest before the bump."""
    for name, printed in (("fallah_printed_sigmoid", True), ("fallah", False)):
        r = bump[name]
        t, z = r.ts.t.to_numpy(), r.ts.body_z.to_numpy()
        assert (_forces(r).min() >= 0.0) == printed, name
        assert (z[t <= 0.5][-1] > 0.05) == printed, name
        assert (abs(z[t <= 0.5][-1]) < 1e-3) == (not printed), name
