"""Vallurupalli (PhD thesis, 1996), Ch. 3–7 (page: docs/reproductions/vallurupalli_thesis_1996.md).

Each item runs the chapter's scenario files at the thesis's timing (load step at 20 s, removed at 40 s; braking
at 9 s).  The thesis gives figures without tables, so "paper" is its text or a value read off an axis.
Every controller claim is set beside the passive (or literal / non-adaptive) baseline on the same scenario.
"""
from __future__ import annotations

import numpy as np

from ..errors import SimulationDiverged
from .framework import SOURCES, Claim, Item, ItemOutput, Source, md_table

G = 9.81


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def win(ts, a, b):
    t = ts.t.to_numpy()
    return (t >= a) & (t < b)


def mean(ts, col, a, b):
    return float(np.mean(ts[col].to_numpy()[win(ts, a, b)]))


HALF_NOTE = ("Step halving for the thesis halves the physics step only; the control step stays the scenario's "
             "(the thesis's 0.01 s in Ch. 3, 4 and 7; 1 ms in Ch. 6): the laws are designed at that sampling "
             "interval (docs/reproductions/vallurupalli_thesis_1996.md gives what a 0.005 s control step does).")


def run_each(ctx, variants, label, diverged=None):
    """Run every variant on its own (the thesis controllers need one parameter set per ensemble).  The
    step-halving run halves the physics step only: the control step stays the thesis's 0.01 s, because the
    discrete designs (ZOH model, delay in samples, per-step RLS Q, κ) are laws at that sampling interval,
    not discretisations of a continuous law that converge as it shrinks (see the page for what a 0.005 s
    control step does).  With a dict ``diverged``, a variant that stops on the divergence check goes there
    (name → SimulationDiverged) instead of raising: the thesis's printed laws may run away."""
    out = {}
    for k, sc in variants.items():
        sc.sim.control_dt = sc.sim.control_dt / ctx.step_factor  # the scenario's own control step
        try:
            out.update(ctx.run({k: sc}, label=label))
        except SimulationDiverged as e:  # a printed law that runs away is a result, not a crash
            if diverged is None:
                raise
            diverged[k] = e.locate(label, k)
    return out


def diverged_text(e) -> str:
    """The divergence stop as a table cell: time, the body's state, the hint."""
    st = ", ".join(f"{k} = {v:.3g}" for k, v in e.state.items() if isinstance(v, float))
    return f"stopped at t = {e.time:.2f} s ({st}): {e.hint}"


# ---- Ch. 3 ------------------------------------------------------------------------------------------------

def ch3_load_step(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    res = run_each(ctx, ctx.variants("thesis_ch3_load_step"), "thesis_ch3_load_step")
    ts = {v: r.ts for v, r in res.items()}
    ref = ts["mrac_thetad"]["ctrl.ref_x"].to_numpy()
    z = {v: mean(t, "body_z", 30, 40) for v, t in ts.items()}
    f = {v: mean(t, "actuator_force", 30, 40) for v, t in ts.items()}
    follow = {v: rms((t.body_z.to_numpy() - ref)[win(t, 5, 20)]) for v, t in ts.items()}
    after = [mean(ts["mrac_thetad"], "body_z", 20 + 2 * k, 22 + 2 * k) for k in range(5)]
    th_nom = np.array([ts["mrac_thetad"][f"ctrl.theta.{k}"].iloc[0] for k in range(5)])
    ws = ts["mrac_thetad_wrong_start"]
    th_ws = np.array([[ws[f"ctrl.theta.{k}"].iloc[i] for k in range(5)] for i in (0, int(np.searchsorted(ws.t, 20.0)) - 1)])
    rel0, rel20 = np.abs(th_ws[0] / th_nom - 1), np.abs(th_ws[1] / th_nom - 1)
    r1, a0, wm2, M = th_nom[0] + 2.0, 2.0, 20.0, 250.0
    x_pred = r1 * (-150 * G) / (M * a0 * wm2)
    # Fig. 3.7 (body acceleration) on this run: before the load (adapted), under it, after it; the 10 ms log samples
    # (taken at the control instants: they under-read the controlled cars' total acceleration by ≈ 10 %, the page)
    acc_w = ((5, 20), (20, 40), (40, 60))
    acc = {v: [rms(t.body_acc.to_numpy()[win(t, a, b)]) for a, b in acc_w] for v, t in ts.items()}
    acc_rel = {v: [a_ / p_ for a_, p_ in zip(acc[v], acc["passive"])] for v in ("mrac_thesis", "mrac_thetad")}

    def acc_txt(v):
        return " / ".join(f"{a_:.3f}" for a_ in acc[v])
    claims = [
        Claim("passive sag under +150 kg (mean 30–40 s)", "sags (Fig. 3.6); m·g/K = 0.294 m",
              f"{z['passive']:.3f} m", "reproduced" if abs(z["passive"] + 0.294) < 0.015 else "not"),
        Claim("adaptive keeps its level — thesis structure as printed (P1 = A_m, no static-load term)",
              "keeps its level, re-adapts within a few seconds",
              f"{z['mrac_thesis']:.2f} m (closed-loop static gain r1·d/(M·a0·ω_m²) = {x_pred:.2f} m); "
              f"force {f['mrac_thesis']:.0f} N", "not",
              "the printed regulator has no constant term: A·R + b0·S = A0·A_m fixes its static stiffness"),
        Claim("same with our static-load parameter θ_d and P1 = (s + 20)² (variant `mrac_thetad`, not in the thesis)", "as above",
              f"{z['mrac_thetad']:.4f} m; 2-s means after the step " + ", ".join(f"{a * 100:.1f}" for a in after) + " cm",
              "partly", "an addition; recovery within 1 cm takes ≈ 6–8 s"),
        Claim("mean upward actuator force (30–40 s)", "≈ 1500 N (150·g = 1471 N)",
              f"printed law {f['mrac_thesis']:.0f} N; variant `mrac_thetad` {f['mrac_thetad']:.0f} N",
              "not" if abs(f["mrac_thesis"] - 1471) > 150 else "reproduced",
              ("the variant (our addition) gives it: " + ("reproduced" if abs(f["mrac_thetad"] - 1471) < 150 else "not"))),
        Claim("model following before the step, RMS(body − reference) 5–20 s", "tracks within 10 s",
              f"thesis structure {follow['mrac_thesis'] * 1000:.2f} mm, `mrac_thetad` {follow['mrac_thetad'] * 1000:.2f} mm; "
              f"passive {follow['passive'] * 1000:.1f} mm", "reproduced"
              if max(follow["mrac_thesis"], follow["mrac_thetad"]) < 0.2 * follow["passive"] else "not",
              "by the nominal design this run starts from (the known-parameter design held follows as well: item "
              "ch3_adaptation, where the tracking from wrong gains is the adaptation's)"),
        Claim("adaptation from wrong initial gains, variant `mrac_thetad_wrong_start` (every Θ entry ±30 %; the thesis "
              "gives no values; the printed law from a wrong start: item ch3_adaptation)",
              "gains updated from their initial values (Fig. 3.8)",
              f"largest Θ error {rel0.max():.0%} at 0 s → {rel20.max():.1%} at 20 s; following "
              f"{follow['mrac_thetad_wrong_start'] * 1000:.2f} mm (nominal start {follow['mrac_thetad'] * 1000:.2f} mm)",
              "not" if rel20.max() > 0.5 * rel0.max() else "reproduced",
              "γ = 1 (rate ≈ γ·b0 = 0.004 s⁻¹), and the fast θ_d law (γ_d = 20000, ours) is a high-gain integral "
              "action on ε that follows with any Θ (even Θ = 0): see item ch3_adaptation, where Θ does adapt"),
        Claim("body acceleration (Fig. 3.7), RMS 5–20 / 20–40 / 40–60 s (before / under / after the load; 10 ms samples)",
              "higher before adaptation, then very low against passive",
              f"printed law {acc_txt('mrac_thesis')} m/s², `mrac_thetad` {acc_txt('mrac_thetad')}, wrong start "
              f"{acc_txt('mrac_thetad_wrong_start')}, passive {acc_txt('passive')}; against passive: printed "
              + " / ".join(f"{r_:.2f}×" for r_ in acc_rel["mrac_thesis"]) + ", `mrac_thetad` "
              + " / ".join(f"{r_:.2f}×" for r_ in acc_rel["mrac_thetad"]),
              "partly" if acc_rel["mrac_thesis"][0] < 0.2 and acc_rel["mrac_thetad"][0] < 0.2 else "not",
              "low against passive before the load with either law; under and after it only with our θ_d (the printed "
              "law's sink to metres below level shakes the body after each change of load); no pre-adaptation excess: "
              "the runs start from the nominal design (from a wrong start: item ch3_adaptation, where the known-"
              "parameter design is as low); the low level is the skyhook design's, not the adaptation's"),
    ]
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True)
    for v, s in (("passive", "g-"), ("mrac_thesis", "m-"), ("mrac_thetad", "r-"), ("mrac_thetad_wrong_start", "b--")):
        ax[0].plot(ts[v].t, ts[v].body_z, s, lw=0.7, label=v)
        ax[1].plot(ts[v].t, ts[v].actuator_force, s, lw=0.7)
    ax[0].plot(ts["mrac_thetad"].t, ref, "k:", lw=0.7, label="reference")
    ax[0].set_ylim(-0.6, 0.15)
    ax[0].set_ylabel("body x (m) [mrac_thesis off scale: −3 m]")
    ax[0].legend(fontsize=7, ncol=3)
    ax[1].set_ylabel("actuator force (N)")
    ax[1].set_ylim(-3000, 4000)
    for k in range(5):
        ax[2].plot(ws.t, ws[f"ctrl.theta.{k}"] / th_nom[k] - 1, lw=0.8, label=f"Θ{k}")
    ax[2].set_ylabel("Θ / nominal − 1 (wrong start)")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(fontsize=7, ncol=5)
    fig.suptitle("Thesis Ch. 3 (Figs. 3.6–3.10): +150 kg at 20–40 s", fontsize=9)
    fig.tight_layout()
    key = {"passive_sag": (z["passive"], 0.01), "thesis_sag": (z["mrac_thesis"], 0.01),
           "thesis_force": (f["mrac_thesis"], 10.0),
           "mrac_level": (z["mrac_thetad"], 0.01), "mrac_force": (f["mrac_thetad"], 10.0),
           "follow_mrac": (follow["mrac_thetad"], 1e-5), "theta_err_20s": (float(rel20.max()), 0.01)}
    # the rows' other numbers: the level 2-s means after the step, the printed law's and the wrong start's following
    for k_, a_ in enumerate(after):
        key[f"level_after_step_{2 * k_}_{2 * k_ + 2}s"] = (a_, 1e-3)
    key["follow_thesis"] = (follow["mrac_thesis"], 1e-5)
    key["follow_wrong_start"] = (follow["mrac_thetad_wrong_start"], 1e-5)
    for v in ("passive", "mrac_thesis", "mrac_thetad"):  # the body-acceleration row (floor 0.01 m/s²)
        for (a, b), a_ in zip(acc_w, acc[v]):
            key[f"acc_{v}_{a}_{b}"] = (a_, 0.01)
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE])


def theta_star(M, K, C, Kd=5000.0, Cd=250.0, a0=2.0, Mm=250.0, Km=5000.0, Dm=6000.0):
    """The matching Θ* = (r1 − a0, s0, s1, t0, t1) of the Ch. 3 regulator for the plant (M, K, C) when the
    fail-safe feedforward of Eq. 3.6 uses the nominal K*, C* (Kd, Cd): the Diophantine design for the true
    plant, with T corrected by the feedforward mismatch, T' = T* − (s + r1)(ΔC·s + ΔK) (its ΔC·s² part is
    not in the structure and is left out), and v = dΘ*/da0: the observer polynomial A0 = s + a0 is free,
    every a0 gives the same reference following, so the matching gains form a line Θ*(a0)."""
    wm2, zw2 = Km / Mm, Dm / Mm
    r1 = a0 + zw2 - C / M
    s0 = M * (wm2 + a0 * zw2 - K / M - r1 * C / M)
    s1 = M * (a0 * wm2 - r1 * K / M)
    dK, dC = K - Kd, C - Cd
    th = np.array([r1 - a0, s0, s1, M * wm2 - dK - r1 * dC, a0 * M * wm2 - r1 * dK])
    v = np.array([0.0, M * zw2 - C, M * wm2 - K, -dC, M * wm2 - dK])
    return th, v


def nearest_star(th, star, v, scale):
    """Distance (scaled by the nominal |Θ|) from Θ to the line Θ* + c·v, the nearest point and its a0 shift."""
    d, vs = (th - star) / scale, v / scale
    c = float(d @ vs / (vs @ vs))
    return float(np.linalg.norm(d - c * vs)), star + c * v, c


def ch3_adaptation(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    dv = {}
    res = run_each(ctx, ctx.variants("thesis_ch3_adaptation"), "thesis_ch3_adaptation", diverged=dv)
    if set(dv) - {"drift_adaptive"}:  # only the printed law on the drifting plant may run away
        raise next(e for k, e in dv.items() if k != "drift_adaptive")
    ts = {v: r.ts for v, r in res.items()}
    ad, na = ts["adaptive"], ts["nonadaptive"]
    ref = ad["ctrl.ref_x"].to_numpy()
    t = ad.t.to_numpy()
    edges = (0, 5, 10, 20, 40, 60)

    def fol(name, a, b, r=ref):
        x = ts[name]
        return rms((x.body_z.to_numpy() - r)[win(x, a, b)])

    star, v = theta_star(250.0, 5000.0, 250.0)
    scale = np.abs(star)
    th = np.stack([ad[f"ctrl.theta.{k}"].to_numpy() for k in range(5)], 1)
    at = {T: int(min(np.searchsorted(t, T), len(t) - 1)) for T in (0, 10, 20, 60)}
    dist = {T: nearest_star(th[i], star, v, scale) for T, i in at.items()}
    d0, dend = dist[0][0], dist[60][0]
    rel_end = th[at[60]] / dist[60][1] - 1
    # excitation: eigenvalues of the normalised information matrix of the scaled regressor (last 30 s)
    m = win(ad, 30, 60)
    psi = np.stack([ad[f"ctrl.phi.{k}"].to_numpy()[m] for k in range(5)], 1) * scale
    info = (psi.T / np.sum(psi ** 2, 1)) @ psi / len(psi)
    lam, vec = np.linalg.eigh(info)
    f = {k: [fol(k, a, b) for a, b in zip(edges[:-1], edges[1:])] for k in ("adaptive", "nonadaptive", "passive", "known")
         if k in ts}
    ref_d = ts["drift_adaptive_thetad"]["ctrl.ref_x"].to_numpy()
    fd = {k: fol(k, 10, 60, ref_d) for k in ("drift_adaptive_thetad", "drift_nonadaptive_thetad", "drift_passive")}
    lev = {k: mean(ts[k], "body_z", 30, 50) for k in ("drift_adaptive_thetad", "drift_nonadaptive_thetad", "drift_passive")}
    if "drift_adaptive" in dv:
        e_p = dv["drift_adaptive"]
        lit_p, stop_p, lev_p = diverged_text(e_p), float(e_p.time), float("nan")
    else:
        lev_p, stop_p = mean(ts["drift_adaptive"], "body_z", 30, 50), float("inf")
        lit_p = (f"mean level 30–50 s {lev_p * 1000:.0f} mm, at 60 s {float(ts['drift_adaptive'].body_z.iloc[-1]) * 1000:.0f} "
                 f"mm; RMS(body − reference) 10–60 s {fol('drift_adaptive', 10, 60, ref_d) * 1000:.0f} mm")
    th_only = fol("thetad_only", 5, 60)
    acc = {k: [rms(ts[k].body_acc.to_numpy()[win(ts[k], a, b)]) for a, b in ((0, 5), (40, 60))]
           for k in ("adaptive", "nonadaptive", "passive")}
    # plant ≠ design from the nominal start: C halved before the start
    ref_b = ts["blowoff_adaptive"]["ctrl.ref_x"].to_numpy()
    fb = {k: [fol(k, a, b, ref_b) for a, b in ((0, 10), (40, 60))] for k in ("blowoff_adaptive", "blowoff_nonadaptive")}
    star_b, v_b = theta_star(250.0, 5000.0, 125.0)
    bo = ts["blowoff_adaptive"]
    thb = np.stack([bo[f"ctrl.theta.{k}"].to_numpy() for k in range(5)], 1)
    db = [nearest_star(thb[i], star_b, v_b, scale)[0] for i in (0, len(thb) - 1)]
    ok = f["adaptive"][-1] < 0.1 * f["adaptive"][0] and f["adaptive"][-1] < 0.1 * f["nonadaptive"][-1]
    claims = [
        Claim("adaptation from wrong initial gains (every Θ entry 30 % off; printed structure and law, γ = 300)",
              "gains move from their initial values (Fig. 3.8); stable tracking within 10 s",
              "RMS(body − reference) per window 0–5, 5–10, 10–20, 20–40, 40–60 s: adaptive "
              + ", ".join(f"{x * 1000:.2f}" for x in f["adaptive"]) + " mm; adaptation off (same start) "
              + ", ".join(f"{x * 1000:.2f}" for x in f["nonadaptive"]) + " mm; "
              + (("known parameters (the matching design, adaptation off) "
                  + ", ".join(f"{x * 1000:.2f}" for x in f["known"]) + " mm; ") if "known" in f else "")
              + f"passive {f['passive'][-1] * 1000:.1f} mm",
              "reproduced" if ok else "not",
              "within 10 s the error is 2.2× smaller, below 0.2 mm from ≈ 15 s on"
              + ("; from 10–20 s on at or below the known-parameter case's (the continuous design is not the best "
                 "gain set for the loop sampled at 0.01 s; the adaptation also takes up that mismatch)"
                 if "known" in f else "")),
        Claim("Θ moves toward the matching gains Θ*", "updated to \"some required values\" (Fig. 3.8)",
              f"scaled distance to the matching line Θ*(a0) {d0:.2f} at 0 s → {dist[10][0]:.2f} at 10 s → "
              f"{dend:.2f} at 60 s; at 60 s per entry (r1 − a0, s0, s1, t0, t1) "
              + ", ".join(f"{x:+.0%}" for x in rel_end),
              "partly", "the rest lies in a weakly excited direction: eigenvalues of the normalised information "
              "matrix " + ", ".join(f"{x:.1e}" for x in lam) + "; the smallest is the observer pole a0 "
              "(exactly unidentifiable: every a0 gives the same following)"),
        Claim("body acceleration (Fig. 3.7), RMS 0–5 s / 40–60 s (sampled at the 10 ms log step)",
              "higher before adaptation, then very low compared with passive",
              f"adaptive {acc['adaptive'][0]:.3f} / {acc['adaptive'][1]:.3f} m/s², adaptation off "
              f"{acc['nonadaptive'][0]:.3f} / {acc['nonadaptive'][1]:.3f}, passive {acc['passive'][0]:.2f} / "
              f"{acc['passive'][1]:.2f}", "partly" if acc["adaptive"][1] < 0.2 * acc["passive"][1] else "not",
              "low against passive from the start: the 30 % wrong gains already isolate (no pre-adaptation excess)"),
        Claim("plant ≠ design, nominal start: damper blown off (C halved from 0 s), printed structure",
              "adapts to the reference under unknown parameter changes",
              f"RMS(body − reference) 0–10 s / 40–60 s: adaptive {fb['blowoff_adaptive'][0] * 1000:.2f} / "
              f"{fb['blowoff_adaptive'][1] * 1000:.2f} mm, adaptation off {fb['blowoff_nonadaptive'][0] * 1000:.2f} / "
              f"{fb['blowoff_nonadaptive'][1] * 1000:.2f} mm; distance to Θ*(C = 125) {db[0]:.3f} → {db[1]:.3f}",
              "reproduced" if fb["blowoff_adaptive"][1] < 0.2 * fb["blowoff_nonadaptive"][1] else "not",
              "Θ* from the Diophantine design for the true plant (the ΔC·s² part of the feedforward mismatch is "
              "outside the structure)"),
        Claim("mode I stiffness/damping drifts (K −20 % over 10–50 s, C −50 % at 30 s: sizes ours), the printed "
              "law (variant `drift_adaptive`)", "robust to K(t), C(t) (Figs. 2.7–2.8, 3.6)",
              lit_p + f" (passive follows to {fd['drift_passive'] * 1000:.1f} mm)",
              "reproduced" if np.isfinite(lev_p) and abs(lev_p) < 0.03 else "not",
              "unstable: a growing oscillation once the spring has softened and the damper halved (3× the passive "
              "car's following error); at half the physics step it reaches the 5 m divergence stop at 49.6 s, at the "
              "shipped step it is still finite at 60 s: the runaway's timing is not converged, so it is no key number"),
        Claim("same with our θ_d and P1 = (s + 20)² (named variants `drift_*_thetad`, not in the thesis)",
              "robust to K(t), C(t)",
              f"RMS(body − reference) 10–60 s: adaptive {fd['drift_adaptive_thetad'] * 1000:.2f} mm, adaptation off "
              f"{fd['drift_nonadaptive_thetad'] * 1000:.2f} mm, passive {fd['drift_passive'] * 1000:.1f} mm; mean level "
              f"30–50 s {lev['drift_adaptive_thetad'] * 1000:.1f} / {lev['drift_nonadaptive_thetad'] * 1000:.1f} / "
              f"{lev['drift_passive'] * 1000:.0f} mm",
              "partly", "through our θ_d; the error is the level lag of θ_d, and adapting Θ does not change it"),
        Claim("why the load-step scenario's wrong start never adapted", "—",
              f"all gains zero, adaptation off, fast θ_d (γ_d = 20000): following {th_only * 1000:.2f} mm",
              "n.a.", "the fast static-load law is a high-gain integral action on ε that follows with any Θ"),
    ]
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True)
    for k, s_ in (("passive", "g-"), ("nonadaptive", "b-"), ("adaptive", "r-")):
        e = ts[k].body_z.to_numpy() - ref
        ax[0].plot(ts[k].t, ts[k].body_z * 1000, s_, lw=0.6, label=k)
        ax[1].semilogy(ts[k].t, np.abs(e) * 1000 + 1e-4, s_, lw=0.5)
    ax[0].plot(t, ref * 1000, "k:", lw=0.8, label="reference")
    ax[0].set_ylim(-25, 25)
    ax[0].set_ylabel("body x (mm)")
    ax[0].legend(fontsize=7, ncol=4)
    ax[1].set_ylabel("|body − reference| (mm)")
    ax[1].set_ylim(1e-3, 100)
    for k in range(5):
        ax[2].plot(t, th[:, k] / star[k] - 1, lw=0.8, label=("r1−a0", "s0", "s1", "t0", "t1")[k])
    ax[2].set_ylabel("Θ / Θ*(a0 = 2) − 1")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(fontsize=7, ncol=5)
    fig.suptitle("Thesis Ch. 3 (Figs. 3.6–3.9): adaptation from 30 % wrong gains, printed structure", fontsize=9)
    fig.tight_layout()
    key = {"follow_adaptive_40_60": (f["adaptive"][-1], 1e-5), "follow_nonadaptive_40_60": (f["nonadaptive"][-1], 1e-5),
           "follow_adaptive_0_5": (f["adaptive"][0], 1e-5), "theta_dist_60": (dend, 0.05),
           "drift_follow_adaptive": (fd["drift_adaptive_thetad"], 1e-5),
           "blowoff_follow_adaptive": (fb["blowoff_adaptive"][1], 1e-5)}
    if "known" in f:
        key["follow_known_40_60"] = (f["known"][-1], 1e-5)
    # the other rows' numbers: the body acceleration row (10 ms samples), the baselines of the blow-off and drift rows,
    # the blow-off's Θ distance
    for k_ in ("adaptive", "nonadaptive"):
        key[f"acc_{k_}_0_5"] = (acc[k_][0], 0.01)
        key[f"acc_{k_}_40_60"] = (acc[k_][1], 0.01)
    key["blowoff_follow_nonadaptive"] = (fb["blowoff_nonadaptive"][1], 1e-5)
    key["drift_follow_nonadaptive"] = (fd["drift_nonadaptive_thetad"], 1e-5)
    key["blowoff_theta_dist_end"] = (db[1], 0.05)
    # the following row's other windows (issue 12 item 3: the page gives each one's change on halving)
    for k_ in ("adaptive", "nonadaptive"):
        for (a_, b_), x_ in zip(zip(edges[:-1], edges[1:]), f[k_]):
            key.setdefault(f"follow_{k_}_{a_}_{b_}", (x_, 1e-5))
    key["blowoff_follow_adaptive_0_10"] = (fb["blowoff_adaptive"][0], 1e-5)
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE])


