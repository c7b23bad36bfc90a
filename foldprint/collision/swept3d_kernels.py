"""Compiled screen between the swept check's broad and narrow phases: which samples of a
candidate pair run (:func:`foldprint.collision.broadphase.candidate_runs`) need FCL.

A run's panel pair is walked from its first sample as the narrow phase walks it
(:meth:`foldprint.collision.swept3d.SweptChecker.steps`), but on a lower bound of the
distance instead of FCL's: the largest separation of the two panels' prism vertices
projected on three axes (the centroids' direction and each panel's normal). The convex
hull of a panel's vertices holds the panel, and the projections of two sets on a unit axis
are at least their distance apart, so the bound is never above the true distance. With the
pair's motion bound F (``SweptChecker.cumulative_motion``, the same levers), a sample k
with bound d certifies every later sample k' with F(k') - F(k) < d - tol, and an interval
[k, k + 1] is certified when d(k) + d(k + 1) - (F(k + 1) - F(k)) > 2 tol: the distance
stays above the contact tolerance throughout (the narrow phase's rules, one tol stricter,
so no sample the screen passes over is one where the narrow phase could see a contact).
The walk stops at the first sample it cannot certify; the narrow phase starts there (or
the run is dropped when certified to its end). Each bound costs ~0.1 us where an FCL
distance through python-fcl costs ~20 us.

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.jit import njit


@njit
def lower_bound(pose_i, pose_j, pi, pj):  # pragma: no cover - compiled
    """A lower bound of the distance between the convex hulls of the vertices ``pi`` (a,
    3) at ``pose_i`` and ``pj`` (b, 3) at ``pose_j`` (panel frames, (4, 4) poses)."""
    return _bound(pose_i, pose_j, pi, pj, np.empty((pi.shape[0], 3)), np.empty((pj.shape[0], 3)))


@njit
def _world(pose, pts, out):  # pragma: no cover - compiled
    """``pts`` (a, 3) at ``pose`` into ``out``; returns their mean (summed as x / a)."""
    na = pts.shape[0]
    c0 = c1 = c2 = 0.0
    for v in range(na):
        x0 = pose[0, 0] * pts[v, 0] + pose[0, 1] * pts[v, 1] + pose[0, 2] * pts[v, 2] + pose[0, 3]
        x1 = pose[1, 0] * pts[v, 0] + pose[1, 1] * pts[v, 1] + pose[1, 2] * pts[v, 2] + pose[1, 3]
        x2 = pose[2, 0] * pts[v, 0] + pose[2, 1] * pts[v, 1] + pose[2, 2] * pts[v, 2] + pose[2, 3]
        out[v, 0], out[v, 1], out[v, 2] = x0, x1, x2
        c0 += x0 / na
        c1 += x1 / na
        c2 += x2 / na
    return c0, c1, c2


@njit
def _extent(w, n, u0, u1, u2, norm):  # pragma: no cover - compiled
    """The smallest and largest projection of the first ``n`` points of ``w`` on u / norm."""
    lo, hi = np.inf, -np.inf
    for v in range(n):
        x = (w[v, 0] * u0 + w[v, 1] * u1 + w[v, 2] * u2) / norm
        lo = min(lo, x)
        hi = max(hi, x)
    return lo, hi


@njit
def _bound(pose_i, pose_j, pi, pj, wi, wj):  # pragma: no cover - compiled
    """:func:`lower_bound` with scratch ``wi`` and ``wj`` for the world vertices (no
    allocation: the screen calls it hundreds of times a sample): the largest gap between
    the two sets' projections on the centroids' direction and on each panel's normal."""
    na, nb = pi.shape[0], pj.shape[0]
    ci0, ci1, ci2 = _world(pose_i, pi, wi)
    cj0, cj1, cj2 = _world(pose_j, pj, wj)
    best = -np.inf
    for axis in range(3):
        if axis == 0:
            u0, u1, u2 = cj0 - ci0, cj1 - ci1, cj2 - ci2
        elif axis == 1:
            u0, u1, u2 = pose_i[0, 2], pose_i[1, 2], pose_i[2, 2]
        else:
            u0, u1, u2 = pose_j[0, 2], pose_j[1, 2], pose_j[2, 2]
        norm = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
        if norm == 0.0:
            continue
        lo_i, hi_i = _extent(wi, na, u0, u1, u2, norm)
        lo_j, hi_j = _extent(wj, nb, u0, u1, u2, norm)
        best = max(best, lo_j - hi_i, lo_i - hi_j)
    return best


