"""RMS and peak body (heave) acceleration."""
from ..registry import METRICS
from .base import Accumulator, metric


@METRICS.register("body_acc")
@metric
class BodyAcc(Accumulator):
    """RMS and peak heave acceleration of the body at the c.g. (m/s²)."""

    channels = ("body_acc",)

    def update(self, chunk) -> None:
        self.r.start(chunk)
        self.r.rms_peak("a", chunk.held("body_acc"))

    def result(self) -> dict:
        return {"body_acc_rms": self.r.rms("a"), "body_acc_peak": self.r.peak("a")}
