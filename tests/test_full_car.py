"""Full car (models/full_car.xml, suspension_sim/vehicles/full_car.py) and the ISO 3888-1 double lane change.

- the suspension tendons' pitch/roll coefficients against MuJoCo's own hinge kinematics (the body sites
  above the corners moved by small pitch/roll angles) and the corner/track layout;
- the static equilibrium (the file alone, and rebuilt with other parameters) carries the weight;
- steady roll under a constant lateral acceleration equals m_s·a_y·h / K_φ with K_φ the series combination
  of suspension (springs + anti-roll bars) and tire roll stiffnesses per axle, written from the parameters;
  the sign convention (left turn → right side down, right corners compress);
- braking pitches the nose down; a one-sided bump rolls the body towards the other side and reaches the rear
  axle one wheelbase later;
- the double lane change's path stays inside the course's lanes, its lateral acceleration stays within
  the friction limit and the manoeuvre is registered.
"""
from __future__ import annotations

import mujoco
import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from suspension_sim.config import parse_scenario
from suspension_sim.maneuvers import MANEUVERS
from suspension_sim.maneuvers_dlc import DLCParams, DoubleLaneChange, lane_geometry
from suspension_sim.registry import VEHICLES
from suspension_sim.simulation import Simulation
from suspension_sim.vehicles.base import models_dir

G = 9.81
OTHER = dict(a=1.2, b=1.5, track_front=1.6, track_rear=1.5, sprung_mass=1300.0, arb_front=20000.0, arb_rear=0.0,
             spring_stiffness_rear=23000.0, unsprung_mass_rear=45.0)


def _model(**vp):
    V = VEHICLES.get("full_car")
    root = V.build(V.Params(**vp))
    return mujoco.MjModel.from_xml_string(root.to_xml_string()), V, V.Params(**vp)


@pytest.mark.parametrize("vp", [{}, OTHER], ids=["defaults", "other"])
def test_tendon_signs_match_hinge_kinematics(vp):
    m, V, p = _model(**vp)
    rng = np.random.default_rng(3)
    for _ in range(5):
        q = rng.uniform(-1e-3, 1e-3, 3)  # body_z, pitch, roll (small)
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        z0 = {c.name: d.site(f"corner_{c.name}").xpos[2] for c in V.corners(p)}
        for jn, val in zip(("body_z", "pitch", "roll"), q):
            d.qpos[m.joint(jn).qposadr[0]] = val
        mujoco.mj_forward(m, d)
        for c in V.corners(p):
            dz = d.site(f"corner_{c.name}").xpos[2] - z0[c.name]  # MuJoCo's rigid-body kinematics
            travel = d.ten_length[m.tendon(f"suspension_{c.name}").id]  # the tendon (small-angle model)
            assert travel == pytest.approx(dz, abs=1e-8)
    # roll positive = right side down, pitch positive = nose down
    d = mujoco.MjData(m)
    d.qpos[m.joint("roll").qposadr[0]] = 0.01
    d.qpos[m.joint("pitch").qposadr[0]] = 0.01
    mujoco.mj_forward(m, d)
    assert d.site("corner_fr").xpos[2] < d.site("corner_fl").xpos[2]
    assert d.site("corner_fl").xpos[2] < d.site("corner_rl").xpos[2]
    cs = V.corners(p)
    assert [c.name for c in cs] == ["fl", "fr", "rl", "rr"]
    assert [c.track for c in cs] == [0, 1, 0, 1]
    assert [c.y > 0 for c in cs] == [True, False, True, False]


@pytest.mark.parametrize("vp", [None, OTHER], ids=["file_alone", "rebuilt"])
def test_static_equilibrium(vp):
    if vp is None:
        m = mujoco.MjModel.from_xml_path(str(models_dir() / "full_car.xml"))
        ms = m.body("body").mass[0]
    else:
        m, _, p = _model(**vp)
        ms = p.sprung_mass
    d = mujoco.MjData(m)
    for _ in range(2000):
        mujoco.mj_step(m, d)
    assert np.abs(d.qpos).max() < 2e-5  # the file's springlengths are rounded to 1e-8 m
    loads = [m.tendon_stiffness[m.tendon(f"suspension_{c}").id] * m.tendon_lengthspring[m.tendon(f"suspension_{c}").id, 0]
             for c in ("fl", "fr", "rl", "rr")]
    assert sum(loads) == pytest.approx(ms * G, rel=1e-6)


def _run(vp, maneuver=None, road=None, duration=4.0, speed=10.0):
    raw = dict(vehicle=dict(model="full_car", params=vp),
               road=dict(type="flat", speed=speed) if road is None else dict(road, speed=speed),
               sim=dict(duration=duration, dt=5e-4, control_dt=1e-3, log_dt=1e-3))
    if maneuver:
        raw["vehicle"]["maneuver"] = maneuver
    return Simulation([parse_scenario(raw)]).run()[0]


