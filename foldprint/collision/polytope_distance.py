"""Exact distance between two panels' rigid solids: the figure every reported clearance
is (the smallest clearance along a fold, check's FP172, the printed-state gaps, the
margins, the studio's and gallery's clearance).

FCL's GJK (python-fcl 0.7, libccd's solver or FCL's own) is not exact between two convex
prisms: where a face of one and an edge of the other are the nearest features, worst when
their faces are coplanar, it was measured up to 16 % above the true distance far from
contact (12.37 mm for 12) and 0.80 mm for 0.068 mm near it, never below it
(``tests/test_collision_scale.py``, ``tests/test_polytope_distance.py``). A clearance read
that high can make a marginal fold look safe, and a distance that high lets the swept
check certify an interval across a contact, so every distance is computed here instead.

A panel's solid is a set of convex prisms (:func:`foldprint.collision.rigid.convex_pieces`
of its rigid polygon, extruded to its thickness): the same pieces the swept check gives
FCL. Between two disjoint convex polytopes the distance is attained at a vertex of one and
a face of the other (the vertex's foot inside the face) or at two edges, so the smallest
of those candidates, each the distance of a real pair of points, is the distance. Each
result is then certified: the plane through the nearest points' midpoint, normal to their
difference, must have one prism on each side; the projections on that normal are a lower
bound of the distance (``lb``), the nearest points' distance an upper bound (``ub``).
Where the nearest features are parallel edges whose ranges overlap by a hair, that normal
leans along the edges, and the normal squared off against each edge direction in turn
(:func:`square_gap`) gives the lower bound instead. A
pair certified to :func:`certify_tol` is exact to it; a pair the plane cannot separate
overlaps (the candidates are complete for disjoint prisms), which the separating-axis
theorem confirms (face normals and edge-direction cross products), and its distance is 0.

The numpy functions here are the reference; ``polytope_distance_kernels`` compiles the
same algorithm (:func:`foldprint.core.jit.use_kernels`), and the tests hold them equal.
Without the kernel, the enumeration costs ~200 us a prism pair, so the numpy path first
tries FCL's nearest points under the same certificate (:func:`seeded_bounds`): the result
is certified to the same tolerance either way.
"""

from __future__ import annotations

from dataclasses import dataclass

import fcl
import numpy as np

from ..core.jit import use_kernels

#: Absolute part of the certificate's tolerance, mm (our choice: a thousandth of a micron,
#: far below any printer's resolution, far above double round-off at sheet sizes).
CERT_ABS = 1e-9
#: Relative part, times the largest coordinate involved (double precision resolves a
#: coordinate to ~1e-16 of itself; a few hundred operations stay below 1e-12).
CERT_REL = 1e-12


#: FCL's query on the numpy path (:func:`seeded_bounds`): its nearest points are wanted
_SEED_REQUEST = fcl.DistanceRequest(enable_nearest_points=True)


def certify_tol(scale: float) -> float:
    """The largest ``ub - lb`` a certified distance may have (mm) for coordinates up to
    ``scale`` mm: the distance reported is within this of the true one."""
    return CERT_ABS + CERT_REL * float(scale)


@dataclass(frozen=True)
class PrismSet:
    """Every panel's convex prisms, flat: ring points (m, 2, sheet frame, counter-clockwise),
    each piece's slice ``piece_off`` (p + 1,), each panel's pieces ``panel_off`` (n + 1,),
    half thickness per panel ``half`` (n,), each piece's centre (p, 3) and radius (p,) (a
    sphere holding it: pairs of pieces that cannot be nearer than the best are skipped)."""

    ring: np.ndarray
    piece_off: np.ndarray
    panel_off: np.ndarray
    half: np.ndarray
    cen: np.ndarray
    rad: np.ndarray


