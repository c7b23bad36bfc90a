"""The panels' mesh of the bar-and-hinge model (:mod:`foldprint.physics.barhinge.model`): each
panel's outline and holes with the nodes of its fold lines inserted (shared by the panels a
hinge joins), simplified to a few points, triangulated (``manifold3d.triangulate``, holes
and non-convex panels too), and the panels' points merged into the model's nodes.
"""

from __future__ import annotations

import manifold3d as mf
import numpy as np
import shapely

from ...core.errors import DesignError
from ...model.design import Design


def _insert(ring: list, p: np.ndarray, eps: float) -> None:
    """Insert point ``p`` into the closed ring (list of (2,) arrays) on the edge it lies on."""
    for q in ring:
        if np.linalg.norm(q - p) <= eps:
            return
    for a in range(len(ring)):
        u, v = ring[a], ring[(a + 1) % len(ring)]
        d = v - u
        L2 = float(d @ d)
        s = float((p - u) @ d) / L2
        if 0.0 < s < 1.0 and np.linalg.norm(u + s * d - p) <= eps:
            ring.insert(a + 1, p.copy())
            return


def on_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray, eps: float) -> float | None:
    """Position of p along a-b in [0, 1], or None when p is off the segment."""
    d = b - a
    s = float((p - a) @ d) / float(d @ d)
    if -eps <= s * np.sqrt(d @ d) <= np.sqrt(d @ d) + eps and np.linalg.norm(a + s * d - p) <= eps:
        return s
    return None


class _Union:
    def __init__(self, n: int):
        self.p = list(range(n))

    def find(self, a: int) -> int:
        while self.p[a] != a:
            self.p[a] = self.p[self.p[a]]
            a = self.p[a]
        return a

    def join(self, a: int, b: int) -> None:
        self.p[self.find(a)] = self.find(b)


def panel_rings(design: Design, eps: float) -> list[list[list[np.ndarray]]]:
    """Every panel's rings (outline counter-clockwise, then holes) with the points of its
    hinges' fold lines inserted."""
    pidx = design.panel_index()
    rings = [[[np.asarray(q, float) for q in p.outline]] + [[np.asarray(q, float) for q in h] for h in p.holes]
             for p in design.panels]
    for h in design.hinges:
        a, b = (np.asarray(q, float) for q in h.line)
        pts = [a, b]
        for pid in h.panels:
            for r in rings[pidx[pid]]:
                pts += [q for q in r if on_segment(q, a, b, eps) is not None]
        for pid in h.panels:
            for p in pts:
                for r in rings[pidx[pid]]:
                    _insert(r, p, eps)
    return rings


def _simplify(ring: list, pinned: np.ndarray, tol: float) -> list:
    """Douglas-Peucker on a closed ring (list of (2,) arrays) to ``tol`` (mm), keeping
    every ``pinned`` point (the points on fold lines, which the hinges' panels share). A
    ring without two pins is cut at its first point and the point farthest from it."""
    pts = np.array(ring, float)
    n = len(pts)
    pins = list(np.nonzero(pinned)[0])
    if len(pins) < 2:
        far = int(np.argmax(np.linalg.norm(pts - pts[0], axis=1)))
        pins = sorted({0, far, *pins})
    keep = np.zeros(n, bool)
    keep[pins] = True
    for a, b in zip(pins, pins[1:] + [pins[0] + n]):
        stack = [(a, b)]
        while stack:
            i, j = stack.pop()
            if j - i < 2:
                continue
            idx = np.arange(i + 1, j) % n
            p, q = pts[i % n], pts[j % n]
            d = q - p
            L = float(np.hypot(*d))
            r = pts[idx] - p
            dist = np.abs(d[0] * r[:, 1] - d[1] * r[:, 0]) / L if L > 0 else np.linalg.norm(r, axis=1)
            k = int(np.argmax(dist))
            if dist[k] > tol:
                keep[idx[k]] = True
                stack += [(i, i + 1 + k), (i + 1 + k, j)]
    return [ring[i] for i in range(n) if keep[i]]


