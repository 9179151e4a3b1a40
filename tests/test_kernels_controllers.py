"""The built-in controllers' laws, each written once as a numba kernel (one car), against hand-written
reference computations of their papers' equations, and the two ways of running them: the Python loop (the
base class broadcasts the kernel over the ensemble) and the compiled loop (the kernel inlined) must agree
bit for bit.  A user's controller in plain numpy (no kernel) still runs, through the Python or hybrid loop.

The references below are written from the equations in the controllers' docstrings, in plain Python floats
(math) or numpy, not from the kernels: where the kernel sums or evaluates in another order, they agree to
round-off (REL of the largest magnitude), which is what the tests allow."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import load_scenario, parse_scenario
from suspension_sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[1]
REL = 1e-12


def _close(got, ref, rel=REL):
    got, ref = np.asarray(got, dtype=float), np.asarray(ref, dtype=float)
    assert got.shape == ref.shape, (got.shape, ref.shape)
    scale = max(float(np.max(np.abs(ref))), 1e-300)
    assert float(np.max(np.abs(got - ref))) <= rel * scale, (got, ref)


def _quarter(controller, sensors, duration=0.3, road=None, vehicle="quarter_car", actuator=None, **sim):
    return parse_scenario(dict(
        name="law_test", vehicle=dict(model=vehicle),
        road=road or dict(type="sine", params={"frequency": 1.7, "amplitude": 0.02}, speed=10),
        sensors=sensors,
        actuator=actuator or dict(type="ideal", params=dict(max_force=3000.0, time_constant=0.002)),
        controller=controller,
        sim={**dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001, seed=3), **sim},
    ))


def _from_file(name, duration, road=None, **params):
    sc = load_scenario(ROOT / "scenarios" / name)
    sc.variants = {}
    sc.sim.duration = duration
    sc.outputs.plots = False
    sc = sc.model_copy(deep=True)
    sc.controller.params.update(params)
    sc.road.params.update(road or {})
    return sc


def _signals(ctrl):
    """The controller's signals, each (n_cars, width)."""
    return {k: np.reshape(v, (ctrl.ctx.n_cars, -1)) for k, v in ctrl.signals().items()}


def _readings(ctrl, rng, scale=None, **given):
    """Readings for every declared sensor of ``ctrl`` (random, ``scale`` per sensor name, default 1), with
    ``given`` ones fixed; each (n_cars, width)."""
    n = ctrl.ctx.n_cars
    out = {}
    for name, labels in ctrl.ctx.sensors.items():
        k = len(labels)
        out[name] = np.broadcast_to(np.asarray(given[name], float).reshape(-1, k), (n, k)) if name in given else \
            (scale or {}).get(name, 1.0) * rng.standard_normal((n, k))
    return out


# passive and skyhook -------------------------------------------------------------------------------------

def test_passive_commands_zero():
    sim = Simulation([_quarter(dict(type="passive"), [dict(type="corner_body_vel")], vehicle="half_car")] * 2)
    c = sim.controller
    y = _readings(c, np.random.default_rng(0))
    assert np.array_equal(c.step(0.0, y), np.zeros((2, 2)))


SKY_SENSORS = [dict(type="travel_rate"), dict(type="corner_body_vel"), dict(type="wheel_vel")]


def test_skyhook_law_per_car():
    """F = −c_sky·ż_body + c_ground·ż_wheel; semi-active cars keep F only where F·(ż_body − ż_wheel) <= 0.
    Three cars with their own gains and flags, on a half car."""
    cases = ((2500.0, 0.0, True), (1200.0, 800.0, False), (4000.0, 300.0, True))
    sim = Simulation([_quarter(dict(type="skyhook", params=dict(c_sky=cs, c_ground=cg, semi_active=semi)),
                               SKY_SENSORS, vehicle="half_car") for cs, cg, semi in cases])
    c = sim.controller
    rng = np.random.default_rng(1)
    clipped = kept = 0
    for k in range(20):
        y = _readings(c, rng)
        u = c.step(k * 0.001, y)
        for i, (cs, cg, semi) in enumerate(cases):
            for j in range(2):
                vb, vw, vr = y["corner_body_vel"][i, j], y["wheel_vel"][i, j], y["travel_rate"][i, j]
                f = -cs * vb + cg * vw
                if semi and f * vr > 0:
                    f, clipped = 0.0, clipped + 1
                elif semi:
                    kept += 1
                assert u[i, j] == pytest.approx(f, rel=1e-15, abs=0.0)
    assert clipped > 5 and kept > 5  # both sides of the clip


