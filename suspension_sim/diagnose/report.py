"""Outputs of a diagnosis: ``report.json`` (for programs), ``model.fitted.yaml`` (vehicle block with the
fitted parameters and 95 % intervals), ``model.fitted.xml`` (the MJCF of the fitted vehicle),
``scenario.fitted.yaml`` (a runnable scenario replaying the measured inputs through MuJoCo), ``report.html``
and ``plots/*.png`` (for people)."""
from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import yaml

from . import locate
from .io import UNITS
from .model import vehicle_params
from .select import Diagnosis


def _r(x, n=6):
    if isinstance(x, dict):
        return {k: _r(v, n) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_r(v, n) for v in x]
    if isinstance(x, (np.floating, float)):
        return None if not np.isfinite(x) else float(f"{float(x):.{n}g}")
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.ndarray):
        return _r(x.tolist(), n)
    return x


def vehicle_block(D: Diagnosis) -> dict:
    """The fitted model as {vehicle, actuator?, inputs, ci95}."""
    P = D.final.P
    spec = D.final.spec
    kind = D.record.kind
    params = {n: float(P[n]) for n in vehicle_params(kind) if n in P}
    effects, actuator = [], {}
    added = {c.name for c, _, _ in D.added}
    for e in spec.effects:
        if e.label in added:
            continue
        ep = {k.split(".", 1)[1]: float(v) for k, v in P.items() if k.startswith(e.label + ".")}
        ep.update(e.fixed)
        ent = {"type": e.type, "params": ep}
        if e.corners != "all":
            ent["corners"] = list(e.corners)
        effects.append(ent)
    for cand, _, _ in D.added:
        d = cand.describe(P)
        if "effect" in d:
            ent = {"type": d["effect"]["type"], "params": {k: (v if isinstance(v, str) else float(v))
                                                          for k, v in d["effect"]["params"].items()}}
            if "corners" in d["effect"]:
                ent["corners"] = d["effect"]["corners"]
            effects.append(ent)
        elif "actuator" in d:
            actuator.update({k: float(v) for k, v in d["actuator"].items()})
    veh = {"model": kind, "params": params, "effects": effects}
    if kind != "damper":
        from .engine import levelled_with

        lw = levelled_with(kind, D.prob.level or D.nominal.P, P)
        if lw:  # a changed mass sags from the nominal ride height (the search does not re-level it)
            veh["levelled_with"] = lw
    out = {"vehicle": veh, "position_zero": spec.position_zero}
    if actuator:
        out["actuator"] = {"type": "ideal", "params": actuator}
    if D.prob.has_force:
        out["inputs"] = {"force_gain": float(P.get("input.gain", 1.0)), "force_offset": float(P.get("input.offset", 0.0))}
    if D.final.offsets is not None and np.any(D.final.offsets):
        out["channel_offsets"] = {c: float(o) for c, o, m in zip(D.prob.channels, D.final.offsets, D.prob.offset_mask) if m}
    if D.final.gains is not None:  # rule (h): the sensors read these multiples of what the model's channels are
        out["channel_gains"] = {c: float(g) for c, g in zip(D.prob.channels, D.final.gains)}
    if spec.position_zero == "own":  # the positions from the car's own equilibrium: a replay states their offsets
        out["position_zero"] = "measured"
        out.setdefault("channel_offsets", {}).update((D.own_equilibrium or {}).get("offsets", {}))
    out["ci95"] = {k: [float(a), float(b)] for k, (a, b) in D.final.ci95.items()}
    return out


def write_fitted_yaml(D: Diagnosis, path: Path) -> dict:
    blk = vehicle_block(D)
    lines = ["# Fitted by `suspension-sim diagnose` (output-error calibration + added effects).",
             "# `vehicle` is a scenario's vehicle block, ready to simulate; `actuator` (if present) goes into the",
             "# scenario's actuator block; `inputs` is the measured force input's gain/offset; `ci95` = 95 % intervals",
             "# of the fitted parameters (Gauss-Newton covariance, inflated for correlated residuals)."]
    path.write_text("\n".join(lines) + "\n" + yaml.safe_dump(_r(blk, 8), sort_keys=False))
    return blk


