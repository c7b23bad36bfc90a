"""Compiled kernel of :mod:`foldprint.collision.broadphase`: the panels' world centroids at
every pose, which the hierarchy descent's sphere distances read.

The same sums as :func:`foldprint.collision.broadphase.panel_centres` in the same order
(R[:, 0] c_x + R[:, 1] c_y + R[:, 2] c_z + t), without its six temporary (n_t, n, 3)
arrays: equal to it bit for bit where the compiler does not contract a product and a sum
into one fused multiply-add, else to round-off (``tests/test_kernels.py``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

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
