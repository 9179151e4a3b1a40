"""RMS and peak actuator force per corner."""
from ..registry import METRICS
from ._util import peak
import numpy as np

from .base import CornerRmsPeakStream, EnsembleView, RunView, ensemble_version, peak_rows, rms, rms_rows, stream_version


@METRICS.register("actuator_force")
def actuator_force(run: RunView) -> dict:
    """RMS and peak (max |F|) delivered actuator force per corner (N); zero for a passive run."""
    out = {}
    for s in run.suffixes:
        f = run.col(f"actuator_force{s}")
        out[f"actuator_force_rms{s}"] = rms(f)
        out[f"actuator_force_peak{s}"] = peak(f)
    return out


@ensemble_version(actuator_force, channels=("actuator_force{s}",))
def _actuator_force_many(ens: EnsembleView) -> dict:
    out = {}
    for s in ens.suffixes:
        f = ens.col(f"actuator_force{s}")
        out[f"actuator_force_rms{s}"] = rms_rows(f)
        out[f"actuator_force_peak{s}"] = peak_rows(f)
    return out


@stream_version(actuator_force)
class _ActuatorForceStream(CornerRmsPeakStream):
    channel = key = "actuator_force"