def ch3_dirt(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    dv = {}
    res = run_each(ctx, ctx.variants("thesis_ch3_dirt"), "thesis_ch3_dirt", diverged=dv)
    a, p = res["mrac_thetad"].ts, res["passive"].ts
    sa, sp = a[a.t > 8], p[p.t > 8]
    fs = 1.0 / float(a.t.iloc[1] - a.t.iloc[0])
    f, Pref = welch(sa["ctrl.ref_acc"].to_numpy(), fs=fs, nperseg=8192)
    _, Pa = welch(sa.body_acc.to_numpy(), fs=fs, nperseg=8192)
    _, Pp = welch(sp.body_acc.to_numpy(), fs=fs, nperseg=8192)
    bands = ((0.25, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 8.0))

    def ratio(P, lo, hi):
        s_ = (f >= lo) & (f < hi)
        return float(np.mean(P[s_]) / np.mean(Pref[s_]))

    ra = [ratio(Pa, *b) for b in bands]
    rp = [ratio(Pp, *b) for b in bands]
    n = res["mrac_thetad_nonadaptive"].ts
    _, Pn = welch(n[n.t > 8].body_acc.to_numpy(), fs=fs, nperseg=8192)
    rn = [ratio(Pn, *b) for b in bands]
    za, zp, zn = mean(a, "body_z", 8, 1e9), mean(p, "body_z", 8, 1e9), mean(n, "body_z", 8, 1e9)

    def follow(ts):
        m = (ts.t > 8).to_numpy()
        return float(np.sqrt(np.mean((ts.body_z.to_numpy()[m] - a["ctrl.ref_x"].to_numpy()[m]) ** 2)))

    fa, fn = follow(a), follow(n)
    dip = float(np.min(a.body_z.to_numpy()[win(a, 0, 3)]))
    closer = all(abs(np.log10(x)) < abs(np.log10(y)) for x, y in zip(ra[1:3], rp[1:3]))
    def literal(name):  # (text, stop time) of a printed-law variant: its divergence stop, or its level
        if name in dv:
            return diverged_text(dv[name]), float(dv[name].time)
        t_ = res[name].ts
        return f"ran to the end; mean body x after 8 s {mean(t_, 'body_z', 8, 1e9) * 1000:.0f} mm", float("inf")

    lit, t_stop = literal("mrac_thesis")
    lit_off, t_stop_off = literal("mrac_thesis_nonadaptive")
    claims = [
        Claim("mode II, the thesis's law as printed (scenario default `mrac_thesis`: P1 = A_m, no static-load term, "
              "nominal Θ)", "keeps the level, follows the reference (Figs. 3.11–3.14)", lit, "not",
              "the printed regulator has no constant term (see ch3_load_step): the unknown +100 kg and the softer "
              "spring's lost share of the static load pull the body down until the run's divergence stop"),
        Claim("the printed law with the Θ adaptation off (`mrac_thesis_nonadaptive`: γ = 0, nominal Θ): the "
              "baseline of the row above", "(adaptation is what keeps the level)", lit_off,
              "n.a.", f"baseline; stop time with adaptation {t_stop:.2f} s, without {t_stop_off:.2f} s: no Θ of the "
              "printed regulator (no constant term) holds a constant load"),
        Claim("mode II (+40 % M, −10 % K, C from 0 s): passive static deflection; variant `mrac_thetad` (our θ_d, "
              "P1 = (s + 20)², not in the thesis) keeps the level",
              "passive sags; adaptive shows no static deflection (Fig. 3.11)",
              f"mean body x after 8 s: passive {zp * 1000:.0f} mm, adaptive {za * 1000:.1f} mm (dip {dip * 1000:.0f} mm "
              "in the first 3 s)", "reproduced" if zp < -0.2 and abs(za) < 0.01 else "not",
              "the level through our θ_d (the printed law sinks, row above)"),
        Claim("body-acc PSD / reference PSD per octave 0.25–8 Hz", "adaptive follows the reference closely except "
              "at very low frequency (Figs. 3.12–3.13)", "adaptive " + ", ".join(f"{x:.2f}" for x in ra)
              + "; passive " + ", ".join(f"{x:.3g}" for x in rp),
              "reproduced" if closer else "not",
              "adaptive within 0.45–0.7× of the reference (it isolates more than the reference at the 0.01 s step); "
              "no low-frequency deviation after 8 s"),
        Claim("the Θ adaptation is what follows: baseline with adaptation off (γ = 0, nominal Θ, θ_d kept)",
              "adapts to the unknown mode II parameters (Sec. 3.4)",
              f"adaptation off: level {zn * 1000:.1f} mm, RMS(body − reference) {fn * 1000:.2f} mm (adaptive "
              f"{fa * 1000:.2f}), PSD / reference " + ", ".join(f"{x:.2f}" for x in rn),
              "not" if abs(np.log10(rn[1] / ra[1])) < np.log10(1.5) and fn < 1.5 * fa else "reproduced",
              "the baseline follows as well: the nominal design plus our θ_d do it, the Θ adaptation adds nothing "
              "measurable"),
    ]
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 6.0))
    ax[0].plot(p.t, p.body_z, "g-", lw=0.5, label="passive")
    ax[0].plot(a.t, a.body_z, "r-", lw=0.5, label="mrac_thetad (ours)")
    ax[0].plot(a.t, a["ctrl.ref_x"], "k:", lw=0.5, label="reference")
    ax[0].set_ylabel("body x (m)")
    ax[0].legend(fontsize=7, ncol=3)
    for P, s_, lab in ((Pref, "k-", "reference"), (Pp, "g-", "passive"), (Pa, "r-", "mrac_thetad (ours)")):
        ax[1].loglog(f[1:], P[1:], s_, lw=0.7, label=lab)
    ax[1].set_xlim(0.2, 10)
    ax[1].set_ylim(1e-5, 3)
    ax[1].set_xlabel("frequency (Hz)")
    ax[1].set_ylabel("body acc PSD (m²/s⁴/Hz)")
    ax[1].legend(fontsize=7)
    fig.suptitle("Thesis Ch. 3 (Figs. 3.11–3.14): dirt road, mode II unknown to the controller;\nthe printed law "
                 + (f"stopped at {t_stop:.1f} s (sinks)" if np.isfinite(t_stop) else "ran"), fontsize=9)
    fig.tight_layout()
    key = {"thesis_stop_time": (t_stop, 0.1), "thesis_nonadaptive_stop_time": (t_stop_off, 0.1), "passive_level": (zp, 0.01), "mrac_level": (za, 0.01), "ratio_res": (ra[1], 0.1), "ratio_hi": (ra[3], 0.1),
           "follow_adaptive": (fa, 1e-3), "follow_nonadaptive": (fn, 1e-3), "nonadaptive_level": (zn, 0.01),
           "mrac_dip": (dip, 0.01)}
    for i_, (lo_, hi_) in enumerate(bands):  # every band of the PSD-ratio rows (adaptive, passive, adaptation off)
        for n_, r_ in (("adaptive", ra), ("passive", rp), ("nonadaptive", rn)):
            key[f"psd_ratio_{n_}_{lo_:g}_{hi_:g}Hz"] = (r_[i_], 0.1)
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE])


# ---- Ch. 4 ------------------------------------------------------------------------------------------------

# perturbed runs of the chaotic variant mrac_kappa_q (ensemble mean and standard error): 256 per step, so that the
# standard error of the force median's change on halving (≈ 1 %) can bound the 2 % rule (64 gave ≈ 2.3 %)
CH4_REALISATIONS = 256
CH4_CHUNK = 32  # realisations per ensemble run
CH4_PRINTED_REALISATIONS = 4  # the same perturbations on the printed law (it is not chaotic: a check, not a mean)
CH4_PERTURBATION = 1e-4  # realisation k: first sine amplitude × (1 + k·1e-4), i.e. +2e-6·k m
# the realisations run to the end of the load step: every ensemble number is read before 40 s (level and force
# 30–40 s, following 1.5–20 s, bursts 20–40 s), so the 20 s after it (a third of the item's largest cost) is not run
CH4_ENSEMBLE_S = 40.0


def _ch4_theta(ts):
    return ts[[c for c in ts.columns if c.startswith("ctrl.theta.")]].to_numpy()


def _ch4_stats(ts):
    """(level 30–40 s, mean force 30–40 s, RMS(body − ref) 1.5–20 s, peak |x| 20–40 s) of one realisation."""
    return (mean(ts, "body_z", 30, 40), mean(ts, "actuator_force", 30, 40),
            rms((ts.body_z.to_numpy() - ts["ctrl.ref_x"].to_numpy())[win(ts, 1.5, 20)]),
            float(np.max(np.abs(ts.body_z.to_numpy()[win(ts, 20, CH4_ENSEMBLE_S)]))))


def _ch4_realisations(ctx, variant, n, first=0):
    """:func:`_ch4_stats` of the runs k = ``first`` … ``n`` − 1 of ``variant`` whose first sine amplitude is scaled
    by 1 + k·CH4_PERTURBATION (k = 0 is the scenario run), each run to :data:`CH4_ENSEMBLE_S` (the end of the load
    step).  The realisations differ only in the road, so they run as ensembles (each car as it would alone) of
    :data:`CH4_CHUNK` cars (progress per chunk, bounded memory; realisation k is the same car at every step)."""
    scs = {}
    for k in range(first, n):
        sc = ctx.variants("thesis_ch4_load_step", [f"sim.duration={CH4_ENSEMBLE_S:g}"], only=[variant])[variant]
        sc.sim.control_dt = sc.sim.control_dt / ctx.step_factor  # the thesis's control step (run_each)
        amp = list(sc.road.params["amplitudes"])
        amp[0] = amp[0] * (1 + k * CH4_PERTURBATION)
        sc.road.params["amplitudes"] = amp
        scs[f"{variant}#{k}"] = sc
    res, names = {}, list(scs)
    for a in range(0, len(names), CH4_CHUNK):
        part = names[a:a + CH4_CHUNK]
        res.update(ctx.run({k: scs[k] for k in part},
                           label=f"ch4 realisations {first + a}–{first + a + len(part) - 1} of {variant}"))
    return np.array([_ch4_stats(res[k].ts) for k in names])


