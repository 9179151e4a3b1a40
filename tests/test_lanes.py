"""Four cars' controller kernel in one call (suspension_sim.compiled.lanes): the same numbers as car by car."""
from __future__ import annotations

import numba
import numpy as np
import pytest

from suspension_sim.compiled import loop as cloop
from suspension_sim.compiled.lanes import block4, block_rows, interleave_blocks, lanes4
from suspension_sim.compiled.views import row
from suspension_sim.config import parse_scenario
from suspension_sim.controllers.thesis_mrac_continuous import MRACContinuous, _kernel
from suspension_sim.simulation import Simulation

CTRL = {"type": "thesis_mrac_continuous",
        "params": {"mass": 290.0, "stiffness": 16812.0, "damping": 1000.0, "ref_mass": 290.0,
                   "ref_stiffness": 16812.0, "ref_damping": 6000.0}}


def _raw(i, duration=0.3):
    ctrl = CTRL
    return {
        "name": f"car{i}",
        "vehicle": {"model": "quarter_car", "effects": [{"type": "quadratic_damping", "params": {"c_v": 300.0}},
                                                        {"type": "bump_stop", "params": {"gap": 0.03,
                                                                                         "stiffness": 40000.0}}]},
        "road": {"type": "sine", "params": {"amplitude": 0.01 + 0.002 * i, "frequency": 0.8 + 0.1 * i}, "speed": 20.0},
        "sensors": [{"type": s} for s in ("body_pos", "body_vel", "road", "road_vel")],
        "actuator": {"type": "ideal"},
        "controller": ctrl,
        "sim": {"duration": duration, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001, "seed": i},
    }


@numba.njit
def _steps_scalar(ys, p, st, u, k):  # pragma: no cover - compiled
    for j in range(k):
        for c in range(4):
            _kernel(0.0, ys[j, c], p, row(st, c), row(u, c))


@numba.njit
def _steps_lanes(ys, p, stb, u, k):  # pragma: no cover - compiled
    for j in range(k):
        y = ys[j]
        _kernel(0.0, lanes4(row(y, 0), row(y, 1), row(y, 2), row(y, 3)), p, block4(stb),
                lanes4(row(u, 0), row(u, 1), row(u, 2), row(u, 3)))


def test_mrac_kernel_four_lanes_equal_four_scalar_calls():
    """The MRAC's kernel run for four cars in one call (readings and states differing per car, the states
    lane-interleaved) ends in the same states and commands, bit for bit, as four scalar calls per step; the four
    cars do differ (a lane mix-up or a broadcast would show)."""
    sim = Simulation([parse_scenario(_raw(i)) for i in range(4)])
    ctrl = sim.controller
    assert isinstance(ctrl, MRACContinuous) and MRACContinuous.kernel_lanes
    p, st = ctrl.kernel_data()
    rng = np.random.default_rng(5)
    st = np.ascontiguousarray(st * (1.0 + 1e-3 * rng.standard_normal(st.shape)))
    ys = np.ascontiguousarray(rng.normal(0.0, 0.02, (300, 4, 4)))
    p0 = np.ascontiguousarray(p[0])
    st_s, u_s = st.copy(), np.zeros((4, 1))
    _steps_scalar(ys, p0, st_s, u_s, 300)
    stb, u_l = np.ascontiguousarray(st.T), np.zeros((4, 1))
    _steps_lanes(ys, p0, stb, u_l, 300)
    assert np.ascontiguousarray(stb.T).tobytes() == st_s.tobytes()
    assert u_l.tobytes() == u_s.tobytes()
    assert len(set(u_s[:, 0].tolist())) == 4 and len({r.tobytes() for r in st_s}) == 4


def test_lane_division_by_zero_raises_like_the_scalar_kernel():
    from suspension_sim.compiled.lanes import lane, pack4

    @numba.njit
    def div(a, b):
        v = pack4(a, a, a, a) / pack4(1.0, b, 2.0, 3.0)
        return lane(v, 0), lane(v, 1), lane(v, 2), lane(v, 3)

    with pytest.raises(ZeroDivisionError):
        div(1.0, 0.0)
    with pytest.raises(ZeroDivisionError):
        numba.njit(lambda a, b: a / b)(1.0, 0.0)
    assert div(1.0, 4.0) == (1.0, 0.25, 0.5, 1.0 / 3.0)


def test_interleaved_blocks_round_trip():
    """A lane block's four rows interleaved in place and back; rows of a block with two parameter rows, and the
    cars past the last full block, stay as they are."""
    n, k = 11, 5
    a = np.arange(n * k, dtype=float).reshape(n, k)
    c_pi = np.zeros(n, np.int64)
    c_pi[5] = 1  # block 1 (cars 4..7) mixes two parameter rows: not a lane block
    b = a.copy()
    interleave_blocks(b, c_pi, n, True)
    assert np.array_equal(b[0:4].ravel(), a[0:4].T.ravel())  # lane-interleaved: entry [j, c] is car c's st[j]
    assert np.array_equal(b[4:], a[4:])

    @numba.njit
    def view(x, i):
        return block_rows(x, i).copy()

    assert np.array_equal(view(b, 0), a[0:4].T)
    interleave_blocks(b, c_pi, n, False)
    assert b.tobytes() == a.tobytes()


def test_loop_with_lane_blocks_equals_the_python_loop(monkeypatch):
    """An ensemble of 11 MRAC cars, every channel logged (the controller's signals too): two lane blocks, one block
    whose cars read two parameter rows (car 5 given a row of its own, with the same numbers: the thesis controllers
    take one parameter set per ensemble) and three cars past the last full block run car by car; the compiled loop's
    logs, metrics and final controller signals equal the Python loop's, which calls the scalar kernel car by car."""
    scs = [parse_scenario(_raw(i)) for i in range(11)]
    used = []
    orig, orig_rows = cloop.load_module, cloop._shared_rows

    def spy(*a, **kw):
        used.append(a[2])
        return orig(*a, **kw)

    def own_row_for_car5(a):
        rows, idx = orig_rows(a)
        if len(idx) > 5:
            rows, idx = np.concatenate([rows, rows[idx[5]:idx[5] + 1]]), idx.copy()
            idx[5] = len(rows) - 1
        return rows, idx

    monkeypatch.setattr(cloop, "load_module", spy)
    monkeypatch.setattr(cloop, "_shared_rows", own_row_for_car5)
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "1")
    sim_c = Simulation(scs)
    rc = sim_c.run()
    assert sim_c.loop == "full" and used and used[-1][2] is True  # the lanes ran
    monkeypatch.setenv("SUSPENSION_SIM_COMPILED", "0")
    sim_p = Simulation(scs)
    rp = sim_p.run()
    assert any(c.startswith("ctrl.") for c in rc[0].ts.columns)
    for a, b in zip(rp, rc):
        assert list(a.ts.columns) == list(b.ts.columns)
        for col in a.ts.columns:
            assert a.ts[col].to_numpy().tobytes() == b.ts[col].to_numpy().tobytes(), col
        assert a.metrics == b.metrics
    sc, sp = sim_c.controller.signals(), sim_p.controller.signals()
    assert sc.keys() == sp.keys()
    for k in sc:
        assert np.asarray(sc[k]).tobytes() == np.asarray(sp[k]).tobytes(), k
