"""SDOF rig (``models/sdof.xml``): the thesis's fail-safe single-degree-of-freedom suspension (Vallurupalli
1996, Ch. 3, 4 and 8): a mass M on a spring K, a damper C and the actuator in parallel, over a base moved
by the road input (the shaker plate of the rig).  There is no wheel and no tire: the one corner
(``single``, suffix ``""``) has ``has_tire = False``, its suspension tendon is ``body_z − road_z``, and
the logged ``travel`` is the relative displacement x − w of the thesis.

Defaults: Ch. 3 nominal values M* = 250 kg, K* = 5000 N/m, C* = 250 N·s/m (natural frequency
√(K/M) = 4.47 rad/s = 0.71 Hz, damping ratio 0.11).  Ch. 4's fail-safe plant replaces the linear damper by
velocity-squared damping (C_v = 250 N·s²/m²) and adds Coulomb friction and elastic stops: set
``damping: 0`` and add the ``quadratic_damping``, ``coulomb_friction`` and ``bump_stop`` effects.  With a
``flat`` road the base is at rest and the rig is driven by the actuator force alone (force input).
"""
from __future__ import annotations

from pydantic import Field

from ..components import Params
from ..registry import VEHICLES
from .base import Corner, Vehicle, set_body_mass, set_tendon


class SDOFParams(Params):
    sprung_mass: float = Field(250.0, gt=0, description="kg (thesis M)")
    spring_stiffness: float = Field(5000.0, ge=0, description="N/m (thesis K)")
    damping: float = Field(250.0, ge=0, description="N·s/m (thesis C, linear)")


@VEHICLES.register("sdof")
class SDOF(Vehicle):
    """SDOF rig: one mass on a spring/damper/actuator over a moving base; no tire."""

    xml = "sdof.xml"
    Params = SDOFParams
    body_joints = ("body_z",)

    @classmethod
    def corners(cls, p):
        return [Corner("single", "", 0.0, has_tire=False)]

    @classmethod
    def apply_params(cls, root, p):
        set_body_mass(root, "body", p.sprung_mass)
        set_tendon(root, "suspension", p.spring_stiffness, p.damping)

    @classmethod
    def variation_targets(cls, p):
        return {
            "sprung_mass": [("body_mass", "body", 0)],
            "spring_stiffness": [("tendon_stiffness", "suspension", 0)],
            "damping": [("tendon_damping", "suspension", 0)],
        }
