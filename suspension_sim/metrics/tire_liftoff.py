"""Tire lift-off time per corner."""
import numba
import numpy as np

from ..registry import METRICS
from .base import Accumulator, metric

#: total tire force below this share of the static load counts as lifted off (absorbs round-off when the
#: tire_liftoff effect clamps the total force to exactly zero)
LIFTOFF_TOL = 1e-9


@METRICS.register("tire_liftoff")
@metric
class TireLiftoff(Accumulator):
    """Time with the tire off the ground (total tire force = static + dynamic <= 0), per corner.

    Keys: ``tire_liftoff_fraction{s}`` (share of samples) and ``tire_liftoff_time{s}`` (s).  Without the
    ``tire_liftoff`` effect the linear tire may pull (negative total force); those samples count too, as the
    time a real tire would have left the ground.
    """

    channels = ("tire_force{s}",)

    def update(self, chunk) -> None:
        self.r.start(chunk)
        for s in chunk.suffixes:
            static = np.ascontiguousarray(self.meta.static_tire_force[s], dtype=float)
            x = chunk.held(f"tire_force{s}")
            self.r.sum_value(f"off{s}", _off(x.T, static, LIFTOFF_TOL * np.maximum(np.abs(static), 1.0)))

    def result(self) -> dict:
        out = {}
        for s in self.meta.suffixes:
            f = self.r.mean(f"off{s}")
            out[f"tire_liftoff_fraction{s}"] = f
            out[f"tire_liftoff_time{s}"] = f * self.r.duration
        return out


@numba.njit(cache=True, nogil=True)
def _off(x, static, thr):  # pragma: no cover - compiled
    """Per car c, the number of samples of ``x`` (samples, cars; any layout) with static[c] + x <= thr[c] (the
    total tire force at or below the lift-off threshold), as a float, in one pass."""
    n, m = x.shape
    out = np.zeros(m)
    for j in range(n):
        for c in range(m):
            if static[c] + x[j, c] <= thr[c]:
                out[c] += 1.0
    return out
