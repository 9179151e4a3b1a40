"""Memory of a 10,000-run sweep without time series (issue 7: "well under 1 GB resident").

A grid of 100 skyhook gains × 100 sensor-noise seeds on the quarter car (0.2 s runs, so the benchmark
takes minutes, not hours; the per-run memory that matters — one summary row — does not depend on the
duration, and a worker's logs are bounded by the automatic ensemble size).  Resident memory is sampled
every 0.2 s from /proc for the driver process and all its worker processes together (PSS, which splits the
pages that forked workers share with the driver, and the plain RSS sum, which counts them in every
process), and the peaks are printed with the driver's and the largest worker's own peaks (getrusage).

Run:  python benchmarks/bench_batch_memory.py [--workers N] [--runs-side 100]
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

SWEEP = """
name: mem10k
base:
  name: qc_mem
  vehicle: {{model: quarter_car}}
  road: {{type: sine, params: {{amplitude: 0.02, frequency: 1.5}}, speed: 20}}
  sensors: [{{type: corner_body_vel, noise_std: 0.002}}]
  controller: {{type: skyhook, params: {{c_sky: 1000}}}}
  sim: {{duration: {duration}, dt: 0.0005, control_dt: 0.001, log_dt: 0.001}}
grid:
  controller.params.c_sky: {gains}
seeds: {{count: {side}, start: 0, path: sim.seed}}
keep_timeseries: false
"""


def rss_tree(pid: int) -> tuple[int, int]:
    """(resident, proportional) bytes of pid and all its descendants (Linux /proc).  Forked workers share
    the driver's imported pages copy-on-write: the sum of RSS counts those once per process, the sum of
    PSS (smaps_rollup) splits them, so it is the memory the sweep really occupies."""
    total = pss = 0
    kids = {}
    for p in os.listdir("/proc"):
        if not p.isdigit():
            continue
        try:
            with open(f"/proc/{p}/stat") as f:
                ppid = int(f.read().rsplit(")", 1)[1].split()[1])
            kids.setdefault(ppid, []).append(int(p))
        except (OSError, ValueError, IndexError):
            pass
    stack = [pid]
    while stack:
        q = stack.pop()
        try:
            with open(f"/proc/{q}/statm") as f:
                total += int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
            with open(f"/proc/{q}/smaps_rollup") as f:
                for line in f:
                    if line.startswith("Pss:"):
                        pss += int(line.split()[1]) * 1024
        except OSError:
            pass
        stack.extend(kids.get(q, []))
    return total, pss


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--runs-side", type=int, default=100, help="grid side: runs = side^2")
    ap.add_argument("--duration", type=float, default=0.2)
    a = ap.parse_args()
    from suspension_sim.batch import run_batch

    tmp = Path(tempfile.mkdtemp(prefix="bench_mem_"))
    gains = [round(30.0 * i, 1) for i in range(a.runs_side)]
    (tmp / "sweep.yaml").write_text(SWEEP.format(duration=a.duration, gains=gains, side=a.runs_side))
    peak = {"tree": 0, "pss": 0}
    stop = threading.Event()

    def sample():
        while not stop.is_set():
            r, p = rss_tree(os.getpid())
            peak["tree"], peak["pss"] = max(peak["tree"], r), max(peak["pss"], p)
            time.sleep(0.2)

    th = threading.Thread(target=sample, daemon=True)
    th.start()
    t0 = time.perf_counter()
    rep = run_batch(tmp / "sweep.yaml", out=tmp / "out", workers=a.workers, resume=False)
    wall = time.perf_counter() - t0
    stop.set()
    th.join()
    self_peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    child_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
    size = (rep.out / "summary.parquet").stat().st_size
    print(f"{rep.n_total} runs x {a.duration:g} s on {rep.engine}: {rep.counts} in {wall:.1f} s wall "
          f"({rep.n_total / wall:.0f} runs/s, {rep.n_total * a.duration / wall:.0f} simulated s per wall s; "
          f"load average {os.getloadavg()[0]:.1f})")
    print(f"peak memory, driver + workers together: {peak['pss'] / 2**20:.0f} MiB proportional (PSS), "
          f"{peak['tree'] / 2**20:.0f} MiB summed RSS (shared pages counted in every process) "
          f"(driver alone {self_peak / 2**20:.0f} MiB, largest worker {child_peak / 2**20:.0f} MiB)")
    print(f"summary.parquet: {len(rep.summary)} rows x {rep.summary.shape[1]} columns, {size / 2**20:.2f} MiB")


if __name__ == "__main__":
    main()
