"""Dynamic tire load: RMS and peak, absolute and relative to the static load, per corner."""
import numpy as np

from ..registry import METRICS
from ._util import peak
from .base import CornerRmsPeakStream, EnsembleView, RunView, ensemble_version, peak_rows, rms, rms_rows, stream_version


@METRICS.register("tire_load")
def tire_load(run: RunView) -> dict:
    """Dynamic tire load RMS and peak (N) and RMS relative to the static wheel load, per corner.

    ``tire_force{s}`` in the log is the dynamic part (total minus static, positive = more compression), so
    ``tire_load_rms_rel{s}`` = RMS(F_dyn)/F_static, the usual road-holding measure (1/3 means the tire
    lifts off about 0.1 % of the time for Gaussian loads).
    """
    out = {}
    for s in run.suffixes:
        f = run.col(f"tire_force{s}")
        static = float(run.static_tire_force[s])
        r = rms(f)
        out[f"tire_force_rms{s}"] = r
        out[f"tire_force_peak{s}"] = peak(f)
        out[f"tire_load_rms_rel{s}"] = r / static if static > 0 else float("nan")
    return out


@ensemble_version(tire_load, channels=("tire_force{s}",))
def _tire_load_many(ens: EnsembleView) -> dict:
    out = {}
    for s in ens.suffixes:
        f = ens.col(f"tire_force{s}")
        static = np.asarray(ens.static_tire_force[s], dtype=float)
        r = rms_rows(f)
        out[f"tire_force_rms{s}"] = r
        out[f"tire_force_peak{s}"] = peak_rows(f)
        with np.errstate(divide="ignore", invalid="ignore"):
            out[f"tire_load_rms_rel{s}"] = np.where(static > 0, r / np.where(static > 0, static, 1.0), np.nan)
    return out


@stream_version(tire_load)
class _TireLoadStream(CornerRmsPeakStream):
    channel = key = "tire_force"

    def more(self, s: str, rms: np.ndarray) -> dict:
        static = np.asarray(self.meta.static_tire_force[s], dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return {f"tire_load_rms_rel{s}": np.where(static > 0, rms / np.where(static > 0, static, 1.0), np.nan)}
