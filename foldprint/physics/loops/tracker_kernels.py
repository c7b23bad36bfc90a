"""The loop tracker's bookkeeping between two compiled rounds, compiled: which drives' points
have all stopped, the end of their steps (the answer chosen, the window's answers kept) and
their next points (skips, sub-steps, predictor starts, restarts from the drive, windows), in
one call a round (``docs/loops.md``, "Little work per round").

The numpy code of :mod:`foldprint.physics.loops.tracker` and
:mod:`foldprint.physics.loops.drive_state` is the reference; this is the same arithmetic
drive by drive, each rule a scalar loop, so a drive's answers are the same bits: the
predictor's two matrix-vector products are ``np.dot``, the BLAS ``gemv`` numpy's ``matmul``
calls, and a norm sums its squares in numpy's pairwise order
(:mod:`~foldprint.physics.loops.pairwise_kernels`). Imported lazily, only where
:func:`foldprint.core.jit.use_kernels` says yes.

The arrays travel as three tuples: ``st`` a :class:`~foldprint.physics.loops.drive_state.DriveState`'s,
``rq`` the tracker's requests', ``pl`` a :class:`~foldprint.physics.loops.corrector.Pool`'s
with its stack of free rows and their count (``nf``, one element). Pool rows are never
grown here: the caller sizes the pool for every point a drive can hold at once.
"""

from __future__ import annotations

import numpy as np

from ...core.jit import njit, stale_with
from . import corrector, drive_state, pairwise_kernels
from .corrector import MAX_STEP, OPT_TOL
from .drive_state import (ACCEPT, FOLLOW_TOL, JUMP, LINE_ABOVE, LOST_TOL, NEAR_FLAT, PREFETCH, RESTART_SIDED, SKIP_FAR,
                          SKIP_TOL, WINDOW)
from .pairwise_kernels import norm


@njit
def _amax(v):  # pragma: no cover - compiled
    """np.abs(v).max(initial=0.0): nan if any element is."""
    m = 0.0
    for j in range(v.shape[0]):
        a = abs(v[j])
        if a != a:
            return a
        m = max(m, a)
    return m


@njit
def _amax_diff(a, b):  # pragma: no cover - compiled
    """np.abs(a - b).max(initial=0.0)."""
    m = 0.0
    for j in range(a.shape[0]):
        d = abs(a[j] - b[j])
        if d != d:
            return d
        m = max(m, d)
    return m


@njit
def _predict(x, target, basis, free, work):  # pragma: no cover - compiled
    """corrector.predict of one point, into work[2] (work: (3, n) scratch rows)."""
    n = x.shape[0]
    v, t, out = work[0], work[1], work[2]
    for j in range(n):
        v[j] = target[j] - x[j]
    np.dot(basis.T, v, t)
    for j in range(n):
        t[j] = (1.0 if free[j] else 0.0) * t[j]
    np.dot(basis, t, v)  # the step
    big = _amax(v)
    f = big if big != big else min(1.0, MAX_STEP / max(big, 1e-300))
    for j in range(n):
        out[j] = x[j] + v[j] * f
    return out


@njit
def _put(dst, src):  # pragma: no cover - compiled
    """dst[:] = src (1-D), as a loop: numba's generic slice assignment is large code."""
    for j in range(src.shape[0]):
        dst[j] = src[j]


@njit
def _add(pl, x, target, spec, far, taken, line, guide, tag):  # pragma: no cover - compiled
    """Pool.add of one point; returns its row."""
    px, ptarget, it, pspec, pfar, plain, res, null, done, _, _, alive, pline, pguide, ptag, stack, nf = pl
    if nf[0] == 0:
        raise RuntimeError("loop tracker: pool rows exhausted")
    nf[0] -= 1
    r = stack[nf[0]]
    _put(px[r], x)
    _put(ptarget[r], target)
    it[r], pspec[r], pfar[r], alive[r], plain[r] = taken, spec, far, True, not far
    res[r], done[r], null[r], ptag[r], pline[r] = np.inf, False, 0, tag, line
    if line:
        _put(pguide[r], guide)
    return r


@njit
def _release(pl, r):  # pragma: no cover - compiled
    pl[11][r] = False
    stack, nf = pl[15], pl[16]
    stack[nf[0]] = r
    nf[0] += 1


