"""numba's on-disk cache shared by processes that compile at once (batch workers, pytest-xdist -n 2): two
writers that save different signatures of one function must not end up with an index that maps a signature to
the other's machine code (suspension_sim.numba_cache)."""
import subprocess
import sys
import threading
import types

import pytest

pytest.importorskip("fcntl")

from suspension_sim import numba_cache  # noqa: E402


def _race(folder, save):
    """Two writers save signatures A and B of one function, both having read the index before either writes
    it (what two processes compiling at the same moment do); then a third process loads both."""
    from numba.core.caching import IndexDataCacheFile

    stamp = (1.0, 100)
    barrier = threading.Barrier(2, timeout=0.5)

    def load_index(self):
        ov = IndexDataCacheFile._load_index(self)
        try:
            barrier.wait()
        except threading.BrokenBarrierError:  # the other writer is held by the lock
            pass
        return ov

    writers = []
    for sig, code in (("sigA", "code compiled for A"), ("sigB", "code compiled for B")):
        f = IndexDataCacheFile(str(folder), "kernel-12.py311", stamp)
        f._load_index = types.MethodType(load_index, f)
        writers.append(threading.Thread(target=save, args=(f, (sig,), code)))
    for t in writers:
        t.start()
    for t in writers:
        t.join(30)
    reader = IndexDataCacheFile(str(folder), "kernel-12.py311", stamp)
    return reader.load(("sigA",)), reader.load(("sigB",))


def test_concurrent_saves_of_two_signatures_keep_both(tmp_path):
    from numba.core.caching import IndexDataCacheFile

    assert IndexDataCacheFile.save is numba_cache.locked_save
    assert _race(tmp_path, numba_cache.locked_save) == ("code compiled for A", "code compiled for B")


def test_numbas_own_save_races(tmp_path):
    """The baseline: numba's unlocked save gives both signatures data file 1; one signature is lost and the
    file may hold the other's code."""
    from numba.core.caching import IndexDataCacheFile

    got = _race(tmp_path, IndexDataCacheFile.numba_save)
    assert got != ("code compiled for A", "code compiled for B")
    assert None in got  # the index kept one entry only


def test_data_file_is_written_before_the_index_entry(tmp_path, monkeypatch):
    """A reader never finds an index entry whose data file is not (yet) that entry's."""
    from numba.core.caching import IndexDataCacheFile

    f = IndexDataCacheFile(str(tmp_path), "k-1.py311", (1.0, 1))
    order = []
    monkeypatch.setattr(f, "_save_data", lambda name, data, orig=f._save_data: (order.append("data"), orig(name, data)))
    monkeypatch.setattr(f, "_save_index", lambda ov, orig=f._save_index: (order.append("index"), orig(ov)))
    f.save(("sig",), "x")
    assert order == ["data", "index"] and f.load(("sig",)) == "x"


def test_installed_when_numba_was_imported_first():
    """(Imported after suspension_sim, numba.core.caching is patched on import: the first test's assertion.)"""
    code = ("import numba.core.caching, suspension_sim, sys; from suspension_sim import numba_cache; "
            "sys.exit(0 if sys.modules['numba.core.caching'].IndexDataCacheFile.save is numba_cache.locked_save else 1)")
    assert subprocess.run([sys.executable, "-c", code], timeout=120).returncode == 0


def test_compile_lock_makes_the_second_process_wait(tmp_path):
    """The generated loop's first call (compile or cache load) holds NAME.lock: a second holder of the same name
    (another process, or a thread: flock locks are per open file) waits until the first is done; another name
    does not wait."""
    import time

    order = []
    held = threading.Event()

    def first():
        with numba_cache.compile_lock(tmp_path, "loop_a"):
            held.set()
            time.sleep(0.3)
            order.append("first done")

    def second(name):
        held.wait(5)
        with numba_cache.compile_lock(tmp_path, name):
            order.append(f"{name} in")

    a = threading.Thread(target=first)
    b = threading.Thread(target=second, args=("loop_b",))
    c = threading.Thread(target=second, args=("loop_a",))
    for t in (a, b, c):
        t.start()
    for t in (a, b, c):
        t.join(10)
    assert order == ["loop_b in", "first done", "loop_a in"]
