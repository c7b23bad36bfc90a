"""Compiled kernel of :mod:`foldprint.collision.broadphase`: the panels' world centroids at
every pose, which the hierarchy descent's sphere distances read.

The same sums as :func:`foldprint.collision.broadphase.panel_centres` in the same order
(R[:, 0] c_x + R[:, 1] c_y + R[:, 2] c_z + t), without its six temporary (n_t, n, 3)
arrays: equal to it bit for bit where the compiler does not contract a product and a sum
into one fused multiply-add, else to round-off (``tests/test_kernels.py``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.jit import njit


@njit
def centres(poses, centroid):  # pragma: no cover - compiled
    """World centroids (n_t, n, 3) of panels with sheet centroids ``centroid`` (n, 3) at
    ``poses`` (n_t, n, 4, 4)."""
    n_t, n = poses.shape[0], poses.shape[1]
    out = np.empty((n_t, n, 3))
    for t in range(n_t):
        for p in range(n):
            for a in range(3):
                out[t, p, a] = (poses[t, p, a, 0] * centroid[p, 0] + poses[t, p, a, 1] * centroid[p, 1]
                                + poses[t, p, a, 2] * centroid[p, 2]) + poses[t, p, a, 3]
    return out


@njit
def prefix_sums(angles, hinge, parent, child, n, y, yw):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.motion.TreeBounds.prefix`: A, B, W (n_t, n) over each
    panel's root path of |rho_h(t) - rho_h(t_0)|, weighted by 1, ``y`` and ``yw`` (= y + w),
    tree hinges (``hinge``, ``parent``, ``child``) root outward; the same sums."""
    n_t = angles.shape[0]
    A = np.zeros((n_t, n))
    B = np.zeros((n_t, n))
    W = np.zeros((n_t, n))
    for t in range(n_t):
        for f in range(hinge.shape[0]):
            h, p, c = hinge[f], parent[f], child[f]
            tf = abs(angles[t, h] - angles[0, h])
            A[t, c] = A[t, p] + tf
            B[t, c] = B[t, p] + tf * y[h]
            W[t, c] = W[t, p] + tf * yw[h]
    return A, B, W


@njit
def _sphere_gap(C, k, ra, rb, rsum):  # pragma: no cover - compiled
    """|c_ra - c_rb| - rsum at grid index k, summed as ``np.linalg.norm`` sums."""
    x = C[k, ra, 0] - C[k, rb, 0]
    y = C[k, ra, 1] - C[k, rb, 1]
    z = C[k, ra, 2] - C[k, rb, 2]
    return math.sqrt((x * x + y * y) + z * z) - rsum


