"""Compiled effect kernels (suspension_sim.compiled) against the numpy ``force`` methods.

Each effect is built as ``simulation.py`` builds it (validated Params per car, stacked per corner) for a lone
car and for an ensemble of cars with different (scalar and per-corner) parameters, driven through inputs
that reach every branch of its force law, and ``check_effect`` compares force and logged signals step by
step.  Kernels do the same floating-point operations in the same order as ``force``, so the difference must
be exactly 0.0; where a kernel calls a transcendental function (named at the test) numpy and numba may
differ by an ulp, and the bound is 1e-12 relative to the force scale.
"""
from __future__ import annotations

import numpy as np
import pytest

from suspension_sim.compiled.testing import check_effect
from suspension_sim.components import stack_params, validate_params
from suspension_sim.effects.base import EffectContext
from suspension_sim.registry import EFFECTS

N_SEL = 4
DT = 5e-4


def build(name, raws, n_sel=N_SEL, **ctx_over):
    cls = EFFECTS.get(name)
    plist = [validate_params(cls.Params, raw, "x") for raw in raws]
    n = len(plist)
    rng = np.random.default_rng(7)
    ctx = dict(n_cars=n, corners=[f"c{i}" for i in range(n_sel)], dt=DT,
               static_suspension_force=rng.uniform(2000, 3000, (n, n_sel)),
               static_tire_force=rng.uniform(3000, 4000, (n, n_sel)),
               spring_stiffness=rng.uniform(15000, 20000, (n, n_sel)),
               damping=rng.uniform(800, 1200, (n, n_sel)),
               tire_stiffness=rng.uniform(150000, 250000, (n, n_sel)),
               tire_damping=rng.uniform(0, 200, (n, n_sel)),
               effective_mass=rng.uniform(40, 60, (n, n_sel)))
    ctx.update(ctx_over)
    return cls(stack_params(plist, n_sel), EffectContext(**ctx))


def sine_inputs(n_cars, amp, freq=2.0, steps=1200, noise=0.0, seed=0):
    """Travel s = amp·sin(2π f t + phase) per corner (phases/amplitude factors differ per car and corner)
    and its exact rate, as (steps, n_cars, N_SEL) sequences; optional random jitter on both."""
    rng = np.random.default_rng(seed)
    t = np.arange(steps)[:, None, None] * DT
    ph = rng.uniform(0, 2 * np.pi, (1, n_cars, N_SEL))
    a = amp * rng.uniform(0.7, 1.3, (1, n_cars, N_SEL))
    w = 2 * np.pi * freq
    s = a * np.sin(w * t + ph)
    v = a * w * np.cos(w * t + ph)
    if noise:
        s = s + noise * rng.standard_normal(s.shape)
        v = v + noise * 50 * rng.standard_normal(v.shape)
    return s, v


def with_specials(s, v):
    """Add exact zeros (v = 0, s = 0) so sign/branch ties are exercised."""
    s, v = s.copy(), v.copy()
    v[::50, 0, 0] = 0.0
    s[::70, 0, -1] = 0.0
    return s, v


def run(eff, s, v):
    return check_effect(eff, list(s), list(v), dt=DT)


# ------------------------------------------------------------------------------------------------------
def test_quadratic_damping():
    for raws in ([{"c_v": 300.0}], [{"c_v": 250.0}, {"c_v": [100.0, 200.0, 300.0, 400.0]}, {"c_v": 0.0}]):
        eff = build("quadratic_damping", raws)
        s, v = with_specials(*sine_inputs(len(raws), 0.05, steps=400))
        assert run(eff, s, v) == 0.0


def test_bump_stop():
    # (an optional gap given for some cars and not others does not stack: each car sets both or none)
    ens = [{"gap": 0.05, "gap_compression": 0.05, "stiffness": 40000.0, "damping": 2000.0},
           {"gap": [0.04, 0.05, 0.06, 0.07], "gap_compression": 0.03, "stiffness": [1e4, 2e4, 3e4, 4e4]},
           {"gap": 0.06, "gap_compression": [0.02, 0.03, 0.04, 0.05], "damping": [0.0, 500.0, 1500.0, 3000.0]}]
    for raws in ([ens[0]], ens):
        eff = build("bump_stop", raws)
        # amplitude beyond both gaps: both stops engage, with damping large enough to clip to zero
        s, v = with_specials(*sine_inputs(len(raws), 0.09, freq=3.0, steps=800))
        p, _ = eff.kernel_data()
        assert np.any(s < -p[..., 0]) and np.any(s > p[..., 1])
        assert run(eff, s, v) == 0.0


