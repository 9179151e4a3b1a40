"""Toscano & Dumas: fuzzy adaptive compensation with an electromagnetic actuator, constant (Figs. 6–8) and
time-varying (Figs. 9–11) suspension parameters (page: docs/reproductions/toscano_dumas.md).

Scenarios ``toscano_constant`` and ``toscano_varying``: the controller (the paper's law, two-rule triangular
approximators (33)) starts from β̂ = 0, i.e. f̂_k = f̂_b = 0 (−100 %; the paper does not state its initial
values), beside the uncontrolled car and the reference car (k = 10000 N/m, b = 1000 N·s/m).  Estimate errors are
RMS over the last 4 s of the 10 s runs, against the truth at that instant.
"""
from __future__ import annotations

import numpy as np

from .framework import SOURCES, Claim, Item, ItemOutput, Source, md_table

K0, B0, DK, DB, WK, WB = 15000.0, 1500.0, 5000.0, 500.0, 3.0, 4.0


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def nrmse(a, ref):
    return rms(np.asarray(a) - np.asarray(ref)) / rms(ref)


def est_errors(ts, wk, wb, dk=DK, db=DB, window=4.0):
    last = ts.t.to_numpy() > ts.t.iloc[-1] - window
    t = ts.t.to_numpy()[last]
    kt = K0 + (dk * np.sin(wk * t) if wk else 0 * t)
    bt = B0 + (db * np.sin(wb * t) if wb else 0 * t)
    return rms(ts["ctrl.fk_hat"].to_numpy()[last] - kt), rms(ts["ctrl.fb_hat"].to_numpy()[last] - bt)


def _figure(res, title, kt, bt):
    import matplotlib.pyplot as plt

    C, U, R = res["controlled"].ts, res["uncontrolled"].ts, res["reference"].ts
    fig, ax = plt.subplots(3, 2, figsize=(9, 6.5), sharex=True)
    ax[0, 0].plot(C.t, C["ctrl.fk_hat"], "r-", lw=0.8, label="f̂_k")
    ax[0, 0].plot(C.t, kt(C.t.to_numpy()), "k--", lw=0.8, label="k_M")
    ax[0, 0].set_ylabel("stiffness (N/m)", fontsize=8)
    ax[0, 0].legend(fontsize=7)
    ax[0, 1].plot(C.t, C["ctrl.fb_hat"], "r-", lw=0.8, label="f̂_b")
    ax[0, 1].plot(C.t, bt(C.t.to_numpy()), "k--", lw=0.8, label="b_M")
    ax[0, 1].set_ylabel("damping (N·s/m)", fontsize=8)
    ax[0, 1].legend(fontsize=7)
    ax[1, 0].plot(C.t, C["ctrl.v_err"], "r-", lw=0.6)
    ax[1, 0].set_ylabel("ṽ_M (m/s)", fontsize=8)
    ax[1, 1].plot(C.t, C["command"], "r-", lw=0.6, label="command")
    ax[1, 1].plot(C.t, C["actuator_force"], "b:", lw=0.6, label="force")
    ax[1, 1].set_ylabel("F_m (N)", fontsize=8)
    ax[1, 1].legend(fontsize=7)
    for a, q in ((ax[2, 0], "body_z"), (ax[2, 1], "body_vel")):
        a.plot(R.t, R[q], "k-", lw=0.8, label="reference")
        a.plot(C.t, C[q], "r--", lw=0.8, label="controlled")
        a.plot(U.t, U[q], "g:", lw=0.8, label="uncontrolled")
        a.set_ylabel(q, fontsize=8)
        a.set_xlabel("time (s)")
    ax[2, 0].legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


def _approach_claim(res, adaptive, baseline, baseline_text, known_text, implied) -> Claim:
    """Issue item 1's "performance approaching the known-parameter case", one rule for both cases: NRMSE body z
    of the adaptive run against the known-parameter run (variant ``known``) and the non-adaptive baseline;
    reproduced within 2× the known law's NRMSE, partly when the adaptation closes more than half of the gap
    from the baseline to the known law, else not."""
    R = res["reference"].ts
    a, b, k = (nrmse(res[v].ts.body_z, R.body_z) for v in (adaptive, baseline, "known"))
    kv = nrmse(res["known"].ts.body_vel, R.body_vel)
    gap, ratio = (b - a) / (b - k), a / k
    return Claim(
        f"the adaptive law approaches the known-parameter case: {known_text}, NRMSE",
        f"(implied: {implied})",
        f"known parameters body z {k:.4f}, body v {kv:.4f}; adaptive {a:.3f} ({ratio:.1f}× the known), "
        f"{baseline_text} {b:.3f} ({b / k:.0f}×): the adaptation closes {gap:.0%} of the gap from that baseline "
        "to the known law", "reproduced" if ratio < 2 else ("partly" if gap > 0.5 else "not"),
        "verdict rule: reproduced within 2× the known law's NRMSE, partly when the adaptation closes more than "
        "half of the baseline-to-known gap; the known law differs from the reference only by the coil's lag")


