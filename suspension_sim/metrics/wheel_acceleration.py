"""RMS and peak wheel (unsprung mass) acceleration per corner."""
from ..registry import METRICS
from .base import CornerRmsPeak, metric


@METRICS.register("wheel_acc")
@metric
class WheelAcc(CornerRmsPeak):
    """RMS and peak vertical wheel acceleration per corner (m/s²)."""

    channel = key = "wheel_acc"
