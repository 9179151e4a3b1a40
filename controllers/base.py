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
from suspension_sim.errors import ScenarioError
from suspension_sim.kernels import broadcast_controller, call, f64


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
    # full_state: {"state.<name>": width} of the true plant quantities the controller may read, in order
    state_widths: dict = field(default_factory=dict)

    @property
    def n_corners(self) -> int:
        return len(self.corners)

    def reading_layout(self) -> dict[str, int]:
        """{reading name: width} in the order of a kernel's reading vector y: the declared sensors in declared
        order, then (with ``full_state``) the true plant quantities ``state.<name>`` (:attr:`state_widths`)."""
        out = {sname: len(labels) for sname, labels in self.sensors.items()}
        if self.full_state:
            out.update(self.state_widths)
        return out

    def reading_slices(self) -> dict[str, tuple[int, int]]:
        """{reading name: (start, stop)} in a kernel's reading vector y (:meth:`reading_layout`), computed once."""
        key = (tuple(self.sensors), self.full_state, tuple(self.state_widths))
        cached = self.__dict__.get("_slices")
        if cached is None or cached[0] != key:
            out, start = {}, 0
            for name, width in self.reading_layout().items():
                out[name] = (start, start + width)
                start += width
            cached = self.__dict__["_slices"] = (key, out)
        return cached[1]

    def sensor_slice(self, name: str) -> tuple[int, int]:
        """(start, stop) of reading ``name`` in a kernel's reading vector y (:meth:`reading_layout`); a name
        the scenario does not declare is read from the true state ``state.<name>`` when ``full_state`` is set;
        KeyError otherwise."""
        sl = self.reading_slices()
        if name not in sl and self.full_state and f"state.{name}" in sl:
            name = f"state.{name}"
        return sl[name]

    def reading_start(self, name: str) -> int:
        """Start of reading ``name`` in a kernel's reading vector y (:meth:`sensor_slice`), for a kernel's
        parameter row; a reading neither declared nor in the full state is a one-line scenario error."""
        try:
            return self.sensor_slice(name)[0]
        except KeyError:
            raise ScenarioError(f"the controller reads {name!r}: declare a sensor of that name (or set "
                                f"controller.full_state)", field="sensors") from None


class Controller:
    """Base class.  A built-in controller writes its law once, as the numba :attr:`kernel` for one car; the
    base class broadcasts it over the ensemble (:meth:`step`, :meth:`signals`), and the compiled loop inlines
    it.  A subclass sets ``Params``, implements :meth:`reset` (calling ``super().reset()``) and
    :meth:`kernel_data`, and declares :meth:`kernel_signals`.  A user's controller may instead override
    :meth:`step` (and :meth:`signals`) in plain numpy; it then runs in the Python or hybrid loop."""

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
        """Reset the controller state; subclasses call ``super().reset()``."""
        self._kd = None

    # the law: a module-level numba @njit function (t, y, p, st, u) -> None doing one control step for one
    # car: y its readings (ControlContext.sensor_slice), p and st its rows of kernel_data(), u its command row
    # (n_corners) to fill
    kernel = None
    # True when the kernel is straight-line arithmetic on its readings and state (no branch, comparison or math
    # function on them, only on p): the compiled loop then runs it for four cars sharing a parameter row in one
    # call, lane by lane, with the same numbers (suspension_sim.compiled.lanes)
    kernel_lanes = False

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, kp) and (n_cars, ks) from the current (reset) state.
        Raise NotImplementedError for a setting the kernel cannot run."""
        raise NotImplementedError

    def kernel_signals(self) -> dict[str, tuple[int, int]]:
        """{signal name: (start, stop)} with signals()[name] == st[:, start:stop] (stop = start + 1: 1-D)."""
        return {}

    def kernel_sync(self, st: np.ndarray) -> None:
        """Take the kernel state of a compiled run (so that :meth:`signals` and a following :meth:`step`
        continue from it)."""
        p, _ = self._data()
        self._kd = (p, f64(np.array(st, dtype=np.float64)))

    def _data(self):
        if getattr(self, "_kd", None) is None:
            if type(self).kernel is None:
                raise NotImplementedError(f"controller {self.name!r} has neither a kernel nor a step()")
            self._kd = tuple(f64(np.array(x, dtype=np.float64)) for x in self.kernel_data())
        return self._kd

    def readings(self, y: dict[str, np.ndarray]) -> np.ndarray:
        """The readings ``y`` (name -> (n_cars, k)) as the kernel's reading matrix (n_cars, sum of widths), in
        the order of :meth:`ControlContext.reading_layout` (one buffer, refilled at each call)."""
        sl = self.ctx.reading_slices()
        buf = self.__dict__.get("_ybuf")
        if buf is None or buf[0] is not sl:
            width = max((b for _, b in sl.values()), default=0)
            buf = self._ybuf = (sl, np.zeros((self.ctx.n_cars, width)))
        out = buf[1]
        n = self.ctx.n_cars
        for name, (a, b) in sl.items():
            out[:, a:b] = np.reshape(y[name], (n, -1))
        return out

    def step(self, t: float, y: dict[str, np.ndarray]) -> np.ndarray:
        """One control step for every car: the kernel broadcast over the ensemble; returns (n_cars, n_corners)."""
        p, st = self._data()
        u = np.zeros((self.ctx.n_cars, self.ctx.n_corners))
        call(broadcast_controller, type(self).kernel, float(t), self.readings(y), p, st, u)
        return u

    def signals(self) -> dict[str, np.ndarray]:
        """Internal signals (parameter estimates, errors), each (n_cars, k) or (n_cars,), from the kernel
        state (:meth:`kernel_signals`)."""
        sig = self.kernel_signals()
        if not sig:
            return {}
        _, st = self._data()
        return {nm: (st[:, a].copy() if b == a + 1 else st[:, a:b].copy()) for nm, (a, b) in sig.items()}

    def zeros(self) -> np.ndarray:
        return np.zeros((self.ctx.n_cars, self.ctx.n_corners))

    def per_car(self, v) -> np.ndarray:
        """A parameter stacked over the ensemble (a value, or one per car) as floats (n_cars,), for a column of
        the kernel's parameter rows."""
        return np.broadcast_to(np.asarray(v, dtype=float).reshape(-1), (self.ctx.n_cars,))


def block_offsets(start: int, blocks) -> dict[str, int]:
    """{name: offset} of consecutive blocks ``(name, width)`` of a kernel's state row from ``start``, and
    ``"_next"``: the offset after the last."""
    out = {}
    for name, width in blocks:
        out[name] = start
        start += width
    out["_next"] = start
    return out
