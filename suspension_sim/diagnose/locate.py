"""Where the calibrated model disagrees with the data, each against a noise floor estimated from the data:

- :func:`windows`: residual RMS per channel in consecutive time windows, flagged where it exceeds 3× the
  channel's noise floor;
- :func:`spectra`: Welch PSD of the residual against the (white) noise-floor level, the frequency band where
  the residual rises more than 10 dB above it, and the coherence of the residual with each input;
- :func:`force_map`: the residual *force* across the suspension by inverse dynamics where an acceleration
  is measured (travel and travel rate from the measured travel, zero-phase low-passed) (quarter car: ``m_s·z̈_s`` measured minus the model's suspension force at the measured travel
  and travel rate; SDOF: ``m·ẍ`` − model force; for the SDOF a measured position is differentiated twice
  when no acceleration is measured; damper: measured − model force), averaged in bins of travel × travel
  rate, with the standard error of each bin's mean from the acceleration noise floor.
"""
from __future__ import annotations

import numpy as np
from scipy.signal import coherence, welch



def windows(t, resid, channels, floors, n_win: int = 20) -> dict:
    out = {"t_start": [], "t_end": [], "rms": {c: [] for c in channels}, "flagged": []}
    idx = np.array_split(np.arange(len(t)), n_win)
    for w in idx:
        if len(w) == 0:
            continue
        out["t_start"].append(float(t[w[0]]))
        out["t_end"].append(float(t[w[-1]]))
        flag = False
        for i, c in enumerate(channels):
            r = float(np.sqrt(np.mean(resid[w, i] ** 2)))
            out["rms"][c].append(r)
            if floors[c]["value"] > 0 and r > 3 * floors[c]["value"]:
                flag = True
        out["flagged"].append(flag)
    return out


def spectra(resid, inputs: dict, channels, floors, fs_hz: float) -> dict:
    out = {}
    nper = int(min(len(resid), max(256, 2 ** int(np.log2(fs_hz * 4)))))
    for i, c in enumerate(channels):
        f, p = welch(resid[:, i], fs=fs_hz, nperseg=nper)
        level = floors[c]["value"] ** 2 / (fs_hz / 2)
        above = p > 10 * level if level > 0 else np.zeros_like(p, bool)
        band = [float(f[above].min()), float(f[above].max())] if above.any() else None
        coh = {}
        for name, u in inputs.items():
            if np.std(u) == 0:
                continue
            fc, cc = coherence(u, resid[:, i], fs=fs_hz, nperseg=nper)
            # where the input has power (above 1 % of its PSD peak): elsewhere coherence is meaningless
            _, pu = welch(u, fs=fs_hz, nperseg=nper)
            ok = (fc > 0) & (pu > 0.01 * pu.max())
            if not ok.any():
                continue
            k = int(np.flatnonzero(ok)[np.argmax(cc[ok])])
            coh[name] = {"max": float(cc[k]), "at_hz": float(fc[k]), "mean_below_50hz": float(np.mean(cc[(fc > 0) & (fc < 50)]))}
        out[c] = {"f": f, "psd": p, "floor_psd": level, "band_above_floor_hz": band, "coherence": coh,
                  "peak_hz": float(f[1 + int(np.argmax(p[1:]))])}
    return out


