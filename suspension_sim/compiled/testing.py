"""Checks that a controller's kernel, replayed one car at a time, reproduces the commands and signals of its
ensemble ``step`` (used by the tests).  Effects and actuators need no such check: their Python methods are
their kernels broadcast over the ensemble (:mod:`suspension_sim.kernels`)."""
from __future__ import annotations

import copy

import numpy as np


def _maxdiff(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise AssertionError(f"shape {a.shape} != {b.shape}")
    both_nan = np.isnan(a) & np.isnan(b)
    return float(np.max(np.where(both_nan, 0.0, np.abs(a - b)), initial=0.0))


def check_controller(sim) -> float:
    """Run the Simulation ``sim`` (Python path) and replay each control step's readings through a fresh copy
    of its controller's kernel; return the largest difference of commands and kernel_signals."""
    ctrl = sim.controller
    kn = copy.deepcopy(ctrl)
    log = []
    readings = sim.start()
    while readings is not None:
        u = np.broadcast_to(np.asarray(ctrl.step(sim.t, readings), dtype=float), (sim.plant.n, sim.plant.nc))
        log.append((sim.t, {k: np.array(v, dtype=float) for k, v in readings.items()}, u.copy(),
                    {k: np.array(v, dtype=float) for k, v in ctrl.signals().items()}))
        readings = sim.control_step(u)
    kn.reset()
    p, st = kn.kernel_data()
    sig = kn.kernel_signals()
    names = list(kn.ctx.sensors)
    worst = 0.0
    out = np.zeros(kn.ctx.n_corners)
    for t, y, u, sp in log:
        for i in range(kn.ctx.n_cars):
            yi = np.ascontiguousarray(np.concatenate([np.zeros(0)] + [
                np.asarray(y[nm], dtype=float).reshape(kn.ctx.n_cars, -1)[i] for nm in names]))
            out[:] = 0.0
            kn.kernel(t, yi, p[i], st[i], out)
            worst = max(worst, _maxdiff(u[i], out))
        for name, (a, b) in sig.items():
            ref = np.asarray(sp[name], dtype=float).reshape(kn.ctx.n_cars, -1)
            worst = max(worst, _maxdiff(ref, st[:, a:b]))
    return worst