def ch4_load_step(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    v = ctx.variants("thesis_ch4_load_step")
    res = run_each(ctx, v, "thesis_ch4_load_step")
    ts = {k: r.ts for k, r in res.items()}
    m = ts["mrac"]
    ref = m["ctrl.ref_x"].to_numpy()

    def own_ref(k):  # every controlled run's reference is the same skyhook model driven by the same road
        return ts[k]["ctrl.ref_x"].to_numpy() if "ctrl.ref_x" in ts[k] else ref

    z = {k: mean(t, "body_z", 30, 40) for k, t in ts.items()}
    zd = {k: mean(t, "body_z", 42, 50) for k, t in ts.items()}
    F = {k: mean(t, "actuator_force", 30, 40) for k, t in ts.items()}
    fol = {k: rms((t.body_z.to_numpy() - own_ref(k))[win(t, 1.5, 20)]) for k, t in ts.items()}
    stuck = {k: mean(t, "effect.coulomb_friction.stuck.0", 1.5, 20) for k, t in ts.items()}
    ref_size = float(np.std(ref[win(m, 1.5, 20)]))
    after = {k: [mean(ts[k], "body_z", 20 + 2 * i, 22 + 2 * i) for i in range(5)] for k in ("mrac", "mrac_bias")}

    def start(k):  # the first 1.5 s: peak force and mean |ΔU| per 0.01 s control step
        f_ = ts[k].actuator_force.to_numpy()[win(ts[k], 0, 1.5)]
        return float(np.max(np.abs(f_))), float(np.mean(np.abs(np.diff(f_))))

    def dU(k):  # mean |ΔU| per control step after 1.5 s (ringing at the Nyquist frequency would show here)
        return float(np.mean(np.abs(np.diff(ts[k].actuator_force.to_numpy()[win(ts[k], 1.5, 60)]))))

    # the estimates from the wrong design: distance (scaled by the nominal |Θ| per row, bias row by 1000 N) between
    # the wrong start's Θ and the right start's Θ at the same instant, with the bias row left out; the printed law's
    # wrong start (`wrong_design`) against its right start `mrac`, ours with the bias (`wrong_design_bias`) against
    # `mrac_bias`
    th_r, th_w, th_off = (_ch4_theta(ts["mrac_bias"]), _ch4_theta(ts["wrong_design_bias"]),
                          _ch4_theta(ts["wrong_design_bias_off"]))
    th_rp, th_wp, th_offp = _ch4_theta(ts["mrac"]), _ch4_theta(ts["wrong_design"]), _ch4_theta(ts["wrong_design_off"])
    sc_ = np.abs(th_r[0])
    sc_[sc_ == 0] = 1000.0
    keep = np.ones(th_r.shape[1], bool)
    keep[-2] = False  # the bias (operating-point force) row

    def at(a, t_):
        return a[min(int(np.searchsorted(m.t.to_numpy(), t_)), len(a) - 1)]

    def dist(a, b):
        return float(np.linalg.norm(((a - b) / sc_)[keep]))

    def gap(a, b, t_):
        return dist(at(a, t_), at(b, t_))
    gap_t = (0.0, 1.5, 5.0, 20.0, 40.0, 60.0)
    gaps = [gap(th_w, th_r, t_) for t_ in gap_t]
    drift_r = [dist(at(th_r, t_), th_r[0]) for t_ in gap_t]
    travel_w = dist(at(th_w, 60.0), th_w[0])
    off_gap = gap(th_off, th_r, 0.0)
    gaps_p = [gap(th_wp, th_rp, t_) for t_ in gap_t]
    drift_rp = [dist(at(th_rp, t_), th_rp[0]) for t_ in gap_t]
    travel_wp = dist(at(th_wp, 60.0), th_wp[0])
    off_gap_p = gap(th_offp, th_rp, 60.0)

    def theta_story(gaps_, off_name, off_gap_, off_t, drift_, travel_):
        """The wrong-start claims' Θ sentence (the printed law's and ours): distances to the right start's Θ."""
        return ("Θ distance (scaled, bias row left out) to the right start's Θ at "
                + ", ".join(f"{t_:g}" for t_ in gap_t) + " s: " + ", ".join(f"{g:.2f}" for g in gaps_)
                + f" (adaptation off, `{off_name}`: {off_gap_:.2f} at {off_t:g} s); the right start's own Θ moves "
                + ", ".join(f"{d_:.2f}" for d_ in drift_) + f" from the nominal design (the wrong start's "
                f"{travel_:.2f} from its own)")

    def held(k):  # adaptation off: the largest relative change of a non-zero Θ entry over the run
        th_ = _ch4_theta(ts[k])
        nz = np.abs(th_[0]) > 0
        return float(np.max(np.abs(th_[:, nz] - th_[0, nz]) / np.abs(th_[0, nz])))
    held_off = {k: held(k) for k in ("mrac_off", "wrong_design_off", "wrong_design_bias_off")}

    # the chaotic variant: ensemble over perturbed runs (one run has no converged value); the printed law under
    # the same perturbations as a check that it is not chaotic
    ens = _ch4_realisations(ctx, "mrac_kappa_q", CH4_REALISATIONS)
    # (a column of the ensemble table, no key number: not rerun in the half-step run, whose tables are not shown)
    ens_p = _ch4_realisations(ctx, "mrac", CH4_PRINTED_REALISATIONS) if ctx.step_factor == 1.0 else None
    gap_x = 0.125  # D/2: a body beyond it is on the stops (a burst)

    def mse(x):
        return float(np.mean(x)), float(np.std(x, ddof=1) / np.sqrt(len(x)))
    eL, eF, eFo = mse(ens[:, 0]), mse(ens[:, 1]), mse(ens[:, 2])
    bursts = int(np.sum(ens[:, 3] > gap_x))
    # statistics of the chaotic distribution less sensitive to its tails than the means: the medians (standard
    # error by a bootstrap with a fixed seed) and the fraction of runs that pass the stops (binomial)
    boot = np.random.default_rng(0).integers(0, len(ens), (2000, len(ens)))

    def med(x):
        return float(np.median(x)), float(np.std(np.median(x[boot], axis=1), ddof=1))
    mL, mF, mFo = med(ens[:, 0]), med(ens[:, 1]), med(ens[:, 2])
    p_b = bursts / len(ens)
    eB = (p_b, float(np.sqrt(max(p_b * (1 - p_b), 1.0 / len(ens)) / len(ens))))
    def span(x, s_, d):
        return "—" if x is None else f"{np.min(x) * s_:.{d}f} … {np.max(x) * s_:.{d}f}"
    ens_rows = [[name, f"{mu * s_:.{d}f} ± {se * s_:.{d}f}", f"{np.std(ens[:, i], ddof=1) * s_:.{d}f}",
                 span(ens[:, i], s_, d), span(None if ens_p is None else ens_p[:, i], s_, d)]
                for i, (name, (mu, se), s_, d) in enumerate((
                    ("level 30–40 s (mm)", eL, 1000, 1),
                    ("mean force 30–40 s (N)", eF, 1, 0),
                    ("RMS(body − ref) 1.5–20 s (mm)", eFo, 1000, 1),
                    (f"peak |x| 20–{CH4_ENSEMBLE_S:g} s (mm)", mse(ens[:, 3]), 1000, 0)))]
    ens_rows += [["median level 30–40 s (mm), ± bootstrap s.e.", f"{mL[0] * 1000:.1f} ± {mL[1] * 1000:.1f}", "", "",
                  ""],
                 ["median force 30–40 s (N), ± bootstrap s.e.", f"{mF[0]:.0f} ± {mF[1]:.0f}", "", "", ""],
                 ["median RMS(body − ref) 1.5–20 s (mm), ± bootstrap s.e.", f"{mFo[0] * 1000:.2f} ± {mFo[1] * 1000:.2f}",
                  "", "", ""],
                 [f"runs past the stops' {gap_x * 100:.1f} cm, 20–{CH4_ENSEMBLE_S:g} s", f"{bursts} of {len(ens)} "
                  f"({eB[0]:.0%} ± {eB[1]:.0%})", "", "", ""]]
    ens_table = md_table([f"`mrac_kappa_q` (κ = 0.1, Q = 1e-4, ours) over {CH4_REALISATIONS} realisations",
                          "mean ± s.e.", "s.d.", "min … max",
                          f"printed law `mrac`, {CH4_PRINTED_REALISATIONS} realisations: min … max"], ens_rows)

    pk_m, du0_m = start("mrac_bias")
    pk_k, du0_k = start("mrac_kappa")

    def drift_verdict(k):  # the level held under the load and after it (passive stays down after it)
        return ("reproduced" if abs(z[k]) < 0.02 and abs(zd[k]) < 0.02 and zd["drift_passive"] < -0.05
                else "partly" if abs(zd[k]) < 0.02 else "not")

    claims = [
        Claim("passive sag with the stops (30–40 s)", "≈ 15 cm ([CALC] 0.144 m)", f"{-z['passive']:.3f} m",
              "reproduced" if abs(z["passive"] + 0.144) < 0.025 else "not"),
        Claim("the printed law (scenario default `mrac`: κ = 1, RLS with Q = 0, the printed φ without a constant) "
              "holds the level", "maintains the static level (Fig. 4.4)",
              f"mean 30–40 s {z['mrac'] * 100:.1f} cm; 2-s means after the step "
              + ", ".join(f"{a * 100:.1f}" for a in after["mrac"]) + f" cm; baseline adaptation off (`mrac_off`) "
              f"{z['mrac_off'] * 100:.1f} cm, passive {z['passive'] * 100:.1f} cm",
              "reproduced" if abs(z["mrac"]) < 0.02 else "partly" if abs(z["mrac"]) < 0.5 * abs(z["mrac_off"])
              else "not",
              "without a constant in φ the static force comes from Θᵀφ's output and input terms, i.e. from a level "
              "error, and with Q = 0 the body sticks wherever the 1000 N friction catches it (anywhere within "
              "±F/K = ±20 cm of the spring equilibrium)"),
        Claim("mean upward force, printed law", "≈ 1500 N (Fig. 4.8)",
              f"{F['mrac']:.0f} N (adaptation off {F['mrac_off']:.0f} N; 150·g = 1471 N)",
              "reproduced" if abs(F["mrac"] - 1471) < 200 else "not"),
        Claim("model following, RMS(body − reference) 1.5–20 s, printed law", "within 1.5 s (Figs. 4.4, 4.7)",
              f"{fol['mrac'] * 1000:.1f} mm (passive {fol['passive'] * 1000:.1f} mm, adaptation off "
              f"{fol['mrac_off'] * 1000:.1f} mm; the reference moves {ref_size * 1000:.1f} mm RMS); friction stuck "
              f"{stuck['mrac']:.0%} (passive {stuck['passive']:.0%}) of the time",
              "not" if fol["mrac"] > 0.5 * fol["passive"] else "reproduced",
              "the 1000 N Coulomb friction locks the body to the base (road spring force ≈ 150 N); where the printed "
              "law breaks it away it does not move the body with the reference (adaptation off stays locked and "
              "passive-like)"),
        Claim("the same law with our bias parameter (`mrac_bias`: the constant −1 in φ with the operating-point "
              "force u0; ours, in `mrac_kappa*`, `wrong_design_bias*` and `drift_mrac_bias`)", "maintains the static level, ≈ 1500 N, "
              "follows (Figs. 4.4, 4.7, 4.8)",
              f"level 30–40 s {z['mrac_bias'] * 100:.1f} cm (printed {z['mrac'] * 100:.1f}); 2-s means after the step "
              + ", ".join(f"{a * 100:.1f}" for a in after["mrac_bias"]) + f" cm; force {F['mrac_bias']:.0f} N "
              f"(printed {F['mrac']:.0f}); following {fol['mrac_bias'] * 1000:.1f} mm (printed "
              f"{fol['mrac'] * 1000:.1f}), stuck {stuck['mrac_bias']:.0%}",
              "partly" if abs(z["mrac_bias"]) < 0.5 * abs(z["mrac_off"]) and abs(F["mrac_bias"] - 1471) < 200
              else "not",
              "the bias estimate supplies the static force; the friction still holds the body low, and it follows "
              "worse than passive"),
        Claim("κ = 1 (the thesis's d-step-ahead law, with our bias: `mrac_bias`) against our κ = 0.1 (`mrac_kappa`, "
              "with the bias), both Q = 0", "κ not in the thesis (κ = 1)",
              f"κ = 1: level {z['mrac_bias'] * 100:.1f} cm, force {F['mrac_bias']:.0f} N, following "
              f"{fol['mrac_bias'] * 1000:.1f} mm, "
              f"stuck {stuck['mrac_bias']:.0%}, first 1.5 s peak {pk_m / 1000:.1f} kN and {du0_m:.0f} N per step, then "
              f"{dU('mrac_bias'):.0f} N per step; κ = 0.1: {z['mrac_kappa'] * 100:.1f} cm, {F['mrac_kappa']:.0f} N, "
              f"{fol['mrac_kappa'] * 1000:.1f} mm, stuck {stuck['mrac_kappa']:.0%}, {pk_k / 1000:.1f} kN and "
              f"{du0_k:.0f} N per step, then {dU('mrac_kappa'):.0f} N per step", "n.a.",
              "κ = 1 does not ring here (the friction-locked body keeps its increments small after the start, "
              "unlike Ch. 7); it breaks the friction more often and follows worse than passive"),
        Claim(f"our covariance addition Q = 1e-4 per step with κ = 0.1 (`mrac_kappa_q`, the former default), mean of "
              f"{CH4_REALISATIONS} perturbed runs", "maintains the level, ≈ 1500 N",
              f"level {eL[0] * 1000:.1f} ± {eL[1] * 1000:.1f} mm (s.e.; runs {np.min(ens[:, 0]) * 1000:.0f} … "
              f"{np.max(ens[:, 0]) * 1000:.0f} mm), force {eF[0]:.0f} ± {eF[1]:.0f} N, following "
              f"{eFo[0] * 1000:.1f} ± {eFo[1] * 1000:.1f} mm; {bursts} of {CH4_REALISATIONS} runs burst beyond the "
              f"stops' {gap_x * 100:.1f} cm under the load (20–{CH4_ENSEMBLE_S:g} s; peak up to "
              f"{np.max(ens[:, 3]) * 100:.0f} cm)",
              "partly" if abs(eL[0]) < 0.02 and abs(eF[0] - 1471) < 200 else "not",
              "ours, not the thesis's value; chaotic: the covariance addition lets the estimates wander while "
              "friction locks the body (ensemble table)"),
        Claim("adaptation from a stated wrong design (`wrong_design`: M* +30 %, K* −30 %, C0 +30 %, size ours), the "
              "printed law (right start `mrac`)",
              "estimates converge fast from their initial values (Fig. 4.6)",
              theta_story(gaps_p, "wrong_design_off", off_gap_p, 60.0, drift_rp, travel_wp)
              + f"; level {z['wrong_design'] * 100:.1f} cm (right start "
              f"{z['mrac'] * 100:.1f}, adaptation off {z['wrong_design_off'] * 100:.1f}), force "
              f"{F['wrong_design']:.0f} N ({F['mrac']:.0f}, {F['wrong_design_off']:.0f}), following "
              f"{fol['wrong_design'] * 1000:.1f} mm ({fol['mrac'] * 1000:.1f}, {fol['wrong_design_off'] * 1000:.1f})",
              "partly" if gaps_p[-1] < 0.5 * gaps_p[0] else "not",
              "the printed law's estimates from the wrong design do not join the right start's"
              + (" (the gap grows)" if gaps_p[-1] > gaps_p[0] else "") + ": without the constant in φ the "
              "static load is carried by Θ's output and input terms at a level error, and the friction-locked body "
              "does not identify Θ, so each start settles on its own Θ and its own level"),
        Claim("the same from the law with our bias (`wrong_design_bias`, ours; right start `mrac_bias`)",
              "estimates converge fast from their initial values (Fig. 4.6)",
              theta_story(gaps, "wrong_design_bias_off", off_gap, 0.0, drift_r, travel_w)
              + f"; level {z['wrong_design_bias'] * 100:.1f} cm (right start "
              f"{z['mrac_bias'] * 100:.1f}, adaptation off {z['wrong_design_bias_off'] * 100:.1f}), following "
              f"{fol['wrong_design_bias'] * 1000:.1f} mm ({fol['mrac_bias'] * 1000:.1f}, "
              f"{fol['wrong_design_bias_off'] * 1000:.1f})",
              "partly" if gaps[-1] < 0.5 * gaps[0] else "not",
              "the wrong start's estimates merge with the right start's (the loop forgets its initial design), but "
              "neither settles: on the friction-locked body the data do not identify Θ"),
        Claim("the baselines with adaptation off (P0 = 1e-18): Θ held", "n.a.",
              "largest relative change of a Θ entry over the run: "
              + ", ".join(f"`{k}` {v:.1e}" for k, v in held_off.items()),
              "n.a.", "P0 = 1e-12 (the former setting) let `mrac_off`'s first entry move 1.9 % over 60 s"),
        Claim("mode I drifts (K −20 % over 10–50 s, C_v −50 % at 30 s: sizes ours) with the load step, the printed "
              "law (`drift_mrac`: κ = 1, Q = 0, no bias)",
              "robust to K(t), C_v(t) (Figs. 2.7–2.8, 4.4)",
              f"mean level 30–40 s: printed law {z['drift_mrac'] * 100:.1f} cm, passive {z['drift_passive'] * 100:.1f} cm; "
              f"42–50 s (load off, K −18 %): {zd['drift_mrac'] * 100:.1f} / {zd['drift_passive'] * 100:.1f} cm; force "
              f"30–40 s {F['drift_mrac']:.0f} N",
              drift_verdict("drift_mrac"),
              "C_v(t) is the orifice-damper effect's coefficient (effects.quadratic_damping.c_v)"),
        Claim("the same with our bias (`drift_mrac_bias`) and with our κ = 0.1, Q = 1e-4 (`drift_mrac_kappa_q`, one run "
              "of a chaotic loop)", "as above",
              f"mean level 30–40 s: {z['drift_mrac_bias'] * 100:.1f} / {z['drift_mrac_kappa_q'] * 100:.1f} cm; 42–50 s: "
              f"{zd['drift_mrac_bias'] * 100:.1f} / {zd['drift_mrac_kappa_q'] * 100:.1f} cm",
              drift_verdict("drift_mrac_bias"), "ours"),
    ]
    # would a larger excitation or a softer friction law (the thesis smooths sgn by a truncated Fourier integral
    # whose width it does not give) un-stick the body?  Same scenario without the load step, 1.5–20 s (printed
    # law; run once: no key numbers)
    tables = [ens_table]
    if ctx.step_factor == 1.0:
        study = []
        for amp, veps in ((1.0, None), (5.0, None), (10.0, None), (1.0, 0.01), (1.0, 0.1), (1.0, 0.5)):
            vv = ctx.variants("thesis_ch4_load_step", ["sim.duration=20"], only=["passive", "mrac"])
            for sc in vv.values():
                sc.vehicle.variations = []
                sc.road.params["amplitudes"] = [a * amp for a in sc.road.params["amplitudes"]]
                if veps is not None:  # the smooth law F = −F_c·tanh(v/v_eps) instead of the scenario's stick-slip
                    # (at the start of each step, as first measured; its mean over the step gave 24.6, 44.2 and
                    # 22.7 mm for the printed law at v_eps 0.01, 0.1, 0.5 m/s: the page)
                    sc.vehicle.effects[1].params.update(law="tanh", v_eps=veps, step_force="start")
            rr = run_each(ctx, vv, f"ch4 study ×{amp:g}, v_eps {veps}")
            r_ = rr["mrac"].ts["ctrl.ref_x"].to_numpy()
            mm = win(rr["mrac"].ts, 1.5, 20)
            e_ = {k: rms((rr[k].ts.body_z.to_numpy() - r_)[mm]) for k in rr}
            study.append([f"×{amp:g}", "stick-slip (scenario)" if veps is None else f"tanh, v_eps {veps:g} m/s",
                          f"{float(np.std(r_[mm])) * 1000:.1f}", f"{e_['mrac'] * 1000:.1f}", f"{e_['passive'] * 1000:.1f}"])
        tables.insert(0, md_table(["sine amplitudes", "friction law", "reference RMS (mm)",
                                   "printed-law MRAC RMS(body − ref) (mm)", "passive (mm)"], study))
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True)
    for k, s in (("passive", "g-"), ("mrac_off", "y-"), ("mrac", "r-"), ("mrac_bias", "m-"), ("mrac_kappa_q", "b-")):
        ax[0].plot(ts[k].t, ts[k].body_z, s, lw=0.7, label=k + (" (ours)" if k in ("mrac_bias", "mrac_kappa_q") else
                                                               " (printed)" if k == "mrac" else ""))
        ax[1].plot(ts[k].t, ts[k].actuator_force, s, lw=0.6)
    ax[0].plot(m.t, ref, "k:", lw=0.7, label="reference")
    ax[0].plot(m.t, m.road, "c-", lw=0.4, label="base w")
    ax[0].set_ylabel("x (m)")
    ax[0].legend(fontsize=7, ncol=3)
    ax[1].set_ylabel("actuator force (N)")
    ax[1].set_ylim(-6000, 6000)
    tt = m.t.to_numpy()
    for a_, b_, s, lab in ((th_wp, th_rp, "k-", "wrong design − right start (printed law)"),
                           (th_w, th_r, "m-", "wrong design − right start (both with our bias)"),
                           (th_r, np.broadcast_to(th_r[0], th_r.shape), "r-", "right start − nominal design"),
                           (th_off, th_r, "y--", "wrong design, adaptation off − right start (with our bias)")):
        ax[2].plot(tt, np.linalg.norm(((a_ - b_) / sc_)[:, keep], axis=1), s, lw=0.8, label=lab)
    ax[2].set_yscale("log")
    ax[2].set_ylim(1e-2, 1e2)
    ax[2].set_ylabel("Θ distance (scaled)")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(fontsize=7)
    fig.suptitle("Thesis Ch. 4 (Figs. 4.4–4.8): discrete MRAC, 0.05 s delay, +150 kg at 20–40 s;\nprinted law "
                 "(`mrac`: κ = 1, Q = 0, no bias), adaptation off; ours: with the bias, and κ = 0.1, Q = 1e-4",
                 fontsize=9)
    fig.tight_layout()
    key = {"passive_sag": (z["passive"], 0.01), "mrac_level": (z["mrac"], 0.01), "mrac_force": (F["mrac"], 10.0),
           "mrac_follow": (fol["mrac"], 1e-3), "off_level": (z["mrac_off"], 0.01),
           "bias_level": (z["mrac_bias"], 0.01), "bias_force": (F["mrac_bias"], 10.0),
           "bias_follow": (fol["mrac_bias"], 1e-3),
           "kappa_level": (z["mrac_kappa"], 0.01), "kappa_force": (F["mrac_kappa"], 10.0),
           "kappa_follow": (fol["mrac_kappa"], 1e-3), "wrong_level": (z["wrong_design"], 0.01),
           "wrong_force": (F["wrong_design"], 10.0), "wrong_follow": (fol["wrong_design"], 1e-3),
           # (the 20-s gap, 2.01, moved 2.1 % on halving, 0.7 % of the initial gap: not a key; 60 s 0.09 %)
           "wrong_theta_gap_60s": (gaps_p[-1], gaps_p[0]),
           "wrong_off_level": (z["wrong_design_off"], 0.01),
           "wrong_bias_level": (z["wrong_design_bias"], 0.01), "wrong_bias_follow": (fol["wrong_design_bias"], 1e-3),
           # the remaining Θ gap is the small difference of two Θ trajectories that each travel ≈ 5 (scaled) and
           # converge at first order: compared against the initial gap, the scale of the claim (the fraction of
           # the initial distance closed); each trajectory's travel is a key number against itself
           "wrong_bias_theta_gap_60s": (gaps[-1], gaps[0]), "wrong_bias_theta_travel_60s": (travel_w, 0.05),
           "right_theta_travel_60s": (drift_r[-1], 0.05),
           "drift_passive_level": (zd["drift_passive"], 0.01), "drift_mrac_level": (z["drift_mrac"], 0.01),
           "drift_mrac_level_after": (zd["drift_mrac"], 0.01), "drift_bias_level": (z["drift_mrac_bias"], 0.01),
           "drift_bias_level_after": (zd["drift_mrac_bias"], 0.01),
           # the chaotic variant's ensemble means with their standard errors (a statistical estimate: framework)
           "q_ensemble_level": (eL[0], 0.01, eL[1]), "q_ensemble_force": (eF[0], 10.0, eF[1]),
           "q_ensemble_follow": (eFo[0], 1e-3, eFo[1]),
           # statistics of the distribution less sensitive to its tails: medians and the fraction past the stops
           "q_ensemble_median_level": (mL[0], 0.01, mL[1]), "q_ensemble_median_force": (mF[0], 10.0, mF[1]),
           "q_ensemble_median_follow": (mFo[0], 1e-3, mFo[1]),
           "q_ensemble_stops_fraction": (eB[0], 0.05, eB[1])}
    notes = [HALF_NOTE,
             "Literal first: the scenario default `mrac` is the law as printed, the d-step-ahead control of Eq. 4.55 "
             "(κ = 1) with the RLS of Eq. 4.56 at Q = 0 and the printed regressor φ (no constant).  Eq. 4.56 prints a covariance addition 0 ≤ Q < ∞ whose value the "
             "thesis never gives (its text says the addition keeps P high for fast re-adaptation), so Q = 0 is the "
             "printed law at the bottom of its range and Q = 1e-4 per step is our value (`mrac_kappa_q`); κ < 1 is ours.  "
             "The bias parameter (the constant −1 in φ with the operating-point force u0 of the linearisation, Eq. 4.7) "
             "is ours: variant `mrac_bias` (controller switch bias: true), carried by the other adaptive variants "
             "(`mrac_kappa`, `mrac_kappa_q`, `wrong_design_bias*`, `drift_mrac_bias`, `drift_mrac_kappa_q`; `drift_mrac` is the "
             "printed law on the drifting plant); adaptation off (`mrac_off`) holds a bias "
             "at its initial 0 either way.",
             f"Ensemble (table): realisation k scales the first sine amplitude by 1 + k·{CH4_PERTURBATION:g} "
             f"(k = 0 … {CH4_REALISATIONS - 1}: ≤ {(CH4_REALISATIONS - 1) * CH4_PERTURBATION * 0.02 * 1e6:.0f} µm); the "
             f"realisations run to {CH4_ENSEMBLE_S:g} s, the end of the load step (every number of the table is read "
             "before it).  The "
             "printed law does not move under these perturbations (last column), the Q variant spreads over "
             "centimetres and bursts: its single runs have no converged value, and its ensemble statistics "
             "(q_ensemble_*) carry their standard errors (the step-halving table gives each change in standard errors of "
             "the difference, and whether the 2 % bound is decided).  The medians and the fraction "
             "of runs past the stops (q_ensemble_median_*, q_ensemble_stops_fraction) are less sensitive to the runs "
             "on the stops than the means.  With the stop and orifice-damper forces held over each physics step (the "
             "former setting: first order in the step) the force's whole distribution moved up ≈ 100 N on halving "
             "(64 runs: median 1438 ± 27 → 1561 ± 22 N, 3.5 s.e.; a third step lay between the two); the scenario now "
             "runs their means over each step (step_force: mean, second order; the page).",
             "The wrong design's (with our bias) remaining Θ gap at 60 s is compared against the initial gap (the claim is the "
             "fraction of the initial distance closed): it is the small difference of two Θ trajectories that each "
             "travel ≈ 5 (scaled) and converge at first order (wrong_bias/right_theta_travel_60s, each against itself); the printed law's wrong "
             "start (`wrong_design`) does not close its gap (wrong_theta_gap_60s, against the initial gap as well).  "
             "RK4 at 0.0625 ms: the printed law (κ = 1) cancels the sampling zero of its design model near z = −1, and "
             "implicitfast's first-order integration of the held force moved the rig's own zero by 2·dt/T, so the wrong "
             "design's level and following wandered with the step (−50.4, −49.1, −48.7, −49.3 mm at 0.125 … 0.016 ms); "
             "RK4 integrates the held force exactly (the page)."]
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=tables)