def force_map(prob, P: dict, floors: dict, a: int, b: int, nbins: int = 12, effects=(), offsets=None,
              gains=None) -> dict | None:
    """Residual suspension force over travel × travel rate on samples [a, b) (None when it cannot be formed);
    ``offsets``, ``gains``: the fit's channel offsets and gains, taken off the measured channels."""
    from .beyond import measured_in_model_frame

    rec = prob.rec
    o, dt = measured_in_model_frame(prob, rec.outputs, offsets, gains), rec.dt
    kind = rec.kind
    if kind not in ("quarter_car", "sdof", "damper"):
        return None  # a corner's force does not follow from its body acceleration alone (pitch/roll couple them)
    if kind == "quarter_car":
        if "body_acc" not in o or "susp_travel" not in o:
            return None
        s = o["susp_travel"][a:b]
        acc = o["body_acc"][a:b]
        m = P["sprung_mass"]
        sig_acc = floors.get("body_acc", {}).get("value", 0.0)
        note = "m_s·(measured body acceleration) − model suspension force at the measured travel and rate"
    elif kind == "sdof":
        if "pos" not in o:
            return None
        base = prob.inputs.get("base", np.zeros(len(rec)))[a:b]
        s = o["pos"][a:b] - base
        if "acc" in o:
            acc = o["acc"][a:b]
            sig_acc = floors.get("acc", {}).get("value", 0.0)
            note = "m·(measured acceleration) − model force"
        else:
            acc = np.gradient(np.gradient(o["pos"][a:b], dt), dt)
            # noise of (x[k+2] − 2x[k] + x[k−2]) / (4 dt²) for white position noise σ
            sig_acc = floors.get("pos", {}).get("value", 0.0) * np.sqrt(6) / (4 * dt ** 2)
            note = "m·(position differentiated twice) − model force"
        m = P["sprung_mass"]
    else:
        s = prob.inputs["disp"][a:b]
        acc = None
        m = 0.0
        sig_acc = floors.get("force", {}).get("value", 0.0)
        note = "measured force − model force"
    if kind != "damper":
        # measured travel is noisy: differentiating it would put noise into the bin variable (errors in
        # variables: the map would show spurious slopes and steps), so travel and rate come from a zero-phase
        # low-pass (4th-order Butterworth at min(40 Hz, 0.2·fs), above the vehicle modes)
        from scipy.signal import butter, filtfilt

        fc = min(40.0, 0.2 * rec.fs)
        bb, aa = butter(4, fc / (rec.fs / 2))
        if len(s) > 30:
            s = filtfilt(bb, aa, s)
        v = np.gradient(s, dt)
    else:
        v = prob.inputs["vel"][a:b] if "vel" in prob.inputs else np.gradient(s, dt)
    from .engine import effect_force

    Fsusp = -P["spring_stiffness"] * s - P["damping"] * v
    # stateful effects (hysteresis, backlash) are left out of the map: they are what the map should reveal
    eff = [e for e in effects if e[1] not in ("hysteresis", "backlash", "tire_liftoff")]
    if eff:
        Fsusp = Fsusp + effect_force(eff, P, s, v, dt)
    if kind == "damper":
        resid = o["force"][a:b] - (-Fsusp)
        sig = sig_acc
    else:
        fa = P.get("input.gain", 1.0) * prob.inputs["force"][a:b] + P.get("input.offset", 0.0) \
            if prob.has_force and "force" in prob.inputs else 0.0
        resid = m * acc - (Fsusp + fa)
        sig = m * sig_acc
    se = np.quantile(s, [0.01, 0.99])
    ve = np.quantile(v, [0.01, 0.99])
    sb = np.linspace(se[0], se[1], nbins + 1)
    vb = np.linspace(ve[0], ve[1], nbins + 1)
    i = np.clip(np.digitize(s, sb) - 1, 0, nbins - 1)
    j = np.clip(np.digitize(v, vb) - 1, 0, nbins - 1)
    mean = np.full((nbins, nbins), np.nan)
    cnt = np.zeros((nbins, nbins), int)
    np.add.at(cnt, (i, j), 1)
    tot = np.zeros((nbins, nbins))
    np.add.at(tot, (i, j), resid)
    ok = cnt >= 5
    mean[ok] = tot[ok] / cnt[ok]
    sem = np.where(ok, max(sig, 1e-12) / np.sqrt(np.maximum(cnt, 1)), np.nan)
    zmap = np.abs(mean) / sem
    # 1-D profiles against travel rate and against travel
    prof_v = _profile(v, resid, 24)
    prof_s = _profile(s, resid, 24)
    return {"s_edges": sb, "v_edges": vb, "mean": mean, "count": cnt, "z": zmap, "note": note,
            "rms_residual_force": float(np.sqrt(np.mean((resid - resid.mean()) ** 2))), "noise_force": float(sig),
            "max_abs_z": float(np.nanmax(zmap)) if np.isfinite(zmap).any() else None,
            "profile_v": prof_v, "profile_s": prof_s}


def _profile(x, r, n):
    e = np.quantile(x, np.linspace(0.01, 0.99, n + 1))
    e = np.unique(e)
    k = np.clip(np.digitize(x, e) - 1, 0, len(e) - 2)
    c = np.bincount(k, minlength=len(e) - 1)
    m = np.bincount(k, weights=r, minlength=len(e) - 1) / np.maximum(c, 1)
    return {"x": 0.5 * (e[1:] + e[:-1]), "mean": m, "count": c}
