"""``suspension-sim diagnose DATA... --model MODEL.yaml --out DIR``: find where simulation and measured data
disagree, name the missing effect, add it to the model and show the gap shrink (see
:mod:`suspension_sim.diagnose`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def _rows(s: Optional[str]):
    if not s:
        return None
    a, _, b = s.partition(":")
    return (int(a) if a else 0, int(b) if b else None)


def register(app: typer.Typer) -> None:
    @app.command()
    def diagnose(
        data: List[Path] = typer.Argument(..., help="CSV/Parquet/.mat file(s); several files are merged column-wise"),
        model: Path = typer.Option(..., "--model", "-m", help="MODEL.yaml: the vehicle block (model, params, effects)"),
        out: Path = typer.Option(..., "--out", "-o", help="output folder"),
        map_: Optional[List[str]] = typer.Option(None, "--map", help="rename/scale a column: SRC=NAME or SRC=NAME*scale"),
        fs: Optional[float] = typer.Option(None, "--fs", help="sample rate in Hz when there is no time column"),
        split: float = typer.Option(0.7, "--split", help="training fraction of the record (the rest is held out)"),
        test: Optional[List[Path]] = typer.Option(None, "--test", help="held-out record file(s) (replaces --split)"),
        rows: Optional[str] = typer.Option(None, "--rows", help="use only rows a:b of DATA (0-based)"),
        test_rows: Optional[str] = typer.Option(None, "--test-rows", help="rows a:b of DATA (or of --test) held out"),
        floor: Optional[List[str]] = typer.Option(None, "--floor", help="noise/repeatability floor CHANNEL=value (channel units)"),
        candidates: Optional[str] = typer.Option(None, "--candidates", help="comma-separated subset of the library"),
        max_effects: int = typer.Option(3, "--max-effects", help="stop after this many effects"),
        nan: str = typer.Option("error", "--nan", help="missing values: error | drop | interp"),
        sort: bool = typer.Option(False, "--sort", help="repair: sort rows by time"),
        dedupe: bool = typer.Option(False, "--dedupe", help="repair: drop duplicate time stamps"),
        resample: bool = typer.Option(False, "--resample", help="repair: resample a non-uniform time base"),
        demean: bool = typer.Option(False, "--demean", help="subtract the training record's channel means"),
        no_confirm: bool = typer.Option(False, "--no-confirm", help="skip the MuJoCo re-simulation of the fitted model"),
    ):
        """Diagnose a model against measured data: calibrate, locate, name the missing effect, refit, report."""
        from ..cli import console, fail, guarded

        if nan not in ("error", "drop", "interp"):
            fail(f"--nan must be error, drop or interp (got {nan!r})")

        def go():
            from ..diagnose import diagnose as run
            from ..diagnose.io import parse_map
            from ..errors import ScenarioError

            floors = {}
            for f in floor or []:
                k, _, v = f.partition("=")
                try:
                    floors[k.strip()] = float(v)
                except ValueError:
                    raise ScenarioError(f"--floor expects CHANNEL=value, got {f!r}") from None
            rep = run([str(p) for p in data], str(model), out, mapping=parse_map(map_), fs=fs, split=split,
                      test=[str(p) for p in test] if test else None, floors=floors,
                      candidates=[c.strip() for c in candidates.split(",")] if candidates else None,
                      max_effects=max_effects, rows=_rows(rows), test_rows=_rows(test_rows), nan=nan, sort=sort,
                      dedupe=dedupe, resample=resample, demean=demean, confirm=not no_confirm,
                      log=lambda m: console.print(m, highlight=False))
            console.print(f"[bold]{rep['verdict']}[/]")
            console.print(f"report: [bold]{out / 'report.html'}[/]  model: [bold]{out / 'model.fitted.yaml'}[/]")

        guarded(go)
