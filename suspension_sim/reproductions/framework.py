"""The reproduction framework behind ``suspension-sim reproduce``.

A *source* (one paper or thesis) is one module in this package that registers a :class:`Source` by name::

    from suspension_sim.reproductions.framework import SOURCES, Item, ItemOutput, Claim, Source

    def fig2(ctx):                         # ctx: Context (step factor, scenario loading, ensemble runs)
        res = ctx.run_scenario("kim_fig2")  # dict variant -> Result
        ...
        return ItemOutput(claims=[Claim("force error", "small", "4 N", "reproduced")],
                          key={"force_error": (4.0, 0.5)}, figure=fig)

    SOURCES.register("kim")(Source("kim", "Kim (1996)", "docs/reproductions/kim_1996.md",
                                   [Item("fig2", "Fig. 2: ...", fig2)]))

Each item runs its scenarios, returns the paper-claim / ours / verdict rows, a figure and its *key numbers*.
The runner writes ``<out>/<source>/<item>.png`` and ``<item>.md`` and a ``README.md`` with every table, and
checks convergence: the item runs again with every scenario's physics and control step both halved (an item
may hold its control step, as the thesis's discrete laws do; the page states the steps both runs used, read from
the runs themselves), and each key
number must change by less than 2 % (relative to ``max(|value|, floor)``; the floor keeps a number that is
nearly zero from failing on noise).  The verdict of the check is part of each item's table.

A key number that is a statistical estimate (e.g. the mean over realisations of a chaotic run) is given as
``(value, floor, standard_error)``: its change on halving then carries the standard error of the difference,
and it counts as converged only when the change plus one standard error is below 2 %; when the 2 % bound lies
within one standard error of the change the check says "undecided" (a mean below the bound with a spread across
it is not a pass).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import ScenarioError
from ..registry import Registry

CONVERGENCE_TOL = 0.02  # key numbers change by less than 2 % when the step is halved


@dataclass
class Claim:
    """One row: what the paper claims, what we measure, the verdict (reproduced / partly / not / n.a.)."""
    quantity: str
    paper: str
    ours: str
    verdict: str
    note: str = ""


@dataclass
class ItemOutput:
    claims: list[Claim]
    # name -> (value, floor) or (value, floor, standard error) for a statistical estimate (see the module doc)
    key: dict[str, tuple] = field(default_factory=dict)
    figure: object | None = None  # a matplotlib Figure
    notes: list[str] = field(default_factory=list)
    tables: list[str] = field(default_factory=list)  # extra Markdown tables (e.g. a whole study)


@dataclass
class Item:
    name: str
    title: str
    run: Callable[["Context"], ItemOutput]
    converge: bool = True  # run again at half the step and compare the key numbers


@dataclass
class Source:
    name: str
    title: str
    page: str
    items: list[Item]


SOURCES: Registry[Source] = Registry("reproduction source")


def _load_sources() -> None:
    import importlib
    import pkgutil

    from . import __path__ as pkg_path

    for info in pkgutil.iter_modules(pkg_path):
        if not info.name.startswith("_") and info.name != "framework":
            importlib.import_module(f"{__package__}.{info.name}")


def sources() -> dict[str, Source]:
    _load_sources()
    return {name: SOURCES._items[name] for name in sorted(SOURCES._items)}


def scenarios_dir() -> Path:
    d = Path(__file__).resolve().parents[2] / "scenarios"
    if not d.is_dir():
        raise ScenarioError("the reproductions need the scenario files of a source checkout "
                            f"(not found: {d})")
    return d


class Context:
    """What an item gets: the step factor (1, or 0.5 in the convergence run) and helpers that load the
    source's scenario files and run them as ensembles, reporting progress."""

    def __init__(self, step_factor: float = 1.0, progress: Callable[[str, float], None] | None = None):
        self.step_factor = step_factor
        self._progress = progress or (lambda label, f: None)
        self.steps: set[tuple[float, float]] = set()  # (physics dt, control dt) of every scenario run

    def scenario(self, name: str, sets: list[str] | None = None):
        """Load ``scenarios/<name>.yaml`` with ``path=value`` overrides; the step is scaled by the factor."""
        from ..config import load_scenario

        sc = load_scenario(scenarios_dir() / f"{name}.yaml", sets or [])
        self.scale_step(sc)
        return sc

    def scale_step(self, sc):
        if self.step_factor != 1.0:
            sc.sim.dt = sc.sim.dt * self.step_factor
            sc.sim.control_dt = sc.sim.control_dt * self.step_factor
        return sc

    def variants(self, name: str, sets: list[str] | None = None, only: list[str] | None = None) -> dict:
        """The scenario's variants as resolved scenarios (step scaled), optionally only some of them."""
        sc = self.scenario(name, sets)  # step already scaled; the variants inherit it (a variant that sets
        out = {}                        # its own sim.dt is scaled below)
        for vname, v in sc.expand(str(scenarios_dir() / f"{name}.yaml")):
            if only is None or vname in only:
                over = ((sc.variants or {}).get(vname) or {}).get("sim", {})
                if v is not sc and self.step_factor != 1.0:
                    if "dt" in over:
                        v.sim.dt = v.sim.dt * self.step_factor
                    if "control_dt" in over:
                        v.sim.control_dt = v.sim.control_dt * self.step_factor
                out[vname] = v
        return out

    def run(self, scenarios: dict, label: str = "") -> dict:
        """Run ``{label: Scenario}``; scenarios that can share an ensemble (:func:`..batch.ensemble_key`:
        the structure plus everything the loop takes from the first car, e.g. the sensor noise) run as one."""
        from ..batch import ensemble_key
        from ..simulation import Simulation

        groups: dict = {}
        for name, v in scenarios.items():
            self.steps.add((float(v.sim.dt), float(v.sim.control_dt)))
            groups.setdefault(ensemble_key(v), []).append((name, v))
        out = {}
        for k, members in enumerate(groups.values()):
            text = f"{label} ({', '.join(n for n, _ in members)})"
            res = Simulation([v for _, v in members]).run(progress=lambda f, t=text: self._progress(t, f))
            out.update({name: r for (name, _), r in zip(members, res)})
        return out

    def run_scenario(self, name: str, sets: list[str] | None = None, only: list[str] | None = None) -> dict:
        return self.run(self.variants(name, sets, only), label=name)


