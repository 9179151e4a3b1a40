"""Shareable HTML reports: one run (``report.html`` in its run folder) or several runs overlaid (``compare``).

A run report holds the scenario summary, the metrics table, the run's plots (``plots/*.png`` embedded as base64,
or overlay plots drawn here when the folder has none) and the recorded 3D view (``viewer.html`` beside it,
embedded in an iframe and linked).  A comparison report puts the runs' metrics side by side, overlays their
time series in common plots, and shows the cars side by side in one 3D view.  Every page is a single file
that opens offline (the comparison's 3D view is its own ``viewer.html`` next to ``report.html``).
"""
from __future__ import annotations

import base64
import html
import io
import json
import math
import os
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

KEY_METRICS = ["body_acc_rms", "body_acc_wk_rms", "body_acc_vdv", "travel_rms", "travel_peak", "tire_load_rms_rel",
               "liftoff", "actuator_force_rms", "actuator_power_mean", "pitch_peak", "roll_peak"]


def load_run(run_dir) -> "object":
    """A :class:`~suspension_sim.results.Result` read back from a run folder (``timeseries.parquet``,
    ``summary.json``, ``scenario.resolved.yaml``).  The scenario is validated when possible, else kept as a
    plain dict."""
    import pandas as pd

    from .errors import ScenarioError
    from .results import Result

    d = Path(run_dir)
    subs = sorted(p.parent.name for p in d.glob("*/timeseries.parquet")) if d.is_dir() else []
    if subs and not (d / "timeseries.parquet").exists():
        raise ScenarioError(f"a run folder with variants: give one of its variant folders ({', '.join(subs)})",
                            source=str(d))
    if not (d / "summary.json").exists():
        raise ScenarioError("not a run folder (no summary.json)", source=str(d))
    try:
        summary = json.loads((d / "summary.json").read_text(encoding="utf-8"))
    except (ValueError, UnicodeDecodeError) as err:
        raise ScenarioError(f"summary.json is not readable JSON ({str(err).splitlines()[0][:120]})",
                            source=str(d)) from None
    if not isinstance(summary, dict):
        raise ScenarioError("summary.json is not a run summary", source=str(d))
    ts_path = d / "timeseries.parquet"
    if not ts_path.exists():
        raise ScenarioError("the run folder has no timeseries.parquet (outputs.timeseries was off)", source=str(d))
    try:
        ts = pd.read_parquet(ts_path)
    except Exception as err:  # noqa: BLE001 - pyarrow's messages vary
        raise ScenarioError(f"cannot read timeseries.parquet ({str(err).splitlines()[0][:120]})",
                            source=str(d)) from None
    raw = {}
    if (d / "scenario.resolved.yaml").exists():
        from .safeyaml import load_file

        raw = load_file(d / "scenario.resolved.yaml", "resolved scenario") or {}
    scenario = raw
    try:
        from .config import parse_scenario

        scenario = parse_scenario(raw, source=str(d / "scenario.resolved.yaml"))
    except Exception:
        pass
    return Result(scenario=scenario, timeseries=ts, info=summary.get("info", {}), metrics=summary.get("metrics", {}))


def _name(result) -> str:
    sc = result.scenario
    return str(getattr(sc, "name", None) or (sc.get("name") if isinstance(sc, dict) else None) or "run")


def _get(sc, path: str, default=None):
    cur = sc
    for k in path.split("."):
        if cur is None:
            return default
        cur = getattr(cur, k, None) if not isinstance(cur, dict) else cur.get(k)
    return default if cur is None else cur


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90, bbox_inches="tight")
    import matplotlib.pyplot as plt

    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode("ascii")


