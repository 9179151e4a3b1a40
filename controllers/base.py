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

    def sensor_slice(self, name: str) -> tuple[int, int]:
        """(start, stop) of sensor ``name`` in a compiled controller's reading vector y (the declared sensors
        concatenated in declared order); KeyError if the scenario does not declare it."""
        start = 0
        for sname, labels in self.sensors.items():
            if sname == name:
                return start, start + len(labels)
            start += len(labels)
        raise KeyError(name)


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

    # optional compiled kernel (see suspension_sim.compiled): a module-level numba @njit function
    # (t, y, p, st, u) -> None doing step() for one car: y its readings (ControlContext.sensor_slice), p and st
    # its rows of kernel_data(), u its command row (n_corners) to fill
    kernel = None

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, kp) and (n_cars, ks) from the current (reset) state."""
        raise NotImplementedError

    def kernel_signals(self) -> dict[str, tuple[int, int]]:
        """{signal name: (start, stop)} with signals()[name] == st[:, start:stop] (stop = start + 1: 1-D)."""
        return {}

    def kernel_sync(self, st: np.ndarray) -> None:
        """Write the kernel state back to the Python attributes after a compiled run (optional)."""

    def zeros(self) -> np.ndarray:
        return np.zeros((self.ctx.n_cars, self.ctx.n_corners))
