"""Body pitch and roll: peak and RMS angle, RMS angular acceleration (models that have them)."""
from ..registry import METRICS
from ._util import peak
import numpy as np

from .base import EnsembleView, Reductions, RunView, ensemble_version, peak_rows, rms, rms_rows, stream_version


def _attitude(run: RunView, dof: str) -> dict:
    ang = run.col(dof)
    out = {f"{dof}_peak": peak(ang), f"{dof}_rms": rms(ang)}
    if run.has(f"{dof}_acc"):
        acc = run.col(f"{dof}_acc")
        out[f"{dof}_acc_rms"] = rms(acc)
        out[f"{dof}_acc_peak"] = peak(acc)
    return out


def _attitude_many(ens: EnsembleView, dof: str) -> dict:
    ang = ens.col(dof)
    out = {f"{dof}_peak": peak_rows(ang), f"{dof}_rms": rms_rows(ang)}
    if ens.has(f"{dof}_acc"):
        acc = ens.col(f"{dof}_acc")
        out[f"{dof}_acc_rms"] = rms_rows(acc)
        out[f"{dof}_acc_peak"] = peak_rows(acc)
    return out


@METRICS.register("pitch")
def pitch(run: RunView) -> dict:
    """Peak and RMS pitch angle (rad, positive nose down) and RMS/peak pitch acceleration (rad/s²)."""
    return _attitude(run, "pitch")


@METRICS.register("roll")
def roll(run: RunView) -> dict:
    """Peak and RMS roll angle (rad, positive right side down) and RMS/peak roll acceleration (rad/s²)."""
    return _attitude(run, "roll")


@ensemble_version(pitch, channels=("pitch", "pitch_acc"))
def _pitch_many(ens: EnsembleView) -> dict:
    return _attitude_many(ens, "pitch")


@ensemble_version(roll, channels=("roll", "roll_acc"))
def _roll_many(ens: EnsembleView) -> dict:
    return _attitude_many(ens, "roll")


class _AttitudeStream:
    dof = ""

    def __init__(self, meta: EnsembleView):
        self.meta, self.r, self.has_acc = meta, Reductions(), False

    def update(self, ens: EnsembleView) -> None:
        self.r.start(ens)
        d = self.dof
        ang = ens.col(d)
        self.r.sum("ss", ang * ang)
        self.r.max("pk", np.abs(ang))
        if ens.has(f"{d}_acc"):
            self.has_acc = True
            acc = ens.col(f"{d}_acc")
            self.r.sum("ss_acc", acc * acc)
            self.r.max("pk_acc", np.abs(acc))

    def result(self) -> dict:
        n, d = self.meta.n_cars, self.dof
        out = {f"{d}_peak": self.r.get("pk", n), f"{d}_rms": self.r.rms("ss", n)}
        if self.has_acc:
            out[f"{d}_acc_rms"] = self.r.rms("ss_acc", n)
            out[f"{d}_acc_peak"] = self.r.get("pk_acc", n)
        return out


@stream_version(pitch)
class _PitchStream(_AttitudeStream):
    dof = "pitch"


@stream_version(roll)
class _RollStream(_AttitudeStream):
    dof = "roll"
