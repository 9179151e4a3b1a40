"""The ensemble-vectorised results path (``Result.many_from_logger``, ``Result.from_logger``, lazy time series,
ensemble versions of the metrics) against the straightforward per-car path it replaced (a verbatim copy in
``tests/legacy_results.py``: one DataFrame per car, metrics from DataFrame columns): every metric, the info
dict and the DataFrame must be exactly equal (bit for bit, NaN where NaN), but for the vibration dose value:
the metrics now take a_w⁴ as (a_w²)² (60 times faster than pow(a_w, 4)) and its fourth root as two square
roots, an ulp or two from the reference (1e-12 relative allowed on that key against the reference; the
per-car and ensemble values of the package stay the same numbers)."""
from __future__ import annotations

import dataclasses
import math
import os
import pickle

import numpy as np
import pytest

import legacy_results as L
from suspension_sim.config import parse_scenario
from suspension_sim.metrics.base import EnsembleView, RunView
from suspension_sim.registry import METRICS
from suspension_sim.results import Result, _contiguous, compute_metrics, compute_metrics_many
from suspension_sim.simulation import Simulation


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))


#: keys whose arithmetic differs from the reference's by rounding (see the module doc)
NEAR = ("body_acc_vdv",)


def assert_same_metrics(new: dict, ref: dict, near: tuple = ()):
    assert list(new) == list(ref)  # same keys in the same order
    bad = {k: (new[k], ref[k]) for k in ref if not _same(new[k], ref[k])
           and not (k in near and abs(new[k] - ref[k]) <= 1e-12 * abs(ref[k]))}
    assert not bad


def _run(scs):
    sim = Simulation(list(scs))
    grab = {}
    sim.log_hooks.append(lambda logger, j, t: grab.setdefault("logger", logger))
    old = os.environ.get("SUSPENSION_SIM_COMPILED")
    if isinstance(scs, _PythonLoop):
        os.environ["SUSPENSION_SIM_COMPILED"] = "0"
    try:
        res = sim.run()
    finally:
        if isinstance(scs, _PythonLoop):
            os.environ.pop("SUSPENSION_SIM_COMPILED") if old is None else os.environ.update(SUSPENSION_SIM_COMPILED=old)
    if isinstance(scs, _PythonLoop):
        assert getattr(sim, "loop", "python") == "python"
        assert all(a.flags.c_contiguous for a in grab["logger"].ch.values())
    return sim, grab["logger"], res


def _quarter(n=5, duration=1.5, log_dt=0.001):
    rng = np.random.default_rng(11)
    scs = []
    for i in range(n):
        g = float(rng.uniform(0.008, 0.02))
        stop = {"gap": g, "stiffness": 40000.0, "gap_compression": g, "gap_extension": g}
        if i % 2:  # asymmetric stops on every other car
            stop.update(gap_compression=float(rng.uniform(0.006, 0.012)), gap_extension=float(rng.uniform(0.01, 0.03)))
        scs.append(parse_scenario({
            "name": f"q{i}",
            "vehicle": {"model": "quarter_car", "params": {"sprung_mass": float(rng.uniform(250, 330))},
                        "effects": [{"type": "quadratic_damping", "params": {"c_v": float(rng.uniform(100, 400))}},
                                    {"type": "bump_stop", "params": stop}]},
            "road": {"type": "sine", "params": {"amplitude": float(rng.uniform(0.01, 0.04)),
                                                "frequency": float(rng.uniform(0.8, 3.0))}, "speed": 20.0},
            "sensors": [{"type": "corner_body_vel", "noise_std": 0.01}],
            "actuator": {"type": "ideal", "params": {"max_force": float(rng.uniform(300, 3000))}},
            "controller": {"type": "skyhook", "params": {"c_sky": float(rng.uniform(500, 4000))}},
            "sim": {"duration": duration, "dt": 0.0005, "control_dt": 0.001, "log_dt": log_dt, "seed": i}}))
    return scs


def _half(n=3):
    return [parse_scenario({
        "name": f"h{i}", "vehicle": {"model": "half_car"},
        "road": {"type": "iso8608", "params": {"road_class": "D"}, "speed": 15.0 + 3 * i, "seed": i},
        "controller": {"type": "passive"},
        "sim": {"duration": 1.2, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.0005}}) for i in range(n)]


