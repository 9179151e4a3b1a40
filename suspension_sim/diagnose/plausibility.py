"""Plausibility before confidence: checks of the record and the model file before ``diagnose`` fits anything.

A fit always returns numbers; when the data are in the wrong unit they are confidently wrong (body
acceleration in g fitted as a 5-tonne car, a road in mm "explained" by tire lift-off and hysteresis).  These
checks compare the record with the model and with physics, and say what they suspect:

- **model file**: masses, inertias and tire stiffness > 0, stiffness and damping >= 0, everything finite
  (always an error);
- **time base**: a sample rate below the model's fastest natural frequency (a time column in ms read as s),
  or above 10 MHz (a time column in a larger unit);
- **magnitudes** (vehicle models): road, travel and positions beyond 0.5–1 m, accelerations beyond 100 g,
  any value beyond 1e9 (a unit scale gone wrong);
- **gravity**: an acceleration whose mean is ±1 g (the sensor's static reading was left in);
- **scales against the model** (vehicle models): the measured RMS of each output against the nominal model
  driven by the measured inputs; one acceleration channel 1/g of the prediction ("body_acc looks like g, not
  m/s²"), a channel 1000× or 100× off ("looks like mm/cm, not m"), or every output off by the same factor
  (the input is in the wrong unit).

Each finding is one line; :func:`check` raises a :class:`~suspension_sim.errors.ScenarioError` with the first
one unless ``override`` is set (``diagnose --no-plausibility``), in which case the findings are returned (and
logged) as warnings.  The model-file check is never overridden.
"""
from __future__ import annotations

import numpy as np

from ..errors import ScenarioError

G = 9.81
OVERRIDE_FLAG = "--no-plausibility"
_ACC = ("body_acc", "wheel_acc", "acc")
_LEN = ("susp_travel", "body_pos", "wheel_pos", "pos", "road", "base", "disp")
_BOUND_M = {"road": 1.0, "susp_travel": 0.5, "body_pos": 1.0, "wheel_pos": 1.0}  # vehicle models, metres


def _base(name: str) -> str:
    for sfx in ("_front", "_rear"):
        if name.endswith(sfx):
            return name[: -len(sfx)]
    return name


def check_model(spec, source: str | None = None) -> None:
    """Refuse non-physical parameters in the model file (negative mass, non-finite values)."""
    from .model import positive, vehicle_params

    src = source or getattr(spec, "source", None) or None
    for name in vehicle_params(spec.kind):
        if name not in spec.P:
            continue
        v = float(spec.P[name])
        if not np.isfinite(v):
            raise ScenarioError(f"must be a finite number (got {v})", source=src, field=f"params.{name}")
        if positive(name) and spec.kind != "damper" and v <= 0:
            what = "mass" if "mass" in name else "value"
            raise ScenarioError(f"a {what} must be > 0 (got {v:g})", source=src, field=f"params.{name}")
        if v < 0:
            raise ScenarioError(f"must be >= 0 (got {v:g})", source=src, field=f"params.{name}")


def _rms(x: np.ndarray) -> float:
    x = np.asarray(x, dtype=float)
    with np.errstate(all="ignore"):
        m = float(np.mean(x))
        r = float(np.sqrt(np.mean((x - m) ** 2)))
    return r if np.isfinite(r) else float("inf")


