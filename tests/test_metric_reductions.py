"""The metrics' compiled reductions (one pass per car row: ``Reductions.rms_peak``, the actuator power's sums,
trapezoid and peak, the ISO 2631 statistics) give numpy's and scipy's numbers bit for bit: the numpy forms they
replaced are written out here as the reference, on rows of many lengths (numpy's pairwise blocks of 8 and 128),
fed in one chunk and in several, with zeros of both signs, NaN and infinities (which must propagate alike; the
sign of a NaN is not compared)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import integrate

from suspension_sim.metrics import iso2631
from suspension_sim.metrics.actuator_power import ActuatorPower
from suspension_sim.metrics.base import EnsembleView, Reductions

LENGTHS = [1, 2, 7, 8, 9, 127, 128, 129, 1000, 2001]


def _same(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return np.array_equal(a, b, equal_nan=True) and np.array_equal(np.signbit(a[~np.isnan(a)]),
                                                                    np.signbit(b[~np.isnan(b)]))


def _data(rng, rows, n, specials=True):
    x = rng.standard_normal((rows, n)) * 10 ** rng.uniform(-3, 3, (rows, n))
    x[rng.random((rows, n)) < 0.05] = 0.0
    x[rng.random((rows, n)) < 0.05] = -0.0
    if specials and n > 6:
        x[1, 3], x[2, 5], x[3, 6] = np.nan, np.inf, -np.inf
    return x


def _splits(n):
    return [[n], [n // 2, n - n // 2], [0, n], [1, n - 1] if n > 1 else [n]]


@pytest.mark.parametrize("n", LENGTHS)
def test_rms_peak_is_numpys(n):
    x = _data(np.random.default_rng(n), 6, n)
    r = Reductions(6)
    r.rms_peak("k", x)
    assert _same(r.v["k.ss"], np.sum(x * x, axis=1)) and _same(r.v["k.pk"], np.max(np.abs(x), axis=1))
    assert np.isnan(r.v["k.pk"][1]) == (n > 6) and not np.isnan(r.v["k.pk"][0])


@pytest.mark.parametrize("n", LENGTHS)
def test_actuator_power_is_the_numpy_law(n):
    rng = np.random.default_rng(100 + n)
    F, V = _data(rng, 5, n), _data(rng, 5, n, specials=False)
    t = np.arange(n) * 1e-3
    for splits in _splits(n):
        def chunks():
            j = 0
            for L in splits:
                yield EnsembleView(channels={"actuator_force": F[:, j:j + L].copy(), "travel_rate": V[:, j:j + L].copy()},
                                   t=t[j:j + L], suffixes=[""], static_tire_force={}, infos=[{}] * 5)
                j += L
        acc = ActuatorPower.stream(EnsembleView(channels={}, t=t, suffixes=[""], static_tire_force={}, infos=[{}] * 5))
        ref = Reductions(5)
        for c in chunks():
            acc.update(c)
            ref.start(c)
            with np.errstate(invalid="ignore"):
                p = c.col("actuator_force") * c.col("travel_rate")
            a = np.abs(p)
            ref.sum("abs", a)
            ref.sum("pos", np.clip(p, 0.0, None))
            ref.trapezoid("e", a, c.t)
            ref.max("pk", a)
        got = acc.result()
        exp = {"actuator_power_mean_abs": ref.mean("abs"), "actuator_power_mean_pos": ref.mean("pos"),
               "actuator_energy": ref.get("e", 0.0), "actuator_power_peak": ref.get("pk")}
        for k, v in exp.items():
            assert _same(got[k], v), (splits, k)


class _NumpyStats(iso2631.WeightedStats):
    def _reduce(self, aw, aw2=None):  # the numpy form the compiled pass replaced (two pieces: joined)
        if aw2 is not None:
            aw = np.concatenate([aw, aw2], axis=1)
        sq = aw * aw
        self.ss = self.ss + np.sum(sq, axis=1)
        m = np.max(np.abs(aw), axis=1)
        self.pk = m if self.n_aw == 0 else np.maximum(self.pk, m)
        a4 = sq * sq
        if self.prev4 is not None:
            a4 = np.concatenate([self.prev4, a4], axis=1)
        if a4.shape[1] > 1:
            self.vdv4 = self.vdv4 + integrate.trapezoid(a4, dx=1.0 / self.fs, axis=-1)
        self.prev4 = a4[:, -1:]
        full = np.concatenate([self.c_tail, np.cumsum(np.concatenate([self.c_tail[:, -1:], sq], axis=1),
                                                      axis=1)[:, 1:]], axis=1)
        k0 = self.n_aw + 1
        g0 = k0 - self.c_tail.shape[1]
        a, b = max(self.win, k0) - g0, k0 + aw.shape[1] - g0
        if self.win >= 1 and b > a:
            ms = (full[:, a:b] - full[:, a - self.win:b - self.win]) / self.win
            self.best = np.maximum(self.best, np.max(ms, axis=1))
        self.n_aw += aw.shape[1]
        self.c_tail = full[:, -(self.win + 1):] if self.win >= 1 else full[:, -1:]


@pytest.mark.parametrize("n", [1, 2, 9, 999, 1000, 1001, 2600])
@pytest.mark.parametrize("fs", [1000.0, 0.5])
def test_iso2631_statistics_are_the_numpy_form(n, fs):
    aw = _data(np.random.default_rng(n), 4, n)
    for splits in _splits(n):
        outs = []
        for cls in (iso2631.WeightedStats, _NumpyStats):
            st = cls(4, fs)
            j = 0
            for q, L in enumerate(splits):
                with np.errstate(invalid="ignore"):
                    st.take(aw[:, j:j + L], last=q == len(splits) - 1)
                j += L
            with np.errstate(invalid="ignore"):
                outs.append(st.result())
        for k in outs[1]:
            assert _same(outs[0][k], outs[1][k]), (splits, k)
        assert np.isfinite(outs[0]["rms"][0])
