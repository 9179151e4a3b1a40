"""Lin & Kanellakopoulos (1996), Figs. 2–5 and Table 1 (page: docs/reproductions/lin_kanellakopoulos_1996.md).

Scenarios ``lin_fig2..5.yaml`` (8 cm bump of Eq. 24, gains 25, 0.025 ms step; Table 1 0.0125 ms).  ``harshness`` compares the
readings of the filter constants of Eq. (25) (the text prints one unsubscripted "= 1.5"; ε1 is not printed)
against the paper's axes: ε1 = ε = 1.5 gives a 57 m/s² spike at the filter threshold that no figure shows,
ε1 = 0.01 (default) keeps every curve inside Figs. 2–5's axes; ``table1`` reruns the sensitivity study
(non-adaptive controller, one controller value wrong at a time) at the converged step.
"""
from __future__ import annotations

import numpy as np

from .framework import SOURCES, Claim, Item, ItemOutput, Source, md_table

PANELS = (("body_acc", "body acceleration (m/s²)", 1.0), ("body_z", "body travel (m)", 1.0),
          ("travel", "suspension travel (m)", 1.0), ("wheel_z", "wheel travel (m)", 1.0),
          ("act.load_pressure", "load pressure (Pa)", 1.0), ("act.spool_position", "valve opening (m)", 1.0))


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def window(ts, a, b):
    t = ts.t.to_numpy()
    return (t >= a) & (t <= b)


# The paper's axis limits (Figs. 2-5), read off the extracted figure text: (low, high) per panel.
AXES = {
    2: {"body_acc": (-9.0, 12.0), "body_z": (0.0, 0.025), "travel": (-0.085, 0.085), "wheel_z": (-0.03, 0.09),
        "act.load_pressure": (-1e7, 5e6), "act.spool_position": (-0.01, 0.01)},
    3: {"body_acc": (-20.0, 15.0), "body_z": (-0.005, 0.026), "travel": (-0.085, 0.085), "wheel_z": (-0.04, 0.09),
        "act.load_pressure": (-2e7, 1e7), "act.spool_position": (-0.01, 0.01)},
    4: {"body_acc": (-50.0, 50.0), "body_z": (-0.005, 0.025), "travel": (-0.085, 0.085), "wheel_z": (-0.03, 0.09),
        "act.load_pressure": (-3.5e7, 3.5e7)},
}
AXES[5] = AXES[4]
SHORT = {"body_acc": "acc", "body_z": "body", "travel": "travel", "wheel_z": "wheel", "act.load_pressure": "P_L",
         "act.spool_position": "valve"}


def ranges(ts, t0, t1, cols):
    """(min, max) of each column over [t0, t1]."""
    m = window(ts, t0, t1)
    return {c: (float(ts[c].to_numpy()[m].min()), float(ts[c].to_numpy()[m].max())) for c in cols}


def outside(rng, axes, tol=0.02):
    """The panels whose curve leaves the paper's axis (by more than tol of the axis span)."""
    out = []
    for c, (lo, hi) in axes.items():
        a, b = rng[c]
        span = hi - lo
        if a < lo - tol * span or b > hi + tol * span:
            out.append(SHORT[c])
    return out


def envelope(res, names, t0, t1, axes):
    """The range of every panel over the named runs (the paper draws all curves on one axis)."""
    rs = [ranges(res[n].ts, t0, t1, list(axes)) for n in names]
    return {c: (min(r[c][0] for r in rs), max(r[c][1] for r in rs)) for c in axes}