def _tracking(res):
    C, U, R = res["controlled"].ts, res["uncontrolled"].ts, res["reference"].ts
    return {q: (nrmse(C[q], R[q]), nrmse(U[q], R[q])) for q in ("body_z", "body_vel", "travel")}


def constant(ctx) -> ItemOutput:
    res = ctx.run_scenario("toscano_constant")
    C = res["controlled"].ts
    last = C.t > C.t.iloc[-1] - 3.0
    fk, fb = float(C["ctrl.fk_hat"][last].mean()), float(C["ctrl.fb_hat"][last].mean())
    ek, eb = est_errors(C, 0, 0)
    tr = _tracking(res)
    claims = [
        Claim("estimates (Fig. 6), from f̂_k = f̂_b = 0", "converge to k_M = 15000 N/m, b_M = 1500 N·s/m",
              f"mean of the last 3 s: {fk:.0f} N/m ({fk / K0 - 1:+.1%}), {fb:.0f} N·s/m ({fb / B0 - 1:+.1%}); "
              f"instantaneous RMS error {ek:.0f} N/m, {eb:.0f} N·s/m",
              "reproduced" if abs(fk / K0 - 1) < 0.05 and abs(fb / B0 - 1) < 0.05 else "not",
              "the instantaneous f̂_k(Δx) wanders with Δx (two rules, β̂¹ ≠ β̂²)"),
        Claim("controlled car follows the reference (Fig. 8), NRMSE", "behaves as the reference model",
              f"body z {tr['body_z'][0]:.3f} (uncontrolled {tr['body_z'][1]:.3f}), body v {tr['body_vel'][0]:.3f} "
              f"({tr['body_vel'][1]:.3f}), travel {tr['travel'][0]:.3f} ({tr['travel'][1]:.3f})",
              "reproduced" if tr["body_z"][0] < 0.2 * tr["body_z"][1] else "partly"),
    ]
    R = res["reference"].ts
    base = {v: nrmse(res[v].ts.body_z, R.body_z) for v in ("adaptation_off", "known") if v in res}
    if len(base) == 2:
        claims.append(Claim(
            "the adaptation is what makes the car follow, NRMSE body z: the same law with the adaptation off "
            "(λ = 0, same zero start; the baseline must fail)",
            "(implied: adaptive control from unknown parameters)",
            f"adaptation off {base['adaptation_off']:.3f}; adaptive "
            f"{tr['body_z'][0]:.3f}", "reproduced" if base["adaptation_off"] > 5 * tr["body_z"][0] else "not",
            "without adaptation the car does not follow"))
        claims.append(_approach_claim(res, "controlled", "adaptation_off", "adaptation off",
                                      "the same law at the true 15000, 1500 (λ = 0)",
                                      "adaptive control from unknown parameters"))
    fig = _figure(res, "Toscano & Dumas: constant k_M, b_M, estimates from 0 (cf. Figs. 6–8)",
                  lambda t: K0 + 0 * t, lambda t: B0 + 0 * t)
    key = {"fk_mean": (fk, 1000.0), "fb_mean": (fb, 100.0), "nrmse_body_z": (tr["body_z"][0], 0.005),
           "nrmse_body_v": (tr["body_vel"][0], 0.005), "nrmse_travel": (tr["travel"][0], 0.005)}
    for v, x in base.items():  # the baselines' numbers are the row's numbers too
        key[f"nrmse_body_z_{v}"] = (x, 0.005)
    return ItemOutput(claims, key=key, figure=fig)