def write_mjcf(D: Diagnosis, path: Path) -> str | None:
    if D.record.kind == "damper":
        return "a damper element has no vehicle MJCF"
    try:
        from ..components import validate_params
        from ..registry import VEHICLES
        from ..vehicles.base import levelled_params

        blk = vehicle_block(D)
        vcls = VEHICLES.get(blk["vehicle"]["model"])
        vp = blk["vehicle"]["params"]
        lw = blk["vehicle"].get("levelled_with")
        root = vcls.build(validate_params(vcls.Params, vp, "vehicle.params"), dt=min(5e-4, D.record.dt),
                          level=levelled_params(vcls, vp, lw) if lw else None)
        path.write_text("<!-- fitted by suspension-sim diagnose: masses, springs and dampers of the fitted model; the\n"
                        "     added effects act through the effect_* motors (suspension_sim.effects), see model.fitted.yaml -->\n"
                        + root.to_xml_string())
        return None
    except Exception as err:  # the MJCF of some fits (e.g. a zero spring: no static equilibrium) cannot be built
        return f"{type(err).__name__}: {str(err).splitlines()[0]}"


def _road_delay(rf: np.ndarray, rr: np.ndarray, tol: float = 0.01) -> int | None:
    """Delay (samples, ≥ 1) by which ``rr`` is ``rf`` delayed, or None when it is not (relative RMS > tol)."""
    n = len(rf)
    if n < 4 or np.std(rr) == 0:
        return None
    a, b = rf - rf.mean(), rr - rr.mean()
    xc = np.fft.irfft(np.fft.rfft(b, 2 * n) * np.conj(np.fft.rfft(a, 2 * n)))[:n]
    k = int(np.argmax(xc))
    if k < 1 or k > n // 2:
        return None
    err = np.sqrt(np.mean((rr[k:] - rf[:-k]) ** 2)) / np.std(rr)
    return k if err <= tol else None


