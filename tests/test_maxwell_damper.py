"""The Maxwell damper (effects/maxwell_damper.py): the car's damper c in series with a mount of stiffness k_b.

- its law against the analytic frequency response of a Maxwell element, |R/v| = c/√(1 + (ω·c/k_b)²) with the
  force lagging the rate by atan(ω·c/k_b) (the baseline, a plain damper, misses it by the factor shown);
- the limit k_b → ∞ (compliance → 0) is the plain damper: no added force (exactly at 0);
- a quarter car with the effect against the independent scipy quarter car with the Maxwell state (the plain
  car is far from it: the effect is visible), and compliance 0 equals the plain car bit for bit.
"""
from __future__ import annotations

import numpy as np
import pytest

from reference_models import ExtraState, QuarterCarRef, nrmse
from suspension_sim.components import stack_params, validate_params
from suspension_sim.effects.base import EffectContext
from suspension_sim.registry import EFFECTS

C = 1500.0  # N·s/m, the car's damper


def build(compliances, dt, c=C):
    cls = EFFECTS.get("maxwell_damper")
    plist = [validate_params(cls.Params, {"compliance": h}, "x") for h in compliances]
    n = len(plist)
    one = np.ones((n, 1))
    ctx = EffectContext(n_cars=n, corners=["c0"], dt=dt, static_suspension_force=2500 * one,
                        static_tire_force=3400 * one, spring_stiffness=17000 * one, damping=c * one,
                        tire_stiffness=190000 * one, tire_damping=0 * one, effective_mass=50 * one)
    return cls(stack_params(plist, 1), ctx)


def response(eff, f, dt, cycles=40):
    """(|R/v|, phase lag of R behind v in rad) in steady state under v = sin(ω·t) (the rate at each step's
    start, as the loops give it), R the damper's force logged at each step's end (the ``R`` signal), from a
    least-squares sine fit over the last 10 cycles; one value per car."""
    w = 2 * np.pi * f
    n = int(round(cycles / f / dt))
    t = np.arange(n) * dt
    R = np.empty((n, eff.ctx.n_cars))
    for k in range(n):
        vk = np.full((eff.ctx.n_cars, 1), np.sin(w * t[k]))
        eff.force(np.zeros_like(vk), vk, t[k], dt)
        R[k] = eff.signals()["R"][:, 0]
    last = t > t[-1] - 10 / f
    te = t[last] + dt
    coef, *_ = np.linalg.lstsq(np.stack([np.sin(w * te), np.cos(w * te)], axis=1), R[last], rcond=None)
    a, b = coef  # R = a·sin + b·cos = |R|·sin(ωt − φ)
    return np.hypot(a, b), np.arctan2(-b, a)


@pytest.mark.parametrize("f", [1.0, 8.0, 30.0])
def test_frequency_response_is_the_maxwell_element(f):
    kb = 2 * np.pi * 8.0 * C  # corner at 8 Hz
    dt = 5e-4
    eff = build([1 / kb, 0.0], dt)
    mag, lag = response(eff, f, dt)
    wt = 2 * np.pi * f * C / kb
    # second order in the step: the mid-step rate is extrapolated, off by (3/8)·(ω·dt)² of the rate
    tol = 1e-3 + 0.4 * (2 * np.pi * f * dt) ** 2
    np.testing.assert_allclose(mag[0], C / np.sqrt(1 + wt ** 2), rtol=tol)
    np.testing.assert_allclose(lag[0], np.arctan(wt), atol=tol)
    # the baseline (a rigid mount: the plain damper) is c at every frequency, in phase
    np.testing.assert_allclose(mag[1], C, rtol=tol)
    assert abs(lag[1]) < 2 * np.pi * f * dt  # in phase (R at the end of the step is c·v at its middle)
    if f > 1.0:  # ... which misses the Maxwell element by more than the tolerance above
        assert mag[1] / (C / np.sqrt(1 + wt ** 2)) > 1.4 and abs(lag[1] - np.arctan(wt)) > 0.7