STUDY = {  # label: (overrides, ω_k or None, ω_b or None)
    "paper's variation (3, 4 rad/s)": ([], WK, WB),
    "k_M(t) only": (["vehicle.variations=[]"], WK, None),
    "b_M(t) only": (["vehicle.effects=[]"], None, WB),
    "10× slower (0.3, 0.4 rad/s)": ([f"vehicle.effects=[{{type: varying_stiffness, params: {{amplitude: 5000, frequency: {0.3 / 2 / np.pi}}}}}]",
                                     f"vehicle.variations=[{{param: damping, kind: sine, mode: add, values: [500, {0.4 / 2 / np.pi}, 0]}}]"], 0.3, 0.4),
    "λ ×3": (["controller.params.lambda_k=3e12", "controller.params.lambda_b=3e10"], WK, WB),
    "λ ×10, α = 1000, load cell": (["controller.params.lambda_k=5e13", "controller.params.lambda_b=5e11",
                                    "controller.params.alpha=1000", "controller.params.force_sensor=force",
                                    "sensors=[{name: travel, type: travel}, {name: travel_rate, type: travel_rate}, "
                                    "{name: corner_body_vel, type: corner_body_vel}, {name: force, type: actuator_force}]"], WK, WB),
    "road ×2 (more excitation)": (["road.params.amplitudes=[0.04, 0.02, 0.01, 0.004]"], WK, WB),
    "load cell (measured force in the estimator)": (
        ["controller.params.force_sensor=force",
         "sensors=[{name: travel, type: travel}, {name: travel_rate, type: travel_rate}, "
         "{name: corner_body_vel, type: corner_body_vel}, {name: force, type: actuator_force}]"], WK, WB),
}
SPLIT = ("paper's variation (3, 4 rad/s)", "λ ×3", "load cell (measured force in the estimator)")
SPLIT_FROM = 2.0  # s: the split's window (after the estimates' rise from 0), long enough to separate 3 and 4 rad/s


def error_split(ts, params, t0=SPLIT_FROM):
    """Where the estimate errors come from, over t > t0: f̂_k and f̂_b fitted with a mean and sines at 3 and
    4 rad/s; the error's RMS split into the *lag* (the own-frequency part: f̂ minus the truth's sine), the
    *cross-talk* (the other variation's frequency), the mean offset and the *rest* (every other frequency);
    the own-frequency gain and phase, and the adaptation rate the averaged gradient predicts,
    λ·E[Δx²]/(α·M²) (λ_b·E[Δv²]/(α·M²); M from the controller's params or 290 kg), beside the rate a first-order
    lag with the measured phase would need, ω/tan(−phase)."""
    t = ts.t.to_numpy()
    m = t > t0
    t = t[m]
    A = np.column_stack([np.ones_like(t), np.sin(WK * t), np.cos(WK * t), np.sin(WB * t), np.cos(WB * t)])
    out = {}
    for nm, col, mean, amp, w, own, other, reg, lam in (
            ("k", "ctrl.fk_hat", K0, DK, WK, 1, 3, -ts.travel.to_numpy()[m], params.get("lambda_k", 1e12)),
            ("b", "ctrl.fb_hat", B0, DB, WB, 3, 1, -ts.travel_rate.to_numpy()[m], params.get("lambda_b", 1e10))):
        x = ts[col].to_numpy()[m]
        c = np.linalg.lstsq(A, x, rcond=None)[0]
        ph = float(np.arctan2(c[own + 1], c[own]))
        rate = lam * float(np.mean(reg * reg)) / (params.get("alpha", 200.0) * params.get("body_mass", 290.0) ** 2)
        out[nm] = dict(total=rms(x - mean - amp * np.sin(w * t)), lag=float(np.hypot(c[own] - amp, c[own + 1])) / np.sqrt(2),
                       cross=float(np.hypot(c[other], c[other + 1])) / np.sqrt(2), mean=float(c[0] - mean),
                       rest=rms(x - A @ c), gain=float(np.hypot(c[own], c[own + 1])) / amp,
                       phase=np.degrees(ph), rate=rate, rate_phase=w / np.tan(-ph) if ph < 0 else float("nan"))
    return out


def _verr_last(ts):
    """RMS ṽ over the last 4 s."""
    return rms(ts["ctrl.v_err"][ts.t > ts.t.iloc[-1] - 4])


