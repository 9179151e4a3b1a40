"""The ``suspension-sim`` command line.

``run SCENARIO [--out DIR] [--set path.to.key=value ...]``, ``validate SCENARIO``, ``list``; further
commands (batch, view, compare, diagnose) are modules in :mod:`suspension_sim.commands`, each with a
``register(app)`` function.  A user mistake prints one line (``error: <file>: <field>: <problem>``) and
exits with status 2; a diverging simulation prints the time, the state and a hint and exits with 3.
"""
from __future__ import annotations

import importlib
import pkgutil
import sys
from datetime import datetime
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.table import Table

from .errors import ScenarioError, SimulationDiverged

app = typer.Typer(add_completion=False, no_args_is_help=True, pretty_exceptions_enable=False,
                  help="Active-suspension testbed on MuJoCo: run scenarios, sweep variants, diagnose models.")
console = Console()
err_console = Console(stderr=True)


def fail(msg: str, code: int = 2):
    """Print ``error: <msg>`` on one line, the message literally (no rich markup: ``[batch]`` stays), and exit."""
    from rich.text import Text

    one_line = " ".join(str(msg).split("\n"))
    err_console.print(Text.assemble(("error:", "bold red"), " ", one_line), highlight=False, soft_wrap=True)
    raise typer.Exit(code)


def guarded(fn):
    """Run ``fn`` turning user mistakes and divergence into one-line errors (never a traceback: an
    unexpected exception is reported in one line too, exit status 1)."""
    from .lifecycle import install_signal_handlers

    install_signal_handlers()
    try:
        return fn()
    except ScenarioError as e:
        fail(str(e), 2)
    except SimulationDiverged as e:
        fail(str(e), 3)
    except (typer.Exit, typer.Abort, KeyboardInterrupt, SystemExit):
        raise
    except MemoryError:
        fail("out of memory (a limit of suspension_sim.limits may be set too high for this machine)", 2)
    except OSError as e:
        fail(f"{getattr(e, 'filename', None) or ''}{': ' if getattr(e, 'filename', None) else ''}"
             f"{e.strerror or e}", 2)
    except Exception as e:  # noqa: BLE001 - a bug: one line, status 1 (SUSPENSION_SIM_DEBUG=1 shows the traceback)
        import os

        if os.environ.get("SUSPENSION_SIM_DEBUG"):
            raise
        fail(f"internal error: {type(e).__name__}: {e} (set SUSPENSION_SIM_DEBUG=1 for the traceback)", 1)


def default_out(name: str) -> Path:
    from .outdir import unique_default

    stamp = datetime.now().strftime("%Y%m%d-%H%M%S")
    return unique_default(Path("runs") / f"{name.replace('/', '_')}-{stamp}")


@app.command()
def run(
    scenario: Path = typer.Argument(..., help="scenario YAML file"),
    out: Optional[Path] = typer.Option(None, "--out", "-o", help="run folder (default runs/<name>-<time>)"),
    set_: Optional[List[str]] = typer.Option(None, "--set", "-s", help="override: path.to.key=value (repeatable)"),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
    view: bool = typer.Option(False, "--view", help="stream the run to a meshcat viewer in the browser"),
    view_rate: Optional[float] = typer.Option(None, "--view-rate", min=0.0,
                                              help="with --view: simulated seconds per wall second (1 = real time, 0 = as fast as it runs)"),
    overwrite: bool = typer.Option(False, "--overwrite", help="replace the results in an existing --out folder"),
):
    """Simulate a scenario (all its variants) and write time series, metrics, plots."""
    from rich.markup import escape
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from .outdir import prepare
    from .outputs import write_result
    from .preflight import build, check_disk

    def go():
        sc, sims = build(scenario, set_ or [])  # every pre-run check, for every variant, before any step
        check_disk(sims, out if out else Path("runs"), sc.outputs.timeseries, str(scenario))
        folder = prepare(out, overwrite) if out else default_out(sc.name)
        multi = len(sims) > 1 or bool(sc.variants)
        if sc.outputs.timeseries:  # a long run's log streams into the run folder as it runs
            for vname, sim in sims:
                sim.stream_paths = [folder / f".{vname if multi else 'run'}.timeseries.parquet.tmp"]
        results, diverged = {}, []
        with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                      TimeRemainingColumn(), console=err_console, disable=quiet or not sys.stderr.isatty()) as prog:
            for vname, sim in sims:
                task = prog.add_task(escape(f"{vname}"), total=1.0)
                if view:
                    from .viewer import attach_live_viewer  # provided by the viewer module

                    attach_live_viewer(sim, console=console, **({"rate": view_rate} if view_rate is not None else {}))
                try:
                    res = sim.run(progress=lambda f, t=task: prog.update(t, completed=f))[0]
                except SimulationDiverged as err:  # the other variants still run and are written
                    diverged.append((vname, err.locate(str(scenario), vname)))
                    for p in sim.stream_paths or []:
                        Path(p).unlink(missing_ok=True)
                    continue
                results[vname] = res
        for vname, res in results.items():
            write_result(res, folder / vname if multi else folder, plots=sc.outputs.plots,
                         timeseries=sc.outputs.timeseries)
        if multi and sc.outputs.plots and results:
            from .plots import plot_run

            plot_run({k: v for k, v in results.items()}, folder / "plots")
        if multi and results:
            import json

            from .outdir import write_atomic

            summary = {k: {"metrics": v.metrics, "full_state_access": v.info["full_state_access"]}
                       for k, v in results.items()}
            summary.update({v: {"status": "diverged", "error": str(e)} for v, e in diverged})
            write_atomic(folder / "summary.json", json.dumps(summary, indent=2))
        if results:
            _print_metrics(results)
            console.print(f"run folder: [bold]{escape(str(folder))}[/]")
        for r in results.values():
            if r.info.get("full_state_access"):
                console.print("[yellow]note:[/] the controller had full-state access (controller.full_state: true)")
                break
        if diverged:
            if results:
                console.print(f"written: {', '.join(results)}; diverged: {', '.join(v for v, _ in diverged)}",
                              highlight=False, markup=False)
            raise diverged[0][1]

    guarded(go)