# Kim -----------------------------------------------------------------------------------------------------

KIM_A = (1.0, 15.125e9, 5.176e5)  # Table 1: a1, a2, a3


def _kim_reference(steps, q, Tc):
    """Kim's law step by step from the equations of controllers/kim.py's docstring (Eqs. 5, 7, 17, 18, 22,
    23, 27); ``steps``: readings dicts of floats; returns the commands and the final signals."""
    theta = [-q["a1"], -q["a2"], q["a3"]]
    theta0 = [-KIM_A[0], -KIM_A[1], KIM_A[2]]
    gains = (q["gain_a1"], q["gain_a2"], q["gain_a3"])
    A, Ps = q["area"], q["supply_pressure"]
    prev = None
    x_hat = None
    out = []
    for r in steps:
        x, s, vrel, vb, XV, ab, aw = (r[k] for k in ("x", "travel", "travel_rate", "corner_body_vel", "spool",
                                                      "corner_body_acc", "wheel_acc"))
        if x_hat is None:
            x_hat = x
        F_d = -q["c_sky"] * vb - q["b_s"] * vrel  # (5), dissipative sign
        dFd = -q["c_sky"] * ab - q["b_s"] * (ab - aw)
        v = (dFd if q["use_fd_dot"] else 0.0) - q["k_d"] * (x - F_d)  # (18) / (33)
        Y2 = A * (vrel + (q["rate_prediction"] + 0.5 * Tc * q["hold_midpoint"]) * (ab - aw))
        root = math.sqrt(abs(Ps - math.copysign(1.0, XV) * (XV != 0) * x / A))
        f_hat = theta[0] * x + theta[1] * Y2
        g_min = q["g_min_fraction"] * KIM_A[2] * math.sqrt(Ps)
        floored = theta[2] * root < g_min
        g_hat = max(theta[2] * root, g_min)
        u_s = (v - f_hat) / g_hat  # (17)
        u = (1 + q["k_pf"]) * u_s - q["k_pf"] * XV  # (7)
        if prev is not None:  # (22)-(23), (27) over the interval that ended, rectangle rule but for ΔS exactly
            x0, s0, Y30, pe0 = prev
            Y = (x0, A * (s - s0) / Tc, Y30)
            xhat_dot = -q["alpha1"] * pe0 + sum(th * yy for th, yy in zip(theta, Y))
            if q["adaptive"]:
                theta = [th - Tc * gi * t0 * t0 * yy * pe0 for th, gi, t0, yy in zip(theta, gains, theta0, Y)]
            x_hat = x_hat + Tc * xhat_dot
        p_e = x_hat - x
        prev = (x, s, root * u_s, p_e)
        out.append(u)
    return out, dict(F_d=F_d, F_a=x, force_error=x - F_d, p_e=p_e, u_s=u_s,
                     a1_hat=-theta[0], a2_hat=-theta[1], a3_hat=theta[2]), floored