def rel_change(a: float, b: float, floor: float) -> float:
    if not (math.isfinite(a) and math.isfinite(b)):
        return float("inf") if a != b else 0.0
    return abs(b - a) / max(abs(a), floor, 1e-300)


def conv_status(change: float, se: float | None) -> str:
    """"converged", "undecided" (the 2 % bound within one standard error of the change) or "not converged"."""
    if se is None or not math.isfinite(se):
        return "converged" if change < CONVERGENCE_TOL else "not converged"
    if change + se < CONVERGENCE_TOL:
        return "converged"
    return "undecided" if change - se < CONVERGENCE_TOL else "not converged"


def overall_status(statuses) -> str:
    st = list(statuses)
    if any(s == "not converged" for s in st):
        return "NOT converged"
    return "undecided" if any(s == "undecided" for s in st) else "converged"


_SEVERITY = {"converged": 0, "undecided": 1, "not converged": 2}


def status_summary(entries) -> str:
    """One item's step-halving line from ``(key, change, status)`` entries: the overall status and the key that
    decides it (the worst status first, then the largest change: an undecided ensemble mean with a large change
    does not hide a deterministic key that is not converged)."""
    entries = list(entries)
    worst = max(entries, key=lambda e: (_SEVERITY[e[2]], e[1]))
    return overall_status(e[2] for e in entries) + f" (worst {worst[0]}: {worst[1] * 100:.1f} %)"


def md_table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |" for r in rows]
    return "\n".join(lines)


def fmt(x: float, digits: int = 3) -> str:
    if x is None or not math.isfinite(x):
        return str(x)
    return f"{x:.{digits}g}"


def run_item(item: Item, converge: bool, progress=None) -> dict:
    """Run an item (and its half-step twin); returns a dict with the output, the convergence table and a
    pass flag."""
    ctx = Context(1.0, progress)
    out = item.run(ctx)
    conv, half_ctx, conv_se = None, None, {}
    if converge and item.converge and out.key:
        half_ctx = Context(0.5, progress)
        half = item.run(half_ctx)
        conv = []
        for k, kv in out.key.items():
            v, floor = kv[0], kv[1]
            hv = half.key.get(k, (float("nan"), floor))
            v2 = hv[0]
            conv.append((k, v, v2, rel_change(v, v2, floor)))
            if len(kv) > 2:  # a statistical estimate: the standard error of the change (relative)
                se2 = hv[2] if len(hv) > 2 else kv[2]
                conv_se[k] = math.hypot(kv[2], se2) / max(abs(v), floor, 1e-300)
    return {"out": out, "conv": conv, "conv_se": conv_se, "steps": sorted(ctx.steps),
            "half_steps": None if half_ctx is None else sorted(half_ctx.steps)}


def steps_text(steps) -> str:
    """The steps an item ran at, e.g. "physics 0.5 ms, control 1 ms" (several when its scenarios differ)."""
    def ms(x):
        return f"{x * 1e3:g} ms"
    return "; ".join(f"physics {ms(d)}, control {ms(c)}" for d, c in steps) or "no scenario run"


def halved_text(steps, half_steps) -> str:
    """What the half-step run changed, read from the steps both runs actually used (an item may hold its
    control step, e.g. a law designed at its sampling interval)."""
    if not half_steps or len(steps) != len(half_steps):
        return "when the step is halved"
    phys = all(math.isclose(h[0], 0.5 * f[0]) for f, h in zip(steps, half_steps))
    ctrl = all(math.isclose(h[1], 0.5 * f[1]) for f, h in zip(steps, half_steps))
    held = all(math.isclose(h[1], f[1]) for f, h in zip(steps, half_steps))
    if phys and ctrl:
        return "when the physics and control steps are both halved"
    if phys and held:
        return "when the physics step is halved (the control step is held)"
    return f"when the steps change to {steps_text(half_steps)}"