def ch4_dirt(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    res = run_each(ctx, ctx.variants("thesis_ch4_dirt"), "thesis_ch4_dirt")
    ts = {k: r.ts for k, r in res.items()}
    t0 = 12.0  # the thesis: adapts within the first 12 s
    s_ = {k: t[t.t > t0] for k, t in ts.items()}
    fs = 1.0 / float(ts["mrac"].t.iloc[1] - ts["mrac"].t.iloc[0])
    f, Pref = welch(s_["mrac"]["ctrl.ref_acc"].to_numpy(), fs=fs, nperseg=8192)

    def acc_mean(k):
        # the body acceleration as the mean over each log step, (v(t) − v(t − Δ))/Δ, after t0: the logged body_acc is
        # the last physics step's, and the friction's ±1000 N switching (4 m/s² on the body) has content up to 1/dt
        # that an instantaneous 1 kHz sample folds into every band (without the delay: 200× the 0.5–1 Hz content)
        t_, v_ = ts[k].t.to_numpy(), ts[k].body_vel.to_numpy()
        return (np.diff(v_) * fs)[t_[1:] > t0]
    P = {k: welch(acc_mean(k), fs=fs, nperseg=8192)[1] for k in s_}
    # (the instantaneous sample, for the page's comparison: the laws without the delay, printed and with our bias)
    P_inst = welch(s_["mrac_no_delay"].body_acc.to_numpy(), fs=fs, nperseg=8192)[1]
    P_inst_b = welch(s_["mrac_bias_no_delay"].body_acc.to_numpy(), fs=fs, nperseg=8192)[1]
    bands = ((0.25, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 8.0))

    def ratios(Pk):
        return [float(np.mean(Pk[(f >= lo) & (f < hi)]) / np.mean(Pref[(f >= lo) & (f < hi)])) for lo, hi in bands]
    r = {k: ratios(P[k]) for k in ts}
    lvl = {k: float(np.mean(t.body_z.to_numpy())) for k, t in s_.items()}
    acc = {k: rms(t.body_acc.to_numpy()) for k, t in s_.items()}
    ref_acc = rms(s_["mrac"]["ctrl.ref_acc"].to_numpy())
    stuck = {k: float(np.mean(t["effect.coulomb_friction.stuck.0"].to_numpy())) for k, t in s_.items()}

    def nearer(k):  # closer to the reference than passive (log distance), per band from 0.5 to 4 Hz
        return [abs(np.log10(a)) < abs(np.log10(b)) for a, b in zip(r[k][1:4], r["passive"][1:4])]

    def closer(k):  # ... in every one of them
        return all(nearer(k))

    def row(k):
        return ", ".join(f"{x:.3g}" for x in r[k])
    r_inst = ratios(P_inst)
    r_inst_b = ratios(P_inst_b)
    # the bias (operating-point force) estimate at the end, of the law with our bias without the delay (the printed φ
    # has no constant, so the printed law has no such estimate)
    th_nd = [c for c in ts["mrac_bias_no_delay"].columns if c.startswith("ctrl.theta.")]
    bias_nd = float(ts["mrac_bias_no_delay"][th_nd[-2]].iloc[-1])
    near = nearer("mrac_no_delay")
    near_b = nearer("mrac_bias_no_delay")

    def verdict_delay(k):
        return ("reproduced" if closer(k) and max(abs(np.log10(x)) for x in r[k][:4]) < np.log10(2)
                else "partly" if closer(k) else "not")
    claims = [
        Claim("dirt road, the printed law (`mrac`: κ = 1, Q = 0, the printed φ without a constant) with the thesis's "
              "0.05 s loop delay",
              "adapts within 12 s, then follows the reference gain factors with a small deviation at high "
              "frequency (Figs. 4.9–4.12)",
              f"body-acc PSD / reference per octave 0.25–8 Hz after 12 s: {row('mrac')}; passive {row('passive')}; "
              f"mean level {lvl['mrac'] * 1000:.0f} mm (passive {lvl['passive'] * 1000:.0f}); body acc RMS "
              f"{acc['mrac']:.1f} m/s² (passive {acc['passive']:.1f}, reference {ref_acc:.2f})",
              verdict_delay("mrac"),
              "the friction (1000 N, exact stick-slip, its mean over each step) switches with every reversal of the "
              "rough base's relative "
              "velocity (stuck " f"{stuck['passive']:.0%} of the time): a 4 m/s² square wave on the 250 kg body that "
              "a linear law acting 0.05 s late cannot cancel"),
        Claim("the same law with our bias parameter (`mrac_bias`: the constant −1 in φ with the operating-point force "
              "u0; ours, the former default), with the delay", "as above",
              f"{row('mrac_bias')}; level {lvl['mrac_bias'] * 1000:.0f} mm; body acc RMS {acc['mrac_bias']:.1f} m/s²",
              verdict_delay("mrac_bias"), "ours"),
        Claim("same with our κ = 0.1 and Q = 1e-4 (`mrac_kappa_q`, with our bias)", "as above",
              f"{row('mrac_kappa_q')}; level {lvl['mrac_kappa_q'] * 1000:.0f} mm",
              "partly" if closer("mrac_kappa_q") else "not", "ours"),
        Claim("without the loop delay (our comparison): the printed law `mrac_no_delay`, ours `mrac_kappa_q_no_delay`",
              "(the thesis: satisfactory for a wide range of delays)",
              f"printed {row('mrac_no_delay')}, level {lvl['mrac_no_delay'] * 1000:.0f} mm (the instantaneous 1 kHz "
              "sample of the body acceleration reads " + ", ".join(f"{x:.3g}" for x in r_inst) + "); ours "
              f"{row('mrac_kappa_q_no_delay')}, level {lvl['mrac_kappa_q_no_delay'] * 1000:.0f} mm",
              "partly" if closer("mrac_no_delay") else "not",
              "printed law closer to the reference than passive in the 0.5–1, 1–2, 2–4 Hz bands: "
              + ", ".join("yes" if c else "no" for c in near) + "; ours closer than passive in every band from 0.5 "
              "to 4 Hz: " + ("yes" if closer("mrac_kappa_q_no_delay") else "no")),
        Claim("no delay, the law with our bias (`mrac_bias_no_delay`, ours)", "as above",
              f"{row('mrac_bias_no_delay')}, level {lvl['mrac_bias_no_delay'] * 1000:.0f} mm, bias estimate at 60 s "
              f"{bias_nd:.0f} N (the instantaneous 1 kHz sample reads " + ", ".join(f"{x:.3g}" for x in r_inst_b)
              + ": aliased friction switching)",
              "partly" if closer("mrac_bias_no_delay") else "not",
              "closer to the reference than passive in the 0.5–1, 1–2, 2–4 Hz bands: "
              + ", ".join("yes" if c else "no" for c in near_b)),
    ]
    off_key = {}
    if "mrac_off" in ts and "mrac_off_no_delay" in ts:  # is it the adaptation? the same law with Θ held
        def nearer_ref(k, b):  # k closer to the reference than b (log distance), per band 0.25–8 Hz
            return ", ".join("yes" if abs(np.log10(x)) < abs(np.log10(y)) else "no" for x, y in zip(r[k], r[b]))
        claims.append(Claim(
            "is it the adaptation? the printed law with adaptation off (`mrac_off`, `mrac_off_no_delay`: Θ held at the "
            "nominal design, P0 = 1e-18), with and without the delay",
            "(the thesis: it adapts within 12 s, then follows)",
            f"with the delay {row('mrac_off')}, level {lvl['mrac_off'] * 1000:.0f} mm; without {row('mrac_off_no_delay')}, "
            f"level {lvl['mrac_off_no_delay'] * 1000:.0f} mm",
            "not shown" if any(abs(np.log10(r["mrac_off"][i])) < abs(np.log10(r["mrac"][i])) for i in (1, 2)) else "n.a.",
            "the adaptive law closer to the reference than adaptation off, per octave 0.25–8 Hz: with the delay "
            + nearer_ref("mrac", "mrac_off") + "; without it " + nearer_ref("mrac_no_delay", "mrac_off_no_delay")
            + "; adaptation off closer than passive in every band from 0.5 to 4 Hz: with the delay "
            + ("yes" if closer("mrac_off") else "no") + ", without " + ("yes" if closer("mrac_off_no_delay") else "no")))
        off_key = {"off_ratio_res": (r["mrac_off"][1], 0.1), "off_ratio_hi": (r["mrac_off"][3], 0.1),
                    "off_nodelay_ratio_res": (r["mrac_off_no_delay"][1], 0.1),
                    "off_nodelay_ratio_hi": (r["mrac_off_no_delay"][3], 0.1)}
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 6.0))
    lines = (("passive", "g-", ""), ("mrac", "r-", " (printed)"), ("mrac_no_delay", "b-", " (printed)"),
             ("mrac_bias_no_delay", "m-", " (ours)"))
    for k, st_, lab in lines:
        ax[0].plot(ts[k].t, ts[k].body_z, st_, lw=0.5, label=k + lab)
    ax[0].plot(ts["mrac"].t, ts["mrac"]["ctrl.ref_x"], "k:", lw=0.5, label="reference")
    ax[0].set_ylabel("body x (m)")
    ax[0].legend(fontsize=7, ncol=3)
    ax[1].loglog(f[1:], Pref[1:], "k-", lw=0.7, label="reference")
    for k, st_, lab in lines:
        ax[1].loglog(f[1:], P[k][1:], st_, lw=0.7, label=k + lab)
    ax[1].set_xlim(0.2, 10)
    ax[1].set_xlabel("frequency (Hz)")
    ax[1].set_ylabel("body acc PSD (m²/s⁴/Hz)")
    ax[1].legend(fontsize=7)
    fig.suptitle("Thesis Ch. 4 (Figs. 4.9–4.12): dirt road at 20 m/s, exact stick-slip friction;\nprinted law "
                 "(no bias) with and without the 0.05 s delay, ours with the bias without it", fontsize=9)
    fig.tight_layout()
    key = {"passive_ratio_res": (r["passive"][1], 0.1), "passive_ratio_hi": (r["passive"][3], 0.1),
           "mrac_ratio_res": (r["mrac"][1], 0.1), "mrac_ratio_hi": (r["mrac"][3], 0.1),
           "mrac_level": (lvl["mrac"], 0.01), "mrac_acc": (acc["mrac"], 0.01),
           "bias_ratio_res": (r["mrac_bias"][1], 0.1), "bias_ratio_hi": (r["mrac_bias"][3], 0.1),
           "bias_level": (lvl["mrac_bias"], 0.01), "bias_acc": (acc["mrac_bias"], 0.01),
           # the laws without the delay: their ratios may be small (≈ 0.01), so measured against themselves; the bias
           # estimate against the 1000 N friction (it drifted with the step before RK4 and the friction's step mean:
           # the page)
           "nodelay_ratio_res": (r["mrac_no_delay"][1], 1e-3), "nodelay_ratio_hi": (r["mrac_no_delay"][3], 1e-3),
           "nodelay_bias_ratio_res": (r["mrac_bias_no_delay"][1], 1e-3), "nodelay_bias_60s": (bias_nd, 1000.0),
           "nodelay_kappa_q_ratio_res": (r["mrac_kappa_q_no_delay"][1], 0.1)}
    key.update(off_key)
    notes = [HALF_NOTE,
             "The band ratios are PSDs of the body acceleration averaged over each 1 ms log step (from the logged body "
             "velocity); the logged body_acc is the last physics step's, and an instantaneous 1 kHz sample of the "
             "friction's ±1000 N switching aliases into every band (passive and with the delay the two agree within "
             "≈ 8 %; without the delay the law with our bias, `mrac_bias_no_delay`, reads 0.29 at 0.5–1 Hz from the "
             "instantaneous sample where the content is 0.0098).",
             "Literal first: the scenario default `mrac` (and `mrac_no_delay`) is the printed law, κ = 1, Q = 0 and "
             "the printed regressor φ without a constant (bias: false); the bias parameter (the constant −1 in φ with "
             "the operating-point force u0) is ours: `mrac_bias`, `mrac_bias_no_delay` (the former default's "
             "numbers), carried by `mrac_kappa_q*`.",
             "Discretisation: RK4 at 0.125 ms and the friction's mean over each step (coulomb_friction step_force: "
             "mean).  With implicitfast and the start-of-step friction the law with our bias without the delay "
             "(`mrac_bias_no_delay`, then the default `mrac_no_delay`) was not converged: its estimates drifted with the step (bias estimate at 60 s −839, "
             "−590, −305, −193 N at 0.125, 0.0625, 0.031, 0.016 ms) through first-order errors that do not average out "
             "(held-force integration, the friction's sign over a step with a reversal inside it, its one-step-old "
             "estimate of the actuator's and the other forces); now −68.9, −69.2, −69.3, −70.1 N (the page)."]
    return ItemOutput(claims, key=key, figure=fig, notes=notes)


# ---- Ch. 7 ------------------------------------------------------------------------------------------------

def polarity_claim(quantity, thesis, a, when_a, b, when_b) -> Claim:
    """The half car's actuator polarities: in squat (log window ``a``) the leading (front) actuator compresses
    (mean force < 0) and the trailing one extends; in braking (window ``b``) the reverse."""
    fa, ra = a.actuator_force_front.mean(), a.actuator_force_rear.mean()
    fb, rb = b.actuator_force_front.mean(), b.actuator_force_rear.mean()
    return Claim(quantity, thesis, f"{when_a} front {fa:.0f} N, rear {ra:.0f} N; {when_b} front {fb:.0f} N, rear {rb:.0f} N",
                 "reproduced" if (fa < 0 < ra and rb < 0 < fb) else "not")


PRINTED_CH7 = ("the thesis's law as printed (scenario default `mimo_mrac_thesis`: the pure d-step-ahead control, κ = 1, "
               "the printed φ without a constant)")
BIAS_CH7 = "`mimo_mrac_thesis_bias`: κ = 1 with our bias parameter"


def _only_printed_diverge(dv, allowed=("mimo_mrac_thesis", "mimo_fixed_thesis", "mimo_mrac_thesis_bias")):
    """Re-raise a divergence stop of any variant but the κ = 1 laws' (their running away is a result)."""
    for k, e_ in dv.items():
        if k not in allowed:
            raise e_


def _until_stop(ctx, e, margin=0.03):
    """A run that stopped on the divergence check (``e``): its log up to ``margin`` before the stop (the instants
    a rerun of ``e.time − margin`` s would log), kept by the run itself (``SimulationDiverged.log``: no rerun), for
    the figure (the printed law beside ours; at the item's own step only: the half-step run draws no figure);
    None without a log."""
    if ctx.step_factor != 1.0 or e is None or e.time <= margin + 0.01 or e.log is None:
        return None
    ts = e.log[e.car or 0]
    return ts[ts.t.to_numpy() < round(e.time - margin, 4)]


def _draw_until_stop(axx, ts_, col, scale, style, label, e):
    """The printed law's trace until its divergence stop, on an axis kept at the other runs' scale."""
    lo, hi = axx.get_ylim()
    if ts_ is not None:
        axx.plot(ts_.t, scale * ts_[col], style, lw=0.8, label=label)
    if e is not None:
        axx.axvline(e.time, color=style[0], ls=":", lw=0.8)
        axx.text(0.99, 0.03 + 0.08 * len(axx.texts), f"{label}: diverges at {e.time:.4g} s", transform=axx.transAxes,
                 fontsize=7, color=style[0], ha="right", va="bottom", zorder=6,
                 bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.8, "pad": 1})
    axx.set_ylim(lo, hi)


def _ring(ts):
    """(mean |ΔU| per control step, peak |U|) over both actuators (N): the Nyquist ringing of the κ = 1 law."""
    u = np.stack([ts.actuator_force_front.to_numpy(), ts.actuator_force_rear.to_numpy()])
    return float(np.mean(np.abs(np.diff(u, axis=1)))), float(np.max(np.abs(u)))


def ch7_braking(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    dv = {}
    res = run_each(ctx, ctx.variants("thesis_ch7_braking"), "thesis_ch7_braking", diverged=dv)
    _only_printed_diverge(dv)
    ts = {k: r.ts for k, r in res.items()}
    pk = {k: float(np.degrees(np.max(np.abs(t.pitch.to_numpy())))) for k, t in ts.items()}
    dive = float(np.degrees(np.max(ts["passive"].pitch.to_numpy())))
    zb = {k: float(np.max(np.abs(t.body_z.to_numpy()[win(t, 9, 11.5)]))) for k, t in ts.items()}
    a = ts["mimo_mrac"][win(ts["mimo_mrac"], 4, 9)]
    b = ts["mimo_mrac"][win(ts["mimo_mrac"], 9.5, 11)]
    late = {k: float(np.degrees(np.max(np.abs(ts[k].pitch.to_numpy()[win(ts[k], 4, 9)]))))
            for k in ("mimo_mrac", "asym_mimo_mrac", "mimo_fixed", "asym_mimo_fixed") if k in ts}
    key = {}
    if "mimo_mrac_thesis" in dv:
        printed, ok_p = "diverges: " + diverged_text(dv["mimo_mrac_thesis"]), "not"
        key["printed_stop_s"] = (float(dv["mimo_mrac_thesis"].time), 0.01)
    elif "mimo_mrac_thesis" in ts:
        du, up = _ring(ts["mimo_mrac_thesis"])
        printed = (f"ran to the end: peak |pitch| {pk['mimo_mrac_thesis']:.2f}°; mean |ΔU| {du:.0f} N per step, peak "
                   f"|U| {up / 1000:.1f} kN")
        ok_p = "reproduced" if pk["mimo_mrac_thesis"] < 0.2 * pk["passive"] else "not"
        key["printed_pitch_deg"] = (pk["mimo_mrac_thesis"], 0.1)
    claims = [
        Claim("passive nose dive in braking", "≈ 6°", f"{dive:.2f}° (h = 1.25 m, 45 kg unsprung: ours)",
              "reproduced" if 4.5 < dive < 7.5 else "partly"),
    ]
    if key:
        claims.append(Claim(f"{PRINTED_CH7} eliminates the dive", "dive \"mostly eliminated\"", printed, ok_p,
                            "the rows below are ours (κ = 0.2 with the bias parameter: `mimo_mrac` and the other "
                            "variants): the κ = 1 law cancels the sampling zero near z = −1 and rings at the Nyquist "
                            "frequency"))
    if "mimo_mrac_thesis_bias" in dv or "mimo_mrac_thesis_bias" in ts:
        if "mimo_mrac_thesis_bias" in dv:
            got_b, ok_b = "diverges: " + diverged_text(dv["mimo_mrac_thesis_bias"]), "not"
            key["thesis_bias_stop_s"] = (float(dv["mimo_mrac_thesis_bias"].time), 0.01)
        else:
            got_b = f"ran to the end: peak |pitch| {pk['mimo_mrac_thesis_bias']:.2f}°"
            ok_b = "reproduced" if pk["mimo_mrac_thesis_bias"] < 0.2 * pk["passive"] else "not"
        claims.append(Claim(f"{BIAS_CH7} (ours) eliminates the dive", "dive \"mostly eliminated\"", got_b, ok_b,
                            "the bias carries the manoeuvre moment (the printed law, without it, runs away sooner); "
                            "κ = 1 still rings"))
    if "mimo_mrac_no_bias" in ts:  # κ = 0.2 with the printed regressor: no parameter carries the manoeuvre moment
        nb = "mimo_mrac_no_bias"
        ok_nb = pk[nb] < 0.2 * pk["passive"]
        claims.append(Claim(
            "κ = 0.2 (ours) without the bias parameter (the printed φ, `mimo_mrac_no_bias`) eliminates the dive",
            "dive \"mostly eliminated\"",
            f"peak |pitch| {pk[nb]:.2f}°, 4–9 s max "
            f"{np.degrees(np.max(np.abs(ts[nb].pitch.to_numpy()[win(ts[nb], 4, 9)]))):.2f}°; with our bias "
            f"(`mimo_mrac`) {pk['mimo_mrac']:.2f}°, passive {pk['passive']:.2f}°", "reproduced" if ok_nb else "not",
            "our bias (the operating-point force) carries the manoeuvre moment; without it the κ = 0.2 blend (an "
            "integrator on U) still holds the squat, but the loop bursts after the braking"))
        key["no_bias_pitch_deg"] = (pk[nb], 0.1)
    fx = "mimo_fixed" in ts and "asym_mimo_fixed" in ts  # the adaptation-off baselines (nominal design held)
    off_dive = (f"; adaptation off (`mimo_fixed`) {pk['mimo_fixed']:.2f}°" if fx else "")
    off_bounce = (f", adaptation off {zb['asym_mimo_fixed'] * 1000:.2f} mm" if fx else "")
    off_settle = (f"; adaptation off {late['mimo_fixed']:.3f}° (asymmetric {late['asym_mimo_fixed']:.3f}°)" if fx else "")
    bounce_by_design = fx and zb["asym_mimo_fixed"] < 0.1 * zb["asym_passive"]
    claims += [
        Claim("MIMO MRAC (ours: κ = 0.2) eliminates the dive", "dive \"mostly eliminated\"",
              f"peak |pitch| {pk['mimo_mrac']:.2f}° vs passive {pk['passive']:.2f}° "
              f"({pk['mimo_mrac'] / pk['passive'] - 1:+.0%}){off_dive}",
              "reproduced" if pk["mimo_mrac"] < 0.2 * pk["passive"] else "not"),
        Claim("bounce adapts within 4 s — thesis's symmetric car", "bounce reduced",
              f"|bounce| in braking: passive {zb['passive'] * 1000:.2g} mm, MRAC {zb['mimo_mrac'] * 1000:.2g} mm",
              "n.a.", "a pitch moment on a symmetric car moves no c.g. height: the claim cannot fail here"),
        Claim("bounce, asymmetric car (a = 1.2 m, b = 1.8 m: ours)", "bounce reduced",
              f"|bounce| in braking: passive {zb['asym_passive'] * 1000:.1f} mm, MRAC {zb['asym_mimo_mrac'] * 1000:.2f} mm"
              f"{off_bounce}; peak pitch {pk['asym_passive']:.2f}° → {pk['asym_mimo_mrac']:.2f}°",
              "reproduced" if zb["asym_mimo_mrac"] < 0.1 * zb["asym_passive"] else "not",
              "the nominal design's, not the adaptation's: with adaptation off the bounce is also below 0.1× passive"
              if bounce_by_design else ""),
        Claim("pitch settled during acceleration (4–9 s)", "adapts within 4 s",
              f"max |pitch| {late['mimo_mrac']:.3f}° (asymmetric {late['asym_mimo_mrac']:.3f}°){off_settle}",
              "reproduced" if late["mimo_mrac"] < 0.2 else "not",
              ("the adaptation's: with it off the squat is held only to "
               f"{late['mimo_fixed']:.2f}°, above the 0.2° bound") if fx and late["mimo_fixed"] >= 0.2 else ""),
        polarity_claim("actuator polarities", "squat: leading compresses, trailing extends; reversed in braking",
                       a, "accelerating", b, "braking"),
    ]
    if "wrong_design" in ts:
        late.update({k: float(np.degrees(np.max(np.abs(ts[k].pitch.to_numpy()[win(ts[k], 4, 9)]))))
                     for k in ("wrong_design", "wrong_design_fixed")})
        ok = {k: pk[k] < 0.2 * pk["passive"] and late[k] < 0.2 for k in ("wrong_design", "wrong_design_fixed")}
        claims.append(Claim(
            "from a wrong design (nominal M_s +20 %, I −20 %, K0 −30 %, C0 +30 %; ours): dive removed (≤ 0.2× passive) "
            "and pitch settled at 4–9 s (< 0.2°)", "initial parameters arbitrary; adapts within 4 s, dive eliminated",
            f"peak pitch {pk['wrong_design']:.2f}°, 4–9 s {late['wrong_design']:.3f}°; adaptation off "
            f"{pk['wrong_design_fixed']:.2f}°, {late['wrong_design_fixed']:.3f}°; right design {pk['mimo_mrac']:.2f}°, "
            f"{late['mimo_mrac']:.3f}°", "reproduced" if ok["wrong_design"] and not ok["wrong_design_fixed"] else
            "not shown" if ok["wrong_design"] else "not", "the baseline fails it" if not ok["wrong_design_fixed"]
            else "the baseline passes it too"))
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.0), sharex=True)
    for k, s in (("passive", "g-"), ("mimo_mrac", "r-"), ("asym_passive", "g--"), ("asym_mimo_mrac", "r--")):
        ax[0].plot(ts[k].t, np.degrees(ts[k].pitch), s, lw=0.8, label=k)
        ax[1].plot(ts[k].t, 1000 * ts[k].body_z, s, lw=0.8)
    ax[2].plot(ts["mimo_mrac"].t, ts["mimo_mrac"].actuator_force_front, "b-", lw=0.8, label="front")
    ax[2].plot(ts["mimo_mrac"].t, ts["mimo_mrac"].actuator_force_rear, "m-", lw=0.8, label="rear")
    # the printed law (κ = 1, no bias) and κ = 1 with our bias, each until its divergence stop
    for k, s in (("mimo_mrac_thesis", "k-"), ("mimo_mrac_thesis_bias", "c-")):
        lab = "printed (κ = 1, no bias)" if k == "mimo_mrac_thesis" else "κ = 1 + our bias"
        if k in ts:
            ax[0].plot(ts[k].t, np.degrees(ts[k].pitch), s, lw=0.8, label=lab)
        elif k in dv:
            tk = _until_stop(ctx, dv[k])
            _draw_until_stop(ax[0], tk, "pitch", 180 / np.pi, s, lab, dv[k])
            _draw_until_stop(ax[1], tk, "body_z", 1000.0, s, lab, None)
    ax[0].set_ylabel("pitch (°, nose down +)")
    ax[0].legend(fontsize=7, ncol=2)
    ax[1].set_ylabel("bounce (mm)")
    ax[2].set_ylabel("MRAC force (N)")
    ax[2].legend(fontsize=7)
    ax[2].set_xlabel("time (s)")
    fig.suptitle("Thesis Ch. 7: accelerate 4 m/s² (1–9 s), brake 7 m/s² (9–11 s);\nthe printed law (κ = 1, no bias) "
                 "until it runs away; ours: κ = 0.2 with the bias (`mimo_mrac`)", fontsize=9)
    fig.tight_layout()
    key.update({"passive_dive_deg": (dive, 0.1), "mrac_pitch_deg": (pk["mimo_mrac"], 0.1),
                "asym_passive_bounce": (zb["asym_passive"], 1e-3), "asym_mrac_bounce": (zb["asym_mimo_mrac"], 1e-3)})
    if fx:  # the adaptation-off baselines' numbers of the rows above
        key.update({"fixed_pitch_deg": (pk["mimo_fixed"], 0.1), "fixed_settle_deg": (late["mimo_fixed"], 0.1),
                    "asym_fixed_bounce": (zb["asym_mimo_fixed"], 1e-3)})
    if "wrong_design" in pk:
        key.update({"wrong_pitch_deg": (pk["wrong_design"], 0.1), "wrong_fixed_pitch_deg": (pk["wrong_design_fixed"], 0.1)})
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE])