def mujoco_confirm(D: Diagnosis, out: Path, max_seconds: float = 120.0) -> dict:
    """Replay the fitted model through ``scenario.fitted.yaml`` (a plain scenario: a profile road and an
    open-loop force table) and compare with the search's simulation (the same physics: this checks the written
    scenario) and with the data."""
    import time

    from ..config import parse_scenario
    from ..simulation import Simulation

    rec = D.record
    if rec.kind not in ("quarter_car", "sdof", "half_car"):
        return {"status": "skipped", "reason": f"{rec.kind}: no replay scenario written for this model kind"}
    if rec.t[-1] > max_seconds:
        return {"status": "skipped", "reason": f"record longer than {max_seconds:g} s"}
    blk = vehicle_block(D)
    P = D.final.P
    dt_rec = rec.dt
    sub = max(1, int(np.ceil(dt_rec / 5e-4 - 1e-9)))
    dt = dt_rec / sub
    n = len(rec)
    road = D.prob.inputs.get("road", D.prob.inputs.get("road_front", D.prob.inputs.get("base", np.zeros(len(rec)))))
    d = out / "inputs"
    d.mkdir(exist_ok=True)
    # road: a profile driven at 1 m/s, so that distance = time
    speed = 1.0
    if rec.kind == "half_car":
        # the project's roads give the rear wheel the front road delayed by wheelbase/speed: replay only
        # when the measured rear road is (within 1 %) the front road delayed by a whole number of samples
        if D.prob.has_force:
            return {"status": "skipped", "reason": "half car with force inputs: per-corner force replay not "
                                                   "implemented"}
        rr = D.prob.inputs["road_rear"]
        k = _road_delay(road, rr)
        if k is None:
            return {"status": "skipped", "reason": "the rear road is not the front road delayed (a MuJoCo road "
                                                   "profile cannot reproduce independent front/rear inputs)"}
        speed = float(P["a"] + P["b"]) / (k * dt_rec)
    np.savetxt(d / "road.csv", np.column_stack([rec.t * speed, road]), delimiter=",", header="distance,height",
               comments="")
    sc = {"name": "diagnose_replay", "vehicle": blk["vehicle"],
          "road": {"type": "profile", "speed": speed,
                   "params": {"file": str((d / "road.csv").resolve()), "distance_column": "distance",
                              "height_column": "height", "detrend": "none", "fade_in": 0.0, "beyond_end": "hold"}},
          "actuator": blk.get("actuator", {"type": "ideal", "params": {}}),
          "controller": {"type": "passive"},
          "sim": {"duration": float(rec.t[-1]), "dt": dt, "control_dt": dt_rec, "log_dt": dt_rec},
          "outputs": {"timeseries": False, "plots": False}}
    if D.prob.has_force:
        if "input.delay" in P:
            return {"status": "skipped", "reason": "a fitted input delay: the ideal actuator's delay is whole physics "
                                                   "steps (the fitted YAML states it)"}
        cmd = P.get("input.gain", 1.0) * D.prob.inputs["force"] + P.get("input.offset", 0.0)
        np.savetxt(d / "force.csv", np.column_stack([rec.t, cmd]), delimiter=",", header="time,value", comments="")
        sc["controller"] = {"type": "open_loop", "params": {"signal": "table", "file": str((d / "force.csv").resolve()),
                                                            "time_column": "time", "column": "value"}}
    (out / "scenario.fitted.yaml").write_text(
        "# Replays the measured inputs through MuJoCo with the fitted model (written by diagnose).\n"
        + yaml.safe_dump(_r(sc, 10), sort_keys=False))
    try:
        t0 = time.perf_counter()
        res = Simulation([parse_scenario(_r(sc, 12))]).run()[0]
        wall = time.perf_counter() - t0
    except Exception as err:
        return {"status": "failed", "reason": f"{type(err).__name__}: {str(err).splitlines()[0]}"}
    ts = res.ts
    colmap = {"body_acc": "body_acc", "wheel_acc": "wheel_acc", "susp_travel": "travel", "body_pos": "body_z",
              "wheel_pos": "wheel_z", "tire_force": "tire_force", "pos": "body_z", "vel": "body_vel", "acc": "body_acc"}
    fast = D.final.simulated(D.prob)
    cmp = {}
    m = min(len(ts), n)
    if rec.kind == "half_car":
        ts = ts.copy()
        for e, xc in (("front", float(P["a"])), ("rear", -float(P["b"]))):
            ts[f"body_acc_{e}"] = ts["body_acc"] - xc * ts["pitch_acc"]
            ts[f"body_pos_{e}"] = ts["body_z"] - xc * ts["pitch"]
            for a_, b_ in (("susp_travel", "travel"), ("wheel_pos", "wheel_z"), ("wheel_acc", "wheel_acc"),
                           ("tire_force", "tire_force")):
                ts[f"{a_}_{e}"] = ts[f"{b_}_{e}"]
        colmap = {c: c for c in D.prob.channels}
    for i, c in enumerate(D.prob.channels):
        col = colmap.get(c)
        if col not in ts:
            continue
        mj = ts[col].to_numpy()[:m]
        ref = fast[:m, i]
        cmp[c] = {"nrmse_replay_vs_search": float(np.sqrt(np.mean((mj - ref) ** 2)) / max(np.std(ref), 1e-30)),
                  "nrmse_mujoco_vs_data": float(np.sqrt(np.mean((mj - D.prob.Y[:m, i]) ** 2)) / D.prob.scale[i])}
    return {"status": "ok", "wall_s": wall, "channels": cmp, "scenario": "scenario.fitted.yaml"}