def _full(n=2):
    return [parse_scenario({
        "name": f"f{i}", "vehicle": {"model": "full_car"},
        "road": {"type": "bump", "params": {"preset": "fallah", **({"track": "left"} if i else {})}, "speed": 9.7},
        "controller": {"type": "passive"},
        "sim": {"duration": 1.3, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.002}}) for i in range(n)]


def _sdof(n=2):  # one mass: no wheel, no tire -> the tire and wheel metrics drop out (KeyError path)
    return [parse_scenario({
        "name": f"s{i}", "vehicle": {"model": "sdof"},
        "road": {"type": "sine", "params": {"amplitude": 0.01 * (i + 1), "frequency": 1.5}, "speed": 10.0},
        "controller": {"type": "passive"},
        "sim": {"duration": 0.6, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001}}) for i in range(n)]


class _PythonLoop(list):
    """Scenarios to run with the Python loop (contiguous per-channel logs) instead of the compiled one."""


CASES = {
    "quarter": lambda: _quarter(),
    "quarter_python_loop": lambda: _PythonLoop(_quarter(n=3, duration=1.1)),
    "quarter_500Hz_log": lambda: _quarter(n=3, log_dt=0.002),
    "quarter_short": lambda: _quarter(n=3, duration=0.4),  # shorter than the 1 s MTVV window
    "half": _half,
    "full": _full,
    "sdof": _sdof,
}


@pytest.fixture(scope="module", params=list(CASES))
def run(request):
    return CASES[request.param]()


@pytest.fixture(scope="module")
def ensemble(run):
    return _run(run)


def test_results_equal_the_per_car_reference(ensemble):
    sim, logger, res = ensemble
    assert len(res) == logger.n
    wall = res[0].info["wall_time_s"] * logger.n
    for i, r in enumerate(res):
        ts, info, metrics = L.from_logger(logger, i, sim, wall)
        assert r.__dict__["_ts"] is None  # nothing built yet
        assert_same_metrics(r.metrics, metrics, NEAR)
        assert r.info == info and list(r.info) == list(info)
        assert list(r.ts.columns) == list(ts.columns)
        assert (r.ts.dtypes == ts.dtypes).all()
        assert np.array_equal(r.ts.to_numpy(), ts.to_numpy(), equal_nan=True)
        # and the registry's per-car path on the DataFrame (covers metrics registered by plugins too)
        assert_same_metrics(r.metrics, compute_metrics(Result(scenario=None, timeseries=ts, info=info)))
        assert r.scenario is sim.scenarios[i]
    if sim.scenarios[0].vehicle.model == "sdof":
        assert not any(k.startswith(("tire_", "wheel_")) for k in res[0].metrics)
    assert any(v != 0 for v in res[0].metrics.values())


def test_from_logger_in_any_order_and_many(ensemble):
    sim, logger, res = ensemble
    wall = res[0].info["wall_time_s"] * logger.n
    order = list(range(logger.n))[::-1]
    got = {i: Result.from_logger(logger, i, sim, wall) for i in order}
    again = Result.from_logger(logger, order[0], sim, wall)  # a second round recomputes
    many = Result.many_from_logger(logger, sim, wall)
    for i, r in enumerate(res):
        for other in (got[i], many[i]):
            assert_same_metrics(other.metrics, r.metrics)
            assert other.info == r.info
    assert_same_metrics(again.metrics, res[order[0]].metrics)
    assert "_results_cache" not in logger.__dict__ or order[0] not in logger.__dict__["_results_cache"][1]


