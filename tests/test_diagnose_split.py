"""The split of a record into its training and held-out parts (suspension_sim/diagnose/split.py): by events
when the default held-out part (the record's end) holds none of the record's rare events.  No simulation."""
from __future__ import annotations

import numpy as np

from suspension_sim.diagnose.io import record_from_arrays
from suspension_sim.diagnose.model import load_model
from suspension_sim.diagnose.select import Selector
from suspension_sim.diagnose.split import channel_events, choose, event_level, events

N, FS = 8000, 1000.0


def _record(bumps=(), seed=0, n=N):
    """Three output channels of smooth Gaussian background (a 1.5 Hz-ish random response plus 2 % white noise)
    with decaying 4 Hz bursts of 12 background standard deviations at the times ``bumps`` (s): a car on a
    smooth road meeting a few bumps."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / FS
    Y = []
    for j in range(3):
        f = rng.uniform(0.5, 3.0, 30)
        y = np.sum(np.sin(2 * np.pi * f[:, None] * t + rng.uniform(0, 2 * np.pi, 30)[:, None]), axis=0)
        y = y / np.std(y)
        for tb in bumps:
            m = t >= tb
            y[m] += 12.0 * np.exp(-(t[m] - tb) / 0.15) * np.sin(2 * np.pi * 4.0 * (t[m] - tb))
        Y.append(y + 0.02 * rng.standard_normal(n))
    return t, np.column_stack(Y)


def _held_out_events(Y, test):
    return int(events(Y)[test[0]:test[1]].sum())


def test_two_bumps_in_the_training_part_move_the_held_out_part_to_the_start():
    """stops_sedan_rare_bumps in small: bumps at 0.8 and 4.3 s of 8 s.  The default held-out part (the last
    30 %) holds no event sample (the baseline); the split by events holds out the start piece of the same
    length, which holds the first bump, while the training part keeps the second."""
    t, Y = _record(bumps=(0.8, 4.3))
    base = (int(round(0.7 * N)), N)
    assert _held_out_events(Y, base) == 0  # the old split: nothing rare held out
    ch = choose(Y, 0.7)
    assert ch["by_events"] and len(ch["episodes"]) == 2, ch
    assert ch["test"] == (0, N - base[0]) and ch["train"] == (N - base[0], N), ch
    ev = events(Y)
    assert ev[slice(*ch["test"])].any() and ev[slice(*ch["train"])].any()
    # the boundary lies at least half a gate block from every event sample
    assert not ev[ch["test"][1] - N // 40: ch["test"][1] + N // 40].any()


def test_the_default_split_is_kept_when_it_holds_an_event_or_there_is_nothing_to_share():
    # an event in the held-out part
    _, Y = _record(bumps=(0.8, 6.5))
    ch = choose(Y, 0.7)
    assert not ch["by_events"] and ch["test"] == (5600, N), ch
    # one event only: it cannot be both fitted and held out
    _, Y = _record(bumps=(2.0,))
    ch = choose(Y, 0.7)
    assert not ch["by_events"] and len(ch["episodes"]) == 1 and ch["test"] == (5600, N), ch
    # no event (a stationary Gaussian record)
    _, Y = _record()
    ch = choose(Y, 0.7)
    assert not ch["by_events"] and ch["episodes"] == [] and ch["test"] == (5600, N), ch


def test_a_boundary_never_cuts_an_event_and_the_length_stays_near_the_default():
    """Bumps at 1.5, 2.35 and 4.0 s: the start piece of the default length (2.4 s) would end inside the second
    bump's ringing; the boundary moves to the nearest place half a block clear of every event sample, and
    both parts keep whole events."""
    _, Y = _record(bumps=(1.5, 2.35, 4.0))
    ch = choose(Y, 0.7)
    assert ch["by_events"], ch
    p = ch["test"][1] if ch["test"][0] == 0 else ch["test"][0]
    for e0, e1 in ch["episodes"]:
        assert p <= e0 - N // 40 or p > e1 + N // 40, (p, ch["episodes"])
    assert abs((ch["test"][1] - ch["test"][0]) - 2400) < 0.1 * N
    ev = events(Y)
    assert ev[slice(*ch["test"])].any() and ev[slice(*ch["train"])].any()


def test_gaussian_records_rarely_hold_an_event():
    """The event level is what a Gaussian record of that many samples and channels exceeds anywhere with
    probability 0.0455 (z > 2, Bonferroni over the samples): on independent Gaussian records of 8 000 × 3
    samples the share with a sample beyond it stays near that (12 of 200), and an event needs two such samples
    of a channel within a block, which none of them has; a channel with no spread has none."""
    rng = np.random.default_rng(1)
    recs = [rng.standard_normal((N, 3)) for _ in range(200)]
    beyond = sum(bool(channel_events(Y).any()) for Y in recs)
    assert beyond / 200 < 0.1, beyond
    assert not any(events(Y).any() for Y in recs)
    assert 4.7 < event_level(N, 3) < 4.85
    assert events(np.ones((N, 3))).sum() == 0


def test_a_lone_spike_in_the_held_out_part_is_not_an_event_but_a_contact_on_one_channel_is():
    """The potholes record in small (blind battery stops_suv_rare_potholes): one friction spike of one sample
    just beyond the level in the wheel acceleration at 6.0 s kept the old split when any sample beyond the level
    counted; it is not an event.  A real event in the held-out part, seen in one channel only (a stop's contact
    in the accelerations while the travel stays within its range: stops_truck_damped), keeps the default."""
    _, Y = _record(bumps=(0.8, 4.3))
    lev = event_level(N, 3)
    s = 1.4826 * np.median(np.abs(Y[:, 1] - np.median(Y[:, 1])))
    Y[6000, 1] = np.median(Y[:, 1]) + 1.05 * lev * s
    assert channel_events(Y)[5600:, 1].any()  # beyond the level in the held-out part
    ch = choose(Y, 0.7)
    assert ch["by_events"] and ch["test"] == (0, 2400), ch
    _, Y = _record(bumps=(0.8, 4.3))
    t = np.arange(N) / FS
    m = t >= 6.5
    Y[m, 0] += 12.0 * np.exp(-(t[m] - 6.5) / 0.15) * np.sin(2 * np.pi * 4.0 * (t[m] - 6.5))
    ch = choose(Y, 0.7)
    assert not ch["by_events"] and ch["test"] == (5600, N), ch


def test_the_selector_holds_out_the_events_and_the_baseline_does_not():
    t, Y = _record(bumps=(0.8, 4.3))
    rec = record_from_arrays("quarter_car", t, {"road": np.zeros(N)},
                             {c: Y[:, j] for j, c in enumerate(("body_acc", "wheel_acc", "susp_travel"))})
    spec = {"model": "quarter_car", "params": {"sprung_mass": 385.0, "unsprung_mass": 46.0,
                                               "spring_stiffness": 25500.0, "damping": 1850.0,
                                               "tire_stiffness": 235000.0, "tire_damping": 0.0}}
    sel = Selector(rec, load_model(spec))
    assert sel.test == (0, 2400) and sel.train == (2400, N) and sel.split_info["by_events"]

    class Old(Selector):
        event_split = False

    old = Old(rec, load_model(spec))
    assert old.test == (5600, N) and old.train == (0, 5600) and old.split_info is None
    # a separate test record is never re-split
    sep = Selector(rec, load_model(spec), test_record=rec)
    assert sep.train == (0, N) and sep.test == (0, N)
