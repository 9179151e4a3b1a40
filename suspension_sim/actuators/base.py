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

All arrays have shape ``(n_cars, n_corners)``.  :meth:`states` exposes the internal states by name for
logging and for sensors (e.g. a spool-position sensor).

A built-in actuator writes its law once, as two numba functions for one corner (``kernel_force``,
``kernel_advance``); the base class broadcasts them over the ensemble for the Python loop and the compiled
loop inlines them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..components import NoParams
from ..kernels import KernelState, broadcast_actuator_advance, broadcast_actuator_force, call, f64, pack


@dataclass
class ActuatorContext:
    n_cars: int
    n_corners: int
    dt: float  # physics step
    control_dt: float
    static_suspension_force: np.ndarray  # (n_cars, n_corners)


class Actuator(KernelState):
    """Base class.  A built-in actuator sets ``Params`` and ``command_unit``, sets :attr:`kernel_force` and
    :attr:`kernel_advance` (its law, written once), implements :meth:`kernel_data` (parameters and initial
    state as the kernels' arrays) and declares :meth:`kernel_states`; a subclass that overrides :meth:`reset`
    calls ``super().reset()``.  A user's actuator may instead override :meth:`force`, :meth:`advance` and
    :meth:`states` in plain numpy; it then runs in the Python loop (and overrides :meth:`reset_cars` if it keeps
    a state)."""

    name = "actuator"
    Params = NoParams
    command_unit = "N"  # what the controller's command means

    def __init__(self, p, ctx: ActuatorContext):
        self.p = p
        self.ctx = ctx
        self.reset()
        if type(self).kernel_force is not None:
            self._data()  # checks the parameters when the actuator is built

    def reset(self) -> None:
        """Reset the internal state (the kernel state restarts from :meth:`kernel_data`)."""
        self._kd = None
        self._F = np.zeros((self.ctx.n_cars, self.ctx.n_corners))
        self.forget_states()

    def reset_cars(self, cars) -> None:
        """Reset the internal state of the cars ``cars`` only (the kernel state back to :meth:`kernel_data`'s
        initial value, in whichever loop runs; the last force to zero), e.g. a car the vectorised env
        restarts in place."""
        super().reset_cars(cars)
        self._F[np.asarray(cars, dtype=np.intp)] = 0.0

    # the law: module-level numba @njit functions for one corner of one car, p and st its rows of
    # kernel_data() (st updated in place): kernel_force(cmd, s, v, t, dt, p, st) -> float, the force over the
    # coming physics step, and kernel_advance(cmd, s, v, t, dt, p, st) -> None, the state advanced over dt
    kernel_force = None
    kernel_advance = None

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, n_corners, kp) and (n_cars, n_corners, ks) from the
        current (reset) parameters and state (see :meth:`pack`)."""
        raise NotImplementedError

    def kernel_states(self) -> dict[str, int]:
        """{state name: j}: state ``name`` of corner c is ``st[:, c, j]`` ('force' may be left out)."""
        return {}

    def pack(self, *arrays) -> np.ndarray:
        """Per-corner arrays (each broadcastable to (n_cars, n_corners)) stacked into a kernel_data array."""
        return pack((self.ctx.n_cars, self.ctx.n_corners), *arrays)

    def _data(self):
        if getattr(self, "_kd", None) is None:
            if type(self).kernel_force is None:
                raise NotImplementedError(f"actuator {self.name!r} has neither kernels nor force()/advance()")
            self._kd = tuple(f64(x) for x in self.kernel_data())  # the arrays handed out (reset_cars)
        return self._kd

    def _args(self, *arrays):
        shape = (self.ctx.n_cars, self.ctx.n_corners)
        return [f64(a if np.shape(a) == shape else np.broadcast_to(a, shape)) for a in arrays]

    def force(self, command: np.ndarray, travel: np.ndarray, travel_rate: np.ndarray, t: float) -> np.ndarray:
        """The force of every corner over the coming physics step, (n_cars, n_corners)."""
        p, st = self._data()
        out = np.empty(p.shape[:2])
        call(broadcast_actuator_force, type(self).kernel_force, *self._args(command, travel, travel_rate),
             float(t), float(self.ctx.dt), p, st, out)
        self._F = out
        return out

    def advance(self, command: np.ndarray, travel: np.ndarray, travel_rate: np.ndarray, t: float, dt: float) -> None:
        """Advance the state over ``dt`` with the command held and the travel rate of the step start."""
        p, st = self._data()
        call(broadcast_actuator_advance, type(self).kernel_advance, *self._args(command, travel, travel_rate),
             float(t), float(dt), p, st)

    def states(self) -> dict[str, np.ndarray]:
        """Internal states by name, each (n_cars, n_corners), from the kernel state (:meth:`kernel_states`);
        the last force under 'force' when the kernel state does not hold it."""
        if type(self).kernel_force is None:
            return {}
        _, st = self._data()
        out = {nm: st[:, :, j].copy() for nm, j in self.kernel_states().items()}
        if "force" not in out:
            out["force"] = self._F.copy()
        return out
