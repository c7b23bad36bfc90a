"""FOLD crease patterns as output: write FOLD 1.2.

One counter-clockwise face per panel, shared vertices merged, panel sides split at every
vertex or hinge end lying on them, so each hinge is exactly one or more "V"/"M"/"F"
edges; every other edge (a common side without a hinge too) is "B". foldprint's own data
rides in ``faces_foldprint:*``, ``edges_foldprint:*`` and ``foldprint:design``; the
reader is :mod:`foldprint.io.fold_format`.

Holes: a FOLD face is one simple polygon (``faces_vertices`` is a single cycle), so a
panel with holes is written as several holeless faces, cut at x = the centroid of each
hole, joined by flat ("F", fold angle 0) edges: every FOLD tool then sees the holes as
geometry (the gap between faces), and the reader joins faces across flat edges into one
panel whose holes are the interiors of the union. Only a panel that this cut cannot
free of holes keeps one face and its holes in ``faces_foldprint:holes``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon, box
from shapely.geometry.polygon import orient

from ..core.version import __version__
from ..core.constants import tol
from ..model.design import Design
from ..io.design_io import design_to_dict
from ..core.errors import DesignError, where
from ..io.fold_format import (HINGE_EXTRA, LINE_TOL, index_face_edges, project_onto_line, ring_edges)
# the reader, importable beside the writer (tests and callers round-trip through both)
from ..io.fold_format import design_from_fold, design_from_fold_file  # noqa: F401
from .fileset import write_atomic


class _Vertices:
    """Points merged within ``eps`` (a hash grid keeps this linear)."""

    def __init__(self, eps: float):
        self.eps, self.xy, self._grid = eps, [], {}

    def add(self, p) -> int:
        x, y = float(p[0]), float(p[1])
        i, j = round(x / self.eps), round(y / self.eps)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                for k in self._grid.get((i + di, j + dj), ()):
                    if math.hypot(self.xy[k][0] - x, self.xy[k][1] - y) <= self.eps:
                        return k
        self.xy.append((x, y))
        self._grid.setdefault((i, j), []).append(len(self.xy) - 1)
        return len(self.xy) - 1


def holeless_facets(panel) -> list[np.ndarray] | None:
    """Counter-clockwise rings of holeless polygons that tile a panel with holes: the
    panel cut by a line x = const through the centroid of each hole. None when the cut
    leaves a hole inside a facet (then the panel keeps its holes as foldprint data)."""
    poly = orient(panel.polygon, 1.0)
    x0, lo_y, x1, hi_y = poly.bounds
    xs = sorted({float(Polygon(h).centroid.x) for h in panel.holes})
    edges = [x0 - 1.0, *xs, x1 + 1.0]
    out = []
    for a, b in zip(edges, edges[1:]):  # one strip between two cuts at a time: shapely's split
        strip = poly.intersection(box(a, lo_y - 1.0, b, hi_y + 1.0))  # by several lines can drop a piece
        for g in getattr(strip, "geoms", [strip]):
            if g.is_empty or not isinstance(g, Polygon):
                continue  # a line or point where the strip only touches the panel
            if g.interiors or g.area <= tol.area:
                return None
            out.append(np.asarray(orient(g, 1.0).exterior.coords)[:-1])
    total = sum(Polygon(r).area for r in out)
    return out if abs(total - poly.area) <= 1e-9 * max(poly.area, 1.0) else None


def _panel_rings(design: Design, verts: _Vertices) -> list[list[int]]:
    """Each panel's outline as a counter-clockwise ring of merged vertices."""
    rings: list[list[int]] = []
    for p in design.panels:
        ring_xy = np.asarray(orient(Polygon(p.outline), 1.0).exterior.coords)[:-1]
        ring = [verts.add(q) for q in ring_xy]
        rings.append([v for k, v in enumerate(ring) if v != ring[k - 1]])
    return rings


def _facets(design: Design, rings: list, verts: _Vertices) -> tuple[list, list, list]:
    """The faces: the panel's outline, or holeless facets of a panel with holes; with the
    panel of each face and the holes it keeps as foldprint data."""
    face_panel: list[int] = []
    face_holes: list[list] = []
    facets: list[list[int]] = []
    for k, p in enumerate(design.panels):
        cut = holeless_facets(p) if p.holes else None
        if cut is None:
            facets.append(rings[k])
            face_panel.append(k)
            face_holes.append([h.tolist() for h in p.holes])
            continue
        for ring_xy in cut:
            ring = [verts.add(q) for q in ring_xy]
            facets.append([v for j, v in enumerate(ring) if v != ring[j - 1]])
            face_panel.append(k)
            face_holes.append([])
    return facets, face_panel, face_holes


def _add_hinge_ends(design: Design, rings: list, verts: _Vertices, eps: float) -> None:
    """Hinge ends that fall inside a panel side become vertices (snapped onto the side)."""
    index = design.panel_index()
    for h in design.hinges:
        for pid in h.panels:
            for a, b in ring_edges(rings[index[pid]]):
                A, B = np.asarray(verts.xy[a]), np.asarray(verts.xy[b])
                t, dist, foot = project_onto_line(h.line, A, B)
                L = float(np.linalg.norm(B - A))
                for k in range(2):
                    if dist[k] <= LINE_TOL and eps < t[k] * L < L - eps:
                        verts.add(foot[k])


