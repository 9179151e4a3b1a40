"""Quarter car (``models/quarter_car.xml``): road plate, wheel and body on vertical slides; suspension
spring/damper and tire as fixed tendons.  Defaults: the Alleyne–Hedrick quarter car used by Kim and by
Lin & Kanellakopoulos (290 kg, 59 kg, 16812 N/m, 1000 N·s/m, tire 190000 N/m)."""
from __future__ import annotations

from pydantic import Field

from ..components import Params
from ..registry import VEHICLES
from .base import Corner, Vehicle, set_body_mass, set_tendon


class QuarterCarParams(Params):
    sprung_mass: float = Field(290.0, gt=0, description="kg")
    unsprung_mass: float = Field(59.0, gt=0, description="kg")
    spring_stiffness: float = Field(16812.0, ge=0, description="N/m")
    damping: float = Field(1000.0, ge=0, description="N·s/m")
    tire_stiffness: float = Field(190000.0, gt=0, description="N/m")
    tire_damping: float = Field(0.0, ge=0, description="N·s/m")


@VEHICLES.register("quarter_car")
class QuarterCar(Vehicle):
    """Quarter car: sprung and unsprung mass, linear spring/damper, point-contact tire spring."""

    xml = "quarter_car.xml"
    Params = QuarterCarParams
    body_joints = ("body_z",)

    @classmethod
    def corners(cls, p):
        return [Corner("single", "", 0.0)]

    @classmethod
    def apply_params(cls, root, p):
        set_body_mass(root, "body", p.sprung_mass)
        set_body_mass(root, "wheel", p.unsprung_mass)
        set_tendon(root, "suspension", p.spring_stiffness, p.damping)
        set_tendon(root, "tire", p.tire_stiffness, p.tire_damping)

    @classmethod
    def variation_targets(cls, p):
        return {
            "sprung_mass": [("body_mass", "body", 0)],
            "unsprung_mass": [("body_mass", "wheel", 0)],
            "spring_stiffness": [("tendon_stiffness", "suspension", 0)],
            "damping": [("tendon_damping", "suspension", 0)],
            "tire_stiffness": [("tendon_stiffness", "tire", 0)],
            "tire_damping": [("tendon_damping", "tire", 0)],
        }
