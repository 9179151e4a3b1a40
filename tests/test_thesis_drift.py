"""The thesis's mode I stiffness/damping drifts (Figs. 2.7–2.8) are defined once
(suspension_sim/reproductions/_thesis_drift.py); every thesis scenario that drifts a spring or a damper with a
``scale`` ramp (a damper with a ``scale`` step) must use exactly that definition for its run length, and a drift must reach the
plant (a softer spring sags under the same load)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from suspension_sim.config import load_scenario, parse_scenario
from suspension_sim.reproductions import _thesis_drift as drift
from suspension_sim.simulation import Simulation

SCEN = Path(__file__).resolve().parents[1] / "scenarios"


def _drifting():
    out = []
    for f in sorted(SCEN.glob("thesis_*.yaml")):
        sc = load_scenario(f)
        for name, v in sc.expand(str(f)):
            for var in v.vehicle.variations:
                if drift.drift_kind(var):
                    out.append((f.stem, name, var, v.sim.duration))
    return out


def test_some_thesis_scenarios_drift():
    assert {s for s, *_ in _drifting()} >= {"thesis_ch3_adaptation", "thesis_ch6_bump", "thesis_ch6_sine",
                                            "thesis_ch7_road", "thesis_ch7_dirt"}
    assert {drift.drift_kind(v) for _, _, v, _ in _drifting()} == {"stiffness", "damping"}


def test_every_damper_drifts_where_the_springs_do():
    """Mode I drifts every damper, linear or not: a thesis run whose springs drift and whose vehicle has a
    velocity-squared damper effect also drifts that effect's coefficient (effects.quadratic_damping.c_v)."""
    runs = {}
    for stem, variant, var, _ in _drifting():
        runs.setdefault((stem, variant), set()).add((drift.drift_kind(var), var.param.startswith("effects.")))
    effect_dampers = {(s, v) for (s, v), kinds in runs.items() if ("damping", True) in kinds}
    assert {s for s, _ in effect_dampers} >= {"thesis_ch4_load_step", "thesis_ch6_bump", "thesis_ch6_sine",
                                              "thesis_ch7_road", "thesis_ch7_dirt"}
    for f in sorted(SCEN.glob("thesis_*.yaml")):
        for name, v in load_scenario(f).expand(str(f)):
            has_damper_effect = any(e.type in drift.DAMPER_EFFECTS for e in v.vehicle.effects)
            if has_damper_effect and ("stiffness", False) in runs.get((f.stem, name), set()):
                assert (f.stem, name) in effect_dampers, (f.stem, name)


@pytest.mark.parametrize("stem,variant,var,duration", _drifting(),
                         ids=lambda x: x if isinstance(x, str) else "")
def test_every_drift_is_the_one_definition(stem, variant, var, duration):
    assert drift.matches(var, duration), (stem, variant, var)


def test_a_stiffness_drift_reaches_the_plant():
    """SDOF rig, passive, flat road: the spring −15 % by 5T/6 leaves the static load on a softer spring, so
    the body sinks by δ_st·0.15/0.85 (δ_st = M·g/K); without the drift it stays at 0 (the baseline)."""
    T = 12.0
    base = {"name": "d", "vehicle": {"model": "sdof", "params": {"sprung_mass": 250, "spring_stiffness": 5000,
                                                                  "damping": 2000}},
            "road": {"type": "flat"}, "controller": {"type": "passive"},
            "sim": {"duration": T, "dt": 0.001, "control_dt": 0.01, "log_dt": 0.01}}
    drifted = parse_scenario({**base, "vehicle": {**base["vehicle"], "variations": [
        {"param": "spring_stiffness", **drift.stiffness_drift(T)}]}})
    r0, r1 = (Simulation([parse_scenario(base)]).run()[0], Simulation([drifted]).run()[0])
    z0, z1 = (float(r.ts.body_z.iloc[-1]) for r in (r0, r1))
    dst = 250 * 9.81 / 5000
    assert abs(z0) < 1e-6
    assert z1 == pytest.approx(-dst * drift.STIFFNESS_DROP / (1 - drift.STIFFNESS_DROP), rel=0.03)
    assert np.all(np.diff(r1.ts.body_z.to_numpy()[r1.ts.t.to_numpy() < T / 6]) == 0)
