"""``suspension-sim batch SWEEP.yaml [--out DIR] [--workers N] [--scheduler ADDRESS | --dask-local N] [--resume]``:
run a parameter sweep / Monte Carlo study headless (see :mod:`suspension_sim.batch`)."""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Optional

import typer

KEY_METRICS = ("body_acc_rms", "body_acc_wk_rms", "travel_rms", "travel_peak", "tire_load_rms_rel",
               "actuator_force_rms", "body_acc_peak")


def register(app: typer.Typer) -> None:
    @app.command()
    def batch(
        sweep: Path = typer.Argument(..., help="sweep YAML file (base scenario + what varies)"),
        out: Optional[Path] = typer.Option(None, "--out", "-o", help="output folder (default runs/batch-<name>)"),
        workers: Optional[int] = typer.Option(None, "--workers", "-w", help="local worker processes (default: cores)"),
        scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler address, e.g. tcp://host:8786"),
        dask_local: Optional[int] = typer.Option(None, "--dask-local", help="start a local Dask cluster of N workers"),
        resume: bool = typer.Option(True, "--resume/--fresh",
                                    help="recompute only missing or failed runs in --out (default) / start over"),
        ensemble_size: Optional[int] = typer.Option(None, "--ensemble-size", help="cars per MuJoCo model per task"),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
        overwrite: bool = typer.Option(False, "--overwrite",
                                       help="replace an existing --out folder that is not this sweep's batch folder"),
    ):
        """Run a sweep (grids, lists, random samples, Monte Carlo seeds) on local processes or Dask."""
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn
        from rich.table import Table

        from ..batch import BatchInterrupted, run_batch
        from ..cli import console, err_console, fail, guarded

        if scheduler and dask_local:
            fail("give either --scheduler or --dask-local, not both")
        if workers is not None and workers < 1:
            fail(f"--workers must be >= 1 (got {workers})")
        if dask_local is not None and dask_local < 1:
            fail(f"--dask-local must be >= 1 (got {dask_local})")
        if ensemble_size is not None and ensemble_size < 1:
            fail(f"--ensemble-size must be >= 1 (got {ensemble_size})")

        def go():
            from ..batch import load_sweep
            from ..outdir import prepare

            load_sweep(sweep)  # the sweep file's errors first (one line, naming it)
            if out is not None:  # a batch resumes into its own folder; any other folder needs --overwrite
                prepare(out, overwrite, allow_resume=_is_batch_folder(out, sweep) and not overwrite)
            with Progress(TextColumn("[bold]runs"), BarColumn(), MofNCompleteColumn(), TextColumn("•"),
                          TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(), console=err_console,
                          disable=quiet or not sys.stderr.isatty()) as prog:
                task = prog.add_task("runs", total=None)

                def progress(done, total):
                    prog.update(task, completed=done, total=total)

                try:
                    rep = run_batch(sweep, out=out, workers=workers, scheduler=scheduler, dask_local=dask_local,
                                    resume=resume, ensemble_size=ensemble_size, progress=progress)
                except BatchInterrupted as err:  # Ctrl-C: one line, the finished runs kept, exit 130 (128 + SIGINT)
                    prog.stop()
                    fail(str(err), 130)
            df = rep.summary
            counts = ", ".join(f"{k} {v}" for k, v in sorted(rep.counts.items()))
            console.print(f"[bold]{rep.n_total}[/] runs ({rep.n_run} computed, {rep.n_skipped} already done) on "
                          f"{rep.engine} in {rep.wall:.1f} s: {counts or 'nothing run'}")
            if df is not None and len(df):
                ok = df[df["status"] == "ok"]
                cols = [f"metric.{k}" for k in KEY_METRICS if f"metric.{k}" in df.columns]
                if len(ok) and cols:
                    t = Table(title="metrics over ok runs")
                    for h in ("metric", "min", "mean", "max"):
                        t.add_column(h, justify="right" if h != "metric" else "left")
                    for c in cols:
                        v = ok[c]
                        t.add_row(c[7:], f"{v.min():.4g}", f"{v.mean():.4g}", f"{v.max():.4g}")
                    console.print(t)
                bad = df[df["status"] != "ok"]
                from rich.markup import escape

                for _, r in bad.head(5).iterrows():
                    console.print(f"  [red]{r['status']}[/] run {r['run_id']}: {escape(str(r['error'])[:160])}",
                                  highlight=False)
                if len(bad) > 5:
                    console.print(f"  ... {len(bad) - 5} more failed runs (see the 'error' column)")
            console.print(f"summary: [bold]{rep.out / 'summary.parquet'}[/]")
            if rep.counts and set(rep.counts) - {"ok"}:
                raise typer.Exit(1)

        guarded(go)


def _is_batch_folder(out: Path, sweep: Path) -> bool:
    """``out`` holds a batch of the same sweep file (so running again resumes it)."""
    import json

    meta = Path(out) / "sweep.resolved.json"
    if not meta.is_file():
        return False
    try:
        src = json.loads(meta.read_text()).get("source")
    except (ValueError, OSError):
        return False
    try:
        return Path(src).resolve() == Path(sweep).resolve()
    except (TypeError, OSError):
        return False