def test_kim_law_against_the_equations():
    """Four steps of three cars (with dF_d/dt and rate prediction; without them and not adapting; an a3
    estimate so low that the ĝ floor acts, with larger adaptation gains) from random readings."""
    g = dict(gain_a1=1e-10, gain_a2=1e-10, gain_a3=1e-10, a1=KIM_A[0])  # not the scenario's
    cases = [dict(k_d=10.0, use_fd_dot=True, rate_prediction=2e-4, hold_midpoint=True, a2=0.8 * KIM_A[1],
                  a3=1.2 * KIM_A[2], **g),
             dict(k_d=1000.0, use_fd_dot=False, rate_prediction=0.0, hold_midpoint=False, adaptive=False, a2=KIM_A[1],
                  a3=KIM_A[2], **g),
             dict(k_d=100.0, use_fd_dot=True, rate_prediction=0.0, hold_midpoint=False, a2=KIM_A[1], a3=0.02 * KIM_A[2],
                  **{**g, "gain_a1": 1e-8, "gain_a2": 1e-8, "gain_a3": 1e-8})]
    sim = Simulation([_from_file("kim_fig2.yaml", 0.1, force_sensor="hydraulic_force", **c) for c in cases])
    ctrl = sim.controller
    Tc = ctrl.ctx.control_dt
    rng = np.random.default_rng(2)
    scale = dict(hydraulic_force=800.0, actuator_force=800.0, travel_rate=0.3, corner_body_vel=0.3,
                 spool_position=1e-3, corner_body_acc=5.0, wheel_acc=30.0)
    steps = [_readings(ctrl, rng, scale, travel=0.01 + 3e-5 * k * np.arange(1, 4)) for k in range(4)]
    got = [ctrl.step(k * Tc, y) for k, y in enumerate(steps)]
    sig = _signals(ctrl)
    floors = []
    for i, case in enumerate(cases):
        q = {k: float(np.asarray(getattr(ctrl.p, k)).reshape(-1)[i]) for k in (
            "c_sky", "b_s", "k_d", "use_fd_dot", "alpha1", "k_pf", "area", "supply_pressure", "a1", "a2", "a3",
            "adaptive", "gain_a1", "gain_a2", "gain_a3", "g_min_fraction", "rate_prediction", "hold_midpoint")}
        r = [{k: float(y[k][i, 0]) for k in ("travel", "travel_rate", "corner_body_vel", "corner_body_acc", "wheel_acc")}
             | dict(x=float(y["hydraulic_force"][i, 0]), spool=float(y["spool_position"][i, 0])) for y in steps]
        u_ref, sig_ref, floored = _kim_reference(r, q, Tc)
        _close([g[i, 0] for g in got], u_ref)
        for name, v in sig_ref.items():
            _close(sig[name][i, 0], v)
        floors.append(floored)
        assert (sig["a2_hat"][i, 0] == q["a2"]) == (i == 1)  # adaptation off for the second car only
    assert floors == [False, False, True]


# Toscano & Dumas -----------------------------------------------------------------------------------------

ALPHA_PAIR = 50 * math.sqrt(2) / (17 * math.sqrt(math.log(2)))  # Eq. (33), 1/m, for range_dx = 0.2


def _psi(u, n_rules, umax, membership, alpha_pair):
    """The normalised bases ψ_i(u) of the docstring: the paper's pair (33), triangles on the grid of (16)
    (end ones held), or gaussians with (16)'s σ."""
    if membership == "triangular" and n_rules == 2:
        mu = max(min(alpha_pair * u + 1.0, 1.0 - alpha_pair * u), 0.0)
        return [mu, 1.0 - mu]
    m = [-umax + 2 * umax * i / (n_rules - 1) for i in range(n_rules)]
    if membership == "gaussian":
        sigma = 2 * umax / (2 * math.sqrt(2 * math.log(2)) * (n_rules - 1))
        mu = [math.exp(-0.5 * ((u - mi) / sigma) ** 2) for mi in m]
    else:
        h = 2 * umax / (n_rules - 1)
        mu = [max(1 - abs(u - mi) / h, 0.0) for mi in m]
        mu[0] = 1.0 if u <= m[0] else mu[0]
        mu[-1] = 1.0 if u >= m[-1] else mu[-1]
    return [v / sum(mu) for v in mu]


