"""Metric interface.

A metric is a function registered by name that takes a :class:`RunView` (one car's log) and returns a flat
``dict[str, float]`` (keys are metric names with units implied by SI; per-corner values carry the corner
suffix, e.g. ``travel_rms_front``)::

    @METRICS.register("body_acc")
    def body_acc(run: RunView) -> dict[str, float]:
        a = run.ts["body_acc"].to_numpy()
        return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd


@dataclass
class RunView:
    ts: pd.DataFrame  # columns: t, body_z, body_vel, body_acc, [pitch...], travel{s}, ... (see results.py)
    suffixes: list[str]  # corner suffixes ('' for one-corner models)
    static_tire_force: dict[str, float]  # suffix -> N
    stop_gap: dict[str, float] = field(default_factory=dict)  # suffix -> m (bump-stop free travel), if any
    info: dict = field(default_factory=dict)

    @property
    def dt(self) -> float:
        t = self.ts["t"].to_numpy()
        return float(t[1] - t[0]) if len(t) > 1 else 0.0


def rms(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")