@pytest.mark.parametrize("vp", [{}, OTHER], ids=["defaults", "other"])
def test_steady_roll_and_pitch(vp):
    p = VEHICLES.get("full_car").Params(**vp)
    h, ay, ax = 0.5, 4.0, -3.0
    man = dict(type="accel_table", params=dict(cg_height=h, times=[0.0, 0.5, 100.0], ay=[0.0, ay, ay],
                                                ax=[0.0, ax, ax]))
    r = _run(vp, man, duration=5.0)
    end = r.ts[r.ts.t > 4.0].mean()
    # roll stiffness per axle: (springs + bar) in series with the tires, all written from the parameters
    K = 0.0
    for ax_ in ("front", "rear"):
        t = getattr(p, f"track_{ax_}")
        Ks = getattr(p, f"spring_stiffness_{ax_}") * t ** 2 / 2 + getattr(p, f"arb_{ax_}") * t ** 2
        Kt = getattr(p, f"tire_stiffness_{ax_}") * t ** 2 / 2
        K += Ks * Kt / (Ks + Kt)
    assert end["roll"] == pytest.approx(p.sprung_mass * ay * h / K, rel=0.01)
    assert end["roll"] > 0  # a left turn (a_y > 0) rolls the right side down
    assert end["travel_fr"] < end["travel_fl"] and end["travel_rr"] < end["travel_rl"]  # right corners compress
    # braking (a_x < 0) pitches the nose down; pitch stiffness: corners in series with tires
    kf = 2 * p.spring_stiffness_front * p.tire_stiffness_front / (p.spring_stiffness_front + p.tire_stiffness_front)
    kr = 2 * p.spring_stiffness_rear * p.tire_stiffness_rear / (p.spring_stiffness_rear + p.tire_stiffness_rear)
    a, b = p.a, p.b
    Kyy = np.array([[kf + kr, -kf * a + kr * b], [-kf * a + kr * b, kf * a ** 2 + kr * b ** 2]])  # [z, pitch]
    z, th = np.linalg.solve(Kyy, [0.0, -p.sprung_mass * ax * h])
    assert end["pitch"] == pytest.approx(th, rel=0.01)
    assert end["pitch"] > 0 and end["travel_fl"] + end["travel_fr"] < end["travel_rl"] + end["travel_rr"]
    assert end["body_z"] == pytest.approx(z, abs=0.01 * abs(th) * max(a, b))


def test_one_sided_bump_rolls_and_reaches_rear_later():
    speed = 9.7222
    r = _run({}, road=dict(type="bump", params=dict(preset="fallah", track="left")), duration=3.0, speed=speed)
    ts = r.ts
    assert ts["road_fr"].abs().max() == 0 and ts["road_rr"].abs().max() == 0
    assert ts["road_fl"].max() == pytest.approx(0.10, rel=1e-3)
    t_front = ts.t[ts["road_fl"].idxmax()]
    t_rear = ts.t[ts["road_rl"].idxmax()]
    p = VEHICLES.get("full_car").Params()
    assert t_rear - t_front == pytest.approx((p.a + p.b) / speed, abs=2e-3)
    # the left side is lifted: roll positive (left up = right side down) while the front-left wheel is on it
    on = (ts.t > t_front - 0.1) & (ts.t < t_front + 0.1)
    assert ts.loc[on, "roll"].max() > 0.005 and ts.loc[on, "roll"].min() > -0.002


def test_double_lane_change_path_and_acceleration():
    assert "double_lane_change" in MANEUVERS.names()
    p = DLCParams()
    m = DoubleLaneChange(p)
    h = m.history
    xs, widths, y3 = lane_geometry(p.vehicle_width, p.offset)
    assert y3 == pytest.approx(3.5 + 0.05 * p.vehicle_width)
    # the c.g. stays inside every lane (the car's edges may touch the cones by a few cm: a simple driver)
    for name, (dev, room) in m.gate_deviation().items():
        assert dev < room + 0.5 * p.vehicle_width, name
    assert np.max(np.abs(h["ay"])) < p.mu * G  # within the friction limit
    assert np.max(h["Y"]) == pytest.approx(y3, abs=0.5)  # it reaches the side lane
    assert abs(h["Y"][-1]) < 0.3 and abs(h["psi"][-1]) < 0.02  # and comes back straight
    ax, ay = m.accel(np.array([0.0, p.start - 0.01, p.start + 2.0]))
    assert np.all(ax == 0) and ay[0] == 0 and ay[1] == 0 and abs(ay[2]) > 1.0
    # lateral acceleration is the yaw-rate/lateral-velocity kinematics: v_y(t) = ∫(a_y − u·r) dt
    vy = cumulative_trapezoid(h["ay"] - p.speed * h["r"], h["t"], initial=0.0)
    assert np.max(np.abs(vy - h["vy"])) < 0.01 * np.max(np.abs(h["vy"])) + 1e-4


def test_double_lane_change_rolls_the_full_car():
    man = dict(type="double_lane_change", params=dict(speed=22.2222, start=0.5, cg_height=0.5))
    r = _run({}, man, duration=4.0, speed=22.2222)
    ts = r.ts
    mv = DoubleLaneChange(DLCParams(speed=22.2222, start=0.5, cg_height=0.5))
    _, ay = mv.accel(ts.t.to_numpy())
    # roll follows the lateral acceleration (right side down in the left-hand part of the manoeuvre)
    assert np.corrcoef(ts.roll, ay)[0, 1] > 0.9
    assert ts.roll.abs().max() > 0.01
    assert ts.body_acc.abs().max() < 1e-6  # a symmetric linear car: the roll moment alone does not heave
