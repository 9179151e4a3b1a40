"""Tire lift-off time per corner."""
import numpy as np

from ..registry import METRICS
from ._util import duration, fraction
from .base import EnsembleView, Reductions, RunView, ensemble_version, fraction_rows, stream_version

#: total tire force below this share of the static load counts as lifted off (absorbs round-off when the
#: tire_liftoff effect clamps the total force to exactly zero)
LIFTOFF_TOL = 1e-9


@METRICS.register("tire_liftoff")
def tire_liftoff(run: RunView) -> dict:
    """Time with the tire off the ground (total tire force = static + dynamic <= 0), per corner.

    Keys: ``tire_liftoff_fraction{s}`` (share of samples) and ``tire_liftoff_time{s}`` (s).  Without the
    ``tire_liftoff`` effect the linear tire may pull (negative total force); those samples count too, as the
    time a real tire would have left the ground.
    """
    out = {}
    T = duration(run)
    for s in run.suffixes:
        static = float(run.static_tire_force[s])
        total = static + run.col(f"tire_force{s}")
        f = fraction(total <= LIFTOFF_TOL * max(abs(static), 1.0))
        out[f"tire_liftoff_fraction{s}"] = f
        out[f"tire_liftoff_time{s}"] = f * T
    return out


@ensemble_version(tire_liftoff, channels=("tire_force{s}",))
def _tire_liftoff_many(ens: EnsembleView) -> dict:
    out = {}
    T = duration(ens)
    for s in ens.suffixes:
        static = [float(v) for v in ens.static_tire_force[s]]
        thr = np.array([LIFTOFF_TOL * max(abs(v), 1.0) for v in static])  # python max: same as per car
        total = np.asarray(static)[:, None] + ens.col(f"tire_force{s}")
        f = fraction_rows(total <= thr[:, None])
        out[f"tire_liftoff_fraction{s}"] = f
        out[f"tire_liftoff_time{s}"] = f * T
    return out


@stream_version(tire_liftoff)
class _TireLiftoffStream:
    def __init__(self, meta: EnsembleView):
        self.meta, self.r = meta, Reductions()

    def update(self, ens: EnsembleView) -> None:
        self.r.start(ens)
        for s in ens.suffixes:
            static = [float(v) for v in self.meta.static_tire_force[s]]
            thr = np.array([LIFTOFF_TOL * max(abs(v), 1.0) for v in static])
            total = np.asarray(static)[:, None] + ens.col(f"tire_force{s}")
            self.r.count(f"off{s}", total <= thr[:, None])

    def result(self) -> dict:
        n, out = self.meta.n_cars, {}
        T = self.r.duration
        for s in self.meta.suffixes:
            f = self.r.mean(f"off{s}", n)
            out[f"tire_liftoff_fraction{s}"] = f
            out[f"tire_liftoff_time{s}"] = f * T
        return out
