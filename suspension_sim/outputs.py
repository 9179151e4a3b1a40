"""Writing a run's files: the run folder of one result (:func:`write_result`).

``timeseries.parquet`` (one column per channel, SI units), ``summary.json`` (metrics and info),
``scenario.resolved.yaml`` (the full scenario, to rerun), ``plots/*.png``, and ``viewer.html`` /
``report.html`` when the scenario's outputs ask for them.
"""
from __future__ import annotations

import json
from pathlib import Path


def write_result(result, out: Path, plots: bool = True, timeseries: bool = True) -> Path:
    """Write ``timeseries.parquet``, ``summary.json``, ``scenario.resolved.yaml`` and ``plots/*.png`` (and
    ``viewer.html`` / ``report.html`` when the scenario's ``outputs.viewer`` / ``outputs.report`` are set)."""
    import yaml

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if timeseries:
        result.timeseries.to_parquet(out / "timeseries.parquet", index=False)
    resolved = result.scenario.resolved_dict()
    resolved.pop("variants", None)
    resolved["sim"]["seed"] = result.scenario.sim.seed
    header = (f"# resolved by suspension_sim {result.info['versions'].get('suspension_sim')} "
              f"(mujoco {result.info['versions'].get('mujoco')}); rerun with: suspension-sim run {out / 'scenario.resolved.yaml'}\n")
    (out / "scenario.resolved.yaml").write_text(header + yaml.safe_dump(resolved, sort_keys=False))
    summary = {"name": result.scenario.name, "metrics": result.metrics, "info": result.info}
    (out / "summary.json").write_text(json.dumps(summary, indent=2, default=float))
    if plots:
        from .plots import plot_run

        plot_run({result.scenario.name: result}, out / "plots")
    outputs = getattr(result.scenario, "outputs", None)
    if getattr(outputs, "viewer", False):  # self-contained 3D view (suspension_sim.viewer)
        from .viewer import write_viewer

        write_viewer(result, out / "viewer.html")
    if getattr(outputs, "report", False):  # metrics, plots and the 3D view in one page (suspension_sim.report)
        from .report import write_report

        write_report(out, result=result)
    return out