def six_panels(res, styles, t0, t1, title):
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(3, 2, figsize=(8.5, 7.0), sharex=True)
    for k, (col, lab, _) in enumerate(PANELS):
        a = ax[k // 2, k % 2]
        for name, st in styles.items():
            ts = res[name].ts
            m = window(ts, t0, t1)
            a.plot(ts.t[m], ts[col][m], st, lw=0.9, label=name)
        a.set_ylabel(lab, fontsize=8)
        a.tick_params(labelsize=7)
    ax[0, 0].legend(fontsize=7)
    ax[2, 0].set_xlabel("time (s)")
    ax[2, 1].set_xlabel("time (s)")
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return fig


FITTED = "consistent (fitted)"  # ε1 is chosen to fit these axes: the row cannot fail, it is not a test


def _inside(rng, axes, cols, fitted=False):
    """The verdict of an axis row: "not" when a curve leaves the paper's axis; inside, "reproduced", or for the axes
    that ε1 was fitted to (Fig. 2's), :data:`FITTED`: a fit cannot fail on the data it was fitted to."""
    if outside({c: rng[c] for c in cols}, {c: axes[c] for c in cols}):
        return "not"
    return FITTED if fitted else "reproduced"


EPS1_CAVEAT = ("Reproduced only given the filter constant ε1 = 0.01 1/s, which the paper does not print: it is "
               "fitted to Fig. 2's axes (any 0.005–0.012 fits; item harshness), so the axis rows of Fig. 2 confirm "
               "the fit rather than test the law (their verdict: \"consistent (fitted)\").  With only what is "
               "printed (ε1 = 0) the known run's travel passes the ±8 cm limit (8.88 cm); with our earlier reading "
               "ε1 = ε = 1.5 it spikes to 57 m/s² and 4.4e7 Pa.")


def fig2(ctx) -> ItemOutput:
    res = ctx.run_scenario("lin_fig2")
    k = res["known"].ts
    J = {v: rms(res[v].ts.body_acc.to_numpy()[window(res[v].ts, 0.5, 1.5)]) for v in res}
    dev = {v: rms((res[v].ts.body_acc - k.body_acc).to_numpy()[window(k, 0.5, 1.5)]) for v in res}
    env = envelope(res, list(res), 0.0, 3.0, AXES[2])
    zmax = env["body_z"][1]
    spread = max(abs(J[v] / J["known"] - 1) for v in J)
    ax = AXES[2]
    claims = [
        Claim("three curves (known; M_b +20 %, K_a −20 %; M_b −20 %, K_a +20 %)", "\"almost overlap\"",
              f"RMS body acc 0.5–1.5 s: {J['known']:.2f} / {J['mb_plus_ka_minus']:.2f} / "
              f"{J['mb_minus_ka_plus']:.2f} m/s² (spread {spread:.1%})",
              "reproduced" if spread < 0.05 else "not"),
        Claim("body acceleration, all three curves (axis −9…12 m/s²)", "within the axis",
              f"{env['body_acc'][0]:.1f}…{env['body_acc'][1]:.1f} m/s²", _inside(env, ax, ["body_acc"], fitted=True)),
        Claim("load pressure (axis −1e7…5e6 Pa)", "within the axis",
              f"{env['act.load_pressure'][0]:.3g}…{env['act.load_pressure'][1]:.3g} Pa",
              _inside(env, ax, ["act.load_pressure"], fitted=True)),
        Claim("body travel (axis 0…0.025 m)", "peak ≤ 2.5 cm", f"{zmax * 100:.2f} cm", _inside(env, ax, ["body_z"], fitted=True)),
        Claim("suspension travel, wheel travel, valve opening (axes ±0.085, −0.03…0.09, ±0.01 m)", "within the axes",
              f"{env['travel'][0] * 100:.2f}…{env['travel'][1] * 100:.2f} cm, {env['wheel_z'][0] * 100:.2f}…"
              f"{env['wheel_z'][1] * 100:.2f} cm, |x_v| ≤ {max(map(abs, env['act.spool_position'])) * 1000:.1f} mm",
              _inside(env, ax, ["travel", "wheel_z", "act.spool_position"], fitted=True)),
    ]
    fig = six_panels(res, {"known": "k-", "mb_plus_ka_minus": "r--", "mb_minus_ka_plus": "b:"}, 0.0, 3.0,
                     "Lin & Kanellakopoulos Fig. 2: errors in M_b and K_a (non-adaptive)")
    for i, c in enumerate(p[0] for p in PANELS):
        fig.axes[i].axhspan(*ax[c], color="0.93", zorder=0)
    key = {"rms_acc_known": (J["known"], 0.1), "rms_acc_mb_plus": (J["mb_plus_ka_minus"], 0.1),
           "rms_acc_mb_minus": (J["mb_minus_ka_plus"], 0.1),
           "peak_acc_known": (float(np.max(np.abs(k.body_acc))), 1.0), "body_z_peak": (zmax, 1e-3)}
    for c, fl in (("body_acc", 1.0), ("act.load_pressure", 1e5), ("travel", 1e-3), ("wheel_z", 1e-3)):
        key[f"envelope_min {c}"] = (env[c][0], fl)  # the axis rows: every curve's range
        key[f"envelope_max {c}"] = (env[c][1], fl)
    notes = [f"RMS deviation from the known run over 0.5–1.5 s: {dev['mb_plus_ka_minus']:.2f} and "
             f"{dev['mb_minus_ka_plus']:.2f} m/s². Grey bands: the paper's axis ranges.", EPS1_CAVEAT]
    return ItemOutput(claims, key=key, figure=fig, notes=notes)


def fig3(ctx) -> ItemOutput:
    res = ctx.run_scenario("lin_fig3")
    J = {}
    for v in res:
        ts = res[v].ts
        J[v] = {w: rms(ts.body_acc.to_numpy()[window(ts, *win)]) for w, win in
                (("bump", (0.5, 0.8)), ("all", (0.5, 1.5)))}
    d = {v: J[v]["bump"] / J["known"]["bump"] - 1 for v in ("better", "worse")}
    env = envelope(res, list(res), 0.5, 0.8, AXES[3])
    ax = AXES[3]
    claims = [
        Claim("\"s.b.\" set (M_b, M_us, C_a, τ +20 %; K_a, K_t −20 %)", "dashed \"almost uniformly better\"",
              f"RMS body acc 0.5–0.8 s {d['better']:+.1%} vs known (0.5–1.5 s "
              f"{J['better']['all'] / J['known']['all'] - 1:+.1%})",
              "reproduced" if d["better"] < -0.01 else ("partly" if d["better"] < 0.01 else "not")),
        Claim("\"s.w.\" set (the opposite errors)", "dotted \"uniformly worse\"",
              f"{d['worse']:+.1%} (0.5–1.5 s {J['worse']['all'] / J['known']['all'] - 1:+.1%})",
              "reproduced" if d["worse"] > 0.01 else "not"),
        Claim("body acceleration, all three curves (axis −20…15 m/s²)", "within the axis",
              f"{env['body_acc'][0]:.1f}…{env['body_acc'][1]:.1f} m/s²", _inside(env, ax, ["body_acc"])),
        Claim("body travel, load pressure (axes −0.005…0.026 m, −2e7…1e7 Pa)", "within the axes",
              f"{env['body_z'][0] * 100:.2f}…{env['body_z'][1] * 100:.2f} cm, {env['act.load_pressure'][0]:.3g}…"
              f"{env['act.load_pressure'][1]:.3g} Pa", _inside(env, ax, ["body_z", "act.load_pressure"])),
    ]
    fig = six_panels(res, {"known": "k-", "better": "r--", "worse": "b:"}, 0.5, 0.8,
                     "Lin & Kanellakopoulos Fig. 3: six values wrong in the s.b. / s.w. directions (non-adaptive)")
    for i, c in enumerate(p[0] for p in PANELS):
        fig.axes[i].axhspan(*ax[c], color="0.93", zorder=0)
    key = {f"rms_acc_bump_{v}": (J[v]["bump"], 0.1) for v in J}
    return ItemOutput(claims, key=key, figure=fig, notes=["Grey bands: the paper's axis ranges.", EPS1_CAVEAT])


# Readings of Eq. (25) "ε = 1.5; m1 = 0.055; m2 = 0.005" (one unsubscripted filter constant; ε1 not printed)
READINGS = {
    "ε = ε1 = 1.5 (earlier default)": {"eps1": 1.5},
    "ε = 1.5, ε1 = 0 (only what is printed)": {"eps1": 0.0},
    "ε1 = 1.5, ε = 0.5 (glyph read as ε1)": {"eps1": 1.5, "eps": 0.5},
    "ε1 = 1.5, ε = 3 (glyph read as ε1)": {"eps1": 1.5, "eps": 3.0},
    "ε = 1.5, ε1 = 0.005": {"eps1": 0.005},
    "ε = 1.5, ε1 = 0.01 (default)": {"eps1": 0.01},
    "ε = 1.5, ε1 = 0.015": {"eps1": 0.015},
    "ε = ε1 = 1.5, m2 = 0.02": {"eps1": 1.5, "m2": 0.02},
}
EARLIER, DEFAULT = "ε = ε1 = 1.5 (earlier default)", "ε = 1.5, ε1 = 0.01 (default)"


def harshness(ctx) -> ItemOutput:
    """Which reading of the filter constants of Eq. (25) the paper's figures show: the known-parameter run of
    Fig. 2 for each reading against the six axes of Fig. 2, and Fig. 4's runs for the earlier and the default
    reading against Fig. 4's axes."""
    import matplotlib.pyplot as plt

    base = ctx.variants("lin_fig2", ["sim.log_dt=0.0001"], only=["known"])["known"]
    scs = {}
    for name, p in READINGS.items():
        sc = base.model_copy(deep=True)
        sc.controller.params.update({"eps": 1.5, "m2": 0.005, **p})
        scs[name] = sc
    f4 = {}
    for reading in (EARLIER, DEFAULT):
        for v, sc in ctx.variants("lin_fig4", ["sim.duration=1.5"]).items():
            sc.controller.params.update(READINGS[reading])
            scs[f"fig4 {v} | {reading}"] = sc
            f4.setdefault(reading, []).append(f"fig4 {v} | {reading}")
    res = ctx.run(scs, label="filter readings")
    rows, rng = [], {}
    for name, p in READINGS.items():
        q = {"eps": 1.5, "m2": 0.005, **p}
        r = rng[name] = ranges(res[name].ts, 0.0, 3.0, list(AXES[2]))
        off = outside(r, AXES[2])
        trav = max(map(abs, r["travel"]))
        rows.append([name, f"{q['eps1'] / q['m2'] ** 4:.2g}", f"{r['body_acc'][0]:.1f}…{r['body_acc'][1]:.1f}",
                     f"{r['body_z'][1] * 100:.2f}", f"{trav * 100:.2f}" + (" (> 8)" if trav > 0.08 else ""),
                     f"{r['act.load_pressure'][0]:.2g}…{r['act.load_pressure'][1]:.2g}",
                     f"{max(map(abs, r['act.spool_position'])) * 1000:.1f}",
                     ", ".join(off) if off else "none"])
    f4rows = []
    for reading, names in f4.items():
        e = envelope(res, names, 0.5, 0.8, AXES[4])
        off = outside(e, AXES[4])
        f4rows.append([reading, f"{e['body_acc'][0]:.1f}…{e['body_acc'][1]:.1f}",
                       f"{e['act.load_pressure'][0]:.2g}…{e['act.load_pressure'][1]:.2g}",
                       ", ".join(off) if off else "none"])
    d, o = rng[DEFAULT], rng[EARLIER]
    peak = {n: float(np.max(np.abs(res[n].ts.body_acc))) for n in (DEFAULT, EARLIER)}
    fig, ax = plt.subplots(3, 1, figsize=(7.5, 7.0), sharex=True)
    for k, (col, lab, band) in enumerate((("body_acc", "body acc (m/s²)", AXES[2]["body_acc"]),
                                          ("body_z", "body travel (m)", AXES[2]["body_z"]),
                                          ("act.load_pressure", "load pressure (Pa)", AXES[2]["act.load_pressure"]))):
        ax[k].axhspan(*band, color="0.9", label="paper Fig. 2 axis range")
        for name, st in ((EARLIER, "k-"), (DEFAULT, "r-"), ("ε = 1.5, ε1 = 0 (only what is printed)", "b:")):
            ts = res[name].ts
            m = window(ts, 0.45, 1.2)
            ax[k].plot(ts.t[m], ts[col][m], st, lw=0.9, label=name)
        ax[k].set_ylabel(lab, fontsize=8)
        ax[k].tick_params(labelsize=7)
    ax[0].legend(fontsize=7)
    ax[2].set_xlabel("time (s)")
    fig.suptitle("Lin & Kanellakopoulos: the known-parameter run for three readings of the filter constants",
                 fontsize=9)
    fig.tight_layout()
    ok = [r[0] for r in rows if r[-1] == "none" and "(> 8)" not in r[4]]
    claims = [
        Claim("known-parameter run, default reading (ε = 1.5, ε1 = 0.01)", "inside all six axes of Fig. 2",
              f"acc {d['body_acc'][0]:.1f}…{d['body_acc'][1]:.1f} m/s², body ≤ {d['body_z'][1] * 100:.2f} cm, "
              f"P_L {d['act.load_pressure'][0]:.3g}…{d['act.load_pressure'][1]:.3g} Pa",
              FITTED if not outside(d, AXES[2]) else "not"),
        Claim("the same, earlier reading ε1 = ε = 1.5", "inside all six axes of Fig. 2",
              f"acc up to {o['body_acc'][1]:.1f} m/s², body {o['body_z'][1] * 100:.2f} cm, P_L up to "
              f"{o['act.load_pressure'][1]:.3g} Pa (outside: {', '.join(outside(o, AXES[2])) or 'none'})",
              "reproduced" if not outside(o, AXES[2]) else "not"),
        Claim("readings inside every Fig. 2 axis with the travel inside ±8 cm", "—", "; ".join(ok) or "none", "n.a."),
    ]
    table = md_table(["reading", "ε1/m2⁴ (1/(s·m⁴))", "body acc (m/s²; axis −9…12)", "body rise (cm; axis 2.5)",
                      "peak travel (cm; limit 8)", "P_L (Pa; axis −1e7…5e6)", "valve (mm; axis 10)",
                      "outside Fig. 2 axes"], rows)
    table4 = md_table(["reading", "Fig. 4 runs, body acc 0.5–0.8 s (axis ±50)", "P_L (axis ±3.5e7)",
                       "outside Fig. 4 axes"], f4rows)
    notes = ["Only ε1/m2⁴ is identified by the figures (compare ε1 = 0.01, m2 = 0.005 with ε1 = 1.5, m2 = 0.02): "
             "ε1·φ(η) = (ε1/m2⁴)·(|η| − m1)⁴.",
             f"Peak |body acc|: default {peak[DEFAULT]:.1f} m/s², earlier reading {peak[EARLIER]:.1f} m/s²."]
    key = {"peak_acc_default": (peak[DEFAULT], 1.0), "peak_acc_earlier": (peak[EARLIER], 1.0),
           "body_z_default": (d["body_z"][1], 1e-3), "travel_default": (max(map(abs, d["travel"])), 1e-3)}
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=[table, table4])