def build_report(D: Diagnosis, out: Path, confirm: bool = True, plots: bool = True) -> dict:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_fitted_yaml(D, out / "model.fitted.yaml")
    mjcf_err = write_mjcf(D, out / "model.fitted.xml")
    before, after = D.nrmse(D.nominal), D.nrmse(D.final)
    rb, ra = D.rmse(D.nominal), D.rmse(D.final)
    effects = []
    for cand, fr, tr in D.added:
        names = [k for k in fr.params if k.startswith(cand.name + ".")]
        if cand.name.startswith("parameter:"):
            names = [cand.name.split(":", 1)[1]]
        elif not names:  # an actuator candidate: its declared parameter
            names = [n if isinstance(n, str) else n[0] for n in getattr(cand, "size_names", [])]
        params = {k.split(".", 1)[-1]: fr.params[k] for k in names}
        ci = {k.split(".", 1)[-1]: D.final.ci95.get(k) for k in names}
        desc = cand.describe(D.final.P)
        notes = {}
        if "effect" in desc:
            params.update({k: v if isinstance(v, str) else float(v) for k, v in desc["effect"]["params"].items()})
            notes = effect_notes(D, desc["effect"], ci)
        effects.append({"name": cand.name, "parameters": params, "ci95": ci, "notes": notes,
                        "evidence": {"round": tr.round, "delta_bic_train": tr.d_bic, "aic_train": tr.aic,
                                     "test_nrmse_before": tr.test_before, "test_nrmse_after": tr.test_after,
                                     "test_excess_over_floor_before": tr.excess_before,
                                     "test_excess_over_floor_after": tr.excess_after,
                                     "z_test_improvement": tr.z, "z_spectral": tr.z_spectral,
                                     "signature": cand.signature,
                                     "model_change": desc}})
    # locate on the nominal model
    s_nom, st_nom = D.sims(D.nominal)
    s_fin, st_fin = D.sims(D.final)
    resid_nom = s_nom - D.prob.Y
    resid_fin = s_fin - D.prob.Y
    loc_w = locate.windows(D.record.t, resid_nom, D.prob.channels, D.floors)
    loc_s = locate.spectra(resid_nom[D.train[0]:D.train[1]],
                           {k: v[D.train[0]:D.train[1]] for k, v in D.record.inputs.items()},
                           D.prob.channels, D.floors, D.record.fs)
    loc_s_after = locate.spectra(resid_fin[D.train[0]:D.train[1]], {}, D.prob.channels, D.floors, D.record.fs)
    fmap = locate.force_map(D.prob, D.nominal.P, D.floors, *D.train,
                            effects=[(e.label, e.type, e.corners, e.fixed) for e in D.nominal.spec.effects],
                            offsets=D.nominal.offsets, gains=D.nominal.gains)
    fmap_after = locate.force_map(D.prob, D.final.P, D.floors, *D.train,
                                  effects=[(e.label, e.type, e.corners, e.fixed) for e in D.final.spec.effects],
                                  offsets=D.final.offsets, gains=D.final.gains)
    conf = mujoco_confirm(D, out) if confirm else {"status": "skipped", "reason": "--no-confirm"}
    report = {
        "effects": effects,
        "nrmse": {"before": before, "after": after},
        "rmse": {"before": rb, "after": ra, "units": {c: UNITS.get(c, "") for c in D.prob.channels}},
        "noise_floor": {c: {"value": v["value"], "nrmse": v["nrmse"], "source": v["source"]} for c, v in D.floors.items()},
        "model_after": "model.fitted.yaml",
        "model_before": {"free": D.nominal.params, "ci95": D.nominal.ci95},
        "calibration": {"fitted": D.final.params, "ci95": D.final.ci95, "std": D.final.std},
        "split": {"train_samples": list(D.train), "test_samples": list(D.test),
                  "test_record": D.test_prob.rec.source if D.test_prob is not None else None,
                  # split.py: the held-out part moved to the record's start to hold its rare events
                  "by_events": bool(D.split and D.split["by_events"]),
                  **({"reason": D.split["reason"]} if D.split and D.split["by_events"] else {})},
        "candidates": [t.as_dict() for t in D.trials],
        "locate": {
            "windows": {"t_start": loc_w["t_start"], "flagged": loc_w["flagged"], "rms": loc_w["rms"]},
            "spectra": {c: {k: v for k, v in s.items() if k not in ("f", "psd")} for c, s in loc_s.items()},
            "force_map": None if fmap is None else {k: v for k, v in fmap.items() if k in ("note", "rms_residual_force", "noise_force", "max_abs_z")},
            "force_map_after": None if fmap_after is None else {k: v for k, v in fmap_after.items() if k in ("rms_residual_force", "max_abs_z")},
        },
        "mujoco_confirmation": conf,
        "mjcf": "model.fitted.xml" if mjcf_err is None else None,
        "mjcf_note": mjcf_err,
        "timings_s": D.timings,
        "record": {"source": D.record.source, "kind": D.record.kind, "samples": len(D.record), "fs_hz": D.record.fs,
                   "notes": D.record.notes, "inputs": list(D.record.inputs), "outputs": D.prob.channels},
        "verdict": verdict(D, effects, before, after),
        "unexplained_x_floor": D.unexplained,
        "sensor_zero": D.sensor_zero,
        "own_equilibrium": D.own_equilibrium,
        "sensor_gain": D.sensor_gain,
        "proposal": D.proposal,
        "not_separable": not_separable(D),
    }
    report = _r(report)
    (out / "report.json").write_text(json.dumps(report, indent=1))
    if plots:
        figs = make_plots(D, out, s_nom, s_fin, st_nom, st_fin, loc_s, loc_s_after, fmap, fmap_after, loc_w)
        write_html(D, report, figs, out / "report.html")
    return report


