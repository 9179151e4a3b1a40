"""Full car (``models/full_car.xml``): body bounce ``body_z``, pitch ``pitch`` (positive = nose down, hinge
about +y) and roll ``roll`` (positive = right side down, hinge about +x), four wheels on vertical slides,
four road plates; suspensions, tires and (optional) anti-roll bars as fixed tendons (see the XML header).

Corners ``fl``, ``fr``, ``rl``, ``rr`` (suffixes ``_fl`` ...) at (x, y) = (+a, ±t_f/2), (−b, ±t_r/2), y left
positive; left wheels on road track 0, right wheels on track 1.  The simulation delays the rear road input
by the wheelbase (each axle meets a spatial bump when its own distance reaches it).

Default parameters: a mid-size passenger sedan.  The paper it serves (Fallah, Sorniotti & Gruber) uses an
IPG CarMaker car whose data are only shown as unreadable figures, so the values are chosen, from these
sources:

- mass and c.g. position: the mid-size sedan of R. Rajamani, *Vehicle Dynamics and Control* (2nd ed.,
  Springer 2012), used there for the lateral (bicycle) model: total mass 1573 kg, l_f = 1.10 m,
  l_r = 1.58 m (wheelbase 2.68 m), yaw inertia 2873 kg·m² (as commonly quoted from that book; not re-checked
  against the printed table when this was written).  Unsprung masses chosen 40 kg (front, with
  brakes and hub carrier) and 35 kg (rear) per wheel, so the sprung mass is 1573 − 150 = 1423 kg → 1413 kg
  rounded down for a little non-suspended mass (drive shafts, half of the links).
- body inertias (not in Rajamani's table for this car, chosen): roll I_xx = 500 kg·m², pitch
  I_yy = 2100 kg·m² (radii of gyration 0.59 m and 1.22 m, the usual 0.4·track and 0.45·wheelbase).
- ride rates from the guidelines of T.D. Gillespie, *Fundamentals of Vehicle Dynamics* (SAE 1992, Ch. 5):
  body natural frequencies near 1 Hz with the rear 10–20 % above the front, damping ratios 0.2–0.4.
  With the corner sprung masses m_s·l_r/(2L) = 416.5 kg (front) and 290 kg (rear): springs 20000 N/m and
  19500 N/m give 1.10 Hz and 1.30 Hz; dampers 1700 and 1450 N·s/m give ζ ≈ 0.29 and 0.30 (linear dampers;
  add ``asymmetric_damping`` for compression/rebound asymmetry).
- tires 200 kN/m (a 205/55 R16 passenger tire at ~2.2 bar: 180–250 kN/m), wheel hop ≈ 11.8 Hz front.
- track 1.55 m front and rear (a 4.8 m × 1.8 m sedan), c.g. height 0.55 m.
- anti-roll bars 25000 N/m front and 10000 N/m rear (of differential travel): roll stiffness
  k·t²/2 per axle from the springs + k_arb·t² from the bars = 84 kN·m/rad front, 47 kN·m/rad rear; in series
  with the tires (k_t·t²/2 = 240 kN·m/rad per axle) 62 + 40 = 102 kN·m/rad, a front share of 61 %
  (understeering) and a roll gradient m_s·g·h/K_φ ≈ 3.9 °/g with the manoeuvre arm h = 0.5 m above the roll
  axis (passenger cars: 3–7 °/g, Gillespie Ch. 9; the model has no gravity moment about the roll axis, the
  c.g. lies on it).  Set ``arb_front``/``arb_rear`` to 0 for no bars (the roll gradient then is ≈ 9 °/g).

Positions are from the static equilibrium (spring lengths carry the static loads, computed for the actual
parameters).  The tendon coefficients are the small-angle kinematics; the test checks them against MuJoCo's
hinge kinematics of the body sites above the corners.
"""
from __future__ import annotations

from pydantic import Field

from ..components import Params
from ..registry import VEHICLES
from .base import Corner, Vehicle, set_body_mass, set_tendon, size_body_box

CORNERS = ("fl", "fr", "rl", "rr")


class FullCarParams(Params):
    sprung_mass: float = Field(1413.0, gt=0, description="kg")
    roll_inertia: float = Field(500.0, gt=0, description="kg·m², about the c.g. (x axis)")
    pitch_inertia: float = Field(2100.0, gt=0, description="kg·m², about the c.g. (y axis)")
    yaw_inertia: float = Field(2300.0, gt=0, description="kg·m² (no yaw joint; keeps the inertia physical)")
    unsprung_mass_front: float = Field(40.0, gt=0, description="kg per wheel")
    unsprung_mass_rear: float = Field(35.0, gt=0, description="kg per wheel")
    spring_stiffness_front: float = Field(20000.0, ge=0, description="N/m per corner")
    spring_stiffness_rear: float = Field(19500.0, ge=0, description="N/m per corner")
    damping_front: float = Field(1700.0, ge=0, description="N·s/m per corner (linear)")
    damping_rear: float = Field(1450.0, ge=0, description="N·s/m per corner (linear)")
    tire_stiffness_front: float = Field(200000.0, gt=0, description="N/m per wheel")
    tire_stiffness_rear: float = Field(200000.0, gt=0, description="N/m per wheel")
    tire_damping_front: float = Field(0.0, ge=0, description="N·s/m")
    tire_damping_rear: float = Field(0.0, ge=0, description="N·s/m")
    arb_front: float = Field(25000.0, ge=0, description="front anti-roll bar, N/m of left−right travel difference")
    arb_rear: float = Field(10000.0, ge=0, description="rear anti-roll bar, N/m of left−right travel difference")
    a: float = Field(1.10, gt=0, description="m, c.g. to front axle")
    b: float = Field(1.58, gt=0, description="m, c.g. to rear axle")
    track_front: float = Field(1.55, gt=0, description="m")
    track_rear: float = Field(1.55, gt=0, description="m")
    cg_height: float = Field(0.55, gt=0, description="m, c.g. height above the road (information; the manoeuvre "
                                                     "takes its own arm above the roll/pitch axis)")