def _verr_claim(C, frozen) -> Claim:
    """Fig. 10's ṽ → 0, beside the baseline frozen at the true means (λ = 0): a small ṽ shows the adaptation only
    if the baseline's is clearly larger."""
    va = _verr_last(C)
    text = f"RMS ṽ last 4 s {va * 1000:.2f} mm/s (body velocity {rms(C.body_vel) * 1000:.0f} mm/s)"
    if frozen is None:
        return Claim("estimation error ṽ → 0 (Fig. 10)", "converges to zero", text, "reproduced")
    vf = _verr_last(frozen.ts)
    return Claim("estimation error ṽ → 0 (Fig. 10)", "converges to zero",
                 text + f"; baseline frozen at the true means {vf * 1000:.2f} mm/s",
                 "reproduced" if va < 0.5 * vf else "partly",
                 "" if va < 0.5 * vf else "the baseline's ṽ is as small: ṽ alone does not show the adaptation")


def varying(ctx) -> ItemOutput:
    base = ctx.variants("toscano_varying")
    runs = dict(base)
    for lab, (sets, _, _) in STUDY.items():
        if sets:
            runs[lab] = ctx.variants("toscano_varying", sets, only=["controlled"])["controlled"]
    runs["reference road ×2"] = ctx.variants("toscano_varying", STUDY["road ×2 (more excitation)"][0],
                                             only=["reference"])["reference"]
    res = ctx.run(runs, label="toscano_varying")
    C = res["controlled"].ts
    ek, eb = est_errors(C, WK, WB)
    vk, vb = DK / np.sqrt(2), DB / np.sqrt(2)
    tr = _tracking(res)
    rows = []
    for lab, (sets, wk, wb) in STUDY.items():
        r = res[lab if sets else "controlled"].ts
        e1, e2 = est_errors(r, wk, wb, DK if wk else 0, DB if wb else 0)
        ref = res["reference road ×2" if "road" in lab else "reference"].ts
        rows.append([lab, f"{e1:.0f} N/m ({e1 / vk:.2f})", f"{e2:.0f} N·s/m ({e2 / vb:.2f})",
                     f"{nrmse(r.body_z, ref.body_z):.3f}", f"{nrmse(r.body_vel, ref.body_vel):.3f}"])
    if "known" in res:  # the known-parameter reference: the law told k_M(t), b_M(t) (estimates = the truth)
        K = res["known"].ts
        e1, e2 = est_errors(K, WK, WB)
        rows.append(["known parameters (the law told k_M(t), b_M(t))", f"{e1:.0f} N/m ({e1 / vk:.2f})",
                     f"{e2:.0f} N·s/m ({e2 / vb:.2f})", f"{nrmse(K.body_z, res['reference'].ts.body_z):.3f}",
                     f"{nrmse(K.body_vel, res['reference'].ts.body_vel):.3f}"])
    # the constant-parameter floor: same controller, constant k_M, b_M
    cst = ctx.run({"constant": ctx.variants("toscano_constant", only=["controlled"])["controlled"]}, label="floor")
    f1, f2 = est_errors(cst["constant"].ts, 0, 0)
    rows.append(["constant k_M, b_M (floor)", f"{f1:.0f} N/m ({f1 / vk:.2f})", f"{f2:.0f} N·s/m ({f2 / vb:.2f})", "—", "—"])
    table = md_table(["case", "f̂_k error (÷ variation RMS 3536)", "f̂_b error (÷ 354)", "NRMSE body z", "NRMSE body v"], rows)
    srows, split = [], {}
    for lab in SPLIT:
        sc = runs[lab if STUDY[lab][0] else "controlled"]
        split[lab] = sp = error_split(res[lab if STUDY[lab][0] else "controlled"].ts, sc.controller.params)
        for nm, unit, w in (("k", "N/m", WK), ("b", "N·s/m", WB)):
            q = sp[nm]
            srows.append([lab, f"f̂_{nm}", f"{q['total']:.0f} {unit}", f"{q['lag']:.0f}", f"{q['cross']:.0f}",
                          f"{q['mean']:+.0f}", f"{q['rest']:.0f}", f"{q['gain']:.3f}, {q['phase']:+.1f}°",
                          f"{q['rate']:.1f}", f"{q['rate_phase']:.1f}"])
    split_table = md_table(["case", "estimate", f"RMS error after {SPLIT_FROM:g} s", "lag (own ω)",
                            "cross-talk (other ω)", "mean offset", "rest (other frequencies)",
                            "own-ω gain, phase", "rate λE[Δ²]/(αM²) (1/s)", "rate from the phase (1/s)"], srows)
    claims = [
        Claim("estimates follow k_M(t), b_M(t) (Fig. 9), from 0", "\"convergence towards the expressions of b_M(t) and k_M(t)\"",
              f"RMS error {ek:.0f} N/m ({ek / vk:.0%} of the variation's RMS), {eb:.0f} N·s/m ({eb / vb:.0%})",
              "partly" if ek < vk and eb < vb else "not",
              "follows with a lag and a floor; see the study table"),
        _verr_claim(C, res.get("frozen_means")),
        Claim("car follows the reference, independent of the variation (Fig. 11), NRMSE",
              "behaves as the reference model",
              f"body z {tr['body_z'][0]:.3f} (uncontrolled {tr['body_z'][1]:.3f}), body v {tr['body_vel'][0]:.3f} "
              f"({tr['body_vel'][1]:.3f})", "reproduced" if tr["body_z"][0] < 0.3 * tr["body_z"][1] else "partly"),
    ]
    if "frozen_means" in res:
        F = res["frozen_means"].ts
        fz = nrmse(F.body_z, res["reference"].ts.body_z)
        claims.append(Claim(
            "the adaptation is what keeps the car on the reference: the same law frozen at the true means 15000 / 1500 "
            "(λ = 0; the best constant estimates; the baseline must fail), NRMSE", "(implied by Fig. 11)", f"body z {fz:.3f}, body v {nrmse(F.body_vel, res['reference'].ts.body_vel):.3f} (adaptive "
            f"{tr['body_z'][0]:.3f}, {tr['body_vel'][0]:.3f})",
            "reproduced" if fz > 2 * tr["body_z"][0] else "not",
            "following through the variation needs the adaptation"))
    if "known" in res and "frozen_means" in res:
        claims.append(_approach_claim(res, "controlled", "frozen_means", "frozen at the means",
                                      "the same law told k_M(t), b_M(t) at each instant (estimates held at the "
                                      "truth, no adaptation)", "adaptive control of unknown, varying parameters"))
    pk, l3 = split[SPLIT[0]]["k"], split["λ ×3"]["k"]
    notes = [f"Why about half (the split table): at the chosen gains the averaged gradient's rate for f̂_k is "
             f"λ_k·E[Δx²]/(α·M²) = {pk['rate']:.1f} 1/s ({pk['rate'] / WK:.1f}× the 3 rad/s variation), and the "
             f"measured phase of f̂_k at 3 rad/s, {pk['phase']:+.1f}°, is that of a first-order lag of "
             f"{pk['rate_phase']:.1f} 1/s: the lag is {pk['lag']:.0f} of the {pk['total']:.0f} N/m error "
             f"({(pk['lag'] / pk['total']) ** 2:.0%} of its mean square).  Tripling λ halves the lag "
             f"({l3['lag']:.0f} N/m, phase {l3['phase']:+.1f}°) but the error only falls to {l3['total']:.0f} N/m: "
             f"the rest ({pk['rest']:.0f} → {l3['rest']:.0f} N/m at frequencies other than 3 and 4 rad/s) and the "
             f"cross-talk ({pk['cross']:.0f} → {l3['cross']:.0f}) do not shrink with the gain, nor with the "
             f"measured force in the estimator (load cell: rest {split[SPLIT[2]]['k']['rest']:.0f}), so neither the "
             "gain against the variation's rate nor the coil lag is the main cause; the rest includes the "
             "wander of the two-rule f̂_k(Δx) that the constant case shows too (its floor row).",
             "Why the estimates miss by about half the variation while the car still follows the reference: the "
             "gradient law (27) only needs θ̃ᵀφ = (f_k − f̂_k)Δx + (f_b − f̂_b)Δv small, not θ̃.  The rows above "
             "separate the causes: a floor present with constant parameters (f̂_k(Δx) wanders with Δx, β̂¹ ≠ "
             "β̂²); cross-talk (k_M(t) alone or b_M(t) alone leaves errors in both estimates, since k(t)·Δx(t) "
             "has components a constant damping term can absorb); and a lag that shrinks for a 10× slower "
             "variation.  Raising the gain tightens the reference tracking but not the estimates, and more "
             "excitation (road ×2) does not help either: the two-rule, 4-parameter model cannot separate a "
             "3 rad/s stiffness variation from damping on this road.  The paper shows curves only, so this is "
             "recorded as partly reproduced, not as a contradiction."]
    fig = _figure(res, "Toscano & Dumas: k_M = 15000 + 5000 sin 3t, b_M = 1500 + 500 sin 4t, estimates from 0 (cf. Figs. 9–11)",
                  lambda t: K0 + DK * np.sin(WK * t), lambda t: B0 + DB * np.sin(WB * t))
    key = {"fk_error": (ek, 500.0), "fb_error": (eb, 50.0), "nrmse_body_z": (tr["body_z"][0], 0.005),
           "nrmse_body_v": (tr["body_vel"][0], 0.005),
           "v_err_rms": (rms(C['ctrl.v_err'][C.t > C.t.iloc[-1] - 4]), 1e-4)}
    if "frozen_means" in res:
        key["nrmse_body_z_frozen_means"] = (nrmse(res["frozen_means"].ts.body_z, res["reference"].ts.body_z), 0.005)
        Fm = res["frozen_means"].ts
        key["v_err_rms_frozen_means"] = (rms(Fm["ctrl.v_err"][Fm.t > Fm.t.iloc[-1] - 4]), 1e-4)
    if "known" in res:
        K = res["known"].ts
        key["nrmse_body_z_known"] = (nrmse(K.body_z, res["reference"].ts.body_z), 0.005)
        key["nrmse_body_v_known"] = (nrmse(K.body_vel, res["reference"].ts.body_vel), 0.005)
    for lab, tag in ((SPLIT[0], ""), ("λ ×3", "_lambda3")):  # the split's numbers the reading rests on
        for part in ("lag", "rest", "cross"):
            key[f"fk_{part}{tag}"] = (split[lab]["k"][part], 100.0)
        key[f"fb_lag{tag}"] = (split[lab]["b"]["lag"], 10.0)
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=[table, split_table])