@pytest.mark.parametrize("membership,nk,nb", [("triangular", 2, 2), ("triangular", 5, 9), ("gaussian", 3, 4)])
def test_toscano_law_against_the_equations(membership, nk, nb):
    """Estimator (20), gradient law (27) and control (28) over four steps, two cars on a half car (one with
    its own mass and gains), with readings beyond the rule ranges too."""
    base = dict(membership=membership, n_rules_k=nk, n_rules_b=nb, range_dx=0.02, range_dv=0.3)
    cases = [dict(base), dict(base, k_ref=12000.0, alpha=50.0, lambda_k=3e11, lambda_b=5e9, beta_k0=1500.0,
                              beta_b0=150.0, body_mass=250.0)]
    sensors = [dict(type="travel"), dict(type="travel_rate"), dict(type="corner_body_vel")]
    sim = Simulation([_quarter(dict(type="toscano_dumas", params=c), sensors, vehicle="half_car") for c in cases])
    ctrl = sim.controller
    Tc = ctrl.ctx.control_dt
    rng = np.random.default_rng(3)
    steps = [_readings(ctrl, rng, dict(travel=0.02, travel_rate=0.3, corner_body_vel=0.3)) for _ in range(4)]
    got = [ctrl.step(k * Tc, y) for k, y in enumerate(steps)]
    sig = _signals(ctrl)
    M = np.asarray(ctrl.ctx.static_suspension_force) / 9.81
    for i, case in enumerate(cases):
        q = {k: float(np.asarray(getattr(ctrl.p, k)).reshape(-1)[i]) for k in (
            "k_ref", "b_ref", "alpha", "lambda_k", "lambda_b", "beta_k0", "beta_b0")}
        for c in range(2):
            m = case.get("body_mass", M[i, c])
            bk, bb = [q["beta_k0"]] * nk, [q["beta_b0"]] * nb
            v_hat = prev = None
            for k, y in enumerate(steps):
                dx, dv = -y["travel"][i, c], -y["travel_rate"][i, c]
                v = y["corner_body_vel"][i, c]
                if prev is None:
                    v_hat = v
                else:
                    dx0, dv0, pk0, pb0, v0, F0 = prev
                    fk0 = sum(b * s for b, s in zip(bk, pk0))
                    fb0 = sum(b * s for b, s in zip(bb, pb0))
                    e = math.exp(-q["alpha"] * Tc)  # dv̂/dt = −α(v̂ − v0) + drive/M: the α term exactly
                    v_hat = v0 + (v_hat - v0) * e + Tc * (fk0 * dx0 + fb0 * dv0 + F0) / m
                    v_err = v - v_hat
                    bk = [b + Tc * q["lambda_k"] / m * s * dx0 * v_err for b, s in zip(bk, pk0)]
                    bb = [b + Tc * q["lambda_b"] / m * s * dv0 * v_err for b, s in zip(bb, pb0)]
                pk = _psi(dx, nk, 0.02, membership, ALPHA_PAIR * 0.2 / 0.02)
                pb = _psi(dv, nb, 0.3, membership, ALPHA_PAIR / 100.0 * 20.0 / 0.3)
                fk = sum(b * s for b, s in zip(bk, pk))
                fb = sum(b * s for b, s in zip(bb, pb))
                F = (q["k_ref"] - fk) * dx + (q["b_ref"] - fb) * dv  # (28)
                _close(got[k][i, c], F, rel=1e-11)
                prev = (dx, dv, pk, pb, v, F)
            _close(sig["fk_hat"][i, c], fk)
            _close(sig["fb_hat"][i, c], fb)
            _close(sig["v_err"][i, c], v_err, rel=1e-9)  # a difference of close numbers


def test_toscano_known_parameter_hold():
    """``known_k_sine`` / ``known_b_sine``: the estimates are held at beta_0 + A·sin(2πft + φ) at every control
    instant (no gradient step, whatever λ), so the control (28) acts with the scheduled values; the same car
    without the schedule adapts (its estimates leave beta_0)."""
    base = dict(beta_k0=15000.0, beta_b0=1500.0, lambda_k=1e12, lambda_b=1e10)
    cases = [dict(base, known_k_sine=[5000.0, 0.4, 0.3], known_b_sine=[500.0, 0.7, -1.0]),
             dict(base, known_b_sine=[500.0, 0.7, -1.0]),  # stiffness held at its constant beta_k0
             dict(base)]
    sensors = [dict(type="travel"), dict(type="travel_rate"), dict(type="corner_body_vel")]
    sim = Simulation([_quarter(dict(type="toscano_dumas", params=c), sensors) for c in cases])
    ctrl = sim.controller
    Tc = ctrl.ctx.control_dt
    rng = np.random.default_rng(5)
    for k in range(6):
        t = 0.37 + k * Tc
        y = _readings(ctrl, rng, dict(travel=0.02, travel_rate=0.3, corner_body_vel=0.3))
        u = ctrl.step(t, y)
        sig = _signals(ctrl)
        for i, (ka, kph) in enumerate(((5000.0, 0.3), (0.0, 0.0))):
            kt = 15000.0 + ka * math.sin(2 * math.pi * 0.4 * t + kph)
            bt = 1500.0 + 500.0 * math.sin(2 * math.pi * 0.7 * t - 1.0)
            dx, dv = -y["travel"][i, 0], -y["travel_rate"][i, 0]
            _close(sig["fk_hat"][i, 0], kt, rel=1e-13)
            _close(sig["fb_hat"][i, 0], bt, rel=1e-13)
            _close(u[i, 0], (10000.0 - kt) * dx + (1000.0 - bt) * dv, rel=1e-11)
    assert abs(sig["fk_hat"][2, 0] - 15000.0) > 1.0 and abs(sig["fb_hat"][2, 0] - 1500.0) > 0.1  # λ acts unheld


