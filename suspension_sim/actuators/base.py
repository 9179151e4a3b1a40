"""Actuator interface.

An actuator turns the controller's *command* (held constant over a control step) into the force along each
corner's suspension tendon (positive pushes the body up and the wheel down).  Its internal states (a lag,
a delay line, a spool position and load pressure, a coil current) advance with the physics step:

- :meth:`force` returns the force applied over the coming physics step, from the current state and the
  held command (an ideal actuator passes the command straight through; a hydraulic one ignores it and
  returns A·P_L);
- :meth:`advance` integrates the state over ``dt`` given the command and the suspension travel rate.
  Stiff dynamics (hydraulic pressure) may sub-step or integrate implicitly inside :meth:`advance`, so that
  results do not change when the physics step is halved.

All arrays have shape ``(n_cars, n_corners)`` (states may add a trailing axis).  :meth:`states` exposes the
internal states by name for logging and for sensors (e.g. a spool-position sensor).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..components import NoParams


@dataclass
class ActuatorContext:
    n_cars: int
    n_corners: int
    dt: float  # physics step
    control_dt: float
    static_suspension_force: np.ndarray  # (n_cars, n_corners)


class Actuator:
    name = "actuator"
    Params = NoParams
    command_unit = "N"  # what the controller's command means

    def __init__(self, p, ctx: ActuatorContext):
        self.p = p
        self.ctx = ctx
        self.reset()

    def reset(self) -> None:
        pass

    def force(self, command: np.ndarray, travel: np.ndarray, travel_rate: np.ndarray, t: float) -> np.ndarray:
        raise NotImplementedError

    def advance(self, command: np.ndarray, travel: np.ndarray, travel_rate: np.ndarray, t: float, dt: float) -> None:
        raise NotImplementedError

    def states(self) -> dict[str, np.ndarray]:
        """Internal states by name, each (n_cars, n_corners)."""
        return {}

    # optional compiled kernels (see suspension_sim.compiled): module-level numba @njit functions for one corner
    # of one car, same arithmetic as force()/advance(): kernel_force(cmd, s, v, t, dt, p, st) -> float and
    # kernel_advance(cmd, s, v, t, dt, p, st) -> None
    kernel_force = None
    kernel_advance = None

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, n_corners, kp) and (n_cars, n_corners, ks) from the
        current (reset) parameters and state; the kernels update st[i, c] in place."""
        raise NotImplementedError

    def kernel_states(self) -> dict[str, int]:
        """{state name: j} with states()[name][:, c] == st[:, c, j] ('force' may be left out)."""
        return {}
