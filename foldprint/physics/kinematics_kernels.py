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
    the identity with ``fill_eye``, else 0 (as ``forward`` leaves them)."""
    n_t = angles.shape[0]
    nh = hinge.shape[0]
    poses = np.zeros((n_t, n_panels, 4, 4))
    rot = np.empty((3, 3))
    tr = np.empty(3)
    for t in range(n_t):
        P = poses[t]
        if fill_eye:
            for p in range(n_panels):
                for a in range(4):
                    P[p, a, a] = 1.0
        for a in range(4):
            P[root, a, a] = 1.0
        for h in range(nh):
            ang = angles[t, hinge[h]]
            s = math.sin(ang)
            c1 = 1.0 - math.cos(ang)
            for a in range(3):
                for b in range(3):
                    rot[a, b] = ((1.0 if a == b else 0.0) + s * k[h, a, b]) + c1 * kk[h, a, b]
            if point:
                for a in range(3):
                    tr[a] = q[h, a] - (rot[a, 0] * q[h, 0] + rot[a, 1] * q[h, 1] + rot[a, 2] * q[h, 2])
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
                for a in range(3):
                    turned = rot[a, 0] * line[h, 0] + rot[a, 1] * line[h, 1] + rot[a, 2] * line[h, 2]
                    tip = start[h, a] + (arc * sc) * nrm[h, a] + ((arc * cc) if a == 2 else 0.0)
                    tr[a] = tip - turned
            pa, ch = parent[h], child[h]
            for a in range(4):
                for b in range(3):
                    P[ch, a, b] = P[pa, a, 0] * rot[0, b] + P[pa, a, 1] * rot[1, b] + P[pa, a, 2] * rot[2, b]
                P[ch, a, 3] = P[pa, a, 0] * tr[0] + P[pa, a, 1] * tr[1] + P[pa, a, 2] * tr[2] + P[pa, a, 3]
    return poses
