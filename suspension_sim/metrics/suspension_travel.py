"""RMS and peak suspension travel, and time on the bump stops, per corner."""
import numba
import numpy as np

from ..registry import METRICS
from .base import Accumulator, metric


def _sides(info: dict, stop_gap: dict, s: str):
    sides = (info or {}).get("stop_gap_sides", {}).get(s)
    gap = stop_gap.get(s)
    if sides is None and gap is not None:
        sides = (gap, gap)
    return sides


@METRICS.register("suspension_travel")
@metric
class SuspensionTravel(Accumulator):
    """RMS and peak suspension travel (m) per corner; time on the stops where a bump_stop effect sets a gap.

    Keys (``{s}`` = corner suffix): ``travel_rms{s}``, ``travel_peak{s}`` (max |travel|) and, when the run
    has a bump stop on that corner, ``travel_stop_fraction{s}`` (share of samples beyond the free travel:
    travel < −gap_compression or travel > gap_extension; |travel| > gap when the stop is symmetric) and
    ``travel_stop_time{s}`` (that share times the record length, s).  The sided gaps come from
    ``run.info["stop_gap_sides"]`` when the run recorded them, else the symmetric ``run.stop_gap``.
    """

    channels = ("travel{s}",)

    def __init__(self, meta):
        super().__init__(meta)
        n = self.n
        infos = meta.infos or [{}] * n
        gaps = meta.stop_gaps or [{}] * n
        self.sides = {}  # suffix -> (compression gap, extension gap), (n_cars, 1) each
        for s in meta.suffixes:
            sides = [_sides(infos[i], gaps[i], s) for i in range(n)]
            have = [sd is not None for sd in sides]
            if any(have) and not all(have):
                raise NotImplementedError("stop gaps on some cars only")  # -> car by car
            if all(have):
                self.sides[s] = tuple(np.array([float(sd[j]) for sd in sides])[:, None] for j in (0, 1))

    def update(self, chunk) -> None:
        self.r.start(chunk)
        for s in chunk.suffixes:
            x = chunk.held(f"travel{s}")
            self.r.rms_peak(s, x)
            if s in self.sides:
                lo, hi = self.sides[s]
                self.r.sum_value(f"stop{s}", _beyond(x.T, lo[:, 0], hi[:, 0]))

    def result(self) -> dict:
        out = {}
        for s in self.meta.suffixes:
            out[f"travel_rms{s}"] = self.r.rms(s)
            out[f"travel_peak{s}"] = self.r.peak(s)
            if s in self.sides:
                f = self.r.mean(f"stop{s}")
                out[f"travel_stop_fraction{s}"] = f
                out[f"travel_stop_time{s}"] = f * self.r.duration
        return out


@numba.njit(cache=True, nogil=True)
def _beyond(x, lo, hi):  # pragma: no cover - compiled
    """Per car c, the number of samples of ``x`` (samples, cars; any layout) with x < −lo[c] or x > hi[c]
    (np.count_nonzero of ``(x < -lo) | (x > hi)``, as a float), in one pass."""
    n, m = x.shape
    out = np.zeros(m)
    for j in range(n):
        for c in range(m):
            v = x[j, c]
            if v < -lo[c] or v > hi[c]:
                out[c] += 1.0
    return out