def _fig45(n):
    def run(ctx) -> ItemOutput:
        import matplotlib.pyplot as plt

        res = ctx.run_scenario(f"lin_fig{n}")
        k = res["known"].ts
        w = window(k, 0.5, 0.8)
        dev = {v: rms((res[v].ts.body_acc - k.body_acc).to_numpy()[w]) for v in res}
        trav = {v: float(np.max(np.abs(res[v].ts.travel))) for v in res}
        th = res["adaptive"].ts["ctrl.theta_hat"].to_numpy()
        ratio = dev["adaptive"] / dev["nonadaptive"]
        known_rms = rms(k.body_acc.to_numpy()[w])
        # "close to known": the adaptive run's deviation below half the known run's own RMS in the window;
        # closer than the non-adaptive run but not that close is "partly"
        claims = [
            Claim("adaptive (dashed) vs non-adaptive (dotted), deviation of body acc from the known run, 0.5–0.8 s",
                  "adaptive close to known, non-adaptive deviates",
                  f"{dev['adaptive']:.1f} vs {dev['nonadaptive']:.1f} m/s² (ratio {ratio:.2f}); the known run's "
                  f"RMS {known_rms:.1f} m/s²",
                  "reproduced" if ratio < 0.6 and dev["adaptive"] < 0.5 * known_rms
                  else ("partly" if ratio < 1 else "not")),
            Claim("suspension travel", "inside ±8 cm", ", ".join(f"{v} {trav[v] * 100:.2f} cm" for v in res),
                  "reproduced" if max(trav.values()) < 0.08 else "not"),
            Claim("ρθ̂ (Fig. 4: 1361 → ≈ 1512.5; Fig. 5: starts at 1512.5)",
                  "rises toward 1512.5" if n == 4 else "compensates the γ error",
                  f"{th[0]:.1f} → {th[-1]:.1f} at {float(res['adaptive'].ts.t.iloc[-1]):.0f} s"
                  + ("" if n == 4 else f" (1.1 × 1512.5 = {1.1 * 1512.5:.1f} restores θ̂/γ̂ = θ/γ)"),
                  "reproduced" if (abs(th[-1] / 1512.5 - 1) < 0.03 if n == 4 else th[-1] > 1.05 * 1512.5) else "partly"),
        ]
        fig = six_panels(res, {"known": "k-", "adaptive": "r--", "nonadaptive": "b:"}, 0.5, 0.8,
                         f"Lin & Kanellakopoulos Fig. {n}: {'α −10 %' if n == 4 else 'γ +10 %'} "
                         "(known / adaptive / non-adaptive)")
        ax = fig.axes[5]
        ax.clear()
        ax.plot(res["adaptive"].ts.t, th, "r--", lw=0.9)
        ax.axhline(1512.5, color="k", lw=0.5)
        ax.set_ylabel("ρθ̂ (N/m³ × 1e-7)", fontsize=8)
        ax.set_xlabel("time (s)")
        ax.tick_params(labelsize=7)
        key = {"dev_adaptive": (dev["adaptive"], 0.5), "dev_nonadaptive": (dev["nonadaptive"], 0.5),
               "theta_end": (float(th[-1]), 10.0), "travel_adaptive": (trav["adaptive"], 1e-3)}
        peak = {v: float(np.max(np.abs(res[v].ts.body_acc))) for v in res}
        stop = {v: float(np.mean(np.abs(res[v].ts["act.spool_position"].to_numpy()[w]) >= 0.00999)) for v in res}
        for v in res:  # the rows' other numbers: every run's travel and peak acceleration (the time at a spool stop
            key[f"travel_{v}"] = (trav[v], 1e-3)  # is a count of 0.5 ms log samples, not a key: see the page)
            key[f"peak_acc_{v}"] = (peak[v], 1.0)
        notes = ["Time at a spool stop (|x_v| = 1 cm), 0.5–0.8 s: " + ", ".join(f"{v} {stop[v]:.0%}" for v in res) + ".",
                 "Peak |body acc| over the run: " + ", ".join(f"{v} {peak[v]:.1f}" for v in res) + " m/s² (paper's "
                 "axis ±50)."]
        return ItemOutput(claims, key=key, figure=fig, notes=notes)

    return run