def test_lazy_timeseries_behaves_like_a_field():
    sim, logger, res = _run(_quarter(n=2, duration=0.3))
    r = res[1]
    assert [f.name for f in dataclasses.fields(Result)] == ["scenario", "timeseries", "info", "metrics"]
    assert r.__dict__["_ts"] is None
    # a pickled result carries its own DataFrame, not the ensemble's logs
    r2 = pickle.loads(pickle.dumps(r))
    assert r2.__dict__["_src"] is None and r2.ts.equals(logger.frame(1))
    assert r.ts is r.timeseries and r.ts.equals(logger.frame(1))
    df = r.ts.iloc[:10].copy()
    r.timeseries = df
    assert r.ts is df
    # the metrics view of a lazy result reads the log arrays; its DataFrame is built only when asked for
    v = res[0].view()
    assert v.columns is not None and np.array_equal(v.col("travel"), logger.ch["travel"][0])
    assert v.ts.equals(logger.frame(0))
    assert res[0].__dict__["_ts"] is None
    # the cars' DataFrames share their (immutable) column Index; renaming one leaves the other alone
    fresh = Result.many_from_logger(logger, sim, res[0].info["wall_time_s"] * 2)
    a, b = fresh[0].ts, fresh[1].ts
    assert a.columns is b.columns
    a.columns = [f"x{k}" for k in range(a.shape[1])]
    assert list(b.columns) == list(logger.frame(1).columns) and b.equals(logger.frame(1))
    plain = Result(scenario=None, timeseries=df, info={"suffixes": [""]})
    assert plain.ts is df and plain.metrics == {}


