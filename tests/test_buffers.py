"""Work buffers reused between runs (:mod:`suspension_sim.buffers`): a buffer is handed out again only when
nothing references it any more, so a run never writes into the log that an earlier run's results still read,
and a run on a reused (dirty) buffer gives the same numbers as on a fresh one."""
from __future__ import annotations

import gc

import numpy as np
import pytest

from suspension_sim import buffers
from suspension_sim.config import parse_scenario
from suspension_sim.simulation import Simulation


@pytest.fixture(autouse=True)
def _empty_pool(monkeypatch):
    """A pool of this test's own: buffers still referenced by results of earlier tests in the same worker
    (module fixtures of other files under pytest-xdist) stay busy in the shared pool and spoiled the counts."""
    gc.collect()
    monkeypatch.setattr(buffers, "_pool", [])
    yield
    gc.collect()
    buffers.release()


def _addr(a):
    return a.__array_interface__["data"][0]


def test_a_buffer_is_reused_only_when_nothing_references_it():
    a = buffers.empty((100, 7, 3))
    a[:] = 1.0
    held = a[5]  # a view keeps the buffer busy
    p = _addr(a)
    del a
    b = buffers.empty((100, 7, 3))
    assert _addr(b) != p  # still referenced through the view: a new buffer
    del held
    c = buffers.empty((50, 7, 3))  # idle now: the same memory, also for a smaller shape
    assert _addr(c) == p and c.shape == (50, 7, 3) and c.flags.c_contiguous
    buffers.release()
    assert len(buffers._pool) == 2  # b and c are busy: kept; nothing idle to drop
    del b, c
    buffers.release()
    assert not buffers._pool


def test_the_pool_is_bounded(monkeypatch):
    monkeypatch.setenv("SUSPENSION_SIM_LOG_BUFFER_MB", "1")
    a = buffers.empty((200_000,))  # 1.6 MB: larger than the bound, not kept
    assert not buffers._pool
    b = buffers.empty((60_000,))  # 0.48 MB: kept
    del b
    c = buffers.empty((70_000,))  # the idle one is too small; it is dropped to make room for this one
    assert len(buffers._pool) == 1 and len(buffers._pool[0]) == 8 * 70_000
    del a, c


def _scs(amp):
    return [parse_scenario({"name": f"c{i}", "vehicle": {"model": "quarter_car"},
                            "road": {"type": "sine", "params": {"amplitude": amp * (1 + 0.1 * i), "frequency": 1.5}},
                            "controller": {"type": "skyhook"}, "sensors": [{"type": "corner_body_vel"}], "sim": {"duration": 0.4}})
            for i in range(3)]


@pytest.mark.parametrize("log_channels", ["metrics", "all"])
def test_runs_keep_their_logs_and_a_reused_buffer_gives_the_same_numbers(log_channels):
    first = Simulation(_scs(0.01), log_channels=log_channels).run()
    ts0 = [r.view().columns for r in first]
    keep = [{k: np.array(v) for k, v in c.items()} for c in ts0]
    m0 = [dict(r.metrics) for r in first]
    second = Simulation(_scs(0.03), log_channels=log_channels).run()  # while the first results are alive
    for cols, kept in zip(ts0, keep):
        for k in kept:
            assert np.array_equal(cols[k], kept[k], equal_nan=True)  # not overwritten
    assert second[0].metrics["body_acc_rms"] != m0[0]["body_acc_rms"]
    addr = {_addr(np.frombuffer(raw)) for raw in buffers._pool}
    del first, ts0, second
    gc.collect()
    again = Simulation(_scs(0.01), log_channels=log_channels).run()  # on the buffers of the runs above
    cols = again[0].view().columns
    assert any(_addr(a.base) in addr for a in cols.values() if isinstance(a.base, np.ndarray))  # reused
    if log_channels == "metrics":  # the compiled loop's log channels: views of its 3-D buffer, gathered at once
        assert all(a.base.ndim == 3 for k, a in cols.items() if k != "t")
    for r, kept, m in zip(again, keep, m0):
        assert r.metrics == m
        c = r.view().columns
        for k in kept:
            assert np.array_equal(c[k], kept[k], equal_nan=True)
