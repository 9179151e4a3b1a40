"""Per-call cost of the compiled kernel of ``thesis_mrac_continuous`` (the adaptive controller of the issue-7
speed benchmark), the generic header-driven kernel it replaced against the current specialised one, side by
side from one run.

Both kernels are called 100000 times for one car from an njit loop, on the readings of a 1 s Python-loop run
of the issue-7 benchmark's closed loop (benchmarks/bench_speed.py: quarter car, 1 ms control) replayed
cyclically (open loop: the kernels' commands do not feed back), from the same initial p/st rows; best of 5
(CPU time, the machine is shared).  The two kernels must end in the same state (Θ, b0, signals and filter
states bit for bit, and the same sum of the commands): they do the same floating-point operations.

The old kernel is kept here verbatim (``_old_kernel``, as in controllers/thesis_mrac_continuous.py before the
specialisation) with the generic helpers of controllers/thesis_common.py.

Run:  python benchmarks/bench_mrac_kernel.py
"""
from __future__ import annotations

import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from suspension_sim.controllers.thesis_common import ZOH_HEADER, k_dot, zoh_update, zoh_y, zoh_yu
from suspension_sim.controllers.thesis_mrac_continuous import (
    _FILTERS,
    _LAY,
    _PG,
    _PS,
    _ST_B0,
    _ST_E,
    _ST_F,
    _ST_P1PHI,
    _ST_PHI,
    _ST_RA,
    _ST_RT,
    _ST_RX,
    _ST_TH,
    _ST_U,
    _SIZES,
)

N_CALLS = 100_000
REPEATS = 5

# ---- the generic kernel before the specialisation (verbatim) ------------------------------------------------
_HEF, _HP, _HSP, _HP2, _HSP2, _HP1, _HREF = (ZOH_HEADER * i for i in range(len(_FILTERS)))


@numba.njit
def _den3(st, p):
    acc = 0.0
    for j in range(5):
        acc += st[_ST_PHI + j] * p[_PG + j] * st[_ST_PHI + j]
    return acc


@numba.njit
def _old_kernel(t, y, p, st, u):
    x = y[int(p[_PS])]
    xd = y[int(p[_PS + 1])]
    w = y[int(p[_PS + 2])]
    wd = y[int(p[_PS + 3])]
    h = p[_PS + 4]
    k_v = p[_PS + 5]
    alpha = p[_PS + 6]
    # regressor φ and P1·φ (as step: filter outputs before this step's update)
    st[_ST_PHI] = zoh_y(p, st, _HP, 0, 0)
    st[_ST_PHI + 1] = zoh_y(p, st, _HSP, 0, 0)
    st[_ST_PHI + 2] = zoh_y(p, st, _HP, 1, 0)
    st[_ST_PHI + 3] = -zoh_y(p, st, _HSP, 1, 0)
    st[_ST_PHI + 4] = -zoh_y(p, st, _HP, 2, 0)
    st[_ST_PHI + 5] = zoh_y(p, st, _HP, 3, 0)
    st[_ST_U + 1] = x
    st[_ST_U + 2] = w
    st[_ST_U + 3] = 1.0
    st[_ST_P1PHI] = zoh_y(p, st, _HP2, 0, 0)
    st[_ST_P1PHI + 1] = zoh_yu(p, st, _HSP2, 0, 0, st, _ST_U + 1)
    st[_ST_P1PHI + 2] = zoh_y(p, st, _HP2, 1, 0)
    st[_ST_P1PHI + 3] = -zoh_yu(p, st, _HSP2, 1, 0, st, _ST_U + 2)
    st[_ST_P1PHI + 4] = -zoh_y(p, st, _HP2, 2, 0)
    st[_ST_P1PHI + 5] = zoh_y(p, st, _HP2, 3, 0)
    xr0 = zoh_y(p, st, _HREF, 0, 0)
    xr1 = zoh_y(p, st, _HREF, 0, 1)
    e = x - xr0
    st[_ST_E] = e
    ef = zoh_yu(p, st, _HEF, 0, 0, st, _ST_E)
    ed = xd - xr1
    FP1 = zoh_y(p, st, _HP1, 0, 0)
    b0 = st[_ST_B0]
    eta = -(FP1 + k_dot(st, _ST_PHI, st, _ST_TH, 6))
    eps = ef + b0 * eta + k_v * ed
    # adaptation
    den = alpha + _den3(st, p)
    r = eps / den
    for j in range(5):
        st[_ST_TH + j] += h * p[_PG + j] * st[_ST_PHI + j] * r
    if p[_PS + 8] != 0.0:
        pd = st[_ST_PHI + 5]
        st[_ST_TH + 5] += h * p[_PS + 7] * pd * eps / (alpha + pd * pd)
    if p[_PS + 9] > 0.0:
        epsh = ef + b0 * eta
        b = b0 - h * p[_PS + 9] * eta * epsh / (1e-12 + eta * eta)
        st[_ST_B0] = min(max(b, p[_PS + 10]), p[_PS + 11])
    F = -k_dot(st, _ST_TH, st, _ST_P1PHI, 6)
    u[0] = F - p[_PS + 13] * wd - p[_PS + 12] * w
    # advance the filters with this step's inputs
    st[_ST_U] = F
    for c in range(4):
        zoh_update(p, st, _HP, c, st, _ST_U + c)
        zoh_update(p, st, _HP2, c, st, _ST_U + c)
    for c in range(2):
        zoh_update(p, st, _HSP, c, st, _ST_U + 1 + c)
        zoh_update(p, st, _HSP2, c, st, _ST_U + 1 + c)
    zoh_update(p, st, _HP1, 0, st, _ST_U)
    zoh_update(p, st, _HREF, 0, st, _ST_U + 2)
    zoh_update(p, st, _HEF, 0, st, _ST_E)
    st[_ST_F] = F
    st[_ST_RX] = xr0
    st[_ST_RA] = -p[_PS + 14] * xr1 - p[_PS + 15] * (xr0 - w)
    st[_ST_RT] = xr0 - w


