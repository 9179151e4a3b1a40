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


def relative_errors(act, cmd, s, v, dt=DT):
    """Like check_actuator, but per quantity: {name: max |kernel − Python| / max |Python|} for the force and
    every kernel state (for kernels that call exp/tanh, which numba and numpy may round differently)."""
    py = copy.deepcopy(act)
    py.reset()
    kn = copy.deepcopy(act)
    kn.reset()
    p, st = kn.kernel_data()
    idx = kn.kernel_states()
    diff, scale = {}, {}

    def acc(name, ref, got):
        ref = np.broadcast_to(np.asarray(ref, dtype=float), got.shape)
        diff[name] = max(diff.get(name, 0.0), float(np.max(np.abs(ref - got))))
        scale[name] = max(scale.get(name, 0.0), float(np.max(np.abs(ref))))

    for k, (u, sk, vk) in enumerate(zip(cmd, s, v)):
        t = k * dt
        f_py = np.array(py.force(u, sk, vk, t), dtype=float)
        py.advance(u, sk, vk, t, dt)
        f_kn = np.empty(u.shape)
        for i in range(u.shape[0]):
            for c in range(u.shape[1]):
                f_kn[i, c] = kn.kernel_force(u[i, c], sk[i, c], vk[i, c], t, dt, p[i, c], st[i, c])
                kn.kernel_advance(u[i, c], sk[i, c], vk[i, c], t, dt, p[i, c], st[i, c])
        acc("force()", f_py, f_kn)
        sp = py.states()
        for name, j in idx.items():
            acc(name, sp[name], st[:, :, j])
    return {name: diff[name] / scale[name] if scale[name] > 0 else diff[name] for name in diff}


# ---------------------------------------------------------------------------------------------------------
# hydraulic: spool lag with end stops, trapezoidal pressure sub-steps (valve both ways, |P_L| beyond P_s),
# optional tanh seal friction
from suspension_sim.actuators.hydraulic import HydraulicActuator  # noqa: E402

HYD_CASES = {
    "single": ([dict(spool_time_constant=0.003)], 1),
    "ensemble": ([dict(spool_time_constant=0.003, spool_limit=0.004, initial_pressure=1e6),
                  dict(spool_limit=None, beta=3.0, area=4e-4, max_substep=1e-4),
                  dict(spool_time_constant=0.01, spool_limit=0.006, supply_pressure=2e7, gamma=1e9)], 4),
    "friction": ([dict(spool_time_constant=0.003, friction_max=250.0),
                  dict(friction_max=0.0, friction_velocity=0.02, spool_limit=0.005),
                  dict(spool_time_constant=0.005, friction_max=100.0, friction_velocity=0.005)], 2),
}


def hydraulic_inputs(shape, n_steps=600, dt=DT, seed=2):
    """Spool commands: 0 for the first steps (closed valve, x_v = 0 exactly), then held random levels up to
    ±2.5 cm (beyond the end stops, both ways); travel rate: a smooth random signal with bursts up to
    ±0.6 m/s (which drive |P_L| beyond P_s against the closed or opposing valve); travel = its integral."""
    rng = np.random.default_rng(seed)
    cmd = held(rng, n_steps, shape, -0.025, 0.025, hold=40)
    cmd[:20] = 0.0
    v = np.cumsum(rng.normal(0, 0.02, (n_steps,) + shape), axis=0)
    v[100:130] += 0.6
    v[300:330] -= 0.6
    s = np.concatenate([np.zeros((1,) + shape), np.cumsum(v * dt, axis=0)[:-1]])
    return cmd, s, v


def check_hydraulic_branches(act, cmd, s, v, dt=DT):
    _, st = run_python(act, cmd, s, v, dt)
    P, xv = st["load_pressure"], st["spool_position"]
    Ps = np.broadcast_to(act.p.supply_pressure, xv.shape[1:])
    assert np.all(xv[0] == 0.0)  # the closed-valve branch (sgn x_v = 0)
    assert np.all(np.max(xv, axis=0) > 0) and np.all(np.min(xv, axis=0) < 0)  # valve opened both ways
    assert np.all(np.max(np.abs(P), axis=0) > 0.5 * Ps)  # pressure builds up
    assert np.any(np.sign(xv) * P > Ps)  # w3 with P_s − sgn(x_v)·P_L < 0
    lim = act.xlim
    hit = np.isfinite(lim)
    assert np.any(hit)
    assert np.all((np.max(np.abs(xv), axis=0) == lim)[hit])  # end stops reached


@pytest.mark.parametrize("case", ["single", "ensemble"])
def test_hydraulic_kernel_is_exact(case):
    """Without friction the kernels are bit-identical: the spool's exp factors at the physics step are
    numpy's own values, precomputed in kernel_data; the rest is + − × ÷ and sqrt (correctly rounded)."""
    params, nc = HYD_CASES[case]
    act = build(HydraulicActuator, params, nc)
    kernel_layout_ok(act)
    cmd, s, v = hydraulic_inputs((len(params), nc))
    check_hydraulic_branches(act, cmd, s, v)
    assert check_actuator(act, cmd, s, v) == 0.0