def test_toscano_bases_are_the_paper_pair():
    from suspension_sim.controllers.toscano_dumas import ALPHA_B, ALPHA_K, basis

    assert ALPHA_K == pytest.approx(ALPHA_PAIR) and ALPHA_B == pytest.approx(ALPHA_PAIR / 100.0)
    u = np.linspace(-0.3, 0.3, 13)
    for memb, n in (("triangular", 2), ("triangular", 7), ("gaussian", 7)):
        got = basis(u, n, 0.2, memb, ALPHA_K)
        _close(got, [_psi(x, n, 0.2, memb, ALPHA_K) for x in u])


# Fallah ----------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("cases, nw", [
    ([dict(mean_window=0.003, position_mean_removal=True), dict(mean_window=0.003, a=8.0, c=0.5)], 3),
    ([dict(), dict(position_mean_removal=True, sigmoid="printed", a=8.0, c=0.5)], None)])
def test_fallah_estimation_and_law_against_the_equations(cases, nw):
    """Eight steps of the full car from random IMU and LVDT readings: the differentiator (19), trapezoidal
    integration with the mean removal (a 3-step moving window, so it wraps; or, the default as printed, the running
    mean since t = 0), the corner velocities (21)-(23), s = K·x and the sigmoid (our symmetric one, or Eq. (18)
    as printed, one-sided); with and without the position mean removal (the default: without)."""
    sim = Simulation([_from_file("fallah_bump.yaml", 0.1, **c) for c in cases])
    ctrl = sim.controller
    dt = ctrl.ctx.control_dt
    rng = np.random.default_rng(4)
    steps = [_readings(ctrl, rng, dict(body_acc=1.0, gyro=0.05), travel=0.005 + 1e-4 * k * np.array([1.0, -2.0, 0.5, 3.0]))
             for k in range(8)]
    got = [ctrl.step(k * dt, y) for k, y in enumerate(steps)]
    sig = _signals(ctrl)
    coefs = [16, 1, -10, -10, -6, 9]
    labels = ctrl.ctx.sensors["gyro"]
    cx, cy = ctrl.ctx.corner_x, ctrl.ctx.corner_y

    def mean_to(x, k):  # the mean removed at step k
        return np.mean(x[max(0, k - nw + 1):k + 1] if nw else x[:k + 1])

    for i, case in enumerate(cases):
        a, c0, fmax = case.get("a", 4.0), case.get("c", 0.0), 6000.0
        pmr = case.get("position_mean_removal", False)
        printed = case.get("sigmoid") == "printed"
        acc = [y["body_acc"][i, 0] for y in steps]
        v_int = [0.0]
        for k in range(1, len(steps)):
            v_int.append(v_int[-1] + 0.5 * (acc[k] + acc[k - 1]) * dt)
        v_cg = [v_int[k] - mean_to(v_int, k) for k in range(len(steps))]
        for c in range(ctrl.ctx.n_corners):
            tr = [y["travel"][i, c] for y in steps]
            vs = [v_cg[k] + cy[c] * y["gyro"][i, labels.index("roll")] - cx[c] * y["gyro"][i, labels.index("pitch")]
                  for k, y in enumerate(steps)]
            z = [0.0]
            for k in range(1, len(steps)):
                z.append(z[-1] + 0.5 * (vs[k] + vs[k - 1]) * dt)
            for k in range(len(steps)):
                hist = [tr[max(k - j, 0)] for j in range(6)]  # at rest before the start
                dv = sum(cj * h for cj, h in zip(coefs, hist)) / (28 * dt)
                zs = z[k] - mean_to(z, k) if pmr else z[k]
                s = float(np.dot(ctrl.K[i, c], [zs, vs[k], tr[k], dv]))
                if printed:  # f = -f_max/(1 + e^(-a·B1ᵀPx + c)) with B1ᵀPx ∝ -s, and F = -f
                    F = fmax / (1.0 + math.exp(a * s + c0))
                else:
                    F = -fmax * (2.0 / (1.0 + math.exp(-(a * s + c0))) - 1.0)
                _close(got[k][i, c], F, rel=1e-9)
            _close(sig["dv_hat"][i, c], dv, rel=1e-9)
            _close(sig["vs_hat"][i, c], vs[-1])
            _close(sig["zs_hat"][i, c], zs, rel=1e-9)
            _close(sig["s"][i, c], s, rel=1e-9)


# Lin & Kanellakopoulos -------------------------------------------------------------------------------------

def _lin_sim(cases, duration=0.02):
    scs = []
    for c in cases:
        sc = _from_file("lin_fig4.yaml", duration, **c)
        sc.sim.dt = sc.sim.control_dt = 0.0001
        scs.append(sc)
    return Simulation(scs)


