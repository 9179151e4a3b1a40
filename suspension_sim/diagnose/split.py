"""Where the record is split into its training and held-out parts: by default the last ``1 − split`` of it is
held out; **a split by events** when that part holds none of the record's rare events.

Every gate of the search (select.py) judges a candidate by what it predicts on samples it was not fitted on.
An effect that acts only in rare events (a bump stop met on two bumps of an otherwise smooth road) can be
judged only when the held-out part holds an event: on the blind battery's ``stops_sedan_rare_bumps`` both
bumps (0.8 and 4.0 s of 8 s) fell in the training 70 %, the held-out part held no contact (nominal held-out
error 0.0201 against a true floor of 0.0199), so no gate could pass and nothing was named although the
training part showed the stop.

*Events* (:func:`events`): samples where a measured output leaves the range a Gaussian record of that
channel's robust scale (1.4826·MAD about the median) reaches only with probability ``ALPHA`` over the whole
record (all samples and channels, Bonferroni: the two-sided level of the gate's z > 2, 0.0455), with a second
such sample of the channel within one of the gate's 20 blocks (a lone one is chance or a sharp spike: a
friction step); the outputs only (the inputs are what the record was driven with, the outputs what the car
did, e.g. met a stop).  Event samples closer than a block are one *episode*.

*The split* (:func:`choose`): the default held-out part (the record's end) is kept when the record has fewer
than two episodes (an event seen once cannot be both fitted and checked) or when the held-out part holds one.
Otherwise the held-out part is the end piece or the start piece of the record (the two pieces that leave a
contiguous training part, which the search fits simulated from the record's start; a start piece is simulated
through, driven by its inputs only, and its outputs are not used in training) that holds at least one whole
episode while the training part keeps one, whose boundary lies at least half a block from any event sample,
and whose length is closest to the default's (ties: the end piece).  The gates keep their meaning: an effect is
named only when it predicts data it was not fitted on.

Cost: only a record whose events all fall in the training part is split otherwise; then its fits simulate
the start piece as well (up to 1/split more per simulation).  Records whose held-out part holds an event,
or that have none, are split as before, to the sample.
"""
from __future__ import annotations

import numpy as np

ALPHA = 0.0455  # the chance, over the whole record, that Gaussian data reach the event level (z > 2 two-sided)
BLOCKS = 20  # the gate's contiguous held-out blocks (select.Selector._gate): an episode's merging distance


def event_level(n_samples: int, n_channels: int = 1, alpha: float = ALPHA) -> float:
    """The level, in robust standard deviations, that a Gaussian record of ``n_samples`` × ``n_channels``
    independent samples exceeds (in absolute value) anywhere with probability ``alpha`` (Bonferroni; correlated
    samples exceed it less often).  8 000 samples of three channels: 4.76."""
    from scipy.stats import norm

    return float(norm.isf(alpha / (2.0 * max(1, n_samples) * max(1, n_channels))))


def channel_events(Y: np.ndarray) -> np.ndarray:
    """Boolean mask (n, channels) of the event samples of the outputs ``Y`` (n, channels): beyond
    :func:`event_level` robust standard deviations from the channel's median.  A channel with no spread (MAD 0)
    has none."""
    Y = np.asarray(Y, float).reshape(len(Y), -1)
    n, c = Y.shape
    lev = event_level(n, c)
    mask = np.zeros((n, c), bool)
    for j in range(c):
        y = Y[:, j]
        med = float(np.median(y))
        s = 1.4826 * float(np.median(np.abs(y - med)))
        if s > 0:
            mask[:, j] = np.abs(y - med) > lev * s
    return mask


def events(Y: np.ndarray, gap: int | None = None) -> np.ndarray:
    """Boolean mask of the event samples of the outputs ``Y`` (n, channels): samples beyond the level in some
    channel (:func:`channel_events`) with another of that channel's within ``gap`` samples (default one of the
    gate's blocks).  A lone sample beyond the level is not an event: a Gaussian record holds one with
    probability ``ALPHA`` by construction of the level, and a sharp spike (a friction step at 1 kHz) makes one;
    two in one block by chance have a probability of order ALPHA²."""
    ev = channel_events(Y)
    n = len(ev)
    gap = max(1, n // BLOCKS) if gap is None else gap
    out = np.zeros(n, bool)
    for j in range(ev.shape[1]):
        idx = np.flatnonzero(ev[:, j])
        if idx.size < 2:
            continue
        d = np.diff(idx)
        near = np.zeros(idx.size, bool)
        near[1:] |= d < gap
        near[:-1] |= d < gap
        out[idx[near]] = True
    return out


def episodes(mask: np.ndarray, gap: int) -> list[tuple[int, int]]:
    """The runs of event samples as [first, last] sample pairs, runs closer than ``gap`` samples merged."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return []
    out = [[int(idx[0]), int(idx[0])]]
    for i in idx[1:]:
        if i - out[-1][1] < gap:
            out[-1][1] = int(i)
        else:
            out.append([int(i), int(i)])
    return [tuple(e) for e in out]


def choose(Y: np.ndarray, split: float) -> dict:
    """The training and held-out parts of a record with outputs ``Y`` (module docstring).  Returns
    {"train": (a, b), "test": (a, b), "by_events": bool, "episodes": [(first, last) samples], "reason": str}."""
    n = len(Y)
    b = int(round(split * n))
    gap = max(1, n // BLOCKS)
    eps = episodes(events(Y, gap), gap)
    default = {"train": (0, b), "test": (b, n), "by_events": False, "episodes": eps}
    if len(eps) < 2:
        default["reason"] = ("no rare event in the outputs" if not eps else
                             "one rare event only: it cannot be both fitted and held out")
        return default
    if any(e1 >= b for _, e1 in eps):
        default["reason"] = "the held-out part holds a rare event"
        return default
    margin = max(1, gap // 2)
    n_test = n - b
    lo, hi = int(np.ceil(0.05 * n)) + 1, int(np.floor(0.95 * n)) - 1
    best = None
    # the length closest to the default's is at the default's boundary or next to an episode
    cands = {b, n_test} | {e1 + margin + 1 for _, e1 in eps} | {e0 - margin for e0, _ in eps}
    for p in sorted(c for c in cands if lo <= c <= hi):
        if any(e0 - margin < p <= e1 + margin for e0, e1 in eps):
            continue  # the boundary cuts an episode, or lies within half a block of one
        before = sum(1 for _, e1 in eps if e1 < p)
        if not 0 < before < len(eps):
            continue
        for side, m in (("end", n - p), ("start", p)):
            key = (abs(m - n_test), side != "end")
            if best is None or key < best[0]:
                best = (key, side, p)
    if best is None:
        default["reason"] = "the rare events cannot be shared between the two parts"
        return default
    _, side, p = best
    train, test = ((0, p), (p, n)) if side == "end" else ((p, n), (0, p))
    share = (test[1] - test[0]) / n
    return {"train": train, "test": test, "by_events": True, "episodes": eps,
            "reason": (f"split by events: the last {1 - split:.0%} held none of the record's {len(eps)} rare "
                       f"events; the {side} piece, {share:.0%} of the record (samples {test[0]}–{test[1]}), is "
                       f"held out")}