def test_hydraulic_kernel_friction_and_other_step():
    """tanh (friction) and exp (spool, when advance gets a dt other than the physics step) are numba's libm
    against numpy's SIMD versions: within 1e-12 relative; everything without them stays exact."""
    params, nc = HYD_CASES["friction"]
    act = build(HydraulicActuator, params, nc)
    cmd, s, v = hydraulic_inputs((len(params), nc), n_steps=400)
    check_hydraulic_branches(act, cmd, s, v)
    rel = relative_errors(act, cmd, s, v)
    assert rel["load_pressure"] == 0.0 and rel["spool_position"] == 0.0 and rel["hydraulic_force"] == 0.0
    assert rel["friction_force"] <= 1e-12 and rel["force"] <= 1e-12 and rel["force()"] <= 1e-12
    F, _ = run_python(act, cmd, s, v)
    assert np.max(np.abs(F)) > 0
    # advance with dt = half the context's physics step: exp(−s/τ) from math.exp, sub-step count recomputed
    params, nc = HYD_CASES["ensemble"]
    act = build(HydraulicActuator, params, nc)
    cmd, s, v = hydraulic_inputs((len(params), nc), n_steps=400, dt=DT / 2)
    rel = relative_errors(act, cmd, s, v, dt=DT / 2)
    assert max(rel.values()) <= 1e-12, rel


# ---------------------------------------------------------------------------------------------------------
# electromagnetic: force law p(x)·i², current references with the i_max limit, PI current loops with voltage
# saturation, anti-windup and the i >= 0 clamp
from suspension_sim.actuators.electromagnetic import ElectromagneticActuator  # noqa: E402

EM_CASES = {
    "single": ([{}], 1),
    "ensemble": ([dict(i_max=60.0, x_max=0.12, substeps=1),  # x_max past the root of p(x): the 1e-6 floor
                  dict(u_max=24.0, bandwidth=60.0, x0=0.04, substeps=3, resistance=0.3, inductance=0.004),
                  dict(i_max=150.0, x_min=0.01, x_max=0.09, bandwidth=150.0)], 4),
    "explicit_gains_pull_only": ([dict(Ti=0.002, Ki=0.5, push_pull=False),
                                  dict(Ti=0.004, Ki=1.5, push_pull=False, i_max=80.0),
                                  dict(Ti=0.001, Ki=0.0, push_pull=False, u_max=30.0)], 2),
}


def em_inputs(shape, n_steps=800, seed=3):
    """Force demands held over 10 control steps, up to ±3000 N (beyond i_max at x0, both signs, so each unit
    is driven up and then freewheels to 0); travel up to ±8 cm (cores clipped at both stroke ends)."""
    rng = np.random.default_rng(seed)
    cmd = held(rng, n_steps, shape, -3000.0, 3000.0, hold=20)
    k = np.arange(n_steps)[:, None, None]
    s = 0.08 * np.sin(2 * np.pi * k / 500.0 + rng.uniform(0, 6, shape))
    v = 0.08 * 2 * np.pi / (500.0 * DT) * np.cos(2 * np.pi * k / 500.0 + rng.uniform(0, 6, shape))
    return cmd, s, v


@pytest.mark.parametrize("case", list(EM_CASES))
def test_electromagnetic_kernel_is_exact(case):
    params, nc = EM_CASES[case]
    act = build(ElectromagneticActuator, params, nc)
    kernel_layout_ok(act)
    cmd, s, v = em_inputs((len(params), nc))
    assert check_actuator(act, cmd, s, v) == 0.0
    # the inputs reach every branch: reference limit, voltage saturation both ways, i >= 0 clamp, stroke ends
    _, st = run_python(act, cmd, s, v)
    i_max = np.broadcast_to(act.p.i_max, st["current_ref_pull"].shape[1:])
    umax = np.broadcast_to(act.p.u_max, st["voltage_pull"].shape[1:])
    units = ["pull"] if not act.p.push_pull else ["push", "pull"]
    for unit in units:
        assert np.all(np.max(st[f"current_ref_{unit}"], axis=0) == i_max)
        assert np.any(np.max(st[f"voltage_{unit}"], axis=0) == umax)
        assert np.any(np.min(st[f"voltage_{unit}"], axis=0) == -umax)
        assert np.all(np.max(st[f"current_{unit}"], axis=0) > 0)
    # the i >= 0 clamp: a current that has been driven up comes back to exactly 0 (not with the default
    # critically damped loop of the single car, whose current decays to 0 without undershoot)
    assert case == "single" or any(np.any((st[f"current_{u}"] == 0.0) & (np.maximum.accumulate(st[f"current_{u}"], axis=0) > 0))
               for u in units)
    if not act.p.push_pull:
        assert np.all(st["current_push"] == 0.0)
    x_push = act.p.x0 - s
    assert np.any(x_push < act.p.x_min) and np.any(x_push > act.p.x_max)