KEY_METRICS = ["body_acc_rms", "body_acc_wk_rms", "body_acc_vdv", "travel_rms", "travel_peak",
               "tire_load_rms_rel", "actuator_force_rms", "actuator_power_mean", "pitch_peak"]


def _print_metrics(results: dict):
    names = []
    for r in results.values():
        for k in r.metrics:
            if any(k.startswith(b) for b in KEY_METRICS) and k not in names:
                names.append(k)
    if not names:
        names = sorted({k for r in results.values() for k in r.metrics})[:12]
    table = Table(title="metrics")
    table.add_column("metric")
    for v in results:
        table.add_column(v, justify="right")
    for k in names:
        table.add_row(k, *[f"{r.metrics.get(k, float('nan')):.4g}" for r in results.values()])
    console.print(table)


@app.command()
def validate(
    scenario: Path = typer.Argument(..., help="scenario YAML file"),
    set_: Optional[List[str]] = typer.Option(None, "--set", "-s", help="override: path.to.key=value"),
):
    """Check a scenario file without running it (every check that ``run`` makes before stepping)."""
    from rich.markup import escape

    from .preflight import build

    def go():
        sc, sims = build(scenario, set_ or [])  # builds every variant's model and components, no stepping
        n = len(sims)
        console.print(f"[green]ok[/]: {escape(str(scenario))} ({sc.vehicle.model}, road {sc.road.type}, controller "
                      f"{sc.controller.type}, {n} variant{'s' if n != 1 else ''})")

    guarded(go)


@app.command("list")
def list_(kind: Optional[str] = typer.Argument(
        None, help="models|effects|roads|maneuvers|sensors|actuators|controllers|metrics")):
    """List the registered models, effects, roads, manoeuvres, sensors, actuators, controllers and metrics."""
    from .maneuvers import MANEUVERS
    from .registry import ACTUATORS, CONTROLLERS, EFFECTS, METRICS, ROADS, SENSORS, VEHICLES, summary_line

    groups = {"models": VEHICLES, "effects": EFFECTS, "roads": ROADS, "maneuvers": MANEUVERS, "sensors": SENSORS,
              "actuators": ACTUATORS, "controllers": CONTROLLERS, "metrics": METRICS}
    if kind and kind not in groups:
        fail(f"unknown kind {kind!r} (choose from {', '.join(groups)})")
    for gname, reg in groups.items():
        if kind and gname != kind:
            continue
        console.print(f"[bold]{gname}[/]")
        for name, obj in reg.items():
            console.print(f"  {name:<22} {summary_line(obj)}", highlight=False, soft_wrap=True)


def _register_commands():
    from . import commands

    for info in pkgutil.iter_modules(commands.__path__):
        if info.name.startswith("_"):
            continue
        mod = importlib.import_module(f"{commands.__name__}.{info.name}")
        if hasattr(mod, "register"):
            mod.register(app)


_register_commands()


def main():
    app()


if __name__ == "__main__":
    main()