def effect_notes(D: Diagnosis, effect: dict, ci95: dict) -> dict:
    """The effect's own reading of its fitted values on this record (``fitted_notes(params, travel, ci95)``,
    e.g. a stop gap beyond the largest travel: "no extension stop"), with the fitted model's travel over the
    whole record at the effect's corners."""
    from ..registry import EFFECTS

    notes_of = getattr(EFFECTS.get(effect["type"]), "fitted_notes", None)
    if notes_of is None or D.record.kind in ("sdof", "damper"):
        return {}
    spec, P = D.final.spec, D.final.P
    eng = D.prob.engine(spec)
    out = eng.run([P], len(D.record), [(e.label, e.type, e.corners, e.fixed) for e in spec.effects])[0]
    corners = effect.get("corners")
    cols = [j for j, c in enumerate(eng.channels) if c.startswith("susp_travel")
            and (corners is None or any(c == f"susp_travel{k.suffix}" for k in eng.corners if k.name in corners))]
    if not cols:
        return {}
    return dict(notes_of(effect["params"], out[:, cols].ravel(), ci95))


def not_separable(D) -> list:
    """Candidates that passed every other test but would have replaced earlier fitted physics they cannot be
    told apart from on this record (:meth:`.select.Selector._replaced`): the pair is reported, not named."""
    from .select import NOT_SEPARABLE

    out = []
    named = {c.name for c, _, _ in D.added}
    for t in D.trials:
        # a candidate named in the end (in a later round, or by an exchange) is not reported as held back
        if NOT_SEPARABLE in t.reason and t.name.split(" in place of ")[0] not in named:
            for r in t.replaces:
                if r.get("blocking"):
                    out.append({"candidate": t.name, "round": t.round, "parameter": r["parameter"],
                                "before": r["before"], "after": r["after"], "correlation": r["correlation"],
                                "test_nrmse_before": t.test_before, "test_nrmse_after": t.test_after})
    return out


def gain_sentence(g: dict) -> str:
    """Rule (h)'s finding in words: the channels whose gain is off 1 by more than 2 standard errors and by more
    than the channel's noise floor (NRMSE: a gain error smaller than that changes the channel by less than its
    noise, gate (e)'s measure), as sensors reading high or low, relative to the measured inputs' scale (a gain
    common to every output channel is the same as the road or force input reading off by its reciprocal)."""
    fl = g.get("floor_nrmse", {})
    off = [(c, v) for c, v in g["gains"].items() if abs(v - 1.0) > max(2.0 * g["std"][c], fl.get(c, 0.0))]
    said = ", ".join(f"{c} reads {100 * abs(v - 1):.1f} % {'high' if v > 1 else 'low'} (gain {v:.4f} ± "
                     f"{g['std'][c]:.4f})" for c, v in off) or "no channel's gain is off 1 beyond 2 standard errors"
    why = ("explained the record better than " + ", ".join(b["candidate"] for b in g["beats"]) + " by training BIC"
           if g["beats"] else f"lowered the held-out error beyond the noise where no effect did "
                              f"({g['test_before']:.4g} → {g['test_after']:.4g})")
    return (f"Sensor gains: {said}, relative to the measured inputs (a free gain on every output channel {why}; "
            f"the gains are now fitted).")


def verdict(D, effects, before, after) -> str:
    tail = (f" Unexplained: {D.unexplained:.1f}× the noise floor (the library cannot explain the rest)."
            if D.unexplained else "")
    pairs = sorted({(r["candidate"], r["parameter"]) for r in not_separable(D)})
    if D.sensor_zero:  # rule (g) of the selection: the honest finding, not an effect
        z = D.sensor_zero
        tail += (" The position sensors' zero differs from the nominal ride height: "
                 + ", ".join(f"{c} reads {1e3 * o:+.2f} mm there" for c, o in z["offsets"].items())
                 + " (a free sensor offset explained the record better than "
                 + ", ".join(b["candidate"] for b in z["beats"]) + " by training BIC; the offsets are now fitted).")
    if D.sensor_gain:  # rule (h) of the selection: a sensor finding, not a vehicle parameter
        tail += " " + gain_sentence(D.sensor_gain)
    if D.own_equilibrium:  # rule (g)'s joint explanation: a sag-moving parameter beside free position offsets
        tail += (" The positions appear measured from the car's own equilibrium (offsets "
                 + ", ".join(f"{c} {1e3 * o:+.2f} mm" for c, o in D.own_equilibrium["offsets"].items())
                 + ": the changed mass's sag is not in the record; the offsets are now fitted).")
    if pairs:
        tail += " Not separable on this record: " + ", ".join(f"{c} vs the fitted {p}" for c, p in pairs) + \
                " (either explains the data; the earlier physics is kept)."
    if not effects:
        if D.unexplained:
            return "No candidate effect lowers the held-out error beyond the noise: nothing is named." + tail
        return ("No candidate effect lowers the held-out error beyond the noise: nothing is named. "
                "The calibrated nominal model" + (" (with the position sensors' zero fitted)" if D.sensor_zero else "")
                + (" (with the sensors' gains fitted)" if D.sensor_gain else "")
                + " is as good as any in the library on this record." + tail)
    names = ", ".join(e["name"] + (f" ({'; '.join(e['notes'].values())})" if e.get("notes") else "")
                      for e in effects)
    tb = np.sqrt(np.mean(np.square(list(before["test"].values()))))
    ta = np.sqrt(np.mean(np.square(list(after["test"].values()))))
    return (f"Missing: {names}. Held-out NRMSE {tb:.4g} → {ta:.4g} "
            f"({100 * (1 - ta / max(tb, 1e-30)):.1f} % lower).{tail}")


