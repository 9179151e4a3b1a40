"""Helpers shared by the effect modules (not an effect itself: the leading underscore keeps it out of
plugin discovery)."""
from __future__ import annotations

from typing import Annotated, Union

import numpy as np
from pydantic import Field

from ..errors import ScenarioError

GRAVITY = 9.81

NonNegative = Annotated[float, Field(ge=0)]
Positive = Annotated[float, Field(gt=0)]
# a value for every corner of the effect, or one list entry per corner
PerCornerNonNeg = Union[NonNegative, list[NonNegative]]
PerCornerPos = Union[Positive, list[Positive]]
PerCornerReal = Union[float, list[float]]


def corner_array(effect, name: str) -> np.ndarray:
    """Parameter ``name`` of ``effect`` as a float array of shape ``(n_cars, n_sel)``.

    Scalars broadcast; a per-corner list must have one entry per corner the effect applies to."""
    value = getattr(effect.p, name)
    n, k = effect.ctx.n_cars, len(effect.ctx.corners)
    arr = np.asarray(value, dtype=float) if not isinstance(value, list) or _flat(value) else None
    if arr is None or arr.ndim > 2 or (arr.ndim == 2 and arr.shape[1] not in (1, k)):
        raise ScenarioError(f"needs one value or a list of {k} values (one per corner: {effect.ctx.corners})",
                            field=f"effects.{effect.name}.params.{name}")
    if arr.ndim == 0:
        arr = arr.reshape(1, 1)
    elif arr.ndim == 1:  # an unstacked per-corner list
        if arr.size != k:
            raise ScenarioError(f"needs {k} values (one per corner: {effect.ctx.corners}), got {arr.size}",
                                field=f"effects.{effect.name}.params.{name}")
        arr = arr.reshape(1, k)
    return np.broadcast_to(arr, (n, k)).astype(float)


def per_car(effect, name: str) -> list:
    """Parameter ``name`` of ``effect`` (one value, or one per car when the effect is stacked over a batch) as a
    list of ``n_cars`` values: for per-car switches such as ``law`` and ``step_force``."""
    value = getattr(effect.p, name)
    return value if isinstance(value, list) else [value] * effect.ctx.n_cars


def step_mean_column(effect) -> np.ndarray:
    """``(n_cars, 1)``: 1.0 for a car whose ``step_force`` is ``mean``, else 0.0 (the kernels' flag row)."""
    return np.array([1.0 if sf == "mean" else 0.0 for sf in per_car(effect, "step_force")]).reshape(-1, 1)


def _flat(v) -> bool:
    return all(isinstance(x, (int, float)) for x in v)


def reduced_mass(ctx) -> np.ndarray:
    """Effective mass (kg) along each corner's suspension: ``ctx.effective_mass`` (1/(J·M⁻¹·Jᵀ), computed by
    the simulation from the MuJoCo mass matrix) when given, else ``1/(1/m_s + 1/m_u)`` with the corner's
    sprung and unsprung shares estimated from the static loads (exact for the quarter car, within ~2 % for the
    half and full cars, wrong for suspensions in series such as the two-DOF rig)."""
    if getattr(ctx, "effective_mass", None) is not None:
        return np.asarray(ctx.effective_mass, dtype=float)
    ms = np.asarray(ctx.static_suspension_force, dtype=float) / GRAVITY
    mt = np.asarray(ctx.static_tire_force, dtype=float) / GRAVITY
    mu = np.where(mt > ms, mt - ms, np.inf)  # no tire (SDOF rig): the base is rigid
    return 1.0 / (1.0 / np.maximum(ms, 1e-9) + 1.0 / mu)
