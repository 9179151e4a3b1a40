"""Full matrix of the discrepancy workflow on synthetic records: every effect of the library hidden in a
quarter-car record from the independent truth generator (suspension_sim/diagnose/truth.py: scipy
solve_ivp, own effect implementations), with random strength, random road (and force input where the effect
needs one), random sensor noise; plus no effect and two effects.  Prints a markdown table (named correctly /
held-out NRMSE shrink) for docs/diagnose.md.

    python benchmarks/diagnose_matrix.py [--seeds 2] [--duration 10] [--only NAME,...]
"""
from __future__ import annotations

import argparse
import zlib
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
warnings.filterwarnings("ignore")

from suspension_sim.diagnose import diagnose, truth  # noqa: E402
from suspension_sim.diagnose.io import record_from_arrays  # noqa: E402

QC = {"model": "quarter_car", "params": {"sprung_mass": 290, "unsprung_mass": 59, "spring_stiffness": 16812,
                                         "damping": "free", "tire_stiffness": 190000, "tire_damping": 0}}


def case(name, rng):
    """(hidden effects, truth params, road rms, force rms, expected names)."""
    U = rng.uniform
    if name == "coulomb_friction":
        return {name: {"force": U(80, 300)}}, {}, 0.01, 0.0, [name]
    if name == "quadratic_damping":
        return {name: {"c_v": U(1500, 5000)}}, {}, 0.01, 0.0, [name]
    if name == "asymmetric_damping":
        return {name: {"c_reb": U(500, 1500), "c_comp": 0.0}}, {}, 0.01, 0.0, [name]
    if name == "bump_stop":
        return {name: {"gap": U(0.015, 0.025), "stiffness": U(5e4, 1.5e5)}}, {}, 0.01, 0.0, [name]
    if name == "bump_stop_compression":  # a jounce bumper alone: no rebound stop
        return ({"bump_stop": {"gap_compression": U(0.015, 0.025), "gap_extension": None, "stiffness": U(5e4, 1.5e5)}},
                {}, 0.01, 0.0, ["bump_stop"])
    if name == "cubic_stiffness":
        return {name: {"k3": U(1.5e7, 5e7)}}, {}, 0.01, 0.0, [name]
    if name == "tire_liftoff":
        return {name: {}}, {}, 0.03, 0.0, [name]
    if name == "actuator_delay":
        return {name: {"delay": U(0.005, 0.02)}}, {}, 0.01, 800.0, [name]
    if name == "actuator_lag":
        return {name: {"time_constant": U(0.005, 0.03)}}, {}, 0.01, 800.0, [name]
    if name == "hysteresis":
        return {name: {"force": U(100, 300), "x_y": U(0.001, 0.003)}}, {}, 0.01, 0.0, [name]
    if name == "backlash":
        return {name: {"stiffness": U(5000, 12000), "play": U(0.001, 0.003)}}, {}, 0.01, 0.0, [name]
    if name == "maxwell_damper":  # the damper (1000 N·s/m) on a mount with its corner at 4-10 Hz
        return {name: {"compliance": 1.0 / (2 * np.pi * U(4.0, 10.0) * 1000.0)}}, {}, 0.01, 0.0, [name]
    if name == "parameter:sprung_mass":
        return {}, {"sprung_mass": 290 * U(1.1, 1.25)}, 0.01, 0.0, [name]
    if name == "none":
        return {}, {}, 0.01, 0.0, []
    if name == "two:coulomb+cubic":
        return ({"coulomb_friction": {"force": U(100, 250)}, "cubic_stiffness": {"k3": U(2e7, 5e7)}}, {}, 0.01, 0.0,
                ["coulomb_friction", "cubic_stiffness"])
    raise KeyError(name)


CASES = ["coulomb_friction", "quadratic_damping", "asymmetric_damping", "bump_stop", "bump_stop_compression",
         "cubic_stiffness",
         "tire_liftoff", "actuator_delay", "actuator_lag", "hysteresis", "backlash", "maxwell_damper",
         "parameter:sprung_mass", "none",
         "two:coulomb+cubic"]


def run_case(name, seed, duration=10.0, fs=1000.0):
    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    eff, params, road, force, expect = case(name, rng)
    noise = float(rng.uniform(0.01, 0.03))
    outs = ["body_acc", "susp_travel"]
    d = truth.simulate_truth("quarter_car", duration, fs, eff, params=params, seed=int(rng.integers(1 << 30)),
                             road_rms=road, force_rms=force, noise=noise, outputs=outs)
    ins = {"road": d["road"]}
    if "force" in d:
        ins["force"] = d["force"]
    rec = record_from_arrays("quarter_car", d["time"], ins, {k: d[k] for k in outs})
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        rep = diagnose(rec, QC, tmp, confirm=False, plots=False)
    wall = time.perf_counter() - t0
    # the noise floor of the held-out part (the NRMSE of the noisy record against the noise-free truth: the
    # best any model can do) and the shrink of the error above it are computed in _row
    return _row(name, seed, noise, eff or params, expect, rep, d, outs, wall)


