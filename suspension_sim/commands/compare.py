"""``suspension-sim compare RUN_DIR... --out DIR``: overlay runs (passive against a controller, or several
controllers) in one report: metrics side by side, overlaid time series, the cars side by side in one 3D view."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def compare(
        run_dirs: List[Path] = typer.Argument(..., help="run folders to compare (the first is the reference)"),
        out: Path = typer.Option(..., "--out", "-o", help="folder for report.html and viewer.html"),
        labels: Optional[str] = typer.Option(None, "--labels", help="comma-separated labels (default: scenario names)"),
        no_viewer: bool = typer.Option(False, "--no-viewer", help="no 3D view"),
        overwrite: bool = typer.Option(False, "--overwrite", help="replace the results in an existing --out folder"),
    ):
        """Compare finished runs in one HTML report."""
        from ..cli import console, fail, guarded

        labs = [s.strip() for s in labels.split(",")] if labels else None
        if labs is not None and len(labs) != len(run_dirs):
            fail(f"--labels: {len(labs)} labels for {len(run_dirs)} runs")

        def go():
            from ..outdir import prepare
            from ..report import write_compare

            prepare(out, overwrite)
            p = write_compare(run_dirs, out, labels=labs, viewer=not no_viewer)
            console.print(f"comparison report: {p}", markup=False, highlight=False)

        guarded(go)
