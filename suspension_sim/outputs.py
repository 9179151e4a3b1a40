"""Writing a run's files: the run folder of one result (:func:`write_result`).

``timeseries.parquet`` (one column per channel, SI units), ``summary.json`` (metrics and info),
``scenario.resolved.yaml`` (the full scenario, to rerun), ``plots/*.png``, and ``viewer.html`` /
``report.html`` when the scenario's outputs ask for them.
"""
from __future__ import annotations

import json
from pathlib import Path


TIMING_KEYS = ("wall_time_s",)  # Result.info entries that vary from run to run (written to timing.json)


def resolved_yaml(resolved: dict, info: dict) -> str:
    """The resolved scenario as YAML, with ``sim.integrator`` the integrator the run used: ``auto`` is written
    as its choice, with the reason as a comment (``integrator: trapezoidal  # auto: ...``), so that a rerun of
    the file uses the same scheme."""
    import yaml

    used, why = info.get("integrator"), info.get("integrator_reason") or ""
    if used and resolved.get("sim", {}).get("integrator") == "auto":
        resolved["sim"]["integrator"] = used
    text = yaml.safe_dump(resolved, sort_keys=False)
    if used and why:
        line = f"  integrator: {used}\n"
        k = text.find(line, text.find("\nsim:\n"))
        if k >= 0:
            text = text[:k] + f"  integrator: {used}  # {why.replace(chr(10), ' ')}\n" + text[k + len(line):]
    return text


def write_result(result, out: Path, plots: bool = True, timeseries: bool = True) -> Path:
    """Write ``timeseries.parquet``, ``summary.json``, ``scenario.resolved.yaml`` and ``plots/*.png`` (and
    ``viewer.html`` / ``report.html`` when the scenario's ``outputs.viewer`` / ``outputs.report`` are set)."""
    import yaml

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    if timeseries:
        src = getattr(result, "timeseries_file", None)
        if src is not None:  # a streamed (long) run: its file was written chunk by chunk during the run
            import shutil

            src = Path(src)
            dst = out / "timeseries.parquet"
            if src.resolve() != dst.resolve():
                if src.name == "timeseries.parquet":  # another run folder's file: copied
                    shutil.copyfile(src, dst)
                else:  # the run's own spool file: moved (a rename on the same disk)
                    shutil.move(str(src), str(dst))
                    result.__dict__["_file"] = dst
        else:
            tmp = out / ".timeseries.parquet.tmp"
            result.timeseries.to_parquet(tmp, index=False)
            tmp.replace(out / "timeseries.parquet")
    resolved = result.scenario.resolved_dict()
    resolved.pop("variants", None)
    resolved["sim"]["seed"] = result.scenario.sim.seed
    header = (f"# resolved by suspension_sim {result.info['versions'].get('suspension_sim')} "
              f"(mujoco {result.info['versions'].get('mujoco')}); rerun with: suspension-sim run {out / 'scenario.resolved.yaml'}\n")
    (out / "scenario.resolved.yaml").write_text(header + resolved_yaml(resolved, result.info))
    from .outdir import write_atomic

    # summary.json is a function of the scenario and its seed (byte-identical when rerun); wall-clock times go
    # to timing.json
    info = dict(result.info)
    timing = {k: info.pop(k) for k in TIMING_KEYS if k in info}
    summary = {"name": result.scenario.name, "metrics": result.metrics, "info": info}
    write_atomic(out / "summary.json", json.dumps(summary, indent=2, default=float))
    write_atomic(out / "timing.json", json.dumps(timing, indent=2, default=float))
    if plots:
        from .plots import plot_run

        plot_run({result.scenario.name: result}, out / "plots")
    outputs = getattr(result.scenario, "outputs", None)
    if getattr(outputs, "viewer", False):  # self-contained 3D view (suspension_sim.viewer)
        from .results import previewed
        from .viewer import write_viewer

        write_viewer(previewed(result), out / "viewer.html")
    if getattr(outputs, "report", False):  # metrics, plots and the 3D view in one page (suspension_sim.report)
        from .report import write_report

        from .results import previewed

        write_report(out, result=previewed(result))
    return out