# ----------------------------------------------------------------------------------------------------------
def make_plots(D, out, s_nom, s_fin, st_nom, st_fin, loc_s, loc_s_after, fmap, fmap_after, loc_w) -> list[tuple[str, str]]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    pd_ = out / "plots"
    pd_.mkdir(exist_ok=True)
    figs = []
    chans = D.prob.channels
    tp = D.test_prob or D.prob
    a, b = D.test
    a = max(a, tp.skip)
    # overlay on a stretch of held-out data
    span = min(b - a, int(5 * tp.rec.fs))
    sl = slice(a, a + span)
    fig, axs = plt.subplots(len(chans), 1, figsize=(10, 2.6 * len(chans)), squeeze=False, sharex=True)
    for i, c in enumerate(chans):
        ax = axs[i, 0]
        tt = tp.rec.t[sl]
        ax.plot(tt, tp.Y[sl, i], "k", lw=1.2, label="measured")
        ax.plot(tt, st_nom[sl, i], "C3", lw=0.9, label="nominal (calibrated)")
        ax.plot(tt, st_fin[sl, i], "C0", lw=0.9, ls="--", label="fitted model")
        ax.set_ylabel(f"{c} [{UNITS.get(c, '')}]")
    axs[0, 0].legend(loc="upper right", fontsize=8)
    axs[-1, 0].set_xlabel("time [s] (held-out data)")
    fig.tight_layout()
    fig.savefig(pd_ / "overlay_test.png", dpi=90)
    plt.close(fig)
    figs.append(("plots/overlay_test.png", "Held-out data: measured, calibrated nominal model, fitted model"))
    # residual over time windows
    fig, ax = plt.subplots(figsize=(10, 3))
    for i, c in enumerate(chans):
        r = np.array(loc_w["rms"][c]) / max(D.floors[c]["value"], 1e-30)
        ax.step(loc_w["t_start"], r, where="post", label=c)
    ax.axhline(3, color="k", ls=":", label="3 × noise floor")
    cut, lab = (D.train[1], "train | test") if D.train[0] == 0 else (D.train[0], "test | train")
    ax.axvline(D.record.t[min(cut, len(D.record) - 1)], color="gray", ls="--", label=lab)
    ax.set_yscale("log")
    ax.set_ylabel("residual RMS / noise floor")
    ax.set_xlabel("time [s]")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(pd_ / "residual_windows.png", dpi=90)
    plt.close(fig)
    figs.append(("plots/residual_windows.png", "Nominal model: residual RMS per time window against the noise floor"))
    # PSDs
    fig, axs = plt.subplots(1, len(chans), figsize=(5 * len(chans), 3.4), squeeze=False)
    for i, c in enumerate(chans):
        ax = axs[0, i]
        s0, s1 = loc_s[c], loc_s_after[c]
        ax.loglog(s0["f"][1:], s0["psd"][1:], "C3", label="residual, nominal")
        ax.loglog(s1["f"][1:], s1["psd"][1:], "C0", label="residual, fitted")
        if s0["floor_psd"] > 0:
            ax.axhline(s0["floor_psd"], color="k", ls=":", label="noise floor")
        ax.set_title(c)
        ax.set_xlabel("frequency [Hz]")
    axs[0, 0].set_ylabel("PSD")
    axs[0, 0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(pd_ / "residual_psd.png", dpi=90)
    plt.close(fig)
    figs.append(("plots/residual_psd.png", "Residual PSD (training data) before and after, against the noise floor"))
    # force maps
    if fmap is not None:
        fig, axs = plt.subplots(1, 3, figsize=(15, 4))
        for ax, fm, title in ((axs[0], fmap, "nominal"), (axs[1], fmap_after, "fitted")):
            im = ax.pcolormesh(fm["v_edges"], fm["s_edges"], fm["mean"], cmap="RdBu_r", shading="flat",
                               vmin=-np.nanmax(np.abs(fmap["mean"])), vmax=np.nanmax(np.abs(fmap["mean"])))
            ax.set_xlabel("travel rate [m/s]")
            ax.set_ylabel("travel [m]")
            ax.set_title(f"residual force, {title} model")
            fig.colorbar(im, ax=ax, label="N (bin mean)")
        ax = axs[2]
        ax.plot(fmap["profile_v"]["x"], fmap["profile_v"]["mean"], "C3.-", label="nominal")
        ax.plot(fmap_after["profile_v"]["x"], fmap_after["profile_v"]["mean"], "C0.-", label="fitted")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xlabel("travel rate [m/s]")
        ax.set_ylabel("mean residual force [N]")
        ax.legend(fontsize=8)
        fig.suptitle(fmap["note"], fontsize=9)
        fig.tight_layout()
        fig.savefig(pd_ / "residual_force_map.png", dpi=90)
        plt.close(fig)
        figs.append(("plots/residual_force_map.png", "Residual force over travel × travel rate (inverse dynamics)"))
    return figs


def write_html(D, rep: dict, figs, path: Path) -> None:
    e = html.escape
    rows = []
    for split in ("train", "test"):
        for c in D.prob.channels:
            b = rep["nrmse"]["before"][split].get(c)
            a = rep["nrmse"]["after"][split].get(c)
            sh = 100 * (1 - a / b) if b else float("nan")
            rows.append(f"<tr><td>{split}</td><td>{e(c)}</td><td>{b:.4g}</td><td>{a:.4g}</td><td>{sh:.1f} %</td>"
                        f"<td>{rep['noise_floor'][c]['nrmse']:.3g}</td></tr>")
    eff_rows = []
    for ef in rep["effects"]:
        ps = "<br>".join(f"{e(k)} = {v if isinstance(v, str) else format(v, '.5g')}"
                         + (f" [{ef['ci95'][k][0]:.4g}, {ef['ci95'][k][1]:.4g}]" if ef["ci95"].get(k) else "")
                         for k, v in ef["parameters"].items())
        ps += "".join(f"<br><i>{e(n)}</i>" for n in (ef.get("notes") or {}).values())
        ev = ef["evidence"]
        eff_rows.append(f"<tr><td><b>{e(ef['name'])}</b></td><td>{ps}</td><td>{ev['delta_bic_train']:.1f}</td>"
                        f"<td>{ev['test_nrmse_before']:.4g} → {ev['test_nrmse_after']:.4g}</td><td>{ev['z_test_improvement']:.1f}</td>"
                        f"<td>{e(ev['signature'])}</td></tr>")
    cand_rows = []
    for t in rep["candidates"]:
        if not t["applicable"]:
            cand_rows.append(f"<tr><td>{t['round']}</td><td>{e(t['name'])}</td><td colspan=5>not tried: {e(t['reason'])}</td></tr>")
            continue
        f = lambda v, fmt: "–" if v is None else format(v, fmt)  # noqa: E731
        cand_rows.append(f"<tr><td>{t['round']}</td><td>{e(t['name'])}</td><td>{f(t['d_bic'], '.1f')}</td>"
                         f"<td>{f(t['test_before'], '.4g')} → {f(t['test_after'], '.4g')}</td><td>{f(t['z'], '.1f')}</td>"
                         f"<td>{f(t['excess_before'], '.3g')} → {f(t['excess_after'], '.3g')}</td>"
                         f"<td>{'<b>kept</b>' if t['kept'] else ''}</td></tr>")
    loc = rep["locate"]
    spec_lines = []
    for c, s in loc["spectra"].items():
        band = s["band_above_floor_hz"]
        coh = ", ".join(f"{k}: max {v['max']:.2f} at {v['at_hz']:.1f} Hz" for k, v in s["coherence"].items())
        spec_lines.append(f"<li><b>{e(c)}</b>: residual above the noise floor (+10 dB) "
                          f"{'between %.2f and %.1f Hz' % tuple(band) if band else 'nowhere'}; peak at {s['peak_hz']:.2f} Hz; "
                          f"coherence with inputs: {e(coh) or '–'}</li>")
    nflag = sum(loc["windows"]["flagged"])
    fm = loc["force_map"]
    fm_line = (f"<p>Residual force map ({e(fm['note'])}): RMS {fm['rms_residual_force']:.4g} N, largest |bin mean| / "
               f"standard error = {fm['max_abs_z']:.1f} (after: {loc['force_map_after']['max_abs_z']:.1f}).</p>"
               if fm else "<p>No residual force map (needs a measured acceleration and travel).</p>")
    conf = rep["mujoco_confirmation"]
    conf_line = (("<p>Replay of scenario.fitted.yaml (the fitted model with the measured inputs): " + ", ".join(
        f"{e(c)}: NRMSE replay vs search {v['nrmse_replay_vs_search']:.3g}, vs data {v['nrmse_mujoco_vs_data']:.3g}"
        for c, v in conf["channels"].items()) + "</p>") if conf.get("status") == "ok"
        else f"<p>MuJoCo re-simulation: {e(conf.get('status', ''))} ({e(str(conf.get('reason', '')))})</p>")
    imgs = "".join(f"<figure><img src='{e(p)}' style='max-width:100%'><figcaption>{e(c)}</figcaption></figure>"
                   for p, c in figs)
    cal = "".join(f"<tr><td>{e(k)}</td><td>{v:.6g}</td><td>[{rep['calibration']['ci95'][k][0]:.5g}, "
                  f"{rep['calibration']['ci95'][k][1]:.5g}]</td></tr>" for k, v in rep["calibration"]["fitted"].items())
    doc = f"""<!doctype html><html><head><meta charset='utf-8'><title>diagnose report</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}} table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:3px 8px;font-size:90%}} .v{{font-size:120%;background:#eef;padding:8px}}</style>
</head><body><h1>Discrepancy report</h1>
<p>Record: {e(rep['record']['source'])} ({e(rep['record']['kind'])}, {rep['record']['samples']} samples at
{rep['record']['fs_hz']:.6g} Hz; inputs {e(', '.join(rep['record']['inputs']))}; outputs {e(', '.join(rep['record']['outputs']))}).
{e('; '.join(rep['record']['notes']))}</p>
<p class='v'>{e(rep['verdict'])}</p>
<h2>1. Calibration</h2><p>Output-error fit on training samples {rep['split']['train_samples']};
held-out: {('samples ' + str(rep['split']['test_samples'])) if not rep['split']['test_record'] else e(rep['split']['test_record'])}.</p>
<table><tr><th>parameter (final model)</th><th>value</th><th>95 % interval</th></tr>{cal}</table>
<h2>2. Where the nominal model fails</h2>
<p>{nflag} of {len(loc['windows']['flagged'])} time windows have a residual above 3× the noise floor.</p>
<ul>{''.join(spec_lines)}</ul>{fm_line}
<h2>3. Missing effects</h2>
<table><tr><th>effect</th><th>parameters [95 % interval]</th><th>ΔBIC (train)</th><th>held-out NRMSE</th><th>z</th><th>signature</th></tr>
{''.join(eff_rows) or '<tr><td colspan=6>none named</td></tr>'}</table>
<h3>All candidates</h3>
<table><tr><th>round</th><th>candidate</th><th>ΔBIC (train)</th><th>held-out NRMSE</th><th>z</th><th>excess over floor</th><th></th></tr>
{''.join(cand_rows)}</table>
<h2>4. Corrected model</h2><p><a href='model.fitted.yaml'>model.fitted.yaml</a>
{"· <a href='model.fitted.xml'>model.fitted.xml</a>" if rep['mjcf'] else '(no MJCF: ' + e(str(rep['mjcf_note'])) + ')'}</p>{conf_line}
<h2>5. The gap, before and after (NRMSE = RMS error / std of the measured channel)</h2>
<table><tr><th>data</th><th>channel</th><th>before</th><th>after</th><th>shrink</th><th>noise floor</th></tr>{''.join(rows)}</table>
{imgs}
</body></html>"""
    path.write_text(doc)