def coarse_rings(rings: list, lines: list, tol: float, eps: float) -> list:
    """A panel's rings for the model: simplified to ``tol`` (:func:`_simplify`) with the
    points on its fold ``lines`` kept; holes that collapse (fewer than 3 points or under
    tol^2 of area) are left out."""
    out = []
    for n, r in enumerate(rings):
        pinned = np.array([any(on_segment(q, a, b, eps) is not None for a, b in lines) for q in r], bool)
        s = _simplify(r, pinned, tol)
        if n > 0 and (len(s) < 3 or abs(_area(s)) < tol * tol):
            continue
        out.append(s if len(s) >= 3 else r)
    return out


def _area(ring) -> float:
    a = np.array(ring, float)
    return 0.5 * float(np.sum(a[:, 0] * np.roll(a[:, 1], -1) - np.roll(a[:, 0], -1) * a[:, 1]))


def triangulate(rings: list[list[np.ndarray]], what: str) -> np.ndarray:
    arrs, index, start = [], [], 0
    for n, r in enumerate(rings):  # outline counter-clockwise, holes clockwise (positive fill)
        a = np.array(r, dtype=np.float64)
        area = _area(a)
        keep = (area > 0) == (n == 0)
        arrs.append(a if keep else a[::-1].copy())
        ids = np.arange(start, start + len(a))
        index.append(ids if keep else ids[::-1])
        start += len(a)
    tris = np.concatenate(index)[np.asarray(mf.triangulate(arrs), dtype=np.int64).reshape(-1, 3)]
    if len(tris) == 0:
        raise DesignError(f"panel {what!r}: its outline could not be triangulated for the bar-and-hinge model")
    pts = np.concatenate(arrs)[np.argsort(np.concatenate(index))]
    flat = _flat_triangles(pts, tris)
    if flat.any():  # manifold3d joins collinear vertices (aligned holes) into 0-area triangles
        tris = _delaunay(rings, pts)
        flat = _flat_triangles(pts, tris)
    if flat.any():
        x, y = pts[tris[np.argmax(flat)]].mean(axis=0)
        raise DesignError(f"panel {what!r}: its bar-and-hinge triangulation has a triangle of zero area near "
                          f"({x:.3g}, {y:.3g}) mm (vertices on one line); move or remove one of them")
    return tris


def _flat_triangles(pts: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(T,) whether each triangle's area is under 1e-9 of its longest edge squared."""
    a, b, c = pts[tris[:, 0]], pts[tris[:, 1]], pts[tris[:, 2]]
    u, v = b - a, c - a
    area = 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    edge2 = np.max([np.sum(u * u, 1), np.sum(v * v, 1), np.sum((c - b) ** 2, 1)], axis=0)
    return area <= 1e-9 * edge2


def _delaunay(rings: list, pts: np.ndarray) -> np.ndarray:
    """The rings' constrained Delaunay triangulation (shapely), as indices into ``pts``."""
    poly = shapely.Polygon(np.array(rings[0], float), [np.array(r, float) for r in rings[1:]])
    at = {tuple(q): i for i, q in enumerate(pts.tolist())}
    out = [[at.get(tuple(q), -1) for q in np.asarray(t.exterior.coords)[:3].tolist()]
           for t in shapely.constrained_delaunay_triangles(poly).geoms]
    tris = np.array(out, dtype=np.int64).reshape(-1, 3)
    return tris[(tris >= 0).all(axis=1)]


def shared_nodes(design: Design, rings, eps: float):
    """Global node ids: (per panel, its ring points' provisional ids), the merged ids and
    the 2D positions."""
    pos, owner = [], []
    for k, pr in enumerate(rings):
        for r in pr:
            for q in r:
                pos.append(q)
                owner.append(k)
    pos = np.array(pos)
    owner = np.array(owner)
    uf = _Union(len(pos))
    pidx = design.panel_index()
    for h in design.hinges:
        a, b = (np.asarray(q, float) for q in h.line)
        sel = np.nonzero(np.isin(owner, [pidx[h.panels[0]], pidx[h.panels[1]]]))[0]
        on = [i for i in sel if on_segment(pos[i], a, b, eps) is not None]
        for x in on:
            for y in on:
                if x < y and np.linalg.norm(pos[x] - pos[y]) <= eps:
                    uf.join(x, y)
    roots = np.array([uf.find(i) for i in range(len(pos))])
    uniq, gid = np.unique(roots, return_inverse=True)
    return gid, pos[uniq], owner