def corner_geometry(p) -> dict[str, tuple[float, float]]:
    """(x, y) of each corner from the c.g. (x forward, y left)."""
    a, b, tf, tr = float(p.a), float(p.b), float(p.track_front), float(p.track_rear)
    return {"fl": (a, 0.5 * tf), "fr": (a, -0.5 * tf), "rl": (-b, 0.5 * tr), "rr": (-b, -0.5 * tr)}


def _axle(c: str) -> str:
    return "front" if c[0] == "f" else "rear"


def _set_coefs(root, tendon: str, coefs: dict[str, float]) -> None:
    for elem in root.find("tendon", tendon).joint:
        name = getattr(elem.joint, "name", elem.joint)  # dm_control gives an element reference
        if name in coefs:
            elem.coef = float(coefs[name])


@VEHICLES.register("full_car")
class FullCar(Vehicle):
    """Full car: body bounce, pitch and roll, four wheels, linear springs/dampers, tire springs, anti-roll bars."""

    xml = "full_car.xml"
    Params = FullCarParams
    body_joints = ("body_z", "pitch", "roll")

    @classmethod
    def corners(cls, p):
        g = corner_geometry(p)
        return [Corner(c, f"_{c}", g[c][0], g[c][1], track=0 if c[1] == "l" else 1) for c in CORNERS]

    @classmethod
    def apply_params(cls, root, p):
        g = corner_geometry(p)
        set_body_mass(root, "body", p.sprung_mass)
        root.find("body", "body").inertial.diaginertia = [float(p.roll_inertia), float(p.pitch_inertia),
                                                          float(p.yaw_inertia)]
        for c in CORNERS:
            x, y = g[c]
            ax = _axle(c)
            set_body_mass(root, f"wheel_{c}", getattr(p, f"unsprung_mass_{ax}"))
            for body in (f"wheel_{c}", f"road_{c}"):
                el = root.find("body", body)
                el.pos = [x, y, el.pos[2]]
            root.find("site", f"corner_{c}").pos = [x, y, 0.0]
            set_tendon(root, f"suspension_{c}", getattr(p, f"spring_stiffness_{ax}"), getattr(p, f"damping_{ax}"))
            set_tendon(root, f"tire_{c}", getattr(p, f"tire_stiffness_{ax}"), getattr(p, f"tire_damping_{ax}"))
            # travel = body_z − x·pitch + y·roll − wheel_z (nose-down pitch lowers the front, positive roll
            # lowers the right side, y < 0)
            _set_coefs(root, f"suspension_{c}", {"pitch": -x, "roll": y})
        set_tendon(root, "arb_front", p.arb_front, 0.0)
        set_tendon(root, "arb_rear", p.arb_rear, 0.0)
        _set_coefs(root, "arb_front", {"roll": float(p.track_front)})
        _set_coefs(root, "arb_rear", {"roll": float(p.track_rear)})
        size_body_box(root, float(p.a), float(p.b), 0.5 * max(float(p.track_front), float(p.track_rear)) + 0.03)

    @classmethod
    def variation_targets(cls, p):
        out = {
            "sprung_mass": [("body_mass", "body", 0)],
            "roll_inertia": [("body_inertia", "body", 0)],
            "pitch_inertia": [("body_inertia", "body", 1)],
            "arb_front": [("tendon_stiffness", "arb_front", 0)],
            "arb_rear": [("tendon_stiffness", "arb_rear", 0)],
        }
        for ax in ("front", "rear"):
            cs = [c for c in CORNERS if _axle(c) == ax]
            out[f"unsprung_mass_{ax}"] = [("body_mass", f"wheel_{c}", 0) for c in cs]
            out[f"spring_stiffness_{ax}"] = [("tendon_stiffness", f"suspension_{c}", 0) for c in cs]
            out[f"damping_{ax}"] = [("tendon_damping", f"suspension_{c}", 0) for c in cs]
            out[f"tire_stiffness_{ax}"] = [("tendon_stiffness", f"tire_{c}", 0) for c in cs]
            out[f"tire_damping_{ax}"] = [("tendon_damping", f"tire_{c}", 0) for c in cs]
        return out
