"""Paper-style figures and the numbers of docs/reproductions/toscano_dumas.md for issue 5 (Fallah; Toscano & Dumas).

    python benchmarks/figures_fallah_toscano.py [--out figures/fallah_toscano]      # runs the scenario files (~ 3 minutes)

Fallah (scenarios/fallah_bump.yaml, fallah_dlc.yaml), passive vs controlled: pitch and pitch rate (their
Fig. 4), body acceleration and displacement (Fig. 5), front-left and rear-right forces with the ±f_max bounds
(Figs. 6, 9), roll and roll rate (Fig. 7), accelerations in the DLC (Fig. 8: roll acceleration, vertical
acceleration above the front-left corner, lateral c.g. acceleration a_y + h·φ̈), and the estimator against the
truth.  Toscano & Dumas (toscano_constant.yaml, toscano_varying.yaml): f̂_k, f̂_b against the truth (Figs. 6, 9),
the estimation error ṽ and the command (Figs. 7, 10), body displacement against the reference model (Figs. 8,
11).  The printed numbers are the table's.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import suspension_sim as ss  # noqa: E402
from suspension_sim.maneuvers_dlc import DLCParams, DoubleLaneChange  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def rms(x):
    return float(np.sqrt(np.mean(np.square(np.asarray(x, float)))))


def red(p, c):
    return f"{100 * (c / p - 1):+.1f} %" if p else "n/a"


def corner(ts, x, y, q):
    base = {"vel": ("body_vel", "pitch_rate", "roll_rate"), "acc": ("body_acc", "pitch_acc", "roll_acc"),
            "pos": ("body_z", "pitch", "roll")}[q]
    return ts[base[0]] + y * ts[base[2]] - x * ts[base[1]]


def fallah(out: Path):
    bump = ss.simulate(str(ROOT / "scenarios" / "fallah_bump.yaml"))
    dlc = ss.simulate(str(ROOT / "scenarios" / "fallah_dlc.yaml"))
    P, C = bump["passive"].ts, bump["fallah"].ts
    fig, ax = plt.subplots(3, 2, figsize=(11, 9), sharex=True)
    for a, (q, lab) in zip(ax.flat, [("pitch", "pitch (rad)"), ("pitch_rate", "pitch rate (rad/s)"),
                                     ("body_acc", "heave acc. (m/s²)"), ("body_z", "heave (m)"),
                                     ("actuator_force_fl", "force FL (N)"), ("actuator_force_rr", "force RR (N)")]):
        a.plot(P.t, P[q], label="passive")
        a.plot(C.t, C[q], label="fallah")
        a.set_ylabel(lab)
        if q.startswith("actuator"):
            a.axhline(6000, color="k", ls=":")
            a.axhline(-6000, color="k", ls=":")
    ax[0, 0].legend()
    fig.suptitle("Fallah: bump at 35 km/h (cf. Figs. 4–6)")
    fig.tight_layout()
    fig.savefig(out / "fallah_bump.png", dpi=110)
    print("## Fallah bump (passive → controlled, RMS change)")
    for q in ("body_acc", "body_z", "pitch", "pitch_rate", "pitch_acc"):
        print(f"- {q}: RMS {rms(P[q]):.4g} → {rms(C[q]):.4g} ({red(rms(P[q]), rms(C[q]))}), "
              f"peak {P[q].abs().max():.4g} → {C[q].abs().max():.4g}")
    Fb = np.max(np.abs(C[[f"actuator_force_{c}" for c in ("fl", "fr", "rl", "rr")]].to_numpy()))
    print(f"- max |force| {Fb:.0f} N")

    P, C = dlc["passive"].ts, dlc["fallah"].ts
    info = dlc["fallah"].info
    mv = DoubleLaneChange(DLCParams(speed=22.2222, start=0.5, cg_height=0.5))
    _, ay = mv.accel(P.t.to_numpy())
    x0, y0 = info["corner_x"][0], info["corner_y"][0]
    fig, ax = plt.subplots(3, 2, figsize=(11, 9), sharex=True)
    rows = [("roll", "roll (rad)"), ("roll_rate", "roll rate (rad/s)"), ("roll_acc", "roll acc. (rad/s²)")]
    for a, (q, lab) in zip(ax[:, 0], rows):
        a.plot(P.t, P[q], label="passive")
        a.plot(C.t, C[q], label="fallah")
        a.set_ylabel(lab)
    ax[0, 1].plot(P.t, corner(P, x0, y0, "acc"), label="passive")
    ax[0, 1].plot(C.t, corner(C, x0, y0, "acc"), label="fallah")
    ax[0, 1].set_ylabel("vert. acc. FL (m/s²)")
    ax[1, 1].plot(P.t, ay + 0.5 * P.roll_acc, label="passive")
    ax[1, 1].plot(C.t, ay + 0.5 * C.roll_acc, label="fallah")
    ax[1, 1].set_ylabel("lateral c.g. acc. (m/s²)")
    for c in ("fl", "rr"):
        ax[2, 1].plot(C.t, C[f"actuator_force_{c}"], label=c)
    ax[2, 1].set_ylabel("force (N)")
    ax[2, 1].legend()
    ax[0, 0].legend()
    fig.suptitle("Fallah: ISO 3888-1 double lane change at 80 km/h (cf. Figs. 7–9)")
    fig.tight_layout()
    fig.savefig(out / "fallah_dlc.png", dpi=110)
    print("## Fallah DLC")
    for q in ("roll", "roll_rate", "roll_acc"):
        print(f"- {q}: RMS {rms(P[q]):.4g} → {rms(C[q]):.4g} ({red(rms(P[q]), rms(C[q]))}), "
              f"peak {P[q].abs().max():.4g} → {C[q].abs().max():.4g}")
    ca = [np.stack([corner(T, x, y, "acc") for x, y in zip(info["corner_x"], info["corner_y"])]) for T in (P, C)]
    print(f"- vertical acc. above the corners: RMS {rms(ca[0]):.4g} → {rms(ca[1]):.4g} ({red(rms(ca[0]), rms(ca[1]))})")
    lp, lc = ay + 0.5 * P.roll_acc, ay + 0.5 * C.roll_acc
    print(f"- lateral c.g. acc. a_y + h·φ̈: RMS {rms(lp):.4g} → {rms(lc):.4g}; heave at the c.g.: "
          f"{rms(P.body_acc):.3g} / {rms(C.body_acc):.3g}")

    # estimator vs truth (bump, front-left corner)
    C = bump["fallah"].ts
    fig, ax = plt.subplots(3, 1, figsize=(9, 8), sharex=True)
    for a, (sig, truth, lab) in zip(ax, [("ctrl.zs_hat.0", corner(C, x0, y0, "pos"), "z_s (m)"),
                                         ("ctrl.vs_hat.0", corner(C, x0, y0, "vel"), "ż_s (m/s)"),
                                         ("ctrl.dv_hat.0", C["travel_rate_fl"], "Δ̇ (m/s)")]):
        a.plot(C.t, truth, label="truth")
        a.plot(C.t, C[sig], "--", label="estimate")
        a.set_ylabel(lab)
        print(f"- estimate {lab}: RMS error {rms(C[sig] - truth):.3g} ({100 * rms(C[sig] - truth) / rms(truth):.1f} % of RMS)")
    ax[0].legend()
    fig.suptitle("Fallah estimator, front-left corner, bump")
    fig.tight_layout()
    fig.savefig(out / "fallah_estimator.png", dpi=110)


def toscano(out: Path):
    for name, kt, bt in (("toscano_constant", lambda t: 15000 + 0 * t, lambda t: 1500 + 0 * t),
                         ("toscano_varying", lambda t: 15000 + 5000 * np.sin(3 * t), lambda t: 1500 + 500 * np.sin(4 * t))):
        r = ss.simulate(str(ROOT / "scenarios" / f"{name}.yaml"))
        C, U, R = r["controlled"].ts, r["uncontrolled"].ts, r["reference"].ts
        fig, ax = plt.subplots(3, 2, figsize=(11, 9), sharex=True)
        ax[0, 0].plot(C.t, C["ctrl.fk_hat"], label="estimate")
        ax[0, 0].plot(C.t, kt(C.t), "k--", label="truth")
        ax[0, 0].set_ylabel("f̂_k (N/m)")
        ax[0, 0].legend()
        ax[0, 1].plot(C.t, C["ctrl.fb_hat"])
        ax[0, 1].plot(C.t, bt(C.t), "k--")
        ax[0, 1].set_ylabel("f̂_b (N·s/m)")
        ax[1, 0].plot(C.t, C["ctrl.v_err"])
        ax[1, 0].set_ylabel("ṽ_M (m/s)")
        ax[1, 1].plot(C.t, C["command"], label="command")
        ax[1, 1].plot(C.t, C["actuator_force"], label="force")
        ax[1, 1].set_ylabel("F_m (N)")
        ax[1, 1].legend()
        for a, q in ((ax[2, 0], "body_z"), (ax[2, 1], "body_vel")):
            a.plot(R.t, R[q], "k", label="reference")
            a.plot(C.t, C[q], "--", label="controlled")
            a.plot(U.t, U[q], ":", label="uncontrolled")
            a.set_ylabel(q)
        ax[2, 0].legend()
        fig.suptitle(f"Toscano & Dumas: {name.split('_')[1]} k_M, b_M (cf. Figs. 6–11)")
        fig.tight_layout()
        fig.savefig(out / f"{name}.png", dpi=110)
        last = C[C.t > C.t.iloc[-1] - 3]
        print(f"## {name}")
        print(f"- f̂_k (last 3 s) {last['ctrl.fk_hat'].mean():.0f}, f̂_b {last['ctrl.fb_hat'].mean():.0f}")
        for q in ("body_z", "body_vel", "travel"):
            print(f"- NRMSE {q} vs reference: controlled {rms(C[q] - R[q]) / rms(R[q]):.3f}, "
                  f"uncontrolled {rms(U[q] - R[q]) / rms(R[q]):.3f}")
        print(f"- max current {C[['act.current_push', 'act.current_pull']].to_numpy().max():.1f} A")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="figures/fallah_toscano")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    fallah(out)
    toscano(out)
    print(f"figures in {out}")


if __name__ == "__main__":
    main()