def test_lin_law_against_the_derivation():
    """Three steps of two cars (adaptive, non-adaptive), travel inside and beyond the filter threshold m1:
    the filter (9)-(10) advanced exactly over each step, w3 with its guard, the derivation's α4 (sympy,
    evaluated in floats) and u = τ·α4/w3 (15), θ̂ by forward Euler of (12)."""
    from suspension_sim.controllers.lin_kanellakopoulos import _OUT, _PARAM, derivation

    cases = [dict(), dict(adaptive=False, c2=150.0)]
    sim = _lin_sim(cases)
    ctrl = sim.controller
    Tc = ctrl.ctx.control_dt
    f = derivation()["f_math"]
    names = ctrl._NAMES
    m1 = float(np.asarray(ctrl.p.m1).reshape(-1)[0])
    for travel in (0.5 * m1, m1 + 0.015):
        ctrl.reset()
        rng = np.random.default_rng(5)
        steps = [_readings(ctrl, rng, dict(wheel_pos=0.01, corner_body_vel=0.3, wheel_vel=0.5, load_pressure=3e6,
                                           spool_position=2e-3), travel=np.full((2, 1), travel + 1e-3 * k))
                 for k in range(3)]
        got = [ctrl.step(k * Tc, y) for k, y in enumerate(steps)]
        sig = _signals(ctrl)
        for i, case in enumerate(cases):
            q = {k: float(np.asarray(getattr(ctrl.p, names[k])).reshape(-1)[i]) for k in _PARAM}
            p = {k: float(np.asarray(getattr(ctrl.p, k)).reshape(-1)[i]) for k in (
                "m1", "m2", "supply_pressure", "w3_guard", "spool_time_constant", "alpha", "area")}
            th = p["alpha"] * p["area"]
            e = 0.0
            prev = None
            for k, y in enumerate(steps):
                r = {nm: float(y[nm][i, 0]) for nm in y}
                x3, x2, x4, x5, x6 = r["wheel_pos"], r["corner_body_vel"], r["wheel_vel"], r["load_pressure"], r["spool_position"]
                x1 = r["travel"] + x3
                if prev is not None:  # de/dt = −λe − x4, x4 linear over the step
                    lam, x4p = prev
                    a = math.exp(-lam * Tc)
                    e = e * a - 0.5 * (x4 + x4p) * (1 - a) / lam
                eta = x1 - x3
                d = eta - p["m1"] if eta > p["m1"] else (eta + p["m1"] if eta < -p["m1"] else 0.0)
                m2 = p["m2"]
                P = (d ** 4 / m2 ** 4, 4 * d ** 3 / m2 ** 4, 12 * d ** 2 / m2 ** 4, 24 * d / m2 ** 4)
                D = p["supply_pressure"] - math.copysign(1.0, x6) * x5
                w3 = math.copysign(math.sqrt(abs(D)), D)
                w3g = w3 if abs(w3) >= p["w3_guard"] else math.copysign(p["w3_guard"], w3)
                S, Q = x6 * w3, abs(x6) / (2 * abs(w3g))
                out = dict(zip(_OUT, f(x1, x2, x3, x4, x5, x3 + e, *P, th, S, Q, *(q[k] for k in _PARAM))))
                u = p["spool_time_constant"] * (x6 * w3 / p["spool_time_constant"] + out["alpha4_rest"]) / w3g
                _close(got[k][i, 0], u, rel=1e-9)
                rho_th = q["rho"] * th
                th = th + (0.0 if case.get("adaptive") is False else Tc * out["thdot"])
                prev = (q["eps"] + q["eps1"] * P[0], x4)
            for name in ("z1", "z2", "z3", "z4", "h3", "h4", "R3", "R4"):
                _close(sig[name][i, 0], out[name], rel=1e-9)
            _close(sig["theta_hat"][i, 0], rho_th)
            _close(sig["phi"][i, 0], P[0], rel=1e-9)
            assert (P[0] > 0) == (travel > m1)


def test_lin_kernel_generated_code_is_up_to_date():
    """The kernel's copy of the symbolic derivation (between the GENERATED markers) is what kernel_source()
    produces from the current derivation."""
    import suspension_sim.controllers.lin_kanellakopoulos as lk

    text = (ROOT / "controllers" / "lin_kanellakopoulos.py").read_text()
    a, b = "# --- GENERATED by kernel_source(), do not edit ---\n", "# --- END GENERATED ---\n"
    assert text[text.index(a) + len(a):text.index(b)] == lk.kernel_source()


