"""Step halving of Fallah's near-sgn (a = 1000 s/m) rows on a large ensemble (default: the 5 m bump, ideal sensors).

The key number ``heave_ratio[5 m bump, a = 1000,fallah]`` of ``suspension-sim reproduce fallah`` (item
``bang_bang``) is a mean over realisations of a chaotic closed loop: realisation k runs the bump height
× (1 + k·1e-6) and the sim seed + k (``reproductions/fallah.py``, :func:`bb_realisations`).  Its heave ratio is the
whole-run RMS heave acceleration over the passive car's on the same bump, at the same step.  With 128 realisations
per step the item could not decide issue 12's 2 % rule for this row (page:
docs/reproductions/fallah_sorniotti_gruber.md, "Step halving"); this script decided it (not converged at the
scenario's 0.5 ms physics step, converged from 0.25 ms), which is why the item now runs the near-sgn rows at a
0.25 ms physics step.  It runs realisations k0 … k0 + n − 1 of a row (``--row``, ``--sensors``), built by the item's
own code path (``bb_scenarios``, ``bb_realisation``; the control step held at 1 ms) but at physics steps set here
explicitly, whatever step the item uses: 0.5 ms and 0.25 ms (``--third``: 0.125 ms; ``--integrator RK4``: RK4 at
0.5 ms), many cars per compiled-loop ensemble, and prints

- each step's mean ± standard error;
- the change of the mean on halving, with the unpaired standard error (the item's estimator, independent
  means) and the paired one (realisation k at both steps: same bump height, same seed), with their
  correlation;
- the verdict of the item's rule (:func:`~suspension_sim.reproductions.framework.conv_status`: converged when
  change + 1 s.e. < 2 %, undecided when the bound lies within 1 s.e.).

The per-realisation ratios are saved (``--save``, .npz, with the row) and merged with earlier saves of the same
row (``--merge``), so an ensemble can be grown in pieces.  Cost is printed as CPU seconds per realisation at each step.

Run:  nice -n 10 python benchmarks/fallah_near_sgn_ensemble.py --n 512 [--k0 0] [--chunk 128]
      [--row "1 m × 15 cm bump, a = 1000"] [--sensors noisy]
      [--save runs/fallah_ens_0.npz] [--merge runs/fallah_ens_*.npz]
      nice -n 10 python benchmarks/fallah_near_sgn_ensemble.py --third --n 512 --save runs/fallah_ens3_0.npz
      nice -n 10 python benchmarks/fallah_near_sgn_ensemble.py --integrator RK4 --n 512 --save runs/fallah_ensi_0.npz
      python benchmarks/fallah_near_sgn_ensemble.py --merge "runs/fallah_ens*.npz" --n 0   (report only)
"""
from __future__ import annotations

import argparse
import glob
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

LABEL = "5 m bump, a = 1000"
SCENARIO_DT = 0.0005  # fallah_bump's physics step; the steps below are fractions of it (0.5, 0.25, 0.125 ms),
# set explicitly, whatever physics step the item itself runs the row at


def build(step_factor: float, k0: int, n: int, integrator: str | None = None, label: str = LABEL,
          variant: str = "fallah"):
    """The passive reference and realisations k0 … k0+n−1 of the row, built by the item's own functions, at the
    physics step SCENARIO_DT × step_factor (the control step held at the item's 1 ms)."""
    from suspension_sim.reproductions.fallah import bb_realisation, bb_scenarios
    from suspension_sim.reproductions.framework import Context

    v = bb_scenarios(Context(1.0), label, only=["passive", variant])
    for sc in v.values():
        sc.sim.dt = SCENARIO_DT * step_factor
        if integrator:
            sc.sim.integrator = integrator
    return v["passive"], [bb_realisation(v[variant], j) for j in range(k0, k0 + n)]


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def run_ratios(step_factor: float, k0: int, n: int, chunk: int, integrator: str | None = None,
               label: str = LABEL, variant: str = "fallah"):
    from suspension_sim.simulation import Simulation

    passive, scs = build(step_factor, k0, n, integrator, label, variant)
    pa = rms(Simulation([passive]).run()[0].ts.body_acc)
    out = []
    c0 = time.process_time()
    for i in range(0, n, chunk):
        res = Simulation(scs[i:i + chunk], log_channels={"body_acc"}).run()
        if any(r.info.get("streamed_log") for r in res):  # r.ts would be the thinned preview, not the log
            raise SystemExit(f"--chunk {chunk}: the ensemble's log was streamed (its time series would be a "
                             "thinned preview); use a smaller chunk (128 fits)")
        out += [rms(r.ts.body_acc) / pa for r in res]
        print(f"  step ×{step_factor:g}: {i + len(res)}/{n} realisations, "
              f"{(time.process_time() - c0) / (i + len(res)):.4f} CPU-s each", flush=True)
    return np.array(out), (time.process_time() - c0) / max(n, 1)


