"""Kim (1996) nonlinear indirect adaptive force control (controllers/kim.py) on the hydraulic quarter car:
the behaviours of Figs. 2–5 (1 Hz, 2.54 cm road sine), starting from wrong estimates (a2 −20 %, a3 +20 %, the
scenarios' default), each against its baseline (the same wrong estimates without adaptation, or the passive
car).  The full figures: ``suspension-sim reproduce kim`` (tests/test_reproduce.py, slow)."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import load_scenario
from suspension_sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
A2, A3 = 15.125e9, 5.176e5


def _case(duration=3.0, **params):
    sc = load_scenario(ROOT / "scenarios/kim_fig2.yaml")
    sc.variants = {}
    sc.sim.duration = duration
    sc.sim.dt = sc.sim.control_dt = 1e-4  # Fig. 2's scenario runs at 0.025 ms for its page; 0.1 ms suffices here
    sc.outputs.plots = False
    sc = copy.deepcopy(sc)
    sc.controller.params.update(params)
    return sc


def rms(x):
    return float(np.sqrt(np.mean(np.asarray(x, float) ** 2)))


CASES = {"fig2": dict(k_d=10, use_fd_dot=True), "fig3": dict(k_d=10, use_fd_dot=False),
         "fig4": dict(k_d=1000, use_fd_dot=True), "fig5": dict(k_d=1000, use_fd_dot=False)}


@pytest.fixture(scope="module")
def figs():
    """Figs. 2–5 from the wrong initial estimates, adaptive, non-adaptive and with known parameters (3 s)."""
    runs = {}
    for k, p in CASES.items():
        runs[(k, "adaptive")] = _case(**p)
        runs[(k, "nonadaptive")] = _case(adaptive=False, **p)
        runs[(k, "known")] = _case(adaptive=False, a2=A2, a3=A3, **p)
    res = Simulation(list(runs.values())).run()
    return {k: r.ts for k, r in zip(runs, res)}


def _track(ts):
    m = ts.t >= 2.0
    e = (ts["ctrl.F_a"] - ts["ctrl.F_d"])[m]
    return rms(e), rms(e) / rms(ts["ctrl.F_d"][m])


def test_force_tracking_with_and_without_the_desired_force_derivative(figs):
    err = {k: _track(figs[(k, "adaptive")]) for k in CASES}
    # with dF_d/dt both gains track (Figs. 2 and 4); k_d = 10 leaves a few per cent (the page: 5.9 % at 0.025 ms;
    # the spool lag the reduced model drops)
    assert err["fig4"][1] < 0.02 and err["fig2"][1] < 0.15, err
    # without it, k_d = 10 leaves a large error (Fig. 3), k_d = 1000 does not (Fig. 5)
    assert err["fig3"][1] > 0.3, err
    assert err["fig3"][0] > 10 * err["fig5"][0], err
    assert err["fig5"][1] < 0.02, err
    # and the derivative is what makes k_d = 10 work
    assert err["fig3"][0] > 5 * err["fig2"][0], err
    # baseline: the same wrong estimates without adaptation do not track in any figure
    for k in ("fig2", "fig4", "fig5"):
        assert _track(figs[(k, "nonadaptive")])[0] > 10 * err[k][0], k
    assert _track(figs[("fig3", "nonadaptive")])[0] > 1.2 * err["fig3"][0]  # Fig. 3 is bad either way


@pytest.mark.parametrize("fig", ["fig2", "fig4", "fig5"])
def test_estimates_converge_and_performance_approaches_the_known_case(figs, fig):
    def pe_decays(ts):
        t, pe = ts.t.to_numpy(), ts["ctrl.p_e"].to_numpy()
        return rms(pe[t > 2.0]) < 0.05 * np.max(np.abs(pe[t < 1.0]))

    ts = figs[(fig, "adaptive")]
    assert pe_decays(ts)
    # baseline: with the same wrong estimates and no adaptation the estimator error stays (θ̃ᵀY_r/α1 persists)
    assert not pe_decays(figs[(fig, "nonadaptive")])
    # from −20 % / +20 % to within 2 % in 3 s (Fig. 4/5 keep ~0.8 % along the poorly excited direction
    # θ ∝ θ̂, which scales f̂ and ĝ together and barely changes the force)
    assert abs(ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) < 0.02
    assert abs(ts["ctrl.a3_hat"].iloc[-1] / A3 - 1) < 0.02
    assert abs(figs[(fig, "nonadaptive")]["ctrl.a2_hat"].iloc[-1] / A2 - 1) > 0.1  # the baseline's estimates stay
    e_ad, e_known, e_non = (_track(figs[(fig, v)])[0] for v in ("adaptive", "known", "nonadaptive"))
    assert e_ad < 1.5 * e_known + 1.0, (e_ad, e_known)
    assert e_non > 10 * e_known + 10.0, (e_non, e_known)  # the baseline stays far from the known case


def test_kd_changes_the_excitation_not_the_estimation_equations():
    """Kim: "k_d does not affect the estimation error system".  With a small adaptation gain (1e-10) and
    a2 −5 %, a3 +5 %, k_d = 10 lets the uncancelled hydraulic-spring term lock the suspension, the regressor
    A·(ẋ2 − ẋ1) collapses and the estimates stall; k_d = 1000 keeps the deflection rate and converges.  A
    100× larger gain converges at both k_d (the claim holds once adaptation outruns the locking)."""
    runs = {(g, kd): _case(duration=3.0, k_d=kd, a2=0.95 * A2, a3=1.05 * A3,
                           gain_a1=g, gain_a2=g, gain_a3=g) for g in (1e-10, 1e-8) for kd in (10, 1000)}
    res = dict(zip(runs, Simulation(list(runs.values())).run()))
    err = {k: abs(r.ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) for k, r in res.items()}
    rate = {k: rms(r.ts.travel_rate[r.ts.t >= 2.0]) for k, r in res.items()}
    assert err[(1e-10, 10)] > 0.04 and err[(1e-10, 1000)] < 0.025, err
    assert rate[(1e-10, 10)] < 0.3 * rate[(1e-10, 1000)], rate
    assert err[(1e-8, 10)] < 0.01 and err[(1e-8, 1000)] < 0.01, err
    assert rate[(1e-8, 10)] > 0.9 * rate[(1e-8, 1000)], rate
    # per unit of delivered excitation Γ·∫(a2·A·(ẋ2 − ẋ1))²dt the â2 error decays alike at both k_d (the estimation
    # system itself has no k_d), although the raw errors differ several-fold
    per = {}
    for kd in (10, 1000):
        ts = res[(1e-10, kd)].ts
        y2 = A2 * 3.35e-4 * ts.travel_rate.to_numpy()
        exc = 1e-10 * float(np.sum(y2[1:] ** 2 * np.diff(ts.t.to_numpy())))
        per[kd] = np.log(0.05 / err[(1e-10, kd)]) / exc
    assert 0.5 < per[10] / per[1000] < 2.0, per
    assert err[(1e-10, 10)] > 3 * err[(1e-10, 1000)], err


def test_body_motion_at_1hz_below_passive(figs):
    sc = load_scenario(ROOT / "scenarios/kim_fig2.yaml")
    passive = dict(sc.expand())["passive"]
    passive.sim.duration = 3.0
    p = Simulation([passive]).run()[0].ts
    peak_p = np.max(np.abs(p.body_z[p.t >= 2.0]))
    for k in CASES:
        ts = figs[(k, "adaptive")]
        assert np.max(np.abs(ts.body_z[ts.t >= 2.0])) < 0.6 * peak_p, k


@pytest.mark.slow
def test_kd_study_residual_estimate_error_is_first_order_in_the_step():
    """The k_d study at the scenarios' gain (1e-8, a2 −5 %): what is left of the â2 error after 5 s (≈ 0.02–0.08 %)
    moves by 3–10 % of itself when the step (physics = control) is halved from the page's 0.025 ms.  It is a step
    error, not noise: the change halves with each halving (first order), and against the 5 % start error, the scale
    the reproduction compares it with, it is < 0.1 %.  (≈ 40 s.)"""
    def err(dt, kd):
        sc = _case(duration=5.0, k_d=kd, a2=0.95 * A2, a3=1.05 * A3, gain_a1=1e-8, gain_a2=1e-8, gain_a3=1e-8)
        sc.sim.dt = sc.sim.control_dt = dt
        return sc
    steps = (2.5e-5, 1.25e-5, 6.25e-6)
    res = {}
    for dt in steps:  # one ensemble per step (an ensemble shares its timing)
        res.update({(dt, kd): r for kd, r in zip((10, 1000), Simulation([err(dt, kd) for kd in (10, 1000)]).run())})
    for kd in (10, 1000):
        e = [abs(res[(dt, kd)].ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) for dt in steps]
        d1, d2 = e[1] - e[0], e[2] - e[1]
        assert e[0] < 0.001 and abs(d1) / e[0] > 0.02, (kd, e)  # near zero, and > 2 % of itself per halving
        assert 0.35 < d2 / d1 < 0.65, (kd, e)  # first order: the change halves with the step
        assert abs(d1) < 0.001 * 0.05, (kd, e)  # < 0.1 % of the 5 % start error