@njit
def motion(angles, k, k0, idx, lev):  # pragma: no cover - compiled
    """F(t_k) of the pair: sum over its path's hinges of lever |rho(t_k) - rho(t_k0)|."""
    f = 0.0
    for h in range(idx.shape[0]):
        f += abs(angles[k, idx[h]] - angles[k0, idx[h]]) * lev[h]
    return f


@njit
def _reach(angles, k, kb, k0, idx, lev, limit):  # pragma: no cover - compiled
    """The last sample in [k, kb] with F < ``limit`` (k itself when k + 1 is not): F rises
    with the sample (monotone coordinates), so a galloping search, then bisection."""
    if k >= kb or motion(angles, k + 1, k0, idx, lev) >= limit:
        return k
    lo, step = k + 1, 1  # F(lo) < limit
    hi = min(kb, lo + step)
    while hi > lo and motion(angles, hi, k0, idx, lev) < limit:
        lo = hi
        if lo >= kb:
            return kb
        step *= 2
        hi = min(kb, lo + step)
    while hi - lo > 1:  # F(lo) < limit <= F(hi)
        mid = (lo + hi) // 2
        if motion(angles, mid, k0, idx, lev) < limit:
            lo = mid
        else:
            hi = mid
    return lo


@njit
def screen_runs(runs, angles, poses, pts, poff, idx, lev, lo, hi, tol, margin):  # pragma: no cover - compiled
    """The first sample of each run (m, 4: i, j, ka, kb) the screen cannot certify (kb when
    it certifies the whole run). ``pts`` / ``poff``: every panel's prism vertices (panel
    frame) and their offsets; ``idx`` / ``lev``: path hinges and levers, run r's from
    ``lo[r]`` to ``hi[r]``; ``tol``: the contact tolerance; ``margin``: added to every
    motion bound (round-off of the bound and of the motion sums)."""
    m = runs.shape[0]
    out = np.empty(m, np.int64)
    big = 0
    for p in range(poff.shape[0] - 1):
        big = max(big, poff[p + 1] - poff[p])
    wi = np.empty((big, 3))
    wj = np.empty((big, 3))
    for r in range(m):
        i, j, ka, kb = runs[r, 0], runs[r, 1], runs[r, 2], runs[r, 3]
        pi = pts[poff[i]:poff[i + 1]]
        pj = pts[poff[j]:poff[j + 1]]
        ri = idx[lo[r]:hi[r]]
        rl = lev[lo[r]:hi[r]]
        k = ka
        d = _bound(poses[k, i], poses[k, j], pi, pj, wi, wj)
        fk = 0.0
        while k < kb and d > tol:
            k2 = _reach(angles, k, kb, ka, ri, rl, fk + d - tol - margin)
            if k2 >= kb:
                k = kb
                break
            if k2 > k:
                k = k2
                fk = motion(angles, k, ka, ri, rl)
                d = _bound(poses[k, i], poses[k, j], pi, pj, wi, wj)
                continue
            d1 = _bound(poses[k + 1, i], poses[k + 1, j], pi, pj, wi, wj)
            f1 = motion(angles, k + 1, ka, ri, rl)
            if d1 > tol and d + d1 - (f1 - fk) - margin > 2.0 * tol:
                k, d, fk = k + 1, d1, f1
                continue
            break
        out[r] = k
    return out
