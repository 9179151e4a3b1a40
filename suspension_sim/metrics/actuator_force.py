"""RMS and peak actuator force per corner."""
from ..registry import METRICS
from .base import CornerRmsPeak, metric


@METRICS.register("actuator_force")
@metric
class ActuatorForce(CornerRmsPeak):
    """RMS and peak (max |F|) delivered actuator force per corner (N); zero for a passive run."""

    channel = key = "actuator_force"
