"""Helpers shared by the metric modules (not a metric: the leading underscore keeps it out of discovery)."""
from __future__ import annotations

import numpy as np

from .base import RunView


def duration(run: RunView) -> float:
    """Length of the record in s, each log sample standing for one log step (N·dt); also of an
    :class:`~.base.EnsembleView` (all its cars share the time axis)."""
    return run.n_samples * run.dt


def fraction(mask) -> float:
    mask = np.asarray(mask, dtype=bool)
    return float(np.mean(mask)) if mask.size else float("nan")


def peak(x) -> float:
    x = np.asarray(x, dtype=float)
    return float(np.max(np.abs(x))) if x.size else float("nan")
