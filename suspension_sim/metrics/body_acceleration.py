"""RMS and peak body (heave) acceleration."""
import numpy as np

from ..registry import METRICS
from .base import EnsembleView, RunView, ensemble_version, rms, rms_rows


@METRICS.register("body_acc")
def body_acc(run: RunView) -> dict:
    """RMS and peak heave acceleration of the body at the c.g. (m/s²)."""
    a = run.col("body_acc")
    return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}


@ensemble_version(body_acc, channels=("body_acc",))
def _body_acc_many(ens: EnsembleView) -> dict:
    a = ens.col("body_acc")
    return {"body_acc_rms": rms_rows(a), "body_acc_peak": np.max(np.abs(a), axis=1)}
