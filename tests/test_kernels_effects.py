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