def python_signals(eff, s, v, name):
    """The Python effect's signal ``name`` after each step (to check that the inputs reach every branch)."""
    import copy
    e = copy.deepcopy(eff)
    e.reset()
    out = []
    for k in range(len(s)):
        e.force(s[k].copy(), v[k].copy(), k * DT, DT)
        out.append(np.broadcast_to(e.signals()[name], s[k].shape).copy())
    return np.array(out)


def test_asymmetric_damping_coefficients():
    ens = [{"c_comp": 800.0, "c_reb": 2400.0}, {"c_comp": [500.0, 600.0, 700.0, 800.0], "c_reb": 1500.0},
           {"c_comp": 0.0, "c_reb": [1000.0, 0.0, 3000.0, 4000.0]}]
    for raws in ([ens[0]], ens):
        eff = build("asymmetric_damping", raws)
        s, v = with_specials(*sine_inputs(len(raws), 0.05, steps=300))
        assert np.any(v > 0) and np.any(v < 0) and np.any(v == 0)
        assert run(eff, s, v) == 0.0


def test_asymmetric_damping_map():
    """Damper maps: velocities beyond both ends (extrapolation), exactly on map points, between them; cars with
    maps of different lengths (padded p rows)."""
    tab1 = [[-1.0, -900.0], [-0.1, -300.0], [0.0, 0.0], [0.1, 500.0], [1.0, 1800.0]]
    tab2 = [[-0.5, -400.0], [0.0, 0.0], [0.3, 900.0]]
    tab3 = [[-2.0, -1500.0], [-0.3, -450.0], [-0.05, -60.0], [0.0, 10.0], [0.05, 150.0], [0.4, 1100.0],
            [1.5, 2500.0]]
    for raws in ([{"table": tab1}], [{"table": tab1}, {"table": tab2}, {"table": tab3}],
                 [{"table": tab2}] * 3):
        eff = build("asymmetric_damping", raws)
        s, v = sine_inputs(len(raws), 0.12, freq=3.0, steps=400)  # |v| up to ~3 m/s: beyond every map end
        for i, r in enumerate(raws):  # exact map points
            pts = np.array(r["table"])[:, 0]
            v[:len(pts), i, 0] = pts
        assert np.all(v.max(axis=(0, 2)) > 1.5) and np.all(v.min(axis=(0, 2)) < -2.0)
        assert run(eff, s, v) == 0.0


def test_backlash():
    ens = [{"stiffness": 5000.0, "play": 0.002}, {"stiffness": [1e3, 2e3, 3e3, 4e3], "play": 0.004},
           {"stiffness": 8000.0, "play": [0.0, 0.001, 0.003, 0.01]}]
    for raws in ([ens[0]], ens):
        eff = build("backlash", raws)
        # a sine with jitter: many reversals, the play taken up in both directions and held in between
        s, v = sine_inputs(len(raws), 0.01, freq=4.0, steps=1000, noise=2e-4)
        y = python_signals(eff, s, v, "y")
        p, _ = eff.kernel_data()
        b = p[..., 1]
        assert np.any(np.isclose(y, s - b)) and np.any(np.isclose(y, s + b))  # driven both ways
        assert np.any(np.abs(y - s) < b - 1e-4)  # free motion inside the play
        assert run(eff, s, v) == 0.0


def test_tire_liftoff():
    for n in (1, 3):
        eff = build("tire_liftoff", [{}] * n)
        # wheel − road from equilibrium beyond F_static/k_t (0.012 … 0.027 m here): the wheel lifts
        s, v = with_specials(*sine_inputs(n, 0.04, freq=8.0, steps=500))
        lifted = python_signals(eff, s, v, "lifted")
        assert lifted.min() == 0.0 and lifted.max() == 1.0
        assert run(eff, s, v) == 0.0


