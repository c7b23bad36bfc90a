"""numpy's sums, compiled to the same bits: a row's pairwise sum of squares and its norm, in
numpy's order of additions (``np.add.reduce`` over a contiguous row: blocks of eight running
sums, runs over 128 halved), so that the loop tracker's compiled bookkeeping
(:mod:`foldprint.physics.loops.tracker_kernels`) takes the same decisions as its numpy
reference, whose norms are :func:`foldprint.physics.loops.corrector.norms`. Imported lazily,
only where :func:`foldprint.core.jit.use_kernels` says yes.
"""

from __future__ import annotations

import numpy as np

from ...core.jit import njit


@njit
def block(a, lo, n):  # pragma: no cover - compiled
    """numpy's pairwise sum of a block a[lo:lo + n], n <= 128: eight running sums."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r = a[lo:lo + 8].copy()
    i = 8
    while i < n - n % 8:
        for j in range(8):
            r[j] += a[lo + i + j]
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@njit
def pairwise(a):  # pragma: no cover - compiled
    """numpy's pairwise sum of a (its order of additions, so its bits): blocks of at most
    128 summed by :func:`block`, longer runs halved (at a multiple of 8), the halves added;
    the halving walked with an explicit stack (a cached compiled function must not recurse)."""
    if a.shape[0] <= 128:
        return block(a, 0, a.shape[0])
    los, ns, part = np.zeros(64, np.int64), np.zeros(64, np.int64), np.zeros(64)
    state = np.zeros(64, np.int64)  # 0: not begun, 1: left half summed into part
    los[0], ns[0], top, out = 0, a.shape[0], 0, 0.0
    while top >= 0:
        lo, n = los[top], ns[top]
        n2 = n // 2 - (n // 2) % 8
        if n <= 128 or state[top] == 2:
            v = block(a, lo, n) if n <= 128 else part[top]
            top -= 1
            if top < 0:
                out = v
            elif state[top] == 0:
                part[top], state[top] = v, 1
            else:
                part[top], state[top] = part[top] + v, 2
            continue
        if state[top] == 0:
            los[top + 1], ns[top + 1] = lo, n2
        else:
            los[top + 1], ns[top + 1] = lo + n2, n - n2
        state[top + 1] = 0
        top += 1
    return out


@njit
def norm(a, b):  # pragma: no cover - compiled
    """corrector.norms of the row a - b."""
    sq = np.empty(a.shape[0])
    for j in range(a.shape[0]):
        d = a[j] - b[j]
        sq[j] = d * d
    return np.sqrt(pairwise(sq))
