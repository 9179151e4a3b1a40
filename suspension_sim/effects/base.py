"""Effect interface.

An effect is a force element acting along a corner's suspension tendon (``target = "suspension"``: force
positive = pushes body up and wheel down, as a function of travel ``s`` = body − wheel from equilibrium and
its rate ``v``) or along the tire tendon (``target = "tire"``: force positive = pushes the wheel up; ``s`` =
wheel − road from equilibrium, so ``-s`` is the extra tire compression).

Effects are vectorised over the ensemble: ``s`` and ``v`` have shape ``(n_cars, n_sel)`` for the corners the
effect applies to, and ``self.p`` holds the stacked parameters (``(n_cars, 1)`` or ``(n_cars, n_sel)``).
:meth:`force` is called once per physics step with the state at the start of that step; stateful effects
(hysteresis, backlash) update their state in :meth:`force` using ``dt``.

Every effect documents its force law and the *signature* it leaves in measured data (used by the
discrepancy workflow).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..components import NoParams


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


class Effect:
    """Base class. Subclasses set ``Params`` (pydantic), ``target`` and implement :meth:`force`."""

    name = "effect"
    target = "suspension"  # or "tire"
    Params = NoParams
    signature = ""  # what the effect looks like in data

    def __init__(self, p, ctx: EffectContext):
        self.p = p
        self.ctx = ctx
        self.reset()

    def reset(self) -> None:
        """Reset internal state (stateful effects)."""

    def force(self, s: np.ndarray, v: np.ndarray, t: float, dt: float) -> np.ndarray:
        raise NotImplementedError

    def signals(self) -> dict[str, np.ndarray]:
        """Internal signals to log, each of shape (n_cars, k)."""
        return {}

    # optional compiled kernel (see suspension_sim.compiled): a module-level numba @njit function
    # (s, v, t, dt, p, st) -> float, the force of one corner of one car, same law and operation order as force()
    kernel = None

    def kernel_data(self) -> tuple[np.ndarray, np.ndarray]:
        """(p, st): float64 C-contiguous arrays (n_cars, n_sel, kp) and (n_cars, n_sel, ks) for :attr:`kernel`,
        taken from the current (reset) parameters and state; the kernel updates st[i, c] in place."""
        raise NotImplementedError

    def kernel_signals(self) -> dict[str, int]:
        """{signal name: j} with signals()[name][:, c] == st[:, c, j]."""
        return {}
