"""Each effect's law (its numba kernel, broadcast over the ensemble by ``Effect.force``) against the physics
written out by hand, at chosen points: the force law of the effect's docstring evaluated with ``math``,
per corner and per car, in every branch (both stops, sticking and slipping, inside and beyond a damper map).

Also: a car inside an ensemble of cars with other parameters behaves as the car alone (the stacking of
per-car parameters), the Python loop runs the same kernels as the compiled loop (bit for bit), and an effect
written in plain numpy, without a kernel, still runs (in the Python loop).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from suspension_sim.components import stack_params, validate_params
from suspension_sim.config import parse_scenario
from suspension_sim.effects.base import Effect, EffectContext
from suspension_sim.registry import EFFECTS
from suspension_sim.simulation import Simulation

DT = 5e-4


def build(name, raws, n_sel=2, **ctx_over):
    """The effect as simulation.py builds it: validated Params per car, stacked per corner."""
    cls = EFFECTS.get(name)
    plist = [validate_params(cls.Params, raw, "x") for raw in raws]
    n = len(plist)
    ctx = dict(n_cars=n, corners=[f"c{i}" for i in range(n_sel)], dt=DT,
               static_suspension_force=np.full((n, n_sel), 2500.0), static_tire_force=np.full((n, n_sel), 3400.0),
               spring_stiffness=np.full((n, n_sel), 17000.0), damping=np.full((n, n_sel), 1000.0),
               tire_stiffness=np.full((n, n_sel), 190000.0), tire_damping=np.full((n, n_sel), 150.0),
               effective_mass=np.full((n, n_sel), 50.0))
    ctx.update(ctx_over)
    return cls(stack_params(plist, n_sel), EffectContext(**ctx))


def f(eff, s, v, t=0.0):
    """One call of force() with s, v given as nested lists (n_cars, n_sel)."""
    return eff.force(np.array(s, dtype=float), np.array(v, dtype=float), t, DT)


# ------------------------------------------------------------------------------------------------------
def test_quadratic_damping_law():
    eff = build("quadratic_damping", [{"c_v": 250.0}, {"c_v": [100.0, 400.0]}])
    v = [[-1.2, 0.3], [0.0, -0.05]]
    ref = [[-250.0 * -1.2 * 1.2, -250.0 * 0.3 * 0.3], [0.0, -400.0 * -0.05 * 0.05]]
    np.testing.assert_allclose(f(eff, [[0.1, 0.0], [0.0, 0.0]], v), ref, rtol=1e-15)


def test_quadratic_damping_step_mean_law():
    """step_force: mean: −c_v times the mean of w·|w| over the step, w linear from v with the last step's slope
    (v − v_prev)/dt (the first step: held), against quadrature; one sign, a reversal inside the step, and the
    start law differs on the same sequence (the check can fail)."""
    c = 250.0
    eff = build("quadratic_damping", [{"c_v": c, "step_force": "mean"}], n_sel=1)
    start = build("quadratic_damping", [{"c_v": c}], n_sel=1)
    tau = (np.arange(20000) + 0.5) / 20000
    v_prev, diff = None, 0.0
    for v in (0.8, 1.0, 0.3, 0.05, -0.1, -0.4, -0.2):
        a = 0.0 if v_prev is None else (v - v_prev) / DT
        w = v + a * DT * tau
        ref = -c * np.mean(w * np.abs(w))
        got = f(eff, [[0.0]], [[v]])[0, 0]
        assert got == pytest.approx(ref, rel=1e-6, abs=1e-9), v
        diff = max(diff, abs(got - f(start, [[0.0]], [[v]])[0, 0]))
        v_prev = v
    assert diff > 10.0


def test_bump_stop_step_mean_law():
    """step_force: mean: the law's exact mean over the step along the travel s + v·τ, against quadrature of the
    start-of-step law (the damped stop jumps by c·v at a contact inside the step); fully engaged at v = 0 it is
    the start law, and on a contact inside the step it differs from it (the check can fail)."""
    k, c, gc, ge = 40000.0, 2000.0, 0.03, 0.05
    for damping in (0.0, c):
        raw = {"gap": 0.05, "gap_compression": gc, "stiffness": k, "damping": damping}
        eff = build("bump_stop", [dict(raw, step_force="mean")], n_sel=1)
        start = build("bump_stop", [raw], n_sel=1)
        tau = (np.arange(40000) + 0.5) / 40000 * DT
        diff = 0.0
        for s, v in [(0.0, 1.0), (-0.0295, -2.0), (-0.0305, 2.0), (-0.04, -0.2), (-0.04, 0.5), (-0.04, 0.0),
                     (0.0498, 1.0), (0.0502, -1.0), (0.07, -0.5), (-0.02, -30.0)]:
            ref = np.mean([f(start, [[s + v * x]], [[v]])[0, 0] for x in tau])
            got = f(eff, [[s]], [[v]])[0, 0]
            assert got == pytest.approx(ref, rel=1e-4, abs=(k * abs(v) * DT + damping * abs(v)) * 1e-4), (s, v)
            assert eff.signals()["engaged"][0, 0] == (1.0 if s < -gc else -1.0 if s > ge else 0.0)
            diff = max(diff, abs(got - f(start, [[s]], [[v]])[0, 0]))
        assert f(eff, [[-0.04]], [[0.0]])[0, 0] == f(start, [[-0.04]], [[0.0]])[0, 0] == pytest.approx(k * 0.01)
        assert diff > 0.1 * k * 2.0 * DT


def test_asymmetric_damping_coefficients_law():
    eff = build("asymmetric_damping", [{"c_comp": 800.0, "c_reb": 2400.0}, {"c_comp": [500.0, 0.0], "c_reb": 1500.0}])
    v = [[0.2, -0.2], [-0.1, 0.4]]
    ref = [[-2400.0 * 0.2, 800.0 * 0.2], [500.0 * 0.1, -1500.0 * 0.4]]  # rebound v > 0, compression v < 0
    np.testing.assert_allclose(f(eff, np.zeros((2, 2)), v), ref, rtol=1e-15)
    assert np.all(f(eff, np.zeros((2, 2)), np.zeros((2, 2))) == 0.0)


def _interp_by_hand(v, tab):
    """F = −R(v): R through the [v, F] points, linear between them, the end segments continued."""
    xs, fs = [p[0] for p in tab], [p[1] for p in tab]
    j = 0 if v < xs[0] else len(xs) - 2 if v >= xs[-1] else max(i for i in range(len(xs) - 1) if xs[i] <= v)
    return -(fs[j] + (fs[j + 1] - fs[j]) / (xs[j + 1] - xs[j]) * (v - xs[j]))


def test_asymmetric_damping_map_law():
    """Two cars with maps of different lengths: beyond both ends, on map points, between them."""
    tab1 = [[-1.0, -900.0], [-0.1, -300.0], [0.0, 0.0], [0.1, 500.0], [1.0, 1800.0]]
    tab2 = [[-0.5, -400.0], [0.0, 0.0], [0.3, 900.0]]
    eff = build("asymmetric_damping", [{"table": tab1}, {"table": tab2}])
    pts = [-2.5, -1.0, -0.55, -0.1, -0.03, 0.0, 0.05, 0.1, 0.3, 0.7, 1.0, 3.0]
    for v in pts:
        got = f(eff, np.zeros((2, 2)), [[v, v], [v, v]])
        assert got[0, 0] == pytest.approx(_interp_by_hand(v, tab1), rel=1e-13, abs=1e-9), v
        assert got[1, 1] == pytest.approx(_interp_by_hand(v, tab2), rel=1e-13, abs=1e-9), v
    assert f(eff, np.zeros((2, 2)), [[3.0, 0.0], [0.0, 0.0]])[0, 0] == pytest.approx(-(1800.0 + 1300.0 / 0.9 * 2.0))


def test_coulomb_friction_tanh_law():
    eff = build("coulomb_friction", [{"force": 150.0, "v_eps": 0.02}, {"force": [80.0, 200.0], "law": "tanh"}])
    v = [[0.01, -0.5], [0.0, -0.003]]
    ref = [[-150.0 * math.tanh(0.5), 150.0 * math.tanh(25.0)], [0.0, 200.0 * math.tanh(0.3)]]  # v_eps 0.01 default
    np.testing.assert_allclose(f(eff, np.zeros((2, 2)), v), ref, rtol=1e-14)
    np.testing.assert_allclose(eff.signals()["force"], ref, rtol=1e-14)


def test_coulomb_friction_tanh_step_mean_law():
    """step_force: mean: the F that equals −F_c times the mean of tanh(v(τ)/v_eps) over the step, v(τ) linear
    from v_k to v_k + (a_k + F/m_r)·dt (a_k as for stick_slip), checked by quadrature (bisection on F, a
    midpoint rule of 20 000 points), through a rate reversal inside a step and a stiff v_eps."""
    m_r, Fc, ve = 50.0, 180.0, 0.002
    eff = build("coulomb_friction", [{"force": Fc, "v_eps": ve, "step_force": "mean"}], n_sel=1)
    tau = (np.arange(20000) + 0.5) / 20000 * DT

    def by_hand(v, a):
        lo, hi = -Fc, Fc
        for _ in range(80):
            F = 0.5 * (lo + hi)
            r = F + Fc * np.mean(np.tanh((v + (a + F / m_r) * tau) / ve))
            lo, hi = (lo, F) if r > 0 else (F, hi)
        return 0.5 * (lo + hi)

    F_prev, v_prev, seen = 0.0, None, set()
    for v in (0.01, 0.004, 0.0005, -0.002, -0.0001, 0.3, 0.0):
        a = 0.0 if v_prev is None else (v - v_prev) / DT - F_prev / m_r
        ref = by_hand(v, a)
        got = f(eff, [[0.0]], [[v]])[0, 0]
        assert got == pytest.approx(ref, rel=1e-6, abs=1e-6), v
        seen.add(np.sign(v) * np.sign(v + (a + got / m_r) * DT))  # the rate's sign at the start and end
        F_prev, v_prev = got, v
    assert -1.0 in seen and 1.0 in seen  # steps with and without a reversal inside
    # a narrow ramp (no other acceleration, a mass the friction hardly moves): the law at the rate itself
    eff = build("coulomb_friction", [{"force": Fc, "v_eps": 0.05, "step_force": "mean"}], n_sel=1,
                effective_mass=np.full((1, 1), 1e9))
    assert f(eff, [[0.0]], [[0.03]])[0, 0] == pytest.approx(-Fc * math.tanh(0.03 / 0.05), rel=1e-5)


def test_coulomb_friction_stick_slip_law():
    """Time stepping: F_k = clip(−m_r·(v_k/dt + a_k), −F_c, F_c), a_k = (v_k − v_{k−1})/dt − F_{k−1}/m_r."""
    m_r, Fc = 50.0, 100.0
    eff = build("coulomb_friction", [{"force": Fc}], n_sel=1)
    F_prev, v_prev = 0.0, None
    for v in (1e-4, 5e-4, 0.3, 0.25, -1e-4, 0.0):
        a = 0.0 if v_prev is None else (v - v_prev) / DT - F_prev / m_r
        ref = min(max(-m_r * (v / DT + a), -Fc), Fc)
        got = f(eff, [[0.0]], [[v]])[0, 0]
        assert got == pytest.approx(ref, rel=1e-12, abs=1e-12), v
        assert eff.signals()["stuck"][0, 0] == (1.0 if abs(ref) < Fc * (1 - 1e-9) else 0.0)
        F_prev, v_prev = ref, v
    # the sequence both stuck (|F| < F_c) and slipped (F = ±F_c)
    eff.reset()
    assert abs(f(eff, [[0.0]], [[1e-4]])[0, 0]) < Fc and f(eff, [[0.0]], [[0.3]])[0, 0] == -Fc


def test_bump_stop_law():
    """max(0, k·(−g_c − s) − c·v) beyond the compression gap, min(0, −k·(s − g_e) − c·v) beyond the extension
    gap, 0 inside; the damping never makes a stop pull."""
    eff = build("bump_stop", [{"gap": 0.05, "gap_compression": 0.03, "stiffness": 40000.0, "damping": 2000.0}],
                n_sel=1)
    k, c, gc, ge = 40000.0, 2000.0, 0.03, 0.05
    for s, v, ref, engaged in [(0.0, 1.0, 0.0, 0.0), (-0.029, -0.5, 0.0, 0.0), (0.049, 0.5, 0.0, 0.0),
                               (-0.04, -0.2, k * 0.01 + c * 0.2, 1.0), (-0.04, 0.1, k * 0.01 - c * 0.1, 1.0),
                               (-0.04, 0.5, 0.0, 1.0),  # separating fast: clipped to 0, no adhesion
                               (0.07, 0.1, -k * 0.02 - c * 0.1, -1.0), (0.07, -0.5, 0.0, -1.0)]:
        assert f(eff, [[s]], [[v]])[0, 0] == pytest.approx(ref, rel=1e-12, abs=1e-9), (s, v)
        assert eff.signals()["engaged"][0, 0] == engaged


def test_cubic_stiffness_law():
    eff = build("cubic_stiffness", [{"k3": [1e6, -2e5]}])
    np.testing.assert_allclose(f(eff, [[0.05, -0.1]], [[0.0, 0.0]]), [[-1e6 * 0.05 ** 3, -2e5 * 0.1 ** 3]], rtol=1e-14)


def test_tire_liftoff_law():
    """Correction max(0, k_t·x + c_t·ẋ − F_static): zero while the tire pushes, cancels the pull when it lifts."""
    eff = build("tire_liftoff", [{}], n_sel=1)
    kt, ct, Fs = 190000.0, 150.0, 3400.0
    for x, xd, lifted in [(0.0, 0.0, 0.0), (0.017, 0.0, 0.0), (0.018, 0.0, 1.0), (0.017, 2.0, 1.0), (0.03, -2.0, 1.0),
                              (0.03, -20.0, 0.0)]:
        ref = max(0.0, kt * x + ct * xd - Fs)
        assert f(eff, [[x]], [[xd]])[0, 0] == pytest.approx(ref, rel=1e-12, abs=1e-9)
        assert eff.signals()["lifted"][0, 0] == lifted


def test_varying_stiffness_law():
    eff = build("varying_stiffness", [{"amplitude": 2000.0, "frequency": 1.5, "phase": 0.3, "offset": 500.0}], n_sel=1)
    for t in (0.0, 0.1, 0.77):
        dk = 500.0 + 2000.0 * math.sin(2 * math.pi * 1.5 * t + 0.3)
        assert eff.force(np.array([[0.02]]), np.zeros((1, 1)), t, DT)[0, 0] == pytest.approx(-dk * 0.02, rel=1e-13)
        assert eff.signals()["dk"][0, 0] == pytest.approx(dk, rel=1e-13)


def test_backlash_law():
    """Play operator with b = 2 mm: the driven side y stays until the travel has taken up the play."""
    eff = build("backlash", [{"stiffness": 5000.0, "play": 0.002}], n_sel=1)
    path = [0.0, 0.001, 0.003, 0.002, -0.002, -0.005, -0.004]
    y_ref = [0.0, 0.0, 0.001, 0.001, 0.0, -0.003, -0.003]
    for s, y in zip(path, y_ref):
        assert f(eff, [[s]], [[0.0]])[0, 0] == pytest.approx(-5000.0 * y, abs=1e-12)
        assert eff.signals()["y"][0, 0] == pytest.approx(y, abs=1e-15)


def test_hysteresis_law_against_the_bouc_wen_ode():
    """The exact per-step update against dw/ds = (1 − |w|·(1 + sgn(ds·w))/2)/x_y integrated in fine steps
    along a path with reversals (loading, unloading through w = 0, saturation)."""
    Fh, xy = 100.0, 0.004
    eff = build("hysteresis", [{"force": Fh, "x_y": xy}], n_sel=1)
    t = np.arange(600) * DT
    path = [0.02 * math.sin(2 * math.pi * 3.0 * tk) + 0.003 * math.sin(2 * math.pi * 17.0 * tk) for tk in t]
    w, F = 0.0, []
    for k, s in enumerate(path):
        if k:
            ds = (s - path[k - 1]) / 2000
            for _ in range(2000):
                sg = (ds * w > 0) - (ds * w < 0)  # sgn(ṡ·w)
                w += ds * (1 - abs(w) * (1 + sg) / 2) / xy
        F.append(f(eff, [[s]], [[0.0]])[0, 0])
        assert F[-1] == pytest.approx(-Fh * w, abs=2e-3 * Fh), k
    assert max(F) > 0.99 * Fh and min(F) < -0.99 * Fh


def _coulomb_mean_by_hand(v, a, m_r, Fc, n=20000):
    """The mean force over one step DT of exact Coulomb friction on a mass m_r pushed by the other forces
    m_r·a (held): the rate integrated in n sub-steps, a sub-step split where the rate crosses zero; at zero
    rate it sticks while |a| ≤ F_c/m_r, else slides the way a pushes."""
    h, imp, b = DT / n, 0.0, Fc / m_r
    for _ in range(n):
        left = h
        while left > 0.0:
            if v == 0.0:
                if abs(a) <= b:
                    imp += -m_r * a * left
                    break
                F = -Fc * math.copysign(1.0, a)
            else:
                F = -Fc * math.copysign(1.0, v)
            acc = a + F / m_r
            v_new = v + acc * left
            if v != 0.0 and v_new * v < 0.0:  # reaches zero inside the sub-step
                dt0 = -v / acc
                imp += F * dt0
                left -= dt0
                v = 0.0
                continue
            imp += F * left
            v, left = v_new, 0.0
    return imp / DT


def test_coulomb_friction_stick_slip_step_mean_law():
    """stick_slip with step_force: mean: the exact law's mean over the step with the other forces held, their
    acceleration a_k = 2·g_{k−1} − g_{k−2} + F_act,k/m_r, g_{k−1} = (v_k − v_{k−1})/dt − (F_{k−1} + F_act,k−1)/m_r
    (the other forces' mean over the last step extrapolated; this step's actuator force, which the effect reads),
    checked against sub-stepped Coulomb friction: sliding, sticking, a rate reversal
    inside a step that slides on, and actuator jumps.  The start-of-step law on the same sequence is off by
    more than F_c/2 (the check can fail)."""
    m_r, Fc = 50.0, 100.0
    seq = [(0.01, 0.0), (0.012, 0.0), (0.001, 0.0), (0.001, -400.0), (-0.002, -400.0), (-0.0021, 150.0),
           (-1e-4, 150.0), (0.0, 0.0), (0.02, 300.0)]
    got_all, ref_all = [], []
    for mode in ("mean", "start"):
        eff = build("coulomb_friction", [{"force": Fc, "step_force": mode}], n_sel=1)
        assert type(eff).reads_actuator_force
        F_prev, v_prev, fa_prev, g_prev, kinds = 0.0, None, 0.0, None, set()
        for v, fa in seq:
            g = 0.0 if v_prev is None else (v - v_prev) / DT - (F_prev + fa_prev) / m_r
            a = (g if g_prev is None else 2.0 * g - g_prev) + fa / m_r
            g_prev = None if v_prev is None else g
            ref = _coulomb_mean_by_hand(v, a, m_r, Fc)
            got = eff.force(np.array([[0.0]]), np.array([[v]]), 0.0, DT, np.array([[fa]]))[0, 0]
            if mode == "mean":
                assert got == pytest.approx(ref, rel=1e-3, abs=1e-3), (v, fa)
                b = Fc / m_r
                kind = ("reverses" if v * a < 0 and abs(a) > b and abs(v) < (b + abs(a)) * DT else
                        "sticks" if abs(got) < Fc * (1 - 1e-9) else "slides")
                kinds.add(kind)
                assert eff.signals()["stuck"][0, 0] == (1.0 if kind == "sticks" else 0.0)
                got_all.append(got)
                ref_all.append(ref)
            else:
                got_all.append(got)
            F_prev, v_prev, fa_prev = got, v, fa
        if mode == "mean":
            assert kinds == {"reverses", "sticks", "slides"}
    start = np.array(got_all[len(seq):])
    assert np.max(np.abs(start - np.array(ref_all))) > 0.5 * Fc


# ------------------------------------------------------------------------------------------------------
ENSEMBLES = {
    "quadratic_damping": [{"c_v": 300.0}, {"c_v": [100.0, 400.0], "step_force": "mean"}, {"c_v": 0.0}],
    "asymmetric_damping": [{"table": [[-1.0, -900.0], [0.0, 0.0], [1.0, 1800.0]]}, {"c_comp": 500.0, "c_reb": 900.0},
                           {"table": [[-0.5, -400.0], [0.0, 0.0], [0.1, 100.0], [0.3, 900.0]]}],
    "coulomb_friction": [{"force": 100.0, "step_force": "mean"}, {"force": 150.0, "v_eps": 0.02},
                         {"force": [50.0, 400.0], "law": "stick_slip"}],
    # (an optional gap given for some cars and not others does not stack: each car sets both or none)
    "bump_stop": [{"gap": 0.01, "gap_compression": 0.01, "damping": 500.0},
                  {"gap": [0.02, 0.005], "gap_compression": 0.004, "step_force": "mean"},
                  {"gap": 0.015, "gap_compression": [0.02, 0.01], "stiffness": [1e4, 8e4]}],
    "cubic_stiffness": [{"k3": 1e6}, {"k3": [-2e5, 3e6]}, {"k3": 0.0}],
    "hysteresis": [{"force": 100.0, "x_y": 0.005}, {"force": [50.0, 200.0], "x_y": 0.002}, {"force": 0.0}],
    "backlash": [{"stiffness": 5000.0, "play": 0.002}, {"stiffness": 8000.0, "play": [0.0, 0.004]}, {}],
    "tire_liftoff": [{}, {}, {}],
    "varying_stiffness": [{"amplitude": 2000.0, "frequency": 1.5}, {"offset": [100.0, -300.0]},
                          {"amplitude": 500.0, "frequency": 3.0, "phase": 1.0}],
    "maxwell_damper": [{"compliance": 5e-6}, {"compliance": [1e-6, 2e-5]}, {"compliance": 0.0}],
    "digressive_damping": [{"v_knee_comp": 0.01, "drop_reb": 0.8}, {"v_knee_reb": [0.005, 0.02], "step_force": "mean"},
                           {"drop_comp": 0.0, "drop_reb": 1.0, "v_knee_reb": 0.0}],
}


@pytest.mark.parametrize("name", sorted(ENSEMBLES))
def test_a_car_in_an_ensemble_is_the_car_alone(name):
    """Forces and signals of each car of a mixed ensemble equal those of the same car built alone."""
    raws = ENSEMBLES[name]
    rng = np.random.default_rng(5)
    steps = 300
    s = 0.03 * np.sin(np.arange(steps)[:, None, None] * 0.05 + rng.uniform(0, 6, (1, 3, 2)))
    v = np.gradient(s, DT, axis=0) + rng.normal(0, 0.01, s.shape)
    ens = build(name, raws)
    alone = [build(name, [r]) for r in raws]
    for k in range(steps):
        fe = ens.force(s[k], v[k], k * DT, DT)
        se = ens.signals()
        for i, a in enumerate(alone):
            np.testing.assert_array_equal(fe[i], a.force(s[k, i:i + 1], v[k, i:i + 1], k * DT, DT)[0])
            for nm, val in a.signals().items():
                np.testing.assert_array_equal(se[nm][i], val[0])
    assert np.any(fe != 0) or name == "tire_liftoff"


def test_reset_restarts_the_state():
    eff = build("hysteresis", [{"force": 100.0, "x_y": 0.002}])
    first = [f(eff, [[s, -s]], [[0.0, 0.0]]).copy() for s in (0.0, 0.01, 0.004)]
    eff.reset()
    again = [f(eff, [[s, -s]], [[0.0, 0.0]]).copy() for s in (0.0, 0.01, 0.004)]
    np.testing.assert_array_equal(first, again)
    assert np.any(np.array(first) != 0)


def test_every_effect_has_a_kernel():
    names = EFFECTS.names()
    assert {"quadratic_damping", "bump_stop", "asymmetric_damping", "backlash", "coulomb_friction",
            "cubic_stiffness", "hysteresis", "tire_liftoff", "varying_stiffness"} <= set(names)
    for name in names:
        assert EFFECTS.get(name).kernel is not None, name


# ------------------------------------------------------------------------------------------------------
ALL_EFFECTS = [
    {"type": "quadratic_damping", "params": {"c_v": 300.0}},
    {"type": "asymmetric_damping", "params": {"table": [[-1.0, -900.0], [-0.1, -300.0], [0.0, 0.0], [0.1, 500.0],
                                                        [1.0, 1800.0]]}},
    {"type": "coulomb_friction", "params": {"force": 80.0}},
    {"type": "coulomb_friction", "params": {"force": 50.0, "v_eps": 0.05}},
    {"type": "coulomb_friction", "params": {"force": 60.0, "step_force": "mean"}},  # reads the actuator force
    {"type": "bump_stop", "params": {"gap": 0.02, "stiffness": 40000.0, "damping": 500.0}},
    {"type": "bump_stop", "params": {"gap": 0.025, "stiffness": 30000.0, "damping": 300.0, "step_force": "mean"}},
    {"type": "quadratic_damping", "params": {"c_v": 200.0, "step_force": "mean"}},
    {"type": "cubic_stiffness", "params": {"k3": 1e6}},
    {"type": "hysteresis", "params": {"force": 60.0, "x_y": 0.003}},
    {"type": "backlash", "params": {"stiffness": 3000.0, "play": 0.002}},
    {"type": "varying_stiffness", "params": {"amplitude": 2000.0, "frequency": 1.0, "offset": 100.0}},
    {"type": "tire_liftoff", "params": {}},
    {"type": "maxwell_damper", "params": {"compliance": 2e-5}},
]


def _scenario(effects, duration=0.4, amplitude=0.05, **over):
    raw = {"name": "effects", "vehicle": {"model": "quarter_car", "effects": effects},
           "road": {"type": "sine", "params": {"amplitude": amplitude, "frequency": 3.0}, "speed": 20.0},
           "sensors": [{"type": "corner_body_vel"}], "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
           "sim": {"duration": duration, "seed": 1}}
    raw.update(over)
    return parse_scenario(raw)


def _run(scs, compiled, monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1" if compiled else "0")
    sim = Simulation(scs)
    return sim, sim.run()


def test_python_loop_equals_compiled_loop_with_every_effect(monkeypatch):
    """Every effect at once, on a road that reaches the stops and lifts the wheel: the two loops run the same
    kernels, so every logged channel is identical, bit for bit (tanh, sin, exp and pow included)."""
    scs = [_scenario(ALL_EFFECTS)]
    sim_c, rc = _run(scs, True, monkeypatch)
    sim_p, rp = _run(scs, False, monkeypatch)
    assert sim_c.loop == "full" and sim_p.loop == "python"
    ts = rp[0].ts
    assert ts["effect.bump_stop.engaged.0"].abs().max() == 1.0 and ts["effect.tire_liftoff.lifted.0"].max() == 1.0
    assert rp[0].ts.equals(rc[0].ts)


def test_effect_in_plain_numpy_runs_in_the_python_loop(monkeypatch):
    """A user's effect without a kernel: its numpy force() and signals() drive the Python loop (the compiled
    loop declines it, naming it), and it matches the built-in kernel of the same law."""
    if "_test_numpy_quadratic" not in EFFECTS._items:
        @EFFECTS.register("_test_numpy_quadratic")
        class NumpyQuadratic(Effect):
            Params = EFFECTS.get("quadratic_damping").Params

            def reset(self):
                self.c_v = np.asarray(self.p.c_v, dtype=float)
                self.last = np.zeros((self.ctx.n_cars, len(self.ctx.corners)))

            def force(self, s, v, t, dt):
                self.last = -self.c_v * v * np.abs(v)
                return self.last

            def signals(self):
                return {"force": self.last}

    user = _scenario([{"type": "_test_numpy_quadratic", "params": {"c_v": 400.0}}])
    builtin = _scenario([{"type": "quadratic_damping", "params": {"c_v": 400.0}}])
    sim_u, ru = _run([user], True, monkeypatch)
    sim_b, rb = _run([builtin], True, monkeypatch)
    assert sim_u.loop == "python" and "_test_numpy_quadratic" in sim_u.loop_reason
    assert sim_b.loop == "full"
    ts_u, ts_b = ru[0].ts, rb[0].ts
    assert ts_u["effect_force"].abs().max() > 10.0
    np.testing.assert_array_equal(ts_u["effect._test_numpy_quadratic.force.0"].to_numpy(), ts_u["effect_force"].to_numpy())
    for col in ("body_z", "travel", "effect_force"):
        np.testing.assert_allclose(ts_u[col], ts_b[col], rtol=0, atol=1e-12 * ts_b[col].abs().max())


def test_two_effects_of_one_type_log_separate_columns(monkeypatch):
    """Bump stops front and rear with different gaps: each effect's signals get their own columns
    (``bump_stop`` and ``bump_stop#2``) in both loops; before, the second overwrote the first's."""
    effects = [{"type": "bump_stop", "corners": ["front"], "params": {"gap": 0.005}},
               {"type": "bump_stop", "corners": ["rear"], "params": {"gap": 0.5}}]
    raw = {"name": "two_stops", "vehicle": {"model": "half_car", "effects": effects},
           "road": {"type": "sine", "params": {"amplitude": 0.05, "frequency": 3.0}, "speed": 20.0},
           "controller": {"type": "passive"}, "sim": {"duration": 0.4, "seed": 1}}
    for compiled in (True, False):
        sim, res = _run([parse_scenario(raw)], compiled, monkeypatch)
        ts = res[0].ts
        assert [e.label for e, _ in sim.effects] == ["bump_stop", "bump_stop#2"]
        front, rear = ts["effect.bump_stop.engaged.0"], ts["effect.bump_stop#2.engaged.0"]
        assert front.abs().max() == 1.0  # the 5 mm front stop is reached
        assert rear.abs().max() == 0.0   # the 50 cm rear stop is not