# open loop -------------------------------------------------------------------------------------------------
# (the signal shapes against their formulas: tests/test_open_loop.py)

def test_open_loop_random_has_no_kernel_and_runs():
    from suspension_sim.compiled.loop import plan
    from suspension_sim.controllers.open_loop import OpenLoop

    sim = Simulation([_rig(signal="random", amplitude=1.0, duration=0.05)])
    assert isinstance(sim.controller, OpenLoop) and type(sim.controller).kernel is None
    assert plan(sim)[0] == "hybrid"  # the compiled loop returns to Python for this controller
    r = sim.run()[0]
    assert r.ts["command"].std() > 0.5
    assert type(Simulation([_rig(signal="sine", amplitude=1.0, frequency=1.0)]).controller).kernel is not None


def _rig(vehicle="quarter_car", duration=0.3, **params):
    return parse_scenario(dict(
        vehicle=dict(model=vehicle), road=dict(type="flat"), controller=dict(type="open_loop", params=params),
        sim=dict(duration=duration, dt=0.0005, control_dt=0.001, log_dt=0.001)))


def test_pairwise_sums_are_numpys():
    from suspension_sim.compiled.numpy_order import pairwise_sum

    rng = np.random.default_rng(0)
    for n in (1, 5, 7, 8, 9, 16, 17, 127, 128, 129, 200, 513, 1029, 5000):
        a = rng.standard_normal((2, n)) * 10.0 ** rng.uniform(-3, 3, (2, n))
        ref = np.sum(a, axis=1)
        for i in range(2):
            assert pairwise_sum(np.ascontiguousarray(a[i]), 0, n) == ref[i]
            assert pairwise_sum(np.concatenate([[9.0, 9.0], a[i]]), 2, n) == ref[i]  # at an offset


# the two loops -----------------------------------------------------------------------------------------------

def _toscano_half(duration=0.3, **params):
    return _quarter(dict(type="toscano_dumas", params=dict(membership="triangular", n_rules_k=5, n_rules_b=9,
                                                           range_dx=0.015, range_dv=0.2, **params)),
                    [dict(type="travel"), dict(type="corner_body_vel"), dict(type="travel_rate"),
                     dict(type="actuator_force")], duration=duration, vehicle="half_car",
                    road=dict(type="sine", params={"frequency": 1.5, "amplitude": 0.03}, speed=10),
                    actuator=dict(type="ideal", params=dict(time_constant=0.003)))


def _lin_scs(**kw):
    out = []
    for c in (dict(), dict(adaptive=False)):
        sc = _from_file("lin_fig4.yaml", 0.1, road=dict(start=0.02, height=0.03), **c)
        sc.sim.dt = sc.sim.control_dt = 0.0001
        out.append(sc)
    return out


def _kim_no_friction(**params):
    """Kim's Fig. 2 without the seal friction: the hydraulic actuator's tanh friction law is evaluated by
    numpy in the Python loop and by the C library in the compiled one (last-bit differences that are the
    actuator's, not the controller's)."""
    sc = _from_file("kim_fig2.yaml", 0.1, force_sensor="hydraulic_force", **params)
    sc.actuator.params["friction_max"] = 0.0
    return sc


LOOP_CASES = {
    # (the passive law reads no sensor: quickstart's noisy one, so that this runs the loop quickstart's passive
    # variant compiles instead of one of its own, 6 CPU-s on an empty cache)
    "passive": lambda: [_quarter(dict(type="passive"), [dict(type="corner_body_vel", noise_std=0.002)])] * 2,
    "skyhook": lambda: [_quarter(dict(type="skyhook", params=dict(c_sky=cs, c_ground=cg, semi_active=semi)),
                                 [dict(type="travel_rate", noise_std=0.01), dict(type="corner_body_vel", noise_std=0.005),
                                  dict(type="wheel_vel", noise_std=0.01)])
                        for cs, cg, semi in ((2500.0, 0.0, True), (1200.0, 800.0, False))],
    "open_loop": lambda: [_rig(signal="multisine", frequencies=[1.0, 2.0, 5.0], amplitude=a, fade_in=0.1)
                          for a in (50.0, 80.0)],
    "kim": lambda: [_kim_no_friction(use_fd_dot=fd) for fd in (True, False)],
    "toscano_dumas": lambda: [_toscano_half(force_sensor="actuator_force", k_ref=10000.0),
                              _toscano_half(force_sensor="actuator_force", k_ref=8000.0, beta_k0=12000.0,
                                            known_k_sine=[3000.0, 2.0, 0.3])],  # the held (known-parameter) law
    "fallah": lambda: [_from_file("fallah_bump.yaml", 0.3, road=dict(start=0.5), mean_window=0.05, a=a)
                       for a in (4.0, 8.0)],
    "lin_kanellakopoulos": _lin_scs,
}


