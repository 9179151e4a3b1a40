"""Kim (1996), Figs. 2–5 and the claim that k_d does not affect the estimation error (page:
docs/reproductions/kim_1996.md).

Every figure runs ``scenarios/kim_fig<N>.yaml``: the paper's law as printed (variant ``kim``) adapting from
wrong initial estimates (a2 −20 %, a3 +20 %; the paper gives none), beside the known-parameter case
(``known``), the same wrong estimates without adaptation (``nonadaptive``, the baseline that must do worse),
our rate-prediction addition (``rate_prediction``, not in the paper) and the passive car.  Numbers over the
last second of the 5 s runs unless stated.
"""
from __future__ import annotations

import numpy as np

from .framework import SOURCES, Claim, Item, ItemOutput, Source, fmt

A2, A3 = 15.125e9, 5.176e5
FIGS = {2: (10, True), 3: (10, False), 4: (1000, True), 5: (1000, False)}
KD_START_ERROR = 0.05  # the k_d study starts from a2 −5 %, a3 +5 %


def rms(x):
    x = np.asarray(x, float)
    return float(np.sqrt(np.mean(x * x)))


def force_error(ts, t0):
    m = ts.t.to_numpy() >= t0
    e = (ts["ctrl.F_a"] - ts["ctrl.F_d"]).to_numpy()[m]
    return rms(e), rms(e) / rms(ts["ctrl.F_d"].to_numpy()[m])


def param_error(ts):
    """Largest relative error of â2, â3 at the end of the run."""
    return max(abs(ts["ctrl.a2_hat"].iloc[-1] / A2 - 1), abs(ts["ctrl.a3_hat"].iloc[-1] / A3 - 1))


