"""The batch closed loop against bare ``mj_step`` of the same ensemble model, paired and interleaved (issue 15).

The case is bench_speed's batch (256 cars of the quarter car with quadratic damping + bump stops, the thesis's
continuous MRAC, ideal actuator, 0.5 ms physics, 1 ms control, 2 s, the batch engine's logging: only the
channels the metrics read).  Each pair runs, in one process and back to back:

- A: ``Simulation(scenarios, log_channels="metrics").run()`` and the metrics of every car (the whole run),
  with the CPU time spent inside the compiled loop's calls recorded separately (the loop alone);
- B: bare ``mujoco.mj_step(model, data, nstep)`` on a fresh ``MjData`` of the very ensemble model A stepped,
  for the same number of steps (one C call, no Python in between).

The order alternates (A B, B A, ...) so a change of the machine's load hits both sides alike; each pair's
ratio is A / B, and the median and range over the pairs are printed.  Times are CPU seconds of this process.

Run:  python benchmarks/bench_overhead.py [--pairs N] [--cars N] [--duration S] [--logging all] [--worker-gc]
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from bench_speed import scenario_raw  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pairs", type=int, default=8)
    ap.add_argument("--cars", type=int, default=256)
    ap.add_argument("--duration", type=float, default=2.0)
    ap.add_argument("--logging", default="metrics", choices=("metrics", "all"))
    ap.add_argument("--worker-gc", action="store_true",
                    help="after the warm-up, freeze the garbage collector's objects as a batch worker process does "
                         "(lifecycle.freeze_gc); default: the collector of a plain Python process")
    a = ap.parse_args()

    import mujoco

    from suspension_sim.compiled import loop as cloop
    from suspension_sim.config import parse_scenario
    from suspension_sim.loop import one_blas_thread
    from suspension_sim.simulation import Simulation

    rng = np.random.default_rng(0)
    scs = [parse_scenario(scenario_raw(duration=a.duration, amplitude=float(x), frequency=float(f)))
           for x, f in zip(rng.uniform(0.01, 0.03, a.cars), rng.uniform(0.8, 2.0, a.cars))]
    Simulation(scs[:2], log_channels=a.logging).run()  # load the compiled loop
    if a.worker_gc:
        from suspension_sim.lifecycle import freeze_gc

        freeze_gc()

    inside = [0.0]
    orig_load = cloop.load_module

    def load_module(*args, **kw):  # time the compiled loop's calls (CPU of this process)
        mod = orig_load(*args, **kw)
        if not getattr(mod, "_timed", False):
            inner = mod.loop

            def timed(*x):
                c = time.process_time()
                r = inner(*x)
                inside[0] += time.process_time() - c
                return r

            timed.overloads = inner.overloads  # the caller asks whether the loop is compiled yet (the same dict)
            mod.loop, mod._timed = timed, True
        return mod

    cloop.load_module = load_module

    def run_a():
        s = Simulation(scs, log_channels=a.logging)
        inside[0] = 0.0
        c = time.process_time()
        ms = [r.metrics for r in s.run()]
        whole = time.process_time() - c
        assert all(np.isfinite(m["body_acc_rms"]) for m in ms)
        return whole, inside[0], s

    def run_b(model, nstep):
        d = mujoco.MjData(model)
        with one_blas_thread():
            c = time.process_time()
            mujoco.mj_step(model, d, nstep=nstep)
            return time.process_time() - c

    _, _, sim = run_a()
    model, nstep = sim.plant.model, sim.n_steps
    print(f"{a.cars} cars x {a.duration:g} s ({nstep} steps, {sim.loop} compiled loop, integrator "
          f"{model.opt.integrator}, logging {a.logging}, {'worker' if a.worker_gc else 'plain'} gc); load average "
          f"{os.getloadavg()[0]:.1f}")
    loop_r, whole_r, raw_t, loop_t, whole_t = [], [], [], [], []
    for p in range(a.pairs):
        if p % 2 == 0:
            whole, lp, _ = run_a()
            raw = run_b(model, nstep)
        else:
            raw = run_b(model, nstep)
            whole, lp, _ = run_a()
        loop_r.append(lp / raw)
        whole_r.append(whole / raw)
        raw_t.append(raw)
        loop_t.append(lp)
        whole_t.append(whole)
        print(f"  pair {p}: raw {raw:.3f} s, loop {lp:.3f} s ({lp / raw:.2f}x), whole run {whole:.3f} s "
              f"({whole / raw:.2f}x)", flush=True)

    def fmt(r):
        return f"{np.median(r):.2f}x (range {min(r):.2f}-{max(r):.2f})"

    print(f"loop alone / raw mj_step: {fmt(loop_r)}")
    print(f"whole run (loop + road + results + metrics) / raw mj_step: {fmt(whole_r)}")
    print(f"best CPU s: raw {min(raw_t):.3f}, loop {min(loop_t):.3f}, whole {min(whole_t):.3f}; "
          f"ratio of bests: loop {min(loop_t) / min(raw_t):.2f}x, whole {min(whole_t) / min(raw_t):.2f}x")
    print(f"load average at end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
