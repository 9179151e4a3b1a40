"""Rate gyros of a body-fixed IMU: the angular rates of the body's rotational joints (pitch rate about +y,
roll rate about +x, rad/s, in the order of the model's body joints; empty for models without them).

Small-angle model: the body joints are the world-frame pitch and roll angles, so their rates are what a
gyro at the c.g. reads (yaw is not modelled).  The heave accelerometer of the IMU is the first component
of the ``body_acc`` sensor."""
from __future__ import annotations

from ..registry import SENSORS
from .base import Sensor


@SENSORS.register("gyro")
class Gyro(Sensor):
    """IMU rate gyros: pitch and roll rates of the body (rad/s), the model's rotational body joints."""

    unit = "rad/s"

    def _cols(self):
        return [k for k, j in enumerate(self.ctx.body_joints) if j != "body_z"]

    def labels(self):
        return [self.ctx.body_joints[k] for k in self._cols()]

    def kernel_field(self):
        return "body_vel", self._cols()
