"""``suspension-sim reproduce [SOURCE...] --out DIR``: rerun the figures and tables of the source papers.

Each source (``suspension_sim/reproductions/<name>.py``) lists its figures and tables; every item writes a
PNG and a table of paper claim / ours / verdict under ``DIR/<source>/``, and is run again at half the step to
check that its key numbers change by less than 2 %."""
from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer


def register(app: typer.Typer) -> None:
    @app.command()
    def reproduce(
        names: Optional[List[str]] = typer.Argument(None, help="sources (default: all); `--list` shows them"),
        out: Path = typer.Option(Path("runs/reproduce"), "--out", "-o", help="output folder"),
        only: Optional[List[str]] = typer.Option(None, "--only", help="run only these items (repeatable)"),
        no_convergence: bool = typer.Option(False, "--no-convergence", help="skip the half-step rerun"),
        list_: bool = typer.Option(False, "--list", help="list the sources and their items, run nothing"),
        quiet: bool = typer.Option(False, "--quiet", "-q", help="no progress bar"),
    ):
        """Reproduce the papers' figures and tables (PNG + claim/ours/verdict tables, step-halving check)."""
        from ..cli import console, err_console, fail, guarded
        from ..reproductions import framework as fw

        def go():
            srcs = fw.sources()
            if list_:
                for s in srcs.values():
                    console.print(f"[bold]{s.name}[/]  {s.title}  ({s.page})", highlight=False)
                    for it in s.items:
                        console.print(f"  {it.name:<16} {it.title}", highlight=False, soft_wrap=True)
                return
            chosen = list(names or srcs)
            unknown = [n for n in chosen if n not in srcs]
            if unknown:
                fail(f"unknown source {unknown[0]!r} (known: {', '.join(srcs)})")
            items = [(srcs[n], it) for n in chosen for it in srcs[n].items if not only or it.name in only]
            if only:
                missing = set(only) - {it.name for _, it in items}
                if missing:
                    fail(f"--only: no item {sorted(missing)[0]!r} in {', '.join(chosen)}")
            from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

            results: dict = {}
            with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                          TimeElapsedColumn(), console=err_console,
                          disable=quiet or not sys.stderr.isatty()) as prog:
                total = prog.add_task("items", total=len(items))
                sim_task = prog.add_task("", total=1.0)

                def progress(label, f):
                    prog.update(sim_task, description=f"  {label}", completed=f)

                for src, it in items:
                    prog.update(total, description=f"{src.name}: {it.title[:60]}")
                    r = fw.run_item(it, converge=not no_convergence, progress=progress)
                    fw.write_item(out / src.name, src, it, r)
                    results.setdefault(src.name, {})[it.name] = r
                    prog.advance(total)
            for name, res in results.items():
                fw.finish_source(out / name, srcs[name], res)
                _print(console, srcs[name], res, fw)
            fw.write_index(out, {n: srcs[n] for n in results}, results)
            console.print(f"reproductions written under [bold]{out}[/]")

        guarded(go)


def _print(console, src, res, fw):
    from rich.table import Table

    table = Table(title=src.title)
    for col in ("item", "verdicts", "step halving"):
        table.add_column(col)
    for name, r in res.items():
        table.add_row(name, *fw.verdict_row(r))
    console.print(table)