def test_a_stiff_mount_is_the_plain_damper():
    """compliance → 0 (k_b → ∞): the added force vanishes, as c·τ times the (mid-step) rate's change per step
    over the step (τ = c/k_b: a vanishing mass), and is exactly zero at 0; also for τ far below the step (the state is
    integrated exactly: no stability limit).  Under a rate that jumps at random every step."""
    rng = np.random.default_rng(0)
    v = rng.normal(0, 0.5, 2000)
    dt = 1e-3
    jump = np.max(np.abs(np.diff(v)))
    peaks = []
    for h in (0.0, 1e-12, 1e-9):
        eff = build([h], dt)
        F = np.array([eff.force(np.zeros((1, 1)), np.full((1, 1), x), 0.0, dt)[0, 0] for x in v])
        assert np.all(np.isfinite(F)) and np.max(np.abs(F)) <= 1.001 * C * (C * h) / dt * 2 * jump
        peaks.append(np.max(np.abs(F)))
    assert peaks[0] == 0.0 and 0 < peaks[1] < 1e-2 and peaks[2] > 100 * peaks[1]
    eff = build([1e-3], 1e-3)  # a soft mount (τ = 1.5 s): the damper force barely builds up (|R| ≪ c·|v|)
    R = []
    for x in v[:50]:
        eff.force(np.zeros((1, 1)), np.full((1, 1), x), 0.0, 1e-3)
        R.append(eff.signals()["R"][0, 0])
    assert np.max(np.abs(R)) < 0.05 * C * np.max(np.abs(v[:50]))


def _road(rp):
    from test_effects import road_fn

    return road_fn(rp)


def test_quarter_car_against_the_reference(monkeypatch):
    """A quarter car riding a sine near its wheel hop (8 Hz), with the damper on a mount of corner 6 Hz,
    against the scipy quarter car with the Maxwell state dR/dt = k_b·(v − R/c) (the Python loop; the compiled
    loop runs the same kernel, tests/test_kernels_effects.py)."""
    from test_effects import compare, run_sim

    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    rp = dict(amplitude=0.004, frequency=8.0, fade_in=0.3)
    kb = 2 * np.pi * 6.0 * C
    vp = {"damping": C}
    ts, zero_ts = run_sim(None, rp, 1.0, vehicle_params=vp, cars=[
        [{"type": "maxwell_damper", "params": {"compliance": h}}] for h in (1 / kb, 0.0)])
    plain_ts, = run_sim([], rp, 1.0, vehicle_params=vp)
    ref = QuarterCarRef(road=_road(rp), damping=0.0, extra_states=[ExtraState(
        n=1, y0=[0.0], deriv=lambda y, s, v, t: kb * (v - y[0] / C), force=lambda y, s, v, t: -y[0])])
    out = ref.simulate(ts.t.values)
    err = compare(ts, out, channels=("travel", "body_acc", "wheel_acc"))
    # measured 0.04-0.06 % at the 0.5 ms step; with the rate at the step's start instead of its middle 0.9-1.7 %
    assert max(err.values()) < 0.005, err
    # the baseline: the plain damper's car is far from the Maxwell reference
    base = compare(plain_ts, out, channels=("travel", "body_acc", "wheel_acc"))
    assert min(base.values()) > 0.2, base  # measured 44-71 %
    # compliance 0 is the plain car, bit for bit
    for col in ("body_z", "travel", "wheel_acc"):
        np.testing.assert_array_equal(zero_ts[col].to_numpy(), plain_ts[col].to_numpy())
    # the logged state: R after the step, logged at the step's start (1.3 % at 8 Hz: a phase of ω·dt/2)
    assert nrmse(ts["effect.maxwell_damper.R.0"].to_numpy(), out["extra"][0]) < 0.03