def _synthetic(n_cars, n_log, fs, rng, sfx=("",)):
    t = np.arange(n_log) / fs
    ch = {}
    for s in sfx:
        for base in ("travel", "travel_rate", "actuator_force", "tire_force", "wheel_acc"):
            x = rng.standard_normal((n_cars, n_log)).cumsum(axis=1) * 10.0 ** rng.uniform(-3, 3, (n_cars, 1))
            ch[f"{base}{s}"] = x
    for k in ("body_acc", "pitch", "pitch_acc", "roll"):
        ch[k] = rng.standard_normal((n_cars, n_log)) * rng.uniform(0.1, 10, (n_cars, 1))
    ch["body_acc"][0] = 0.0  # a silent car: crest factor NaN
    ch["actuator_force" + sfx[0]][1] = 0.0
    if n_cars > 3:
        ch["travel" + sfx[-1]][3, n_log // 2] = np.nan  # a NaN sample
    return t, ch


@pytest.mark.parametrize("n_log,fs,sfx", [
    (3000, 1000.0, ("",)),
    (20001, 2000.0, ("_front", "_rear")),  # longer than numpy's 8192-element buffer; no upsampling
    (700, 333.0, ("_fl", "_fr", "_rl", "_rr")),  # upsampled by 7; shorter than the MTVV window
    (2, 1000.0, ("",)),
])
def test_ensemble_versions_equal_per_car_metrics(n_log, fs, sfx):
    rng = np.random.default_rng(n_log)
    n = 6
    t, ch = _synthetic(n, n_log, fs, rng, sfx)
    static = [{s: float(v) for s, v in zip(sfx, rng.uniform(-100, 4000, len(sfx)))} for _ in range(n)]
    static[2] = {s: 0.0 for s in sfx}  # zero static load: NaN relative RMS
    gaps = [{s: float(rng.uniform(0.001, 1.0)) for s in sfx} for _ in range(n)]
    infos = [{"suffixes": list(sfx), "static_tire_force": static[i], "stop_gap": gaps[i],
              "stop_gap_sides": ({sfx[0]: [0.5, 2.0]} if i % 2 else {})} for i in range(n)]
    # logged as a compiled loop may: L[:, :, j] views of one (n_cars, n_log, n_channels) buffer, L[:, :, j].T of
    # one (n_log, n_cars, n_channels) buffer (the compiled loop's), one channel transposed ((n_log, n_cars)
    # memory), the rest contiguous
    names = [k for k in ch if k != "body_acc"]
    half = len(names) // 2
    buf = np.empty((n, n_log, half + 1))
    buf_s = np.empty((n_log, n, len(names) - half + 2))  # step-major, gathered in blocks of rows
    buf2 = np.empty((n, n_log, 3))
    for j, k in enumerate(names[:half]):
        buf[:, :, j + 1] = ch[k]
        ch[k] = buf[:, :, j + 1]
    for j, k in enumerate(names[half:]):
        buf_s[:, :, j + 1] = ch[k].T
        ch[k] = buf_s[:, :, j + 1].T
    buf2[:, :, 2] = ch["body_acc"]
    ch["body_acc"] = buf2[:, :, 2]
    ch["travel" + sfx[-1]] = np.ascontiguousarray(ch["travel" + sfx[-1]].T).T
    ch["extra"] = np.ascontiguousarray(ch["pitch"])
    gathered = _contiguous(ch, list(ch))
    # C rows, or (the step-major buffer's channels) the transposes of C-contiguous step-major arrays
    assert all((gathered[k].flags.c_contiguous or gathered[k].T.flags.c_contiguous)
               and np.array_equal(gathered[k], ch[k], equal_nan=True) for k in ch)
    assert not any(gathered[k].flags.c_contiguous for k in names[half:] if k != "travel" + sfx[-1])
    assert gathered["extra"] is ch["extra"]

    def view(i):
        cols = {"t": t, **{k: np.array(a[i]) for k, a in ch.items()}}
        return RunView(ts=L.frame(type("Lg", (), {"t": t, "ch": {k: np.array(a) for k, a in ch.items()}}), i),
                       suffixes=list(sfx), static_tire_force=static[i], stop_gap=gaps[i], info=infos[i]) \
            if i % 2 else RunView(ts=None, suffixes=list(sfx), static_tire_force=static[i], stop_gap=gaps[i],
                                  info=infos[i], columns=cols)

    got = compute_metrics_many(t, ch, list(sfx), infos, gaps, [lambda i=i: view(i) for i in range(n)])
    for i in range(n):
        ts = L.frame(type("Lg", (), {"t": t, "ch": ch}), i)
        ref = L.metrics_of(ts, infos[i])
        assert_same_metrics(got[i], ref, NEAR)
        assert_same_metrics(compute_metrics(Result(None, ts, infos[i])), got[i])  # one car = the ensemble
    # every built-in metric has an ensemble version and it was used (no per-car view needed)
    ens = EnsembleView(channels=ch, t=t, suffixes=list(sfx), static_tire_force={}, stop_gaps=gaps, infos=infos)
    assert ens.n_cars == n
    assert all(getattr(METRICS.get(k), "ensemble", None) is not None for k in L.METRICS)


def test_plugin_metric_without_ensemble_version_and_fallback():
    """A metric with no ensemble version is computed car by car (in registry order); an ensemble version
    that raises NotImplementedError (stop gaps on some cars only) falls back to that too."""
    rng = np.random.default_rng(5)
    n, n_log = 4, 1500
    t, ch = _synthetic(n, n_log, 1000.0, rng)
    calls = []

    def aaa_plugin(run):  # sorts first: its keys come first
        calls.append(1)
        return {"plugin_mean_travel": float(np.mean(run.ts["travel"].to_numpy())), "plugin_n": len(run.ts)}

    def zzz_needs_missing(run):
        return {"never": float(run.col("no_such_channel")[0])}

    METRICS._items["aaa_plugin"] = aaa_plugin
    METRICS._items["zzz_needs_missing"] = zzz_needs_missing
    try:
        gaps = [{"": 0.01} if i < 2 else {} for i in range(n)]
        infos = [{"suffixes": [""], "static_tire_force": {"": 3000.0}, "stop_gap": gaps[i]} for i in range(n)]
        lg = type("Lg", (), {"t": t, "ch": ch})

        def view(i):
            return RunView(ts=None, suffixes=[""], static_tire_force=infos[i]["static_tire_force"],
                           stop_gap=gaps[i], info=infos[i], columns={"t": t, **{k: a[i] for k, a in ch.items()}})

        got = compute_metrics_many(t, ch, [""], infos, gaps, [lambda i=i: view(i) for i in range(n)])
        assert len(calls) == n
        for i in range(n):
            ts = L.frame(lg, i)
            ref = compute_metrics(Result(None, ts, infos[i]))
            assert_same_metrics(got[i], ref)
            assert list(got[i])[:2] == ["plugin_mean_travel", "plugin_n"] and "never" not in got[i]
            assert ("travel_stop_fraction" in got[i]) == (i < 2)
            assert _same(got[i]["plugin_mean_travel"], float(np.mean(ch["travel"][i])))
    finally:
        del METRICS._items["aaa_plugin"], METRICS._items["zzz_needs_missing"]