NOMINAL = {"sprung_mass": 290.0, "unsprung_mass": 59.0, "spring_stiffness": 16812.0, "damping": 1000.0,
           "tire_stiffness": 190000.0, "spool_time_constant": 1.0 / 30.0, "area": 3.35e-4, "alpha": 4.515e13,
           "beta": 1.0, "gamma": 1.545e9}
# (paper symbol, controller parameter, percent, paper's verdict for +, for −); "*" = not uniform over the run
PAPER = [
    ("M_b", "sprung_mass", 20, "s.b.", "s.w."),
    ("M_us", "unsprung_mass", 20, "s.b.*", "s.w."),
    ("K_a", "spring_stiffness", 20, "s.w.", "s.b."),
    ("C_a", "damping", 20, "s.b.*", "s.w."),
    ("K_t", "tire_stiffness", 20, "s.w.", "s.b.*"),
    ("τ", "spool_time_constant", 20, "s.b.*", "s.w.*"),
    ("A", "area", 10, "m.w.", "m.w."),
    ("α", "alpha", 10, "m.w.", "m.w."),
    ("β", "beta", 20, "n.c.", "n.c."),
    ("γ", "gamma", 10, "m.w.", "m.w."),
]


def measures(ts):
    a = ts.body_acc.to_numpy()
    return {"J": rms(a[window(ts, 0.5, 1.5)]), "bump": rms(a[window(ts, 0.5, 0.8)]),
            "settle": rms(a[window(ts, 0.8001, 1.5)]), "travel": float(np.max(np.abs(ts.travel)))}