def _fig(n):
    k_d, fd = FIGS[n]

    def run(ctx) -> ItemOutput:
        import matplotlib.pyplot as plt

        res = ctx.run_scenario(f"kim_fig{n}")
        T = float(res["kim"].ts.t.iloc[-1])
        t0 = T - 1.0
        err = {v: force_error(res[v].ts, t0) for v in ("kim", "known", "nonadaptive", "rate_prediction", "load_cell",
                                                         "zoh")}
        ts = res["kim"].ts
        pe = ts["ctrl.p_e"].to_numpy()
        t = ts.t.to_numpy()
        pe_last, pe_peak = rms(pe[t >= t0]), float(np.max(np.abs(pe)))
        e2 = ts["ctrl.a2_hat"].to_numpy() / A2 - 1
        e3 = ts["ctrl.a3_hat"].to_numpy() / A3 - 1
        perr = param_error(ts)
        x2 = {v: float(np.max(np.abs(res[v].ts.body_z.to_numpy()[res[v].ts.t.to_numpy() >= 1.0])))
              for v in ("kim", "known", "passive")}

        claims = []
        small = err["kim"][1] < 0.1
        if fd:
            claims.append(Claim(
                "force tracking with dF_d/dt, RMS(F_a − F_d) / RMS F_d",
                "F_a on F_d (panel a); \"not sensitive to the variation of the controller gain\" (Figs. 2 vs 4)",
                f"{err['kim'][0]:.1f} N ({err['kim'][1]:.1%}); known parameters {err['known'][0]:.1f} N ({err['known'][1]:.1%})",
                ("reproduced" if k_d > 100 else "partly") if small else "not",
                "k_d = 10 leaves the spool lag ε/(1+K_pf) (neglected by the reduced model) uncorrected; "
                "k_d = 1000 rejects it" if k_d < 100 else ""))
        else:
            claims.append(Claim(
                "force tracking without dF_d/dt, RMS(F_a − F_d) / RMS F_d",
                "large steady error for k_d = 10 (Fig. 3)" if k_d < 100 else "small error for k_d = 1000 (Fig. 5)",
                f"{err['kim'][0]:.1f} N ({err['kim'][1]:.1%}); known parameters {err['known'][0]:.1f} N ({err['known'][1]:.1%})",
                "reproduced" if (err["kim"][1] > 0.3) == (k_d < 100) else "not"))
        nt = res["nonadaptive"].ts
        pe_n = nt["ctrl.p_e"].to_numpy()
        pe_n_last = rms(pe_n[nt.t.to_numpy() >= t0])
        pe_n_peak = float(np.max(np.abs(pe_n)))
        claims.append(Claim(
            "estimation error p_e (panel b)", "decays (Eq. 28–31)",
            f"peak {pe_peak:.0f} N → RMS {pe_last:.1f} N in the last second; baseline (the same wrong estimates, "
            f"no adaptation): peak {pe_n_peak:.0f} N → {pe_n_last:.1f} N",
            ("reproduced" if pe_last < 0.1 * pe_peak else "partly")
            if pe_n_last > 0.1 * pe_n_peak else "not (the baseline decays too)"))
        claims.append(Claim(
            "estimates from a2 −20 %, a3 +20 % (ours: the paper gives no initial values)",
            "θ̃ bounded; performance of the known-parameter case",
            f"â2 {e2[-1]:+.2%}, â3 {e3[-1]:+.2%} at {T:.0f} s; force error {err['kim'][0]:.1f} N vs known "
            f"{err['known'][0]:.1f} N, non-adaptive {err['nonadaptive'][0]:.1f} N",
            "reproduced" if perr < 0.05 and err["kim"][0] < 1.5 * err["known"][0] + 1.0 else "partly"))
        claims.append(Claim(
            "body displacement x2 (panel c), peak after 1 s", "sky-hook damps the sprung mass",
            f"{x2['kim'] * 100:.2f} cm (known {x2['known'] * 100:.2f}, passive car with a 1000 N·s/m damper "
            f"{x2['passive'] * 100:.2f})", "reproduced" if x2["kim"] < 0.6 * x2["passive"] else "not"))
        claims.append(Claim(
            "variants not in the paper", "—",
            f"plain hold (deflection rate at the start of the hold) {err['zoh'][0]:.1f} N; rate prediction "
            f"(ours, + ε/(1+K_pf)) {err['rate_prediction'][0]:.1f} N; load cell instead of pressure "
            f"transducer {err['load_cell'][0]:.1f} N", "n.a."))

        fig, ax = plt.subplots(4, 1, figsize=(7.5, 8.0), sharex=True)
        ax[0].plot(t, ts["ctrl.F_d"], "k-", lw=1.0, label="F_d")
        ax[0].plot(t, ts["ctrl.F_a"], "r--", lw=0.8, label="F_a (adaptive)")
        nt = res["nonadaptive"].ts
        ax[0].plot(nt.t, nt["ctrl.F_a"], "b:", lw=0.8, label="F_a (non-adaptive)")
        ax[0].set_ylabel("force (N)")
        ax[0].legend(fontsize=7, loc="upper right", ncol=3)
        ax[1].plot(t, pe, "r-", lw=0.8)
        ax[1].set_ylabel("p_e (N)")
        ax[1].set_ylim(-1.1 * max(pe_peak, 1), 1.1 * max(pe_peak, 1))
        ax[2].plot(t, 100 * e2, "r-", lw=1.0, label="â2/a2 − 1")
        ax[2].plot(t, 100 * e3, "m--", lw=1.0, label="â3/a3 − 1")
        ax[2].axhline(0, color="k", lw=0.5)
        ax[2].set_ylabel("estimate error (%)")
        ax[2].legend(fontsize=7)
        for v, style in (("kim", "r-"), ("known", "k:"), ("passive", "g-")):
            r = res[v].ts
            ax[3].plot(r.t, 100 * r.body_z, style, lw=0.8, label=v)
        ax[3].set_ylabel("x2 (cm)")
        ax[3].set_xlabel("time (s)")
        ax[3].legend(fontsize=7, ncol=3)
        fig.suptitle(f"Kim Fig. {n}: k_d = {k_d}, {'with' if fd else 'without'} dF_d/dt (the paper's law, "
                     "a2 −20 %, a3 +20 % at t = 0)", fontsize=9)
        fig.tight_layout()
        key = {"force_error_adaptive_N": (err["kim"][0], 0.1), "force_error_known_N": (err["known"][0], 0.1),
               "param_error_end": (perr, 0.01), "x2_peak_m": (x2["kim"], 1e-3)}
        notes = []
        if n == 2:
            notes.append("Step: 0.025 ms here (Figs. 3 and 5: 0.1 ms; Fig. 4: 0.025 ms). At k_d = 10 the force error is sensitive to the "
                         "sampled realisation: with the deflection rate of f̂ taken at the start of each hold "
                         "(variant zoh) it is first order in the step (21.0, 17.0, 15.1, 14.2, 13.8 N at 0.1, "
                         "0.05, 0.025, 0.0125, 0.00625 ms); at the middle of the hold (the scenarios' "
                         "hold_midpoint) 15.0, 14.1, 13.7, 13.5, 13.5 N. Both tend to ≈ 13.4 N, the continuous "
                         "law's value on this plant: what remains is the spool lag ε/(1 + K_pf) = 0.14 ms that "
                         "the reduced model (14) drops (K_pf = 20 is ours; the error scales with that lag).")
        return ItemOutput(claims, key=key, figure=fig, notes=notes)

    return run


