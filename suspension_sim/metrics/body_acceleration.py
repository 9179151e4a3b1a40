"""RMS and peak body (heave) acceleration."""
import numpy as np

from ..registry import METRICS
from .base import RunView, rms


@METRICS.register("body_acc")
def body_acc(run: RunView) -> dict:
    """RMS and peak heave acceleration of the body at the c.g. (m/s²)."""
    a = run.ts["body_acc"].to_numpy()
    return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}
