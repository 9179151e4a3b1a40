"""numba versions of numpy reductions that add in numpy's own order, so compiled kernels reproduce numpy
results bit for bit (see the kernel protocol in suspension_sim/compiled/__init__.py)."""
from __future__ import annotations

import numba
import numpy as np

@numba.njit(cache=True)
def pairwise_block(a, lo, n):
    """numpy's pairwise summation of a[lo:lo+n] for n <= 128 (8 accumulators), same additions, same order."""
    if n < 8:
        res = -0.0
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@numba.njit(cache=True)
def pairwise_sum(a, lo, n):
    """numpy's pairwise summation of a[lo:lo+n] (np.sum along a contiguous axis): blocks of <= 128 summed
    by pairwise_block, longer runs split in halves (multiples of 8) as numpy does; numpy's recursion is
    written out by :func:`pairwise_plan` (a recursive function does not survive numba's cache)."""
    if n <= 128:
        return pairwise_block(a, lo, n)
    leaf_lo, leaf_n, merges = pairwise_plan(n)
    stack = np.empty(64)
    top = 0
    for li in range(leaf_lo.shape[0]):
        stack[top] = pairwise_block(a, lo + leaf_lo[li], leaf_n[li])
        top += 1
        for _ in range(merges[li]):
            stack[top - 2] = stack[top - 2] + stack[top - 1]
            top -= 1
    return stack[0]


@numba.njit(cache=True)
def sign(x):
    """np.sign of a float: -1, 0 or 1, and NaN for NaN."""
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    if x == 0.0:
        return 0.0
    return x  # NaN


# ----------------------------------------------------------------------------------------------------------
# pairwise_sum of every column of a (rows, columns) array at once: the same tree of additions per column, so
# the same numbers as pairwise_sum of each column alone, with the columns (e.g. the cars of a step-major log)
# side by side in each addition (one vector instruction for several columns)
# ----------------------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def pairwise_plan(n):
    """The leaves of numpy's pairwise summation of n terms in order, ``(lo, length)``, and after each leaf the
    number of merges (left + right of a finished node) that follow it: pairwise_sum's recursion written out."""
    cap = 2 * (n // 64) + 4
    lo = np.empty(cap, np.int64)
    ln = np.empty(cap, np.int64)
    merges = np.zeros(cap, np.int64)
    s_lo = np.empty(64, np.int64)
    s_n = np.empty(64, np.int64)
    s_stage = np.empty(64, np.int64)
    nl = 0
    depth = 0
    s_lo[0], s_n[0], s_stage[0] = 0, n, 0
    while True:
        if s_n[depth] <= 128:
            lo[nl], ln[nl] = s_lo[depth], s_n[depth]
            nl += 1
            depth -= 1
            while depth >= 0:
                if s_stage[depth] == 0:
                    s_stage[depth] = 1
                    n2 = s_n[depth] // 2
                    n2 -= n2 % 8
                    depth += 1
                    s_lo[depth], s_n[depth], s_stage[depth] = s_lo[depth - 1] + n2, s_n[depth - 1] - n2, 0
                    break
                merges[nl - 1] += 1
                depth -= 1
            if depth < 0:
                return lo[:nl], ln[:nl], merges[:nl]
        else:
            n2 = s_n[depth] // 2
            n2 -= n2 % 8
            depth += 1
            s_lo[depth], s_n[depth], s_stage[depth] = s_lo[depth - 1], n2, 0


@numba.njit(cache=True, inline="always")
def leaf_sums(T, ln, acc, res):
    """res[c] = pairwise_block(T[:, c], 0, ln) for every column c of the leaf's terms ``T`` (>= ln rows);
    ``acc`` (8, columns) scratch."""
    m = res.shape[0]
    if ln < 8:
        for c in range(m):
            res[c] = -0.0
        for i in range(ln):
            for c in range(m):
                res[c] += T[i, c]
        return
    for k in range(8):
        for c in range(m):
            acc[k, c] = T[k, c]
    i = 8
    while i < ln - (ln % 8):
        for k in range(8):
            for c in range(m):
                acc[k, c] += T[i + k, c]
        i += 8
    for c in range(m):
        res[c] = ((acc[0, c] + acc[1, c]) + (acc[2, c] + acc[3, c])) + ((acc[4, c] + acc[5, c]) + (acc[6, c] + acc[7, c]))
    while i < ln:
        for c in range(m):
            res[c] += T[i, c]
        i += 1


@numba.njit(cache=True, inline="always")
def push_leaf(stack, top, res, merges):
    """Push a leaf's sums ``res`` on ``stack`` (depth, columns) and merge the finished nodes (left + right, as
    pairwise_sum adds its halves); returns the new top.  After the last leaf the total is ``stack[0]``."""
    m = res.shape[0]
    for c in range(m):
        stack[top, c] = res[c]
    top += 1
    for _ in range(merges):
        for c in range(m):
            stack[top - 2, c] = stack[top - 2, c] + stack[top - 1, c]
        top -= 1
    return top
