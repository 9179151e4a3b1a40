"""Helpers shared by the actuators' compiled kernels (see :mod:`suspension_sim.compiled`)."""
from __future__ import annotations

import numpy as np


def kernel_pack(ctx, *arrays) -> np.ndarray:
    """Stack per-corner arrays (each broadcastable to ``(n_cars, n_corners)``) along a last axis into the float64,
    C-contiguous ``(n_cars, n_corners, len(arrays))`` array of an actuator kernel's ``p`` or ``st``."""
    shape = (ctx.n_cars, ctx.n_corners)
    out = np.empty(shape + (len(arrays),), dtype=np.float64)
    for j, a in enumerate(arrays):
        out[:, :, j] = np.broadcast_to(np.asarray(a, dtype=np.float64), shape)
    return out


def optional_array(value, fill: float) -> np.ndarray:
    """A stacked optional parameter (array, None, or a per-car list mixing None and numbers) as floats, with
    ``fill`` where it is None (only for kernel_data; the Python methods keep their own handling)."""
    if value is None:
        return np.asarray(fill, dtype=float)
    if isinstance(value, list):
        return np.asarray([fill if v is None else v for v in value], dtype=float).reshape(len(value), -1)
    return np.asarray(value, dtype=float)