# ---- Ch. 7, road-excited: Sec. 7.5.1 (Figs. 7.4–7.7) and Sec. 7.5.2 (Figs. 7.8–7.12) ------------------------

def _ch7_ref_gain(f, speed, L=3.0, M=500.0, I=1125.0, mu=45.0, a=1.5, b=1.5, Km=17000.0, Cm=9000.0, Dm=9000.0,
                  kt=100000.0):
    """Gain factors of the two-tier skyhook reference (the controller's model, thesis_mimo_mrac) to the leading
    road input, the trailing wheel seeing it τ = L/v later: |x_wf/w_f|, |travel_f/w_f|, |(x_wf − w_f)/w_f|."""
    Mr = np.diag([M, I, mu, mu])
    S = np.array([[1.0, -a, -1.0, 0.0], [1.0, b, 0.0, -1.0]])
    Tb = np.array([[1.0, -a, 0.0, 0.0], [1.0, b, 0.0, 0.0]])
    Tw = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    Kr, Cr = Km * S.T @ S + kt * Tw.T @ Tw, Cm * Tb.T @ Tb + Dm * Tw.T @ Tw
    out = np.zeros((3, len(f)))
    for i, fi in enumerate(f):
        s = 2j * np.pi * fi
        d = np.array([1.0, np.exp(-s * L / speed)])
        force = np.zeros(4, complex)
        force[2:] = (kt + Dm * s) * d
        q = np.linalg.solve(Mr * s * s + Cr * s + Kr, force)
        out[:, i] = np.abs([q[2], (S @ q)[0], q[2] - 1.0])
    return out


def _err(ts, ref, col, a, b):
    m = win(ts, a, b)
    return rms((ts[col].to_numpy() - ref[col].to_numpy())[m])


def ch7_road(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    dv = {}
    res = run_each(ctx, ctx.variants("thesis_ch7_road"), "thesis_ch7_road", diverged=dv)
    _only_printed_diverge(dv)
    ts = {k: r.ts for k, r in res.items()}
    m = ts["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"], pitch=m["ctrl.ref_pitch"])  # the reference in the plant's columns
    e = {k: {c: _err(t, ref, c, 4, 20) for c in ("body_z", "pitch")} for k, t in ts.items()}
    e_first = {c: _err(m, ref, c, 0, 4) for c in ("body_z", "pitch")}
    size = {c: rms(ref[c].to_numpy()[win(ref, 4, 20)]) for c in ("body_z", "pitch")}
    acc_ = {k: {c: _err(t, ref, c, 20, 25) for c in ("body_z", "pitch")} for k, t in ts.items()}
    cruise = {k: {c: _err(t, ref, c, 25, 40) for c in ("body_z", "pitch")} for k, t in ts.items()}
    dive = {k: float(np.degrees(np.max((t.pitch.to_numpy() - ref.pitch.to_numpy())[win(t, 40, 43)])))
            for k, t in ts.items()}
    a = m[win(m, 22, 28)]
    b = m[win(m, 40.3, 42)]
    deg = np.degrees
    claims = [
        Claim("bounce is excited (road reaches the rear τ = L/v later)", "bounce response (Fig. 7.4)",
              f"passive bounce RMS 4–20 s {rms(ts['passive'].body_z.to_numpy()[win(ts['passive'], 4, 20)]) * 1000:.1f} mm; "
              f"reference {size['body_z'] * 1000:.1f} mm", "n.a.", "the symmetric braking case has none"),
        Claim("bounce follows the reference after 4 s (RMS(x_b − x_b,ref), 4–20 s)",
              "adapts to the reference within the first 4 s (Fig. 7.4)",
              f"MRAC {e['mimo_mrac']['body_z'] * 1000:.2f} mm (0–4 s: {e_first['body_z'] * 1000:.2f}); adaptation off "
              f"{e['mimo_fixed']['body_z'] * 1000:.2f} mm; passive {e['passive']['body_z'] * 1000:.1f} mm",
              "reproduced" if e["mimo_mrac"]["body_z"] < min(0.2 * e["passive"]["body_z"],
                                                            0.5 * e["mimo_fixed"]["body_z"]) else "not"),
        Claim("pitch follows the reference after 4 s (RMS(θ − θ_ref), 4–20 s)", "within 4 s (Fig. 7.5)",
              f"MRAC {deg(e['mimo_mrac']['pitch']):.3f}° (0–4 s: {deg(e_first['pitch']):.3f}°); adaptation off "
              f"{deg(e['mimo_fixed']['pitch']):.3f}°; passive {deg(e['passive']['pitch']):.3f}°; reference "
              f"{deg(size['pitch']):.3f}° RMS",
              "reproduced" if e["mimo_mrac"]["pitch"] < min(0.2 * e["passive"]["pitch"],
                                                           0.5 * e["mimo_fixed"]["pitch"]) else "not"),
        Claim("acceleration at 20 s: deviates slightly, re-adapts within 5 s",
              "slight deviation at 20 s, back within 5 s",
              f"bounce error 20–25 s {acc_['mimo_mrac']['body_z'] * 1000:.2f} mm, 25–40 s "
              f"{cruise['mimo_mrac']['body_z'] * 1000:.2f} mm (passive {acc_['passive']['body_z'] * 1000:.1f}, "
              f"{cruise['passive']['body_z'] * 1000:.1f}); pitch {deg(acc_['mimo_mrac']['pitch']):.3f}°, "
              f"{deg(cruise['mimo_mrac']['pitch']):.3f}°",
              "reproduced" if cruise["mimo_mrac"]["body_z"] < 0.2 * cruise["passive"]["body_z"] else "not"),
        Claim("nose dive at 40 s removed (peak θ − θ_ref, 40–43 s)", "≈ 6° eliminated (Fig. 7.5)",
              f"passive {dive['passive']:.2f}°, MRAC {dive['mimo_mrac']:.2f}°, adaptation off {dive['mimo_fixed']:.2f}°",
              "reproduced" if dive["mimo_mrac"] < 0.2 * dive["passive"] else "not"),
        polarity_claim("polarities (Fig. 7.6)", "20–30 s leading compresses, trailing extends; reversed at 40 s",
                       a, "22–28 s", b, "40.3–42 s"),
    ]
    key = {}
    if any(k in ts or k in dv for k in ("mimo_mrac_thesis", "mimo_fixed_thesis", "mimo_mrac_thesis_bias")):
        def printed(k):
            if k in dv:  # (no key: the stop time of the runaway depends on the step, the page gives both)
                return "diverges: " + diverged_text(dv[k])
            if k not in ts:
                return "not run"
            du, up = _ring(ts[k])
            key[f"{k}_bounce_err"] = (e[k]["body_z"], 1e-3)
            return (f"ran to the end: bounce error 4–20 s {e[k]['body_z'] * 1000:.2f} mm, pitch "
                    f"{deg(e[k]['pitch']):.3f}°, dive {dive[k]:.2f}°; mean |ΔU| {du:.0f} N per 0.01 s step, peak |U| "
                    f"{up / 1000:.1f} kN")
        du_o, up_o = _ring(m)
        claims.insert(1, Claim(
            f"{PRINTED_CH7}, the same with adaptation off (`mimo_fixed_thesis`), and with our bias ({BIAS_CH7})",
            "adapts within 4 s, follows the reference, dive removed",
            f"adaptive: {printed('mimo_mrac_thesis')}; adaptation off: {printed('mimo_fixed_thesis')}; with our bias: "
            f"{printed('mimo_mrac_thesis_bias')}; ours (κ = 0.2 with the bias, "
            f"`mimo_mrac`): mean |ΔU| {du_o:.0f} N per step, peak |U| {up_o / 1000:.1f} kN",
            "not" if "mimo_mrac_thesis" in dv or "mimo_mrac_thesis" not in ts
            or e["mimo_mrac_thesis"]["body_z"] > 0.2 * e["passive"]["body_z"] else "reproduced",
            "the pure d-step-ahead law cancels the sampling zero near z = −1 (thesis_common.DiscreteMRAC); the other "
            "rows are ours (κ = 0.2 with the bias)"))
    if "mimo_mrac_no_bias" in ts:  # the printed regressor (no constant −1), κ = 0.2
        nb = "mimo_mrac_no_bias"
        claims.append(Claim(
            "without the bias parameter (the printed φ, `mimo_mrac_no_bias`, κ = 0.2): bounce / pitch error 4–20 s, "
            "dive 40–43 s", "follows; dive removed",
            f"{e[nb]['body_z'] * 1000:.2f} mm, {deg(e[nb]['pitch']):.3f}°, dive {dive[nb]:.2f}° (with our bias "
            f"{e['mimo_mrac']['body_z'] * 1000:.2f} mm, {deg(e['mimo_mrac']['pitch']):.3f}°, {dive['mimo_mrac']:.2f}°)",
            "reproduced" if (e[nb]["body_z"] < 0.2 * e["passive"]["body_z"] and dive[nb] < 0.2 * dive["passive"])
            else "not"))
        key.update({"no_bias_bounce_err": (e[nb]["body_z"], 1e-3), "no_bias_dive_deg": (dive[nb], 0.1)})
    if "wrong_design" in ts:
        # errors to the common reference (the wrong design keeps the thesis's reference masses, ref_*)
        wins = ((0, 4), (4, 20), (20, 40), (44, 60))
        w = {(k, c, t0): _err(ts[k], ref, c, t0, t1) for k in ("wrong_design", "wrong_design_fixed", "mimo_mrac")
             for c in ("body_z", "pitch") for t0, t1 in wins}
        dive.update({k: float(np.degrees(np.max((ts[k].pitch.to_numpy() - ref.pitch.to_numpy())[win(ts[k], 40, 43)])))
                     for k in ("wrong_design", "wrong_design_fixed")})
        # the property (thesis: adapts within 4 s from arbitrary initial parameters): after 4 s the error is within
        # 20 % of the right design's (or below), in every later window, and the dive is removed (≤ 0.2× passive)
        reach = {k: all(w[k, c, t0] <= 1.2 * w["mimo_mrac", c, t0] for c in ("body_z", "pitch") for t0, _ in wins[1:])
                 and dive[k] < 0.2 * dive["passive"] for k in ("wrong_design", "wrong_design_fixed")}

        def row(k):
            return (" / ".join(f"{w[k, 'body_z', t0] * 1000:.2f}" for t0, _ in wins) + " mm, pitch "
                    + " / ".join(f"{deg(w[k, 'pitch', t0]):.3f}" for t0, _ in wins) + f"°, dive {dive[k]:.2f}°")
        beats = all(w["wrong_design", c, t0] < w["wrong_design_fixed", c, t0] for c in ("body_z", "pitch")
                    for t0, _ in wins) and dive["wrong_design"] < dive["wrong_design_fixed"]
        claims.append(Claim(
            "adaptation from a wrong design (nominal M_s +20 %, I −20 %, K0 −30 %, C0 +30 %; ours): errors "
            + ", ".join(f"{a}–{b} s" for a, b in wins) + "; dive 40–43 s",
            "adapts within the first 4 s from arbitrary initial parameters; robust at 20 and 40 s",
            f"wrong start: bounce {row('wrong_design')}; adaptation off: {row('wrong_design_fixed')}; right design: "
            f"{row('mimo_mrac')}",
            "reproduced" if reach["wrong_design"] and not reach["wrong_design_fixed"] else
            "not shown" if reach["wrong_design"] else "partly" if beats else "not",
            "property: after 4 s within 1.2× the right design's error in every window, dive ≤ 0.2× passive; the "
            + ("baseline fails it" if not reach["wrong_design_fixed"] else "baseline passes it too")))
        key["wrong_design_bounce_err"] = (w["wrong_design", "body_z", 4], 1e-4)
        key["wrong_design_dive_deg"] = (dive["wrong_design"], 0.1)
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.5), sharex=True)
    for k, s_ in (("passive", "g-"), ("mimo_fixed", "b-"), ("mimo_mrac", "r-")):
        ax[0].plot(ts[k].t, 1000 * ts[k].body_z, s_, lw=0.5, label=k)
        ax[1].plot(ts[k].t, np.degrees(ts[k].pitch), s_, lw=0.5)
    ax[0].plot(m.t, 1000 * ref.body_z, "k:", lw=0.7, label="reference")
    ax[1].plot(m.t, np.degrees(ref.pitch), "k:", lw=0.7)
    if "mimo_mrac_thesis" in dv:  # the printed law (κ = 1, no bias) until its divergence stop
        tp = _until_stop(ctx, dv["mimo_mrac_thesis"])
        _draw_until_stop(ax[0], tp, "body_z", 1000.0, "c-", "printed (κ = 1, no bias)", dv["mimo_mrac_thesis"])
        _draw_until_stop(ax[1], tp, "pitch", 180 / np.pi, "c-", "printed", None)
    ax[2].plot(m.t, m.actuator_force_front, "b-", lw=0.5, label="front (leading)")
    ax[2].plot(m.t, m.actuator_force_rear, "m-", lw=0.5, label="rear (trailing)")
    ax[0].set_ylabel("bounce (mm)")
    ax[0].legend(fontsize=7, ncol=4)
    ax[1].set_ylabel("pitch (°, nose down +)")
    ax[2].set_ylabel("MRAC force (N)")
    ax[2].legend(fontsize=7)
    ax[2].set_xlabel("time (s)  [accelerate 20–28 s, brake 40–42 s; springs −20 % 10–50 s]")
    fig.suptitle("Thesis Ch. 7, Sec. 7.5.1 (Figs. 7.4–7.6): sines with front–rear delay + manoeuvre + drift",
                 fontsize=9)
    fig.tight_layout()
    key.update({"mrac_bounce_err": (e["mimo_mrac"]["body_z"], 1e-3), "mrac_pitch_err_deg": (deg(e["mimo_mrac"]["pitch"]), 0.05),
                "passive_bounce_err": (e["passive"]["body_z"], 1e-3), "passive_dive_deg": (dive["passive"], 0.1),
                "mrac_dive_deg": (dive["mimo_mrac"], 0.1)})
    # every other number of the rows above (issue 12 item 3: the page gives each one's change on halving): the
    # baselines of the following and dive rows, the re-adaptation windows, the polarity forces, the printed-law rows
    key.update({"fixed_bounce_err": (e["mimo_fixed"]["body_z"], 1e-3), "fixed_pitch_err_deg": (deg(e["mimo_fixed"]["pitch"]), 0.05),
                "passive_pitch_err_deg": (deg(e["passive"]["pitch"]), 0.05), "fixed_dive_deg": (dive["mimo_fixed"], 0.1),
                "mrac_bounce_err_20_25": (acc_["mimo_mrac"]["body_z"], 1e-3),
                "mrac_bounce_err_25_40": (cruise["mimo_mrac"]["body_z"], 1e-3),
                "squat_force_front": (float(a.actuator_force_front.mean()), 100.0),
                "squat_force_rear": (float(a.actuator_force_rear.mean()), 100.0),
                "brake_force_front": (float(b.actuator_force_front.mean()), 100.0),
                "brake_force_rear": (float(b.actuator_force_rear.mean()), 100.0)})
    if "mimo_fixed_thesis" in ts:
        key["mimo_fixed_thesis_pitch_err_deg"] = (deg(e["mimo_fixed_thesis"]["pitch"]), 0.05)
        key["mimo_fixed_thesis_dive_deg"] = (dive["mimo_fixed_thesis"], 0.1)
        key["mimo_fixed_thesis_dU"] = (_ring(ts["mimo_fixed_thesis"])[0], 100.0)
    if "mimo_mrac_no_bias" in ts:
        key["no_bias_pitch_err_deg"] = (deg(e["mimo_mrac_no_bias"]["pitch"]), 0.05)
    if "wrong_design" in ts:  # the wrong start's partly: its pitch error against the right design's, per window
        for t0, t1 in ((4, 20), (20, 40), (44, 60)):
            key[f"wrong_design_pitch_ratio_{t0}_{t1}"] = (w["wrong_design", "pitch", t0] / w["mimo_mrac", "pitch", t0], 0.1)
            key[f"wrong_fixed_bounce_err_{t0}_{t1}"] = (w["wrong_design_fixed", "body_z", t0], 1e-3)
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE])


def _ch7_batch(ts, th0, am, lo, hi, K0=17000.0, C0=500.0):
    """Batch least-squares estimates of (β0)⁻¹ (diagonal / the nominal design's th0) from a Ch. 7 run logged at the
    0.01 s control step, over [lo, hi): the quantities of the controller (Y = [x_b, θ], U = u + K0·w + C0·ẇ, a_m):

    - ``direct``: the MRAC's estimator identity (direct form, as estimated online): U[k−1] on
      [−Y[k−1], −Y[k−2], −U[k−2], −1, Ȳ[k]], Ȳ[k] = a_m(q⁻¹)Y[k] the *measured* output in the regressor;
    - ``direct_w``: the same with the road terms −W[k] … −W[k−3] (the thesis's printed regressor, Eq. 7.44, its β²
      terms);
    - ``forward``: the predictor itself (indirect form), Ȳ[k+1] on [Y[k], Y[k−1], U[k], U[k−1], 1], whose U[k]
      coefficient is β0 (inverted): the road's disturbance sits in the regressed variable, not in a regressor.

    Also ``resid``: (RMS of the nominal design's identity residual, RMS of U), N."""
    bi0 = np.diag(th0[-2:])
    Y = ts[["body_z", "pitch"]].to_numpy()
    W = ts[["road_front", "road_rear"]].to_numpy()
    U = ts[["command_front", "command_rear"]].to_numpy() + K0 * W + C0 * ts[["road_vel_front", "road_vel_rear"]].to_numpy()
    k = np.arange(6, len(Y) - 2)
    k = k[win(ts.iloc[k], lo, hi)]

    def yb(i):
        return am[0] * Y[i] + am[1] * Y[i - 1] + am[2] * Y[i - 2]

    one = np.ones((len(k), 1))
    phi = np.hstack([-Y[k - 1], -Y[k - 2], -U[k - 2], -one, yb(k)])
    phiw = np.hstack([-Y[k - 1], -Y[k - 2], -U[k - 2], -W[k], -W[k - 1], -W[k - 2], -W[k - 3], -one, yb(k)])
    r = {}
    for form, ph in (("direct", phi), ("direct_w", phiw)):
        est = np.linalg.lstsq(ph, U[k - 1], rcond=None)[0]
        r[form] = tuple(float(x) for x in np.diag(est[-2:]) / bi0)
    X = np.hstack([Y[k], Y[k - 1], U[k], U[k - 1], one])
    est = np.linalg.lstsq(X, yb(k + 1), rcond=None)[0]
    r["forward"] = tuple(float(x) for x in np.diag(np.linalg.inv(est[4:6])) / bi0)
    r["resid"] = (rms(U[k - 1] - phi @ th0), rms(U[k - 1]))
    return r


def ch7_regression(ctx, duration=30.0, amplitude=1000.0):
    """Is the dirt road's pull on (β0)⁻¹ the estimator's?  The Ch. 7 plant (thesis_ch7_dirt, drifts off) driven open
    loop by a random force on each actuator (1 kN, independent per corner and of the road, held 0.01 s), on a flat
    road and on the dirt road; :func:`_ch7_batch` over 2 s … end.  Returns ({road: estimates}, th0, a_m)."""
    from ..config import parse_scenario, read_yaml
    from ..controllers.thesis_common import am_poly
    from .framework import scenarios_dir

    raw = read_yaml(scenarios_dir() / "thesis_ch7_dirt.yaml")
    th = run_each(ctx, ctx.variants("thesis_ch7_dirt", ["sim.duration=0.05"], only=["mimo_mrac"]), "thesis_ch7_dirt")
    t0 = th["mimo_mrac"].ts
    th0 = t0[[c for c in t0.columns if c.startswith("ctrl.theta.")]].to_numpy()[0].reshape(-1, 2)
    am = am_poly(2 * np.pi * 2.0, 1.0, 0.01)
    out = {}
    for road in ("flat", "dirt"):
        d = {**raw, "variants": {}, "sim": {**raw["sim"], "duration": duration},
             "vehicle": {**raw["vehicle"], "variations": []},
             "controller": {"type": "open_loop", "params": {"signal": "random", "amplitude": amplitude,
                                                            "independent": True, "hold": 0.01, "seed": 3}}}
        if road == "flat":
            d["road"] = {"type": "flat"}
        sc = ctx.scale_step(parse_scenario(d))
        sc.sim.control_dt = raw["sim"]["control_dt"]  # the law's 0.01 s (HALF_NOTE)
        out[road] = _ch7_batch(ctx.run({road: sc}, label="thesis_ch7_dirt")[road].ts, th0, am, 2.0, duration)
    return out, th0, am


