"""RMS and peak suspension travel, and time on the bump stops, per corner."""
import numpy as np

from ..registry import METRICS
from ._util import duration, fraction, peak
from .base import RunView, rms


@METRICS.register("suspension_travel")
def suspension_travel(run: RunView) -> dict:
    """RMS and peak suspension travel (m) per corner; time on the stops where a bump_stop effect sets a gap.

    Keys (``{s}`` = corner suffix): ``travel_rms{s}``, ``travel_peak{s}`` (max |travel|) and, when the run
    has a bump stop on that corner, ``travel_stop_fraction{s}`` (share of samples with |travel| > gap, the
    free travel before the stop engages) and ``travel_stop_time{s}`` (that share times the record length, s).
    """
    out = {}
    T = duration(run)
    for s in run.suffixes:
        x = run.ts[f"travel{s}"].to_numpy()
        out[f"travel_rms{s}"] = rms(x)
        out[f"travel_peak{s}"] = peak(x)
        gap = run.stop_gap.get(s)
        if gap is not None:
            f = fraction(np.abs(x) > gap)
            out[f"travel_stop_fraction{s}"] = f
            out[f"travel_stop_time{s}"] = f * T
    return out
