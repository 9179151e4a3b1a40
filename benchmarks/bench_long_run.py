"""Peak memory and time of long runs at 1 kHz logging (issue 15: flat memory for long runs).

Each duration runs in its own process (``suspension-sim run`` of the quarter car on an ISO 8608 road with
skyhook, 0.5 ms physics, 1 ms logging, time series written), and the child's peak RSS is read from
``resource.getrusage(RUSAGE_SELF)`` in the child.  Usage:
``python benchmarks/bench_long_run.py [--with-1e5] [--road iso8608|sine] [DURATION ...]`` (default 1e2 1e3 1e4; ``--with-1e5`` adds
the 28-hour case, ~25 min on one shared core).  A log longer than the 64 MB buffer streams to
``timeseries.parquet`` in ~30 s row groups with the metrics computed chunk by chunk
(``suspension_sim/stream.py``), so the peak should not grow with the duration; the last column is the
growth of the peak per simulated hour against the first duration.
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


#: ``--road sine``: a road that costs no memory, to separate the log's memory from the ISO 8608 profile's
#: (past 20 km the ISO 8608 profile repeats one 20 km period, so its memory no longer grows with the duration;
#: the sine road remains a check that costs no profile at all)
ROADS = {"iso8608": SC["road"], "sine": {"type": "sine", "params": {"frequency": 1.5, "amplitude": 0.01}}}


def one(duration: float, tmp: Path, road: str = "iso8608") -> tuple[float, float, int]:
    p = tmp / f"long_{duration:g}.yaml"
    p.write_text(yaml.safe_dump(dict(SC, road=ROADS[road], sim=dict(SC["sim"], duration=duration))))
    out = tmp / f"run_{duration:g}"
    code = ("import resource, sys; from suspension_sim.cli import app; sys.argv=['suspension-sim','run',"
            f"{str(p)!r},'--out',{str(out)!r},'--quiet'];\ntry: app()\nexcept SystemExit: pass\n"
            "print('PEAK', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)")
    t0 = time.perf_counter()
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    one.cpu = (c1.ru_utime + c1.ru_stime) - (c0.ru_utime + c0.ru_stime)
    peak = [int(line.split()[1]) for line in r.stdout.splitlines() if line.startswith("PEAK")]
    if not peak:
        raise SystemExit(f"{duration:g} s failed: {r.stderr.strip()[-500:]}")
    size = sum(f.stat().st_size for f in out.rglob("*.parquet"))
    return wall, peak[0] / 1024, size


def main(durations, road="iso8608"):
    print(f"road: {road}")
    print(f"{'simulated s':>12} {'wall s':>8} {'CPU s':>8} {'peak RSS MiB':>13} {'parquet MB':>11} {'MiB per sim. h':>15}")
    first = None
    with tempfile.TemporaryDirectory() as tmp:
        for d in durations:
            wall, peak, size = one(d, Path(tmp), road)
            if first is None:
                first = (d, peak)
            slope = (peak - first[1]) / ((d - first[0]) / 3600.0) if d > first[0] else float("nan")
            print(f"{d:>12g} {wall:>8.1f} {one.cpu:>8.1f} {peak:>13.0f} {size / 1e6:>11.1f} {slope:>15.2f}", flush=True)


if __name__ == "__main__":
    argv = sys.argv[1:]
    road = "iso8608"
    if "--road" in argv:
        k = argv.index("--road")
        road = argv[k + 1]
        del argv[k:k + 2]
    ds = [float(a) for a in argv if a != "--with-1e5"] or [1e2, 1e3, 1e4]
    if "--with-1e5" in argv:
        ds.append(1e5)
    main(ds, road)
