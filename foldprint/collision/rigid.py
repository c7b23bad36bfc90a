"""The rigid part of each panel under a hinge model, its side view and convex pieces.

Under the ``point`` model a panel is its whole outline. Under the ``arc`` model the hinge
strip of flat width w = R |rho| is centred on the fold line, so the rigid part of a panel
is its outline less a band of w/2 along each of its hinges (``shared/design.md``).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..model.derived import derived
from ..model.design import Design
from ..core.errors import GeometryError
from ..core.modes import HingeModel
from ..physics.kinematics import hinge_frames
from ..model.relief import relieve


def rigid_polygon(design: Design, index: int, model: HingeModel):
    """Shapely polygon (possibly with holes) of panel ``index``'s rigid part, sheet frame
    (every panel's is made at once: a loop over the panels takes :func:`rigid_polygons`)."""
    return rigid_polygons(design, model)[index]


def rigid_polygons(design: Design, model: HingeModel) -> list:
    """Every panel's rigid polygon (:func:`rigid_polygon`), once per active derived-data
    cache (without one, once per call: the design's vertex reliefs are made for all panels)."""
    return derived(design, ("rigid_polygons", str(model)), lambda: _compute_rigid_polygons(design, model))


def _compute_rigid_polygons(design: Design, model: HingeModel) -> list:
    try:  # vertex reliefs are part of the printed panels
        design = relieve(design)
    except GeometryError:  # a relief design-rule failure is export's and check's to report
        pass
    polys = [p.polygon for p in design.panels]
    if model == HingeModel.ARC:
        for f in hinge_frames(design):
            if f.width <= 0:
                continue
            a, b = f.hinge.line
            band = LineString([a, b]).buffer(f.width / 2, cap_style="flat")
            for idx in (f.parent, f.child):
                polys[idx] = polys[idx].difference(band)
    return [_largest_polygon(poly) for poly in polys]


def _largest_polygon(geom):
    """The largest polygon of what cutting the strips left (a Polygon, possibly empty).
    Cutting several strips can leave a MultiPolygon, or a GeometryCollection in which GEOS
    keeps a zero-area line where two strip edges meet on a panel's side (six panels of
    Origami Simulator's miura-ori.svg): lines and points are no part of a solid."""
    if geom.geom_type != "Polygon":
        parts = [g for g in shapely.get_parts(geom) if g.geom_type == "Polygon" and g.area > 0]
        parts += [g for m in shapely.get_parts(geom) if m.geom_type == "MultiPolygon" for g in m.geoms]
        geom = max(parts, key=lambda g: g.area) if parts else Polygon()
    return shapely.normalize(geom) if not geom.is_empty else geom


def side_segments(design: Design, model: HingeModel, y: float | None = None) -> list[np.ndarray]:
    """Side view (xz) of a planar strip: for each panel, the sheet-frame segments
    (k, 2, 2) where its rigid part crosses the line y = ``y`` (default: mid-depth).
    Holes split a panel into several segments. Once per active derived-data cache (a
    fold's 2D index and its bisection, and every fold of a batch of ``assign``'s, read
    the same)."""
    return derived(design, ("side_segments", str(model), y), lambda: _side_segments(design, model, y))


def _side_segments(design: Design, model: HingeModel, y: float | None) -> list[np.ndarray]:
    if y is None:
        y = design.depth / 2 if design.depth else float(design.panels[0].outline[:, 1].mean())
    xs = np.concatenate([p.outline[:, 0] for p in design.panels])
    probe = LineString([(xs.min() - 1.0, y), (xs.max() + 1.0, y)])
    out = []
    for poly in rigid_polygons(design, model):
        cut = poly.intersection(probe)
        segs = []
        for g in getattr(cut, "geoms", [cut]):
            if g.geom_type == "LineString" and g.length > 1e-9:
                c = np.asarray(g.coords)
                segs.append(np.array([c[0], c[-1]]))
        segs.sort(key=lambda s: min(s[0, 0], s[1, 0]))
        out.append(np.array(segs).reshape(-1, 2, 2))
    return out


def _is_convex(ring: np.ndarray) -> bool:
    d1 = np.roll(ring, -1, axis=0) - ring
    d2 = np.roll(d1, -1, axis=0)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    return bool(np.all(cross >= -1e-9) or np.all(cross <= 1e-9))


# A corner of a merged piece counts as convex when it turns left by more than -1e-12 rad
# (our choice: round-off of the cross product of input coordinates, not a design tolerance)
_TURN_TOL = 1e-12
# Collinear corners closer than this to their neighbours' chord are dropped from a piece
# (mm; our choice, the old merge's ``shapely.simplify(u, 1e-9)``)
_COLLINEAR_MM = 1e-9


def convex_pieces(poly) -> list[np.ndarray]:
    """Split a polygon (with holes) into convex pieces, each (k, 2) counter-clockwise.

    Constrained Delaunay triangles merged by Hertel-Mehlhorn: one pass over the diagonals
    removes each whose two pieces stay convex at both of its ends. A piece only grows, so
    a diagonal that cannot go once cannot go later: one pass is maximal (at most 4x the
    fewest convex pieces). The pass runs twice, in the triangulation's order and longest
    diagonal first, and the fewer pieces are kept: on random holed polygons 1.5 % fewer
    than the pairwise merge this replaced, which restarted after every merge (cubic: the
    200-hole panel of ``tests/test_barhinge_sizes.py`` took 26-30 CPU-s, now 0.06 CPU-s,
    the same 203 pieces; 2 cores at load 3-7). A convex polygon without holes is returned as is.
    """
    if poly.is_empty:
        return []
    if not poly.interiors:
        ring = np.asarray(shapely.orient_polygons(poly).exterior.coords)[:-1]
        if _is_convex(ring):
            return [ring]
    tris = [t for t in shapely.constrained_delaunay_triangles(poly).geoms if t.area > 1e-12]
    if not tris:
        return []
    xy, org, twin = _half_edges(tris)
    diag = [h for h in range(len(org)) if twin[h] > h]
    longest = sorted(diag, key=lambda h: -float(np.hypot(*(xy[org[twin[h]]] - xy[org[h]]))))
    tries = [_faces(xy, org, _merge_diagonals(xy, org, twin, order)) for order in (diag, longest)]
    return min(tries, key=len)


def _half_edges(tris) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The triangles as half-edges: vertex coordinates, each half-edge's origin vertex
    (3 per triangle, counter-clockwise) and its twin across a shared side (-1 on the
    boundary). Vertices are matched by exact coordinates (the triangulation's corners are
    the polygon's); a side whose ends do not match stays a boundary, never merged."""
    coords = np.array([t.exterior.coords[:3] for t in tris], dtype=float)  # (n, 3, 2)
    e1, e2 = coords[:, 1] - coords[:, 0], coords[:, 2] - coords[:, 0]
    cw = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] < 0
    coords[cw] = coords[cw][:, ::-1]
    xy, org = np.unique(coords.reshape(-1, 2), axis=0, return_inverse=True)
    org = org.reshape(-1)
    dst = org.reshape(-1, 3)[:, [1, 2, 0]].reshape(-1)
    index = {(int(a), int(b)): h for h, (a, b) in enumerate(zip(org, dst))}
    twin = np.array([index.get((int(b), int(a)), -1) for a, b in zip(org, dst)], dtype=np.int64)
    return xy, org, twin


def _left_turn(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> bool:
    """Whether p -> q -> r turns left or goes straight on (not back)."""
    a, b = q - p, r - q
    cross = a[0] * b[1] - a[1] * b[0]
    scale = float(np.hypot(*a) * np.hypot(*b))
    if cross > _TURN_TOL * scale:
        return True
    return cross >= -_TURN_TOL * scale and float(a @ b) > 0


def _merge_diagonals(xy, org, twin, order) -> list[int]:
    """Hertel-Mehlhorn on the half-edges: the next links of each piece's boundary after
    removing, in ``order``, every diagonal whose removal keeps both ends convex."""
    n = len(org)
    nxt = [h - h % 3 + (h + 1) % 3 for h in range(n)]
    prv = [h - h % 3 + (h + 2) % 3 for h in range(n)]
    for h in order:
        g = int(twin[h])  # h: u -> v in one piece, g: v -> u in the other
        p1, n1, p2, n2 = prv[h], nxt[h], prv[g], nxt[g]
        if twin[n1] == p2 or twin[p1] == n2:
            # the pieces share the side before or after this one too (in line: the turn
            # there goes back) or are one piece (never for convex pieces): kept apart
            continue
        if not (_left_turn(xy[org[p1]], xy[org[h]], xy[org[nxt[n2]]]) and
                _left_turn(xy[org[p2]], xy[org[g]], xy[org[nxt[n1]]])):
            continue
        nxt[p1], prv[n2] = n2, p1  # at u: into u in the one, out of u in the other
        nxt[p2], prv[n1] = n1, p2  # at v
        nxt[h] = nxt[g] = -1
    return nxt


def _faces(xy, org, nxt) -> list[np.ndarray]:
    """Each piece's ring (counter-clockwise), collinear corners dropped."""
    seen = [h < 0 for h in nxt]
    out = []
    for h0 in range(len(nxt)):
        if seen[h0]:
            continue
        ring, h = [], h0
        while not seen[h]:
            seen[h] = True
            ring.append(org[h])
            h = nxt[h]
        out.append(_drop_collinear(xy[ring]))
    return out


def _drop_collinear(ring: np.ndarray) -> np.ndarray:
    """``ring`` without corners within ``_COLLINEAR_MM`` of the chord of their neighbours."""
    prev, after = np.roll(ring, 1, axis=0), np.roll(ring, -1, axis=0)
    chord = after - prev
    off = np.abs(chord[:, 0] * (ring[:, 1] - prev[:, 1]) - chord[:, 1] * (ring[:, 0] - prev[:, 0]))
    keep = off > _COLLINEAR_MM * np.hypot(chord[:, 0], chord[:, 1])
    return ring[keep] if keep.sum() >= 3 else ring


def prism(ring: np.ndarray, thickness: float) -> tuple[np.ndarray, np.ndarray]:
    """A convex prism over ``ring`` (k, 2), z in [-t/2, t/2]: vertices (2k, 3) and the
    FCL face list (flat: [n, i0, i1, ...] per face), outward-facing."""
    k = len(ring)
    h = thickness / 2
    verts = np.vstack([np.column_stack([ring, np.full(k, -h)]), np.column_stack([ring, np.full(k, h)])])
    faces = [k, *range(k - 1, -1, -1)] + [k, *range(k, 2 * k)]
    for i in range(k):
        j = (i + 1) % k
        faces += [4, i, j, k + j, k + i]
    return verts, np.array(faces, dtype=np.int64)


