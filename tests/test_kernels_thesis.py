"""Compiled kernels of the thesis controllers (controllers/thesis_*.py) against their numpy ``step``.

Each test runs a shortened copy of a thesis scenario file through the Python loop and replays every control
step's readings through the controller's numba kernel (``suspension_sim.compiled.testing.check_controller``);
commands and logged signals must be bit-identical (difference exactly 0.0): the kernels do the numpy
method's floating-point operations in numpy's order (see the summation-order note in
controllers/thesis_common.py, checked against np.einsum below).  Ensembles of three cars differ in their
vehicle parameters: the thesis controllers need equal controller parameters across an ensemble
(thesis_common._f), so the cars' readings, not their designs, differ."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from suspension_sim.controllers.thesis_common import k_dot, k_dot_seq
from suspension_sim.compiled.testing import check_controller
from suspension_sim.config import parse_scenario, read_yaml
from suspension_sim.simulation import Simulation


def scenario(repo, name, duration, edit=None):
    raw = read_yaml(repo / "scenarios" / f"{name}.yaml")
    raw["sim"]["duration"] = duration
    raw.pop("variants", None)
    if edit:
        edit(raw)
    return parse_scenario(raw)


def ensemble(repo, name, duration, param, values, edit=None):
    """Scenarios that differ in vehicle parameter ``param`` (one car each), after ``edit``."""
    out = []
    for v in values:
        def e(raw, v=v):
            raw["vehicle"].setdefault("params", {})[param] = v
            if edit:
                edit(raw)
        out.append(scenario(repo, name, duration, e))
    return out


def replay_and_sync(sim):
    """Run ``sim`` in Python, replay its readings through a copy's kernel, kernel_sync that copy; return
    (python controller, synced copy)."""
    ctrl = sim.controller
    kn = copy.deepcopy(ctrl)
    names = list(kn.ctx.sensors)
    log = []
    readings = sim.start()
    while readings is not None:
        u = np.broadcast_to(np.asarray(ctrl.step(sim.t, readings), dtype=float), (sim.plant.n, sim.plant.nc))
        log.append((sim.t, {k: np.array(v, dtype=float) for k, v in readings.items()}))
        readings = sim.control_step(u)
    kn.reset()
    p, st = kn.kernel_data()
    out = np.zeros(kn.ctx.n_corners)
    for t, y in log:
        for i in range(kn.ctx.n_cars):
            yi = np.ascontiguousarray(np.concatenate([y[nm].reshape(kn.ctx.n_cars, -1)[i] for nm in names]))
            kn.kernel(t, yi, p[i], st[i], out)
    kn.kernel_sync(st)
    return ctrl, kn


def assert_same_signals(a, b):
    sa, sb = a.signals(), b.signals()
    assert set(sa) == set(sb) and sa
    for k in sa:
        np.testing.assert_array_equal(np.asarray(sb[k]).reshape(a.ctx.n_cars, -1),
                                      np.asarray(sa[k]).reshape(a.ctx.n_cars, -1), err_msg=k)


# --- the summation order of np.einsum that the kernels reproduce ------------------------------------------

def test_einsum_summation_order_is_the_one_the_kernels_use():
    """k_dot reproduces np.einsum over an axis contiguous in both operands, k_dot_seq a strided reduction
    and a three-operand product (if a numpy build sums differently, this fails first)."""
    rng = np.random.default_rng(0)
    for K in list(range(1, 20)) + [24, 33]:
        for _ in range(20):
            a = rng.standard_normal((3, K)) * 10.0 ** rng.uniform(-6, 6, (3, K))
            b = rng.standard_normal((3, K))
            ref = np.einsum("nk,nk->n", a, b)
            got = [k_dot(a[i], 0, b[i], 0, K) for i in range(3)]
            assert np.array_equal(ref, got), K
            m = 3
            th = rng.standard_normal((2, K, m)) * 10.0 ** rng.uniform(-6, 6, (2, K, m))
            ref = np.einsum("npm,np->nm", th, a[:2])
            got = [[k_dot_seq(th[i].ravel(), c, m, a[i], 0, 1, K) for c in range(m)] for i in range(2)]
            assert np.array_equal(ref, got), K
    # a Θ laid out along p (a lone car's, see dm_theta_strides) is summed as k_dot
    th = np.tile(rng.standard_normal((2, 9)).T[None], (1, 1, 1))
    assert th.strides[1] == 8
    ph = rng.standard_normal((1, 9)) * 10.0 ** rng.uniform(-6, 6, (1, 9))
    ref = np.einsum("npm,np->nm", th, ph)
    assert np.array_equal(ref[0], [k_dot(np.ascontiguousarray(th[0, :, c]), 0, ph[0], 0, 9) for c in range(2)])
    # the plain sequential sum differs from einsum's for some K >= 3: the order matters
    a = rng.standard_normal((200, 6)) * 10.0 ** rng.uniform(-6, 6, (200, 6))
    seq = [k_dot_seq(r, 0, 1, np.ones(6), 0, 1, 6) for r in a]
    assert not np.array_equal(np.einsum("nk,nk->n", a, np.ones((200, 6))), seq)


# --- Ch. 3: continuous MRAC ---------------------------------------------------------------------------------

def _ch3_load(raw):
    raw["vehicle"]["variations"][0]["times"] = [0.4, 0.8]


def test_mrac_continuous_kernel_single_car(request):
    sim = Simulation([scenario(request.config.rootpath, "thesis_ch3_load_step", 1.2, _ch3_load)])
    assert check_controller(sim) == 0.0


def test_mrac_continuous_kernel_ensemble_b0_estimator(request):
    """Three cars (sprung mass 250/350/450 kg) on the dirt road, with the b0 estimator on (it runs into its
    lower clip) and without the static-level parameter: the other branches of the kernel."""
    def edit(raw):
        raw["controller"]["params"].update(gamma_b0=50.0, static_level=False)

    sim = Simulation(ensemble(request.config.rootpath, "thesis_ch3_dirt", 1.0, "sprung_mass", [250, 350, 450],
                              edit))
    assert check_controller(sim) == 0.0
    assert np.all(sim.controller.b0 == sim.controller.b_lim[0])  # the clip was engaged


def test_mrac_continuous_kernel_sync(request):
    sims = ensemble(request.config.rootpath, "thesis_ch3_load_step", 1.0, "sprung_mass", [250, 300, 350],
                    _ch3_load)
    py, kn = replay_and_sync(Simulation(sims))
    np.testing.assert_array_equal(kn.theta, py.theta)
    np.testing.assert_array_equal(kn.b0, py.b0)
    np.testing.assert_array_equal(kn.F, py.F)
    for nm in ("fEf", "fP", "fsP", "fP2", "fsP2", "fP1", "ref"):
        np.testing.assert_array_equal(getattr(kn, nm).x, getattr(py, nm).x, err_msg=nm)
    assert_same_signals(py, kn)


# --- the discrete MRAC estimator (Ch. 4 and Ch. 7) on its own: every branch -------------------------------

def _core_design(m, D, kappa, u_max, beta_inv_range, trace_max, n):
    from suspension_sim.controllers.thesis_common import DiscreteMRAC, am_poly, darma, predictor, theta_from_predictor

    h = 0.01
    if m == 1:
        Ac, Bc, Cc = np.array([[0.0, 1.0], [-20.0, -4.0]]), np.array([[0.0], [0.004]]), np.array([[1.0, 0.0]])
    else:
        Ac = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.array([[130.0, 10.0], [8.0, 90.0]]),
                                                       -np.array([[4.0, 0.5], [0.3, 3.0]])]])
        Bc, Cc = np.vstack([np.zeros((2, 2)), np.array([[0.001, 0.0002], [0.0003, 0.0008]])]), np.eye(2, 4)
    A, B = darma(Ac, Bc, Cc, h)
    am = am_poly(2 * np.pi * 1.5, 0.9, h)
    D, alpha, beta = predictor(A, B, am, D - 1)
    return DiscreteMRAC(theta_from_predictor(alpha, beta), m, D, am, n, 0.01, 1e-3, trace_max,
                        beta_inv_range=beta_inv_range, u_max=u_max, kappa=kappa, p0_bias=0.1, q_bias=0.01)


@pytest.mark.parametrize("m, D, kappa, u_max, n", [(1, 6, 0.1, 300.0, 3), (2, 2, 0.2, None, 3), (2, 1, 1.0, 50.0, 3),
                                                  (2, 2, 0.2, 80.0, 1)])
def test_discrete_mrac_core_kernel_all_branches(m, D, kappa, u_max, n):
    """dm_step against DiscreteMRAC.step on synthetic readings of n cars (different scales), bit for bit,
    with the covariance addition first refused by the trace bound and later applied, the (β0)⁻¹
    projection and (where set) the force limit engaged.  A lone car's Θ (1, p, m) is laid out along p
    (np.tile of the transposed nominal), which changes np.einsum's summation order for m = 2: the n = 1
    case checks that the kernel follows it."""
    from suspension_sim.controllers.thesis_common import DM_HEADER, KernelLayout, dm_step

    core = _core_design(m, D, kappa, u_max, (0.9, 1.1), 0.0, n)
    core.trace_max = float(np.trace(core.P[0])) * 0.5  # the first updates may not add q·I
    lay = KernelLayout(n)
    lay.p(np.zeros(DM_HEADER))
    core.kernel_pack(lay, 0)
    p, st = lay.arrays()
    U = int(p[0, 7])
    rng = np.random.default_rng(5)
    scale = np.array([0.01, 0.05, 0.2])[:n, None]
    yv = np.zeros((n, m))
    seen = {"refused": False, "added": False, "proj": False, "umax": u_max is None}
    tr_prev = np.trace(core.P, axis1=1, axis2=2)
    lo_hi = [sorted((0.9 * b, 1.1 * b)) for b in core.bi_nom]
    for k in range(300):
        yv = 0.95 * yv + scale * rng.standard_normal((n, m))
        ybs = scale * rng.standard_normal((n, m))
        u = core.step(yv.copy(), ybs)
        for i in range(n):
            dm_step(p[i], st[i], 0, np.ascontiguousarray(yv[i]), 0, np.ascontiguousarray(ybs[i]), 0, True)
        np.testing.assert_array_equal(st[:, U:U + m], u)
        tr = np.trace(core.P, axis1=1, axis2=2)
        started = tr != tr_prev
        seen["refused"] |= bool(np.any(started & (tr >= core.trace_max)))  # an addition would leave it below
        seen["added"] |= bool(np.any(tr > tr_prev))
        bi = core.theta[:, core.p - m:, :]
        seen["proj"] |= any(np.any((bi[:, c, c] == lo_hi[c][0]) | (bi[:, c, c] == lo_hi[c][1])) for c in range(m))
        if u_max is not None:
            seen["umax"] |= bool(np.any(np.abs(u) == u_max))
        tr_prev = tr
    ref = copy.deepcopy(core)
    core.kernel_sync(st)
    for nm in ("theta", "P", "Y", "U", "Phi", "err"):
        np.testing.assert_array_equal(getattr(core, nm), getattr(ref, nm), err_msg=nm)
    assert all(seen.values()), seen


# --- Ch. 4: discrete MRAC with loop delay -------------------------------------------------------------------

def test_mrac_discrete_kernel_single_car(request):
    def edit(raw):
        raw["vehicle"]["variations"][0]["times"] = [0.5, 0.8]

    sim = Simulation([scenario(request.config.rootpath, "thesis_ch4_load_step", 1.5, edit)])
    assert check_controller(sim) == 0.0


def test_mrac_discrete_kernel_ensemble(request):
    """Three cars (250/350/450 kg) on the dirt road with a low force limit (the clip engaged) and no delay."""
    def edit(raw):
        raw["sensors"] = [{"type": "body_pos"}, {"type": "road"}, {"type": "road_vel"}]
        raw["controller"]["params"].update(delay_steps=0, u_max=300.0)

    sim = Simulation(ensemble(request.config.rootpath, "thesis_ch4_dirt", 1.0, "sprung_mass", [250, 350, 450],
                              edit))
    assert check_controller(sim) == 0.0
    py, kn = replay_and_sync(Simulation(ensemble(request.config.rootpath, "thesis_ch4_dirt", 0.5, "sprung_mass",
                                                 [250, 350, 450], edit)))
    for nm in ("theta", "P", "Y", "U", "Phi", "err"):
        np.testing.assert_array_equal(getattr(kn.core, nm), getattr(py.core, nm), err_msg=nm)
    np.testing.assert_array_equal(kn.targets, py.targets)
    np.testing.assert_array_equal(kn.ref.x, py.ref.x)
    assert_same_signals(py, kn)


# --- Ch. 7: MIMO MRAC of the half car ---------------------------------------------------------------------

def _ch7(raw):
    """Braking early and a sinusoidal road (the scenario's road is flat: the reference would stay at 0)."""
    raw["vehicle"]["maneuver"]["params"].update(start=0.2, phases=[[0.4, 4.0], [0.4, -7.0]])
    raw["road"] = {"type": "multi_sine", "params": {"amplitudes": [0.02, 0.01], "frequencies": [1.0, 2.5]},
                   "speed": 10}


def test_mimo_mrac_kernel_single_car(request):
    sim = Simulation([scenario(request.config.rootpath, "thesis_ch7_braking", 1.2, _ch7)])
    assert check_controller(sim) == 0.0


def test_mimo_mrac_kernel_ensemble(request):
    """Three half cars (sprung mass 450/500/600 kg), one sample of loop delay (D = 2)."""
    def edit(raw):
        _ch7(raw)
        raw["sensors"] = [{"type": s["type"], "delay": 0.01} for s in raw["sensors"]]
        raw["controller"]["params"]["delay_steps"] = 1

    scs = ensemble(request.config.rootpath, "thesis_ch7_braking", 1.2, "sprung_mass", [450, 500, 600], edit)
    assert check_controller(Simulation(scs)) == 0.0
    py, kn = replay_and_sync(Simulation(scs))
    for nm in ("theta", "P", "Y", "U", "Phi", "err"):
        np.testing.assert_array_equal(getattr(kn.core, nm), getattr(py.core, nm), err_msg=nm)
    np.testing.assert_array_equal(kn.targets, py.targets)
    np.testing.assert_array_equal(kn.ref.x, py.ref.x)
    assert_same_signals(py, kn)


# --- Ch. 5: stochastic optimal control (LQG) ----------------------------------------------------------------

def replay_rel(sim):
    """Like check_controller, but the largest difference of each output relative to that output's largest
    magnitude: {"u": …, signal name: …}."""
    ctrl = sim.controller
    kn = copy.deepcopy(ctrl)
    names = list(kn.ctx.sensors)
    log = []
    readings = sim.start()
    while readings is not None:
        u = np.broadcast_to(np.asarray(ctrl.step(sim.t, readings), dtype=float), (sim.plant.n, sim.plant.nc))
        log.append((sim.t, {k: np.array(v, dtype=float) for k, v in readings.items()}, u.copy(),
                    {k: np.array(v, dtype=float).reshape(sim.plant.n, -1) for k, v in ctrl.signals().items()}))
        readings = sim.control_step(u)
    kn.reset()
    p, st = kn.kernel_data()
    sig = kn.kernel_signals()
    out = np.zeros(kn.ctx.n_corners)
    diff, mag = {}, {}
    for t, y, u, sp in log:
        uk = np.zeros_like(u)
        for i in range(kn.ctx.n_cars):
            yi = np.ascontiguousarray(np.concatenate([y[nm].reshape(kn.ctx.n_cars, -1)[i] for nm in names]))
            kn.kernel(t, yi, p[i], st[i], out)
            uk[i] = out
        pairs = [("u", u, uk)] + [(k, sp[k], st[:, a:b]) for k, (a, b) in sig.items()]
        for k, ref, got in pairs:
            diff[k] = max(diff.get(k, 0.0), float(np.max(np.abs(ref - got))))
            mag[k] = max(mag.get(k, 0.0), float(np.max(np.abs(ref))))
    return {k: diff[k] / mag[k] if mag[k] > 0 else diff[k] for k in diff}


def _ch5_schedule(raw):
    raw["controller"]["params"].update(update_period=0.3, schedule=[
        {"time": 0, "mass": 250, "stiffness": 5000, "damping": 250},
        {"time": 0.5, "mass": 400, "stiffness": 5000, "damping": 250},
        {"time": 0.8, "mass": 400, "stiffness": 3750, "damping": 250}])


@pytest.mark.parametrize("masses", [[250], [250, 320, 400]])
def test_soc_lqg_kernel(request, masses):
    """Rescheduled gains (period 0.3 s, three schedule entries).  Not bit-identical: step's Kalman
    prediction W ← Wf Φᵀ is a BLAS product (OpenBLAS sums 3-term dot products as an FMA chain, or with
    gemv for a lone car), which the kernel sums in order without FMA: its last bit may differ, so w_est
    and the command agree to 1e-13 relative (measured ≈ 1e-16); the gains (table look-up) are exact."""
    scs = ensemble(request.config.rootpath, "thesis_ch5_varying", 1.5, "sprung_mass", masses, _ch5_schedule)
    rel = replay_rel(Simulation(scs))
    assert set(rel) == {"u", "gain", "w_est"}
    assert rel["gain"] == 0.0
    assert rel["u"] <= 1e-13 and rel["w_est"] <= 1e-13, rel


def test_soc_lqg_kernel_sync(request):
    scs = ensemble(request.config.rootpath, "thesis_ch5_varying", 1.0, "sprung_mass", [250, 320, 400], _ch5_schedule)
    py, kn = replay_and_sync(Simulation(scs))
    np.testing.assert_array_equal(kn.gain, py.gain)
    assert kn.next_update == py.next_update
    np.testing.assert_allclose(kn.W, py.W, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(kn.signals()["w_est"], py.signals()["w_est"], rtol=1e-13, atol=1e-18)


# --- Ch. 6: MDOF adaptive control (2-DOF) -------------------------------------------------------------------

def _ch6_bump(raw):
    raw["road"]["params"].update(start=0.1, period=0.4)


def test_mdof_adaptive_kernel_single_car(request):
    """Bit-identical although step has two BLAS products: R2, R3 are diagonal and P⁻¹ holds 0 and 1, so
    every product BLAS could sum differently is exact (see the note in thesis_mdof_adaptive)."""
    sim = Simulation([scenario(request.config.rootpath, "thesis_ch6_bump", 0.8, _ch6_bump)])
    c = sim.controller
    assert np.count_nonzero(c.R2 - np.diag(np.diag(c.R2))) == 0 and np.count_nonzero(c.R3 - np.diag(np.diag(c.R3))) == 0
    assert check_controller(sim) == 0.0


@pytest.mark.parametrize("adapt_model", [True, False])
def test_mdof_adaptive_kernel_ensemble(request, adapt_model):
    """Three cars (sprung mass 70/85/100 kg) over bumps with a tiny gain limit (the clips engaged)."""
    def edit(raw):
        _ch6_bump(raw)
        raw["controller"]["params"].update(gain_limit=1e-4, adapt_model=adapt_model)

    scs = ensemble(request.config.rootpath, "thesis_ch6_bump", 0.6, "sprung_mass", [70, 85, 100], edit)
    sim = Simulation(scs)
    assert check_controller(sim) == 0.0
    c = sim.controller
    assert np.any(np.abs(c.I["kp"]) == 1e-4 * c.g_scale["kp"])  # the integral clip was engaged
    py, kn = replay_and_sync(Simulation(scs))
    for k in py.G:
        np.testing.assert_array_equal(kn.G[k], py.G[k], err_msg=k)
        np.testing.assert_array_equal(kn.I[k], py.I[k], err_msg=k)
    np.testing.assert_array_equal(kn.ref.x, py.ref.x)
    np.testing.assert_array_equal(kn.wd_prev, py.wd_prev)
    assert_same_signals(py, kn)


# --- the kernels in the compiled loop (suspension_sim.compiled.loop) ----------------------------------------

def _no_effects(raw):
    """Without the friction/bump-stop effects: their kernels (not this file's) agree with their numpy
    methods to a few ulps only (tanh), which a closed loop then carries on."""
    raw["vehicle"].pop("effects", None)


def _ch7_no_maneuver(raw):
    _ch7(raw)
    raw["vehicle"].pop("maneuver")  # manoeuvres run in the Python loop


@pytest.mark.parametrize("name, edit, param, values, exact", [
    ("thesis_ch3_dirt", None, "sprung_mass", [250, 350, 450], True),
    ("thesis_ch4_dirt", _no_effects, "sprung_mass", [250, 350, 450], True),
    ("thesis_ch5_nominal", None, "sprung_mass", [250, 320], False),
    ("thesis_ch6_bump", lambda raw: (_ch6_bump(raw), _no_effects(raw)), "sprung_mass", [70, 85], True),
    ("thesis_ch7_braking", lambda raw: (_ch7_no_maneuver(raw), _no_effects(raw)), "sprung_mass", [450, 500], True),
])
def test_compiled_loop_equals_python_loop(request, monkeypatch, name, edit, param, values, exact):
    """The full compiled loop with the thesis kernel gives the Python loop's time series (bit for bit, or
    within 1e-12 relative for the SOC: see test_soc_lqg_kernel), and kernel_sync leaves the controller
    with the Python run's final signals."""
    scs = ensemble(request.config.rootpath, name, 1.0, param, values, edit)
    runs = {}
    for flag in ("1", "0"):
        monkeypatch.setenv("SUSPENSION_SIM_COMPILED", flag)
        sim = Simulation(scs)
        runs[flag] = (sim.run(), sim)
    assert runs["1"][1].loop == "full", runs["1"][1].loop_reason
    assert runs["0"][1].loop == "python"
    for rc, rp in zip(runs["1"][0], runs["0"][0]):
        assert list(rc.ts.columns) == list(rp.ts.columns)
        a, b = rc.ts.to_numpy(dtype=float), rp.ts.to_numpy(dtype=float)
        if exact:
            np.testing.assert_array_equal(a, b)
        else:
            scale = np.max(np.abs(b), axis=0, initial=0.0)
            assert np.all(np.abs(a - b) <= 1e-12 * scale + 1e-300)
    sc, sp = runs["1"][1].controller.signals(), runs["0"][1].controller.signals()
    assert set(sc) == set(sp)
    for k in sp:
        np.testing.assert_allclose(np.asarray(sc[k], dtype=float), np.asarray(sp[k], dtype=float),
                                   rtol=0.0 if exact else 1e-12, atol=0.0, err_msg=k)
