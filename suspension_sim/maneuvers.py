"""Manoeuvres as inertial load transfer on the sprung mass.

A manoeuvre gives the vehicle's longitudinal and lateral acceleration a_x(t), a_y(t) (m/s², x forward,
y left).  On the sprung mass they act as moments about the c.g. (d'Alembert forces m_s·a at the c.g.
height h above the pitch/roll axis), applied as generalised forces on the body's pitch and roll joints:

    pitch torque = −m_s·a_x·h   (braking, a_x < 0, pitches the nose down = positive pitch, ISO 8855)
    roll torque  = +m_s·a_y·h   (a left turn, a_y > 0, rolls the body to the right = positive roll)

The suspension distributes them to the corners.  The vehicle speed for the road input is set separately
(``road.speed`` as a [time, speed] table); :meth:`Maneuver.speed_table` gives the table consistent with
a_x(t) for convenience.  New manoeuvres register in :data:`MANEUVERS` (one class each; full-car
manoeuvres such as the ISO 3888-1 double lane change can live in their own module).
"""
from __future__ import annotations

import numpy as np
from pydantic import Field

from .components import Params, validate_params
from .errors import ScenarioError
from .registry import MANEUVERS


class ManeuverParams(Params):
    cg_height: float | None = Field(None, gt=0, description="c.g. height above the pitch/roll axis, m; "
                                    "default: the vehicle's cg_height")
    sprung_mass: float | None = Field(None, gt=0, description="kg; default: the vehicle's sprung_mass")


class Maneuver:
    """Base: subclasses implement :meth:`accel` returning (a_x, a_y) arrays for a time array."""

    name = "maneuver"
    Params = ManeuverParams

    def __init__(self, p):
        self.p = p

    def accel(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def speed_table(self, v0: float, duration: float, dt: float = 0.01) -> list[list[float]]:
        t = np.arange(0.0, duration + dt, dt)
        ax, _ = self.accel(t)
        v = v0 + np.concatenate([[0.0], np.cumsum(0.5 * (ax[1:] + ax[:-1]) * dt)])
        return [[float(a), float(max(b, 0.0))] for a, b in zip(t, v)]


class PhasesParams(ManeuverParams):
    start: float = Field(1.0, ge=0, description="s, start of the first phase")
    phases: list[tuple[float, float]] = Field(
        default_factory=lambda: [(8.0, 4.0), (2.0, -7.0)],
        description="[duration s, a_x m/s²] phases; default: the thesis's 4 m/s² for 8 s then 7 m/s² braking for 2 s")
    lateral: bool = Field(False, description="the phases give a_y instead of a_x")


@MANEUVERS.register("accel_brake")
class AccelBrake(Maneuver):
    """Piecewise-constant acceleration phases (the thesis's accelerate-then-brake manoeuvre by default)."""

    Params = PhasesParams

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        a = np.zeros_like(t)
        t0 = self.p.start
        for dur, acc in self.p.phases:
            a = np.where((t >= t0) & (t < t0 + dur), acc, a)
            t0 += dur
        z = np.zeros_like(a)
        return (z, a) if self.p.lateral else (a, z)


class TableParams(ManeuverParams):
    times: list[float]
    ax: list[float] | None = None
    ay: list[float] | None = None


@MANEUVERS.register("accel_table")
class AccelTable(Maneuver):
    """Acceleration time histories a_x(t), a_y(t) given as tables (linear interpolation, zero outside)."""

    Params = TableParams

    def accel(self, t):
        t = np.asarray(t, dtype=float)
        tt = self.p.times
        ax = np.interp(t, tt, self.p.ax, left=0.0, right=0.0) if self.p.ax else np.zeros_like(t)
        ay = np.interp(t, tt, self.p.ay, left=0.0, right=0.0) if self.p.ay else np.zeros_like(t)
        return ax, ay


class AppliedManeuver:
    """The ensemble's manoeuvres turned into generalised forces on the pitch/roll joints."""

    def __init__(self, maneuvers, plant, sprung_mass, cg_height):
        self.maneuvers = maneuvers
        self.plant = plant
        self.m = np.asarray(sprung_mass, dtype=float).reshape(-1)
        self.h = np.asarray(cg_height, dtype=float).reshape(-1)
        joints = list(plant.body_joints)
        self.pitch = plant.body_v[:, joints.index("pitch")] if "pitch" in joints else None
        self.roll = plant.body_v[:, joints.index("roll")] if "roll" in joints else None
        self.last = np.zeros((plant.n, 2))

    def accel(self, t: float) -> np.ndarray:
        out = np.zeros((len(self.maneuvers), 2))
        tt = np.array([t])
        for i, mv in enumerate(self.maneuvers):
            ax, ay = mv.accel(tt)
            out[i] = ax[0], ay[0]
        return out

    def loads(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The generalised pitch and roll forces :meth:`apply` adds at each of the times ``t``, as arrays
        (len(t), n_cars), same arithmetic (for the compiled loop, which adds them itself)."""
        t = np.asarray(t, dtype=float)
        ax = np.empty((len(t), len(self.maneuvers)))
        ay = np.empty_like(ax)
        for i, mv in enumerate(self.maneuvers):
            ax[:, i], ay[:, i] = mv.accel(t)
        return -self.m * ax * self.h, self.m * ay * self.h

    def apply(self, t: float, d) -> None:
        a = self.accel(t)
        self.last = a
        if self.pitch is not None:
            d.qfrc_applied[self.pitch] += -self.m * a[:, 0] * self.h
        if self.roll is not None:
            d.qfrc_applied[self.roll] += self.m * a[:, 1] * self.h


def build_maneuver(scenarios, plant, source=None) -> AppliedManeuver:
    cfg0 = scenarios[0].vehicle.maneuver
    cls = MANEUVERS.get(cfg0.type, field="vehicle.maneuver.type", source=source)
    mans, masses, heights = [], [], []
    for i, s in enumerate(scenarios):
        p = validate_params(cls.Params, s.vehicle.maneuver.params, "vehicle.maneuver.params", source)
        mv = cls(p)
        mans.append(mv)
        vp = plant.params[i]
        m = p.sprung_mass if p.sprung_mass is not None else getattr(vp, "sprung_mass", None)
        if m is None:
            raise ScenarioError("give maneuver.params.sprung_mass (the model has no sprung_mass)", source=source,
                                field="vehicle.maneuver.params.sprung_mass")
        masses.append(m)
        h = p.cg_height if p.cg_height is not None else getattr(vp, "cg_height", None)
        if h is None:
            raise ScenarioError("give maneuver.params.cg_height (the model has no cg_height)", source=source,
                                field="vehicle.maneuver.params.cg_height")
        heights.append(h)
    joints = plant.body_joints
    ax, ay = mans[0].accel(np.linspace(0, scenarios[0].sim.duration, 2001))
    if np.any(ax != 0) and "pitch" not in joints:
        raise ScenarioError(f"longitudinal manoeuvre needs a model with pitch (model {plant.vcls.name!r} has "
                            f"{list(joints)})", source=source, field="vehicle.maneuver")
    if np.any(ay != 0) and "roll" not in joints:
        raise ScenarioError(f"lateral manoeuvre needs a model with roll (model {plant.vcls.name!r} has "
                            f"{list(joints)})", source=source, field="vehicle.maneuver")
    return AppliedManeuver(mans, plant, masses, heights)