@njit
def _forget(rq, pl, i):  # pragma: no cover - compiled
    """Drop the restarts drive i started ahead."""
    early, early_k = rq[7], rq[8]
    for s in range(early.shape[1]):
        if early[i, s] >= 0:
            _release(pl, early[i, s])
        early[i, s], early_k[i, s] = -1, -1


@njit
def _settle(st, pl, i, r):  # pragma: no cover - compiled
    """DriveState.settle of drive i with the answer of pool row r."""
    x, basis, free, tangent, plain, settled, xmax, line, dof, res_x = (st[2], st[3], st[4], st[5], st[6], st[7], st[8],
                                                                        st[9], st[15], st[17])
    _put(x[i], pl[0][r])
    res_x[i] = pl[6][r]
    settled[i] = pl[8][r]
    tangent[i] = pl[8][r]
    for a in range(basis.shape[1]):
        _put(basis[i, a], pl[9][r, a])
    _put(free[i], pl[10][r])
    line[i] = np.count_nonzero(free[i]) == 1
    plain[i] = pl[5][r]
    xmax[i] = big = _amax(x[i])
    if dof[i] < 0 and big > 1e-3:
        dof[i] = pl[7][r]


@njit
def _worse(a, b):  # pragma: no cover - compiled
    """np.maximum(a, b): nan if either is."""
    if a != a or b != b:
        return a + b
    return a if a >= b else b


@njit
def _finish(st, i, y, x, res, null):  # pragma: no cover - compiled
    """DriveState.finish of drive i: its answer x for drive y ends grid step k."""
    times, prev, k, sub, locked, worst, out = st[0], st[10], st[11], st[12], st[14], st[16], st[19]
    kk = k[i]
    if null == 0 and locked[i] != locked[i] and _amax_diff(x, y) > FOLLOW_TOL:
        locked[i] = times[kk]
    worst[i] = _worse(worst[i], res)
    _put(prev[i], y)
    _put(out[i, kk], x)
    k[i] = kk + 1
    sub[i] = 0


@njit
def _choose(st, rq, pl, i, rows, b):  # pragma: no cover - compiled
    """tracker._choose of drive i: its main solve's row, or its restart's row b."""
    px, res = pl[0], pl[6]
    xn, xb, yb, x0 = px[rows], px[b], rq[6][i], st[2][i]
    take = (_amax_diff(xn, yb) > OPT_TOL and res[b] <= LOST_TOL and norm(xb, yb) < norm(xn, yb) - 1e-9
            and _amax_diff(xb, x0) <= _amax_diff(xn, x0) + JUMP)
    if take:
        for j in range(xb.shape[0]):
            if xb[j] * yb[j] < 0.0:
                take = False
    return b if take else rows


@njit
def _needless(st, i, y):  # pragma: no cover - compiled
    """DriveState.needless of drive i's restart from drive y."""
    x = st[2][i]
    if not (st[5][i] and _amax(y) >= RESTART_SIDED):
        return False
    for j in range(x.shape[0]):
        if not (x[j] * y[j] > 0.0 and abs(x[j]) > OPT_TOL):
            return False
    return True


@njit
def _after_main(st, rq, pl, i, r):  # pragma: no cover - compiled
    """tracker._after_main of drive i, its answer in pool row r; returns whether its step
    ended converged."""
    times, x, settled, k, sub, nsub, locked, res_x = st[0], st[2], st[7], st[11], st[12], st[13], st[14], st[17]
    lost = pl[6][r] > LOST_TOL
    if lost:
        settled[i] = True
        if locked[i] != locked[i]:
            locked[i] = times[k[i]]
    else:
        _settle(st, pl, i, r)
    ended = lost or sub[i] >= nsub[i]
    if not ended:
        sub[i] += 1
    else:
        _finish(st, i, rq[5][i], x[i], res_x[i], pl[7][r])
    return not lost and ended and pl[8][r]


@njit
def _acceptable(pl, prev, row, y, work):  # pragma: no cover - compiled
    """tracker._acceptable of one window point."""
    px, res, null, done, basis, free = pl[0], pl[6], pl[7], pl[8], pl[9], pl[10]
    if not (done[prev] and done[row] and res[row] <= LOST_TOL and _amax(px[prev]) >= NEAR_FLAT
            and null[row] == null[prev]):
        return False
    return _amax_diff(_predict(px[prev], y, basis[prev], free[prev], work), px[row]) <= ACCEPT


