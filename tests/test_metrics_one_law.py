"""Every built-in metric three ways (one car's log, an ensemble at once, a long run chunk by chunk) against
the straightforward per-car numpy reference in ``tests/legacy_results.py`` (the metrics as first written: one
car, whole arrays, ``np.mean``/``np.max``/``scipy.integrate.trapezoid``, the ISO 2631 weighting in one
``resample_poly`` + ``sosfilt`` pass): same keys in the same order, values within 1e-12 relative, on logs
with several corners, NaN samples, a silent car, a zero static load, sided and symmetric stop gaps, logs
shorter than the MTVV window and logs upsampled for the ISO filter (its state carried across chunks)."""
from __future__ import annotations

import math

import numpy as np
import pytest

import legacy_results as L
from suspension_sim.metrics.base import EnsembleView, RunView
from suspension_sim.registry import METRICS
from suspension_sim.results import Result, compute_metrics, compute_metrics_many

RTOL = 1e-12


def _log(n_cars, n_log, fs, sfx, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n_log) / fs
    ch = {}
    for k in ("body_acc", "pitch", "pitch_acc", "roll"):
        ch[k] = rng.standard_normal((n_cars, n_log)) * rng.uniform(0.1, 10, (n_cars, 1))
    for s in sfx:
        for base, scale in (("travel", 0.01), ("travel_rate", 0.2), ("actuator_force", 300.0),
                            ("tire_force", 2000.0), ("wheel_acc", 10.0)):
            ch[f"{base}{s}"] = scale * rng.standard_normal((n_cars, n_log)).cumsum(axis=1) / math.sqrt(n_log / 50)
    ch["body_acc"][0] = 0.0  # a silent car: crest factor NaN
    ch["actuator_force" + sfx[0]][1] = 0.0  # a passive car
    if n_cars > 2:
        ch["travel" + sfx[-1]][2, n_log // 2] = np.nan  # a NaN sample
    static = [{s: float(v) for s, v in zip(sfx, rng.uniform(1000, 4000, len(sfx)))} for _ in range(n_cars)]
    static[min(1, n_cars - 1)] = {s: 0.0 for s in sfx}  # zero static load: NaN relative RMS
    gaps = [{s: float(rng.uniform(0.005, 0.03)) for s in sfx} for _ in range(n_cars)]
    infos = [{"suffixes": list(sfx), "static_tire_force": static[i], "stop_gap": gaps[i],
              "stop_gap_sides": ({sfx[0]: [0.004, 0.02]} if i % 2 else {})} for i in range(n_cars)]
    return t, ch, infos


def _frame(t, ch, i):
    return L.frame(type("Lg", (), {"t": t, "ch": ch}), i)


def _close(got: dict, ref: dict, what):
    assert list(got) == list(ref), what  # same keys in the same order
    for k, r in ref.items():
        g = float(got[k])
        assert (math.isnan(g) and math.isnan(r)) or abs(g - r) <= RTOL * abs(r), (what, k, g, r)


LOGS = [  # n_cars, n_log, fs, suffixes
    (4, 3000, 1000.0, ("",)),  # upsampled by 2 for the ISO filter
    (3, 2501, 500.0, ("_front", "_rear")),  # upsampled by 4
    (3, 700, 333.0, ("_fl", "_fr", "_rl", "_rr")),  # by 7; shorter than the 1 s MTVV window
    (2, 9000, 2000.0, ("",)),  # no upsampling; longer than numpy's 8192-element buffer
]


@pytest.fixture(scope="module", params=LOGS, ids=lambda p: f"{p[0]}x{p[1]}@{p[2]:g}Hz-{len(p[3])}c")
def log(request):
    n, n_log, fs, sfx = request.param
    t, ch, infos = _log(n, n_log, fs, sfx, seed=n_log)
    refs = [L.metrics_of(_frame(t, ch, i), infos[i]) for i in range(n)]
    assert all("travel_stop_fraction" + sfx[0] in r and "body_acc_wk_mtvv" in r for r in refs)
    return t, ch, infos, list(sfx), refs


def test_one_car_equals_the_reference(log):
    t, ch, infos, sfx, refs = log
    for i, ref in enumerate(refs):
        _close(compute_metrics(Result(None, _frame(t, ch, i), infos[i])), ref, ("DataFrame view", i))
        cols = {"t": t, **{k: a[i] for k, a in ch.items()}}  # views of the ensemble's rows
        run = RunView(ts=None, suffixes=sfx, static_tire_force=infos[i]["static_tire_force"],
                      stop_gap=infos[i]["stop_gap"], info=infos[i], columns=cols)
        got = {}
        for name, fn in METRICS.items():
            if name in L.METRICS:
                got.update({k: float(v) for k, v in fn(run).items()})
        _close(got, ref, ("columns view", i))


def test_ensemble_equals_the_reference_without_going_car_by_car(log):
    t, ch, infos, sfx, refs = log

    def no_view():
        raise AssertionError("a built-in metric fell back to car by car")

    got = compute_metrics_many(t, ch, sfx, infos, [inf["stop_gap"] for inf in infos], [no_view] * len(infos))
    for i, ref in enumerate(refs):
        _close(got[i], ref, ("ensemble", i))


@pytest.mark.parametrize("size", [None, 1000, 997, 7])
def test_streamed_equals_the_reference(log, size):
    t, ch, infos, sfx, refs = log
    n, N = len(infos), len(t)
    size = size or N
    meta = dict(suffixes=sfx, stop_gaps=[inf["stop_gap"] for inf in infos], infos=infos,
                static_tire_force={s: np.array([inf["static_tire_force"][s] for inf in infos]) for s in sfx})
    got = [{} for _ in range(n)]
    bufs = {k: np.empty((n, size)) for k in ch}  # one reused buffer per channel, as the logger's
    for name, fn in METRICS.items():
        if name not in L.METRICS:
            continue
        st = fn.stream(EnsembleView(channels={}, t=t[:0], **meta))
        for a in range(0, N, size):
            rows = min(size, N - a)
            for k, v in ch.items():
                bufs[k][:, :rows] = v[:, a:a + rows]
            st.update(EnsembleView(channels={k: b if rows == size else b[:, :rows] for k, b in bufs.items()},
                                   t=t[a:a + rows], **meta))
            for b in bufs.values():
                b.fill(np.inf)  # the logger writes the next chunk: nothing may be kept from this one
        for k, v in st.result().items():
            for i in range(n):
                got[i][k] = float(np.broadcast_to(v, (n,))[i])
    for i, ref in enumerate(refs):
        _close(got[i], ref, ("streamed", size, i))


def test_one_car_and_the_ensemble_are_the_same_numbers(log):
    """The per-car function and the ensemble version are one accumulator on one chunk: bit for bit equal."""
    t, ch, infos, sfx, refs = log
    ens = compute_metrics_many(t, ch, sfx, infos, [inf["stop_gap"] for inf in infos], [None] * len(infos))
    for i in range(len(infos)):
        one = compute_metrics(Result(None, _frame(t, ch, i), infos[i]))
        assert list(one) == list(ens[i])
        assert all(one[k] == ens[i][k] or (math.isnan(one[k]) and math.isnan(ens[i][k])) for k in one), i
