"""Peak memory and time of long runs at 1 kHz logging (issue: flat memory for long runs).

Each duration runs in its own process (``suspension-sim run`` of the quarter car on an ISO 8608 road with
skyhook, 0.5 ms physics, 1 ms logging, time series written), and the child's peak RSS is read from
``resource.getrusage(RUSAGE_CHILDREN)``.  Usage: ``python benchmarks/bench_long_run.py [1e2 1e3 1e4 1e5]``
(default 1e2 1e3).  A log is still allocated up front (rows × channels × 8 bytes), so the peak grows with
the duration; the numbers are the baseline for streaming the log in chunks.
"""
from __future__ import annotations

import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

SC = {"name": "long", "vehicle": {"model": "quarter_car"},
      "road": {"type": "iso8608", "params": {"road_class": "C"}, "speed": 20.0},
      "sensors": [{"type": "corner_body_vel"}], "controller": {"type": "skyhook", "params": {"c_sky": 2000.0}},
      "sim": {"dt": 0.0005, "control_dt": 0.001, "log_dt": 0.001}, "outputs": {"plots": False}}


def one(duration: float, tmp: Path) -> tuple[float, float, int]:
    p = tmp / f"long_{duration:g}.yaml"
    p.write_text(yaml.safe_dump(dict(SC, sim=dict(SC["sim"], duration=duration))))
    out = tmp / f"run_{duration:g}"
    code = ("import resource, sys; from suspension_sim.cli import app; sys.argv=['suspension-sim','run',"
            f"{str(p)!r},'--out',{str(out)!r},'--quiet'];\ntry: app()\nexcept SystemExit: pass\n"
            "print('PEAK', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)")
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    peak = [int(line.split()[1]) for line in r.stdout.splitlines() if line.startswith("PEAK")]
    if not peak:
        raise SystemExit(f"{duration:g} s failed: {r.stderr.strip()[-500:]}")
    size = sum(f.stat().st_size for f in out.rglob("*.parquet"))
    return wall, peak[0] / 1024, size


def main(durations):
    print(f"{'simulated s':>12} {'wall s':>8} {'peak RSS MiB':>13} {'parquet MB':>11}")
    with tempfile.TemporaryDirectory() as tmp:
        for d in durations:
            wall, peak, size = one(d, Path(tmp))
            print(f"{d:>12g} {wall:>8.1f} {peak:>13.0f} {size / 1e6:>11.1f}", flush=True)


if __name__ == "__main__":
    main([float(a) for a in sys.argv[1:]] or [1e2, 1e3])
