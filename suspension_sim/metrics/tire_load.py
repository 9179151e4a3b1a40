"""Dynamic tire load: RMS and peak, absolute and relative to the static load, per corner."""
import numpy as np

from ..registry import METRICS
from .base import CornerRmsPeak, metric


@METRICS.register("tire_load")
@metric
class TireLoad(CornerRmsPeak):
    """Dynamic tire load RMS and peak (N) and RMS relative to the static wheel load, per corner.

    ``tire_force{s}`` in the log is the dynamic part (total minus static, positive = more compression), so
    ``tire_load_rms_rel{s}`` = RMS(F_dyn)/F_static, the usual road-holding measure (1/3 means the tire
    lifts off about 0.1 % of the time for Gaussian loads).
    """

    channel = key = "tire_force"

    def more(self, s: str, rms: np.ndarray) -> dict:
        static = np.asarray(self.meta.static_tire_force[s], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return {f"tire_load_rms_rel{s}": np.where(static > 0, rms / np.where(static > 0, static, 1.0), np.nan)}
