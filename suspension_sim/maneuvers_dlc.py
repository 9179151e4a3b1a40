"""ISO 3888-1 double lane change as a lateral-acceleration time history (manoeuvre ``double_lane_change``).

Course (ISO 3888-1:1999 severe lane change, vehicle width ``w``; lane widths in m, lengths along the road):

==========  ===========  ===================  ==============================
section     length (m)   lane width (m)       lateral position
==========  ===========  ===================  ==============================
1 entry     15           1.1·w + 0.25         0
2 offset    30           —                    transition
3 side      25           1.2·w + 0.25         offset 3.5 m to the left
4 offset    25           —                    transition
5 exit      15           1.3·w + 0.25         0
6           15           —                    0 (free)
==========  ===========  ===================  ==============================

The 3.5 m lateral offset is between the right-hand cone lines of lanes 1 and 3 (the lanes widen), so the
lane centrelines are offset by 3.5 + (w3 − w1)/2 = 3.5 + 0.05·w.  Reference path: the centrelines, joined
in sections 2 and 4 by cycloid transitions y = Δ·(u − sin(2πu)/2π), u = distance fraction (slope and
curvature zero at both ends, so the driver's curvature feed-forward never steps).

Vehicle: a linear single-track (bicycle) model at constant speed ``speed`` (states lateral velocity v_y and
yaw rate r, plus the yaw angle ψ and lateral position Y), with axle forces saturating smoothly at μ·F_z:
F_y = μF_z·tanh(C_α·α/(μF_z)), α_f = δ − (v_y + l_f r)/u, α_r = −(v_y − l_r r)/u.  Default data: the
mid-size sedan of Rajamani, *Vehicle Dynamics and Control* (2012): m = 1573 kg, I_z = 2873 kg·m²,
l_f = 1.10 m, l_r = 1.58 m, cornering stiffness 80000 N/rad per axle — the same car as the ``full_car``
defaults (values as commonly quoted from that book, not re-checked against its printed table).

Driver: single-point preview (MacAdam's idea, simplest form): the lateral position predicted ``preview``
seconds ahead by straight-line extrapolation, Y + T_p·(u·ψ + v_y), is compared with the path at
X + u·T_p; the steering angle is the one that would close that error with a constant-curvature arc,
δ = gain·2·L·e/(u·T_p)² (L = wheelbase), plus the kinematic feed-forward L·κ of the path there.  The output
is the lateral acceleration a_y = v̇_y + u·r (left positive) at the c.g.; a_x = 0 (constant speed).  The
manoeuvre starts when the front of the car reaches the course at ``start`` s; before that and after the
simulated course a_y = 0.  Set the road speed of the scenario to the same ``speed``.

This is a path-following approximation of a test driver, not a driver model identified from tests: a real
driver (and CarMaker's driver) anticipates more and cuts the corners differently; the peak lateral
acceleration at 80 km/h (≈ 6–7 m/s²) is of the order measured in ISO 3888-1 tests of passenger cars.
"""
from __future__ import annotations

import numpy as np
from pydantic import Field
from scipy.integrate import solve_ivp

from .maneuvers import MANEUVERS, Maneuver, ManeuverParams

G = 9.81
SECTIONS = (15.0, 30.0, 25.0, 25.0, 15.0, 15.0)


class DLCParams(ManeuverParams):
    speed: float = Field(80.0 / 3.6, gt=0, description="m/s, constant (ISO 3888-1 tests: 80 km/h)")
    start: float = Field(0.5, ge=0, description="s, time at which the car enters the course")
    vehicle_width: float = Field(1.80, gt=0, description="m, sets the lane widths")
    offset: float = Field(3.5, description="m, lateral offset of the side lane (cone lines), + = left")
    mass: float = Field(1573.0, gt=0, description="kg, whole vehicle (bicycle model)")
    yaw_inertia: float = Field(2873.0, gt=0, description="kg·m²")
    lf: float = Field(1.10, gt=0, description="m, c.g. to front axle")
    lr: float = Field(1.58, gt=0, description="m, c.g. to rear axle")
    cornering_stiffness_front: float = Field(80000.0, gt=0, description="N/rad per axle")
    cornering_stiffness_rear: float = Field(80000.0, gt=0, description="N/rad per axle")
    mu: float = Field(1.0, gt=0, description="tire–road friction coefficient (axle force saturation)")
    preview: float = Field(0.38, gt=0, description="s, driver preview time (0.38 s: the car stays within 5 cm of the cone-limited space of every lane)")
    gain: float = Field(1.0, gt=0, description="driver gain on the preview error (1 = constant-curvature arc)")
    run_out: float = Field(3.0, ge=0, description="s simulated after the course end (the car settles)")