def classify(m, m0):
    """Our reading of the paper's verdicts: J = RMS body acc 0.5–1.5 s; n.c. |ΔJ| < 1 %, s.b. ΔJ ≤ −1 %,
    s.w. 1–20 %, m.w. > 20 % or travel beyond 8 cm; "*" when bump and settling change in opposite senses."""
    if m is None:
        return "m.w.", float("nan")
    d = m["J"] / m0["J"] - 1
    if m["travel"] > 0.08:
        return "m.w.", d
    c = "n.c." if abs(d) < 0.01 else "s.b." if d <= -0.01 else "s.w." if d <= 0.20 else "m.w."
    db, ds = m["bump"] / m0["bump"] - 1, m["settle"] / m0["settle"] - 1
    if abs(db) > 0.01 and abs(ds) > 0.01 and np.sign(db) != np.sign(ds) and c in ("s.b.", "s.w."):
        c += "*"
    return c, d


T1_STEP = 1.25e-5  # Table 1's step: at 0.025 ms the A −10 % run (chattering at the spool stops) is not converged


def table1(ctx) -> ItemOutput:
    base = ctx.variants("lin_fig2", ["sim.duration=1.5"], only=["known"])["known"]
    base.sim.dt = base.sim.control_dt = T1_STEP * ctx.step_factor
    cases = {"nominal": {}}
    for sym, key, pct, plus, minus in PAPER:
        for sign in (+1, -1):
            cases[f"{sym} {'+' if sign > 0 else '−'}{pct}%"] = {key: NOMINAL[key] * (1 + sign * pct / 100)}
    scs = {}
    for name, p in cases.items():
        sc = base.model_copy(deep=True)
        sc.controller.params.update(NOMINAL)
        sc.controller.params["adaptive"] = False
        sc.controller.params.update(p)
        scs[name] = sc
    res = ctx.run(scs, label="Table 1")
    m0 = measures(res["nominal"].ts)
    rows, agree, key = [], [], {"J0": (m0["J"], 0.1)}
    for sym, k, pct, plus, minus in PAPER:
        for sign, paper in ((+1, plus), (-1, minus)):
            label = f"{sym} {'+' if sign > 0 else '−'}{pct}%"
            m = measures(res[label].ts)
            ours, d = classify(m, m0)
            same = ours.rstrip("*") == paper.rstrip("*")
            agree.append(same)
            key[f"dJ {label}"] = (d, 0.05)
            rows.append([sym, f"{'+' if sign > 0 else '−'}{pct}%", paper, ours, f"{d * 100:+.1f} %",
                         f"{m['travel'] * 100:.2f}", "yes" if same else "no"])
    n = sum(agree)
    key["verdicts agreeing with the paper"] = (float(n), 1.0)
    under = [key[f"dJ {k2}"][0] for k2 in ("A −10%", "α −10%", "γ +10%")]
    over = [key[f"dJ {k2}"][0] for k2 in ("A +10%", "α +10%", "γ −10%")]
    small = [abs(v) for k2, (v, _) in key.items() if k2.startswith("dJ ") and k2.split()[1] not in ("A", "α", "γ")]
    claims = [
        Claim("verdicts per parameter (20 cases)", "Table 1", f"{n} of 20 agree (metric in the notes)",
              "partly" if n >= 10 else "not"),
        Claim("A, α, γ are the parameters that matter", "m.w. for ±10 % on each",
              f"under-compensating errors (A −10 %, α −10 %, γ +10 %) ΔJ {min(under):+.0%}…{max(under):+.0%}; "
              f"the opposite errors {min(over):+.1%}…{max(over):+.1%}; all other parameters at ±20 % at most "
              f"{max(small):.1%}", "partly", "much worse only in the under-compensating direction"),
    ]
    import matplotlib.pyplot as plt

    labels = [f"{r[0]} {r[1]}" for r in rows]
    dj = np.array([key[f"dJ {lab}"][0] for lab in labels])
    colours = {"s.b.": "tab:green", "n.c.": "0.6", "s.w.": "tab:orange", "m.w.": "tab:red"}
    fig, ax = plt.subplots(figsize=(7.5, 5.5))
    y = np.arange(len(rows))[::-1]
    ax.barh(y, 100 * dj, color=[colours[r[2].rstrip("*")] for r in rows])
    ax.set_xscale("symlog", linthresh=2.0)
    ax.axvspan(-1, 1, color="0.92", zorder=0)  # our n.c. band
    ax.set_yticks(y, [f"{lab}  (paper {r[2]}, ours {r[3]})" for lab, r in zip(labels, rows)], fontsize=7)
    ax.set_xlabel("ΔJ = change of RMS body acc 0.5–1.5 s (%); bar colour = the paper's verdict")
    ax.set_title("Lin & Kanellakopoulos Table 1 (non-adaptive, one value wrong at a time)", fontsize=9)
    fig.tight_layout()
    table = md_table(["parameter", "error", "paper", "ours", "ΔJ", "peak travel (cm)", "agree"], rows)
    signs = sum(1 for r in rows if not r[2].startswith(("m.w.", "n.c.")) and
                (float(r[4].split()[0]) < 0) == r[2].startswith("s.b."))
    n_sbw = sum(1 for r in rows if not r[2].startswith(("m.w.", "n.c.")))
    notes = [f"Step {base.sim.dt * 1e3:g} ms. J0 = {m0['J']:.2f} m/s² (RMS body acceleration 0.5–1.5 s, correct "
             f"values), peak travel {m0['travel'] * 100:.2f} cm. " + classify.__doc__.replace("\n    ", " "),
             f"Sign of ΔJ against the paper's s.b./s.w. (ignoring our ±1 % n.c. band): {signs} of {n_sbw} agree."]
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=[table])