HC_CASES = {"hc:bump_stop": lambda U: {"bump_stop": {"gap": U(0.008, 0.014), "stiffness": U(5e4, 1.5e5)}},
            "hc:quadratic_damping": lambda U: {"quadratic_damping": {"c_v": U(1500, 5000)}},
            "hc:coulomb_friction": lambda U: {"coulomb_friction": {"force": U(80, 300)}},
            "hc:cubic_stiffness": lambda U: {"cubic_stiffness": {"k3": U(1.5e7, 5e7)}},
            "hc:asymmetric_damping": lambda U: {"asymmetric_damping": {"c_reb": U(500, 1500), "c_comp": 0.0}},
            "hc:none": lambda U: {}}


def run_half_case(name, seed, duration=10.0, fs=500.0):
    """A half-car record (truth.simulate_truth_half): the effect acts at both corners; outputs: body
    acceleration and travel at both corners, pitch rate; the model's two dampings are free."""
    from suspension_sim.diagnose.truth import HC_NOMINAL

    rng = np.random.default_rng([seed, zlib.crc32(name.encode())])
    eff = HC_CASES[name](rng.uniform)
    noise = float(rng.uniform(0.01, 0.03))
    outs = ["body_acc_front", "body_acc_rear", "susp_travel_front", "susp_travel_rear", "pitch_rate"]
    d = truth.simulate_truth_half(duration, fs, eff, seed=int(rng.integers(1 << 30)), noise=noise, outputs=outs)
    rec = record_from_arrays("half_car", d["time"], {"road_front": d["road_front"], "road_rear": d["road_rear"]},
                             {k: d[k] for k in outs})
    model = {"model": "half_car", "params": {**HC_NOMINAL, "damping_front": "free", "damping_rear": "free"}}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        rep = diagnose(rec, model, tmp, confirm=False, plots=False)
    return _row(name, seed, noise, eff, list(eff), rep, d, outs, time.perf_counter() - t0)


def _row(name, seed, noise, eff, expect, rep, d, outs, wall):
    """One table row; ``floor`` = held-out NRMSE of the noisy data against the noise-free truth (scaled like
    the workflow's NRMSE), ``max_shrink`` = 1 − floor/before (what the true model would reach),
    ``excess_shrink`` = shrink of sqrt(NRMSE² − floor²), the error above the noise."""
    named = [e["name"] for e in rep["effects"]]
    b = np.sqrt(np.mean(np.square(list(rep["nrmse"]["before"]["test"].values()))))
    a = np.sqrt(np.mean(np.square(list(rep["nrmse"]["after"]["test"].values()))))
    n0 = int(round(0.7 * len(d["time"])))
    fl = np.sqrt(np.mean([(np.sqrt(np.mean((d[k][n0:] - d["_clean"][k][n0:]) ** 2)) / np.std(d[k])) ** 2
                          for k in outs]))
    xb, xa = np.sqrt(max(b ** 2 - fl ** 2, 0.0)), np.sqrt(max(a ** 2 - fl ** 2, 0.0))
    return {"case": name, "seed": seed, "noise": noise, "truth": eff, "named": named,
            "correct": sorted(named) == sorted(expect), "before": b, "after": a, "shrink": 1 - a / b, "wall_s": wall,
            "floor": fl, "excess_shrink": (1 - xa / xb) if xb > 0 else float("nan"), "max_shrink": 1 - fl / b,
            "params": {e["name"]: e["parameters"] for e in rep["effects"]}}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--duration", type=float, default=10.0)
    ap.add_argument("--only", default="")
    ap.add_argument("--half", action="store_true", help="run the half-car cases instead")
    args = ap.parse_args()
    names = args.only.split(",") if args.only else (list(HC_CASES) if args.half else CASES)
    rows = []
    for name in names:
        for seed in range(args.seeds):
            r = run_half_case(name, seed, args.duration) if name.startswith("hc:") else run_case(name, seed, args.duration)
            rows.append(r)
            print(f"{r['case']:<24} seed {seed}: named {r['named']} correct={r['correct']} test NRMSE "
                  f"{r['before']:.4f} -> {r['after']:.4f} (shrink {100 * r['shrink']:.1f} %, floor {r['floor']:.4f}, "
                  f"excess shrink {100 * r['excess_shrink']:.1f} %) {r['wall_s']:.0f} s; truth {r['truth']}, "
                  f"fitted {r['params']}",
                  flush=True)
    print("\n| hidden effect | named correctly | held-out NRMSE before → after | shrink | noise floor (NRMSE) | "
          "best possible shrink | shrink above the floor | noise | time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['case']} | {'yes' if r['correct'] else 'no: ' + ', '.join(r['named'])} | {r['before']:.4f} → "
              f"{r['after']:.4f} | {100 * r['shrink']:.1f} % | {r['floor']:.4f} | {100 * r['max_shrink']:.1f} % | "
              f"{100 * r['excess_shrink']:.1f} % | {100 * r['noise']:.1f} % | {r['wall_s']:.0f} s |")


if __name__ == "__main__":
    main()