def report(ks: np.ndarray, x1: np.ndarray, x2: np.ndarray) -> None:
    from suspension_sim.reproductions.framework import CONVERGENCE_TOL, conv_status

    n = len(ks)
    m1, m2 = x1.mean(), x2.mean()
    s1, s2 = x1.std(ddof=1) / np.sqrt(n), x2.std(ddof=1) / np.sqrt(n)
    change = abs(m2 - m1) / abs(m1)
    se_unpaired = np.hypot(s1, s2) / abs(m1)
    d = x2 - x1
    se_paired = d.std(ddof=1) / np.sqrt(n) / abs(m1)
    rho = np.corrcoef(x1, x2)[0, 1]
    print(f"realisations {ks.min()}–{ks.max()} ({n} per step, each run at both steps)")
    print(f"  0.5 ms physics:  mean {m1:.4f} ± {s1:.4f} (s.d. {x1.std(ddof=1) / m1:.1%}, {x1.min():.2f}–{x1.max():.2f})")
    print(f"  0.25 ms physics: mean {m2:.4f} ± {s2:.4f} (s.d. {x2.std(ddof=1) / m2:.1%}, {x2.min():.2f}–{x2.max():.2f})")
    print(f"  correlation of realisation k at the two steps: {rho:+.3f}")
    print(f"  change on halving {100 * (m2 / m1 - 1):+.2f} %; s.e. unpaired {100 * se_unpaired:.2f} %, "
          f"paired {100 * se_paired:.2f} %")
    se = min(se_unpaired, se_paired)
    st = conv_status(change, se)
    print(f"  rule (change + 1 s.e. < {CONVERGENCE_TOL:.0%}), with the smaller s.e.: {st}; 1σ band "
          f"{100 * (change - se):.2f}–{100 * (change + se):.2f} %; the bound is {(CONVERGENCE_TOL - change) / se:+.2f} s.e. "
          "from the change")
    print(f"  worse than passive: {np.sum(x1 > 1)} / {n} at 0.5 ms, {np.sum(x2 > 1)} / {n} at 0.25 ms")


def report_third(k12, x1, x2, k3, x3) -> None:
    """The third step (0.125 ms) on the realisations run there: the three means on the common realisations,
    the two halving changes (paired s.e.), their ratio against first order's 0.5, and the step limit that first
    order would give, 2·m(0.125) − m(0.25)."""
    common, i12, i3 = np.intersect1d(k12, k3, return_indices=True)
    if len(common) < 2:
        return
    a, b, c = x1[i12], x2[i12], x3[i3]
    n = len(common)
    m = [v.mean() for v in (a, b, c)]
    se = [v.std(ddof=1) / np.sqrt(n) for v in (a, b, c)]

    def ch(u, v):
        return 100 * (v.mean() / u.mean() - 1), 100 * (v - u).std(ddof=1) / np.sqrt(n) / u.mean()
    (c1, e1), (c2, e2) = ch(a, b), ch(b, c)
    lim = 2 * m[2] - m[1]
    lim_se = np.sqrt(4 * se[2] ** 2 + se[1] ** 2)
    print(f"third step, realisations {common.min()}–{common.max()} ({n} at each of 0.5, 0.25, 0.125 ms):")
    print("  means " + ", ".join(f"{x:.4f} ± {e:.4f}" for x, e in zip(m, se)))
    print(f"  halving 0.5 → 0.25 ms {c1:+.2f} ± {e1:.2f} %, 0.25 → 0.125 ms {c2:+.2f} ± {e2:.2f} %; their ratio "
          f"{c2 / c1:.2f} (first order 0.5: the second change would be {c1 / 2:+.2f} %, {(c1 / 2 - c2) / e2:.1f} s.e. "
          "from the measured one)")
    print(f"  the 0.5 ms mean is {100 * (m[0] / m[2] - 1):+.2f} % from the 0.125 ms mean; if the error were first "
          f"order the step limit would be 2·m(0.125) − m(0.25) = {lim:.4f} ± {lim_se:.4f}")


