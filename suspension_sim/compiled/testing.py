"""Checks that a component's compiled kernel reproduces its Python method (used by the tests).

Each function drives the Python object and its kernel with the same inputs, step by step, and returns the
largest absolute difference of outputs and signals/states, so a test can assert it is 0 (or within a few
ulp where a kernel calls a transcendental function that numpy evaluates differently)."""
from __future__ import annotations

import copy

import numpy as np


def _maxdiff(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape != b.shape:
        raise AssertionError(f"shape {a.shape} != {b.shape}")
    both_nan = np.isnan(a) & np.isnan(b)
    return float(np.max(np.where(both_nan, 0.0, np.abs(a - b)), initial=0.0))


def check_effect(effect, s_seq, v_seq, t0: float = 0.0, dt: float = 0.0005) -> float:
    """Run ``effect.force`` (on a deep copy) and ``effect.kernel`` over the inputs s_seq[k], v_seq[k]
    (each (n_cars, n_sel)); return the largest difference of forces and kernel_signals."""
    py = copy.deepcopy(effect)
    py.reset()
    kn = copy.deepcopy(effect)
    kn.reset()
    p, st = kn.kernel_data()
    sig = kn.kernel_signals()
    worst = 0.0
    for k, (s, v) in enumerate(zip(s_seq, v_seq)):
        t = t0 + k * dt
        f_py = np.broadcast_to(py.force(np.array(s, dtype=float), np.array(v, dtype=float), t, dt), s.shape)
        f_kn = np.empty(s.shape)
        for i in range(s.shape[0]):
            for c in range(s.shape[1]):
                f_kn[i, c] = kn.kernel(float(s[i, c]), float(v[i, c]), t, dt, p[i, c], st[i, c])
        worst = max(worst, _maxdiff(f_py, f_kn))
        sp = py.signals()
        for name, j in sig.items():
            worst = max(worst, _maxdiff(np.broadcast_to(sp[name], s.shape), st[:, :, j]))
    return worst


def check_actuator(actuator, cmd_seq, s_seq, v_seq, dt: float = 0.0005) -> float:
    """Run force/advance of the Python actuator and its kernels on the same inputs (each (n_cars, n_corners));
    return the largest difference of forces and kernel_states."""
    py = copy.deepcopy(actuator)
    py.reset()
    kn = copy.deepcopy(actuator)
    kn.reset()
    p, st = kn.kernel_data()
    idx = kn.kernel_states()
    worst = 0.0
    for k, (u, s, v) in enumerate(zip(cmd_seq, s_seq, v_seq)):
        t = k * dt
        u, s, v = (np.array(a, dtype=float) for a in (u, s, v))
        f_py = np.array(py.force(u, s, v, t), dtype=float)
        py.advance(u, s, v, t, dt)
        f_kn = np.empty(u.shape)
        for i in range(u.shape[0]):
            for c in range(u.shape[1]):
                f_kn[i, c] = kn.kernel_force(u[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c])
                kn.kernel_advance(u[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c])
        worst = max(worst, _maxdiff(f_py, f_kn))
        sp = py.states()
        for name, j in idx.items():
            worst = max(worst, _maxdiff(np.broadcast_to(sp[name], u.shape), st[:, :, j]))
    return worst


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
