"""One law, one place: a built-in component's law is a numba scalar function (one corner, or one car), and
these generic adapters broadcast it over an ensemble for the Python loop, the environments and ``diagnose``.

The compiled loop (:mod:`suspension_sim.compiled`) inlines the same functions, so the Python loop and the
compiled loop run the same arithmetic; nothing is written twice.  The kernel signatures (see
:mod:`suspension_sim.compiled` for the full protocol):

- effect:      ``kernel(s, v, t, dt, p, st) -> float``            (one corner of one car; with
  ``reads_actuator_force``, ``kernel(s, v, t, dt, p, st, fa)``, ``fa`` the actuator force of the step)
- actuator:    ``kernel_force(cmd, s, v, t, dt, p, st) -> float``  and ``kernel_advance(...) -> None``
- controller:  ``kernel(t, y, p, st, u) -> None``                 (one car: readings y, command row u)

``p`` rows are read-only parameters and ``st`` rows state the kernel updates in place; both are the float64
arrays that the component's ``kernel_data()`` returns.

The broadcasters take the law as an argument (numba compiles one specialisation per law, in memory: the
comment above them says why they are not cached on disk; the laws themselves are).  A call through
numba's dispatcher costs ~10 µs for the argument typing; :func:`call` keeps the compiled entry point of each
(broadcaster, law) pair and calls it directly (~1 µs for a small ensemble, cheaper than the numpy
expressions these replace).
"""
from __future__ import annotations

import numba
import numpy as np

# The broadcasters are compiled per process, not cached on disk (cache=False).  Their first argument is a
# law (a numba dispatcher), so every law makes a new specialisation, and numba's on-disk cache keys a
# specialisation by the law's type, which holds the identity of the dispatcher object of this process: each
# new process appends new entries to the cache index instead of reusing the old ones, the index grows without
# bound, and loading it eventually fails with ``ReferenceError: underlying object has vanished`` (a stale
# entry pointing at a dispatcher of a dead process).  Compiling a broadcaster for a law costs ~0.2 s of CPU,
# once per law and process (measured for quadratic_damping); the laws they call stay ``cache=True``.


@numba.njit(cache=False)  # see above: not cached on disk
def broadcast_effect(kernel, s, v, t, dt, p, st, out):
    """out[i, c] = kernel(s[i, c], v[i, c], t, dt, p[i, c], st[i, c]) for every car i and corner c."""
    n, k = s.shape
    for i in range(n):
        for c in range(k):
            out[i, c] = kernel(s[i, c], v[i, c], t, dt, p[i, c], st[i, c])


@numba.njit(cache=False)  # see above: not cached on disk
def broadcast_effect_fa(kernel, s, v, t, dt, p, st, fa, out):
    """As :func:`broadcast_effect` for a law that reads the actuator force: ``kernel(..., fa[i, c])``."""
    n, k = s.shape
    for i in range(n):
        for c in range(k):
            out[i, c] = kernel(s[i, c], v[i, c], t, dt, p[i, c], st[i, c], fa[i, c])


@numba.njit(cache=False)  # see above: not cached on disk
def broadcast_actuator_force(kernel, cmd, s, v, t, dt, p, st, out):
    """out[i, c] = kernel_force(cmd[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c])."""
    n, k = s.shape
    for i in range(n):
        for c in range(k):
            out[i, c] = kernel(cmd[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c])


@numba.njit(cache=False)  # see above: not cached on disk
def broadcast_actuator_advance(kernel, cmd, s, v, t, dt, p, st):
    """kernel_advance(cmd[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c]) for every car and corner."""
    n, k = s.shape
    for i in range(n):
        for c in range(k):
            kernel(cmd[i, c], s[i, c], v[i, c], t, dt, p[i, c], st[i, c])


@numba.njit(cache=False)  # see above: not cached on disk
def broadcast_controller(kernel, t, y, p, st, u):
    """kernel(t, y[i], p[i], st[i], u[i]) for every car i."""
    for i in range(y.shape[0]):
        kernel(t, y[i], p[i], st[i], u[i])


_ENTRY: dict = {}


def _kind(a):
    if isinstance(a, np.ndarray):
        return a.dtype.char, a.ndim, a.flags.c_contiguous, a.flags.writeable
    return type(a)