def kd_claim(ctx) -> ItemOutput:
    """Section 3: "the value of the controller gain k_d does not affect the estimation error system"."""
    import matplotlib.pyplot as plt

    runs = {}
    for gain in (1e-10, 1e-8):
        for k_d in (10, 1000):
            sc = ctx.scenario("kim_fig2", [f"controller.params.k_d={k_d}",
                                           f"controller.params.a2={A2 * (1 - KD_START_ERROR)}",
                                           f"controller.params.a3={A3 * (1 + KD_START_ERROR)}"] +
                              [f"controller.params.gain_a{i}={gain}" for i in (1, 2, 3)])
            sc.variants = {}
            runs[(gain, k_d)] = sc
    res = ctx.run({f"g{g:g}_kd{k}": sc for (g, k), sc in runs.items()}, label="k_d claim")
    rows, key, per_exc = [], {}, {}
    fig, ax = plt.subplots(2, 1, figsize=(7.5, 5.0), sharex=True)
    styles = {(1e-10, 10): "r-", (1e-10, 1000): "b-", (1e-8, 10): "r--", (1e-8, 1000): "b--"}
    for (g, k) in runs:
        ts = res[f"g{g:g}_kd{k}"].ts
        t = ts.t.to_numpy()
        e2 = ts["ctrl.a2_hat"].to_numpy() / A2 - 1
        last = t >= t[-1] - 1.0
        vrel = rms(ts.travel_rate.to_numpy()[last])
        fe = force_error(ts, t[-1] - 1.0)
        # excitation of θ2 delivered by the closed loop: gain·∫(a2·A_p·(ẋ2 − ẋ1))² dt / α1 (the slow pole of the
        # (p_e, θ̃2) loop integrated over the run); if k_d acts only through it, the decay per unit of it is the same
        y2 = A2 * 3.35e-4 * ts.travel_rate.to_numpy()
        exc = g * float(np.sum(y2[1:] ** 2 * np.diff(t))) / 30.0
        decay = float(np.log(KD_START_ERROR / max(abs(e2[-1]), 1e-12)))
        per_exc[(g, k)] = decay / exc if exc > 0 else float("nan")
        rows.append([f"{g:g}", str(k), f"{e2[np.searchsorted(t, 1.0)]:+.2%}", f"{e2[-1]:+.2%}",
                     f"{fe[0]:.0f} N ({fe[1]:.0%})", f"{vrel * 1000:.1f} mm/s", f"{exc:.3g}",
                     f"{per_exc[(g, k)]:.3g}"])
        # the error left of the 5 % start: near zero at the larger gain, where its own first-order step error
        # (≈ 2e-5 absolute at 0.025 ms) is 10 % of it, so it is compared against the start error (the page)
        key[f"a2_error_end_g{g:g}_kd{k}"] = (abs(e2[-1]), KD_START_ERROR)
        ax[0].plot(t, 100 * e2, styles[(g, k)], lw=1.0, label=f"Γ {g:g}, k_d {k}")
        ax[1].plot(t, 1000 * ts.travel_rate, styles[(g, k)], lw=0.5)
    ax[0].set_ylabel("â2/a2 − 1 (%)")
    ax[0].legend(fontsize=7)
    ax[1].set_ylabel("deflection rate (mm/s)")
    ax[1].set_xlabel("time (s)")
    fig.suptitle("Kim: estimation error against k_d (a2 −5 %, a3 +5 % at t = 0, with dF_d/dt)", fontsize=9)
    fig.tight_layout()
    e_slow = {k: abs(res[f"g1e-10_kd{k}"].ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) for k in (10, 1000)}
    e_fast = {k: abs(res[f"g1e-08_kd{k}"].ts["ctrl.a2_hat"].iloc[-1] / A2 - 1) for k in (10, 1000)}
    from .framework import md_table

    table = md_table(["gain (normalised)", "k_d", "â2 error at 1 s", "â2 error at 5 s",
                       "force error, last s", "RMS deflection rate, last s",
                       "excitation E = Γ·∫(a2·A_p·(ẋ2 − ẋ1))²dt/α1", "ln(5 % / error at 5 s) ÷ E"], rows)
    claims = [
        Claim("estimation error against k_d at the scenarios' gain (1e-8)",
              "k_d does not affect the estimation error system (31)",
              f"â2 error at 5 s: {e_fast[10]:.2%} (k_d = 10) vs {e_fast[1000]:.2%} (k_d = 1000)",
              "reproduced" if max(e_fast.values()) < 0.01 else "partly"),
        Claim("same at a 100× smaller gain (1e-10, the project's earlier choice)", "as above",
              f"{e_slow[10]:.2%} (k_d = 10) vs {e_slow[1000]:.2%} (k_d = 1000)",
              "not" if e_slow[10] > 3 * e_slow[1000] else "reproduced",
              "the equations (24), (27) hold k_d-free; their excitation Y_r does not (see table)"),
    ]
    r = per_exc[(1e-10, 10)] / per_exc[(1e-10, 1000)]
    claims.append(Claim("decay of the â2 error per unit of delivered excitation, gain 1e-10",
                        "independent of k_d (the estimation system (24), (27) has no k_d)",
                        f"k_d = 10 / k_d = 1000: {r:.2f}", "reproduced" if 0.5 < r < 2 else "partly",
                        "k_d changes how much excitation Y_r the closed loop delivers, not what the estimator "
                        "does with it"))
    notes = ["Why: with θ̃ ≠ 0 the uncancelled hydraulic-spring term a2·A·(ẋ2 − ẋ1) makes the actuator stiffen "
             "the suspension by θ̃ᵀY_r/k_d; at k_d = 10 that locks it (deflection rate 7× smaller), the "
             "regressor A·(ẋ2 − ẋ1) that drives the gradient law shrinks with it, and the adaptation (rate ∝ "
             "gain·|Y_r|²) stalls. With known parameters both gains give the same deflection rate. A gain large "
             "enough to converge before the suspension locks restores the paper's claim."]
    return ItemOutput(claims, key=key, figure=fig, notes=notes, tables=[table])


SOURCES.register("kim")(Source(
    "kim", "Kim (1996): nonlinear indirect adaptive control of a quarter car active suspension",
    "docs/reproductions/kim_1996.md",
    [Item(f"fig{n}", f"Fig. {n}: k_d = {FIGS[n][0]}, {'with' if FIGS[n][1] else 'without'} dF_d/dt", _fig(n))
     for n in FIGS] + [Item("kd_claim", "Claim: k_d does not affect the estimation error", kd_claim)]))
