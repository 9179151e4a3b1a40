"""Half car (``models/half_car.xml``): body bounce ``body_z`` and pitch ``pitch`` (positive = nose down,
hinge about +y at the c.g.), front and rear wheels on vertical slides at x = +a and x = −b, road plates
under them; suspensions and tires as fixed tendons (see the XML's header for the tendon definitions).

Corners ``front`` (suffix ``_front``, x = +a) and ``rear`` (``_rear``, x = −b).  The simulation loop
delays the rear road input: the rear wheel sees the road at the corner time at which the front axle was
where the rear wheel is now (``(a + b)/speed`` at constant speed).

Defaults: the thesis's Ch. 7 half car (Vallurupalli 1996, Ch. 2 Eq. 2.9–2.10 and Ch. 7): sprung mass
500 kg, pitch inertia 500·1.5² = 1125 kg·m², a = d1 = b = d2 = 1.5 m, springs 17 kN/m per axle, tires
100 kN/m.  Not given by the thesis, chosen here:

- ``unsprung_mass_front/rear`` = 45 kg per axle.  The 500 kg half car carries one wheel per axle; 45 kg
  gives an unsprung/sprung ratio per axle of 45/250 = 0.18, close to the thesis's Porsche 928 data
  (56 kg per wheel for 1385/4 ≈ 346 kg of body per corner, 0.16), and a wheel-hop frequency
  √((17000 + 100000)/45)/2π ≈ 8.1 Hz, like the 8.6 Hz the thesis quotes for the Porsche.
- ``damping_front/rear`` = 1250 N·s/m (linear).  The thesis's C = 2500 is the coefficient of a
  velocity-squared damper in Ch. 7 (N·s²/m²; Ch. 2 lists the same 2500 with linear units).  The linear
  default gives the same force as the quadratic damper at 0.5 m/s and a body-bounce damping ratio
  1250/(2√(17000·250)) ≈ 0.30 per axle, a typical passenger-car value.  The velocity-squared damper is the
  ``quadratic_damping`` effect (set these to 0 and add it); the thesis's Ch. 2 reading, 2500 N·s/m linear,
  gives ζ ≈ 0.61.
- ``cg_height`` h = 1.25 m (used by manoeuvre load transfer, pitch moment M_s·a_x·h).  Chosen to
  reproduce the thesis's "load shift of the order of 60 %": braking at 7 m/s² moves
  M_s·a_x·h/L = 500·7·1.25/3 = 1458 N onto the front axle, 59 % of its static sprung load
  M_s·g·b/L = 2453 N (thesis Eqs. 2.9–2.10).  This is high for a real car (≈ 0.5 m); set it per scenario.
  Measured with these defaults in the thesis's manoeuvre (``accel_brake``, 4 m/s² for 8 s then 7 m/s² for
  2 s, with ``cg_height: 1.25`` given to the manoeuvre): the passive car pitches 3.2° nose up while
  accelerating and peaks at 6.6° nose down when braking starts (the thesis reports about 6°); statically
  the braking moment alone gives 3.8° (pitch stiffness 2·(k·k_t/(k+k_t))·a² = 65.4 kN·m/rad), the rest is
  the step from −4 to +7 m/s² and the overshoot of the pitch mode (ζ ≈ 0.24).

Positions are from the static equilibrium (the tendon spring lengths carry the static loads, computed for
the actual parameters, so a ≠ b and front/rear differences are handled).
"""
from __future__ import annotations

from pydantic import Field

from ..components import Params
from ..registry import VEHICLES
from .base import Corner, Vehicle, set_body_mass, set_tendon, size_body_box


class HalfCarParams(Params):
    sprung_mass: float = Field(500.0, gt=0, description="kg")
    pitch_inertia: float = Field(1125.0, gt=0, description="kg·m², about the c.g. (y axis)")
    unsprung_mass_front: float = Field(45.0, gt=0, description="kg (one wheel per axle)")
    unsprung_mass_rear: float = Field(45.0, gt=0, description="kg")
    spring_stiffness_front: float = Field(17000.0, ge=0, description="N/m")
    spring_stiffness_rear: float = Field(17000.0, ge=0, description="N/m")
    damping_front: float = Field(1250.0, ge=0, description="N·s/m (linear)")
    damping_rear: float = Field(1250.0, ge=0, description="N·s/m (linear)")
    tire_stiffness_front: float = Field(100000.0, gt=0, description="N/m")
    tire_stiffness_rear: float = Field(100000.0, gt=0, description="N/m")
    tire_damping_front: float = Field(0.0, ge=0, description="N·s/m")
    tire_damping_rear: float = Field(0.0, ge=0, description="N·s/m")
    a: float = Field(1.5, gt=0, description="m, c.g. to front axle (thesis d1)")
    b: float = Field(1.5, gt=0, description="m, c.g. to rear axle (thesis d2)")
    cg_height: float = Field(1.25, gt=0, description="m, c.g. height above the road (manoeuvre load transfer)")


@VEHICLES.register("half_car")
class HalfCar(Vehicle):
    """Half car: body bounce + pitch, front and rear wheel hop, linear springs/dampers, tire springs."""

    xml = "half_car.xml"
    Params = HalfCarParams
    body_joints = ("body_z", "pitch")

    @classmethod
    def corners(cls, p):
        return [Corner("front", "_front", float(p.a)), Corner("rear", "_rear", -float(p.b))]

    @classmethod
    def apply_params(cls, root, p):
        a, b = float(p.a), float(p.b)
        body = root.find("body", "body")
        set_body_mass(root, "body", p.sprung_mass)
        iyy = float(p.pitch_inertia)
        # only the pitch axis has a joint; the other two moments just keep the inertia physical
        body.inertial.diaginertia = [0.25 * iyy, iyy, iyy]
        for s, x in (("front", a), ("rear", -b)):
            set_body_mass(root, f"wheel_{s}", getattr(p, f"unsprung_mass_{s}"))
            wheel, road = root.find("body", f"wheel_{s}"), root.find("body", f"road_{s}")
            wheel.pos = [x, wheel.pos[1], wheel.pos[2]]
            road.pos = [x, road.pos[1], road.pos[2]]
            set_tendon(root, f"suspension_{s}", getattr(p, f"spring_stiffness_{s}"), getattr(p, f"damping_{s}"))
            set_tendon(root, f"tire_{s}", getattr(p, f"tire_stiffness_{s}"), getattr(p, f"tire_damping_{s}"))
            # travel = body_z - x*pitch - wheel_z (pitch positive = nose down: the front end moves down)
            for elem in root.find("tendon", f"suspension_{s}").joint:
                if getattr(elem.joint, "name", elem.joint) == "pitch":  # a reference to the joint element
                    elem.coef = -x
        size_body_box(root, a, b)

    @classmethod
    def variation_targets(cls, p):
        out = {
            "sprung_mass": [("body_mass", "body", 0)],
            "pitch_inertia": [("body_inertia", "body", 1)],
        }
        for s in ("front", "rear"):
            out[f"unsprung_mass_{s}"] = [("body_mass", f"wheel_{s}", 0)]
            out[f"spring_stiffness_{s}"] = [("tendon_stiffness", f"suspension_{s}", 0)]
            out[f"damping_{s}"] = [("tendon_damping", f"suspension_{s}", 0)]
            out[f"tire_stiffness_{s}"] = [("tendon_stiffness", f"tire_{s}", 0)]
            out[f"tire_damping_{s}"] = [("tendon_damping", f"tire_{s}", 0)]
        return out