@njit
def _motion_at(A, B, W, k, near, far, xn, xf, qpl2, s, l):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.motion.TreeBounds.pair_motion` of one pair at grid index k."""
    t1 = xn * (A[k, near] - A[k, s]) - (B[k, near] - B[k, s])
    t2 = (xf - qpl2) * (A[k, s] - A[k, l]) + (W[k, s] - W[k, l])
    t3 = xf * (A[k, far] - A[k, l]) - (B[k, far] - B[k, l])
    return t1 + t2 + t3


@njit
def _ensure_row(k, done, angles, ang_ref, poses, centroid, hinge, parent, child, y, yw, A, B, W, C):  # pragma: no cover
    """Fill row k of the prefix sums (as :func:`prefix_sums`, turning from ``ang_ref``) and of
    the centres (as :func:`centres`) the first time the descent reads it."""
    if done[k]:
        return
    done[k] = True
    n = A.shape[1]
    for v in range(n):
        A[k, v] = 0.0
        B[k, v] = 0.0
        W[k, v] = 0.0
        for a in range(3):
            C[k, v, a] = (poses[k, v, a, 0] * centroid[v, 0] + poses[k, v, a, 1] * centroid[v, 1]
                          + poses[k, v, a, 2] * centroid[v, 2]) + poses[k, v, a, 3]
    for f in range(hinge.shape[0]):
        h, p, c = hinge[f], parent[f], child[f]
        tf = abs(angles[k, h] - ang_ref[h])
        A[k, c] = A[k, p] + tf
        B[k, c] = B[k, p] + tf * y[h]
        W[k, c] = W[k, p] + tf * yw[h]


@njit
def _room(arr, k):  # pragma: no cover - compiled
    """``arr`` (cap, 4), doubled (its first k rows kept) when fewer than 3 rows are free past k."""
    if k + 3 <= arr.shape[0]:
        return arr
    grown = np.empty((2 * arr.shape[0] + 3, 4), np.int64)
    grown[:k] = arr[:k]
    return grown


@njit
def _set(arr, k, v0, v1, v2, v3):  # pragma: no cover - compiled
    arr[k, 0] = v0
    arr[k, 1] = v1
    arr[k, 2] = v2
    arr[k, 3] = v3


@njit
def _gaps(C, A, B, W, a, b, ka, kb, ref, rad, xc, qp, l, s, on_a):  # pragma: no cover - compiled
    """Group pair (a, b) over [ka, kb]: the sphere gaps at both ends and the growth of the
    centre motion bound between them (``TreeBounds.pair_motion``), as ``_descend`` takes them."""
    ra, rb = ref[a], ref[b]
    rsum = rad[a] + rad[b]
    da = _sphere_gap(C, ka, ra, rb, rsum)
    db = _sphere_gap(C, kb, ra, rb, rsum)
    xa, xb = xc[ra], xc[rb]
    if on_a:
        near, far, xn, xf = ra, rb, xa, xb
    else:
        near, far, xn, xf = rb, ra, xb, xa
    qpl2 = 2 * qp[l]
    dF = (_motion_at(A, B, W, kb, near, far, xn, xf, qpl2, s, l)
          - _motion_at(A, B, W, ka, near, far, xn, xf, qpl2, s, l))
    return da, db, dF


@njit
def descend(angles, ang_ref, poses, centroid, hinge, parent, child, y, yw, ref, rad, left, right, xc, qp,
            t_l, t_sp, t_on_a, t_drop, a0, b0, ka0, kb0, refine, margin):  # pragma: no cover - compiled
    """The hierarchy descent of :func:`foldprint.collision.broadphase._descend`, depth first
    (the same tests on the same numbers, one (group pair, interval) at a time: the same
    set of rows and pending pairs, in another order). The centres (world centroids at
    ``poses``, sheet centroids ``centroid``) and the prefix sums A, B, W (turning from
    ``ang_ref``, tree hinges ``hinge``, ``parent``, ``child`` root outward, weights ``y``
    and ``yw``) are computed only at the grid indices the descent reads, with the same
    sums as :func:`centres` and :func:`prefix_sums`. ``t_*``: the node pairs' static data
    (lca, split panel, side, dropped) in dense (m * m) tables. Returns narrow rows (r, 4:
    i, j, ka, kb), pending (p, 3: a, b, k) and the (group pair, interval)s examined."""
    n_t, n = poses.shape[0], poses.shape[1]
    A, B, W = np.empty((n_t, n)), np.empty((n_t, n)), np.empty((n_t, n))
    C = np.empty((n_t, n, 3))
    done = np.zeros(n_t, np.bool_)
    m = ref.shape[0]
    rows, pend, stack = np.empty((64, 4), np.int64), np.empty((64, 4), np.int64), np.empty((64, 4), np.int64)
    nr = npend = top = nodes = 0
    for q in range(a0.shape[0]):
        stack = _room(stack, top)
        _set(stack, top, a0[q], b0[q], ka0[q], kb0[q])
        top += 1
    while top > 0:
        top -= 1
        a, b, ka, kb = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
        nodes += 1
        stack = _room(stack, top)  # room for the three pairs a step can push
        if a == b:
            if left[a] >= 0:
                L, R = left[a], right[a]
                _set(stack, top, L, L, ka, kb)
                _set(stack, top + 1, R, R, ka, kb)
                _set(stack, top + 2, L, R, ka, kb)
                top += 3
            continue
        code = a * m + b
        _ensure_row(ka, done, angles, ang_ref, poses, centroid, hinge, parent, child, y, yw, A, B, W, C)
        _ensure_row(kb, done, angles, ang_ref, poses, centroid, hinge, parent, child, y, yw, A, B, W, C)
        da, db, dF = _gaps(C, A, B, W, a, b, ka, kb, ref, rad, xc, qp, t_l[code], t_sp[code], t_on_a[code])
        if da + db > dF * (1 + 1e-9) + margin or t_drop[code]:
            continue  # certified apart, or a pair not checked
        leaf_a, leaf_b = left[a] < 0, left[b] < 0
        both = leaf_a and leaf_b
        dmin = min(da, db)
        far_apart = dmin > 0 and (both or dmin > max(0.0 if leaf_a else rad[a], 0.0 if leaf_b else rad[b]))
        if refine and far_apart and kb - ka == 1:
            pend = _room(pend, npend)
            _set(pend, npend, a, b, ka, ka)
            npend += 1
        elif far_apart and kb - ka > 1:
            km = (ka + kb) // 2
            _set(stack, top, a, b, ka, km)
            _set(stack, top + 1, a, b, km, kb)
            top += 2
        elif both:
            rows = _room(rows, nr)
            _set(rows, nr, min(ref[a], ref[b]), max(ref[a], ref[b]), ka, kb)
            nr += 1
        else:
            u = a if not leaf_a and (leaf_b or rad[a] >= rad[b]) else b
            v = b if u == a else a
            _set(stack, top, left[u], v, ka, kb)
            _set(stack, top + 1, right[u], v, ka, kb)
            top += 2
    return rows[:nr].copy(), pend[:npend, :3].copy(), nodes