@njit
def _keep(st, rq, pl, i, w, ok, main, work):  # pragma: no cover - compiled
    """tracker._window and _keep of drive i (window width w > 1, its step's answer in pool
    row ``main``, ``ok`` that step converged): the accepted prefix of its window's answers
    ends their steps; widths double while whole windows are kept, else shrink."""
    times, driven, k, locked, dof, worst, width, out = st[0], st[1], st[11], st[14], st[15], st[16], st[18], st[19]
    px, res, null, window = pl[0], pl[6], pl[7], rq[3]
    k0 = k[i]
    nacc = 0
    if ok:
        for o in range(1, w):
            if not _acceptable(pl, main if o == 1 else window[i, o - 2], window[i, o - 1], driven[i, k0 + o - 1],
                               work):
                break
            nacc += 1
    width[i] = min(2 * width[i], WINDOW) if nacc == w - 1 else max(2, nacc + 1)
    if nacc == 0:
        return
    unfolded, first_stop, folded = dof[i] < 0, np.inf, -1
    for o in range(1, nacc + 1):
        r, kk = window[i, o - 1], k0 + o - 1
        x = px[r]
        _put(out[i, kk], x)
        if null[r] == 0 and _amax_diff(x, driven[i, kk]) > FOLLOW_TOL:
            first_stop = min(first_stop, times[kk])
        worst[i] = _worse(worst[i], res[r])
        if unfolded and folded < 0 and _amax(x) > 1e-3:
            folded = r
    if locked[i] != locked[i] and first_stop < np.inf:
        locked[i] = first_stop
    if folded >= 0:
        dof[i] = null[folded]
    last = window[i, nacc - 1]
    _settle(st, pl, i, last)
    _put(st[10][i], driven[i, k0 + nacc - 1])
    k[i] = k0 + nacc


@njit
def _ended(st, rq, pl, i, work):  # pragma: no cover - compiled
    """tracker._ended of drive i: its points have all stopped."""
    main, b, w, window = rq[1][i], rq[2][i], rq[4][i], rq[3]
    chosen = main if b < 0 else _choose(st, rq, pl, i, main, b)
    ok = _after_main(st, rq, pl, i, chosen)
    if w > 1:
        _keep(st, rq, pl, i, w, ok, chosen, work)
    _release(pl, main)
    if b >= 0:
        _release(pl, b)
    for o in range(w - 1):
        _release(pl, window[i, o])
    rq[0][i] = False


@njit
def _skip(st, i):  # pragma: no cover - compiled
    """DriveState.skip of drive i."""
    driven, x, tangent, settled, xmax, prev = st[1], st[2], st[5], st[7], st[8], st[10]
    k, sub, out = st[11], st[12], st[19]
    kk, n_t = k[i], driven.shape[1]
    if not (kk > 0 and kk < n_t and settled[i] and sub[i] == 0):
        return
    tol = SKIP_FAR if tangent[i] and xmax[i] >= NEAR_FLAT else SKIP_TOL
    if not _amax_diff(driven[i, kk], prev[i]) <= tol:
        return
    nxt = n_t
    for m in range(kk + 1, n_t):
        if _amax_diff(driven[i, m], prev[i]) > tol:
            nxt = m
            break
    for m in range(kk, nxt):
        _put(out[i, m], x[i])
    k[i] = nxt


@njit
def _restarts(st, rq, pl, i, ys):  # pragma: no cover - compiled
    """tracker._Requests._restarts of drive i: the row of its restart from the drive at step
    k (taken from those started ahead where it is exactly this one), and the restarts of the
    restarting steps among the next PREFETCH started ahead."""
    driven, k, sub, nsub, restarts = st[1], st[11], st[12], st[13], st[20]
    early, early_k, target = rq[7], rq[8], pl[1]
    kk, n_t, row = k[i], driven.shape[1], -1
    run = not _needless(st, i, ys)  # else this step's restart is not run (nor kept from ahead)
    if PREFETCH:
        own = kk % PREFETCH
        if run and early_k[i, own] == kk and nsub[i] == 1 and sub[i] == 1:
            e = early[i, own]
            same = True
            for j in range(ys.shape[0]):
                same = same and target[e, j] == ys[j]
            if same:
                row = e
                early[i, own] = -1
    for s in range(early.shape[1]):
        if early_k[i, s] >= 0 and early_k[i, s] <= kk:
            if early[i, s] >= 0:
                _release(pl, early[i, s])
            early_k[i, s], early[i, s] = -1, -1
    if run and row < 0:
        row = _add(pl, ys, ys, False, False, 0, False, ys, -1)
    if row >= 0:
        pl[14][row] = i
    for m in range(1, PREFETCH + 1):
        want = kk + m
        slot = want % PREFETCH
        if early_k[i, slot] != want and want < n_t and restarts[i, min(want, n_t - 1)]:
            y0 = driven[i, want - 1]
            y1 = y0 + (driven[i, want] - y0)  # the step's target as begin() computes it
            if not _needless(st, i, y1):
                early[i, slot] = _add(pl, y1, y1, False, False, 0, False, y1, -1)
                early_k[i, slot] = want
    return row


