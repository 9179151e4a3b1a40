"""Cost of turning an ensemble's logs into per-car Results and metrics, before and after (issue 7).

After a batch's stepping loop (compiled: ~0.6 µs per car-step), every car's log becomes a ``Result`` with
its metrics.  *Before* (commit 441d2fb, kept verbatim in ``tests/legacy_results.py``): per car, a
DataFrame (``Logger.frame``), the info dict rebuilt, every metric computed from DataFrame column lookups.
*After* (``suspension_sim/results.py``): the metrics of all cars computed at once from the logger's
``(n_cars, n_log)`` arrays (ensemble versions of the metrics, bit-identical per car), the info pieces shared,
the DataFrame built only when ``timeseries`` is read.  Both run here on the same logs, in one process, and
the metrics are checked equal (exactly, the vibration dose value to 1e-12) before anything is printed.

Cases: 256 quarter cars (quadratic damping + bump stops, skyhook, sine roads) and 64 full cars (passive,
bump), 2 s each, 0.5 ms physics, 1 kHz log.  Rows:

- ``before``: the old per-car path;
- ``after: from_logger per car``: ``[Result.from_logger(logger, i, sim, wall) for i in range(n)]`` as the
  loops call it (the first call computes the whole ensemble, the others pick their car);
- ``after: many_from_logger``: the same in one call;
- ``after + every ts read``: as above, then every car's DataFrame built (a batch with ``keep_timeseries``);
- the same after-rows with the logs laid out channel-major (one contiguous ``(n_cars, n_log)`` array per
  channel) when the loop logged into one ``(n_cars, n_log, n_channels)`` buffer (``L[:, :, j]`` views).

CPU time of this process (``time.process_time``), best of ``--repeats`` (default 5).  The last column is the
real-time factor per core that a loop costing ``--loop-us`` µs per car-step (default 0.6, the compiled
loop's figure) would reach end to end with these results: 1 / ((loop + results) · steps per second).

Run:  python benchmarks/bench_results.py [--repeats N] [--loop-us X] [--quick]
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

import legacy_results as L  # the old per-car path, verbatim

from suspension_sim.config import parse_scenario
from suspension_sim.results import Result
from suspension_sim.simulation import Simulation


def quarter(n, duration):
    rng = np.random.default_rng(0)
    return [parse_scenario({
        "name": f"q{i}",
        "vehicle": {"model": "quarter_car", "effects": [
            {"type": "quadratic_damping", "params": {"c_v": 300.0}},
            {"type": "bump_stop", "params": {"gap": 0.02, "stiffness": 40000.0}}]},
        "road": {"type": "sine", "params": {"amplitude": float(a), "frequency": float(f)}, "speed": 20.0},
        "sensors": [{"type": "corner_body_vel"}], "actuator": {"type": "ideal"},
        "controller": {"type": "skyhook", "params": {"c_sky": 2500.0}},
        "sim": {"duration": duration, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001}})
        for i, (a, f) in enumerate(zip(rng.uniform(0.01, 0.03, n), rng.uniform(0.8, 2.0, n)))]


def full(n, duration):
    return [parse_scenario({
        "name": f"f{i}", "vehicle": {"model": "full_car"},
        "road": {"type": "bump", "params": {"preset": "fallah"}, "speed": 9.7 + 0.01 * i},
        "controller": {"type": "passive"},
        "sim": {"duration": duration, "dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001}}) for i in range(n)]


def run_and_grab(scs):
    sim = Simulation(scs)
    grab = {}
    sim.log_hooks.append(lambda logger, j, t: grab.setdefault("logger", logger))
    res = sim.run()
    wall = res[0].info["wall_time_s"] * len(res)
    return sim, grab["logger"], wall, getattr(sim, "loop", "python")


def best(fn, repeats):
    out = math.inf
    for _ in range(repeats):
        c0 = time.process_time()
        fn()
        out = min(out, time.process_time() - c0)
    return out


def same(a: dict, b: dict) -> bool:
    """Same keys in the same order and values, but the vibration dose value within 1e-12 relative (the
    package takes a_w⁴ as (a_w²)², the reference as pow(a_w, 4): an ulp or two apart)."""
    return list(a) == list(b) and all(a[k] == b[k] or (math.isnan(a[k]) and math.isnan(b[k]))
                                      or (k == "body_acc_vdv" and abs(a[k] - b[k]) <= 1e-12 * abs(b[k])) for k in a)


def channel_major(logger):
    """A copy of the logger's channels as one contiguous (n_cars, n_log) array each."""
    stack = np.stack(list(logger.ch.values()))
    return {k: stack[j] for j, k in enumerate(logger.ch)}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--loop-us", type=float, default=0.6)
    ap.add_argument("--quick", action="store_true", help="64 quarter cars, 16 full cars, 1 s")
    a = ap.parse_args()
    dur = 1.0 if a.quick else 2.0
    cases = [("quarter car", quarter(64 if a.quick else 256, dur)), ("full car", full(16 if a.quick else 64, dur))]
    try:
        load = os.getloadavg()[0]
    except OSError:  # pragma: no cover
        load = float("nan")
    print(f"results + metrics per car, CPU time, best of {a.repeats} (load average {load:.1f})\n")
    hdr = f"{'case':<52} {'µs/car-step':>11} {'ms/car':>8} {'× faster':>9} {'RTF/core':>9}"
    for label, scs in cases:
        sim, logger, wall, loop = run_and_grab(scs)
        n, steps = logger.n, sim.n_steps
        strided = not next(iter(logger.ch.values())).flags.c_contiguous
        # equality first: the old per-car path against the new one, every car, every metric, the DataFrame
        old = [L.from_logger(logger, i, sim, wall) for i in range(n)]
        new = [Result.from_logger(logger, i, sim, wall) for i in range(n)]
        assert all(same(r.metrics, o[2]) and r.info == o[1] for r, o in zip(new, old)), "metrics differ"
        assert all(r.ts.equals(o[0]) for r, o in zip(new[:4], old[:4])), "time series differ"
        del old, new

        rows = []

        def add(name, fn):
            rows.append((name, best(fn, a.repeats)))

        add("before: per car (DataFrame, metrics from columns)",
            lambda: [L.from_logger(logger, i, sim, wall) for i in range(n)])
        add("after: from_logger per car",
            lambda: [Result.from_logger(logger, i, sim, wall) for i in range(n)])
        add("after: many_from_logger", lambda: Result.many_from_logger(logger, sim, wall))
        add("after + every ts read (keep_timeseries)",
            lambda: [r.ts for r in Result.many_from_logger(logger, sim, wall)])
        if strided:
            orig = logger.ch
            logger.ch = channel_major(logger)
            try:
                add("after: many_from_logger, channel-major logs", lambda: Result.many_from_logger(logger, sim, wall))
                add("before, channel-major logs", lambda: [L.from_logger(logger, i, sim, wall) for i in range(n)])
            finally:
                logger.ch = orig
        print(f"{label}: {n} cars × {steps} steps ({dur:g} s), {len(logger.ch)} log channels × {logger.n_log} "
              f"samples, loop: {loop}, logs {'strided views of one buffer' if strided else 'contiguous per channel'}")
        print(hdr)
        ref = rows[0][1]
        for name, t in rows:
            per_cs = t / (n * steps) * 1e6
            rtf = 1.0 / ((a.loop_us + per_cs) * 1e-6 * (steps / dur))
            print(f"{name:<52} {per_cs:>11.4f} {t / n * 1e3:>8.3f} {ref / t:>9.1f} {rtf:>9.0f}")
        print()


if __name__ == "__main__":
    main()
