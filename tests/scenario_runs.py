"""Shared test helper: run a scenario file's variants (optionally edited first, e.g. to shorten it)."""
from __future__ import annotations

from suspension_sim.config import parse_scenario, read_yaml
from suspension_sim.simulation import Simulation


def run_variants(repo, name, edit=None, variants=None, results=False):
    """{variant: time series DataFrame} (or Result with ``results=True``) of ``scenarios/<name>.yaml``,
    after ``edit(raw_dict)`` if given, for the listed ``variants`` (default: all)."""
    raw = read_yaml(repo / "scenarios" / f"{name}.yaml")
    if edit:
        edit(raw)
    sc = parse_scenario(raw)
    out = {}
    for vname, vsc in sc.expand():
        if variants is None or vname in variants:
            r = Simulation([vsc]).run()[0]
            out[vname] = r if results else r.ts
    return out
