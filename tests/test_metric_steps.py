"""The metrics' step-major kernels (the compiled loop's log reduced over its steps with the cars side by side)
give the numbers of the car-by-car kernels bit for bit: the same terms and, per car, numpy's tree of pairwise
additions (``numpy_order.pairwise_plan``), on random inputs with NaN, ±inf, ±0 and every leaf shape."""
import numba
import numpy as np
import pytest

from suspension_sim.compiled.numpy_order import leaf_sums, pairwise_plan, push_leaf
from suspension_sim.metrics.actuator_power import _power, _power_steps
from suspension_sim.metrics.base import EnsembleView, Reductions, colsq_maxabs, sumsq_maxabs

SIZES = [1, 2, 7, 8, 9, 15, 16, 17, 127, 128, 129, 135, 136, 255, 256, 257, 1000, 2001, 4099]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.tobytes() == b.tobytes()  # bit for bit (NaN payloads and signed zeros too)


def _data(rng, n, m, special=True):
    x = rng.normal(size=(n, m)) * 10.0 ** rng.uniform(-8, 8, size=(n, 1))
    if special and n > 3:
        x[rng.integers(0, n), 0] = np.nan
        x[rng.integers(0, n), 1 % m] = np.inf
        x[rng.integers(0, n), 2 % m] = -np.inf
        x[rng.integers(0, n, 3), 3 % m] = -0.0
    return x


@numba.njit(cache=False)
def _colsums(x):
    n, m = x.shape
    lo, ln, merges = pairwise_plan(n)
    T, acc, res, stack = np.empty((128, m)), np.empty((8, m)), np.empty(m), np.empty((64, m))
    top = 0
    for li in range(lo.shape[0]):
        for i in range(ln[li]):
            for c in range(m):
                T[i, c] = x[lo[li] + i, c]
        leaf_sums(T, ln[li], acc, res)
        top = push_leaf(stack, top, res, merges[li])
    return stack[0].copy()


@pytest.mark.parametrize("n", [0] + SIZES + [12345])
def test_pairwise_plan_is_numpy_sum(n):
    x = _data(np.random.default_rng(n), n, 5, special=False)
    ref = np.array([np.sum(np.ascontiguousarray(x[:, c])) for c in range(5)]) if n else np.full(5, -0.0)
    assert _same(_colsums(x), ref)


@pytest.mark.parametrize("n", SIZES)
def test_colsq_maxabs_equals_rows(n):
    rng = np.random.default_rng(100 + n)
    for special in (False, True):
        x = _data(rng, n, 6, special)
        ss, pk, ss2, pk2 = (np.empty(6) for _ in range(4))
        sumsq_maxabs(np.ascontiguousarray(x.T), ss, pk)
        colsq_maxabs(x, ss2, pk2)
        assert _same(ss, ss2) and _same(pk, pk2)
        if special and n > 3:
            assert np.isnan(ss[0]) and np.isnan(pk[0]) and np.isinf(ss[1])  # the cases were exercised


@pytest.mark.parametrize("n", [0, 1, 2, 3] + SIZES)
@pytest.mark.parametrize("has_prev", [False, True])
def test_power_steps_equals_rows(n, has_prev):
    rng = np.random.default_rng(7 * n + has_prev)
    m = 5
    F, v = _data(rng, n, m, special=n > 20), _data(rng, n, m, special=False)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, n)) + 3.0
    py, pt = rng.normal(size=m), 2.9995
    a, b = np.empty((5, m)), np.empty((5, m))
    _power(np.ascontiguousarray(F.T), np.ascontiguousarray(v.T), t, py, pt, has_prev, a)
    _power_steps(np.ascontiguousarray(F), np.ascontiguousarray(v), t, py, pt, has_prev, b)
    rows = [0, 1, 3, 4] + ([2] if n + has_prev > 1 else [])  # out[2] is read only with an interval
    assert _same(a[rows], b[rows])


def test_held_step_major_channel_same_reductions():
    """Reductions.rms_peak of a step-major channel as EnsembleView.held gives it (no copy) equals the C rows'."""
    rng = np.random.default_rng(5)
    L = _data(rng, 2001, 8 * 3, special=True).reshape(2001, 8, 3)
    g = np.ascontiguousarray(L[:, :, 1])  # a gathered step-major channel
    ens = EnsembleView(channels={"x": g.T}, t=np.arange(2001) * 1e-3, suffixes=[""], static_tire_force={},
                       infos=[{}] * 8)
    assert ens.held("x").base is g or ens.held("x").T.base is g or np.shares_memory(ens.held("x"), g)
    r1, r2 = Reductions(8), Reductions(8)
    r1.rms_peak("k", ens.held("x"))
    r2.rms_peak("k", np.ascontiguousarray(g.T))
    assert _same(r1.v["k.ss"], r2.v["k.ss"]) and _same(r1.v["k.pk"], r2.v["k.pk"])


def test_counts_and_turning_round_equal_numpy():
    """The stop and lift-off counts (one compiled pass, either layout) are numpy's counts; a step-major
    channel turned round for EnsembleView.col is the array numpy's copy gives."""
    from suspension_sim.metrics.base import _rows_of_steps
    from suspension_sim.metrics.suspension_travel import _beyond
    from suspension_sim.metrics.tire_liftoff import _off

    rng = np.random.default_rng(9)
    for n, m in ((1, 1), (70, 3), (2001, 65)):
        x = _data(rng, n, m, special=n > 20)
        lo, hi = rng.uniform(0, 1e3, m), rng.uniform(0, 1e3, m)
        ref = np.count_nonzero((x.T < -lo[:, None]) | (x.T > hi[:, None]), axis=1).astype(float)
        assert _same(_beyond(x, lo, hi), ref) and _same(_beyond(np.ascontiguousarray(x.T).T, lo, hi), ref)
        static = rng.uniform(-100, 4000, m)
        thr = 1e-9 * np.maximum(np.abs(static), 1.0)
        ref = np.count_nonzero(static[:, None] + x.T <= thr[:, None], axis=1).astype(float)
        assert _same(_off(x, static, thr), ref)
        r = np.empty((m, n))
        _rows_of_steps(x, r)
        assert _same(r, np.ascontiguousarray(x.T))
