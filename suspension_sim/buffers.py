"""Large work arrays of a run (the log buffer, the metrics' gathered channels) reused from one run to the next.

A fresh array of tens or hundreds of MB comes from the kernel as untouched pages: the first write into each
4 KB page costs a page fault and the kernel's zeroing of it, every run again (the 256-car benchmark batch
logs 29 MB per run with the batch engine's logging, 156 MB with every channel).  :func:`empty` hands out
instead a buffer of an earlier run that **nothing references any more** (its results, and every view of
it, are gone: CPython's reference count of the buffer is the pool's own), whose pages are already mapped;
else a new one.  Like ``numpy.empty`` the contents are undefined: callers write every entry they read.

At most :data:`MAX_MB` (or ``SUSPENSION_SIM_LOG_BUFFER_MB``, the log buffer's own bound) of buffers are kept;
idle ones are dropped oldest first to make room, and a buffer that does not fit is not kept.
:func:`release` drops every idle buffer (e.g. before a long pause of a process that ran a large ensemble).
"""
from __future__ import annotations

import os
import sys
import threading

import numpy as np

MAX_MB = 512.0

_lock = threading.Lock()
_pool: list = []  # bytearrays (the memory of float64 arrays), oldest first


def _limit() -> float:
    return float(os.environ.get("SUSPENSION_SIM_LOG_BUFFER_MB") or MAX_MB) * 1e6


def _idle(i: int) -> bool:
    """Whether nothing but the pool references buffer ``i`` (its list entry and getrefcount's argument)."""
    return sys.getrefcount(_pool[i]) <= 2


def empty(shape) -> np.ndarray:
    """An uninitialised float64 array of ``shape`` (C order): the memory of an idle buffer of an earlier run
    (the smallest that is large enough), or a new buffer kept for later runs."""
    shape = tuple(int(s) for s in shape)
    size = int(np.prod(shape, dtype=np.int64))
    with _lock:
        fits = [i for i in range(len(_pool)) if len(_pool[i]) >= 8 * size and _idle(i)]
        if fits:
            i = min(fits, key=lambda i: len(_pool[i]))
            raw = _pool.pop(i)
            _pool.append(raw)  # the most recently used last
            return _view(raw, shape)
        need, limit = 8.0 * size, _limit()
        total = float(sum(len(r) for r in _pool))
        i = 0
        while total + need > limit and i < len(_pool):  # make room: idle buffers, oldest first
            if _idle(i):
                total -= len(_pool.pop(i))
            else:
                i += 1
        if total + need > limit:
            return np.empty(shape)
        raw = bytearray(8 * size)
        _pool.append(raw)
        return _view(raw, shape)


def _view(raw: bytearray, shape: tuple) -> np.ndarray:
    # an array over the bytearray: its views have the array itself as their ``base`` (numpy stops collapsing a
    # chain of views at an object that is not an array), as they would of a fresh np.empty (the metrics' gather
    # recognises the log's channels as views of one 3-D buffer that way), and it references ``raw``, which
    # keeps ``raw`` busy while it or any of its views lives
    return np.ndarray(shape, dtype=np.float64, buffer=raw)


def release() -> None:
    """Drop every idle buffer (those still referenced by results stay until they are gone)."""
    with _lock:
        for i in reversed(range(len(_pool))):
            if _idle(i):
                del _pool[i]
