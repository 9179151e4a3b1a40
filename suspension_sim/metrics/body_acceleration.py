"""RMS and peak body (heave) acceleration."""
import numpy as np

from ..registry import METRICS
from .base import EnsembleView, Reductions, RunView, ensemble_version, rms, rms_rows, stream_version


@METRICS.register("body_acc")
def body_acc(run: RunView) -> dict:
    """RMS and peak heave acceleration of the body at the c.g. (m/s²)."""
    a = run.col("body_acc")
    return {"body_acc_rms": rms(a), "body_acc_peak": float(np.max(np.abs(a)))}


@ensemble_version(body_acc, channels=("body_acc",))
def _body_acc_many(ens: EnsembleView) -> dict:
    a = ens.col("body_acc")
    return {"body_acc_rms": rms_rows(a), "body_acc_peak": np.max(np.abs(a), axis=1)}


@stream_version(body_acc)
class _BodyAccStream:
    def __init__(self, meta: EnsembleView):
        self.n, self.r = meta.n_cars, Reductions()

    def update(self, ens: EnsembleView) -> None:
        a = ens.col("body_acc")
        self.r.start(ens)
        self.r.sum("ss", a * a)
        self.r.max("pk", np.abs(a))

    def result(self) -> dict:
        return {"body_acc_rms": self.r.rms("ss", self.n), "body_acc_peak": self.r.get("pk", self.n)}
