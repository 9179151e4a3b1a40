"""Body pitch and roll: peak and RMS angle, RMS angular acceleration (models that have them)."""
from ..registry import METRICS
from ._util import peak
from .base import RunView, rms


def _attitude(run: RunView, dof: str) -> dict:
    ang = run.ts[dof].to_numpy()
    out = {f"{dof}_peak": peak(ang), f"{dof}_rms": rms(ang)}
    if f"{dof}_acc" in run.ts:
        acc = run.ts[f"{dof}_acc"].to_numpy()
        out[f"{dof}_acc_rms"] = rms(acc)
        out[f"{dof}_acc_peak"] = peak(acc)
    return out


@METRICS.register("pitch")
def pitch(run: RunView) -> dict:
    """Peak and RMS pitch angle (rad, positive nose down) and RMS/peak pitch acceleration (rad/s²)."""
    return _attitude(run, "pitch")


@METRICS.register("roll")
def roll(run: RunView) -> dict:
    """Peak and RMS roll angle (rad, positive right side down) and RMS/peak roll acceleration (rad/s²)."""
    return _attitude(run, "roll")
