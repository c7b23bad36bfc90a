"""The swept check's narrow phase compiled: every candidate pair run the screen leaves
walked, split and refined in one call (:func:`walk_runs`), with the same rules and the
same numbers as :meth:`foldprint.collision.swept3d.SweptChecker.steps`, ``_split`` and
``_refine`` (the reference, and the path for drives with loops or arrests).

A run is walked from its first sample on exact distances (the compiled
``polytope_distance_kernels.panel_bounds``) and the pair's motion bound F (its path's
levers, F = sum lever |rho - rho(start)|): far apart it jumps to the last sample F has
not grown past by 0.9 d; close, an interval the two distances do not certify is bisected
in continuous time, each split time's poses made here (the drive's ``driven_at`` and the
tree's ``chain_poses``, the calls the reference makes one by one through Python); a
contact is refined to its first touching time. Runs are taken in the order they are
given (their first sample); one whose walk has passed the earliest contact found so far
stops (it cannot come first), as the reference's heap stops. F is summed hinge by hinge
where the reference takes numpy's matrix product: the same terms, round-off apart.

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import numpy as np

from ..core.jit import njit, stale_with
from ..physics import kinematics_kernels
from . import polytope_distance_kernels, swept3d_kernels
from ..physics.kinematics_kernels import chain_poses, driven_at
from .polytope_distance_kernels import panel_bounds
from .swept3d_kernels import motion

#: a run's outcome in :func:`walk_runs`' ``status``
NONE, CONTACT, INITIAL = 0, 1, 2


@njit
def _gap(pose_i, pose_j, i, j, geo):  # pragma: no cover - compiled
    """The exact distance of panels i and j at their poses (``geo``: the prisms' arrays
    and the certificate's tolerances, as ``panel_bounds`` takes them)."""
    ring, piece_off, panel_off, half, cen, rad, cert_abs, cert_rel = geo
    return panel_bounds(pose_i, pose_j, i, j, ring, piece_off, panel_off, half, cen, rad, cert_abs, cert_rel)[0]


@njit
def _poses_at(t, drv, kin):  # pragma: no cover - compiled
    """(every panel's world pose (n, 4, 4), the hinge angles (n_hinges,)) at time ``t``:
    ``HingeDrive.angles_at`` and ``TreeTransforms.poses`` in one."""
    grid, stack, target, fixity = drv
    hinge, parent, child, root, n, k, kk, q, start, nrm, line, w, centred, point = kin
    ang = driven_at(grid, stack, t, target, fixity)
    return chain_poses(ang, hinge, parent, child, root, n, k, kk, q, start, nrm, line, w, centred, point,
                       True)[0], ang[0]


@njit
def _motion(ang, ang0, idx, lev):  # pragma: no cover - compiled
    """F at angles ``ang``: sum over the path's hinges of lever |rho - rho0|."""
    f = 0.0
    for h in range(idx.shape[0]):
        f += abs(ang[idx[h]] - ang0[idx[h]]) * lev[h]
    return f


@njit
def _gap_at(t, i, j, drv, kin, geo):  # pragma: no cover - compiled
    w, ang = _poses_at(t, drv, kin)
    return _gap(w[i], w[j], i, j, geo), ang


@njit
def _refine(t, d, i, j, drv, kin, geo, time_tol, calls):  # pragma: no cover - compiled
    """(contact time, distance, the time of the nearest points) from a time ``t`` with
    distance ``d`` <= tol: the first touching time to within ``time_tol`` when it comes
    within 12 doubling steps (``SweptChecker._refine``). ``calls[0]`` counts distances."""
    lo, hi, found, step = t, t, False, time_tol
    if d > 0:
        for _ in range(12):
            cand = lo + step
            calls[0] += 1
            if _gap_at(cand, i, j, drv, kin, geo)[0] <= 0:
                hi, found = cand, True
                break
            step *= 2
        if found:
            while hi - lo > time_tol:
                mid = 0.5 * (lo + hi)
                calls[0] += 1
                if _gap_at(mid, i, j, drv, kin, geo)[0] <= 0:
                    hi = mid
                else:
                    lo = mid
    if found:
        return hi, 0.0, lo
    return t, d, lo


@njit
def _split(ta, da, fa, tb, db, fb, i, j, ang0, idx, lev, drv, kin, geo, tol, time_tol, rel,
           calls):  # pragma: no cover - compiled
    """``SweptChecker._split`` without recursion (a stack, the earlier half first):
    (found, contact time, distance, nearest-point time) in [ta, tb]."""
    stack = np.empty((16, 6))  # the intervals still to look at, the earlier half on top
    stack[0, 0], stack[0, 1], stack[0, 2], stack[0, 3], stack[0, 4], stack[0, 5] = ta, da, fa, tb, db, fb
    top = 1
    while top:
        top -= 1
        ta, da, fa = stack[top, 0], stack[top, 1], stack[top, 2]
        tb, db, fb = stack[top, 3], stack[top, 4], stack[top, 5]
        if da <= tol:
            t, d, lo = _refine(ta, da, i, j, drv, kin, geo, time_tol, calls)
            return True, t, d, lo
        if (da + db) * (1 - rel) > fb - fa:
            continue
        if tb - ta <= time_tol / 16:
            t, d, lo = _refine(ta, da, i, j, drv, kin, geo, time_tol, calls)
            return True, t, d, lo
        tm = 0.5 * (ta + tb)
        calls[0] += 1
        dm, ang = _gap_at(tm, i, j, drv, kin, geo)
        fm = _motion(ang, ang0, idx, lev)
        dm = min(dm, da + fm - fa, db + fb - fm)
        if top + 2 > stack.shape[0]:
            more = np.empty((2 * stack.shape[0], 6))
            more[:top] = stack[:top]
            stack = more
        stack[top, 0], stack[top, 1], stack[top, 2] = tm, dm, fm
        stack[top, 3], stack[top, 4], stack[top, 5] = tb, db, fb
        stack[top + 1, 0], stack[top + 1, 1], stack[top + 1, 2] = ta, da, fa
        stack[top + 1, 3], stack[top + 1, 4], stack[top + 1, 5] = tm, dm, fm
        top += 2
    return False, 0.0, 0.0, 0.0


@njit
def _jump(angles, k0, k, k1, target, idx, lev):  # pragma: no cover - compiled
    """The last sample in [k, k1] whose F is <= ``target`` (F rises with the sample; k's
    is): galloping, then bisection (the reference's ``bisect_right`` on F)."""
    lo, step = k, 1  # F(lo) <= target
    hi = min(k1, lo + step)
    while hi > lo and motion(angles, hi, k0, idx, lev) <= target:
        lo = hi
        step *= 2
        hi = min(k1, lo + step)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if motion(angles, mid, k0, idx, lev) <= target:
            lo = mid
        else:
            hi = mid
    return lo


@njit
def _finish(r, status, out, code, t, d, at):  # pragma: no cover - compiled
    status[r] = code
    out[r, 0], out[r, 1], out[r, 2] = t, d, at


@njit
def _start(r, i, j, k, times, poses, drv, kin, geo, tol, time_tol, calls, status, out):  # pragma: no cover
    """A run's first sample (the reference's first step): its distance, or the run ends
    there (an initial contact at the first sample, else a contact refined)."""
    calls[0] += 1
    d = _gap(poses[k, i], poses[k, j], i, j, geo)
    if d <= tol:
        if k == 0:
            _finish(r, status, out, INITIAL, times[k], d, times[k])
        else:
            t, dd, lo = _refine(times[k], d, i, j, drv, kin, geo, time_tol, calls)
            _finish(r, status, out, CONTACT, t, dd, lo)
    return d


@njit
def _step(r, i, j, k0, k1, k, d, times, angles, poses, idx, lev, drv, kin, geo, tol, time_tol, rel, calls,
          status, out):  # pragma: no cover - compiled
    """One step of a run from sample ``k`` at distance ``d`` (the reference's loop body,
    from one ``yield`` to the next): (the next sample, its distance), or ``status[r]``
    set (a contact) or the next sample k1 (safe to the run's end)."""
    ck = motion(angles, k, k0, idx, lev)
    kk = _jump(angles, k0, k, k1, ck + 0.9 * d, idx, lev)
    if kk >= k1:
        return k1, d
    if kk > k:
        calls[0] += 1
        d = min(_gap(poses[kk, i], poses[kk, j], i, j, geo), d + motion(angles, kk, k0, idx, lev) - ck)
        if d <= tol:
            t, dd, lo = _refine(times[kk], d, i, j, drv, kin, geo, time_tol, calls)
            _finish(r, status, out, CONTACT, t, dd, lo)
        return kk, d
    c1 = motion(angles, k + 1, k0, idx, lev)
    calls[0] += 1
    d1 = min(_gap(poses[k + 1, i], poses[k + 1, j], i, j, geo), d + c1 - ck)
    if (d + d1) * (1 - rel) <= c1 - ck:
        found, t, dd, lo = _split(times[k], d, ck, times[k + 1], d1, c1, i, j, angles[k0], idx, lev, drv, kin,
                                  geo, tol, time_tol, rel, calls)
        if found:
            _finish(r, status, out, CONTACT, t, dd, lo)
            return k + 1, d1
    if d1 <= tol:
        t, dd, lo = _refine(times[k + 1], d1, i, j, drv, kin, geo, time_tol, calls)
        _finish(r, status, out, CONTACT, t, dd, lo)
    return k + 1, d1


@njit
def _push(heap, n, key):  # pragma: no cover - compiled
    """``key`` into the binary min-heap ``heap[:n]``; returns the new size."""
    c = n
    heap[c] = key
    while c > 0:
        p = (c - 1) // 2
        if heap[p] <= heap[c]:
            break
        heap[p], heap[c] = heap[c], heap[p]
        c = p
    return n + 1


@njit
def _pop(heap, n):  # pragma: no cover - compiled
    """The smallest key of the heap ``heap[:n]``, removed (the heap is then ``heap[:n - 1]``)."""
    key = heap[0]
    n -= 1
    heap[0] = heap[n]
    c = 0
    while True:
        a, b, m = 2 * c + 1, 2 * c + 2, c
        if a < n and heap[a] < heap[m]:
            m = a
        if b < n and heap[b] < heap[m]:
            m = b
        if m == c:
            return key
        heap[m], heap[c] = heap[c], heap[m]
        c = m


@njit
def walk_runs(budget, runs, times, angles, poses, idx, lev, lo, hi, drv, kin, geo, tol, time_tol, rel,
              at, dist, status, out, best):  # pragma: no cover - compiled
    """Advance the runs (m, 4: i, j, ka, kb; ``idx`` / ``lev``: path hinges and levers,
    run r's from ``lo[r]`` to ``hi[r]``) together in time, as the reference's heap does:
    always the run at the earliest sample (then the lowest index), until one is past the
    earliest contact found or ``budget`` distances have been computed. State, kept between
    calls: each run's sample ``at`` (-1: not started) and distance ``dist``, its ``status``
    (NONE open or safe, CONTACT, INITIAL) and ``out`` row (time, distance, nearest-point
    time), ``best`` (the earliest contact's run, its time; -1 and inf for none). Returns
    (finished: no run left to advance, distances computed)."""
    m = runs.shape[0]
    calls = np.zeros(1, np.int64)
    heap, n = np.empty(m, np.int64), 0  # (sample, run) keys: sample * m + run
    for r in range(m):
        if status[r] == NONE and (at[r] < 0 or at[r] < runs[r, 3]):
            n = _push(heap, n, max(at[r], runs[r, 2]) * m + r)
    while n and calls[0] < budget:
        key = _pop(heap, n)
        n -= 1
        k, r = key // m, key % m
        if best[0] >= 0 and times[k] > best[1]:
            return True, calls[0]
        i, j, k1 = runs[r, 0], runs[r, 1], runs[r, 3]
        ri, rl = idx[lo[r]:hi[r]], lev[lo[r]:hi[r]]
        if at[r] < 0:
            dist[r] = _start(r, i, j, k, times, poses, drv, kin, geo, tol, time_tol, calls, status, out)
            at[r] = k
        elif k < k1:
            at[r], dist[r] = _step(r, i, j, runs[r, 2], k1, k, dist[r], times, angles, poses, ri, rl, drv, kin,
                                   geo, tol, time_tol, rel, calls, status, out)
        if status[r] == CONTACT:
            if best[0] < 0 or out[r, 0] < best[1]:
                best[0], best[1] = r, out[r, 0]
        elif status[r] == NONE and at[r] < k1:
            n = _push(heap, n, at[r] * m + r)
    return n == 0, calls[0]


stale_with(__name__, (kinematics_kernels, polytope_distance_kernels, swept3d_kernels))
