"""Tire lift-off time per corner."""

from ..registry import METRICS
from ._util import duration, fraction
from .base import RunView

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
        total = static + run.ts[f"tire_force{s}"].to_numpy()
        f = fraction(total <= LIFTOFF_TOL * max(abs(static), 1.0))
        out[f"tire_liftoff_fraction{s}"] = f
        out[f"tire_liftoff_time{s}"] = f * T
    return out