def lane_geometry(width: float, offset: float = 3.5):
    """Section start distances (m), lane widths and centreline offsets of the ISO 3888-1 course."""
    x = np.concatenate([[0.0], np.cumsum(SECTIONS)])
    w1, w3, w5 = 1.1 * width + 0.25, 1.2 * width + 0.25, 1.3 * width + 0.25
    sgn = 1.0 if offset >= 0 else -1.0
    y3 = offset + sgn * 0.5 * (w3 - w1)  # centreline offset: right cone lines are `offset` apart
    return x, (w1, w3, w5), y3


def reference_path(X, width: float = 1.8, offset: float = 3.5):
    """Lateral position of the reference path (m, left +) and its curvature (1/m) at distances X."""
    X = np.asarray(X, dtype=float)
    xs, _, y3 = lane_geometry(width, offset)
    y = np.zeros_like(X)
    kappa = np.zeros_like(X)
    for (x0, x1, ya, yb) in ((xs[1], xs[2], 0.0, y3), (xs[3], xs[4], y3, 0.0)):
        L = x1 - x0
        u = np.clip((X - x0) / L, 0.0, 1.0)
        # cycloid transition: slope and curvature are zero at both ends (continuous curvature, no step steer)
        y = y + (yb - ya) * (u - np.sin(2 * np.pi * u) / (2 * np.pi))
        kappa = kappa + (yb - ya) * 2 * np.pi / L ** 2 * np.sin(2 * np.pi * u)
    return y, kappa


def simulate_dlc(p: DLCParams, dt: float = 0.002):
    """Bicycle model with a preview driver on the course: dict of time arrays (t from course entry)."""
    u = float(p.speed)
    L = p.lf + p.lr
    Fzf = p.mass * G * p.lr / L
    Fzr = p.mass * G * p.lf / L
    T = float(np.sum(SECTIONS)) / u + p.run_out

    def steer(X, Y, psi, vy):
        Xp = X + u * p.preview
        yp, kp = reference_path(Xp, p.vehicle_width, p.offset)
        e = yp - (Y + p.preview * (u * psi + vy))
        return p.gain * 2.0 * L * e / (u * p.preview) ** 2 + L * kp

    def forces(vy, r, delta):
        af = delta - (vy + p.lf * r) / u
        ar = -(vy - p.lr * r) / u
        Ff = p.mu * Fzf * np.tanh(p.cornering_stiffness_front * af / (p.mu * Fzf))
        Fr = p.mu * Fzr * np.tanh(p.cornering_stiffness_rear * ar / (p.mu * Fzr))
        return Ff, Fr

    def rhs(t, s):
        X, Y, psi, vy, r = s
        delta = steer(X, Y, psi, vy)
        Ff, Fr = forces(vy, r, delta)
        dvy = (Ff * np.cos(delta) + Fr) / p.mass - u * r
        dr = (p.lf * Ff * np.cos(delta) - p.lr * Fr) / p.yaw_inertia
        return [u * np.cos(psi) - vy * np.sin(psi), u * np.sin(psi) + vy * np.cos(psi), r, dvy, dr]

    t = np.arange(0.0, T + dt, dt)
    sol = solve_ivp(rhs, (0.0, t[-1]), [0.0, 0.0, 0.0, 0.0, 0.0], t_eval=t, rtol=1e-6, atol=1e-8, max_step=0.02)
    X, Y, psi, vy, r = sol.y
    delta = steer(X, Y, psi, vy)
    Ff, Fr = forces(vy, r, delta)
    ay = (Ff * np.cos(delta) + Fr) / p.mass  # = v̇_y + u·r
    return {"t": sol.t, "X": X, "Y": Y, "psi": psi, "vy": vy, "r": r, "delta": delta, "ay": ay}


@MANEUVERS.register("double_lane_change")
class DoubleLaneChange(Maneuver):
    """ISO 3888-1 double lane change at constant speed: a_y(t) from a bicycle model with a preview driver."""

    Params = DLCParams

    def __init__(self, p):
        super().__init__(p)
        self.history = simulate_dlc(p)

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        h = self.history
        ay = np.interp(t - self.p.start, h["t"], h["ay"], left=0.0, right=0.0)
        return np.zeros_like(ay), ay

    def gate_deviation(self) -> dict:
        """Largest lateral distance (m) of the c.g. path from the lane centreline inside lanes 1, 3 and 5,
        against the half lane width minus half the vehicle width (the space the car has)."""
        h = self.history
        xs, widths, y3 = lane_geometry(self.p.vehicle_width, self.p.offset)
        out = {}
        for name, (x0, x1), yc, w in (("entry", (xs[0], xs[1]), 0.0, widths[0]),
                                     ("side", (xs[2], xs[3]), y3, widths[1]),
                                     ("exit", (xs[4], xs[5]), 0.0, widths[2])):
            sel = (h["X"] >= x0) & (h["X"] <= x1)
            out[name] = (float(np.max(np.abs(h["Y"][sel] - yc))), 0.5 * (w - self.p.vehicle_width))
        return out
