"""RMS and peak suspension travel, and time on the bump stops, per corner."""
import numpy as np

from ..registry import METRICS
from ._util import duration, fraction, peak
from .base import EnsembleView, Reductions, RunView, ensemble_version, fraction_rows, peak_rows, rms, rms_rows, stream_version


def _sides(info: dict, stop_gap: dict, s: str):
    sides = (info or {}).get("stop_gap_sides", {}).get(s)
    gap = stop_gap.get(s)
    if sides is None and gap is not None:
        sides = (gap, gap)
    return sides


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
        x = run.col(f"travel{s}")
        out[f"travel_rms{s}"] = rms(x)
        out[f"travel_peak{s}"] = peak(x)
        sides = _sides(run.info, run.stop_gap, s)
        if sides is not None:
            f = fraction((x < -sides[0]) | (x > sides[1]))
            out[f"travel_stop_fraction{s}"] = f
            out[f"travel_stop_time{s}"] = f * T
    return out


@ensemble_version(suspension_travel, channels=("travel{s}",))
def _suspension_travel_many(ens: EnsembleView) -> dict:
    out = {}
    T = duration(ens)
    n = ens.n_cars
    infos = ens.infos or [{}] * n
    gaps = ens.stop_gaps or [{}] * n
    for s in ens.suffixes:
        x = ens.col(f"travel{s}")
        out[f"travel_rms{s}"] = rms_rows(x)
        out[f"travel_peak{s}"] = peak_rows(x)
        sides = [_sides(infos[i], gaps[i], s) for i in range(n)]
        have = [sd is not None for sd in sides]
        if any(have) and not all(have):
            raise NotImplementedError("stop gaps on some cars only")  # -> car by car
        if all(have):
            lo = np.array([float(sd[0]) for sd in sides])[:, None]
            hi = np.array([float(sd[1]) for sd in sides])[:, None]
            f = fraction_rows((x < -lo) | (x > hi))
            out[f"travel_stop_fraction{s}"] = f
            out[f"travel_stop_time{s}"] = f * T
    return out


@stream_version(suspension_travel)
class _SuspensionTravelStream:
    def __init__(self, meta: EnsembleView):
        self.meta, self.r = meta, Reductions()
        n = meta.n_cars
        infos = meta.infos or [{}] * n
        gaps = meta.stop_gaps or [{}] * n
        self.sides = {}
        for s in meta.suffixes:
            sides = [_sides(infos[i], gaps[i], s) for i in range(n)]
            have = [sd is not None for sd in sides]
            if any(have) and not all(have):
                raise NotImplementedError("stop gaps on some cars only")  # -> decimated car by car
            if all(have):
                self.sides[s] = (np.array([float(sd[0]) for sd in sides])[:, None],
                                 np.array([float(sd[1]) for sd in sides])[:, None])

    def update(self, ens: EnsembleView) -> None:
        self.r.start(ens)
        for s in ens.suffixes:
            x = ens.col(f"travel{s}")
            self.r.sum(f"ss{s}", x * x)
            self.r.max(f"pk{s}", np.abs(x))
            if s in self.sides:
                lo, hi = self.sides[s]
                self.r.count(f"stop{s}", (x < -lo) | (x > hi))

    def result(self) -> dict:
        n, out = self.meta.n_cars, {}
        T = self.r.duration
        for s in self.meta.suffixes:
            out[f"travel_rms{s}"] = self.r.rms(f"ss{s}", n)
            out[f"travel_peak{s}"] = self.r.get(f"pk{s}", n)
            if s in self.sides:
                f = self.r.mean(f"stop{s}", n)
                out[f"travel_stop_fraction{s}"] = f
                out[f"travel_stop_time{s}"] = f * T
        return out