def nonlinear(ctx) -> ItemOutput:
    """Beyond the paper: a progressive spring and a digressive asymmetric damper; the paper's two-rule
    approximators against 7-rule Gaussian ones."""
    import matplotlib.pyplot as plt

    res = ctx.run_scenario("toscano_nonlinear")
    R = res["reference"].ts
    q = {v: {k: nrmse(res[v].ts[k], R[k]) for k in ("body_z", "body_vel", "travel")}
         for v in ("controlled", "controlled_gauss7", "uncontrolled")}
    cur = max(float(res[v].ts[["act.current_push", "act.current_pull"]].to_numpy().max())
              for v in ("controlled", "controlled_gauss7"))
    claims = [
        Claim("(not in the paper) progressive spring + digressive asymmetric damper, two-rule approximators, NRMSE",
              "—", f"body z {q['controlled']['body_z']:.3f} (uncontrolled {q['uncontrolled']['body_z']:.3f}), "
              f"travel {q['controlled']['travel']:.3f} ({q['uncontrolled']['travel']:.3f})", "n.a."),
        Claim("same, 7-rule Gaussian approximators, NRMSE", "—",
              f"body z {q['controlled_gauss7']['body_z']:.3f}, travel {q['controlled_gauss7']['travel']:.3f}; "
              f"peak coil current {cur:.0f} A (limit 100 A)", "n.a.",
              "the two-rule (A / not A) basis represents one symmetric secant stiffness shape only"),
    ]
    fig, ax = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    for v, st in (("reference", "k-"), ("controlled", "r--"), ("controlled_gauss7", "b:"), ("uncontrolled", "g:")):
        ts = res[v].ts
        ax[0].plot(ts.t, ts.body_z, st, lw=0.8, label=v)
        ax[1].plot(ts.t, ts.travel, st, lw=0.8)
    ax[0].set_ylabel("body_z (m)", fontsize=8)
    ax[1].set_ylabel("travel (m)", fontsize=8)
    ax[1].set_xlabel("time (s)")
    ax[0].legend(fontsize=7)
    fig.suptitle("Toscano & Dumas on a nonlinear car (not in the paper): two-rule vs 7-rule Gaussian approximators",
                 fontsize=9)
    fig.tight_layout()
    key = {"nrmse_body_z": (q["controlled"]["body_z"], 0.05), "nrmse_body_z_gauss7": (q["controlled_gauss7"]["body_z"], 0.05)}
    return ItemOutput(claims, key=key, figure=fig)


SOURCES.register("toscano")(Source(
    "toscano", "Toscano & Dumas: continuous nonlinear adaptive control of an active vehicle suspension",
    "docs/reproductions/toscano_dumas.md",
    [Item("constant", "Figs. 6–8: constant k_M, b_M", constant),
     Item("varying", "Figs. 9–11: time-varying k_M(t), b_M(t)", varying),
     Item("nonlinear", "beyond the paper: progressive spring, digressive damper", nonlinear)]))