# ---- the timing loop -----------------------------------------------------------------------------------------
def make_loop(kernel):
    @numba.njit
    def loop(ys, p, st, u, n):
        acc = 0.0
        m = ys.shape[0]
        for k in range(n):
            kernel(k * 0.001, ys[k % m], p, st, u)
            acc += u[0]
        return acc

    return loop


def readings(duration=1.0):
    """(n_steps, 4) readings of the issue-7 benchmark's closed loop (Python loop) and its controller."""
    from bench_speed import scenario_raw

    from suspension_sim.config import parse_scenario
    from suspension_sim.simulation import Simulation

    os.environ["SUSPENSION_SIM_COMPILED"] = "0"
    try:
        sim = Simulation([parse_scenario(scenario_raw(duration=duration))])
        ctrl = sim.controller
        names = list(ctrl.ctx.sensors)
        rows = []
        y = sim.start()
        while y is not None:
            rows.append(np.concatenate([np.asarray(y[nm], dtype=float).reshape(-1) for nm in names]))
            y = sim.control_step(np.asarray(ctrl.step(sim.t, y), dtype=float).reshape(1, -1))
    finally:
        os.environ.pop("SUSPENSION_SIM_COMPILED")
    return np.ascontiguousarray(rows), ctrl


def time_kernel(kernel, ys, p0, st0):
    loop = make_loop(kernel)
    u = np.zeros(1)
    loop(ys, p0.copy(), st0.copy(), u, 10)  # compile
    best, st_end, acc = float("inf"), None, None
    for _ in range(REPEATS):
        p, st = p0.copy(), st0.copy()
        c = time.process_time()
        acc = loop(ys, p, st, u, N_CALLS)
        best = min(best, time.process_time() - c)
        st_end = st
    return best / N_CALLS, st_end, acc


def main():
    from suspension_sim.controllers.thesis_mrac_continuous import MRACContinuous

    ys, ctrl = readings()
    ctrl.reset()
    p, st = ctrl.kernel_data()
    p0, st0 = np.ascontiguousarray(p[0]), np.ascontiguousarray(st[0])
    res = {}
    for name, kern in (("old (generic helpers)", _old_kernel), ("new (specialised)", MRACContinuous.kernel)):
        res[name] = time_kernel(kern, ys, p0, st0)
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover
        load = float("nan")
    print(f"thesis_mrac_continuous kernel, one car, {N_CALLS} calls from an njit loop, best of {REPEATS} "
          f"(CPU time; load average {load:.2f})")
    (n_old, (t_old, st_old, a_old)), (n_new, (t_new, st_new, a_new)) = res.items()
    print(f"  {n_old:<24s} {t_old * 1e6:8.3f} µs/call")
    print(f"  {n_new:<24s} {t_new * 1e6:8.3f} µs/call")
    print(f"  speed-up                 {t_old / t_new:8.2f} ×")
    # Θ, b0, F and the signals, and the filter states (not the scratch columns, which the new kernel leaves)
    cols = list(range(_ST_PHI))
    for nm, (_, so) in _LAY.items():
        ns, _, _, copies = _SIZES[nm]
        cols += range(so, so + copies * ns)
    same = np.array_equal(st_old[cols], st_new[cols]) and a_old == a_new
    print(f"  final states and command sums bit-identical: {same}; finite: {bool(np.all(np.isfinite(st_new)))}")


if __name__ == "__main__":
    main()