def ch7_dirt(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt
    from scipy.signal import csd, welch

    div = {}  # the probing IV variant may run away (page), and the printed κ = 1 law (a result)
    res = run_each(ctx, ctx.variants("thesis_ch7_dirt"), "thesis_ch7_dirt", diverged=div)
    for k, e_ in div.items():
        if "probe" not in k and k not in ("mimo_mrac_thesis", "mimo_mrac_thesis_bias", "mimo_mrac_no_bias"):
            raise e_
    ts = {k: r.ts for k, r in res.items()}
    m = ts["mimo_mrac"]
    ref = m.assign(body_z=m["ctrl.ref_z"], pitch=m["ctrl.ref_pitch"])
    names = ("passive", "mimo_fixed", "mimo_mrac", "mimo_mrac_q0")
    e = {k: {c: _err(ts[k], ref, c, 4, 60) for c in ("body_z", "pitch")} for k in names}
    drift_ = {k: [_err(ts[k], ref, "body_z", a_, a_ + 12) for a_ in range(0, 60, 12)] for k in names}
    size = rms(ref.body_z.to_numpy()[win(ref, 4, 60)])
    acc = {k: rms(ts[k].body_acc.to_numpy()[win(ts[k], 4, 60)]) for k in names}
    acc_ref = rms(m["ctrl.ref_acc"].to_numpy()[win(m, 4, 60)])
    # gain factors to the leading road input (10–60 s), H1 = |S_xy / S_xx|
    gains, bands = {}, ((0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (6.0, 12.0))
    for k in names:
        t = ts[k][win(ts[k], 10, 60)]
        fs = 1.0 / float(t.t.iloc[1] - t.t.iloc[0])
        w = t.road_front.to_numpy()
        f, Pww = welch(w, fs=fs, nperseg=1024)
        outs = (t.wheel_z_front.to_numpy(), t.travel_front.to_numpy(), t.wheel_z_front.to_numpy() - w)
        gains[k] = [np.abs(csd(w, y, fs=fs, nperseg=1024)[1] / Pww) for y in outs]
    gains["reference"] = list(_ch7_ref_gain(f, 20.0))

    def band(g, lo, hi):
        s = (f >= lo) & (f < hi)
        return float(np.mean(g[s]))

    rows = []
    for k in ("reference",) + names:
        rows.append([k] + [f"{band(gains[k][1], lo, hi):.3g}" for lo, hi in bands]
                    + [f"{band(gains[k][2], 6.0, 12.0):.3g}"])
    deg = np.degrees
    ok_q = e["mimo_mrac"]["body_z"] < min(0.5 * e["passive"]["body_z"], e["mimo_fixed"]["body_z"])
    ok_q0 = e["mimo_mrac_q0"]["body_z"] < min(0.5 * e["passive"]["body_z"], 0.8 * e["mimo_fixed"]["body_z"])
    claims, pkey = [], {}
    if "mimo_mrac_thesis" in div or "mimo_mrac_thesis" in ts:
        if "mimo_mrac_thesis" in div:
            # (no key: the stop time of the runaway depends on the step, the page gives both)
            got_p, ok_p = "diverges: " + diverged_text(div["mimo_mrac_thesis"]), "not"
        else:
            ep_ = _err(ts["mimo_mrac_thesis"], ref, "body_z", 4, 60)
            du, up = _ring(ts["mimo_mrac_thesis"])
            got_p = (f"ran to the end: bounce error {ep_ * 1000:.1f} mm; mean |ΔU| {du:.0f} N per step, peak |U| "
                     f"{up / 1000:.1f} kN")
            ok_p = "reproduced" if ep_ < min(0.5 * e["passive"]["body_z"], e["mimo_fixed"]["body_z"]) else "not"
            pkey["printed_bounce_err"] = (ep_, 1e-3)
        if "mimo_mrac_thesis_bias" in div:  # (no key: as above)
            got_p += f"; with our bias ({BIAS_CH7}): diverges at {div['mimo_mrac_thesis_bias'].time:.2f} s"
        claims.append(Claim(PRINTED_CH7, "adapts within 4 s, follows closely throughout (Fig. 7.8)", got_p, ok_p,
                            "the rows below are ours (κ = 0.2 with the bias)"))
    if "mimo_mrac_no_bias" in ts or "mimo_mrac_no_bias" in div:
        if "mimo_mrac_no_bias" in div:
            got_nb = f"diverges at {div['mimo_mrac_no_bias'].time:.2f} s"
        else:
            e_nb = _err(ts["mimo_mrac_no_bias"], ref, "body_z", 4, 60)
            got_nb = f"bounce error {e_nb * 1000:.1f} mm (with our bias {e['mimo_mrac']['body_z'] * 1000:.1f} mm)"
            pkey["no_bias_bounce_err"] = (e_nb, 1e-3)
        claims.append(Claim("without the bias parameter (the printed φ, `mimo_mrac_no_bias`, κ = 0.2), 4–60 s",
                            "follows closely", got_nb, "not" if "mimo_mrac_no_bias" in div or e_nb > 0.5 * size
                            else "reproduced"))
    claims += [
        Claim("bounce follows the reference from 4 s on (RMS(x_b − x_b,ref), 4–60 s), thesis tuning of Ch. 7 (ours: κ = 0.2)",
              "adapts within 4 s, follows closely throughout (Fig. 7.8)",
              f"MRAC {e['mimo_mrac']['body_z'] * 1000:.1f} mm, per 12 s " +
              ", ".join(f"{x * 1000:.0f}" for x in drift_["mimo_mrac"]) + f" mm; adaptation off "
              f"{e['mimo_fixed']['body_z'] * 1000:.1f} mm; passive {e['passive']['body_z'] * 1000:.1f} mm; reference "
              f"moves {size * 1000:.1f} mm RMS", "reproduced" if ok_q else "not",
              "covariance addition Q = 1e-6 (the braking tuning) lets the estimates drift on this road"),
        Claim("same, no covariance addition on the model parameters (`mimo_mrac_q0`)", "as above",
              f"{e['mimo_mrac_q0']['body_z'] * 1000:.1f} mm, per 12 s " +
              ", ".join(f"{x * 1000:.0f}" for x in drift_["mimo_mrac_q0"]) + " mm",
              "reproduced" if ok_q0 else "not", "adaptation must beat the fixed nominal design (0.8×)"),
        Claim("pitch follows the reference (RMS(θ − θ_ref), 4–60 s)", "closely (Fig. 7.9)",
              f"MRAC {deg(e['mimo_mrac']['pitch']):.2f}°, q0 {deg(e['mimo_mrac_q0']['pitch']):.2f}°, adaptation off "
              f"{deg(e['mimo_fixed']['pitch']):.2f}°, passive {deg(e['passive']['pitch']):.2f}°",
              "reproduced" if e["mimo_mrac_q0"]["pitch"] < 0.5 * e["passive"]["pitch"] else "not"),
        Claim("body acceleration RMS (4–60 s)", "good isolation (reference's)",
              f"reference {acc_ref:.2f}, passive {acc['passive']:.2f}, MRAC {acc['mimo_mrac']:.2f}, q0 "
              f"{acc['mimo_mrac_q0']:.2f}, adaptation off {acc['mimo_fixed']:.2f} m/s²",
              "reproduced" if acc["mimo_mrac_q0"] < acc["passive"] else "not"),
        Claim("leading travel gain factor near the body modes (1–2 Hz) (Fig. 7.11)",
              "reference's; less than passive at the natural frequencies",
              f"reference {band(gains['reference'][1], 1, 2):.2f}, MRAC {band(gains['mimo_mrac'][1], 1, 2):.2f}, q0 "
              f"{band(gains['mimo_mrac_q0'][1], 1, 2):.2f}, passive {band(gains['passive'][1], 1, 2):.2f}",
              "reproduced" if band(gains["mimo_mrac_q0"][1], 1, 2) < band(gains["passive"][1], 1, 2) else "not"),
        Claim("leading tire deflection gain factor at wheel hop (6–12 Hz) (Fig. 7.12)", "follows the reference",
              f"reference {band(gains['reference'][2], 6, 12):.2f}, MRAC {band(gains['mimo_mrac'][2], 6, 12):.2f}, q0 "
              f"{band(gains['mimo_mrac_q0'][2], 6, 12):.2f}, passive {band(gains['passive'][2], 6, 12):.2f}",
              "reproduced" if abs(band(gains["mimo_mrac_q0"][2], 6, 12) / band(gains["reference"][2], 6, 12) - 1) < 0.3
              else "not", "the reference has 9 kN·s/m wheel-to-ground dampers no actuator between body and wheel can give"),
    ]
    # why the braking tuning drifts (page): the RLS regresses U on the filtered measured output, which carries the
    # road's disturbance; the (β0)⁻¹ diagonal (the gain of the whole regulator) is pulled to its lower bound
    wkey = {}
    thc = [c for c in m.columns if c.startswith("ctrl.theta.")]
    npar = len(thc) // 2
    bdiag = (f"ctrl.theta.{2 * (npar - 2)}", f"ctrl.theta.{2 * (npar - 1) + 1}")
    b_end = {k: [float(ts[k][c].iloc[-1] / ts[k][c].iloc[0]) for c in bdiag] for k in ("mimo_mrac", "mimo_mrac_q0")}
    t_bound = {k: float(ts[k].t.to_numpy()[np.argmax(ts[k][bdiag[0]].to_numpy() <= 0.2001 * ts[k][bdiag[0]].iloc[0])])
               for k in ("mimo_mrac", "mimo_mrac_q0")}
    claims.append(Claim("diagnosis: the (β0)⁻¹ diagonal estimate (it scales the whole regulator), end / start",
                        "(not in the thesis)", "; ".join(f"{k}: {b[0]:.2f}, {b[1]:.2f} (front-bounce entry at the 0.2× "
                                                         f"bound from {t_bound[k]:.1f} s)" for k, b in b_end.items()),
                        "n.a.", "pulled down to the projection bound by the road disturbance in the regressor (page)"))
    # whose is the pull: the estimator's form (the measured output as a regressor) or the closed loop?
    ol, th0, am = ch7_regression(ctx)
    cl = _ch7_batch(ts["mimo_fixed"], th0, am, 4.0, 10.0)

    def pr(x):
        return f"{x[0]:.2f} / {x[1]:.2f}"

    claims.append(Claim(
        "diagnosis: whose is the pull? batch least-squares (β0)⁻¹ (bounce / pitch diagonal ÷ the nominal design's) "
        "on open-loop data (a random 1 kN force on each actuator, no feedback; drifts off) and on the closed loop "
        "(`mimo_fixed`, 4–10 s)", "(not in the thesis; its estimator is the direct form with the road terms ΔW, "
        "Eq. 7.44)",
        f"open loop, flat road: direct form {pr(ol['flat']['direct'])}, forward (predictor) form "
        f"{pr(ol['flat']['forward'])}; dirt road: direct {pr(ol['dirt']['direct'])}, with the thesis's ΔW terms "
        f"{pr(ol['dirt']['direct_w'])}, forward {pr(ol['dirt']['forward'])}; the nominal design's identity residual "
        f"{ol['dirt']['resid'][0]:.0f} N RMS against U {ol['dirt']['resid'][1]:.0f} N (flat {ol['flat']['resid'][0]:.0f} / "
        f"{ol['flat']['resid'][1]:.0f}); closed loop: direct {pr(cl['direct'])}, with ΔW {pr(cl['direct_w'])}, forward "
        f"{pr(cl['forward'])}", "n.a.",
        "the estimator's: the direct form regresses on the measured output, which carries the road's disturbance "
        "(errors in variables), so its (β0)⁻¹ is pulled toward zero even without feedback; the printed ΔW terms do "
        "not remove it; the forward form does in open loop (bounce), not in the closed loop"))
    wkey.update({"ol_flat_direct": (ol["flat"]["direct"][0], 0.1), "ol_dirt_direct": (ol["dirt"]["direct"][0], 0.1),
                 "ol_dirt_forward": (ol["dirt"]["forward"][0], 0.1)})
    if "wrong_design" in ts:
        wn = ("wrong_design", "wrong_design_q0", "wrong_design_fixed")
        ew = {k: {c: _err(ts[k], ref, c, 4, 60) for c in ("body_z", "pitch")} for k in wn}
        ew0 = {k: _err(ts[k], ref, "body_z", 0, 4) for k in wn + ("mimo_mrac", "mimo_mrac_q0", "mimo_fixed")}
        ok_w = ew["wrong_design_q0"]["body_z"] < min(0.5 * e["passive"]["body_z"], 0.8 * ew["wrong_design_fixed"]["body_z"])
        claims.append(Claim(
            "from a wrong design (nominal M_s +20 %, I −20 %, K0 −30 %, C0 +30 %; ours): bounce error 0–4 s / 4–60 s",
            "initial parameters arbitrary; adapts within 4 s, follows closely",
            f"wrong start {ew0['wrong_design'] * 1000:.1f} / {ew['wrong_design']['body_z'] * 1000:.1f} mm, q0 "
            f"{ew0['wrong_design_q0'] * 1000:.1f} / {ew['wrong_design_q0']['body_z'] * 1000:.1f} mm, adaptation off "
            f"{ew0['wrong_design_fixed'] * 1000:.1f} / {ew['wrong_design_fixed']['body_z'] * 1000:.1f} mm; right design "
            f"{ew0['mimo_mrac'] * 1000:.1f} / {e['mimo_mrac']['body_z'] * 1000:.1f}, q0 {ew0['mimo_mrac_q0'] * 1000:.1f} / "
            f"{e['mimo_mrac_q0']['body_z'] * 1000:.1f}, off {ew0['mimo_fixed'] * 1000:.1f} / "
            f"{e['mimo_fixed']['body_z'] * 1000:.1f} mm", "reproduced" if ok_w else "not",
            "q0 from the wrong start must beat the wrong design held fixed (0.8×) and passive (0.5×)"))
        wkey.update({"wrong_q0_bounce_err": (ew["wrong_design_q0"]["body_z"], 1e-3),
                     "wrong_fixed_bounce_err": (ew["wrong_design_fixed"]["body_z"], 1e-3)})
    pv = ("wrong_design_iv_probe", "wrong_design_ls_probe", "wrong_design_fixed_probe")
    if any(k in ts or k in div for k in pv):  # issue 12: closed-loop probing with an IV estimator (ours)
        ep = {k: _err(ts[k], ref, "body_z", 4, 60) for k in pv if k in ts}

        def bdiag_end(k):
            return ", ".join(f"{ts[k][c].iloc[-1] / ts[k][c].iloc[0]:.2f}" for c in bdiag) if k in ts else "—"

        def mm(k):
            return f"{ep[k] * 1000:.1f} mm" if k in ep else f"diverged ({div[k].time:.2f} s)"

        ok_p = ("wrong_design_iv_probe" in ep and "wrong_design_fixed_probe" in ep
                and ep["wrong_design_iv_probe"] < min(0.5 * size, 0.8 * ep["wrong_design_fixed_probe"]))
        claims.append(Claim(
            "from the wrong design with closed-loop probing (±300 N random per actuator; ours): the (β0)⁻¹ diagonal "
            "end / start, and the bounce error 4–60 s, for the IV estimator (`wrong_design_iv_probe`), the thesis's "
            "least squares with the same probe (`wrong_design_ls_probe`) and the design held (`wrong_design_fixed_probe`)",
            "adapts within 4 s, follows closely",
            f"IV: (β0)⁻¹ {bdiag_end('wrong_design_iv_probe')}, {mm('wrong_design_iv_probe')}; least squares: "
            f"{bdiag_end('wrong_design_ls_probe')}, {mm('wrong_design_ls_probe')}; held: "
            f"{mm('wrong_design_fixed_probe')}; the reference moves {size * 1000:.1f} mm RMS",
            "reproduced" if ok_p else "not",
            "the IV removes the pull on (β0)⁻¹ (least squares with the same probe still goes to the bound), but "
            "the error stays that of the design held: the claim needs more than an unbiased estimate (page)"))
        for k in ep:
            wkey[f"{k}_bounce_err"] = (ep[k], 1e-3)
    table = md_table(["leading travel / w_f", *[f"{lo}–{hi} Hz" for lo, hi in bands], "tire defl. / w_f 6–12 Hz"], rows)
    fig, ax = plt.subplots(2, 2, figsize=(9, 6.5))
    for k, s_ in (("passive", "g-"), ("mimo_fixed", "b-"), ("mimo_mrac", "r-"), ("mimo_mrac_q0", "m-")):
        ax[0, 0].plot(ts[k].t, 1000 * ts[k].body_z, s_, lw=0.4, label=k)
    ax[0, 0].plot(m.t, 1000 * ref.body_z, "k:", lw=0.6, label="reference")
    if "mimo_mrac_thesis" in div:  # the printed law (κ = 1, no bias) until its divergence stop
        _draw_until_stop(ax[0, 0], _until_stop(ctx, div["mimo_mrac_thesis"]),
                         "body_z", 1000.0, "c-", "printed (κ = 1, no bias)", div["mimo_mrac_thesis"])
    ax[0, 0].set_ylabel("bounce (mm)")
    ax[0, 0].set_xlabel("time (s)")
    ax[0, 0].legend(fontsize=6, ncol=2)
    for j, (lbl, axx) in enumerate((("unsprung bounce / w_f (Fig. 7.10)", ax[0, 1]),
                                     ("travel / w_f (Fig. 7.11)", ax[1, 0]), ("tire defl. / w_f (Fig. 7.12)", ax[1, 1]))):
        for k, s_ in (("passive", "g-"), ("mimo_fixed", "b-"), ("mimo_mrac", "r-"), ("mimo_mrac_q0", "m-"),
                      ("reference", "k--")):
            axx.loglog(f[1:], gains[k][j][1:], s_, lw=0.7, label=k)
        axx.set_xlim(0.3, 20)
        axx.set_ylabel(lbl, fontsize=8)
        axx.set_xlabel("Hz")
    ax[0, 1].legend(fontsize=6)
    fig.suptitle("Thesis Ch. 7, Sec. 7.5.2 (Figs. 7.8–7.12): Hac dirt road at 20 m/s, springs −20 % 10–50 s", fontsize=9)
    fig.tight_layout()
    key = {"mrac_bounce_err": (e["mimo_mrac"]["body_z"], 1e-3), "q0_bounce_err": (e["mimo_mrac_q0"]["body_z"], 1e-3),
           "fixed_bounce_err": (e["mimo_fixed"]["body_z"], 1e-3), "passive_bounce_err": (e["passive"]["body_z"], 1e-3),
           "q0_acc": (acc["mimo_mrac_q0"], 0.1), **wkey, **pkey}
    # every other number of the rows above (issue 12 item 3: the page gives each one's change on halving): the pitch
    # errors, body accelerations, and the gain factors the travel (1–2 Hz) and tire-deflection (6–12 Hz) rows compare
    for k in names:
        key[f"{k}_pitch_err_deg"] = (deg(e[k]["pitch"]), 0.05)
        key[f"{k}_acc"] = (acc[k], 0.1)
        key[f"{k}_travel_gain_1_2Hz"] = (band(gains[k][1], 1.0, 2.0), 0.1)
        key[f"{k}_tire_gain_6_12Hz"] = (band(gains[k][2], 6.0, 12.0), 0.1)
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE], tables=[table])


# ---- Ch. 5 ------------------------------------------------------------------------------------------------

CH5_REF_DAMPINGS = (750.0, 1500.0, 3000.0)  # lighter skyhook references than the thesis's D_m = 6000 N·s/m


