"""Beyond the library: a sparse law fitted to the residual suspension force, proposed (not named) when the
library leaves the error far above the noise floor.

The residual force is formed by inverse dynamics, as the residual-force map of :mod:`.locate` does: the
measured body acceleration times the sprung mass (SDOF: the mass), minus the fitted model's suspension
force (linear spring and damper, the model's stateless effects, the actuator force) at the measured travel
and its rate (zero-phase low-passed, so that noise does not enter the regressors).  The candidate terms are
functions of travel ``s`` and rate ``v``: powers up to 3, ``|s|``, ``|v|``, ``sign(v)``, ``s·|s|``,
``v·|v|`` and the products ``s·v``, ``s²·v``, ``s·v²``, ``|s|·v``, ``s·|v|``.  Sparse regression is
pysindy's sequentially thresholded least squares (STLSQ) on normalised terms, the threshold chosen on the
held-out part (the last 30 % of the training window); the improvement reported is the fraction of the
held-out residual-force variance that the law explains, on data the fit never saw.
"""
from __future__ import annotations

import numpy as np

WORDS = {
    "s": "a linear spring", "v": "a linear damper", "s^2": "a spring that differs between compression and "
    "extension", "v^2": "a damper that differs between compression and rebound", "s^3": "a cubic spring "
    "(hardening or softening)", "v^3": "a cubic damper", "|s|": "a travel-dependent offset (V-shaped)",
    "|v|": "a rate-magnitude force", "sign(v)": "dry friction (a force step at each rate reversal)",
    "s|s|": "a progressive spring (s·|s|)", "v|v|": "quadratic (orifice) damping", "s*v": "damping that changes "
    "sign with travel", "s^2*v": "damping that grows with the stroke (s²·v)", "s*v^2": "a rate-squared force "
    "that changes sign with travel", "|s|*v": "damping that grows linearly with |travel|",
    "s*|v|": "a travel-proportional friction-like force",
}


STOP_QUANTILES = (0.7, 0.8, 0.9, 0.95, 0.98)  # gaps of the hinge (stop) terms: quantiles of |travel|


def _terms(s, v):
    """Candidate terms: powers and products of travel and rate, and hinges (a stop in extension or in
    compression beyond a gap; gaps at quantiles of |travel|, since a polynomial fitted to a one-sided stop
    does not carry over to larger strokes)."""
    hinge = {}
    for g in np.unique(np.round(np.quantile(np.abs(s), STOP_QUANTILES), 4)):
        if g > 0:
            hinge[f"max(s-{g:.4g},0)"] = np.maximum(s - g, 0.0)
            hinge[f"min(s+{g:.4g},0)"] = np.minimum(s + g, 0.0)
    return {**_poly_terms(s, v), **hinge}


def _words(name: str, cf: float) -> str:
    if name[:6] in ("max(s-", "min(s+"):
        side = "extension" if name[:6] == "max(s-" else "compression"
        what = "a stop" if cf < 0 else "a force pulling further (not a stop)"
        return f"{what} in {side} beyond {name[6:-3]} m, {abs(cf):.3g} N/m"
    return f"{WORDS.get(name, name)} ({'pushes the body up' if cf > 0 else 'resists'} for positive {name})"


def _poly_terms(s, v):
    return {"s": s, "v": v, "s^2": s ** 2, "v^2": v ** 2, "s^3": s ** 3, "v^3": v ** 3, "|s|": np.abs(s),
            "|v|": np.abs(v), "sign(v)": np.tanh(v / (0.02 * np.std(v) + 1e-12)), "s|s|": s * np.abs(s),
            "v|v|": v * np.abs(v), "s*v": s * v, "s^2*v": s * s * v, "s*v^2": s * v * v, "|s|*v": np.abs(s) * v,
            "s*|v|": s * np.abs(v)}


def measured_in_model_frame(prob, outputs: dict, offsets, gains=None) -> dict:
    """The measured outputs less the fitted channel offsets (sensor bias, a position sensor zeroed elsewhere) and
    over the fitted channel gains (select.py rule (h)): the travel the model's forces act on, not the sensor's
    reading."""
    if offsets is None and gains is None:
        return outputs
    out = dict(outputs)
    for i, c in enumerate(prob.channels):
        if c in out and offsets is not None and offsets[i] != 0:
            out[c] = out[c] - offsets[i]
        if c in out and gains is not None and gains[i] != 1:
            out[c] = out[c] / gains[i]
    return out


