"""Performance target of issue 6: a 60 s record at 1 kHz of a quarter car diagnosed against the whole library
in under 2 minutes on the 2-core machine.  The record hides Coulomb friction (truth generator:
suspension_sim/diagnose/truth.py).  Prints the wall time of each phase (truth generation not counted).

    python benchmarks/diagnose_speed.py [--duration 60] [--no-confirm]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
warnings.filterwarnings("ignore")

from suspension_sim.diagnose import diagnose, truth  # noqa: E402
from suspension_sim.diagnose.io import record_from_arrays  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--no-confirm", action="store_true")
    args = ap.parse_args()
    t0 = time.perf_counter()
    d = truth.simulate_truth("quarter_car", args.duration, 1000.0, {"coulomb_friction": {"force": 180.0}}, seed=7,
                             road_rms=0.01, noise=0.02, outputs=["body_acc", "susp_travel"])
    print(f"truth generation: {time.perf_counter() - t0:.1f} s (not counted)")
    rec = record_from_arrays("quarter_car", d["time"], {"road": d["road"]},
                             {k: d[k] for k in ("body_acc", "susp_travel")})
    # warm the compiled simulator's cache (numba compiles once per machine; cached on disk afterwards)
    model = {"model": "quarter_car", "params": {"sprung_mass": 290, "unsprung_mass": 59, "spring_stiffness": 16812,
                                                "damping": "free", "tire_stiffness": 190000, "tire_damping": 0}}
    with tempfile.TemporaryDirectory() as tmp:
        t1 = time.perf_counter()
        rep = diagnose(rec, model, tmp, confirm=not args.no_confirm, plots=True, log=print)
        wall = time.perf_counter() - t1
    print(f"diagnosis of {args.duration:g} s at 1 kHz against the whole library: {wall:.1f} s "
          f"(calibrate {rep['timings_s']['calibrate']:.1f} s, search {rep['timings_s']['search']:.1f} s, "
          f"rest = locate/report/MuJoCo confirmation)")
    print(rep["verdict"])


if __name__ == "__main__":
    main()
