"""MuJoCo's C entry points for numba-compiled code, bound by symbol name.

The library is the one shipped next to the ``mujoco`` Python package (the very library the bindings use, so
``MjModel._address`` / ``MjData._address`` point at structures of the same version).  Binding by name (LLVM
resolves the symbol in the loaded library) keeps process-specific addresses out of the compiled code, so
numba's on-disk cache works; ctypes function pointers would force a recompilation in every process."""
from __future__ import annotations

import glob
import os

import mujoco

_LIB = None
_ERROR = None


def library_path() -> str | None:
    here = os.path.dirname(mujoco.__file__)
    for pat in ("libmujoco.so*", "libmujoco*.dylib", "mujoco.dll"):
        hits = sorted(glob.glob(os.path.join(here, pat)))
        if hits:
            return hits[0]
    return None


def load() -> str | None:
    """Load the MuJoCo library for LLVM; returns None when done, else why it cannot be used."""
    global _LIB, _ERROR
    if _LIB is None and _ERROR is None:
        path = library_path()
        if path is None:
            _ERROR = "the MuJoCo shared library was not found next to the mujoco package"
        else:
            try:
                import llvmlite.binding as llvm

                llvm.load_library_permanently(path)
                _LIB = path
            except Exception as exc:  # pragma: no cover - platform specific
                _ERROR = f"cannot load {path}: {exc}"
            no_timers(path)
    return _ERROR


def no_timers(path: str) -> None:
    """Switch off MuJoCo's profiling timers (``mjData.timer``) for the process: the Python bindings install a
    clock as ``mjcb_time``, which ``mj_step`` reads at the start and end of each of its ~20 stages (~1 µs per
    step on the 2-core machine: 45 % of a one-car quarter-car step, the size of most diagnose runs).  Nothing
    here reads the timers; every number MuJoCo computes stays the same.  The mujoco package's own setter
    ``set_mjcb_time(None)`` puts its clock back, so the library's pointer is cleared directly."""
    try:
        import ctypes

        ctypes.c_void_p.in_dll(ctypes.CDLL(path), "mjcb_time").value = None
    except Exception:  # pragma: no cover - platform specific: the timers stay (slower, same results)
        pass


load()

from numba import types  # noqa: E402

# void mj_step1(const mjModel* m, mjData* d), pointers passed as 64-bit integers (MjModel._address)
mj_step1 = types.ExternalFunction("mj_step1", types.void(types.uint64, types.uint64))
mj_step2 = types.ExternalFunction("mj_step2", types.void(types.uint64, types.uint64))
mj_step = types.ExternalFunction("mj_step", types.void(types.uint64, types.uint64))
# void mj_forwardSkip(const mjModel* m, mjData* d, int skipstage, int skipsensor)
mj_forwardSkip = types.ExternalFunction("mj_forwardSkip", types.void(types.uint64, types.uint64, types.intc, types.intc))
