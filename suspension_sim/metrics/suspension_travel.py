"""RMS and peak suspension travel, and time on the bump stops, per corner."""

from ..registry import METRICS
from ._util import duration, fraction, peak
from .base import RunView, rms


@METRICS.register("suspension_travel")
def suspension_travel(run: RunView) -> dict:
    """RMS and peak suspension travel (m) per corner; time on the stops where a bump_stop effect sets a gap.

    Keys (``{s}`` = corner suffix): ``travel_rms{s}``, ``travel_peak{s}`` (max |travel|) and, when the run
    has a bump stop on that corner, ``travel_stop_fraction{s}`` (share of samples beyond the free travel:
    travel < −gap_compression or travel > gap_extension; |travel| > gap when the stop is symmetric) and
    ``travel_stop_time{s}`` (that share times the record length, s).  The sided gaps come from
    ``run.info["stop_gap_sides"]`` when the run recorded them, else the symmetric ``run.stop_gap``.
    """
    out = {}
    T = duration(run)
    for s in run.suffixes:
        x = run.ts[f"travel{s}"].to_numpy()
        out[f"travel_rms{s}"] = rms(x)
        out[f"travel_peak{s}"] = peak(x)
        sides = (run.info or {}).get("stop_gap_sides", {}).get(s)
        gap = run.stop_gap.get(s)
        if sides is None and gap is not None:
            sides = (gap, gap)
        if sides is not None:
            f = fraction((x < -sides[0]) | (x > sides[1]))
            out[f"travel_stop_fraction{s}"] = f
            out[f"travel_stop_time{s}"] = f * T
    return out
