"""Compiled exact distance between two panels' convex prisms: the algorithm of
:mod:`foldprint.collision.polytope_distance` (vertex-face and edge-edge candidates, the
separating-plane certificate, the separating-axis test for pairs that overlap) in loops,
with no temporary arrays per candidate. The numpy functions there are the reference.

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.jit import njit


@njit
def _world(pose, ring, half):  # pragma: no cover - compiled
    """The prism's vertices (2k, 3) at ``pose``: bottom ring, then top."""
    k = ring.shape[0]
    w = np.empty((2 * k, 3))
    for v in range(2 * k):
        x, y, z = ring[v % k, 0], ring[v % k, 1], (half if v >= k else -half)
        for a in range(3):
            w[v, a] = pose[a, 0] * x + pose[a, 1] * y + pose[a, 2] * z + pose[a, 3]
    return w


@njit
def _vertex_face(w, pose, ring, half, best, pa, pb, flip):  # pragma: no cover - compiled
    """Every vertex of ``w`` (world) against the faces of the prism ``ring``/``half`` at
    ``pose`` whose plane holds the vertex's foot inside the face; improves ``best`` (the
    distance so far) and the nearest points ``pa`` (on the first prism), ``pb``."""
    k = ring.shape[0]
    for v in range(w.shape[0]):
        d0, d1, d2 = w[v, 0] - pose[0, 3], w[v, 1] - pose[1, 3], w[v, 2] - pose[2, 3]
        x = pose[0, 0] * d0 + pose[1, 0] * d1 + pose[2, 0] * d2  # the vertex in the prism's frame
        y = pose[0, 1] * d0 + pose[1, 1] * d1 + pose[2, 1] * d2
        z = pose[0, 2] * d0 + pose[1, 2] * d1 + pose[2, 2] * d2
        inside = True
        fx, fy, fz, dist = 0.0, 0.0, 0.0, np.inf
        for f in range(k):
            g = f + 1 if f + 1 < k else 0
            ex, ey = ring[g, 0] - ring[f, 0], ring[g, 1] - ring[f, 1]
            rx, ry = x - ring[f, 0], y - ring[f, 1]
            cross = ex * ry - ey * rx
            if cross < 0:
                inside = False
            ee = ex * ex + ey * ey
            if ee <= 0.0:  # a repeated ring vertex: no side (its neighbours are the sides)
                continue
            s = (rx * ex + ry * ey) / ee
            if s >= 0 and s <= 1 and abs(z) <= half:
                ds = abs(cross) / math.sqrt(ee)
                if ds < dist:
                    dist, fx, fy, fz = ds, ring[f, 0] + s * ex, ring[f, 1] + s * ey, z
        if inside:
            dc = abs(abs(z) - half)
            if dc <= dist:
                dist, fx, fy, fz = dc, x, y, math.copysign(half, z)
        if dist < best:
            best = dist
            for a in range(3):
                foot = pose[a, 0] * fx + pose[a, 1] * fy + pose[a, 2] * fz + pose[a, 3]
                if flip:
                    pa[a], pb[a] = foot, w[v, a]
                else:
                    pa[a], pb[a] = w[v, a], foot
    return best


@njit
def _edge(w, k, m):  # pragma: no cover - compiled
    """Ends (vertex indices) of the prism's edge ``m``: bottom ring, top ring, verticals."""
    if m < k:
        return m, (m + 1) % k
    if m < 2 * k:
        return m, k + (m - k + 1) % k
    return m - 2 * k, m - k


