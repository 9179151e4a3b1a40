"""Effect interface.

An effect is a force element acting along a corner's suspension tendon (``target = "suspension"``: force
positive = pushes body up and wheel down, as a function of travel ``s`` = body − wheel from equilibrium and
its rate ``v``) or along the tire tendon (``target = "tire"``: force positive = pushes the wheel up; ``s`` =
wheel − road from equilibrium, so ``-s`` is the extra tire compression).

A built-in effect writes its law once, as a numba :attr:`Effect.kernel` for one corner of one car.  The
base class broadcasts it over the ensemble for the Python loop (:meth:`Effect.force`, :meth:`Effect.signals`)
and the compiled loop inlines it.  ``force(s, v, t, dt)`` takes ``s`` and ``v`` of shape ``(n_cars, n_sel)``
(the corners the effect applies to) and is called once per physics step with the state at the start of that
step; stateful effects (hysteresis, backlash) keep their state in the kernel's ``st`` rows.  An effect that sets
:attr:`Effect.reads_actuator_force` also gets the actuator's force of that step on its corner (both loops compute
it before the effects): its kernel is ``kernel(s, v, t, dt, p, st, fa)`` and ``force(s, v, t, dt, fa)``.

Every effect documents its force law and the *signature* it leaves in measured data (used by the
discrepancy workflow).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..components import NoParams
from ..kernels import KernelState, broadcast_effect, broadcast_effect_fa, call, f64, pack


@dataclass
class EffectContext:
    n_cars: int
    corners: list[str]  # the corners this effect applies to
    dt: float
    static_suspension_force: np.ndarray  # (n_cars, n_sel) N, spring force carried at equilibrium
    static_tire_force: np.ndarray  # (n_cars, n_sel) N, tire load at equilibrium (>0)
    spring_stiffness: np.ndarray  # (n_cars, n_sel) N/m, linear suspension spring
    damping: np.ndarray  # (n_cars, n_sel) N s/m, linear suspension damper
    tire_stiffness: np.ndarray  # (n_cars, n_sel) N/m
    tire_damping: np.ndarray  # (n_cars, n_sel) N s/m
    # (n_cars, n_sel) kg: 1/(J M^-1 J^T) along the effect's tendon (suspension or tire), road held; None when
    # the context is built outside a Simulation (effects then estimate it, see effects/_common.reduced_mass)
    effective_mass: np.ndarray | None = None


class Effect(KernelState):
    """Base class.  A built-in effect sets ``Params`` (pydantic), ``target`` and ``signature``, sets
    :attr:`kernel` (its law, written once), implements :meth:`kernel_data` (parameters and initial state as
    the kernel's arrays) and declares :meth:`kernel_signals`.  A user's effect may instead override
    :meth:`force` (and :meth:`signals`) in plain numpy; it then runs in the Python loop (and overrides
    :meth:`reset_cars` if it keeps a state)."""

    name = "effect"
    target = "suspension"  # or "tire"
    Params = NoParams
    signature = ""  # what the effect looks like in data
    # whether the force at rest is a function of the travel alone (diagnose's static sag of a car whose mass
    # changed solves for it); False for a path-dependent law (hysteresis, backlash), whose force at rest
    # depends on how the travel got there
    static_law = True
    # whether the law also reads the actuator's force on its corner in the same physics step (N, positive pushes
    # the body up, as an effect's force): its kernel then takes it as a last argument, ``kernel(s, v, t, dt, p,
    # st, fa)``, and both loops pass it (a law that estimates the other forces on the suspension, such as
    # coulomb_friction's step mean, sees the force that the controller's new command gives in this step)
    reads_actuator_force = False

    @property
    def label(self) -> str:
        """The name its signals are logged under (``effect.LABEL.SIGNAL.k``): :attr:`name`, or ``NAME#2``, ... for
        a second effect of the same type in one vehicle (set when the system is built)."""
        return self.__dict__.get("_label", self.name)

    @label.setter
    def label(self, value: str) -> None:
        self._label = value

    def __init__(self, p, ctx: EffectContext):
        self.p = p
        self.ctx = ctx
        self.reset()
        if type(self).kernel is not None:
            self._data()  # checks the parameters (per-corner lists) when the effect is built

    def reset(self) -> None:
        """Reset internal state (the kernel state restarts from :meth:`kernel_data`); a subclass that
        overrides it calls ``super().reset()``.  :meth:`reset_cars` resets single cars."""
        self._kd = None
        self.forget_states()

    # the law: a module-level numba @njit function (s, v, t, dt, p, st) -> float, the force of one corner of
    # one car; p and st are that corner's rows of kernel_data() (st updated in place)
    kernel = None

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, n_sel, kp) and (n_cars, n_sel, ks) for :attr:`kernel`,
        taken from the current (reset) parameters and state (see :meth:`pack`)."""
        raise NotImplementedError

    def kernel_signals(self) -> dict[str, int]:
        """{signal name: j}: signal ``name`` of corner c is ``st[:, c, j]``."""
        return {}

    def pack(self, *arrays) -> np.ndarray:
        """Per-corner arrays (each broadcastable to (n_cars, n_sel)) stacked into a kernel_data array."""
        return pack((self.ctx.n_cars, len(self.ctx.corners)), *arrays)

    def _data(self):
        if getattr(self, "_kd", None) is None:
            if type(self).kernel is None:
                raise NotImplementedError(f"effect {self.name!r} has neither a kernel nor a force()")
            self._kd = tuple(f64(x) for x in self.kernel_data())  # the arrays handed out (reset_cars)
        return self._kd

    def kernel_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The (p, st) arrays the kernel runs on, in both loops (built from :meth:`kernel_data` at the first call
        after :meth:`reset`; :meth:`set_param` rewrites ``p`` in place, the kernel advances ``st``)."""
        return self._data()

    def set_param(self, name: str, value) -> None:
        """Set parameter ``name`` during a run (a time-varying ``effects.<label>.<param>`` variation): ``value``
        as the stacked parameter ((n_cars, 1) or (n_cars, n_sel)).  A kernel effect's parameter rows are
        rebuilt from :meth:`kernel_data` and written into the running ``p`` in place (the state ``st`` is kept),
        so the next force of either loop uses the new value; a Python effect reads ``self.p`` itself."""
        setattr(self.p, name, value)
        self.refresh_parameters()

    def refresh_parameters(self) -> None:
        """Write the parameter rows (:meth:`parameter_rows`, from ``self.p`` and ``self.ctx``) into the running
        kernel's ``p`` in place, after a parameter or the context (e.g. the effective mass) changed during a run."""
        if type(self).kernel is not None and getattr(self, "_kd", None) is not None:
            self._kd[0][...] = self.parameter_rows()

    def force(self, s: np.ndarray, v: np.ndarray, t: float, dt: float, fa=None) -> np.ndarray:
        """The force of every selected corner of every car, (n_cars, n_sel): the kernel broadcast over the
        ensemble (its state advances).  ``fa``: the actuator force on those corners in this step (read only when
        :attr:`reads_actuator_force`; None: zero)."""
        p, st = self._data()
        shape = p.shape[:2]
        s, v = (f64(a if np.shape(a) == shape else np.broadcast_to(a, shape)) for a in (s, v))
        out = np.empty(shape)
        if type(self).reads_actuator_force:
            fa = np.zeros(shape) if fa is None else f64(fa if np.shape(fa) == shape else np.broadcast_to(fa, shape))
            call(broadcast_effect_fa, type(self).kernel, s, v, float(t), float(dt), p, st, fa, out)
        else:
            call(broadcast_effect, type(self).kernel, s, v, float(t), float(dt), p, st, out)
        return out

    def signals(self) -> dict[str, np.ndarray]:
        """Internal signals to log, each (n_cars, n_sel), from the kernel state (:meth:`kernel_signals`)."""
        sig = self.kernel_signals()
        if not sig:
            return {}
        _, st = self._data()
        return {nm: st[:, :, j].copy() for nm, j in sig.items()}
