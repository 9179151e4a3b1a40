"""Body pitch and roll: peak and RMS angle, RMS angular acceleration (models that have them)."""
from ..registry import METRICS
from ._util import peak
from .base import EnsembleView, RunView, ensemble_version, peak_rows, rms, rms_rows


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