def prism_set(checker) -> PrismSet:
    """The prisms of ``checker``'s design under its hinge model, from its panels' convex
    pieces (``SweptChecker.rings``, the pieces it gives FCL), built once per design
    checker (:func:`_store`)."""
    hit = _store(checker).get("_prism_set")
    if hit is None:
        rings, piece_off, panel_off, cen, rad = [], [0], [0], [], []
        for p, pieces in zip(checker.design.panels, checker.rings):
            for ring in pieces:
                ring = np.asarray(ring, float)
                if _area2(ring) < 0:
                    ring = ring[::-1]
                c = ring.mean(axis=0)
                rings.append(ring)
                piece_off.append(piece_off[-1] + len(ring))
                cen.append([c[0], c[1], 0.0])
                rad.append(float(np.hypot(*(ring - c).T).max() + 1e-9) + p.thickness / 2)
            panel_off.append(len(rings))
        hit = PrismSet(np.ascontiguousarray(np.concatenate(rings) if rings else np.zeros((0, 2))),
                       np.array(piece_off, np.int64), np.array(panel_off, np.int64),
                       np.array([p.thickness / 2 for p in checker.design.panels], float),
                       np.array(cen, float).reshape(-1, 3), np.array(rad, float))
        _store(checker)["_prism_set"] = hit
    return hit


def _store(checker) -> dict:
    """Where a checker's prisms and distance kernel are kept: ``SweptChecker.shared``,
    which its :meth:`~foldprint.collision.swept3d.SweptChecker.with_drive` copies share
    (each Monte-Carlo sample's checker is one; built per copy, the prisms cost about
    0.3 ms a sample that asks for a distance), else the object's own attributes."""
    shared = getattr(checker, "shared", None)
    return shared if isinstance(shared, dict) else checker.__dict__


def _area2(ring: np.ndarray) -> float:
    x, y = ring.T
    return float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


#: Nearest-point pairs within this fraction of the coordinates of the smallest distance
#: count as nearest for :func:`nearest_centre` (our choice: faces parallel to 1e-7 rad
#: along a 100 mm contact line tie; a contact point is shown, not computed with).
TIE_REL = 1e-7


def panel_distance(checker, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray):
    """Exact distance (mm, 0 when the solids touch or overlap) between panels ``i`` and
    ``j`` at world poses (4, 4), and a nearest point (world; None when a panel has no
    rigid solid: the distance is then inf): the centre of the nearest-point pairs
    (:func:`nearest_centre`) when the solids are apart, the certified pair's midpoint
    when they touch."""
    ub, _lb, pa, pb = panel_bounds(checker, i, j, pose_i, pose_j)
    if not np.isfinite(ub):
        return float(ub), None
    if ub > 0.0:
        return float(ub), nearest_centre(prism_set(checker), i, j, pose_i, pose_j, ub)
    return float(ub), 0.5 * (pa + pb)


def _piece_pairs(s: PrismSet, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray):
    """Every pair of convex pieces (a of panel i, b of panel j) at the world poses, with the
    distance below which they cannot come (their holding spheres': ``far``)."""
    ci = s.cen[s.panel_off[i]:s.panel_off[i + 1]] @ pose_i[:3, :3].T + pose_i[:3, 3]
    cj = s.cen[s.panel_off[j]:s.panel_off[j + 1]] @ pose_j[:3, :3].T + pose_j[:3, 3]
    for a in range(s.panel_off[i], s.panel_off[i + 1]):
        for b in range(s.panel_off[j], s.panel_off[j + 1]):
            yield a, b, np.linalg.norm(ci[a - s.panel_off[i]] - cj[b - s.panel_off[j]]) - s.rad[a] - s.rad[b]


def nearest_centre(s: PrismSet, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray, dist: float) -> np.ndarray:
    """One nearest point of panels ``i`` and ``j`` (apart by ``dist``), whichever path and
    round-off found the distance: the centroid of the region of nearest points. Where two
    faces or a face and an edge are nearest, every point of a polygon or segment is, and
    which pair an enumeration meets first depends on round-off (the compiled and numpy
    paths reported points 3 mm apart on one contact line). The candidates (vertex-face,
    edge-edge) within ``dist`` + :data:`TIE_REL` of the coordinates hold that region's
    corners; their midpoints' convex hull, in the plane across the nearest direction, is
    the region, and its centroid the point. Numpy on either path; a reported contact's
    point only."""
    mids, gaps = [], []
    for a, b, far in _piece_pairs(s, i, j, pose_i, pose_j):
        if far > dist * (1.0 + 1e-6) + CERT_ABS:  # no point of these pieces is that near
            continue
        ra, rb = s.ring[s.piece_off[a]:s.piece_off[a + 1]], s.ring[s.piece_off[b]:s.piece_off[b + 1]]
        wa = prism_vertices(ra, s.half[i]) @ pose_i[:3, :3].T + pose_i[:3, 3]
        wb = prism_vertices(rb, s.half[j]) @ pose_j[:3, :3].T + pose_j[:3, 3]
        tie = dist + CERT_ABS + TIE_REL * max(np.abs(wa).max(), np.abs(wb).max())
        for w, pose, ring, half, sign in ((wa, pose_j, rb, s.half[j], 1.0), (wb, pose_i, ra, s.half[i], -1.0)):
            d, foot = _vertex_feet(w, pose, ring, half)
            near = d <= tie
            mids.append(0.5 * (w[near] + foot[near]))
            gaps.append(sign * (foot[near] - w[near]))
        c1, c2 = segment_pairs(*_edges(wa, len(ra)), *_edges(wb, len(rb)))
        c1, c2 = c1.reshape(-1, 3), c2.reshape(-1, 3)
        near = np.linalg.norm(c1 - c2, axis=-1) <= tie
        mids.append(0.5 * (c1[near] + c2[near]))
        gaps.append(c2[near] - c1[near])
    mids, gaps = np.vstack(mids), np.vstack(gaps)
    if not len(mids):
        return np.full(3, np.nan)
    return _hull_centroid(mids, gaps[np.linalg.norm(gaps, axis=1).argmax()])


