"""Measure the quantities of Kim's Figs. 2–5 and Lin & Kanellakopoulos' Figs. 4–5 from the scenario files and
print them as Markdown tables (the numbers in docs/reproductions/lin_kanellakopoulos_1996.md come from this script).

    python benchmarks/figures_kim_lin.py            # full durations of the scenario files (~ a few minutes)
    python benchmarks/figures_kim_lin.py --quick    # 2 s runs

Kim: RMS force-tracking error F_a − F_d after the first second (the start-up transient excluded), relative to
the RMS of F_d; RMS p_e in the last second; peak body displacement |x2| after 1 s against the passive car.
Lin & K: peak |suspension travel|, peak |body acceleration|, and the RMS deviation of the body acceleration
from the known-parameter run over the bump window 0.5–0.8 s; θ̂ (= ρ·θ̂, the paper's plot) at the end.
Each scenario's variants run as one ensemble where their structure allows it.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import suspension_sim as ss  # noqa: E402
from suspension_sim.config import load_scenario  # noqa: E402
from suspension_sim.simulation import Simulation, structure_key  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def run_variants(path, duration=None):
    sc = load_scenario(path)
    if duration is not None:
        sc.sim.duration = duration
    variants = sc.expand(str(path))
    groups: dict = {}
    for name, v in variants:
        groups.setdefault(structure_key(v), []).append((name, v))
    out = {}
    for members in groups.values():
        res = Simulation([v for _, v in members], str(path)).run()
        out.update({name: r for (name, _), r in zip(members, res)})
    return out


def kim(quick=False):
    rows = []
    for fig in (2, 3, 4, 5):
        res = run_variants(ROOT / f"scenarios/kim_fig{fig}.yaml", 2.0 if quick else None)
        p = res["passive"].ts
        pz = float(np.max(np.abs(p.body_z[p.t >= 1.0])))
        for var in ("kim", "literal", "load_cell"):
            ts = res[var].ts
            m = ts.t >= 1.0
            e = (ts["ctrl.F_a"] - ts["ctrl.F_d"])[m]
            last = ts.t >= ts.t.iloc[-1] - 1.0
            rows.append((fig, var, rms(e), rms(e) / rms(ts["ctrl.F_d"][m]), rms(ts["ctrl.p_e"][last]),
                         float(np.max(np.abs(ts["ctrl.p_e"]))), float(np.max(np.abs(ts.body_z[m]))), pz,
                         float(ts["ctrl.a2_hat"].iloc[-1]), float(ts["ctrl.a3_hat"].iloc[-1])))
    print("| Fig. | variant | RMS(F_a − F_d) N | relative | RMS p_e last s (N) | peak p_e (N) | peak x2 (m) | passive peak x2 (m) | â2 end | â3 end |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:.1f} | {r[3]:.3f} | {r[4]:.2f} | {r[5]:.1f} | {r[6]:.4f} | {r[7]:.4f} | {r[8]:.4g} | {r[9]:.4g} |")


def lin(quick=False):
    print("| Fig. | variant | peak travel (m) | peak body acc (m/s²) | RMS acc dev. from known, 0.5–0.8 s (m/s²) | peak body z (m) | peak P_L (Pa) | ρθ̂ end |")
    print("|---|---|---|---|---|---|---|---|")
    for fig in (4, 5):
        res = run_variants(ROOT / f"scenarios/lin_fig{fig}.yaml", 1.5 if quick else None)
        k = res["known"].ts
        w = (k.t >= 0.5) & (k.t <= 0.8)
        for var in ("known", "adaptive", "nonadaptive"):
            ts = res[var].ts
            dev = rms((ts.body_acc - k.body_acc)[w])
            print(f"| {fig} | {var} | {np.max(np.abs(ts.travel)):.4f} | {np.max(np.abs(ts.body_acc)):.1f} | {dev:.2f} | "
                  f"{np.max(np.abs(ts.body_z)):.4f} | {np.max(np.abs(ts['act.load_pressure'])):.3g} | "
                  f"{ts['ctrl.theta_hat'].iloc[-1]:.1f} |")


if __name__ == "__main__":
    quick = "--quick" in sys.argv
    if "--lin" not in sys.argv:
        kim(quick)
    if "--kim" not in sys.argv:
        lin(quick)