def residual_force(D, fitres):
    """(travel, rate, residual force, noise of the force) on the training window, or None."""
    from scipy.signal import butter, filtfilt

    from .engine import effect_force

    rec, prob = D.record, D.prob
    o = rec.outputs
    a, b = D.train
    P = fitres.P
    o = measured_in_model_frame(prob, o, fitres.offsets, getattr(fitres, "gains", None))
    if rec.kind == "quarter_car" and "body_acc" in o and "susp_travel" in o:
        s, acc, m = o["susp_travel"][a:b], o["body_acc"][a:b], P["sprung_mass"]
        sig = D.floors["body_acc"]["value"] * m
    elif rec.kind == "sdof" and "pos" in o and "acc" in o:
        s = o["pos"][a:b] - rec.inputs.get("base", np.zeros(len(rec)))[a:b]
        acc, m = o["acc"][a:b], P["sprung_mass"]
        sig = D.floors["acc"]["value"] * m
    elif rec.kind == "damper":
        s = rec.inputs["disp"][a:b]
        acc, m = None, 0.0
        sig = D.floors["force"]["value"]
    else:
        return None
    if rec.kind != "damper":
        fc = min(40.0, 0.2 * rec.fs)
        bb, aa = butter(4, fc / (rec.fs / 2))
        s = filtfilt(bb, aa, s) if len(s) > 30 else s
        acc = filtfilt(bb, aa, acc) if len(acc) > 30 else acc
        v = np.gradient(s, rec.dt)
    else:
        v = rec.inputs["vel"][a:b] if "vel" in rec.inputs else np.gradient(s, rec.dt)
    F = -P["spring_stiffness"] * s - P["damping"] * v
    eff = [(e.label, e.type, e.corners, e.fixed) for e in fitres.spec.effects
           if e.type not in ("hysteresis", "backlash", "tire_liftoff")]
    if eff:
        F = F + effect_force(eff, P, s, v, rec.dt)
    if rec.kind == "damper":
        r = -o["force"][a:b] - F
    else:
        fa = P.get("input.gain", 1.0) * rec.inputs["force"][a:b] + P.get("input.offset", 0.0) \
            if "force" in rec.inputs else 0.0
        r = m * acc - F - fa
    r = r - np.mean(r)
    return s, v, r, sig


def propose(D, fitres, max_terms: int = 3) -> dict | None:
    """A sparse law for the residual force, or None when it cannot be formed or explains nothing."""
    got = residual_force(D, fitres)
    if got is None:
        return None
    s, v, r, sig = got
    from pysindy.optimizers import STLSQ

    T = _terms(s, v)
    names = list(T)
    X = np.stack([T[k] for k in names], axis=1)
    X = X - X.mean(axis=0)
    sc = np.maximum(X.std(axis=0), 1e-30)
    Xn = X / sc
    n = len(r)
    cut = int(0.7 * n)
    best = None
    for thr in np.geomspace(0.02, 2.0, 14) * np.std(r):
        opt = STLSQ(threshold=float(thr), alpha=1e-6, max_iter=40)
        opt.fit(Xn[:cut], r[:cut])
        c = np.asarray(opt.coef_).reshape(-1)
        k = np.count_nonzero(c)
        if k == 0 or k > max_terms:
            continue
        e_ho = r[cut:] - Xn[cut:] @ c
        expl = 1 - np.var(e_ho) / max(np.var(r[cut:]), 1e-300)
        score = expl - 0.01 * k
        if best is None or score > best[0]:
            best = (score, c.copy(), expl, k)
    if best is None or best[2] < 0.05:
        return None
    _, c, expl, k = best
    # refit the kept terms on the whole window (plain least squares) for the stated coefficients
    idx = np.nonzero(c)[0]
    coef, *_ = np.linalg.lstsq(X[:, idx], r, rcond=None)
    terms = [(names[i], float(cf)) for i, cf in zip(idx, coef)]
    eq = "F_extra = " + " ".join(f"{cf:+.4g}·{nm}" for nm, cf in terms)
    words = "; ".join(_words(nm, cf) for nm, cf in terms)
    return {"equation": eq, "terms": {nm: cf for nm, cf in terms}, "in_words": words,
            "heldout_variance_explained": float(expl), "rms_residual_force": float(np.std(r)),
            "noise_force": float(sig), "note": "a proposal from sparse regression (pysindy STLSQ) on the residual "
            "suspension force, not a library effect: F_extra in N, s = travel (m), v = travel rate (m/s), "
            "positive F_extra pushes the body up"}
