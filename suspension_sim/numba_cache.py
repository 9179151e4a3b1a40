"""Numba's on-disk cache made safe for processes that compile at the same time (batch workers, pytest-xdist).

Numba writes each cached function's index (``*.nbi``: compiled signature -> data file) and data files
(``*.nbc``) atomically (temporary file + rename), so a half-written file is never read.  But saving a new
signature is an unlocked read-modify-write of the index (numba 0.5x-0.6x ``IndexDataCacheFile.save``): read the
index, take the first free data-file number, write the index, then the data.  Two processes that save two
different signatures of the same function at the same time (a kernel compiled for a C-contiguous row in one
and for a strided row in the other: 98 of this package's cached functions hold several signatures) both take
the same number; the index then maps one signature to the other's machine code, and every later process that
loads it runs code compiled for other argument types: wrong numbers (strides ignored) or a crash, until the
cache is deleted.  The index is also written before its data file, so a reader can pair a fresh index entry
with a data file of an older source version of the same number.

:func:`install` replaces that method by one that holds an exclusive ``flock`` on ``.suspension_sim.lock`` in
the cache folder for the read-modify-write, and writes the data file before the index entry that points to it.
Compiling is not serialised (only the few milliseconds of the save are), and loading takes no lock (both files
are replaced atomically, and an index entry now only ever names a finished data file of that entry).  It is
installed on ``import suspension_sim``: at once if numba is loaded, else when ``numba.core.caching`` is first
imported (``import suspension_sim`` does not import numba).  Off where ``fcntl`` is missing (Windows), and if
numba's class no longer has the methods it relies on.
"""
from __future__ import annotations

import contextlib
import importlib.abc
import importlib.util
import itertools
import os
import sys

LOCK_NAME = ".suspension_sim.lock"
_PATCHED = "_suspension_sim_locked_save"


@contextlib.contextmanager
def _flock(path: str):
    """An exclusive ``flock`` on the file ``path`` (created when missing), released on exit; a no-op where the
    folder is not writable (numba does not save there either) or ``fcntl`` is missing (Windows)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - Windows
        yield
        return
    try:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def _dir_lock(folder: str):
    """The cache folder's lock (one per folder: index writes)."""
    return _flock(os.path.join(folder, LOCK_NAME))


def compile_lock(folder, name: str):
    """An exclusive ``flock`` on ``NAME.lock`` in ``folder``, held while one process compiles the function whose
    cache file that is: another process that needs the same function at the same time waits, then loads it from
    the cache (~0.25 s) instead of compiling it a second time (3-15 s of CPU; pytest -n 2 and batch workers start
    the same loop at once).  Processes compiling different functions do not wait for each other.  A no-op
    where the folder is not writable or ``fcntl`` is missing."""
    return _flock(os.path.join(str(folder), f"{name}.lock"))


def locked_save(self, key, data):
    """``IndexDataCacheFile.save`` under the cache folder's lock, the data file written before the index."""
    with _dir_lock(self._cache_path):
        overloads = self._load_index()
        name = overloads.get(key)
        if name is not None:  # the key exists (its data failed to load): overwrite its data file
            self._save_data(name, data)
            return
        existing = set(overloads.values())
        for i in itertools.count(1):
            name = self._data_name(i)
            if name not in existing:
                break
        self._save_data(name, data)
        overloads[key] = name
        self._save_index(overloads)


def patch(caching) -> bool:
    """Install :func:`locked_save` on ``caching.IndexDataCacheFile`` (the module ``numba.core.caching``)."""
    cls = getattr(caching, "IndexDataCacheFile", None)
    if cls is None or getattr(cls, _PATCHED, False):
        return False
    if not all(hasattr(cls, m) for m in ("save", "_load_index", "_save_index", "_save_data", "_data_name")):
        return False  # pragma: no cover - a numba whose cache works differently: leave it alone
    cls.numba_save = cls.save  # numba's own (the tests race it)
    cls.save = locked_save
    setattr(cls, _PATCHED, True)
    return True


class _Loader(importlib.abc.Loader):
    def __init__(self, loader):
        self._loader = loader

    def create_module(self, spec):
        return self._loader.create_module(spec)

    def exec_module(self, module):
        self._loader.exec_module(module)
        patch(module)

    def __getattr__(self, name):  # get_source, get_filename, ... of the real loader
        return getattr(self._loader, name)


class _Hook(importlib.abc.MetaPathFinder):
    NAME = "numba.core.caching"

    def find_spec(self, fullname, path, target=None):
        if fullname != self.NAME:
            return None
        for finder in sys.meta_path:
            if finder is self or not hasattr(finder, "find_spec"):
                continue
            spec = finder.find_spec(fullname, path, target)
            if spec is not None:
                if spec.loader is not None:
                    spec.loader = _Loader(spec.loader)
                return spec
        return None


def install() -> None:
    """Lock numba's cache saves in this process (see the module docstring); idempotent."""
    mod = sys.modules.get(_Hook.NAME)
    if mod is not None:
        patch(mod)
    elif not any(isinstance(f, _Hook) for f in sys.meta_path):
        sys.meta_path.insert(0, _Hook())
