"""Compiled kernel of :mod:`foldprint.physics.kinematics`: every panel's world pose, hinge
by hinge down the spanning tree, one time at a time.

The map is :class:`~foldprint.physics.kinematics.TreeTransforms`' (the child's edge of
:func:`~foldprint.physics.kinematics.hinge_map`): the rotation I + sin(rho) K + (1 - cos
rho) K^2 about the hinge axis; ``point``: the translation q - R q; ``arc``: the strip's
tip, start + u sinc(rho) n + u (1 - cos rho) / rho z (u the arc length: the flat width, or
for a ``centred`` frame the width times (rho/2) / tan(rho/2)), less R times the child's
edge line. The pose of a child is its parent's pose times that transform, as
:func:`~foldprint.physics.kinematics.forward` takes it; the products are summed in the same
order, the sines and cosines are the compiler's (LLVM's libm against numpy's own), so the
poses agree with the reference to round-off (measured up to 3.4e-13 mm on the templates'
100 mm helices, asserted below 1e-11 of the sheet's size in ``tests/test_kernels.py``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.jit import njit


@njit
def chain_poses(angles, hinge, parent, child, root, n_panels, k, kk, q, start, nrm, line, w, centred, point,
                fill_eye):  # pragma: no cover - compiled
    """Poses (n_t, n_panels, 4, 4) for hinge angles (n_t, n_hinges): per tree hinge h (tree
    order, parents first) its ``hinge`` index, ``parent`` and ``child`` panel, its axis's
    cross-product matrix ``k`` (and ``kk`` = K^2), fold-line point ``q``, strip start,
    in-plane normal ``nrm``, child's edge ``line``, flat width ``w`` and whether it is
    ``centred``; ``point``: the point hinge model (else arc). Panels off the tree are
    the identity with ``fill_eye``, else 0 (as ``forward`` leaves them). The rotation and
    translation are held in scalars (registers), the bottom row written, not multiplied."""
    n_t = angles.shape[0]
    nh = hinge.shape[0]
    poses = np.empty((n_t, n_panels, 4, 4))
    on_tree = np.zeros(n_panels, np.bool_)
    on_tree[root] = True
    for h in range(nh):
        on_tree[child[h]] = True
    for t in range(n_t):
        P = poses[t]
        for p in range(n_panels):
            if not on_tree[p] or p == root:  # the root and panels off the tree
                d = 1.0 if (fill_eye or p == root) else 0.0
                for a in range(4):
                    for b in range(4):
                        P[p, a, b] = d if a == b else 0.0
        for h in range(nh):
            ang = angles[t, hinge[h]]
            s = math.sin(ang)
            c1 = 1.0 - math.cos(ang)
            r00 = (1.0 + s * k[h, 0, 0]) + c1 * kk[h, 0, 0]
            r01 = (0.0 + s * k[h, 0, 1]) + c1 * kk[h, 0, 1]
            r02 = (0.0 + s * k[h, 0, 2]) + c1 * kk[h, 0, 2]
            r10 = (0.0 + s * k[h, 1, 0]) + c1 * kk[h, 1, 0]
            r11 = (1.0 + s * k[h, 1, 1]) + c1 * kk[h, 1, 1]
            r12 = (0.0 + s * k[h, 1, 2]) + c1 * kk[h, 1, 2]
            r20 = (0.0 + s * k[h, 2, 0]) + c1 * kk[h, 2, 0]
            r21 = (0.0 + s * k[h, 2, 1]) + c1 * kk[h, 2, 1]
            r22 = (1.0 + s * k[h, 2, 2]) + c1 * kk[h, 2, 2]
            if point:
                q0, q1, q2 = q[h, 0], q[h, 1], q[h, 2]
                t0 = q0 - (r00 * q0 + r01 * q1 + r02 * q2)
                t1 = q1 - (r10 * q0 + r11 * q1 + r12 * q2)
                t2 = q2 - (r20 * q0 + r21 * q1 + r22 * q2)
            else:
                if abs(ang) < 1e-6:
                    sc = 1.0 - ang ** 2 / 6.0
                    cc = ang / 2.0
                else:
                    sc = s / ang
                    cc = c1 / ang
                arc = w[h]
                if centred[h]:
                    half = 0.5 * abs(ang)
                    if half < 1e-6:
                        arc = w[h] * (1.0 - half ** 2 / 3.0)
                    else:
                        arc = w[h] * (half / math.tan(min(half, math.pi / 2 - 1e-12)))
                l0, l1, l2 = line[h, 0], line[h, 1], line[h, 2]
                t0 = (start[h, 0] + (arc * sc) * nrm[h, 0] + 0.0) - (r00 * l0 + r01 * l1 + r02 * l2)
                t1 = (start[h, 1] + (arc * sc) * nrm[h, 1] + 0.0) - (r10 * l0 + r11 * l1 + r12 * l2)
                t2 = (start[h, 2] + (arc * sc) * nrm[h, 2] + (arc * cc)) - (r20 * l0 + r21 * l1 + r22 * l2)
            pa, ch = parent[h], child[h]
            for a in range(3):
                p0, p1, p2 = P[pa, a, 0], P[pa, a, 1], P[pa, a, 2]
                P[ch, a, 0] = p0 * r00 + p1 * r10 + p2 * r20
                P[ch, a, 1] = p0 * r01 + p1 * r11 + p2 * r21
                P[ch, a, 2] = p0 * r02 + p1 * r12 + p2 * r22
                P[ch, a, 3] = p0 * t0 + p1 * t1 + p2 * t2 + P[pa, a, 3]
            P[ch, 3, 0] = 0.0
            P[ch, 3, 1] = 0.0
            P[ch, 3, 2] = 0.0
            P[ch, 3, 3] = 1.0
    return poses


@njit
def stacked_at(grid, stack, t):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.hinge_drive.HingeDrive._stacked` at one time per row: the
    columns of ``stack`` (n_grid, n) interpolated at times ``t`` (n_t,), 0 before 0; the
    same index (``searchsorted(side="right") - 1``, clipped), fraction and sums."""
    n_t, n, ng = t.shape[0], stack.shape[1], grid.shape[0]
    out = np.empty((n_t, n))
    g0, g1 = grid[0], grid[ng - 1]
    for r in range(n_t):
        tc = min(max(t[r], g0), g1)
        lo, hi = 0, ng  # first index with grid > tc
        while lo < hi:
            mid = (lo + hi) // 2
            if grid[mid] <= tc:
                lo = mid + 1
            else:
                hi = mid
        k = min(max(lo - 1, 0), ng - 2)
        f = (tc - grid[k]) / (grid[k + 1] - grid[k])
        for c in range(n):
            a = stack[k, c]
            out[r, c] = 0.0 if t[r] < 0 else a + (stack[k + 1, c] - a) * f
    return out


@njit
def driven_at(grid, stack, t, target, fixity):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.hinge_drive.HingeDrive.driven` at one time ``t``, (1, n):
    target (1 - (1 - R) fixity), R the stacked curves at t (:func:`stacked_at`)."""
    tt = np.empty(1)
    tt[0] = t
    r = stacked_at(grid, stack, tt)
    for c in range(r.shape[1]):
        r[0, c] = target[c] * (1.0 - (1.0 - r[0, c]) * fixity[c])
    return r
