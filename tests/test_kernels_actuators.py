"""The actuators' compiled kernels (suspension_sim/compiled) against their Python methods, step by step.

Each case drives the Python actuator and its kernels (``kernel_force``/``kernel_advance`` on the arrays of
``kernel_data``) with the same command / travel / travel-rate sequences (``check_actuator``) and asserts that
forces and every kernel state agree exactly (0.0) where the kernel does the same floating-point operations,
or to 1e-12 relative where a transcendental function (exp, tanh, sqrt is exact) is evaluated by numba's libm
instead of numpy's.  Each case also checks, on the Python actuator, that its inputs really reach the branch
it is meant to exercise (saturation, rate limit, end stops, ...), so a kernel cannot pass on a trivial input."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from suspension_sim.actuators.base import ActuatorContext
from suspension_sim.components import stack_params
from suspension_sim.compiled.testing import check_actuator

DT = 5e-4
CONTROL_DT = 1e-3


def build(acls, params: list[dict], nc: int, dt: float = DT, static=None):
    """The actuator as simulation.py builds it: stacked per-car params and an ActuatorContext."""
    n = len(params)
    plist = [acls.Params(**kw) for kw in params]
    static = np.zeros((n, nc)) if static is None else np.broadcast_to(static, (n, nc)).copy()
    return acls(stack_params(plist, nc), ActuatorContext(n, nc, dt, CONTROL_DT, static))


def held(rng, n_steps, shape, lo, hi, hold=2):
    """Commands held over a control step (``hold`` physics steps), uniformly random in [lo, hi]."""
    n_ctl = -(-n_steps // hold)
    u = rng.uniform(lo, hi, size=(n_ctl,) + shape)
    return np.repeat(u, hold, axis=0)[:n_steps]


def run_python(act, cmd, s, v, dt=DT):
    """Forces and states of the Python actuator over the sequences (to check which branches they reach)."""
    a = copy.deepcopy(act)
    a.reset()
    F, states = [], []
    for k, (u, sk, vk) in enumerate(zip(cmd, s, v)):
        F.append(np.array(a.force(u, sk, vk, k * dt), dtype=float))
        a.advance(u, sk, vk, k * dt, dt)
        states.append({name: np.array(x, dtype=float) for name, x in a.states().items()})
    return np.array(F), {name: np.array([st[name] for st in states]) for name in states[0]}


def kernel_layout_ok(act):
    p, st = act.kernel_data()
    shape = (act.ctx.n_cars, act.ctx.n_corners)
    for a in (p, st):
        assert a.dtype == np.float64 and a.flags.c_contiguous and a.shape[:2] == shape
    idx = act.kernel_states()
    assert set(idx) >= set(act.states()) - {"force"}
    assert all(0 <= j < st.shape[2] for j in idx.values())


# ---------------------------------------------------------------------------------------------------------
# ideal: delay -> lag -> rate limit -> saturation
from suspension_sim.actuators.ideal import IdealActuator  # noqa: E402

IDEAL_CASES = {
    "all_single": ([dict(delay=0.004, time_constant=0.01, rate_limit=1e5, max_force=300.0)], 1),
    "all_ensemble": ([dict(delay=0.002, time_constant=0.0, rate_limit=1e5, max_force=300.0),
                      dict(delay=0.0, time_constant=0.005, rate_limit=5e4, max_force=500.0),
                      dict(delay=0.0035, time_constant=0.02, rate_limit=2e4, max_force=200.0)], 4),
    "lag_sat_ensemble": ([dict(time_constant=0.002, max_force=250.0), dict(time_constant=0.0, max_force=400.0),
                          dict(time_constant=0.03, max_force=150.0)], 2),
    "rate_only": ([dict(rate_limit=3e5), dict(rate_limit=1e5), dict(rate_limit=6e5)], 2),
    "delay_only": ([dict(delay=0.0015), dict(delay=0.0)], 4),
    "pass_through": ([{}, {}, {}], 2),
}


@pytest.mark.parametrize("case", list(IDEAL_CASES))
def test_ideal_kernel_is_exact(case):
    params, nc = IDEAL_CASES[case]
    act = build(IdealActuator, params, nc)
    kernel_layout_ok(act)
    rng = np.random.default_rng(1)
    n_steps = 400
    shape = (len(params), nc)
    cmd = held(rng, n_steps, shape, -1000.0, 1000.0)
    cmd[150:250] = np.linspace(-800, 800, 100)[:, None, None]  # a slow ramp between the jumps
    s = rng.normal(0, 0.01, (n_steps,) + shape)
    v = rng.normal(0, 0.1, (n_steps,) + shape)
    assert check_actuator(act, cmd, s, v) == 0.0
    F, _ = run_python(act, cmd, s, v)
    dF = np.abs(np.diff(F, axis=0))
    for i, kw in enumerate(params):  # the inputs reach every non-ideality the car has
        if kw.get("max_force"):
            assert np.max(np.abs(F[:, i])) == kw["max_force"]
        if kw.get("rate_limit"):
            assert np.isclose(np.max(dF[:, i]), kw["rate_limit"] * DT, rtol=1e-9)
        if not any(kw.get(k) for k in ("max_force", "rate_limit", "time_constant")):
            lag = act.n_delay
            np.testing.assert_array_equal(F[lag:, i], cmd[:n_steps - lag, i])  # pure (ensemble-wide) delay
