"""``suspension-sim diagnose DATA... --model MODEL.yaml --out DIR``: find where simulation and measured data
disagree, name the missing effect, add it to the model and show the gap shrink (see
:mod:`suspension_sim.diagnose`)."""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer


def _rows(s: Optional[str], option: str = "--rows"):
    """``a:b`` (0-based, b exclusive, either may be empty) -> (a, b); a one-line error otherwise."""
    from ..errors import ScenarioError

    if not s:
        return None
    a, sep, b = s.partition(":")
    try:
        out = (int(a) if a.strip() else 0, int(b) if b.strip() else None)
    except ValueError:
        raise ScenarioError(f"{option} expects rows a:b (whole numbers, e.g. 0:5000), got {s!r}") from None
    if not sep:
        raise ScenarioError(f"{option} expects rows a:b (e.g. 0:5000), got {s!r}")
    if out[0] < 0 or (out[1] is not None and out[1] <= out[0]):
        raise ScenarioError(f"{option} {s!r}: needs 0 <= a < b")
    return out


def _check_options(model: Path, split: float, fs, max_effects: int, candidates) -> None:
    """The options' values, before any data is read (one-line errors naming the option)."""
    import math

    from ..errors import ScenarioError

    if not (0.0 < split < 1.0):
        raise ScenarioError(f"--split must be a fraction between 0 and 1 (got {split:g})")
    if fs is not None and not (math.isfinite(fs) and fs > 0):
        raise ScenarioError(f"--fs must be a sample rate > 0 in Hz (got {fs:g})")
    if max_effects < 0:
        raise ScenarioError(f"--max-effects must be >= 0 (got {max_effects})")
    if candidates:
        from ..diagnose.candidates import library
        from ..diagnose.model import load_model

        known = {c.name.split("@")[0] for c in library(load_model(str(model)))} | {"parameter"}
        names = [c.strip() for c in candidates.split(",") if c.strip()]
        bad = [c for c in names if c not in known]
        if bad or not names:
            raise ScenarioError(f"--candidates: unknown name(s) {', '.join(map(repr, bad)) or '(none given)'} "
                                f"(known: {', '.join(sorted(known))})")


def register(app: typer.Typer) -> None:
    @app.command()
    def diagnose(
        data: List[Path] = typer.Argument(..., help="CSV/Parquet/.mat file(s); several files are merged column-wise"),
        model: Path = typer.Option(..., "--model", "-m", help="MODEL.yaml: the vehicle block (model, params, effects)"),
        out: Path = typer.Option(..., "--out", "-o", help="output folder"),
        map_: Optional[List[str]] = typer.Option(None, "--map", help="rename/scale a column: SRC=NAME or SRC=NAME*scale"),
        fs: Optional[float] = typer.Option(None, "--fs", help="sample rate in Hz when there is no time column"),
        split: float = typer.Option(0.7, "--split", help="training fraction of the record (the rest is held out: "
                                    "its end, or its start when only that holds the record's rare events)"),
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
        input_hold: str = typer.Option("linear", "--input-hold",
                                       help="the inputs between samples: linear | bandlimited (low-passed before "
                                            "sampling, e.g. a generator's reconstruction filter) | zoh"),
        no_confirm: bool = typer.Option(False, "--no-confirm", help="skip the MuJoCo re-simulation of the fitted model"),
        no_plausibility: bool = typer.Option(False, "--no-plausibility",
                                             help="fit even when the units/scales look wrong for the model (warn only)"),
        overwrite: bool = typer.Option(False, "--overwrite", help="replace the results in an existing --out folder"),
    ):
        """Diagnose a model against measured data: calibrate, locate, name the missing effect, refit, report."""
        from ..cli import console, fail, guarded

        if nan not in ("error", "drop", "interp"):
            fail(f"--nan must be error, drop or interp (got {nan!r})")

        def go():
            from ..diagnose import diagnose as run
            from ..diagnose.io import parse_map
            from ..errors import ScenarioError

            from ..outdir import prepare

            _check_options(model, split, fs, max_effects, candidates)
            row_sel, test_row_sel = _rows(rows), _rows(test_rows, "--test-rows")
            prepare(out, overwrite)
            floors = {}
            for f in floor or []:
                k, _, v = f.partition("=")
                try:
                    floors[k.strip()] = float(v)
                except ValueError:
                    raise ScenarioError(f"--floor expects CHANNEL=value, got {f!r}") from None
                if not (floors[k.strip()] > 0 and floors[k.strip()] < float("inf")):
                    raise ScenarioError(f"--floor {f!r}: the floor must be a finite value > 0")
            rep = run([str(p) for p in data], str(model), out, mapping=parse_map(map_), fs=fs, split=split,
                      test=[str(p) for p in test] if test else None, floors=floors,
                      candidates=[c.strip() for c in candidates.split(",")] if candidates else None,
                      max_effects=max_effects, rows=row_sel, test_rows=test_row_sel, nan=nan, sort=sort,
                      dedupe=dedupe, resample=resample, demean=demean, confirm=not no_confirm, input_hold=input_hold,
                      plausibility=not no_plausibility, log=lambda m: console.print(m, highlight=False, markup=False))
            console.print(str(rep['verdict']), style="bold", markup=False, highlight=False)
            console.print(f"report: {out / 'report.html'}  model: {out / 'model.fitted.yaml'}", markup=False,
                          highlight=False)

        guarded(go)
