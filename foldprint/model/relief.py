"""Vertex reliefs: where several hinges meet at a vertex their strips (flat width
w = R |rho|) would overlap, so every hinge stops short of the vertex and a hole is cut
there (``docs/loops.md``). A design transform used by the printed geometry
(:mod:`foldprint.geometry.layout`) and by the collision model (:mod:`foldprint.collision.rigid`),
so both see the same panels.
"""

from __future__ import annotations

import math

import numpy as np
import shapely

from .derived import derived
from .design import Design
from ..core.errors import GeometryError

#: vertex relief (docs/loops.md): each hinge meeting others at a vertex stops
#: ``RELIEF_FACTOR * a / sin(theta / 2) + RELIEF_CLEARANCE_MM`` from it (a the larger strip
#: half-width w/2 of a pair of creases theta apart), and the convex hull of the vertex
#: and the strips' cut ends is cut out of the sheet
RELIEF_FACTOR = 1.0
RELIEF_CLEARANCE_MM = 0.3
#: the narrowest panel a relief may leave (mm); thinner is a design-rule error
RELIEF_MIN_WALL_MM = 1.0


def relief_vertices(design: Design) -> dict[tuple, list[tuple[int, int]]]:
    """Points where two or more hinge lines end: {(x, y): [(hinge index, end 0/1)]}."""
    ends: dict[tuple, list[tuple[int, int]]] = {}
    for k, h in enumerate(design.hinges):
        for e in (0, 1):
            key = (round(float(h.line[e][0]), 5), round(float(h.line[e][1]), 5))
            ends.setdefault(key, []).append((k, e))
    return {v: hs for v, hs in ends.items() if len(hs) >= 2}


def _border_extensions(design: Design, lines: list) -> dict[str, list]:
    """A hinge ending on a slanted sheet border: its flat-capped strip leaves a sliver of
    each panel beyond its end, the two touching at the end point; the strip's extension
    to cut from each of the hinge's own two panels (the net may go on beyond)."""
    outer = shapely.union_all([p.polygon for p in design.panels]).boundary
    by_id = {p.id: p for p in design.panels}
    own: dict[str, list] = {}
    for k, h in enumerate(design.hinges):
        for e in (0, 1):
            end = lines[k][e]
            if outer.distance(shapely.Point(end)) > 1e-6:
                continue
            d = end - lines[k][1 - e]
            d /= np.linalg.norm(d)
            n = np.array([-d[1], d[0]])
            a, far = h.width / 2, 10 * h.width + 1.0
            ext = shapely.Polygon([end + a * n, end - a * n, end - a * n + far * d, end + a * n + far * d])
            for pid in h.panels:
                if by_id[pid].polygon.intersection(ext).area > 1e-9:
                    own.setdefault(pid, []).append(ext)
    return own


def _relief_cut(design: Design, v: tuple, hs: list, dirs: list, factor: float, clearance: float) -> float:
    """How far from vertex ``v`` its hinges stop: the largest pair's strip half-width over
    sin(theta / 2), scaled, plus the clearance."""
    cut = 0.0
    for i in range(len(hs)):
        for j in range(i + 1, len(hs)):
            theta = math.acos(float(np.clip(dirs[i] @ dirs[j], -1.0, 1.0)))
            a = max(design.hinges[hs[i][0]].width, design.hinges[hs[j][0]].width) / 2
            if theta < 1e-6:
                raise GeometryError(f"hinges {design.hinges[hs[i][0]].id!r} and {design.hinges[hs[j][0]].id!r} "
                                    f"leave vertex {v} along the same line; merge them")
            cut = max(cut, factor * a / math.sin(theta / 2))
    return cut + clearance


def _vertex_hole(design: Design, v: tuple, hs: list, lines: list, factor: float, clearance: float):
    """The relief hole at vertex ``v`` (convex hull of the vertex and the strips' cut ends);
    the hinge lines in ``lines`` are shortened to stop at it."""
    vv = np.array(v)
    dirs = []
    for k, e in hs:
        d = lines[k][1 - e] - vv
        dirs.append(d / np.linalg.norm(d))
    cut = _relief_cut(design, v, hs, dirs, factor, clearance)
    pts = [vv]
    for (k, e), d in zip(hs, dirs):
        h = design.hinges[k]
        if cut >= h.length - 1e-3 or (np.linalg.norm(lines[k][e] - vv) < 1e-9
                                      and cut >= np.linalg.norm(lines[k][1 - e] - lines[k][e]) - 1e-3):
            raise GeometryError(f"hinge {h.id!r}: the vertex relief at {v} ({cut:.2f} mm from the vertex, "
                                f"from strip widths R*|angle|) eats the whole {h.length:.2f} mm hinge; use "
                                "smaller radii or longer creases")
        lines[k][e] = vv + cut * d
        n = np.array([-d[1], d[0]])
        pts += [vv + cut * d + h.width / 2 * n, vv + cut * d - h.width / 2 * n]
    return shapely.MultiPoint([tuple(p) for p in pts]).convex_hull


def _relieved_panel(p, cutout, min_wall: float):
    """Panel ``p`` with ``cutout`` removed; refused when that splits it or leaves a wall
    thinner than ``min_wall``."""
    from dataclasses import replace

    poly = p.polygon.difference(cutout)
    if poly.geom_type != "Polygon" or poly.is_empty:
        raise GeometryError(f"panel {p.id!r}: the vertex relief cuts it into pieces; use smaller hinge "
                            "radii (narrower strips) or larger panels")
    if poly.buffer(-min_wall / 2).is_empty:
        raise GeometryError(f"panel {p.id!r}: after the vertex relief it is thinner than {min_wall:g} mm "
                            "somewhere; use smaller hinge radii or larger panels")
    poly = shapely.geometry.polygon.orient(poly, 1.0)
    return replace(p, outline=np.asarray(poly.exterior.coords)[:-1],
                   holes=tuple(np.asarray(r.coords)[:-1] for r in poly.interiors))


def relieve(design: Design, factor: float = RELIEF_FACTOR, clearance: float = RELIEF_CLEARANCE_MM,
            min_wall: float = RELIEF_MIN_WALL_MM) -> Design:
    """The design with a relief hole at every vertex where hinges meet: hinge lines stop
    short of the vertex and the hole (convex hull of the vertex and the strips' cut ends)
    is cut from the panels, so the hinge strips and panels of a vertex stay disjoint.
    Raises GeometryError when the relief eats a hinge or leaves a panel thinner than
    ``min_wall`` mm. A design without such vertices is returned unchanged."""
    return derived(design, ("relieve", factor, clearance, min_wall),
                   lambda: _relieve(design, factor, clearance, min_wall))


def _relieve(design: Design, factor: float, clearance: float, min_wall: float) -> Design:
    from dataclasses import replace  # the relieved panels of a validated design: a derived value

    verts = relief_vertices(design)
    lines = [np.array(h.line, float) for h in design.hinges]
    own = _border_extensions(design, lines)
    if not verts and not own:
        return design
    hole = shapely.union_all([_vertex_hole(design, v, hs, lines, factor, clearance) for v, hs in verts.items()])
    panels = [_relieved_panel(p, shapely.union_all([hole, *own.get(p.id, [])]), min_wall)
              for p in design.panels]
    hinges = [replace(h, line=lines[k]) for k, h in enumerate(design.hinges)]
    return replace(design, panels=tuple(panels), hinges=tuple(hinges))