@pytest.mark.parametrize("name", list(LOOP_CASES))
def test_compiled_loop_equals_python_loop(name, monkeypatch):
    """Simulation.run with the compiled loop (the kernel inlined) gives the Python loop's time series (the
    kernel broadcast by Controller.step over the readings in Controller.readings) bit for bit, and the
    controller's signals after the run (kernel_sync) are the same."""
    from suspension_sim.compiled.loop import plan

    sim = Simulation(LOOP_CASES[name]())
    assert plan(sim)[0] == "full"
    compiled = sim.run()
    sig_c = sim.controller.signals()
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    sim_p = Simulation(LOOP_CASES[name]())
    python = sim_p.run()
    assert sim_p.loop == "python"
    for a, b in zip(compiled, python):
        assert list(a.ts.columns) == list(b.ts.columns)
        np.testing.assert_array_equal(a.ts.to_numpy(float), b.ts.to_numpy(float))
    sig_p = sim_p.controller.signals()
    assert sig_c.keys() == sig_p.keys()
    for k in sig_c:
        np.testing.assert_array_equal(sig_c[k], sig_p[k])


def test_each_car_of_an_ensemble_as_if_alone(monkeypatch):
    """Per-car flags (Kim with and without dF_d/dt, adapting or not; skyhook with and without groundhook
    and clip): each car of the ensemble runs as it runs alone."""
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    groups = (
        ([dict(use_fd_dot=True), dict(use_fd_dot=False, adaptive=False, rate_prediction=0.0)],
         lambda c: _from_file("kim_fig2.yaml", 0.05, force_sensor="hydraulic_force", **c)),
        ([dict(c_sky=2500.0, semi_active=True), dict(c_sky=1200.0, c_ground=800.0)],
         lambda c: _quarter(dict(type="skyhook", params=c), SKY_SENSORS, duration=0.2)))
    for case_list, mk in groups:
        ens = Simulation([mk(c) for c in case_list]).run()
        for k, c in enumerate(case_list):
            alone = Simulation([mk(c)]).run()[0]
            np.testing.assert_array_equal(ens[k].ts.to_numpy(float), alone.ts.to_numpy(float))


# a user's controller in plain numpy ------------------------------------------------------------------------

def test_plain_numpy_controller_runs_in_the_python_and_hybrid_loops(monkeypatch):
    """A controller written in numpy (step and signals, no kernel) runs: the compiled loop returns to Python
    at its control instants (hybrid) with the Python loop's results, and a numpy skyhook gives the built-in
    kernel's results."""
    from suspension_sim.controllers.base import Controller
    from suspension_sim.controllers.skyhook import SkyhookParams
    from suspension_sim.registry import CONTROLLERS

    if "_test_numpy_skyhook" not in CONTROLLERS._items:
        @CONTROLLERS.register("_test_numpy_skyhook")
        class NumpySkyhook(Controller):
            Params = SkyhookParams
            requires = ("corner_body_vel",)

            def reset(self):
                self.f = self.zeros()

            def step(self, t, y):
                self.f = -self.p.c_sky * y["corner_body_vel"]
                return self.f

            def signals(self):
                return {"f": self.f}

    sensors = [dict(type="corner_body_vel", noise_std=0.005)]
    scs = [_quarter(dict(type="_test_numpy_skyhook", params=dict(c_sky=c)), sensors) for c in (2000.0, 3000.0)]
    sim_h = Simulation(scs)
    hybrid = sim_h.run()
    assert sim_h.loop == "hybrid" and "no kernel" in sim_h.loop_reason
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    python = Simulation(scs).run()
    builtin = Simulation([sc.model_copy(update={"controller": sc.controller.model_copy(update={"type": "skyhook"})})
                          for sc in scs]).run()
    for h, p, b in zip(hybrid, python, builtin):
        assert h.ts.equals(p.ts)
        np.testing.assert_array_equal(h.ts["command"].to_numpy(), b.ts["command"].to_numpy())
        np.testing.assert_array_equal(h.ts["ctrl.f"].to_numpy(), h.ts["command"].to_numpy())