@njit
def _post(st, rq, pl, i, work):  # pragma: no cover - compiled
    """tracker._Requests.post of drive i: its next points into the pool."""
    driven, x, basis, free, tangent, plain = st[1], st[2], st[3], st[4], st[5], st[6]
    xmax, line, prev = st[8], st[9], st[10]
    k, sub, nsub, width, restarts, run = st[11], st[12], st[13], st[18], st[20], st[21]
    kk, n = k[i], x.shape[1]
    y = driven[i, kk]
    if sub[i] == 0:  # DriveState.begin
        nsub[i] = int(max(1.0, np.ceil(_amax_diff(y, prev[i]) / MAX_STEP)))
        sub[i] = 1
    f = sub[i] / nsub[i]
    ys = np.empty(n)
    for j in range(n):
        ys[j] = prev[i, j] + (y[j] - prev[i, j]) * f
    near = xmax[i] < NEAR_FLAT
    pred = not near and tangent[i]
    first = near and tangent[i] and plain[i]
    start, taken = x[i].copy(), 0
    if pred or first:  # tracker._starts
        p = _predict(x[i], ys, basis[i], free[i], work)
        if pred or _amax_diff(p, x[i]) >= OPT_TOL:
            _put(start, p)
            taken = 1 if first else 0
    w = min(1 + min(run[i, kk], WINDOW), width[i]) if pred and nsub[i] == 1 else 1
    col = 0  # the first free direction: the line's, where the tangent space is one
    while col < n - 1 and not free[i, col]:
        col += 1
    guide = basis[i, :, col]
    lined = line[i] and (pred or (tangent[i] and xmax[i] >= LINE_ABOVE))  # tracker._Requests.post's line
    rq[1][i] = _add(pl, start, ys, False, pred, taken, lined, guide, i)
    rq[2][i] = -1
    flat = near and _amax(ys) < NEAR_FLAT  # the drive too
    if flat and restarts[i, kk]:
        rq[2][i] = _restarts(st, rq, pl, i, ys)
    if not flat:
        _forget(rq, pl, i)
    for o in range(1, w):
        rq[3][i, o - 1] = _add(pl, _predict(x[i], driven[i, kk + o], basis[i], free[i], work), driven[i, kk + o],
                               True, True, 0, line[i], guide, i)
    _put(rq[5][i], y)
    _put(rq[6][i], ys)
    rq[4][i], rq[0][i] = w, True


@njit
def between(first, st, rq, pl):  # pragma: no cover - compiled
    """Everything the tracker does between two rounds (tracker.track's loop body but the
    round): unless ``first``, the drives whose points have all stopped end their step
    (every drive on the first call); those drives skip idle steps, drop their restarts
    ahead when done, else post their next points. Returns the number of live points."""
    s, n_t = st[2].shape[0], st[1].shape[1]
    work = np.empty((3, st[2].shape[1]))
    if first:
        todo = np.arange(s)
    else:
        busy = np.zeros(s, np.bool_)
        alive, tag = pl[11], pl[14]
        for r in range(alive.shape[0]):
            if alive[r] and tag[r] >= 0:
                busy[tag[r]] = True
        todo = np.empty(s, np.int64)
        m = 0
        for i in range(s):
            if rq[0][i] and not busy[i]:
                todo[m] = i
                m += 1
        todo = todo[:m]
        for i in todo:
            _ended(st, rq, pl, i, work)
    for i in todo:
        _skip(st, i)
        if st[11][i] >= n_t:
            _forget(rq, pl, i)
        else:
            _post(st, rq, pl, i, work)
    return np.count_nonzero(pl[11])


stale_with(__name__, (corrector, drive_state, pairwise_kernels))