def ch5(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt
    from scipy.signal import welch

    dn, dvar = {}, {}
    nom = run_each(ctx, ctx.variants("thesis_ch5_nominal"), "thesis_ch5_nominal", diverged=dn)
    var = run_each(ctx, ctx.variants("thesis_ch5_varying"), "thesis_ch5_varying", diverged=dvar)
    if dn:  # the nominal plant carries no extra static load: every law should run to the end
        raise next(iter(dn.values()))
    bands = ((0.25, 0.5), (0.5, 1.0), (1.0, 2.0), (2.0, 4.0), (4.0, 8.0))
    psd, rows = {}, []
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 6.0))
    for k in ("passive", "soc", "mrac", "mrac_nonadaptive", "mrac_thetad"):
        if k not in nom:
            continue
        ts = nom[k].ts[nom[k].ts.t > 5]
        fs = 1.0 / float(ts.t.iloc[1] - ts.t.iloc[0])
        f, P = welch(ts.body_acc.to_numpy(), fs=fs, nperseg=8192)
        psd[k] = [float(np.mean(P[(f >= lo) & (f < hi)])) for lo, hi in bands]
        rattle = rms(ts.travel.to_numpy())
        power = float(np.mean(np.abs(ts.actuator_force.to_numpy() * ts.travel_rate.to_numpy())))
        rows.append([k] + [f"{x:.2g}" for x in psd[k]] + [f"{rattle * 1000:.1f}", f"{power:.0f}"])
        psd[k + "_r"], psd[k + "_p"] = rattle, power
        s_ = {"passive": "g-", "soc": "b-", "mrac": "r-", "mrac_thetad": "m--", "mrac_nonadaptive": None}[k]
        if s_:
            ax[0].loglog(f[1:], P[1:], s_, lw=0.7, label=k)
    ax[0].set_xlim(0.2, 10)
    ax[0].set_ylim(1e-5, 3)
    ax[0].set_ylabel("body acc PSD (m²/s⁴/Hz)")
    ax[0].legend(fontsize=7)
    for k, s_ in (("passive", "g-"), ("soc_fixed", "b-"), ("soc_rescheduled_5s", "c-"), ("mrac", "r-"),
                  ("mrac_thetad", "m--"), ("mrac_thetad_nonadaptive", "k:")):
        if k not in var:
            continue
        ax[1].plot(var[k].ts.t, var[k].ts.body_z, s_, lw=0.5, label=k)
    ax[1].set_ylabel("body x (m), varying")
    ax[1].set_ylim(-1.5, 0.5)
    ax[1].set_xlabel("time (s)  [+150 kg 20–40 s; K −25 % from 33 s]")
    ax[1].legend(fontsize=7, ncol=2)
    fig.suptitle("Thesis Ch. 5: stochastic optimal control vs MRAC on the dirt road", fontsize=9)
    fig.tight_layout()
    sat = {k: float(np.mean(np.abs(var[k].ts.actuator_force.to_numpy()[win(var[k].ts, a, b)]) > 4990))
           for k, (a, b) in (("soc_fixed", (45, 60)), ("soc_rescheduled_5s", (45, 60)),
                             ("soc_rescheduled_10s", (45, 60)), ("mrac", (20, 60)), ("mrac_thetad", (20, 60)))
           if k in var}
    tv = ("mrac", "mrac_thetad", "mrac_thetad_nonadaptive")
    mz = {k: mean(var[k].ts, "body_z", 45, 60) for k in tv if k in var}
    mzl = {k: mean(var[k].ts, "body_z", 25, 40) for k in tv if k in var}
    mzs = {k: mean(var[k].ts, "body_z", 33, 35) for k in tv if k in var}  # the 2 s after the stiffness drop
    low, res_, hi = 0, (1, 2), (2, 3, 4)
    claims = [
        Claim("nominal: MRAC better at and above resonance (acc PSD, 0.5–8 Hz)", "MRAC better",
              "MRAC (printed) / SOC per band " + ", ".join(f"{psd['mrac'][i] / psd['soc'][i]:.2f}" for i in range(1, 5))
              + "; variant `mrac_thetad` / SOC " + ", ".join(f"{psd['mrac_thetad'][i] / psd['soc'][i]:.2f}"
                                                          for i in range(1, 5)),
              "reproduced" if all(psd["mrac"][i] < psd["soc"][i] for i in range(1, 5)) else "not"),
        Claim("nominal: SOC better at low frequency (0.25–0.5 Hz)", "SOC better",
              f"SOC {psd['soc'][low]:.2g}, MRAC (printed) {psd['mrac'][low]:.2g}, `mrac_thetad` "
              f"{psd['mrac_thetad'][low]:.2g} m²/s⁴/Hz",
              "reproduced" if psd["soc"][low] < psd["mrac"][low] else "not", "weights ρ1 = 10, ρ2 = 1e-7 ours"),
        Claim("nominal: SOC needs more rattle space", "more", f"SOC {psd['soc_r'] * 1000:.1f} mm, MRAC (printed) "
              f"{psd['mrac_r'] * 1000:.1f} mm, `mrac_thetad` {psd['mrac_thetad_r'] * 1000:.1f} mm RMS", "reproduced" if psd["soc_r"] > psd["mrac_r"] else "not"),
        Claim("nominal: SOC needs more actuator work ⟨|F·ż|⟩", "more", f"SOC {psd['soc_p']:.0f} W, MRAC (printed) "
              f"{psd['mrac_p']:.0f} W, `mrac_thetad` {psd['mrac_thetad_p']:.0f} W", "reproduced" if psd["soc_p"] > psd["mrac_p"] else "not"),
        Claim("varying: fixed-gain SOC goes unstable", "unstable", f"at the 5 kN limit {sat['soc_fixed']:.0%} "
              "of 45–60 s", "reproduced" if sat["soc_fixed"] > 0.5 else "not",
              "instability from our weights and our 25 % stiffness drop (the thesis gives neither)"),
        Claim("varying: rescheduling every 5 / 10 s restores stability", "stable",
              f"saturated {sat['soc_rescheduled_5s']:.0%} / {sat['soc_rescheduled_10s']:.0%} of 45–60 s",
              "reproduced" if max(sat["soc_rescheduled_5s"], sat["soc_rescheduled_10s"]) < 0.05 else "not"),
        Claim("varying: MRAC keeps its behaviour — the Ch. 3 law as printed (variant `mrac`: P1 = A_m, no "
              "static-load term)", "keeps it",
              diverged_text(dvar["mrac"]) if "mrac" in dvar else
              f"at the 5 kN limit {sat['mrac']:.0%} of 20–60 s; mean level 25–40 s {mzl['mrac'] * 100:.0f} cm, "
              f"45–60 s {mz['mrac'] * 100:.1f} cm",
              "reproduced" if "mrac" in var and sat["mrac"] < 0.01 and abs(mz["mrac"]) < 0.03
              and abs(mzl["mrac"]) < 0.03 else "not",
              "no constant term in the printed regulator: the load and the softer spring's lost share of the static "
              "load (Eq. 3.1, K(t)·δ_st) are carried by its static gain (ch3_load_step)"),
        Claim("varying: same with our θ_d and P1 = (s + 20)² (variant `mrac_thetad`, not in the thesis)", "keeps it",
              diverged_text(dvar["mrac_thetad"]) if "mrac_thetad" in dvar else
              f"never at the limit ({sat['mrac_thetad']:.0%}); mean level 25–40 s {mzl['mrac_thetad'] * 100:.1f} cm, "
              f"33–35 s {mzs['mrac_thetad'] * 100:.1f} cm, 45–60 s {mz['mrac_thetad'] * 100:.1f} cm",
              "reproduced" if "mrac_thetad" in var and sat["mrac_thetad"] < 0.01 and abs(mz["mrac_thetad"]) < 0.03
              else "not", "our addition"),
    ]
    if "mrac_thetad_nonadaptive" in var and "mrac_thetad" in var:
        # the baseline an adaptation claim must beat: Θ adaptation off (γ = 0), θ_d kept
        # adaptation is shown only if it beats the baseline by the 0.8× an adaptation claim must reach, under the
        # load (25–40 s) and right after the unknown stiffness drop (33–35 s)
        same = not all(abs(m["mrac_thetad"]) < 0.8 * abs(m["mrac_thetad_nonadaptive"]) for m in (mzl, mzs))
        claims.append(Claim(
            "varying: is it the Θ adaptation that keeps the behaviour? (baseline `mrac_thetad_nonadaptive`: "
            "γ = 0, nominal Θ, our θ_d kept)", "(no explicit claim: the MRAC that keeps its behaviour is the adaptive law)",
            f"adaptation off: mean level 25–40 s {mzl['mrac_thetad_nonadaptive'] * 100:.1f} cm, 33–35 s "
            f"{mzs['mrac_thetad_nonadaptive'] * 100:.1f} cm, 45–60 s {mz['mrac_thetad_nonadaptive'] * 100:.1f} cm "
            f"(adaptive {mzl['mrac_thetad'] * 100:.1f}, {mzs['mrac_thetad'] * 100:.1f}, {mz['mrac_thetad'] * 100:.1f} cm)",
            "n.a.",
            "the baseline holds the level as well (adaptive not below 0.8× its offset): the nominal design plus "
            "our θ_d, not adaptation" if same else "the adaptation beats its baseline by the 0.8× margin"))
    table = md_table(["nominal", *[f"acc PSD {lo}–{hi} Hz" for lo, hi in bands], "rattle RMS (mm)",
                       "⟨|F·ż|⟩ (W)"], rows)
    # the weights: the thesis gives none.  Sweep ρ1, ρ2 and ask whether any pair places the SOC where the thesis
    # puts it: better than the MRAC at low frequency (absolute displacement PSD, 0.1–0.5 Hz), more rattle space,
    # more actuator work (and still worse at and above resonance, 0.5–4 Hz)
    dbands = ((0.1, 0.5), (0.5, 4.0))

    def disp(ts):
        ts = ts[ts.t > 5]
        f_, P_ = welch(ts.body_z.to_numpy(), fs=1.0 / float(ts.t.iloc[1] - ts.t.iloc[0]), nperseg=16384)
        return [float(np.mean(P_[(f_ >= lo) & (f_ < hi)])) for lo, hi in dbands]

    dm = disp(nom["mrac"].ts)
    sweep, sweep_raw, hits = [], [], {"low": 0, "rattle": 0, "work": 0, "all": 0}
    grid = [(r1, r2) for r1 in (0.01, 1.0, 10.0, 100.0, 1e4, 1e5) for r2 in (1e-9, 1e-7, 1e-6)]
    for r1, r2 in grid:
        v = ctx.variants("thesis_ch5_nominal", only=["soc"])
        v["soc"].controller.params.update({"rho1": r1, "rho2": r2})
        t_ = run_each(ctx, v, f"thesis_ch5 SOC ρ1={r1:g}, ρ2={r2:g}")["soc"].ts
        d = disp(t_)
        tt = t_[t_.t > 5]
        rat = rms(tt.travel.to_numpy())
        pw = float(np.mean(np.abs(tt.actuator_force.to_numpy() * tt.travel_rate.to_numpy())))
        ok = {"low": d[0] < dm[0], "rattle": rat > psd["mrac_r"], "work": pw > psd["mrac_p"]}
        ok["all"] = all(ok.values()) and d[1] > dm[1]
        for k_ in hits:
            hits[k_] += ok[k_]
        sweep.append([f"{r1:g}", f"{r2:g}", f"{d[0] / dm[0]:.2f}", f"{d[1] / dm[1]:.2f}", f"{rat * 1000:.1f}",
                      f"{pw:.0f}", "yes" if ok["all"] else "no"])
        sweep_raw.append((d[0], rat, pw, d[1]))
    sweep_table = md_table(["ρ1", "ρ2", "SOC/MRAC disp. PSD 0.1–0.5 Hz", "SOC/MRAC 0.5–4 Hz", "SOC rattle RMS (mm)",
                            "SOC ⟨|F·ż|⟩ (W)", "all thesis sub-claims"], sweep)
    claims.append(Claim("weights: is there a (ρ1, ρ2) giving all the thesis's nominal sub-claims?",
                        "SOC better at low frequency, more rattle space and more actuator work than MRAC; MRAC better "
                        "at/above resonance", f"{len(grid)} pairs: SOC better at 0.1–0.5 Hz for {hits['low']}, more rattle "
                        f"for {hits['rattle']}, more work for {hits['work']}, all at once for {hits['all']} (MRAC "
                        f"{psd['mrac_r'] * 1000:.1f} mm, {psd['mrac_p']:.0f} W)",
                        "reproduced" if hits["all"] else "not",
                        "the cost's ẍ² term already prices F (ẍ contains F/M), so ρ2 ≪ 1/M² changes little; a "
                        "low-frequency win needs a large ρ1, which also shrinks the rattle space and the work"))
    key = {"mrac_psd_res": (psd["mrac"][1], 1e-4), "soc_psd_res": (psd["soc"][1], 1e-4),
           "soc_rattle": (psd["soc_r"], 1e-3), "mrac_power": (psd["mrac_p"], 10.0), "soc_power": (psd["soc_p"], 10.0)}
    key["sweep_all_hits"] = (float(hits["all"]), 1.0)
    key["thetad_psd_res"] = (psd["mrac_thetad"][1], 1e-4)
    # the nominal rows' other numbers (issue 12 item 3: the page gives each one's change on halving): every band of
    # the PSDs the ratio rows divide, the rattle spaces and the θ_d variant's work
    for k_ in ("mrac", "mrac_thetad", "soc"):
        for i_, (lo_, hi_) in enumerate(bands):
            key.setdefault(f"{k_}_psd_{lo_:g}_{hi_:g}Hz", (psd[k_][i_], 1e-4))
        key[f"{k_}_rattle"] = (psd[k_ + "_r"], 1e-3)
    key["thetad_power"] = (psd["mrac_thetad_p"], 10.0)
    key["varying_mrac_stop_time"] = (float(dvar["mrac"].time) if "mrac" in dvar else float("inf"), 0.1)
    # the varying run's claims (saturation fractions and levels; floors: 1 % of the time, 1 mm)
    for k_ in ("soc_fixed", "mrac"):
        if k_ in sat:
            key[f"varying_sat_{k_}"] = (sat[k_], 0.01)
    for k_ in tv:
        if k_ in var:
            key[f"varying_level_25_40_{k_}"] = (mzl[k_], 1e-3)
            key[f"varying_level_33_35_{k_}"] = (mzs[k_], 1e-3)
    if "mrac_nonadaptive" in nom:
        # the Θ adaptation on the nominal run: the printed law against itself with γ = 0 (no thesis claim is about
        # the adaptation in Ch. 5; this says whether any of its MRAC numbers is the adaptation's)
        qs = [psd["mrac"][i] / psd["mrac_nonadaptive"][i] - 1 for i in range(len(bands))]
        qs += [psd["mrac_r"] / psd["mrac_nonadaptive_r"] - 1, psd["mrac_p"] / psd["mrac_nonadaptive_p"] - 1]
        th_cols = [c for c in nom["mrac"].ts.columns if c.startswith("ctrl.theta.")]
        th_move = max(abs(nom["mrac"].ts[c].iloc[-1] / nom["mrac"].ts[c].iloc[0] - 1) for c in th_cols
                      if nom["mrac"].ts[c].iloc[0] != 0)
        claims.append(Claim(
            "nominal: does the Θ adaptation matter? (baseline `mrac_nonadaptive`: the printed law, γ = 0, nominal Θ)",
            "(no claim: the thesis compares the MRAC with the SOC, not the MRAC with its adaptation off)",
            f"largest difference adaptive vs off over the five acc-PSD bands, rattle and ⟨|F·ż|⟩: "
            f"{max(abs(q) for q in qs):.1%} (PSD 0.5–1 Hz {psd['mrac'][1]:.3g} vs {psd['mrac_nonadaptive'][1]:.3g}; "
            f"rattle {psd['mrac_r'] * 1000:.2f} vs {psd['mrac_nonadaptive_r'] * 1000:.2f} mm; {psd['mrac_p']:.1f} vs "
            f"{psd['mrac_nonadaptive_p']:.1f} W); Θ moves at most {th_move:.2%} in 60 s (rate γ·b0 ≈ 0.004 1/s)",
            "n.a.", "every MRAC number of Ch. 5 is the nominal design's: the Θ adaptation never matters here "
            "(nominal, and in the varying run below)"))
        key["mrac_nonadaptive_psd_res"] = (psd["mrac_nonadaptive"][1], 1e-4)
        key["mrac_nonadaptive_power"] = (psd["mrac_nonadaptive_p"], 10.0)
    # why the SOC cannot be placed where the thesis puts it.  Hypothesis tested: the MRAC's heavily damped skyhook
    # reference (D_m = 6000 N·s/m) makes it do more work than any SOC.  The MRAC at lighter references, and where
    # in frequency each law's force (and so its work on the road's white travel rate) lies
    from scipy.signal import butter, sosfiltfilt

    def force_split(ts, fc=5.0):
        ts = ts[ts.t > 5]
        fs_ = 1.0 / float(ts.t.iloc[1] - ts.t.iloc[0])
        F_ = ts.actuator_force.to_numpy()
        lo_ = sosfiltfilt(butter(4, fc, fs=fs_, output="sos"), F_)
        f_, PF = welch(F_, fs=fs_, nperseg=16384)
        return rms(lo_), rms(F_ - lo_), float(np.mean(PF[(f_ >= 0.1) & (f_ < 0.5)]))

    ref_runs = {f"mrac_D{d:g}": d for d in CH5_REF_DAMPINGS}
    rv = {}
    for name, d in ref_runs.items():
        v = ctx.variants("thesis_ch5_nominal", only=["mrac"])
        v["mrac"].controller.params["ref_damping"] = d
        rv[name] = run_each(ctx, v, f"thesis_ch5 MRAC D_m={d:g}")["mrac"]
    rv["mrac_D6000"], rv["soc"] = nom["mrac"], nom["soc"]
    ref_rows = []
    for name in [*ref_runs, "mrac_D6000", "soc"]:
        ts = rv[name].ts
        tt = ts[ts.t > 5]
        fs_ = 1.0 / float(tt.t.iloc[1] - tt.t.iloc[0])
        fa, Pa = welch(tt.body_acc.to_numpy(), fs=fs_, nperseg=8192)
        lo_acc = float(np.mean(Pa[(fa >= 0.25) & (fa < 0.5)]))
        d_ = disp(ts)
        rat, pw = rms(tt.travel.to_numpy()), float(np.mean(np.abs(tt.actuator_force.to_numpy() * tt.travel_rate.to_numpy())))
        flo, fhi, fpsd = force_split(ts)
        n_all = sum(1 for r_ in sweep_raw if r_[0] < d_[0] and r_[1] > rat and r_[2] > pw and r_[3] > d_[1])
        ref_rows.append([name.replace("mrac_D", "MRAC, D_m = ").replace("soc", "SOC (ρ1 = 10, ρ2 = 1e-7)"),
                         f"{lo_acc:.3g}", f"{d_[0]:.3g}", f"{rat * 1000:.1f}", f"{pw:.0f}", f"{flo:.0f}", f"{fhi:.0f}",
                         f"{fpsd:.3g}", "—" if name == "soc" else f"{n_all} of {len(grid)}"])
        if name != "soc":
            key[f"ref_power_{name}"] = (pw, 10.0)
    ref_table = md_table(["law", "acc PSD 0.25–0.5 Hz", "disp PSD 0.1–0.5 Hz", "rattle RMS (mm)", "⟨|F·ż|⟩ (W)",
                          "RMS force < 5 Hz (N)", "RMS force > 5 Hz (N)", "force PSD 0.1–0.5 Hz (N²/Hz)",
                          "SOC sweep pairs with all three sub-claims against it"], ref_rows)
    pws = [float(r_[4]) for r_ in ref_rows[:-1]]
    claims.append(Claim(
        "why no SOC sits where the thesis puts it: is it the MRAC's heavily damped reference (D_m = 6000 N·s/m)?",
        "(the thesis gives no reason; our earlier guess)",
        f"no: with D_m = {', '.join(f'{d:g}' for d in CH5_REF_DAMPINGS)}, 6000 N·s/m the MRAC's ⟨|F·ż|⟩ is "
        f"{min(pws):.0f}–{max(pws):.0f} W (SOC {psd['soc_p']:.0f} W); its force lies above 5 Hz "
        f"(RMS {ref_rows[-2][6]} N above, {ref_rows[-2][5]} N below; SOC {ref_rows[-1][6]} / {ref_rows[-1][5]} N), where it "
        f"works against the dirt road's white travel rate; below 0.5 Hz the SOC's force PSD is "
        f"{float(ref_rows[-1][7]) / float(ref_rows[-2][7]):.1f}× the MRAC's",
        "n.a.", "measured (table): the work the thesis compares is not set by the reference; on a low-frequency "
        "force reading (the thesis plots PSDs, Figs. 5.7–5.8) the SOC does use more actuator force"))
    return ItemOutput(claims, key=key, figure=fig, notes=[HALF_NOTE], tables=[table, sweep_table, ref_table])


# ---- Ch. 6 ------------------------------------------------------------------------------------------------

# (early, late) windows of the wrong-start comparison: the first and last bump, the first 3 s and the last 10 s of
# the sines (after the drifts), the first 3.5 s and the last 8 s of the random road
WINDOWS_CH6 = {"bump": ((1.0, 3.0), (9.0, 12.0)), "sine": ((1.0, 4.0), (14.0, 24.0)), "random": ((0.5, 4.0), (12.0, 20.0))}
# "the convergence is independent of the initial values" (Sec. 6.9), read as: from a wrong start the late error is
# within 20 % of the right design's (ours: the tolerance of "approaching the known-parameter case", issue 12)
WITHIN = 1.2


def _ch6_wrong_start(short, ts, wrong, right, windows):
    """Claim: from the stated wrong design (K_s −30 %, K_p +30 %, C_s +30 %, C0_p −30 %; the reference kept) the
    rattle-space errors reach the right design's (late error ≤ WITHIN × the right design's), while the same wrong
    design with adaptation off (the baseline) does not."""
    (e0, e1), (l0, l1) = windows
    off = wrong + "_nonadaptive"

    def err(k, j, a, b):
        t = ts[k]
        col = ("travel_secondary", "travel_primary")[j]
        return rms((t[col] - t[f"ctrl.ref_z.{j}"]).to_numpy()[win(t, a, b)])

    e = {(k, j): (err(k, j, e0, e1), err(k, j, l0, l1)) for k in (wrong, off, right) for j in (0, 1)}
    acc = {k: rms(ts[k].body_acc.to_numpy()[win(ts[k], l0, l1)]) for k in (wrong, off, right)}
    ratio = [e[wrong, j][1] / e[right, j][1] for j in (0, 1)]
    ratio_off = [e[off, j][1] / e[right, j][1] for j in (0, 1)]
    reach = all(e[wrong, j][1] <= WITHIN * e[right, j][1] for j in (0, 1))
    base_fails = all(e[off, j][1] > WITHIN * e[right, j][1] for j in (0, 1))
    verdict = ("reproduced" if reach and base_fails else "not shown" if reach else
               "partly" if all(e[wrong, j][1] < e[off, j][1] for j in (0, 1)) else "not")

    def pair(k):
        return " / ".join(f"{e[k, j][0] * 1000:.2f} → {e[k, j][1] * 1000:.2f}" for j in (0, 1))

    c = Claim(f"{short}: adaptation from a wrong design (K_s −30 %, K_p +30 %, C_s +30 %, C0_p −30 %; ours), "
              f"rattle-space errors secondary / primary, {e0:g}–{e1:g} s → {l0:g}–{l1:g} s",
              "the initial controller parameters can be arbitrary: convergence independent of them (Sec. 6.9)",
              f"wrong start {pair(wrong)} mm (body acc {acc[wrong]:.2f} m/s²); adaptation off {pair(off)} mm "
              f"({acc[off]:.2f}); right design {pair(right)} mm ({acc[right]:.2f}); late error / right design's: "
              f"wrong start {ratio[0]:.3f}× / {ratio[1]:.3f}×, adaptation off {ratio_off[0]:.2f}× / {ratio_off[1]:.2f}×",
              verdict,
              f"property: late error ≤ {WITHIN}× the right design's in both rattle spaces (the bound reads the thesis's "
              "'independent of the initial values' as 'the same late error as the right design's', with a 20 % "
              "tolerance that is ours); " + (
                  "the baseline fails it" if base_fails else "the baseline passes it too: the wrong design hardly "
                  "matters here"))
    return c, {f"{short}_wrong_secondary_err": (e[wrong, 0][1], 1e-3), f"{short}_wrong_primary_err": (e[wrong, 1][1], 1e-3),
               f"{short}_wrong_ratio_secondary": (ratio[0], 0.1), f"{short}_wrong_ratio_primary": (ratio[1], 0.1)}


# the five bumps of thesis_ch6_bump: bump b starts at 1 + 2b s; its window is the 2 s to the next bump's start (the
# fifth's, 9–11 s, as long as the others: the wrong-start claim's 9–12 s window holds a quiet second more)
BUMP_WIN = [(1.0 + 2 * b, 3.0 + 2 * b) for b in range(5)]
EDGE = (-0.02, 0.5)  # the bump edge: from just before the bump starts to 0.3 s after it ends (0.2 s long)
FALL = 0.9  # "as the time of adaptation increases, [it] follows the reference model more closely": ≥ 10 % less (ours)


