"""The built-in sensor types: body IMU quantities, corner quantities, LVDT travel, wheel accelerometers,
load cells, road height and preview."""
from __future__ import annotations

from typing import Literal

from pydantic import Field

from ..components import Params
from ..errors import ScenarioError
from ..registry import SENSORS
from .base import Sensor

# how an accelerometer samples when its scenario does not say (docs/sensors.md)
ACC_SAMPLING_DEFAULT = "instant"


class AccelerometerParams(Params):
    sampling: Literal["instant", "period_mean"] = Field(
        ACC_SAMPLING_DEFAULT,
        description="instant: the acceleration of the last physics step before the control instant; period_mean: "
                    "the mean over the control period that ends there, (v(t) − v(t − T))/T (a MEMS IMU's "
                    "decimation filter, a delta-velocity output), which does not depend on the physics step")


class _Accelerometer(Sensor):
    """An acceleration sensor: reads the PlantState field ``attr`` (``sampling: instant``) or its
    control-period mean ``attr + "_mean"`` (``sampling: period_mean``)."""

    Params = AccelerometerParams
    attr = "body_acc"

    def __init__(self, p, ctx):
        super().__init__(p, ctx)
        if p.sampling not in ("instant", "period_mean"):  # a list: the cars of an ensemble disagree
            raise ScenarioError("an accelerometer's sampling must be the same for every car of an ensemble",
                                field="sensors.params.sampling")

    def field_name(self) -> str:
        return self.attr + ("_mean" if self.p.sampling == "period_mean" else "")


def _corner(attr: str, unit: str, doc: str):
    def kernel_field(self):
        return attr, list(range(len(self.ctx.corners)))

    return type(attr.title().replace("_", ""), (Sensor,), {"kernel_field": kernel_field, "unit": unit, "__doc__": doc})


class _CornerAccelerometer(_Accelerometer):
    def kernel_field(self):
        return self.field_name(), list(range(len(self.ctx.corners)))


def _corner_acc(attr: str, unit: str, doc: str):
    return type(attr.title().replace("_", ""), (_CornerAccelerometer,), {"attr": attr, "unit": unit, "__doc__": doc})


class _Body(Sensor):
    attr = "body_pos"

    def labels(self):
        return list(self.ctx.body_joints)

    def kernel_field(self):
        return self.attr, list(range(len(self.ctx.body_joints)))


def _body(attr, unit, doc):
    return type(attr.title().replace("_", ""), (_Body,), {"attr": attr, "unit": unit, "__doc__": doc})


class _BodyAccelerometer(_Accelerometer, _Body):
    def kernel_field(self):
        return self.field_name(), list(range(len(self.ctx.body_joints)))


SENSORS.register("body_acc")(type("BodyAcc", (_BodyAccelerometer,), {
    "attr": "body_acc", "unit": "m/s^2, rad/s^2",
    "__doc__": "IMU at the c.g.: heave acceleration (and pitch/roll angular accelerations)."}))
SENSORS.register("body_vel")(_body("body_vel", "m/s, rad/s", "Body heave velocity and pitch/roll rates at the c.g. (an integrated accelerometer and gyros)."))
SENSORS.register("body_pos")(_body("body_pos", "m, rad", "Body heave, pitch and roll from equilibrium."))
SENSORS.register("corner_body_acc")(_corner_acc("corner_body_acc", "m/s^2", "Vertical acceleration of the body above each corner."))
SENSORS.register("corner_body_vel")(_corner("corner_body_vel", "m/s", "Vertical velocity of the body above each corner (integrated accelerometer)."))
SENSORS.register("corner_body_pos")(_corner("corner_body_pos", "m", "Vertical position of the body above each corner."))
SENSORS.register("wheel_acc")(_corner_acc("wheel_acc", "m/s^2", "Wheel (unsprung mass) vertical acceleration."))
SENSORS.register("wheel_vel")(_corner("wheel_vel", "m/s", "Wheel vertical velocity."))
SENSORS.register("wheel_pos")(_corner("wheel_pos", "m", "Wheel vertical position from equilibrium."))
SENSORS.register("travel")(_corner("travel", "m", "Suspension deflection (LVDT): body − wheel, positive = extension."))
SENSORS.register("travel_rate")(_corner("travel_rate", "m/s", "Suspension deflection rate."))
SENSORS.register("actuator_force")(_corner("actuator_force", "N", "Actuator force (load cell)."))
SENSORS.register("tire_force")(_corner("tire_force", "N", "Dynamic tire force (relative to the static load)."))
SENSORS.register("road")(_corner("road", "m", "Road height under each wheel (base position on a rig)."))
SENSORS.register("road_vel")(_corner("road_vel", "m/s", "Road height rate under each wheel (base velocity on a rig)."))


class ActuatorStateParams(Params):
    state: str = Field(..., description="name of the actuator state (e.g. spool_position, pressure, current)")


@SENSORS.register("actuator_state")
class ActuatorState(Sensor):
    """An internal actuator state (spool position, load pressure, coil current), per corner."""

    Params = ActuatorStateParams

    def read(self, s):
        if self.p.state not in s.actuator_states:
            from ..errors import ScenarioError

            raise ScenarioError(f"the actuator has no state {self.p.state!r} (it has {sorted(s.actuator_states)})",
                                field="sensors.params.state")
        return s.actuator_states[self.p.state]

    def kernel_field(self):
        return "actuator_state", list(range(len(self.ctx.corners)))


class PreviewParams(Params):
    distance: float = Field(..., gt=0, description="preview distance ahead of each wheel (m)")


@SENSORS.register("road_preview")
class RoadPreview(Sensor):
    """Road height a given distance ahead of each wheel (a look-ahead sensor)."""

    Params = PreviewParams
    unit = "m"

    def read(self, s):
        return s.extra["road_preview"](self.p.distance)