@njit
def _edge_edge(wa, ka, wb, kb, best, pa, pb):  # pragma: no cover - compiled
    """Every edge pair's closest points (Ericson's clamped solution); improves ``best``."""
    for ea in range(3 * ka):
        i0, i1 = _edge(wa, ka, ea)
        for eb in range(3 * kb):
            j0, j1 = _edge(wb, kb, eb)
            a = b = c = e = f = 0.0
            for x in range(3):
                d1 = wa[i1, x] - wa[i0, x]
                d2 = wb[j1, x] - wb[j0, x]
                r = wa[i0, x] - wb[j0, x]
                a += d1 * d1
                e += d2 * d2
                b += d1 * d2
                c += d1 * r
                f += d2 * r
            if a <= 0.0 and e <= 0.0:  # both edges a point (ends that coincide in the world)
                s = t = 0.0
            elif a <= 0.0:
                s, t = 0.0, min(1.0, max(0.0, f / e))
            elif e <= 0.0:
                s, t = min(1.0, max(0.0, -c / a)), 0.0
            else:
                den = a * e - b * b
                s = min(1.0, max(0.0, (b * f - c * e) / den)) if den > 1e-14 * a * e else 0.0
                t = (b * s + f) / e
                if t < 0:
                    t, s = 0.0, min(1.0, max(0.0, -c / a))
                elif t > 1:
                    t, s = 1.0, min(1.0, max(0.0, (b - c) / a))
            dd = 0.0
            for x in range(3):
                q = (wa[i0, x] + s * (wa[i1, x] - wa[i0, x])) - (wb[j0, x] + t * (wb[j1, x] - wb[j0, x]))
                dd += q * q
            dd = math.sqrt(dd)
            if dd < best:
                best = dd
                for x in range(3):
                    pa[x] = wa[i0, x] + s * (wa[i1, x] - wa[i0, x])
                    pb[x] = wb[j0, x] + t * (wb[j1, x] - wb[j0, x])
    return best


@njit
def _gap_along(wa, wb, ux, uy, uz):  # pragma: no cover - compiled
    """The gap between the projections of ``wa`` and ``wb`` on (ux, uy, uz) (unit), the
    larger of the two orders."""
    lo_a, hi_a, lo_b, hi_b = np.inf, -np.inf, np.inf, -np.inf
    for v in range(wa.shape[0]):
        p = wa[v, 0] * ux + wa[v, 1] * uy + wa[v, 2] * uz
        lo_a, hi_a = min(lo_a, p), max(hi_a, p)
    for v in range(wb.shape[0]):
        p = wb[v, 0] * ux + wb[v, 1] * uy + wb[v, 2] * uz
        lo_b, hi_b = min(lo_b, p), max(hi_b, p)
    return max(lo_b - hi_a, lo_a - hi_b)


@njit
def _direction(w, k, m):  # pragma: no cover - compiled
    """Edge direction ``m`` of a prism: its ring's sides (m < k), then its axis."""
    if m < k:
        g = m + 1 if m + 1 < k else 0
        return w[g, 0] - w[m, 0], w[g, 1] - w[m, 1], w[g, 2] - w[m, 2]
    return w[k, 0] - w[0, 0], w[k, 1] - w[0, 1], w[k, 2] - w[0, 2]


@njit
def _cross_gap(wa, wb, a, b):  # pragma: no cover - compiled
    """The projection gap along a x b (-inf when a and b are parallel: no axis)."""
    ux, uy, uz = a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]
    n = math.sqrt(ux * ux + uy * uy + uz * uz)
    if n <= 1e-12 * math.sqrt((a[0] ** 2 + a[1] ** 2 + a[2] ** 2) * (b[0] ** 2 + b[1] ** 2 + b[2] ** 2)):
        return -np.inf
    return _gap_along(wa, wb, ux / n, uy / n, uz / n)


@njit
def _square_gap(wa, ka, wb, kb, d):  # pragma: no cover - compiled
    """The reference's ``square_gap``: the gap along ``d`` with its part along each edge
    direction of either prism taken out in turn, the largest (-inf where none is left)."""
    best = -np.inf
    for w, k in ((wa, ka), (wb, kb)):
        for m in range(k + 1):
            e = _direction(w, k, m)
            ee = e[0] ** 2 + e[1] ** 2 + e[2] ** 2
            if not ee > 0.0:  # a zero-length edge: no direction
                continue
            f = (e[0] * d[0] + e[1] * d[1] + e[2] * d[2]) / ee
            vx, vy, vz = d[0] - f * e[0], d[1] - f * e[1], d[2] - f * e[2]
            n = math.sqrt(vx * vx + vy * vy + vz * vz)
            if n > 0.0:
                best = max(best, _gap_along(wa, wb, vx / n, vy / n, vz / n))
    return best