def overlay_plots(results: Mapping[str, object]) -> list[tuple[str, str]]:
    """(title, base64 PNG) plots overlaying the runs: body acceleration, pitch/roll, and per corner travel,
    tire force and actuator force."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = next(iter(results.values()))
    sfx = list(first.info.get("suffixes", [""]))
    groups = [("body acceleration (m/s²)", ["body_acc"]), ("pitch / roll (rad)", ["pitch", "roll"])]
    groups += [(f"{what} {s.lstrip('_') or ''}".strip(), [f"{col}{s}"])
               for what, col in (("suspension travel (m)", "travel"), ("dynamic tire force (N)", "tire_force"),
                                 ("actuator force (N)", "actuator_force"))
               for s in sfx]
    out = []
    for title, cols in groups:
        present = [(lab, r, c) for lab, r in results.items() for c in cols if c in r.timeseries]
        if not present:
            continue
        if all(np.allclose(r.timeseries[c].to_numpy(), 0.0) for _, r, c in present):
            continue
        fig, ax = plt.subplots(figsize=(8.5, 2.6))
        for lab, r, c in present:
            ts = r.timeseries
            ax.plot(ts["t"], ts[c], lw=0.9, label=f"{lab}" + (f" {c}" if len(cols) > 1 else ""))
        ax.set_xlabel("t (s)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        if len(present) > 1:
            ax.legend(fontsize=8, loc="upper right")
        out.append((title, _png(fig)))
    return out


def _fmt(v) -> str:
    try:
        v = float(v)
    except (TypeError, ValueError):
        return html.escape(str(v))
    if not math.isfinite(v):
        return "–"
    return f"{v:.4g}"


def _rel(v, ref) -> str:
    """Change against the reference (first) run, in percent."""
    try:
        v, ref = float(v), float(ref)
    except (TypeError, ValueError):
        return ""
    if not (math.isfinite(v) and math.isfinite(ref)) or ref == 0:
        return ""
    return f" <span class='rel'>({100 * (v - ref) / abs(ref):+.0f}%)</span>"


def _metric_order(names) -> list[str]:
    names = list(dict.fromkeys(names))
    key = [n for n in names if any(n.startswith(k) for k in KEY_METRICS)]
    return key + sorted(n for n in names if n not in key)


def metrics_table(results: Mapping[str, object]) -> str:
    labels = list(results)
    names = _metric_order(n for r in results.values() for n in r.metrics)
    head = "".join(f"<th>{html.escape(l)}</th>" for l in labels)
    rows = []
    for n in names:
        vals = [r.metrics.get(n) for r in results.values()]
        cells = "".join(f"<td>{_fmt(v)}{_rel(v, vals[0]) if k else ''}</td>" for k, v in enumerate(vals))
        rows.append(f"<tr><td class='m'>{html.escape(n)}</td>{cells}</tr>")
    return f"<table class='metrics'><tr><th>metric</th>{head}</tr>{''.join(rows)}</table>"


def _summary_rows(result) -> str:
    sc = result.scenario
    info = result.info
    items = [("model", info.get("model") or _get(sc, "vehicle.model")),
             ("road", f"{_get(sc, 'road.type')} {json.dumps(_get(sc, 'road.params', {}) or {})}"),
             ("speed", _get(sc, "road.speed")),
             ("controller", f"{_get(sc, 'controller.type')} {json.dumps(_get(sc, 'controller.params', {}) or {})}"),
             ("actuator", _get(sc, "actuator.type")),
             ("effects", ", ".join(e.get("type") if isinstance(e, dict) else e.type
                                  for e in (_get(sc, "vehicle.effects", []) or [])) or "none"),
             ("duration", f"{_get(sc, 'sim.duration')} s (dt {_get(sc, 'sim.dt')} s)"),
             ("full-state access", info.get("full_state_access")),
             ("versions", ", ".join(f"{k} {v}" for k, v in (info.get("versions") or {}).items()))]
    return "".join(f"<tr><td class='m'>{html.escape(k)}</td><td>{html.escape(str(v))}</td></tr>" for k, v in items)


_STYLE = """
body { font-family: sans-serif; margin: 18px 26px; color: #222; }
h1 { font-size: 22px; } h2 { font-size: 17px; margin-top: 26px; border-bottom: 1px solid #ccc; }
table { border-collapse: collapse; font-size: 13px; }
td, th { border: 1px solid #ddd; padding: 3px 8px; text-align: right; }
td.m, th:first-child { text-align: left; font-family: monospace; }
.plots img { max-width: 100%; display: block; margin: 6px 0; }
iframe.viewer { width: 100%; height: 560px; border: 1px solid #bbb; }
.note { color: #666; font-size: 12px; }
.rel { color: #777; font-size: 11px; }
"""


def _page(title: str, body: str) -> str:
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            f"<style>{_STYLE}</style></head><body>{body}</body></html>")


def _viewer_block(rel: str | None, note: str = "") -> str:
    if not rel:
        return "<p class='note'>no 3D view</p>"
    return (f"<h2>3D view</h2><p class='note'>Recorded animation: play, pause, scrub, change the camera. "
            f"<a href='{html.escape(rel)}'>open it full-window</a>. {note}</p>"
            f"<iframe class='viewer' id='viewer' src='{html.escape(rel)}'></iframe>")


def write_report(run_dir, result=None, out: str | os.PathLike | None = None, viewer: bool = True) -> Path:
    """Write ``report.html`` for a run folder (``result``: the in-memory Result, else it is read back).
    Creates ``viewer.html`` beside it when missing (``viewer=False``: no 3D view)."""
    d = Path(run_dir)
    result = result if result is not None else load_run(d)
    out = Path(out) if out is not None else d / "report.html"
    name = _name(result)
    vrel = None
    if viewer:
        vpath = d / "viewer.html"
        if not vpath.exists():
            from .viewer import write_viewer

            write_viewer(result, vpath)
        vrel = os.path.relpath(vpath, out.parent)
    pngs = sorted((d / "plots").glob("*.png")) if (d / "plots").is_dir() else []
    if pngs:
        plots = "".join(f"<img alt='{html.escape(p.stem)}' src='data:image/png;base64,"
                        f"{base64.b64encode(p.read_bytes()).decode('ascii')}'>" for p in pngs)
    else:
        plots = "".join(f"<img alt='{html.escape(t)}' src='data:image/png;base64,{b}'>"
                        for t, b in overlay_plots({name: result}))
    body = (f"<h1>{html.escape(name)}</h1>"
            f"<p class='note'>{html.escape(str(_get(result.scenario, 'description', '') or ''))}</p>"
            f"<table>{_summary_rows(result)}</table>"
            + _viewer_block(vrel)
            + f"<h2>metrics</h2>{metrics_table({name: result})}"
            + f"<h2>plots</h2><div class='plots'>{plots}</div>")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(_page(f"{name} — report", body), encoding="utf-8")
    return out


def write_compare(run_dirs: Sequence, out_dir, labels: Sequence[str] | None = None, viewer: bool = True) -> Path:
    """Overlay several runs (e.g. passive against a controller) in ``out_dir/report.html`` (with a side-by-side
    3D view in ``out_dir/viewer.html``)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    results: dict = {}
    for i, rd in enumerate(run_dirs):
        r = load_run(rd)
        lab = labels[i] if labels and i < len(labels) else _name(r)
        base, k = lab, 2
        while lab in results:
            lab, k = f"{base} ({k})", k + 1
        results[lab] = r
    models = {r.info.get("model") for r in results.values()}
    vrel = None
    note = ""
    if viewer:
        from .viewer import write_compare_viewer

        write_compare_viewer(results, out_dir / "viewer.html")
        vrel = "viewer.html"
        note = "Cars side by side, from left to right on screen: " + ", ".join(html.escape(l) for l in results) + "."
    links = "".join(
        f"<li>{html.escape(lab)}: <code>{html.escape(str(rd))}</code>"
        + (f" (<a href='{html.escape(os.path.relpath(Path(rd) / 'report.html', out_dir))}'>report</a>)"
           if (Path(rd) / "report.html").exists() else "") + "</li>"
        for lab, rd in zip(results, run_dirs))
    plots = "".join(f"<img alt='{html.escape(t)}' src='data:image/png;base64,{b}'>"
                    for t, b in overlay_plots(results))
    warn = (f"<p class='note'>note: the runs use different models ({', '.join(sorted(map(str, models)))})</p>"
            if len(models) > 1 else "")
    body = (f"<h1>comparison of {len(results)} runs</h1>{warn}<ul>{links}</ul>"
            + _viewer_block(vrel, note)
            + f"<h2>metrics</h2><p class='note'>in brackets: change against the first run, "
              f"{html.escape(next(iter(results)))}</p>{metrics_table(results)}"
            + f"<h2>overlaid time series</h2><div class='plots'>{plots}</div>")
    out = out_dir / "report.html"
    out.write_text(_page("comparison report", body), encoding="utf-8")
    return out