def chatter(ctx) -> ItemOutput:
    """Table 1's chattering run (A −10 %, non-adaptive) at other (physics, control) steps."""
    base = ctx.variants("lin_fig2", ["sim.duration=1.5"], only=["known"])["known"]
    base.controller.params.update(NOMINAL)
    base.controller.params["adaptive"] = False
    T = T1_STEP
    rows, key = [], {}
    for ph, co in ((2 * T, 2 * T), (T, T), (T / 2, T / 2), (T, 2 * T), (T / 2, T)):
        m = {}
        for name, p in (("nominal", {}), ("A −10%", {"area": NOMINAL["area"] * 0.9})):
            sc = base.model_copy(deep=True)
            sc.controller.params.update(p)
            sc.sim.dt, sc.sim.control_dt = ph, co
            ts = ctx.run({name: sc}, label=f"A −10 % at {ph * 1e3:g}/{co * 1e3:g} ms")[name].ts
            m[name] = measures(ts)
            if name != "nominal":
                stop = float(np.mean(np.abs(ts["act.spool_position"].to_numpy()[window(ts, 0.5, 1.5)]) >= 0.00999))
        d = m["A −10%"]["J"] / m["nominal"]["J"] - 1
        key[f"dJ {ph * 1e3:g}/{co * 1e3:g}"] = (d, 0.05)
        rows.append([f"{ph * 1e3:g}", f"{co * 1e3:g}", f"{m['nominal']['J']:.3f}", f"{m['A −10%']['J']:.3f}",
                     f"{d:+.1%}", f"{stop:.0%}"])
    claims = [Claim("A −10 % (non-adaptive) at equal physics and control steps", "m.w.",
                    f"ΔJ {rows[0][4]} / {rows[1][4]} / {rows[2][4]} at {rows[0][0]} / {rows[1][0]} / {rows[2][0]} ms",
                    "reproduced" if min(v for v, _ in key.values()) > 0.2 else "partly",
                    "the verdict holds at every step; the size converges from 0.0125 ms on")]
    table = md_table(["physics step (ms)", "control step (ms)", "J0 (m/s²)", "J, A −10 % (m/s²)", "ΔJ",
                      "time at a spool stop"], rows)
    notes = ["The spool stop is a clip of the exact spool lag toward the held command (reached within a step, the "
             "stop holds for the rest of it: exact for a held command). What "
             "moves the number is the sampled-data loop: with a control step twice the physics step the chattering "
             "differs from the equal-step runs, which converge from 0.0125 ms on."]
    return ItemOutput(claims, key=key, notes=notes, tables=[table])