def _bump_errs(t, a, lo, hi):
    """(secondary, primary) rattle-space error RMS of run t in [lo, hi) to run a's reference (the same reference in
    every Ch. 6 bump run: the wrong designs keep the thesis's K_ms, K_mp through ref_*)."""
    m = win(t, lo, hi)
    return tuple(rms((t[c].to_numpy() - a[f"ctrl.ref_z.{j}"].to_numpy())[m])
                 for j, c in enumerate(("travel_secondary", "travel_primary")))


def _edge_peak(t, col, b):
    """max |col| at the edge of bump b (its start − 0.02 s to its start + 0.5 s)."""
    t0 = BUMP_WIN[b][0]
    return float(np.max(np.abs(t[col].to_numpy()[win(t, t0 + EDGE[0], t0 + EDGE[1])])))


def _ch6_bump_claims(ts):
    """Where adaptation matters on the bump, and the leakage σ at the bump edges (page, Ch. 6)."""
    a = ts["adaptive"]
    claims, key = [], {}
    f, l = BUMP_WIN[0], BUMP_WIN[4]

    def fl(k):
        return _bump_errs(ts[k], a, *f), _bump_errs(ts[k], a, *l)

    def txt(k):
        e0, e1 = fl(k)
        return " / ".join(f"{e0[j] * 1000:.2f} → {e1[j] * 1000:.2f}" for j in (0, 1))

    # 1. the mode I drifts (Fig. 6.13 is the bump with the drifts): first bump → fifth bump
    grow = {k: fl(k)[1][0] / fl(k)[0][0] for k in ("adaptive", "nonadaptive", "passive")}
    ok = grow["adaptive"] < 1.1 and grow["nonadaptive"] > 1.2
    claims.append(Claim(
        "bump: following irrespective of the mode I drifts (rattle-space errors secondary / primary, first bump "
        f"{f[0]:g}–{f[1]:g} s → fifth bump {l[0]:g}–{l[1]:g} s)",
        "with the time-dependent parametric variations the controller adapts the gains so that the model follows "
        "the reference (Fig. 6.13)",
        f"adaptive {txt('adaptive')} mm (×{grow['adaptive']:.2f}); adaptation off {txt('nonadaptive')} mm "
        f"(×{grow['nonadaptive']:.2f}); passive {txt('passive')} mm (×{grow['passive']:.2f})",
        "reproduced" if ok else "not",
        "property (the sine drift claim's): the secondary error grows < 10 % while the baseline's grows > 20 %"))
    key["bump_drift_growth"] = (grow["adaptive"], 0.1)
    # 2. a second bump after adaptation: the same bumps without the drifts, from the stated wrong design
    w, o, r = "wrong_design_nodrift", "wrong_design_nodrift_nonadaptive", "adaptive_nodrift"
    if all(k in ts for k in (w, o, r)):
        fall = {k: [fl(k)[1][j] / fl(k)[0][j] for j in (0, 1)] for k in (w, o, r)}
        pk = {k: (_edge_peak(ts[k], "body_acc", 0), _edge_peak(ts[k], "body_acc", 4)) for k in (w, o, r, "passive")}
        pk_ref = _edge_peak(a, "ctrl.ref_acc", 4)
        force = {k: max(_edge_peak(ts[k], c, 4) for c in ("actuator_force_secondary", "actuator_force_primary"))
                 for k in (w, o, r)}
        passes = all(x <= FALL for x in fall[w])
        base_fails = any(x > FALL for x in fall[o])
        harsh = pk[w][1] > 2 * pk_ref
        verdict = ("not" if not passes else "not shown" if not base_fails else "partly" if harsh else "reproduced")
        claims.append(Claim(
            "bump, no drifts, from the wrong design (K_s −30 %, K_p +30 %, C_s +30 %, C0_p −30 %; ours): a second "
            "bump after adaptation (rattle-space errors secondary / primary, first → fifth bump; body-acceleration "
            "peak at the first → fifth bump edge)",
            "as the time of adaptation increases the adaptive system follows the reference more closely (Sec. 6.8); "
            "the bump response is the reference's 'forced motion with lower magnitude and damped nature'",
            f"wrong start {txt(w)} mm (×{fall[w][0]:.3f} / ×{fall[w][1]:.3f}), peak {pk[w][0]:.1f} → {pk[w][1]:.1f} "
            f"m/s², forces to {force[w]:.0f} N; adaptation off (same start) {txt(o)} mm (×{fall[o][0]:.3f} / "
            f"×{fall[o][1]:.3f}), peak {pk[o][0]:.1f} → {pk[o][1]:.1f} m/s², {force[o]:.0f} N; right design {txt(r)} "
            f"mm, peak {pk[r][0]:.1f} → {pk[r][1]:.1f} m/s², {force[r]:.0f} N; reference peak {pk_ref:.2f}, passive "
            f"{pk['passive'][1]:.1f} m/s²", verdict,
            f"property: both errors at the fifth bump ≤ {FALL}× the first's (ours: 'more closely' read as ≥ 10 % "
            "less); the baseline " + ("fails it" if base_fails else "passes it too") + "; " + (
                "but the adapted feedforward laws (M0, C0, K0, D0) sharpen the bump edges: body-acceleration peak "
                "above 2× the reference's" if harsh else "the edge peaks stay within 2× the reference's")))
        key["bump_nodrift_fall_secondary"] = (fall[w][0], 0.1)
        key["bump_nodrift_fall_primary"] = (fall[w][1], 0.1)
    # 3. the leakage σ (ours) at the bump edges: 0.02 closes the wrong start's gap on the sines; what it does here
    if "adaptive_sigma002" in ts and "wrong_design_sigma002" in ts:
        pairs = (("right design", "adaptive", "adaptive_sigma002"), ("wrong start", "wrong_design", "wrong_design_sigma002"))
        parts = []
        for lbl, k2, k02 in pairs:
            parts.append(f"{lbl}: fifth-bump errors {fl(k2)[1][0] * 1000:.2f} / {fl(k2)[1][1] * 1000:.2f} mm at σ = 0.2, "
                         f"{fl(k02)[1][0] * 1000:.2f} / {fl(k02)[1][1] * 1000:.2f} at 0.02; edge peak (first → fifth "
                         f"bump) {_edge_peak(ts[k2], 'body_acc', 0):.1f} → {_edge_peak(ts[k2], 'body_acc', 4):.1f} "
                         f"m/s² at 0.2, {_edge_peak(ts[k02], 'body_acc', 0):.1f} → "
                         f"{_edge_peak(ts[k02], 'body_acc', 4):.1f} at 0.02")
        sharper = all(_edge_peak(ts[k02], "body_acc", 4) > _edge_peak(ts[k2], "body_acc", 4) for _, k2, k02 in pairs)
        claims.append(Claim(
            "the leakage σ at the bump edges (ours; the thesis prints no leakage): σ = 0.2 s⁻¹ (the scenarios') "
            "against 0.02 (closes the wrong start's gap on the sines)", "(no σ in the thesis)",
            "; ".join(parts) + f"; reference peak {_edge_peak(a, 'ctrl.ref_acc', 4):.2f} m/s²", "n.a.",
            "σ = 0.2 kept on every road: " + ("0.02 lowers the errors but sharpens every bump edge, more at each bump"
                                              if sharper else "0.02 does not sharpen the bump edges here")))
        key["bump_sigma002_wrong_peak"] = (_edge_peak(ts["wrong_design_sigma002"], "body_acc", 4), 0.1)
    return claims, key



def _force_share(ts, m):
    """(RMS, mean frequency of the PSD in Hz) of the secondary and the primary actuator force in the mask m: Figs.
    6.12 and 6.14 (sine and bump) show "the secondary force low in magnitude but with higher frequency components,
    the primary larger and less oscillatory"."""
    from scipy.signal import welch

    out = {}
    for j in ("secondary", "primary"):
        x = ts[f"actuator_force_{j}"].to_numpy()[m]
        f, P = welch(x, fs=1.0 / float(ts.t.iloc[1] - ts.t.iloc[0]), nperseg=min(4096, len(x)))
        out[j] = (rms(x), float(np.sum(f * P) / np.sum(P)))
    return out


def ch6(ctx) -> ItemOutput:
    import matplotlib.pyplot as plt

    rows, key, claims = [], {}, []
    share = {}  # road -> _force_share of our `adaptive` (Figs. 6.12, 6.14)
    roads = ("thesis_ch6_bump", "thesis_ch6_sine", "thesis_ch6_random")
    fig, ax = plt.subplots(len(roads), 1, figsize=(7.5, 8.0))
    for i, name in enumerate(roads):
        v = ctx.variants(name)
        v["nonadaptive"] = v["adaptive"].model_copy(deep=True)
        v["nonadaptive"].controller.params.update({"alpha": 0.0, "beta": 0.0})
        dv = {}  # the printed laws (the scenario default, variant adaptive_thesis) may run away: a result
        res = run_each(ctx, v, name, diverged=dv)
        for k_, e_ in dv.items():
            if k_ != "adaptive_thesis":
                raise e_
        ts = {k: r.ts for k, r in res.items()}
        a = ts["adaptive"]
        m = win(a, 0.5, 99)
        e, size = {}, {}
        for j, col in enumerate(("travel_secondary", "travel_primary")):
            ref = a[f"ctrl.ref_z.{j}"].to_numpy()[m]
            size[col] = rms(ref)
            e[col] = {k: rms(t[col].to_numpy()[m] - ref) for k, t in ts.items()}
        acc = {k: rms(t.body_acc.to_numpy()[m]) for k, t in ts.items()}
        xabs = {k: rms(t.body_z.to_numpy()[m] - a["ctrl.ref_x"].to_numpy()[m]) for k, t in ts.items()}
        acc_ref = rms(a["ctrl.ref_acc"].to_numpy()[m])
        short = name.split("_")[-1]
        for col in e:
            rows.append([short, col, f"{size[col] * 1000:.2f}", f"{e[col]['adaptive'] * 1000:.2f}",
                         f"{e[col]['nonadaptive'] * 1000:.2f}", f"{e[col]['passive'] * 1000:.2f}"])
            key[f"{short}_{col}_err"] = (e[col]["adaptive"], 1e-3)
        rows.append([short, "secondary mass absolute displacement error", f"{rms(a['ctrl.ref_x'].to_numpy()[m]) * 1000:.2f}",
                     f"{xabs['adaptive'] * 1000:.2f}", f"{xabs['nonadaptive'] * 1000:.2f}", f"{xabs['passive'] * 1000:.2f}"])
        rows.append([short, "body acc (m/s²)", f"{acc_ref:.3f}", f"{acc['adaptive']:.3f}", f"{acc['nonadaptive']:.3f}",
                     f"{acc['passive']:.3f}"])
        key[f"{short}_acc"] = (acc["adaptive"], 0.1)
        sec = "travel_secondary"
        if "adaptive_thesis" in dv or "adaptive_thesis" in ts:
            pr = "the thesis's laws as printed (scenario default `adaptive_thesis`: Eq. 6.67 unnormalised, no σ-leakage, no gain bound)"
            if "adaptive_thesis" in dv:
                got, ok = "diverges: " + diverged_text(dv["adaptive_thesis"]), "not"
                key[f"{short}_printed_stop_s"] = (float(dv["adaptive_thesis"].time), 0.01)
            else:
                got = (f"ran to the end: secondary error {e[sec]['adaptive_thesis'] * 1000:.2f} mm, primary "
                       f"{e['travel_primary']['adaptive_thesis'] * 1000:.2f} mm, body acc "
                       f"{acc['adaptive_thesis']:.3f} m/s² (ours, `adaptive`: {e[sec]['adaptive'] * 1000:.2f} mm, "
                       f"{e['travel_primary']['adaptive'] * 1000:.2f} mm, {acc['adaptive']:.3f} m/s²)")
                ok = ("reproduced" if e[sec]["adaptive_thesis"] < 0.5 * size[sec] and acc["adaptive_thesis"] < 1.5 * acc_ref
                      else "not")
                key[f"{short}_printed_sec_err"] = (e[sec]["adaptive_thesis"], 1e-3)
                key[f"{short}_printed_acc"] = (acc["adaptive_thesis"], 0.1)
                rows.append([short, "printed laws (`adaptive_thesis`): secondary / primary error, body acc", "",
                             f"{e[sec]['adaptive_thesis'] * 1000:.2f} / {e['travel_primary']['adaptive_thesis'] * 1000:.2f}"
                             f" / {acc['adaptive_thesis']:.3f}", "", ""])
            claims.append(Claim(f"{short}: {pr}", "follows the dual-skyhook reference", got, ok,
                                "the rows below are our variant `adaptive` (normalised laws, σ = 0.2 s⁻¹, gain bound 1×)"))
        claims.append(Claim(f"{short}: secondary rattle space follows the dual-skyhook reference",
                            "adapts to the reference (Figs. 6.8–6.11, 6.13)",
                            f"RMS error {e[sec]['adaptive'] * 1000:.2f} mm against a reference of "
                            f"{size[sec] * 1000:.2f} mm RMS (passive {e[sec]['passive'] * 1000:.2f}, non-adaptive "
                            f"{e[sec]['nonadaptive'] * 1000:.2f})",
                            "not" if e[sec]["adaptive"] > 0.5 * size[sec] else "reproduced"))
        pri = "travel_primary"
        claims.append(Claim(f"{short}: primary rattle space", "adapts to the reference",
                            f"{e[pri]['adaptive'] * 1000:.2f} mm vs reference {size[pri] * 1000:.2f} mm (passive "
                            f"{e[pri]['passive'] * 1000:.2f}, non-adaptive {e[pri]['nonadaptive'] * 1000:.2f})",
                            "reproduced" if e[pri]["adaptive"] < 0.5 * min(size[pri], e[pri]["passive"]) else "partly"))
        claims.append(Claim(f"{short}: body acceleration", "that of the reference (isolation)",
                            f"{acc['adaptive']:.2f} m/s² vs reference {acc_ref:.2f}, passive {acc['passive']:.2f}, "
                            f"non-adaptive {acc['nonadaptive']:.2f}",
                            "reproduced" if acc["adaptive"] < 1.5 * acc_ref else "not"))
        if "adaptive_structured" in ts:
            st_ = ts["adaptive_structured"]
            e_st = rms(st_[sec].to_numpy()[m] - a["ctrl.ref_z.0"].to_numpy()[m])
            acc_st = rms(st_.body_acc.to_numpy()[m])
            rows.append([short, "`adaptive_structured` (ours): secondary error / body acc", "",
                         f"{e_st * 1000:.2f} / {acc_st:.3f}", "", ""])
            claims.append(Claim(f"{short}: body acceleration with the structure-preserving K_p/K_v row-0 law "
                                "(`adaptive_structured`, ours)", "that of the reference",
                                f"{acc_st:.3f} m/s² vs reference {acc_ref:.3f}; secondary rattle error {e_st * 1000:.2f} mm "
                                f"(non-adaptive {e[sec]['nonadaptive'] * 1000:.2f}, `adaptive` {e[sec]['adaptive'] * 1000:.2f})",
                                "reproduced" if acc_st < 1.5 * acc_ref and e_st < 0.8 * e[sec]["nonadaptive"] else "not",
                                "the entry-wise laws' K_v drift breaks the nominal cancellation of the primary's motion"))
            key[f"{short}_structured_acc"] = (acc_st, 0.1)
        if short == "bump":
            c_, k_ = _ch6_bump_claims(ts)
            claims += c_
            key.update(k_)
        wv = "wrong_design_drift" if short == "sine" else "wrong_design"
        if wv in ts:
            c, k_ = _ch6_wrong_start(short, ts, wv, "adaptive", WINDOWS_CH6[short])
            claims.append(c)
            key.update(k_)
        if short == "sine":
            # parameter variations mode I: springs drift from T/6, dampers blow off at T/2 (T = 24 s)
            before = {k: rms((t[sec] - a["ctrl.ref_z.0"]).to_numpy()[win(t, 1, 4)]) for k, t in ts.items()}
            after = {k: rms((t[sec] - a["ctrl.ref_z.0"]).to_numpy()[win(t, 14, 24)]) for k, t in ts.items()}
            claims.append(Claim("sine: model following irrespective of the mode I drifts (secondary rattle error "
                                "1–4 s → 14–24 s)", "reference response achieved irrespective of parametric variations",
                                f"adaptive {before['adaptive'] * 1000:.2f} → {after['adaptive'] * 1000:.2f} mm; "
                                f"non-adaptive {before['nonadaptive'] * 1000:.2f} → {after['nonadaptive'] * 1000:.2f} mm; "
                                f"passive {before['passive'] * 1000:.2f} → {after['passive'] * 1000:.2f} mm",
                                "reproduced" if (after["adaptive"] < 1.1 * before["adaptive"]
                                                 and after["nonadaptive"] > 1.2 * before["nonadaptive"]) else "not",
                                "the error itself stays above the reference signal (row above)"))
            if "wrong_design" in ts and "adaptive_nodrift" in ts:
                c, k_ = _ch6_wrong_start("sine, no drifts", ts, "wrong_design", "adaptive_nodrift", WINDOWS_CH6["sine"])
                claims.append(c)
                key.update({kk.replace("sine, no drifts", "sine_nodrift"): v for kk, v in k_.items()})
            key["sine_drift_err_after"] = (after["adaptive"], 1e-3)
        if short in ("sine", "bump"):
            share[short] = _force_share(a, m)
            for j, (r_, c_) in share[short].items():
                key[f"{short}_force_rms_{j}"] = (r_, 1.0)
                key[f"{short}_force_mean_freq_{j}"] = (c_, 0.1)
        for k, s_ in (("passive", "g-"), ("nonadaptive", "b:"), ("adaptive", "r-")):
            ax[i].plot(ts[k].t, 1000 * ts[k].travel_secondary, s_, lw=0.6, label=k + (" (ours)" if k == "adaptive"
                                                                                       else ""))
        ax[i].plot(a.t, 1000 * a["ctrl.ref_z.0"], "k--", lw=0.6, label="reference")
        if "adaptive_thesis" in ts:  # the printed laws beside ours; until their divergence stop where they run away
            ax[i].plot(ts["adaptive_thesis"].t, 1000 * ts["adaptive_thesis"].travel_secondary, "c-", lw=0.6,
                       label="printed")
        elif "adaptive_thesis" in dv:
            _draw_until_stop(ax[i], _until_stop(ctx, dv["adaptive_thesis"]),
                             "travel_secondary", 1000.0, "c-", "printed", dv["adaptive_thesis"])
        ax[i].set_ylabel(f"{short}: sec. travel (mm)", fontsize=8)
        ax[i].legend(fontsize=7, ncol=4)
        if short == "random":
            ax[i].set_xlim(5, 7)
        if short == "sine":
            ax[i].set_xlim(10, 16)
    big = {r_: sh["primary"][0] > sh["secondary"][0] for r_, sh in share.items()}
    fast = {r_: sh["secondary"][1] > sh["primary"][1] for r_, sh in share.items()}
    claims.append(Claim(
        "actuator forces (Figs. 6.12 sine, 6.14 bump): RMS and mean frequency of the force PSD, u_s / u_p",
        "u_p larger and less oscillatory; u_s low in magnitude, with higher frequency components",
        "; ".join(f"{r_}: RMS {sh['secondary'][0]:.0f} / {sh['primary'][0]:.0f} N "
                  f"({sh['secondary'][0] / sh['primary'][0]:.2f}×), mean frequency {sh['secondary'][1]:.1f} / "
                  f"{sh['primary'][1]:.1f} Hz" for r_, sh in share.items()),
        "reproduced" if all(big.values()) and all(fast.values()) else "partly" if all(big.values()) else "not",
        "u_p is the larger on every road; u_s is the higher-frequency one only where listed: "
        + ", ".join(f"{r_} {'yes' if fast[r_] else 'no'}" for r_ in share)))
    ax[-1].set_xlabel("time (s)")
    fig.suptitle("Thesis Ch. 6: 2-DOF bounce model, MDOF adaptive control (Figs. 6.8–6.14);\nbump and sine with "
                 "the mode I drifts; the printed laws until their divergence stop", fontsize=9)
    fig.tight_layout()
    table = md_table(["road", "quantity (RMS, mm)", "reference", "adaptive", "non-adaptive (α = β = 0)", "passive"],
                      rows)
    notes = [HALF_NOTE, "Errors are RMS(travel − reference travel) after 0.5 s; the non-adaptive run keeps the "
             "nominal feedforward and feedback gains (adaptation off). Bump (12 s) and sine (24 s) carry the mode I "
             "drifts of reproductions/_thesis_drift.py (springs −20 % over T/6–5T/6, the secondary's linear damper and "
             "the primary's velocity-squared damper −50 % at T/2); the random road has none."]
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=[table])


SOURCES.register("thesis")(Source(
    "thesis", "Vallurupalli (PhD thesis, 1996): adaptive active suspensions, Ch. 3–7",
    "docs/reproductions/vallurupalli_thesis_1996.md",
    [Item("ch3_load_step", "Ch. 3, Figs. 3.6–3.10: continuous MRAC, +150 kg load step", ch3_load_step),
     Item("ch3_adaptation", "Ch. 3, Figs. 3.6–3.9: adaptation from wrong initial gains; mode I stiffness/damping drifts",
          ch3_adaptation),
     Item("ch3_dirt", "Ch. 3, Figs. 3.11–3.14: dirt road, parameter variations mode II", ch3_dirt),
     Item("ch4_load_step", "Ch. 4, Figs. 4.4–4.8: discrete MRAC with delay, +150 kg load step", ch4_load_step),
     Item("ch4_dirt", "Ch. 4, Figs. 4.9–4.12: discrete MRAC on the dirt road (Excitation mode II)", ch4_dirt),
     Item("ch5", "Ch. 5: stochastic optimal control vs MRAC (nominal; time-varying load and stiffness)", ch5),
     Item("ch6", "Ch. 6: 2-DOF MDOF adaptive control on bumps, sines (with the mode I drifts) and a random road", ch6),
     Item("ch7_braking", "Ch. 7: half car, acceleration and braking (dive, bounce, polarities)", ch7_braking),
     Item("ch7_road", "Ch. 7, Sec. 7.5.1 (Figs. 7.4–7.7): sines with front–rear delay, manoeuvre at 20/40 s, "
          "spring and damper drifts", ch7_road),
     Item("ch7_dirt", "Ch. 7, Sec. 7.5.2 (Figs. 7.8–7.12): Hac dirt road, time and frequency domain", ch7_dirt)]))
