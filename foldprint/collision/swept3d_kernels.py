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
    na, nb = pi.shape[0], pj.shape[0]
    wi = np.empty((na, 3))
    wj = np.empty((nb, 3))
    ci = np.zeros(3)
    cj = np.zeros(3)
    for v in range(na):
        for a in range(3):
            x = pose_i[a, 0] * pi[v, 0] + pose_i[a, 1] * pi[v, 1] + pose_i[a, 2] * pi[v, 2] + pose_i[a, 3]
            wi[v, a] = x
            ci[a] += x / na
    for v in range(nb):
        for a in range(3):
            x = pose_j[a, 0] * pj[v, 0] + pose_j[a, 1] * pj[v, 1] + pose_j[a, 2] * pj[v, 2] + pose_j[a, 3]
            wj[v, a] = x
            cj[a] += x / nb
    best = -np.inf
    u = np.empty(3)
    for axis in range(3):
        if axis == 0:
            for a in range(3):
                u[a] = cj[a] - ci[a]
        elif axis == 1:
            for a in range(3):
                u[a] = pose_i[a, 2]
        else:
            for a in range(3):
                u[a] = pose_j[a, 2]
        norm = math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        if norm == 0.0:
            continue
        lo_i, hi_i, lo_j, hi_j = np.inf, -np.inf, np.inf, -np.inf
        for v in range(na):
            x = (wi[v, 0] * u[0] + wi[v, 1] * u[1] + wi[v, 2] * u[2]) / norm
            lo_i = min(lo_i, x)
            hi_i = max(hi_i, x)
        for v in range(nb):
            x = (wj[v, 0] * u[0] + wj[v, 1] * u[1] + wj[v, 2] * u[2]) / norm
            lo_j = min(lo_j, x)
            hi_j = max(hi_j, x)
        best = max(best, lo_j - hi_i, lo_i - hi_j)
    return best


@njit
def _motion(angles, k, k0, idx, lev):  # pragma: no cover - compiled
    """F(t_k) of the pair: sum over its path's hinges of lever |rho(t_k) - rho(t_k0)|."""
    f = 0.0
    for h in range(idx.shape[0]):
        f += abs(angles[k, idx[h]] - angles[k0, idx[h]]) * lev[h]
    return f


@njit
def _reach(angles, k, kb, k0, idx, lev, limit):  # pragma: no cover - compiled
    """The last sample in [k, kb] with F < ``limit`` (k itself when k + 1 is not): F rises
    with the sample (monotone coordinates), so a galloping search, then bisection."""
    if k >= kb or _motion(angles, k + 1, k0, idx, lev) >= limit:
        return k
    lo, step = k + 1, 1  # F(lo) < limit
    hi = min(kb, lo + step)
    while hi > lo and _motion(angles, hi, k0, idx, lev) < limit:
        lo = hi
        if lo >= kb:
            return kb
        step *= 2
        hi = min(kb, lo + step)
    while hi - lo > 1:  # F(lo) < limit <= F(hi)
        mid = (lo + hi) // 2
        if _motion(angles, mid, k0, idx, lev) < limit:
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
    for r in range(m):
        i, j, ka, kb = runs[r, 0], runs[r, 1], runs[r, 2], runs[r, 3]
        pi = pts[poff[i]:poff[i + 1]]
        pj = pts[poff[j]:poff[j + 1]]
        ri = idx[lo[r]:hi[r]]
        rl = lev[lo[r]:hi[r]]
        k = ka
        d = lower_bound(poses[k, i], poses[k, j], pi, pj)
        fk = 0.0
        while k < kb and d > tol:
            k2 = _reach(angles, k, kb, ka, ri, rl, fk + d - tol - margin)
            if k2 >= kb:
                k = kb
                break
            if k2 > k:
                k = k2
                fk = _motion(angles, k, ka, ri, rl)
                d = lower_bound(poses[k, i], poses[k, j], pi, pj)
                continue
            d1 = lower_bound(poses[k + 1, i], poses[k + 1, j], pi, pj)
            f1 = _motion(angles, k + 1, ka, ri, rl)
            if d1 > tol and d + d1 - (f1 - fk) - margin > 2.0 * tol:
                k, d, fk = k + 1, d1, f1
                continue
            break
        out[r] = k
    return out