REPEAT_N, REPEAT_PERIOD = 3, 2.5  # three bumps of Eq. (24), 2.5 s apart (ours: the paper runs one bump)


def repeat(ctx) -> ItemOutput:
    """Figs. 4–5 continued: does the adaptive run approach the known-parameter run once θ̂ has converged?  The
    paper's bump (24) three times, 2.5 s apart; beside known / adaptive / non-adaptive, the adaptive law started at
    the true θ = αA (``adaptive_true_start``: what the adaptation alone costs)."""
    import matplotlib.pyplot as plt

    # 0.0125 ms, as Table 1: at 0.025 ms the true-start run's last-bump deviation moved 2.6 % on halving
    # (1.389, 1.353, 1.337 m/s² at 0.025, 0.0125, 0.00625 ms)
    sets = [f"sim.duration={0.5 + REPEAT_PERIOD * (REPEAT_N - 1) + 1.0}", f"road.params.repeat={REPEAT_N}",
            f"road.params.period={REPEAT_PERIOD}", "sim.dt=1.25e-5", "sim.control_dt=1.25e-5"]
    claims, key, rows = [], {}, []
    fig, ax = plt.subplots(2, 1, figsize=(8, 5.5))
    for n, st in ((4, "-"), (5, "--")):
        v = ctx.variants(f"lin_fig{n}", sets)
        names = ("known", "adaptive", "nonadaptive", "adaptive_true_start")
        if n == 4:  # the adaptive law started at the true α, γ: the same run for both figures
            true = v["adaptive"].model_copy(deep=True)
            true.controller.params.update({"alpha": 4.515e13, "gamma": 1.545e9})
            v["adaptive_true_start"] = true
            res = ctx.run({k: v[k] for k in names}, label=f"lin_fig{n} × {REPEAT_N} bumps")
            true_run = res["adaptive_true_start"]
        else:
            res = ctx.run({k: v[k] for k in names[:3]}, label=f"lin_fig{n} × {REPEAT_N} bumps")
            res["adaptive_true_start"] = true_run
        k = res["known"].ts
        dev = {m: [] for m in names[1:]}
        th0 = []
        for i in range(REPEAT_N):
            a = 0.5 + i * REPEAT_PERIOD
            w = window(k, a, a + 0.3)
            for m in dev:
                dev[m].append(rms((res[m].ts.body_acc - k.body_acc).to_numpy()[w]))
            th0.append(float(res["adaptive"].ts["ctrl.theta_hat"].to_numpy()[k.t.to_numpy() <= a][-1]))
            rows.append([f"{n}", f"{i + 1} ({a:.1f} s)", f"{th0[-1]:.1f}"]
                        + [f"{dev[m][-1]:.2f}" for m in dev] + [f"{rms(k.body_acc.to_numpy()[w]):.2f}"])
        ad, na, tr = dev["adaptive"], dev["nonadaptive"], dev["adaptive_true_start"]
        ok = ad[-1] < 0.5 * ad[0] and na[-1] > 0.9 * na[0] and ad[-1] < 0.5 * na[-1]
        claims.append(Claim(
            f"Fig. {n} continued ({'α −10 %' if n == 4 else 'γ +10 %'}): deviation of body acc from the known run, "
            f"bump 1 → {REPEAT_N} (0.3 s windows)", "adaptive close to known, non-adaptive deviates",
            f"adaptive {' → '.join(f'{x:.2f}' for x in ad)} m/s², non-adaptive {' → '.join(f'{x:.2f}' for x in na)}; "
            f"the adaptive law started at the true θ {' → '.join(f'{x:.2f}' for x in tr)}",
            "reproduced" if ok else "partly",
            "once θ̂ has converged the adaptive run deviates from the known run only as much as the adaptive law "
            "started at the true θ does (the estimate moving during each bump), not by the initial error"))
        key[f"fig{n}_dev_adaptive_bump1"] = (ad[0], 0.1)
        key[f"fig{n}_dev_adaptive_bump{REPEAT_N}"] = (ad[-1], 0.1)
        key[f"fig{n}_dev_nonadaptive_bump{REPEAT_N}"] = (na[-1], 0.1)
        if n == 4:
            key[f"dev_true_start_bump{REPEAT_N}"] = (tr[-1], 0.1)
        for m, c in (("adaptive", "r"), ("nonadaptive", "b"), ("adaptive_true_start", "g")):
            ax[0].plot(range(1, REPEAT_N + 1), dev[m], c + st + "o", lw=0.9, label=f"Fig. {n} {m}")
        t = res["adaptive"].ts.t
        ax[1].plot(t, res["adaptive"].ts["ctrl.theta_hat"], "r" + st, lw=0.9, label=f"Fig. {n} adaptive")
        ax[1].plot(t, res["adaptive_true_start"].ts["ctrl.theta_hat"], "g" + st, lw=0.9,
                   label=f"Fig. {n} adaptive, true start")
    ax[0].set_xlabel("bump")
    ax[0].set_ylabel("RMS(body acc − known) (m/s²)", fontsize=8)
    ax[0].set_xticks(range(1, REPEAT_N + 1))
    ax[0].legend(fontsize=6, ncol=2)
    ax[1].axhline(1512.5, color="k", lw=0.5)
    ax[1].axhline(1.1 * 1512.5, color="k", lw=0.5, ls=":")
    ax[1].set_ylabel("ρθ̂", fontsize=8)
    ax[1].set_xlabel("time (s)")
    ax[1].legend(fontsize=6, ncol=2)
    fig.suptitle(f"Lin & Kanellakopoulos Figs. 4–5 continued: the bump (24) {REPEAT_N} times, {REPEAT_PERIOD} s apart",
                 fontsize=9)
    fig.tight_layout()
    table = md_table(["Fig.", "bump", "ρθ̂ before it", "adaptive", "non-adaptive", "adaptive from the true θ",
                      "known run's own RMS"], rows)
    return ItemOutput(claims, key=key, figure=fig, tables=[table],
                      notes=["Deviation = RMS(body acc − known-parameter body acc) over the 0.3 s from each bump's "
                             "start, m/s².  Not in the paper (one bump, 3 s): ours, to see whether the adaptive run "
                             "approaches the known one once θ̂ has converged."])


SOURCES.register("lin")(Source(
    "lin", "Lin & Kanellakopoulos (1996): adaptive nonlinear control in active suspensions",
    "docs/reproductions/lin_kanellakopoulos_1996.md",
    [Item("fig2", "Fig. 2: errors in M_b and K_a", fig2),
     Item("fig3", "Fig. 3: robustness enhancement (six values in the s.b. / s.w. directions)", fig3),
     Item("harshness", "The filter constant ε1: which reading of Eq. (25) the paper's axes show", harshness),
     Item("fig4", "Fig. 4: α underestimated by 10 % (adaptive / non-adaptive / known)", _fig45(4)),
     Item("fig5", "Fig. 5: γ overestimated by 10 % (adaptive / non-adaptive / known)", _fig45(5)),
     Item("repeat", "Figs. 4–5 continued: three bumps (does the adaptive run approach the known one?)", repeat),
     Item("table1", "Table 1: sensitivity to errors in the controller's values (non-adaptive)", table1),
     Item("chatter", "Table 1's chattering run (A −10 %) at other steps", chatter, converge=False)]))