def report_integrator(name, k12, x1, x2, k3, x3, ki, xi) -> None:
    """Another integrator at the scenario's 0.5 ms step against the default (trapezoidal) at 0.5 and 0.125 ms on
    the common realisations (paired changes): is the step effect the integration error?"""
    common, i12, ii = np.intersect1d(k12, ki, return_indices=True)
    if len(common) < 2:
        return
    a, b, x = x1[i12], x2[i12], xi[ii]
    n = len(common)

    def ch(u, v):
        return f"{100 * (v.mean() / u.mean() - 1):+.2f} ± {100 * (v - u).std(ddof=1) / np.sqrt(n) / u.mean():.2f} %"
    print(f"{name} at 0.5 ms, realisations {common.min()}–{common.max()} ({n}): mean {x.mean():.4f} ± "
          f"{x.std(ddof=1) / np.sqrt(n):.4f}; against the default at 0.5 ms {ch(a, x)}, at 0.25 ms {ch(b, x)}")
    c3, j3, jj = np.intersect1d(k3, common, return_indices=True)
    if len(c3) > 1:
        u, v = x3[j3], x[np.searchsorted(common, c3)]
        print(f"  against the default at 0.125 ms ({len(c3)} realisations): "
              f"{100 * (v.mean() / u.mean() - 1):+.2f} ± {100 * (v - u).std(ddof=1) / np.sqrt(len(c3)) / u.mean():.2f} %")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=512, help="realisations per step to run (0: report the merged saves)")
    p.add_argument("--k0", type=int, default=0, help="first realisation index")
    p.add_argument("--chunk", type=int, default=128, help="cars per compiled-loop ensemble")
    p.add_argument("--third", action="store_true",
                   help="run the realisations at the third step only (0.125 ms physics), for the order and limit")
    p.add_argument("--integrator", help="run the realisations at the 0.5 ms step only, with this MuJoCo integrator "
                   "(e.g. RK4), against the scenario's (auto: trapezoidal)")
    p.add_argument("--row", default=LABEL, help=f"the near-sgn row of BB_CASES (default: {LABEL})")
    p.add_argument("--sensors", choices=["ideal", "noisy"], default="ideal",
                   help="ideal (variant fallah) or noisy (variant fallah_noisy) sensors")
    p.add_argument("--save", help="save this run's per-realisation ratios (.npz)")
    p.add_argument("--merge", nargs="*", default=[], help="earlier saves (.npz, globs) to merge into the report")
    a = p.parse_args(argv)
    from suspension_sim.reproductions.fallah import BB_CASES
    if a.row not in BB_CASES:
        print(f"--row: unknown row {a.row!r}; rows: {', '.join(BB_CASES)}", file=sys.stderr)
        return 2
    variant = "fallah" if a.sensors == "ideal" else "fallah_noisy"
    row = f"{a.row}|{variant}"
    print(f"row: {row}")
    rr = dict(label=a.row, variant=variant)
    parts, thirds, others = [], [], []
    for pat in a.merge:
        for f in sorted(glob.glob(pat)):
            z = np.load(f)
            zrow = str(z["row"]) if "row" in z else f"{LABEL}|fallah"  # saves before --row were this row
            if zrow != row:
                print(f"(skipped {f}: row {zrow})")
                continue
            if "x3" in z:
                thirds.append((z["k"], z["x3"]))
            elif "xi" in z:
                others.append((str(z["integrator"]), z["k"], z["xi"]))
            else:
                parts.append((z["k"], z["x1"], z["x2"]))
    if a.n > 0:
        ks = np.arange(a.k0, a.k0 + a.n)
        if a.integrator:
            xi, ci = run_ratios(1.0, a.k0, a.n, a.chunk, a.integrator, **rr)
            print(f"cost: {ci:.4f} CPU-s per realisation at 0.5 ms with {a.integrator}")
            if a.save:
                Path(a.save).parent.mkdir(parents=True, exist_ok=True)
                np.savez(a.save, k=ks, xi=xi, integrator=a.integrator, row=row)
            others.append((a.integrator, ks, xi))
        elif a.third:
            x3, c3 = run_ratios(0.25, a.k0, a.n, a.chunk, **rr)
            print(f"cost: {c3:.4f} CPU-s per realisation at 0.125 ms")
            if a.save:
                Path(a.save).parent.mkdir(parents=True, exist_ok=True)
                np.savez(a.save, k=ks, x3=x3, row=row)
            thirds.append((ks, x3))
        else:
            x1, c1 = run_ratios(1.0, a.k0, a.n, a.chunk, **rr)
            x2, c2 = run_ratios(0.5, a.k0, a.n, a.chunk, **rr)
            print(f"cost: {c1:.4f} CPU-s per realisation at 0.5 ms, {c2:.4f} at 0.25 ms")
            if a.save:
                Path(a.save).parent.mkdir(parents=True, exist_ok=True)
                np.savez(a.save, k=ks, x1=x1, x2=x2, row=row)
            parts.append((ks, x1, x2))
    if not parts:
        print("nothing to report: give --n > 0 or --merge files with both steps", file=sys.stderr)
        return 2
    ks = np.concatenate([q[0] for q in parts])
    x1 = np.concatenate([q[1] for q in parts])
    x2 = np.concatenate([q[2] for q in parts])
    ks, idx = np.unique(ks, return_index=True)  # a realisation saved twice counts once
    if len(idx) < sum(len(q[0]) for q in parts):
        print("(dropped duplicate realisations)")
    x1, x2 = x1[idx], x2[idx]
    report(ks, x1, x2)
    if thirds:
        k3 = np.concatenate([q[0] for q in thirds])
        k3, i3 = np.unique(k3, return_index=True)
        x3 = np.concatenate([q[1] for q in thirds])[i3]
        report_third(ks, x1, x2, k3, x3)
    else:
        k3, x3 = np.array([], int), np.array([])
    for name in sorted({q[0] for q in others}):
        ki = np.concatenate([q[1] for q in others if q[0] == name])
        ki, ii = np.unique(ki, return_index=True)
        report_integrator(name, ks, x1, x2, k3, x3, ki, np.concatenate([q[2] for q in others if q[0] == name])[ii])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