def _split_sides(facets: list, pts: np.ndarray, eps: float) -> list[list[int]]:
    """T-junctions: every side of every facet split at the vertices lying on it."""
    faces = []
    for ring in facets:
        out = []
        for a, b in ring_edges(ring):
            out.append(a)
            t, dist, _ = project_onto_line(pts, pts[a], pts[b])
            L = float(np.linalg.norm(pts[b] - pts[a]))
            on = np.nonzero((dist <= eps) & (t * L > eps) & ((1 - t) * L > eps))[0]
            out.extend(int(i) for i in sorted(on, key=lambda i: t[i]) if i not in (a, b))
        faces.append(out)
    return faces


def _edge_columns(design: Design, edges: list, edge_faces: list, face_panel: list,
                  pts: np.ndarray) -> tuple[list, ...]:
    """Per edge: assignment, fold angle (deg), hinge id, material, radius and thickness; a
    hinge's edges "V"/"M"/"F", edges between facets of one panel "F", all others "B"."""
    by_pair: dict[frozenset, list] = {}
    for h in design.hinges:
        by_pair.setdefault(frozenset(h.panels), []).append(h)
    cols: tuple[list, ...] = ([], [], [], [], [], [])
    for (a, b), fs in zip(edges, edge_faces):
        hinge = None
        same_panel = len(fs) == 2 and face_panel[fs[0]] == face_panel[fs[1]]
        if len(fs) == 2 and not same_panel:
            for h in by_pair.get(frozenset(design.panels[face_panel[f]].id for f in fs), []):
                line = LineString(h.line)
                if all(line.distance(shapely.Point(pts[v])) <= LINE_TOL for v in (a, b)):
                    hinge = h
                    break
        if same_panel:  # between two facets of a panel with holes
            row = ("F", 0.0, None, None, None, None)
        elif hinge is None:
            row = ("B", 0.0, None, None, None, None)
        else:
            deg = math.degrees(hinge.angle)
            row = ("V" if deg > 0 else "M" if deg < 0 else "F", deg, hinge.id, hinge.material,
                   float(hinge.radius), float(hinge.thickness))
        for col, v in zip(cols, row):
            col.append(v)
    return cols


def _design_extra(design: Design) -> dict:
    """``foldprint:design``: process, root, description, goals, depth, the paper's
    structure it is; per hinge: panel order, fixity and style."""
    extra = design_to_dict(design)
    extra.pop("panels", None)
    extra["hinges"] = {h["id"]: {k: v for k, v in h.items() if k in HINGE_EXTRA}
                       for h in extra.get("hinges", [])}
    return extra


def design_to_fold(design: Design) -> dict:
    """The design as a FOLD 1.2 crease pattern (a JSON-ready dict)."""
    eps = tol.length
    verts = _Vertices(eps)
    rings = _panel_rings(design, verts)
    facets, face_panel, face_holes = _facets(design, rings, verts)
    _add_hinge_ends(design, rings, verts, eps)
    pts = np.asarray(verts.xy)
    faces = _split_sides(facets, pts, eps)
    edges: list[list[int]] = []
    edge_faces = index_face_edges(faces, edges, {})
    assign, fangle, e_hid, e_mat, e_rad, e_thk = _edge_columns(design, edges, edge_faces, face_panel, pts)
    out: dict[str, Any] = {
        "file_spec": 1.2, "file_creator": f"foldprint {__version__}",
        "file_classes": ["singleModel"], "frame_classes": ["creasePattern"],
        "frame_attributes": ["2D"], "frame_unit": "mm", "frame_title": design.name,
        "vertices_coords": [[x, y] for x, y in verts.xy], "faces_vertices": faces,
        "edges_vertices": edges, "edges_assignment": assign, "edges_foldAngle": fangle,
        "faces_foldprint:id": [design.panels[k].id for k in face_panel],
        "faces_foldprint:material": [design.panels[k].material for k in face_panel],
        "faces_foldprint:thickness_mm": [float(design.panels[k].thickness) for k in face_panel],
        "faces_foldprint:holes": face_holes,
        "edges_foldprint:hinge_id": e_hid, "edges_foldprint:material": e_mat,
        "edges_foldprint:radius_mm": e_rad, "edges_foldprint:thickness_mm": e_thk,
        "foldprint:design": _design_extra(design),
    }
    if design.description:
        out["frame_description"] = design.description
    return out


def fold_bytes(design: Design) -> bytes:
    """The FOLD file's bytes: JSON, sorted keys, byte-identical for the same design."""
    try:
        text = json.dumps(design_to_fold(design), sort_keys=True, indent=1, allow_nan=False)
    except ValueError as exc:
        raise DesignError(f"{where(design.source)}cannot write FOLD: {exc}") from None
    return (text + "\n").encode("utf-8")


def write_fold(design: Design, path: str | Path) -> Path:
    return write_atomic(path, fold_bytes(design))
