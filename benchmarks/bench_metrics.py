"""Time of the metrics of a whole ensemble after a batch (``results.compute_metrics_many``), in total and per
metric.

Cases: 256 quarter cars (quadratic damping, bump stops, skyhook, sine roads) and 64 full cars (passive,
bump), 2 s each, 0.5 ms physics, 1 kHz log, logged as the compiled loop logs them (``L[:, :, j]`` views of
one ``(n_cars, n_log, n_channels)`` buffer).  CPU time of this process, best of ``--repeats``.

``--logs FILE``: keep the simulated logs in FILE (made on the first call, read on the next ones), so that two
versions of the metrics can be timed on the very same logs without simulating again, e.g. the current tree
against an older checkout: ``PYTHONPATH=/tmp/old python benchmarks/bench_metrics.py --logs /tmp/logs.pkl``.
``--check FILE``: also write (first call) or compare (next calls) every car's metrics, so that the two
versions are shown equal (1e-12 relative) on those logs.

Run:  python benchmarks/bench_metrics.py [--repeats N] [--logs FILE] [--check FILE]
"""
from __future__ import annotations

import argparse
import math
import os
import pickle
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import suspension_sim  # noqa: E402  (first: the package on PYTHONPATH, if any, before bench_results adds ROOT)
from bench_results import best as _best  # noqa: E402  (CPU time, best of n)


def _simulate():
    from bench_results import full, quarter, run_and_grab  # the cases of the results benchmark

    from suspension_sim.results import infos_of

    out = {}
    for label, scs in (("256 quarter cars, 2 s", quarter(256, 2.0)), ("64 full cars, 2 s", full(64, 2.0))):
        sim, logger, wall, _ = run_and_grab(scs)
        names = list(logger.ch)
        buf = np.stack([np.asarray(logger.ch[k]) for k in names], axis=2)  # (n_cars, n_log, n_channels)
        out[label] = dict(t=np.array(logger.t), names=names, buf=buf, sfx=list(logger.sfx), infos=infos_of(sim, wall))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--logs", type=Path, default=None)
    ap.add_argument("--check", type=Path, default=None)
    a = ap.parse_args()
    if a.logs is not None and a.logs.exists():
        cases = pickle.loads(a.logs.read_bytes())
    else:
        cases = _simulate()
        if a.logs is not None:
            a.logs.write_bytes(pickle.dumps(cases, protocol=pickle.HIGHEST_PROTOCOL))

    from suspension_sim.registry import METRICS, load_plugins
    from suspension_sim.results import compute_metrics_many

    load_plugins()
    print(f"metrics from {Path(suspension_sim.__file__).parent}, CPU s, best of {a.repeats} "
          f"(load average {os.getloadavg()[0]:.1f})")
    got = {}
    for label, c in cases.items():
        buf = np.array(c["buf"])  # its own array (an unpickled one is a view of a flat buffer), as the loop's
        ch = {k: buf[:, :, j] for j, k in enumerate(c["names"])}
        infos, sfx, t = c["infos"], c["sfx"], c["t"]
        gaps = [inf["stop_gap"] for inf in infos]

        def views(i):
            raise AssertionError("a built-in metric went car by car")

        def run(only=None):
            return compute_metrics_many(t, ch, sfx, infos, gaps, [views] * len(infos), only=only)

        got[label] = run()
        total = _best(run, a.repeats)
        print(f"  {label}: all metrics {1e3 * total:8.1f} ms (channels gathered from the loop's buffer included)")
        ch = {k: np.ascontiguousarray(v) for k, v in ch.items()}  # per metric: the gather done beforehand
        for name in METRICS.names():
            print(f"      {name:<20} {1e3 * _best(lambda: run({name}), a.repeats):8.1f} ms")
    if a.check is not None:
        if not a.check.exists():
            a.check.write_bytes(pickle.dumps(got))
            print(f"metrics written to {a.check}")
        else:
            ref = pickle.loads(a.check.read_bytes())
            worst = 0.0
            for label in ref:
                for m, r in zip(got[label], ref[label]):
                    assert list(m) == list(r), (label, list(m), list(r))
                    for k in r:
                        x, y = m[k], r[k]
                        if not (x == y or (math.isnan(x) and math.isnan(y))):
                            worst = max(worst, abs(x - y) / max(abs(y), 1e-300))
            print(f"metrics equal to {a.check}: same keys in the same order, largest relative difference {worst:.2e}")
            assert worst <= 1e-12


if __name__ == "__main__":
    main()