def findings(rec, spec) -> list[tuple[str, str]]:
    """[(channel or 'time', what is suspected)] for a :class:`~.io.Record` against a :class:`~.model.ModelSpec`."""
    out: list[tuple[str, str]] = []
    vehicle = spec.kind in ("quarter_car", "half_car")
    chans = {**rec.inputs, **rec.outputs}
    # --- absurd values ------------------------------------------------------------------------------------
    for name, x in chans.items():
        peak = float(np.max(np.abs(x))) if len(x) else 0.0
        if not np.isfinite(peak) or peak > 1e9:
            out.append((name, f"values up to {peak:.3g}: not a physical {name} in SI units (a unit scale gone wrong?)"))
    if out:
        return out
    # --- time base ------------------------------------------------------------------------------------------
    from .calibrate import Problem

    fs = rec.fs
    w = Problem.omega_max(spec)
    f_nat = w / (2 * np.pi) if w > 0 else 0.0
    if f_nat > 0 and fs < 2 * f_nat / 4:  # far below Nyquist for the model's fastest mode
        hint = " (is the time column in ms, not s?)" if 1000 * fs >= 2 * f_nat else ""
        out.append(("time", f"sample rate {fs:.4g} Hz is too low for the model (natural frequencies up to "
                            f"{f_nat:.3g} Hz){hint}"))
    elif fs > 1e7:
        out.append(("time", f"sample rate {fs:.4g} Hz is implausibly high (is the time column in a larger unit "
                            "than s, or a sample index scaled wrongly?)"))
    # --- magnitudes and gravity -------------------------------------------------------------------------
    for name, x in chans.items():
        b = _base(name)
        peak = float(np.max(np.abs(x)))
        if vehicle and b in _BOUND_M and peak > _BOUND_M[b]:
            guess = "looks like mm, not m" if peak > 5 * _BOUND_M[b] else "check its unit"
            out.append((name, f"{name} reaches {peak:.4g} m, beyond any vehicle ({_BOUND_M[b]:g} m): {guess}"))
        if b in _ACC:
            mean, sd = float(np.mean(x)), float(np.std(x))
            if abs(abs(mean) - G) < 0.15 * G and sd < abs(mean):
                out.append((name, f"{name} has a mean of {mean:.3g} m/s²: it contains gravity (the sensor's 1 g); "
                                  "remove it (or --demean)"))
            elif vehicle and peak > 100 * G:
                out.append((name, f"{name} reaches {peak:.4g} m/s² (over 100 g): check its unit"))
    if out or not vehicle:
        return out
    # --- scales against the nominal model ---------------------------------------------------------------
    try:
        ratios = _ratios(rec, spec)
    except Exception:  # noqa: BLE001 - the comparison is a heuristic; the fit reports its own problems
        return out
    if len(ratios) >= 2:
        logs = np.log10([r for r in ratios.values()])
        common = float(np.median(logs))
        if np.all(np.abs(logs - common) < 0.35) and abs(common) > 1.5:
            f = 10 ** common
            src = "road" if "road" in rec.inputs or "road_front" in rec.inputs else "the input"
            unit = " (is it in mm, not m?)" if 0.4e-3 < f < 2.5e-3 else ""
            out.append((src, f"every output is {f:.3g}× what the model predicts from {src}: {src} looks scaled "
                             f"wrongly{unit}"))
            return out
    for name, r in ratios.items():
        b = _base(name)
        if b in _ACC and 1 / G / 1.35 < r < 1.35 / G:
            out.append((name, f"{name} looks like g, not m/s² (its RMS is {r:.3g}× the model's prediction, ≈ 1/g)"))
        elif b in _LEN and 1000 / 2 < r < 1000 * 2:
            out.append((name, f"{name} looks like mm, not m (its RMS is {r:.3g}× the model's prediction)"))
        elif b in _LEN and 100 / 2 < r < 100 * 2:
            out.append((name, f"{name} looks like cm, not m (its RMS is {r:.3g}× the model's prediction)"))
        elif r > 300 or r < 1 / 300:
            out.append((name, f"{name} is {r:.3g}× what the model predicts: check its unit and scale"))
    return out


def _ratios(rec, spec) -> dict[str, float]:
    """Measured RMS / nominal-model RMS per output channel (channels the model excites)."""
    from .calibrate import Problem

    n = min(len(rec), 20000)
    sub = rec.slice(0, n)
    prob = Problem(sub, spec)
    sim = prob.simulate(spec, spec.P)
    out = {}
    skip = n // 10
    for i, c in enumerate(prob.channels):
        rp, rm = _rms(sim[skip:, i]), _rms(prob.Y[skip:, i])
        if rp > 0 and np.isfinite(rp) and rm > 0:
            out[c] = rm / rp
    return out


def check(rec, spec, override: bool = False, log=None) -> list[str]:
    """Run :func:`check_model` and :func:`findings`; raise on the first finding unless ``override``."""
    check_model(spec)
    found = findings(rec, spec)
    msgs = [f"{ch}: {what}" for ch, what in found]
    if found and not override:
        ch, what = found[0]
        more = f" ({len(found) - 1} more finding(s))" if len(found) > 1 else ""
        raise ScenarioError(f"{what}{more}; fix the data or --map SRC=NAME*scale, or give {OVERRIDE_FLAG} to fit "
                            "anyway", source=rec.source or None, field=ch)
    for m in msgs:
        if log is not None:
            log(f"warning: plausibility: {m}")
    return msgs
