"""Controller interface.

A controller is reset with the model and then called once per control step::

    u = controller.step(t, y)      # y: {sensor name: array (n_cars, k)}; u: (n_cars, n_corners)

``u`` is the actuator *command* (a force demand in N for the ideal and electromagnetic actuators, a spool
input for the hydraulic one: see the actuator's ``command_unit``), held constant until the next step.
Controllers see only the sensors the scenario declares (``required_sensors`` lists the names a controller
needs; the scenario check fails with a clear message if they are missing), unless the scenario sets
``controller.full_state: true``, which adds the true plant quantities as ``y["state.<name>"]``.

Everything is vectorised over an ensemble of cars: parameters arrive stacked (scalars as ``(n_cars, 1)``),
so one controller object drives many cars.  :meth:`signals` exposes internal signals (parameter estimates,
errors) for logging, each ``(n_cars, k)``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from suspension_sim.components import NoParams


@dataclass
class ControlContext:
    n_cars: int
    corners: list[str]
    suffixes: list[str]
    corner_x: list[float]  # axle positions from the c.g. (m, forward +)
    corner_y: list[float]  # lateral positions (m, left +)
    control_dt: float
    dt: float
    vehicle_model: str
    vehicle: SimpleNamespace  # nominal vehicle parameters, stacked (n_cars, 1)
    sensors: dict[str, list[str]]  # sensor name -> component labels
    actuator: str
    command_unit: str
    full_state: bool = False
    static_suspension_force: np.ndarray | None = None  # (n_cars, n_corners)
    extra: dict = field(default_factory=dict)

    @property
    def n_corners(self) -> int:
        return len(self.corners)


class Controller:
    name = "controller"
    Params = NoParams
    requires: tuple[str, ...] = ()

    @classmethod
    def required_sensors(cls, raw_params: dict) -> list[str]:
        return list(cls.requires)

    def __init__(self, p, ctx: ControlContext):
        self.p = p
        self.ctx = ctx
        self.reset()

    def reset(self) -> None:
        pass

    def step(self, t: float, y: dict[str, np.ndarray]) -> np.ndarray:
        raise NotImplementedError

    def signals(self) -> dict[str, np.ndarray]:
        return {}

    def zeros(self) -> np.ndarray:
        return np.zeros((self.ctx.n_cars, self.ctx.n_corners))
