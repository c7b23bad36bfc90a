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
    Holes split a panel into several segments."""
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


def convex_pieces(poly) -> list[np.ndarray]:
    """Split a polygon (with holes) into convex pieces, each (k, 2) counter-clockwise.

    Constrained Delaunay triangles merged greedily while the union stays convex
    (Hertel-Mehlhorn); a convex polygon without holes is returned as is.
    """
    if poly.is_empty:
        return []
    if not poly.interiors:
        ring = np.asarray(shapely.orient_polygons(poly).exterior.coords)[:-1]
        if _is_convex(ring):
            return [ring]
    tris = [t for t in shapely.constrained_delaunay_triangles(poly).geoms if t.area > 1e-12]
    pieces = [Polygon(t.exterior.coords) for t in tris]
    merged = True
    while merged:
        merged = False
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                if pieces[i].touches(pieces[j]) and pieces[i].intersection(pieces[j]).length > 1e-9:
                    u = pieces[i].union(pieces[j])
                    if u.geom_type == "Polygon" and not u.interiors:
                        u = shapely.simplify(u, 1e-9)
                        ring = np.asarray(u.exterior.coords)[:-1]
                        if _is_convex(ring):
                            pieces[i] = u
                            pieces.pop(j)
                            merged = True
                            break
            if merged:
                break
    return [np.asarray(shapely.orient_polygons(p).exterior.coords)[:-1] for p in pieces]


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


