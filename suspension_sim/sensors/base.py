"""Sensor interface and the measurement pipeline.

A sensor *type* reads one true quantity from the plant (:class:`PlantState`), shape ``(n_cars, k)``.  The
scenario declares each sensor with a name, a type and a pipeline, applied in this order:

    true value -> pure delay -> bias + white noise (seeded) -> quantisation -> sample-and-hold at ``rate``

The delay is rounded to whole control steps; a sensor slower than the control rate holds its last sample.
Controllers receive ``{sensor name: reading}`` and nothing else, unless the scenario grants
``controller.full_state`` (then the true quantities are added under ``"state.<type>"`` and the run's
summary says so).
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numba
import numpy as np

from ..components import NoParams


@dataclass
class PlantState:
    """True plant quantities at the current control instant, all arrays (n_cars, ...).

    ``body_*`` are the body degrees of freedom in the order of the model's body joints (heave in m,
    pitch/roll in rad); ``corner_*`` the body point above each corner; accelerations are those of the last
    physics step (a real accelerometer's sample precedes the force computed from it), and the ``*_acc_mean``
    fields their means over the last control period (:func:`period_mean_acc`; the accelerometers'
    ``sampling: period_mean``).
    """

    t: float
    body_pos: np.ndarray
    body_vel: np.ndarray
    body_acc: np.ndarray
    corner_body_pos: np.ndarray
    corner_body_vel: np.ndarray
    corner_body_acc: np.ndarray
    wheel_pos: np.ndarray
    wheel_vel: np.ndarray
    wheel_acc: np.ndarray
    travel: np.ndarray
    travel_rate: np.ndarray
    road: np.ndarray
    road_vel: np.ndarray
    tire_force: np.ndarray
    actuator_force: np.ndarray
    body_acc_mean: np.ndarray | None = None
    corner_body_acc_mean: np.ndarray | None = None
    wheel_acc_mean: np.ndarray | None = None
    actuator_states: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)  # e.g. road preview, maneuver signals


def full_state_readings(s: PlantState) -> dict:
    """The readings a full-state controller gets on top of its sensors (``controller.full_state: true``):
    ``"state.<field>"`` for every array field of ``s`` and ``"state.actuator.<name>"`` for every actuator
    state."""
    out = {}
    for k, v in s.__dict__.items():
        if isinstance(v, np.ndarray):
            out[f"state.{k}"] = v
    for k, v in s.actuator_states.items():
        out[f"state.actuator.{k}"] = v
    return out


@dataclass
class SensorContext:
    n_cars: int
    corners: list[str]
    suffixes: list[str]
    body_joints: tuple[str, ...]
    control_dt: float


class Sensor:
    """Base class of a sensor type: :meth:`read` the true value, :meth:`labels` name its components.

    A sensor that reads columns of one plant quantity declares them once, in :meth:`kernel_field`: the base
    :meth:`read` takes them from the :class:`PlantState` and the compiled loop reads them itself.  Any other
    sensor overrides :meth:`read` (it then runs with the controller in Python)."""

    name = "sensor"
    Params = NoParams
    unit = ""

    def __init__(self, p, ctx: SensorContext):
        self.p = p
        self.ctx = ctx

    def read(self, s: PlantState) -> np.ndarray:
        """The true value, (n_cars, k): the columns :meth:`kernel_field` names."""
        field = self.kernel_field()
        if field is None:
            raise NotImplementedError(f"sensor {self.name!r} has neither read() nor kernel_field()")
        name, cols = field
        a = np.asarray(getattr(s, name))
        return a if list(cols) == list(range(a.shape[1])) else a[:, list(cols)]

    def labels(self) -> list[str]:
        return [c or "value" for c in self.ctx.suffixes]

    def kernel_field(self):
        """(PlantState field, column indices) when the reading is columns of one plant quantity (the compiled
        loop then reads it itself), else None."""
        return None


@numba.njit(cache=True)
def period_mean_acc(qvel, v_last, dofs, period, out):
    """The accelerometers' ``sampling: period_mean`` law, at a control instant, for every dof ``j`` of
    ``dofs``: ``out[j] = (qvel[j] − v_last[j]) / period``, the mean acceleration over the control period that
    ends now (``v_last`` holds the velocities at the previous control instant, or the initial ones), then
    ``v_last[j] = qvel[j]``.  Both loops call it (the Python loop before :func:`~suspension_sim.loop.plant_state`,
    the compiled loop before its sensors), so the readings are the same."""
    for q in range(dofs.shape[0]):
        j = dofs[q]
        out[j] = (qvel[j] - v_last[j]) / period
        v_last[j] = qvel[j]


@numba.njit(cache=True)
def measure(value, bias, noise, quantization):
    """The measurement law after the delay, for one reading: ``value + bias + noise``, then rounded to the
    nearest multiple of ``quantization`` (when > 0).  The compiled loop inlines it; the Python loop calls
    :func:`measure_all` (the same law over a car × column array)."""
    y = value + bias + noise
    if quantization > 0:
        y = np.rint(y / quantization) * quantization
    return y


@numba.njit(cache=True)
def measure_all(values, bias, noise, quantization, out):
    """:func:`measure` over arrays of one shape (``noise`` the same shape), into ``out``."""
    v, z, o = values.ravel(), noise.ravel(), out.ravel()
    for j in range(v.shape[0]):
        o[j] = measure(v[j], bias, z[j], quantization)


class SensorChannel:
    """One declared sensor: a type plus its measurement pipeline."""

    def __init__(self, cfg, sensor: Sensor, control_dt: float, rng: np.random.Generator):
        self.cfg = cfg
        self.name = cfg.name
        self.sensor = sensor
        self.rng = rng
        self.delay_steps = int(round(cfg.delay / control_dt))
        self.hold_steps = max(1, int(round((1.0 / cfg.rate) / control_dt))) if cfg.rate else 1
        field = sensor.kernel_field()
        if self.hold_steps > 1 and field is not None and field[0].endswith("_acc_mean"):
            from ..errors import ScenarioError

            raise ScenarioError(f"sensor {cfg.name!r}: sampling: period_mean averages over the control period; "
                                "a rate below the control rate is not supported", field="sensors.rate")
        self.reset()

    def reset(self):
        self._buf: deque = deque(maxlen=self.delay_steps + 1)
        self._held = None
        self._k = np.zeros(self.sensor.ctx.n_cars, dtype=np.int64)  # samples taken, per car (the hold phase)

    def sample(self, s: PlantState) -> np.ndarray:
        true = np.asarray(self.sensor.read(s), dtype=float)
        if self._buf:
            self._buf.append(true.copy())
        else:  # the line starts full of the first value (as a sensor switched on: the first sample is held)
            self._buf.extend(true.copy() for _ in range(self.delay_steps + 1))
        delayed = self._buf[0]
        due = self._k % self.hold_steps == 0
        if self._held is None or due.all():
            self._held = self._measure(delayed, None)
        elif due.any():  # cars restarted out of phase (reset_cars): only they sample now
            cars = np.nonzero(due)[0]
            y = self._held.copy()
            y[cars] = self._measure(delayed[cars], cars)
            self._held = y
        self._k += 1
        return self._held

    def _measure(self, delayed, cars):
        """Bias, noise and quantisation of the delayed value (all cars, or the rows of ``cars``)."""
        delayed = np.ascontiguousarray(delayed, dtype=np.float64)
        if self.cfg.noise_std > 0:
            if cars is None:
                z = self.rng.normal(0.0, self.cfg.noise_std, size=delayed.shape)
            elif hasattr(self.rng, "normal_cars"):
                z = self.rng.normal_cars(cars, self.cfg.noise_std, delayed.shape[1:])
            else:
                z = self.rng.normal(0.0, self.cfg.noise_std, size=delayed.shape)
            noise = np.ascontiguousarray(z, dtype=np.float64)
        else:
            noise = np.zeros_like(delayed)
        y = np.empty_like(delayed)
        measure_all(delayed, float(self.cfg.bias), noise, float(self.cfg.quantization), y)
        return y

    def reset_cars(self, cars, s: PlantState) -> None:
        """Restart the pipeline of the cars ``cars`` as a sensor switched on now, reading ``s`` (the true
        state of those cars at this control instant; rows of other cars are ignored): their delay line is
        filled with the value read, their sample is taken now (with its noise draw from the car's own stream)
        and held from here.  Other cars are untouched.  The noise stream goes on (it is not replayed)."""
        cars = np.asarray(cars, dtype=np.intp).reshape(-1)
        if not cars.size:
            return
        true = np.asarray(self.sensor.read(s), dtype=float)
        if not self._buf:
            return  # nothing sampled yet: the first sample starts every car's line
        for b in self._buf:
            b[cars] = true[cars]
        y = self._held.copy()
        y[cars] = self._measure(true[cars], cars)
        self._held = y
        self._k[cars] = 1
