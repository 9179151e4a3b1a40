"""RMS and peak wheel (unsprung mass) acceleration per corner."""
from ..registry import METRICS
from ._util import peak
import numpy as np

from .base import CornerRmsPeakStream, EnsembleView, RunView, ensemble_version, peak_rows, rms, rms_rows, stream_version


@METRICS.register("wheel_acc")
def wheel_acc(run: RunView) -> dict:
    """RMS and peak vertical wheel acceleration per corner (m/s²)."""
    out = {}
    for s in run.suffixes:
        a = run.col(f"wheel_acc{s}")
        out[f"wheel_acc_rms{s}"] = rms(a)
        out[f"wheel_acc_peak{s}"] = peak(a)
    return out


@ensemble_version(wheel_acc, channels=("wheel_acc{s}",))
def _wheel_acc_many(ens: EnsembleView) -> dict:
    out = {}
    for s in ens.suffixes:
        a = ens.col(f"wheel_acc{s}")
        out[f"wheel_acc_rms{s}"] = rms_rows(a)
        out[f"wheel_acc_peak{s}"] = peak_rows(a)
    return out


@stream_version(wheel_acc)
class _WheelAccStream(CornerRmsPeakStream):
    channel = key = "wheel_acc"