@njit
def _sat(wa, ka, wb, kb):  # pragma: no cover - compiled
    """The separating-axis theorem's largest projection gap (> 0 exactly when disjoint):
    each prism's face normals (the caps' is its axis, a side's is its direction across
    the axis) and every cross product of an edge direction of each prism."""
    xa, xb = _direction(wa, ka, ka), _direction(wb, kb, kb)
    best = -np.inf
    for ax in (xa, xb):
        n = math.sqrt(ax[0] ** 2 + ax[1] ** 2 + ax[2] ** 2)
        best = max(best, _gap_along(wa, wb, ax[0] / n, ax[1] / n, ax[2] / n))
    for m in range(ka):
        best = max(best, _cross_gap(wa, wb, _direction(wa, ka, m), xa))
    for m in range(kb):
        best = max(best, _cross_gap(wa, wb, _direction(wb, kb, m), xb))
    for m1 in range(ka + 1):
        for m2 in range(kb + 1):
            best = max(best, _cross_gap(wa, wb, _direction(wa, ka, m1), _direction(wb, kb, m2)))
    return best


@njit
def prism_bounds(pose_a, ring_a, half_a, pose_b, ring_b, half_b, cert_abs, cert_rel):  # pragma: no cover
    """``(ub, lb, pa, pb)`` of two convex prisms (the reference's ``prism_bounds``)."""
    ka, kb = ring_a.shape[0], ring_b.shape[0]
    wa = _world(pose_a, ring_a, half_a)
    wb = _world(pose_b, ring_b, half_b)
    pa = np.zeros(3)
    pb = np.zeros(3)
    best = _vertex_face(wa, pose_b, ring_b, half_b, np.inf, pa, pb, False)
    best = _vertex_face(wb, pose_a, ring_a, half_a, best, pa, pb, True)
    best = _edge_edge(wa, ka, wb, kb, best, pa, pb)
    if best <= 0.0:
        return 0.0, 0.0, pa, pb
    u = (pb - pa) / best
    lb = _gap_along(wa, wb, u[0], u[1], u[2])
    scale = max(np.abs(wa).max(), np.abs(wb).max())
    if best - lb <= cert_abs + cert_rel * scale:
        return best, lb, pa, pb
    lb = max(lb, _square_gap(wa, ka, wb, kb, pb - pa))
    if best - lb <= cert_abs + cert_rel * scale:
        return best, lb, pa, pb
    sep = _sat(wa, ka, wb, kb)
    if sep <= 0.0:
        return 0.0, 0.0, pa, pb
    return best, max(lb, sep), pa, pb


@njit
def _moved(pose, p):  # pragma: no cover - compiled
    out = np.empty(3)
    for a in range(3):
        out[a] = pose[a, 0] * p[0] + pose[a, 1] * p[1] + pose[a, 2] * p[2] + pose[a, 3]
    return out


@njit
def panel_bounds(pose_i, pose_j, i, j, ring, piece_off, panel_off, half, cen, rad,
                 cert_abs, cert_rel):  # pragma: no cover - compiled
    """``(ub, lb, pa, pb)`` of panels i and j: the smallest over their prisms' pairs, a pair
    skipped when its pieces' spheres are at least the best distance apart."""
    best, low = np.inf, np.inf
    pa = np.full(3, np.nan)
    pb = np.full(3, np.nan)
    for a in range(panel_off[i], panel_off[i + 1]):
        ca = _moved(pose_i, cen[a])
        for b in range(panel_off[j], panel_off[j + 1]):
            cb = _moved(pose_j, cen[b])
            if math.sqrt(((ca - cb) ** 2).sum()) - rad[a] - rad[b] >= best:
                continue
            ub, lb, qa, qb = prism_bounds(pose_i, ring[piece_off[a]:piece_off[a + 1]], half[i],
                                          pose_j, ring[piece_off[b]:piece_off[b + 1]], half[j],
                                          cert_abs, cert_rel)
            low = min(low, lb)
            if ub < best:
                best = ub
                pa[:] = qa
                pb[:] = qb
            if best <= 0.0:
                return best, low, pa, pb
    return best, low, pa, pb