def test_coulomb_friction_stick_slip():
    """Exact (no transcendental function): sticking (|F| < F_c) and slipping (F = ±F_c) both occur."""
    ens = [{"force": 100.0}, {"force": [50.0, 100.0, 200.0, 400.0], "law": "stick_slip"}, {"force": 0.0}]
    for raws in ([ens[0]], ens):
        eff = build("coulomb_friction", raws)
        # slow travel-rate wobble (sticks: the force needed to stop it is below F_c) plus fast bursts (slips)
        s, v = sine_inputs(len(raws), 0.002, freq=1.0, steps=800)
        v[300:500] *= 200.0
        v[::97] = 0.0
        stuck = python_signals(eff, s, v, "stuck")
        assert stuck[:, 0].min() == 0.0 and stuck[:, 0].max() == 1.0
        assert run(eff, s, v) == 0.0


def test_coulomb_friction_tanh_and_mixed():
    """np.tanh (numpy SIMD) vs np.tanh in numba (libm): may differ by an ulp -> <= 1e-12·F_c."""
    tanh = [{"force": 150.0, "v_eps": 0.02}, {"force": [80.0, 120.0, 160.0, 200.0], "v_eps": 0.05},
            {"force": 300.0, "law": "tanh"}]
    mixed = [{"force": 100.0}, {"force": 150.0, "v_eps": 0.02},
             {"force": [50.0, 100.0, 200.0, 400.0], "law": "stick_slip"}]
    for raws in ([tanh[0]], tanh, mixed):
        eff = build("coulomb_friction", raws)
        s, v = with_specials(*sine_inputs(len(raws), 0.002, freq=1.0, steps=600))
        v[200:400] *= 100.0
        assert run(eff, s, v) <= 1e-12 * 400.0


def test_cubic_stiffness():
    """numpy's s**3 (SIMD pow) vs libm pow in the kernel: may differ by an ulp -> <= 1e-12·max|F|."""
    ens = [{"k3": 1e6}, {"k3": [-2e5, 5e5, 1e6, 3e6]}, {"k3": 0.0}]
    for raws in ([ens[0]], ens):
        eff = build("cubic_stiffness", raws)
        s, v = with_specials(*sine_inputs(len(raws), 0.1, steps=400))
        scale = 3e6 * 1.3 ** 3 * 0.1 ** 3
        assert run(eff, s, v) <= 1e-12 * scale


def test_hysteresis():
    """Loops: large strokes (saturation at ±F_h) and small reversals (unloading branch, w crossing 0).
    np.exp in the loading branch -> <= 1e-12·max(F_h, 1)."""
    ens = [{"force": 100.0, "x_y": 0.005}, {"force": [50.0, 100.0, 200.0, 400.0], "x_y": 0.002},
           {"force": 300.0, "x_y": [0.001, 0.003, 0.01, 0.02]}]
    for raws in ([ens[0]], ens):
        eff = build("hysteresis", raws)
        s, v = sine_inputs(len(raws), 0.03, freq=3.0, steps=800, noise=3e-4)
        s[400:] *= 0.05  # small loops
        idx = np.arange(60, len(s), 60)
        s[idx] = s[idx - 1]  # zero increments (ds = 0)
        w = python_signals(eff, s, v, "w")
        assert w.max() > 0.99 and w.min() < -0.99 and np.any(np.abs(w[400:]) < 0.5)
        assert run(eff, s, v) <= 1e-12 * 400.0


def test_varying_stiffness():
    """np.sin (numpy SIMD vs libm in the kernel) -> <= 1e-12·max(|dk|, |F|)."""
    ens = [{"amplitude": 2000.0, "frequency": 1.5, "phase": 0.3, "offset": 500.0},
           {"amplitude": [1000.0, 2000.0, 3000.0, 4000.0], "frequency": 3.0, "offset": -200.0},
           {"amplitude": 0.0, "frequency": 0.0, "offset": [100.0, 0.0, -100.0, 300.0]}]
    for raws in ([ens[0]], ens):
        eff = build("varying_stiffness", raws)
        s, v = with_specials(*sine_inputs(len(raws), 0.05, steps=600))
        assert run(eff, s, v) <= 1e-12 * 5000.0


def test_every_effect_has_a_kernel():
    names = EFFECTS.names()
    assert {"quadratic_damping", "bump_stop", "asymmetric_damping", "backlash", "coulomb_friction",
            "cubic_stiffness", "hysteresis", "tire_liftoff", "varying_stiffness"} <= set(names)
    for name in names:
        assert EFFECTS.get(name).kernel is not None, name
