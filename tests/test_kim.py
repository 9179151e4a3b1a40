"""Kim (1996) nonlinear indirect adaptive force control (controllers/kim.py) on the hydraulic quarter car:
the behaviours of Figs. 2–5 (1 Hz, 2.54 cm road sine)."""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import load_scenario
from suspension_sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
A2, A3 = 15.125e9, 5.176e5


def _case(duration=2.0, **params):
    sc = load_scenario(ROOT / "scenarios/kim_fig2.yaml")
    sc.variants = {}
    sc.sim.duration = duration
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
    """The four cases of Figs. 2–5 as one ensemble (2 s each)."""
    res = Simulation([_case(**p) for p in CASES.values()]).run()
    return {k: r.ts for k, r in zip(CASES, res)}


def _track(ts):
    m = ts.t >= 1.0
    e = (ts["ctrl.F_a"] - ts["ctrl.F_d"])[m]
    return rms(e), rms(e) / rms(ts["ctrl.F_d"][m])


def test_force_tracking_with_and_without_the_desired_force_derivative(figs):
    err = {k: _track(ts) for k, ts in figs.items()}
    # with dF_d/dt the tracking is good for both gains (Figs. 2 and 4)
    assert err["fig2"][1] < 0.1 and err["fig4"][1] < 0.1, err
    # without it, k_d = 10 leaves a large error (Fig. 3), k_d = 1000 does not (Fig. 5)
    assert err["fig3"][1] > 0.3, err
    assert err["fig3"][0] > 10 * err["fig5"][0], err
    assert err["fig5"][1] < 0.1, err
    # and the derivative is what makes k_d = 10 work
    assert err["fig3"][0] > 5 * err["fig2"][0], err


def test_estimation_error_decays_and_estimates_stay_bounded(figs):
    for k, ts in figs.items():
        pe = ts["ctrl.p_e"].to_numpy()
        t = ts.t.to_numpy()
        assert np.all(np.isfinite(pe)), k
        assert rms(pe[t > 1.5]) < 0.3 * np.max(np.abs(pe[t < 0.5])), k
        assert abs(ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) < 0.2, k
        assert abs(ts["ctrl.a3_hat"].iloc[-1] / A3 - 1) < 0.2, k


def test_adaptation_removes_an_initial_parameter_error():
    """Not in the paper (its estimates start at the true values): a2 −5 %, a3 +5 % at k_d = 1000.  With the
    chosen gains the (p_e, θ̃) loop converges at about 0.35 1/s (the parameter errors fall ~30 % per second),
    so after 3 s p_e and the parameter errors must have fallen well below their starting values."""
    ts = Simulation([_case(duration=3.0, k_d=1000, a2=0.95 * A2, a3=1.05 * A3)]).run()[0].ts
    t = ts.t.to_numpy()
    pe = ts["ctrl.p_e"].to_numpy()
    assert rms(pe[t > 2.0]) < 0.5 * rms(pe[t < 1.0])
    assert abs(ts["ctrl.a2_hat"].iloc[-1] - A2) < 0.4 * 0.05 * A2
    assert abs(ts["ctrl.a3_hat"].iloc[-1] - A3) < 0.4 * 0.05 * A3


def test_body_motion_at_1hz_below_passive(figs):
    sc = load_scenario(ROOT / "scenarios/kim_fig2.yaml")
    passive = dict(sc.expand())["passive"]
    passive.sim.duration = 2.0
    p = Simulation([passive]).run()[0].ts
    peak_p = np.max(np.abs(p.body_z[p.t >= 1.0]))
    for k, ts in figs.items():
        assert np.max(np.abs(ts.body_z[ts.t >= 1.0])) < 0.6 * peak_p, k