def call(broadcaster, law, *args):
    """``broadcaster(law, *args)`` through the compiled entry point of that pair and these argument types
    (skips numba's typing of the law argument after the first call)."""
    key = (broadcaster, law, tuple(_kind(a) for a in args))
    ep = _ENTRY.get(key)
    if ep is not None:
        return ep(law, *args)
    out = broadcaster(law, *args)
    sig = tuple(broadcaster.typeof_pyval(a) for a in (law,) + args)
    cres = broadcaster.overloads.get(sig)
    if cres is not None:
        _ENTRY[key] = cres.entry_point
    return out


def pack(shape, *arrays) -> np.ndarray:
    """Stack arrays (each broadcastable to ``shape``, e.g. ``(n_cars, n_corners)``) along a last axis into the
    float64, C-contiguous ``shape + (len(arrays),)`` array of a kernel's ``p`` or ``st`` row block; no arrays
    give a ``shape + (0,)`` array."""
    shape = tuple(shape)
    out = np.empty(shape + (len(arrays),), dtype=np.float64)
    for j, a in enumerate(arrays):
        out[..., j] = np.broadcast_to(np.asarray(a, dtype=np.float64), shape)
    return out


def optional(value) -> np.ndarray:
    """A stacked optional parameter (None, an array, or a per-car list mixing None and numbers) as floats with
    NaN where it is not given (for ``np.where(np.isnan(x), default, x)``)."""
    if value is None:
        return np.asarray(np.nan)
    if isinstance(value, list):
        return np.asarray([np.nan if v is None else v for v in value], dtype=float).reshape(len(value), -1)
    return np.asarray(value, dtype=float)


def f64(a) -> np.ndarray:
    """``a`` as a float64, C-contiguous, writeable array (a copy only when needed)."""
    a = np.asarray(a, dtype=np.float64)
    if not a.flags.c_contiguous or not a.flags.writeable:
        a = np.ascontiguousarray(a).copy() if not a.flags.writeable else np.ascontiguousarray(a)
    return a


class KernelState:
    """Base of the components whose kernel keeps a state ``st`` (actuators, effects): per-car reset.

    The loops advance the ``st`` array that :meth:`kernel_data` hands them in place (the Python loop the one it
    keeps, the compiled loop its own).  This base remembers those arrays (weakly, until :meth:`forget_states`,
    which ``reset()`` calls), so that :meth:`reset_cars` can put single cars back to their initial state in
    whichever loop runs them (the vectorised env restarting a car in place).  The initial state is the one
    :meth:`kernel_data` gives: a component's law and its initial state stay in one place.  A component whose
    state lives elsewhere (plain numpy ``force``/``advance``) overrides :meth:`reset_cars`."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        fn = cls.__dict__.get("kernel_data")
        if fn is not None and not getattr(fn, "_keeps_state", False):
            cls.kernel_data = _keeping_state(fn)

    def forget_states(self) -> None:
        self._live_st = []

    def _unremembered_data(self):
        """:meth:`kernel_data` called as a nested call: new (p, st) arrays that the loops are not handed."""
        self._kd_depth = getattr(self, "_kd_depth", 0) + 1
        try:
            return self.kernel_data()
        finally:
            self._kd_depth -= 1

    def initial_state(self) -> np.ndarray:
        """The kernel state ``st`` of a start of run (a new array, not remembered)."""
        return f64(self._unremembered_data()[1])

    def parameter_rows(self) -> np.ndarray:
        """The kernel parameters ``p`` from the current parameters (a new array, not remembered; for a parameter
        changed during a run)."""
        return f64(self._unremembered_data()[0])

    def reset_cars(self, cars) -> None:
        """Put the kernel state of the cars ``cars`` (indices) back to its initial value; other cars untouched."""
        cars = np.asarray(cars, dtype=np.intp).reshape(-1)
        live = [st for st in (r() for r in getattr(self, "_live_st", [])) if st is not None]
        if not cars.size or not live:
            return
        st0 = self.initial_state()
        for st in live:
            if st.shape == st0.shape:
                st[cars] = st0[cars]


def _keeping_state(fn):
    import functools
    import weakref

    @functools.wraps(fn)
    def kernel_data(self):
        depth = getattr(self, "_kd_depth", 0)
        self._kd_depth = depth + 1
        try:
            p, st = fn(self)
        finally:
            self._kd_depth = depth
        if depth:  # a nested call (a subclass calling its parent's, or initial_state): not handed out
            return p, st
        p, st = f64(p), f64(st)
        live = [r for r in getattr(self, "_live_st", []) if r() is not None]
        live.append(weakref.ref(st))
        self._live_st = live
        return p, st

    kernel_data._keeps_state = True
    return kernel_data
