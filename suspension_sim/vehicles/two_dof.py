"""2-DOF bounce model with two actuators (``models/two_dof.xml``): the thesis's Ch. 6 example
(Vallurupalli 1996, Eqs. 6.36–6.40): secondary mass M_s over a primary mass M_p over the ground.

Coordinates (thesis): z_s = x_s − x_p (secondary deflection), z_p = x_p − w (primary deflection).
Secondary: M_s(z̈_s + z̈_p) + C_s ż_s + K_s z_s = −M_s ẅ + u_s.  Primary:
M_p z̈_p − K_s z_s − C_s ż_s + K_p z_p + F sgn ż_p + C_p |ż_p| ż_p + K_es S*(z_p − (D/2) sgn z_p)
= −M_p ẅ + u_p − u_s.

Why a new model rather than the quarter car: the thesis's primary actuator u_p acts between the primary
mass and the ground, which the quarter car (one actuator, between body and wheel) does not have.  Here
each actuator is one "corner": ``secondary`` (travel = z_s, actuator u_s) and ``primary`` (travel = z_p,
actuator u_p).  Both corners have ``has_tire = False``; the primary's nonlinear elements (Coulomb friction
F = 100 N, velocity-squared damping C_p = 200 N·s²/m², limit stops K_es = 7 kN/m) are effects on corner
``primary``.  Caveat of this mapping: the per-corner sensors ``corner_body_*`` and ``wheel_*`` do not have
their usual meaning (the secondary corner's "wheel" is a dummy road plate); use ``body_*``, ``travel``,
``travel_rate``, ``road`` and ``road_vel``.  A quarter car with effects on its tire would have the right
passive structure but no u_p.

Defaults: thesis Ch. 6 values M_s = 85 kg, M_p = 4.5 kg, K_s = 31.5 kN/m, K_p = 8.7 kN/m, C_s = 100 N·s/m
(linear); primary linear damping 0 (the thesis's C_p is velocity-squared: the ``quadratic_damping`` effect).
"""
from __future__ import annotations

from pydantic import Field

from ..components import Params
from ..registry import VEHICLES
from .base import Corner, Vehicle, set_body_mass, set_tendon


class TwoDOFParams(Params):
    sprung_mass: float = Field(85.0, gt=0, description="M_s, secondary mass (kg)")
    primary_mass: float = Field(4.5, gt=0, description="M_p, primary mass (kg)")
    secondary_stiffness: float = Field(31500.0, ge=0, description="K_s (N/m)")
    secondary_damping: float = Field(100.0, ge=0, description="C_s linear (N·s/m)")
    primary_stiffness: float = Field(8700.0, gt=0, description="K_p (N/m)")
    primary_damping: float = Field(0.0, ge=0, description="linear primary damping (N·s/m); the thesis's C_p is quadratic")


@VEHICLES.register("two_dof")
class TwoDOF(Vehicle):
    """2-DOF bounce model (thesis Ch. 6): secondary and primary stages, each with its own actuator."""

    xml = "two_dof.xml"
    Params = TwoDOFParams
    body_joints = ("body_z",)

    @classmethod
    def corners(cls, p):
        return [Corner("secondary", "_secondary", 0.0, has_tire=False),
                Corner("primary", "_primary", 0.0, has_tire=False)]

    @classmethod
    def apply_params(cls, root, p):
        set_body_mass(root, "body", p.sprung_mass)
        set_body_mass(root, "primary", p.primary_mass)
        set_tendon(root, "suspension_secondary", p.secondary_stiffness, p.secondary_damping)
        set_tendon(root, "suspension_primary", p.primary_stiffness, p.primary_damping)

    @classmethod
    def wheelbase(cls, p) -> float:
        return 0.0

    @classmethod
    def variation_targets(cls, p):
        return {
            "sprung_mass": [("body_mass", "body", 0)],
            "primary_mass": [("body_mass", "primary", 0)],
            "secondary_stiffness": [("tendon_stiffness", "suspension_secondary", 0)],
            "secondary_damping": [("tendon_damping", "suspension_secondary", 0)],
            "primary_stiffness": [("tendon_stiffness", "suspension_primary", 0)],
            "primary_damping": [("tendon_damping", "suspension_primary", 0)],
        }