def item_markdown(source: Source, item: Item, r: dict) -> str:
    out, conv = r["out"], r["conv"]
    md = [f"### {item.title}", "", f"![{item.name}]({item.name}.png)" if out.figure is not None else "", ""]
    md.append(md_table(["quantity", "paper", "ours", "verdict", "note"],
                        [[c.quantity, c.paper, c.ours, c.verdict, c.note] for c in out.claims]))
    for t in out.tables:
        md += ["", t]
    if conv is not None:
        ses = r.get("conv_se", {})
        st = {k: conv_status(c, ses.get(k)) for k, a, b, c in conv}
        ov = overall_status(st.values())
        extra = ("; a mean over realisations carries ± one standard error of the change and is undecided when "
                 f"the {CONVERGENCE_TOL:.0%} bound lies within it" if ses else "")
        md += ["", f"Step halving: {ov} (every key number must change by "
                   f"less than {CONVERGENCE_TOL:.0%} {halved_text(r.get('steps', []), r.get('half_steps'))}; "
                   f"run at {steps_text(r.get('steps', []))}{extra}).", ""]
        md.append(md_table(["key number", "step", "half step", "change"],
                            [[k, fmt(a, 4), fmt(b, 4), f"{c * 100:.2f} %" + (
                                f" ± {ses[k] * 100:.2f} % ({st[k]}); the two means differ by "
                                f"{c / ses[k] if ses[k] > 0 else float('inf'):.2f} s.e." if k in ses else "")]
                             for k, a, b, c in conv]))
    elif item.converge is False:
        md += ["", "Step halving: not run for this item (see its notes)."]
    for n in out.notes:
        md += ["", n]
    return "\n".join(md) + "\n"


def write_item(folder: Path, source: Source, item: Item, r: dict) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    out = r["out"]
    if out.figure is not None:
        import matplotlib.pyplot as plt

        out.figure.savefig(folder / f"{item.name}.png", dpi=70)
        plt.close(out.figure)
    (folder / f"{item.name}.md").write_text(item_markdown(source, item, r))


def summary(r: dict) -> dict:
    out, conv, ses = r["out"], r["conv"], r.get("conv_se", {})

    def entry(k, a, b, c):
        e = {"step": a, "half_step": b, "change": c, "converged": conv_status(c, ses.get(k)) == "converged"}
        if k in ses:
            e["change_se"] = ses[k]
            e["status"] = conv_status(c, ses[k])
        return e
    return {
        "claims": [c.__dict__ for c in out.claims],
        "key": {k: v[0] for k, v in out.key.items()},
        "steps": [list(s) for s in r.get("steps", [])],
        "convergence": None if conv is None else {k: entry(k, a, b, c) for k, a, b, c in conv},
    }


def finish_source(folder: Path, source: Source, results: dict) -> None:
    md = [f"# {source.title}", "", f"Generated by `suspension-sim reproduce {source.name}`; the page that "
          f"discusses these results: `{source.page}`.", ""]
    for item in source.items:
        if item.name in results:
            md.append(item_markdown(source, item, results[item.name]))
    (folder / "README.md").write_text("\n".join(md))
    (folder / "summary.json").write_text(json.dumps(
        {name: summary(r) for name, r in results.items()}, indent=2, default=float))


def verdict_row(r: dict) -> tuple[str, str]:
    """(verdicts joined, step-halving summary) of one item's result."""
    verdicts = ", ".join(c.verdict for c in r["out"].claims if c.verdict != "n.a.")
    conv = "not run"
    if r["conv"] is not None:
        ses = r.get("conv_se", {})
        conv = status_summary((c[0], c[3], conv_status(c[3], ses.get(c[0]))) for c in r["conv"])
    return verdicts, conv


def write_index(out: Path, srcs: dict, results: dict) -> None:
    """``<out>/README.md``: one row per item of every source run (merged with the sources already there)."""
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in sorted(p.name for p in out.iterdir() if (p / "summary.json").is_file()):
        s = json.loads((out / name / "summary.json").read_text())
        for item, v in s.items():
            verdicts = ", ".join(c["verdict"] for c in v["claims"] if c["verdict"] != "n.a.")
            conv = v["convergence"]
            if conv is None:
                cs = "not run"
            else:
                cs = status_summary((k, e["change"], e.get("status", "converged" if e["converged"]
                                                       else "not converged")) for k, e in conv.items())
            rows.append([f"[{name}]({name}/README.md)", f"[{item}]({name}/{item}.md)", verdicts, cs])
    (out / "README.md").write_text("# Reproductions\n\nGenerated by `suspension-sim reproduce`.\n\n"
                                   + md_table(["source", "item", "verdicts", "step halving"], rows) + "\n")
