"""Processes we start die with us: worker processes and servers never outlive the command that started them.

- :func:`die_with_parent` (Linux): ``prctl(PR_SET_PDEATHSIG, SIGTERM)`` in a child process, so the kernel
  sends it SIGTERM when its parent dies, whatever the cause (SIGKILL included); if the parent is already gone
  when it is called, the child exits at once.  Used as the initializer of batch worker processes, as the
  ``preexec_fn`` of the viewer server, and on Dask workers and nannies of a local cluster.
- :func:`install_signal_handlers`: SIGTERM (and SIGHUP) in the main process raise ``SystemExit`` like Ctrl-C
  raises ``KeyboardInterrupt``, so ``finally`` blocks and ``atexit`` handlers run (pools shut down, the
  viewer server is terminated, partial batch results are flushed).
- :class:`DeferredSignals`: while a process pool is driven, those exceptions are raised only where the caller
  checks for them, never at an arbitrary bytecode inside ``concurrent.futures`` (see its docstring).
"""
from __future__ import annotations

import os
import signal
import sys
import threading

PR_SET_PDEATHSIG = 1


def die_with_parent(sig: int = signal.SIGTERM, parent_pid: int | None = None) -> bool:
    """Ask the kernel to send ``sig`` to this process when its parent dies (Linux); True if set.  With
    ``parent_pid``, exit at once if the parent has already changed (it died before the call)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        ok = libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0) == 0
    except Exception:  # noqa: BLE001 - best effort
        return False
    if parent_pid is not None and os.getppid() != parent_pid:
        os._exit(1)
    return ok


def child_preexec(parent_pid: int | None = None):
    """A ``preexec_fn`` for :class:`subprocess.Popen`: the child dies with this process."""
    pid = parent_pid if parent_pid is not None else os.getpid()

    def fn():
        die_with_parent(signal.SIGTERM, pid)

    return fn


def worker_initializer(parent_pid: int) -> None:
    """Initializer of pool worker processes: SIGTERM kills (a forked worker inherits the parent's handler, which
    would turn it into an exception the pool catches), SIGINT is ignored (the parent handles Ctrl-C), the
    worker dies with its parent, and what it inherited is frozen for the garbage collector (:func:`freeze_gc`)."""
    try:
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    except (ValueError, OSError):  # pragma: no cover
        pass
    die_with_parent(signal.SIGTERM, parent_pid)
    freeze_gc()


def freeze_gc() -> None:
    """Move every object alive now (in a worker: the imported modules, numba's and MuJoCo's, the sweep it was
    forked with; ~250,000) to the garbage collector's permanent generation (``gc.freeze``).  Python's full
    collections otherwise walk all of them again every few ensembles: ~140 ms each on this machine, a sixth of
    the 256-car benchmark ensemble's bare stepping, against ~4 ms frozen.  Frozen objects are still freed by
    reference counting; only reference cycles among them are never collected.  For a forked worker it also
    keeps the collector from writing into the parent's pages (Python's documented use of ``gc.freeze``)."""
    import gc

    gc.freeze()


_INSTALLED = False


def _raise_exit(signum, frame):  # pragma: no cover - exercised through subprocess tests
    raise SystemExit(128 + signum)


def install_signal_handlers() -> None:
    """SIGTERM/SIGHUP raise SystemExit in the main thread (cleanup runs); once per process."""
    global _INSTALLED
    if _INSTALLED or threading.current_thread() is not threading.main_thread():
        return
    _INSTALLED = True
    for name in ("SIGTERM", "SIGHUP"):
        sig = getattr(signal, name, None)
        if sig is None:
            continue
        try:
            if signal.getsignal(sig) in (signal.SIG_DFL, None):
                signal.signal(sig, _raise_exit)
        except (ValueError, OSError):  # pragma: no cover
            pass


class DeferredSignals:
    """While active (a ``with`` block in the main thread), SIGINT, SIGTERM and SIGHUP whose handler would raise
    (Python's ``KeyboardInterrupt``, :func:`install_signal_handlers`' ``SystemExit``) only record the signal;
    :meth:`check` then calls the previous handler (so the same exception is raised) at a point the caller chose.

    Why: an exception raised by a signal handler can surface at any bytecode of the main thread, including the
    instant after ``concurrent.futures`` acquired a future's condition lock (``wait()``'s ``_AcquireFutures``,
    ``Future.result()``, ``threading.Condition.__enter__``) and before the ``with`` block that releases it is set
    up.  The lock is then held forever; the pool's manager thread blocks on it when it cancels or fails that
    future, and interpreter exit joins the manager thread: the process hangs after Ctrl-C with its workers
    already dead.  Deferring the exception to :meth:`check`, which is called outside the pool's locks, removes
    that window.  Signals whose handler is ``SIG_DFL``/``SIG_IGN`` are left alone, and outside the main thread
    this does nothing."""

    NAMES = ("SIGINT", "SIGTERM", "SIGHUP")

    def __init__(self):
        self.signum: int | None = None
        self._prev: dict[int, object] = {}

    def _record(self, signum, frame):
        if self.signum is None:
            self.signum = signum

    def __enter__(self):
        if threading.current_thread() is not threading.main_thread():
            return self
        for name in self.NAMES:
            sig = getattr(signal, name, None)
            if sig is None:
                continue
            try:
                prev = signal.getsignal(sig)
                if callable(prev):
                    signal.signal(sig, self._record)
                    self._prev[sig] = prev
            except (ValueError, OSError):  # pragma: no cover
                pass
        return self

    def __exit__(self, *exc):
        for sig, prev in self._prev.items():
            try:
                signal.signal(sig, prev)
            except (ValueError, OSError):  # pragma: no cover
                pass
        self._prev.clear()
        return False

    @property
    def pending(self) -> bool:
        return self.signum is not None

    def check(self) -> None:
        """Raise what the recorded signal's own handler raises (once); nothing if no signal came."""
        signum, self.signum = self.signum, None
        if signum is not None:
            prev = self._prev.get(signum)
            if callable(prev):
                prev(signum, None)
