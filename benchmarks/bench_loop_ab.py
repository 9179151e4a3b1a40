"""Two generated compiled loops against each other, interleaved every few steps inside the same runs (issue 15).

Whole-run pairs (``bench_overhead.py``) move by ±10 % and more between neighbouring runs on this shared machine,
so a change of 1–3 % of the loop cannot be seen there.  Here every call of the compiled loop is split into
segments of S physics steps (default 100, ~20 ms for the 256-car batch) run alternately by the loop module of a
base tree ("old", e.g. a ``git archive`` or worktree of main) and by this tree's ("new"); the same arguments go to
both (the two loops must take the same arguments), so the load at any moment hits both alike.  CPU time per
segment is summed per side; the ratio new/old per run and per neighbouring segment pair is printed, with the
difference as a fraction of bare ``mj_step`` of the same model over the same number of steps.

Before timing, one whole run with each loop alone and one interleaved run must give byte-identical metrics.

Case: bench_speed's batch (256 cars of the quarter car, quadratic damping + bump stop, the thesis's continuous
MRAC, 0.5 ms physics, 1 ms control, 2 s, metrics-only logging).

Run:  python benchmarks/bench_loop_ab.py BASE_TREE [--reps N] [--segment S] [--cars N]
      (BASE_TREE: a checkout whose suspension_sim/compiled/loop.py is the old loop)
"""
from __future__ import annotations

import argparse
import importlib.util
import inspect
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
    ap.add_argument("base", help="a checkout whose suspension_sim/compiled/loop.py is the old loop")
    ap.add_argument("--reps", type=int, default=8)
    ap.add_argument("--segment", type=int, default=100, help="physics steps per segment")
    ap.add_argument("--cars", type=int, default=256)
    a = ap.parse_args()
    old_file = Path(a.base) / "suspension_sim" / "compiled" / "loop.py"
    if not old_file.is_file():
        sys.exit(f"bench_loop_ab: {old_file} not found")

    import mujoco

    from suspension_sim.compiled import loop as cloop
    from suspension_sim.config import parse_scenario
    from suspension_sim.loop import one_blas_thread
    from suspension_sim.simulation import Simulation

    spec = importlib.util.spec_from_file_location("suspension_sim.compiled._loop_base", old_file)
    old = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = old
    spec.loader.exec_module(old)
    new_load = cloop.load_module
    spent = {"old": 0.0, "new": 0.0}
    seg = {"old": [], "new": []}

    class Alternating:
        """A loop module whose ``loop`` runs segments of S steps alternately with the old and the new module."""

        def __init__(self, mo, mn):
            self.mo, self.mn, self.flip = mo, mn, 0
            names = list(inspect.signature(mn.loop.py_func).parameters)
            if names != list(inspect.signature(mo.loop.py_func).parameters):
                sys.exit("bench_loop_ab: the two loops take different arguments")
            self.i0, self.i1, self.ir = names.index("k0"), names.index("k1"), names.index("resume")
            self.loop = self._loop
            self.loop.__func__.overloads = mn.loop.overloads  # the caller asks whether it is compiled

        def _loop(self, *x):
            x = list(x)
            k, k1 = x[self.i0], x[self.i1]
            while True:
                e = min(k1, k + a.segment)
                x[self.i0], x[self.i1] = k, e
                side = "old" if self.flip % 2 == 0 else "new"
                self.flip += 1
                c = time.process_time()
                r = (self.mo if side == "old" else self.mn).loop(*x)
                d = time.process_time() - c
                spent[side] += d
                seg[side].append(d)
                if r != e or e == k1:
                    return r
                k, x[self.ir] = e, 0

    rng = np.random.default_rng(0)
    scs = [parse_scenario(scenario_raw(duration=2.0, amplitude=float(x), frequency=float(f)))
           for x, f in zip(rng.uniform(0.01, 0.03, a.cars), rng.uniform(0.8, 2.0, a.cars))]
    sim = Simulation(scs, log_channels="metrics")

    def metrics(load):
        cloop.load_module = load
        return [r.metrics for r in sim.run()]

    def same(xs, ys):
        return all(list(p) == list(q) and all(np.asarray(p[k]).tobytes() == np.asarray(q[k]).tobytes() for k in p)
                   for p, q in zip(xs, ys))

    n_old = len(inspect.signature(old.load_module).parameters)

    def old_load(*x, **kw):  # the base tree's loader may take fewer (trailing, optional) arguments
        return old.load_module(*x[:n_old], **{k: v for k, v in kw.items()
                                              if k in inspect.signature(old.load_module).parameters})

    m_old, m_new = metrics(old_load), metrics(new_load)
    m_alt = metrics(lambda *x, **kw: Alternating(old_load(*x, **kw), new_load(*x, **kw)))
    print(f"{a.cars} cars x 2 s, segments of {a.segment} steps; metrics old == new: {same(m_old, m_new)}, "
          f"interleaved == old: {same(m_old, m_alt)}; load average {os.getloadavg()[0]:.1f}", flush=True)
    if not (same(m_old, m_new) and same(m_old, m_alt)):
        sys.exit("bench_loop_ab: the two loops do not give the same metrics; not timed")
    d = mujoco.MjData(sim.plant.model)
    ratios, extra = [], []
    for r in range(a.reps):
        spent["old"] = spent["new"] = 0.0
        sim.run()
        with one_blas_thread():
            c = time.process_time()
            mujoco.mj_step(sim.plant.model, d, nstep=sim.n_steps // 2)
            bare = time.process_time() - c
        ratios.append(spent["new"] / spent["old"])
        extra.append((spent["new"] - spent["old"]) / bare)
        print(f"  rep {r}: old {spent['old']:.3f} s, new {spent['new']:.3f} s (half the steps each), new/old "
              f"{ratios[-1]:.4f}; bare mj_step of half the steps {bare:.3f} s, (new - old) / bare {extra[-1]:+.4f}",
              flush=True)
    so, sn = np.array(seg["old"]), np.array(seg["new"])
    m = min(len(so), len(sn))
    print(f"new/old per run: median {np.median(ratios):.4f} (range {min(ratios):.4f}-{max(ratios):.4f}); per "
          f"neighbouring segment pair: median {np.median(sn[:m] / so[:m]):.4f} (n = {m}); (new - old) / bare "
          f"mj_step: median {np.median(extra):+.4f}")
    print(f"load average at end {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