def _hull_centroid(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The centroid of the convex hull of ``points`` (n, 3), which lie in one plane across
    ``normal`` (to round-off): a polygon's area centroid, a segment's midpoint, a point."""
    import shapely

    n = np.linalg.norm(normal)
    if n <= 0.0:
        return points.mean(axis=0)
    u = normal / n
    e1 = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(u, e1)
    origin = points[0]
    flat = (points - origin) @ np.column_stack([e1, e2])
    c = shapely.MultiPoint(flat).convex_hull.centroid
    return origin + c.x * e1 + c.y * e2 + float(((points - origin) @ u).mean()) * u


def _vertex_feet(w: np.ndarray, pose: np.ndarray, ring: np.ndarray, half: float):
    """:func:`vertex_feet` of world points ``w`` on the prism at ``pose``, feet in the world."""
    d, foot = vertex_feet((w - pose[:3, 3]) @ pose[:3, :3], ring, half)
    return d, foot @ pose[:3, :3].T + pose[:3, 3]


def panel_gap(checker, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray) -> float:
    """:func:`panel_distance` without the point."""
    return panel_bounds(checker, i, j, pose_i, pose_j)[0]


def panel_bounds(checker, i, j, pose_i, pose_j):
    """``(ub, lb, pa, pb)``: the distance reported (``ub``), its certified lower bound
    (``lb``; ``ub - lb <= certify_tol`` on every pair the tests met), the nearest points on
    panel i and panel j (world)."""
    kernel, s = _prepared(checker)
    if kernel is not None:
        ub, lb, pa, pb = kernel(pose_i, pose_j, i, j, s.ring, s.piece_off, s.panel_off, s.half, s.cen, s.rad,
                                CERT_ABS, CERT_REL)
        return float(ub), float(lb), pa, pb
    return _panel_bounds(np.asarray(pose_i, float), np.asarray(pose_j, float), i, j, s, _seeds(checker, s))


def _seeds(checker, s: PrismSet):
    """The checker's FCL pieces and every piece's :func:`piece_data` (numpy path), once."""
    hit = _store(checker).get("_prism_seeds")
    if hit is None:
        owner = np.repeat(np.arange(len(s.half)), np.diff(s.panel_off))
        hit = _store(checker)["_prism_seeds"] = (checker.pieces, [
            piece_data(s.ring[s.piece_off[a]:s.piece_off[a + 1]], s.half[owner[a]]) for a in range(len(owner))])
    return hit


def warm_kernel() -> None:
    """Load (on a cold numba cache: compile, ~7 CPU-s once per install) the compiled
    distance, so that a timed run does not pay it in its first chunk: a fold whose pairs the
    screen certifies asks for no distance, so folding a sample does not always load it.
    Nothing where the numpy path runs."""
    if use_kernels():
        from .polytope_distance_kernels import panel_bounds as kernel

        ring = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]] * 2)
        far = np.eye(4)
        far[0, 3] = 3.0
        kernel(np.eye(4), far, 0, 1, ring, np.array([0, 3, 6]), np.array([0, 1, 2]), np.full(2, 0.5),
               np.zeros((2, 3)), np.ones(2), CERT_ABS, CERT_REL)


def _prepared(checker):
    """(the compiled ``panel_bounds`` or None for the numpy path, the prisms), once per
    checker: a distance is asked for thousands of times per search."""
    hit = checker.__dict__.get("_prism_kernel")
    if hit is None:
        kernel = None
        if use_kernels():
            from .polytope_distance_kernels import panel_bounds as kernel
        hit = checker.__dict__["_prism_kernel"] = (kernel, prism_set(checker))
    return hit


def _panel_bounds(pose_i, pose_j, i, j, s: PrismSet, seeds=None):
    """The numpy path's panel loop; ``seeds``: the checker's FCL pieces (each panel's list)
    and every piece's :func:`piece_data`, FCL's nearest points tried first (:func:`seeded_bounds`)."""
    best = (np.inf, np.inf, np.full(3, np.nan), np.full(3, np.nan))
    for a, b, far in _piece_pairs(s, i, j, pose_i, pose_j):
        if far >= best[0]:
            continue
        got = None if seeds is None else seeded_bounds(
            seeds[0][i][a - s.panel_off[i]], seeds[0][j][b - s.panel_off[j]], pose_i, seeds[1][a], pose_j, seeds[1][b])
        got = got or prism_bounds(pose_i, s.ring[s.piece_off[a]:s.piece_off[a + 1]], s.half[i],
                                  pose_j, s.ring[s.piece_off[b]:s.piece_off[b + 1]], s.half[j])
        if got[0] < best[0]:
            best = (got[0], min(best[1], got[1]), got[2], got[3])
        else:
            best = (best[0], min(best[1], got[1]), best[2], best[3])
        if best[0] <= 0.0:
            return best
    return best


def seeded_bounds(obj_a, obj_b, pose_a, piece_a, pose_b, piece_b):
    """``(ub, lb, pa, pb)`` from FCL's nearest points when they certify (None otherwise):
    each lies in its prism (to a hair), so their distance is an upper bound, and the
    projections on their difference a lower bound within :func:`certify_tol` of it. FCL's
    points certify on 94-99 % of the templates' prism pairs (measured); the rest, and
    every touching pair, take :func:`prism_bounds`. The numpy path only: one FCL query and
    a few array operations cost a fraction of the candidates' enumeration. ``piece_*``:
    ``(ring, half, vertices, unit side vectors)`` (:func:`piece_data`)."""
    for obj, pose in ((obj_a, pose_a), (obj_b, pose_b)):
        obj.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
    res = fcl.DistanceResult()
    if fcl.distance(obj_a, obj_b, _SEED_REQUEST, res) <= 0.0:
        return None
    pa, pb = np.asarray(res.nearest_points[0], float), np.asarray(res.nearest_points[1], float)
    wa = piece_a[2] @ pose_a[:3, :3].T + pose_a[:3, 3]
    wb = piece_b[2] @ pose_b[:3, :3].T + pose_b[:3, 3]
    tol = certify_tol(max(np.abs(wa).max(), np.abs(wb).max()))
    if not (_holds(pa, pose_a, piece_a, tol / 4) and _holds(pb, pose_b, piece_b, tol / 4)):
        return None
    ub = float(np.linalg.norm(pb - pa))
    if ub <= tol:
        return None
    u = (pb - pa) / ub
    lb = float((wb @ u).min() - (wa @ u).max())
    return (ub, lb, pa, pb) if ub - lb <= tol else None


def piece_data(ring: np.ndarray, half: float) -> tuple:
    """``(ring, half, vertices (2k, 3), unit side vectors (k, 2))`` of a prism (panel frame)."""
    e = np.roll(ring, -1, axis=0) - ring
    return ring, half, prism_vertices(ring, half), e / np.hypot(e[:, 0], e[:, 1])[:, None]


def _holds(p, pose, piece, eps) -> bool:
    """Whether world point ``p`` lies in the prism (within ``eps`` of it)."""
    ring, half, _, e = piece
    local = (p - pose[:3, 3]) @ pose[:3, :3]
    rel = local[:2] - ring
    return bool((e[:, 0] * rel[:, 1] - e[:, 1] * rel[:, 0]).min() >= -eps and abs(local[2]) <= half + eps)


def prism_vertices(ring: np.ndarray, half: float) -> np.ndarray:
    """The prism's vertices (2k, 3), bottom ring then top, in its panel's frame."""
    k = len(ring)
    return np.vstack([np.column_stack([ring, np.full(k, -half)]), np.column_stack([ring, np.full(k, half)])])


def _edges(w: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The prism's 3k edges as segment ends (bottom ring, top ring, verticals)."""
    nxt = np.r_[np.arange(1, k), 0]
    lo = np.arange(k)
    return (np.vstack([w[lo], w[k + lo], w[lo]]), np.vstack([w[nxt], w[k + nxt], w[k + lo]]))


def vertex_feet(p: np.ndarray, ring: np.ndarray, half: float) -> tuple[np.ndarray, np.ndarray]:
    """Each point of ``p`` (m, 3, in the prism's frame): its distance to the prism's faces
    whose plane holds its foot inside the face (caps: foot inside the ring; sides: between
    the side's ends and the caps; inf where none does) and that foot (m, 3). Ties go as in
    the compiled kernel: the first side, a cap before a side at the same distance."""
    e = np.roll(ring, -1, axis=0) - ring  # (k, 2) side vectors, counter-clockwise
    rel = p[:, None, :2] - ring[None]  # (m, k, 2)
    cross = e[None, :, 0] * rel[..., 1] - e[None, :, 1] * rel[..., 0]  # >= 0 left of every side: inside
    z = p[:, 2]
    cap = np.where((cross >= 0).all(axis=1), np.abs(np.abs(z) - half), np.inf)
    ee = (e * e).sum(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):  # a repeated ring vertex: no side (NaN fails the test)
        s = (rel * e[None]).sum(axis=2) / ee
        side = np.where((s >= 0) & (s <= 1) & (np.abs(z) <= half)[:, None], np.abs(cross) / np.sqrt(ee), np.inf)
    rows = np.arange(len(p))
    f = side.argmin(axis=1)
    on_side = side[rows, f] < cap
    sf = np.nan_to_num(s[rows, f])
    foot = np.column_stack([np.where(on_side, ring[f, 0] + sf * e[f, 0], p[:, 0]),
                            np.where(on_side, ring[f, 1] + sf * e[f, 1], p[:, 1]),
                            np.where(on_side, z, np.copysign(half, z))])
    return np.minimum(cap, side[rows, f]), foot


def vertex_face(p: np.ndarray, ring: np.ndarray, half: float) -> tuple[float, int, np.ndarray]:
    """The nearest (distance, vertex index, foot) of :func:`vertex_feet` (the first
    nearest point)."""
    d, foot = vertex_feet(p, ring, half)
    v = int(np.argmin(d))
    return float(d[v]), v, foot[v]


def segment_pairs(p1, q1, p2, q2):
    """Closest points of every pair of segments p1q1 (a, 3) and p2q2 (b, 3) (Ericson's
    clamped solution, exact for parallel segments too): ``(c1, c2)`` each (a, b, 3)."""
    d1 = (q1 - p1)[:, None]
    d2 = (q2 - p2)[None]
    r = p1[:, None] - p2[None]
    a = (d1 * d1).sum(-1)
    e = (d2 * d2).sum(-1)
    b = (d1 * d2).sum(-1)
    c = (d1 * r).sum(-1)
    f = (d2 * r).sum(-1)
    den = a * e - b * b
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(den > 1e-14 * a * e, np.clip((b * f - c * e) / den, 0.0, 1.0), 0.0)
        t = (b * s + f) / e
        s = np.where(t < 0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1, np.clip((b - c) / a, 0.0, 1.0), s))
        t = np.clip(t, 0.0, 1.0)
        # an edge whose ends coincide is a point (Ericson's degenerate cases)
        s, t = np.where(e > 0, s, np.clip(-c / a, 0.0, 1.0)), np.where(e > 0, t, 0.0)
        s, t = np.where(a > 0, s, 0.0), np.where(a > 0, t, np.where(e > 0, np.clip(f / e, 0.0, 1.0), 0.0))
    return p1[:, None] + s[..., None] * d1, p2[None] + t[..., None] * d2


def prism_bounds(pose_a, ring_a, half_a, pose_b, ring_b, half_b):
    """``(ub, lb, pa, pb)`` of two convex prisms at world poses (module docstring)."""
    Ra, ta, Rb, tb = pose_a[:3, :3], pose_a[:3, 3], pose_b[:3, :3], pose_b[:3, 3]
    wa = prism_vertices(ring_a, half_a) @ Ra.T + ta
    wb = prism_vertices(ring_b, half_b) @ Rb.T + tb
    best = (np.inf, None, None)
    d, v, foot = vertex_face((wa - tb) @ Rb, ring_b, half_b)  # A's vertices on B's faces
    if d < best[0]:
        best = (d, wa[v], foot @ Rb.T + tb)
    d, v, foot = vertex_face((wb - ta) @ Ra, ring_a, half_a)
    if d < best[0]:
        best = (d, foot @ Ra.T + ta, wb[v])
    c1, c2 = segment_pairs(*_edges(wa, len(ring_a)), *_edges(wb, len(ring_b)))
    dd = np.linalg.norm(c1 - c2, axis=-1)
    m = np.unravel_index(np.argmin(dd), dd.shape)
    if dd[m] < best[0]:
        best = (float(dd[m]), c1[m], c2[m])
    ub, pa, pb = best
    if ub <= 0.0:
        return 0.0, 0.0, pa, pb
    u = (pb - pa) / ub
    lb = float((wb @ u).min() - (wa @ u).max())
    tol = certify_tol(max(np.abs(wa).max(), np.abs(wb).max()))
    if ub - lb <= tol:
        return float(ub), lb, pa, pb
    lb = max(lb, square_gap(wa, len(ring_a), wb, len(ring_b), pb - pa))
    if ub - lb <= tol:
        return float(ub), lb, pa, pb
    sep = sat_separation(wa, len(ring_a), wb, len(ring_b))
    if sep <= 0.0:  # the plane cannot separate them: they overlap
        return 0.0, 0.0, pa, pb
    return float(ub), max(lb, sep), pa, pb  # disjoint but uncertified: honest bounds


def square_gap(wa, ka, wb, kb, d) -> float:
    """The largest projection gap of the two prisms (world vertices, rings of ``ka`` and
    ``kb``) along ``d`` (the nearest points' difference) with its part along one edge
    direction of either prism taken out, each edge direction in turn. Where the nearest
    features are parallel edges whose ranges overlap by a hair, the nearest points'
    difference leans along the edges by about that overlap, and its own projection misses
    the distance by that lean times the prisms' extent; the separating-axis theorem has no
    axis there (parallel edges have no cross product). The difference squared off against
    the edges' direction is the separating direction. Any direction's gap is a lower
    bound of the distance, so this one can only tighten it."""
    nxt = np.r_[np.arange(1, ka), 0], np.r_[np.arange(1, kb), 0]
    e = np.vstack([wa[nxt[0]] - wa[:ka], wa[ka] - wa[0], wb[nxt[1]] - wb[:kb], wb[kb] - wb[0]])
    with np.errstate(invalid="ignore", divide="ignore"):  # a zero-length edge: no direction (NaN, dropped)
        v = d - (e @ d / np.einsum("ij,ij->i", e, e))[:, None] * e
    n = np.linalg.norm(v, axis=1)
    v = v[n > 0.0] / n[n > 0.0][:, None]
    if not len(v):
        return -np.inf
    pa, pb = wa @ v.T, wb @ v.T
    return float(np.maximum(pb.min(0) - pa.max(0), pa.min(0) - pb.max(0)).max())


def sat_separation(wa, ka, wb, kb) -> float:
    """The largest gap between the two prisms' projections (world vertices, rings of ``ka``
    and ``kb``) over the separating-axis theorem's axes: > 0 exactly when they are disjoint."""
    def dirs(w, k):
        nxt = np.r_[np.arange(1, k), 0]
        ring_dirs = w[nxt] - w[:k]
        return ring_dirs, w[k] - w[0]

    ea, ua = dirs(wa, ka)
    eb, ub = dirs(wb, kb)
    axes = [np.cross(ea, ua), np.cross(eb, ub), ua[None], ub[None]]
    da = np.vstack([ea, ua[None]])
    db = np.vstack([eb, ub[None]])
    axes.append(np.cross(da[:, None], db[None]).reshape(-1, 3))
    ax = np.vstack(axes)
    n = np.linalg.norm(ax, axis=1)
    ax = ax[n > 1e-12 * n.max()] / n[n > 1e-12 * n.max()][:, None]
    pa, pb = wa @ ax.T, wb @ ax.T
    return float(np.maximum(pb.min(0) - pa.max(0), pa.min(0) - pb.max(0)).max())
