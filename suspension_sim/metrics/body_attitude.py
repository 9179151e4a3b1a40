"""Body pitch and roll: peak and RMS angle, RMS angular acceleration (models that have them)."""
from ..registry import METRICS
from .base import Accumulator, metric


class _Attitude(Accumulator):
    """Peak and RMS angle of degree of freedom :attr:`dof`, RMS and peak of its acceleration if logged."""

    dof = ""

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        cls.channels = (cls.dof, f"{cls.dof}_acc")

    def __init__(self, meta):
        super().__init__(meta)
        self.has_acc = False

    def update(self, chunk) -> None:
        d = self.dof
        self.r.start(chunk)
        self.r.rms_peak("ang", chunk.held(d))
        if chunk.has(f"{d}_acc"):
            self.has_acc = True
            self.r.rms_peak("acc", chunk.held(f"{d}_acc"))

    def result(self) -> dict:
        d = self.dof
        out = {f"{d}_peak": self.r.peak("ang"), f"{d}_rms": self.r.rms("ang")}
        if self.has_acc:
            out[f"{d}_acc_rms"] = self.r.rms("acc")
            out[f"{d}_acc_peak"] = self.r.peak("acc")
        return out


@METRICS.register("pitch")
@metric
class Pitch(_Attitude):
    """Peak and RMS pitch angle (rad, positive nose down) and RMS/peak pitch acceleration (rad/s²)."""

    dof = "pitch"


@METRICS.register("roll")
@metric
class Roll(_Attitude):
    """Peak and RMS roll angle (rad, positive right side down) and RMS/peak roll acceleration (rad/s²)."""

    dof = "roll"
