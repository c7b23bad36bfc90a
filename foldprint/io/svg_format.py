"""SVG crease patterns in Origami Simulator's convention as input.

Origami Simulator (Ghassaei et al., 7OSME; ``js/pattern.js``) reads the stroke colour of
every ``path``, ``line``, ``rect``, ``polygon`` and ``polyline``: black border, red
mountain, blue valley, green cut, yellow facet (triangulation, flat), magenta hinge
(unassigned, flat); a crease's fold angle is ``opacity x stroke-opacity x 180`` deg
(mountain negative). Paths may use M/L/H/V/Z (absolute and relative) only, as there.

This reader nodes the segments (splits them where they cross), finds the faces of the
planar graph, writes a FOLD crease pattern and hands it to
:func:`foldprint.io.fold_format.design_from_fold`, so an SVG pattern follows exactly the FOLD
rules (facets joined by flat edges form one panel, hinge ids ``e<edge index>``).

Size: the document scale maps user units to mm through the root ``width``/``height``
(units mm, cm, in, pt, pc, px = 1/96 in; none = px, as in SVG) and ``viewBox``;
``scale`` (mm per user unit, ``--scale``) overrides it. The SVG y axis points down; the
pattern is mirrored to foldprint's y-up sheet (the folded shape is then the mirror image
of Origami Simulator's, with the same mountains and valleys).

The elements are read into segments in :mod:`foldprint.io.svg_paths` and made a crease
graph in :mod:`foldprint.io.svg_creases`; this module chains them (:func:`fold_from_svg`)
and hands the result to the FOLD reader. Their names still import from here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import LineString

from ..core.errors import DesignError
from ..core.schema import MAX_LENGTH_MM
from ..model.design import Design
from ..model.materials import MaterialLibrary
from ..core.inputs import read_input_text, stem_text
from .fold_format import design_from_fold
from .svg_creases import (  # noqa: F401  (importable from here as before)
    KDTREE_POINTS,
    check_creases,
    cluster_points,
    build_edge_graph,
    find_faces,
    refuse_dense,
    snap_segments,
    unique_segments,
    Vertices,
)
from .svg_paths import svg_root, svg_segments  # noqa: F401  (importable from here)

#: Origami Simulator's default vertex merge tolerance (user units, ``globals.vertTol``)
VERTEX_TOL = 3.0


def fold_from_svg(text: str, src: str = "", scale: float | None = None,
                  vertex_tol: float | None = None) -> dict:
    """A FOLD crease-pattern dict (mm) from SVG text."""
    notes: list[str] = []
    segs, factor = svg_segments(svg_root(text, src), src)
    if scale is not None:
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise DesignError(f"{src}scale must be a number > 0 (mm per SVG user unit), got {scale!r}")
        factor = float(scale)
    if not segs:
        raise DesignError(f"{src}no coloured line found; draw the crease pattern with strokes in Origami "
                          "Simulator's colours (black border, red mountain, blue valley, ...)")
    segs = unique_segments(segs)
    pts = np.array([s[0] for s in segs] + [s[1] for s in segs])
    size = float(np.ptp(pts, axis=0).max())
    refuse_dense(segs, src)
    # Origami Simulator merges vertices closer than vertTol = 3 user units and snaps near
    # intersections; we do the same, capped at 0.5 % of the pattern for small documents
    vtol = VERTEX_TOL if vertex_tol is None else float(vertex_tol)
    snap = min(vtol, 0.005 * size)
    segs = snap_segments(segs, snap, size)
    tree = shapely.STRtree([LineString([a, b]) for a, b, *_ in segs])
    verts = Vertices()
    edges, assign, angles, pieces = build_edge_graph(segs, tree, size, snap, src, verts)
    faces = find_faces(pieces, verts, size, edges, assign, src)
    keep = check_creases(faces, edges, assign, verts.coords, segs, tree, snap, src, notes)
    edges = [edges[i] for i in keep]
    angles = [angles[i] if assign[i] != "B" else 0.0 for i in keep]
    assign = [assign[i] for i in keep]
    span = size * factor
    if not (math.isfinite(factor) and factor > 0 and math.isfinite(span) and span <= MAX_LENGTH_MM):
        raise DesignError(f"{src}the pattern is {size:g} user units wide at {factor:g} mm per unit (from the "
                          f"document's width/viewBox), beyond the {MAX_LENGTH_MM:g} mm foldprint accepts; fix "
                          "width and viewBox or give --scale MM_PER_UNIT")
    xy = [[x * factor, -y * factor] for x, y in verts.coords]  # y up
    faces = [r[::-1] for r in faces]  # keep counter-clockwise after the mirror
    return {"file_spec": 1.2, "file_creator": "foldprint.io.svg_format", "frame_classes": ["creasePattern"],
            "frame_unit": "mm", "vertices_coords": xy, "faces_vertices": faces, "edges_vertices": edges,
            "edges_assignment": assign, "edges_foldAngle": angles, "foldprint:notes": notes,
            "foldprint:pieces": "largest"}


def design_from_svg(text: str, source: str = "", library: MaterialLibrary | None = None,
                    scale: float | None = None, crease_materials: Mapping[str, str] | None = None,
                    **kw) -> Design:
    src = f"{source}: " if source else ""
    fold = fold_from_svg(text, src, scale)
    if not kw.get("default_thickness_mm"):
        kw.pop("default_thickness_mm", None)
    fold["frame_title"] = stem_text(source) if source else "svg"
    return design_from_fold(fold, source=source, library=library, crease_materials=crease_materials, **kw)


def design_from_svg_file(path: str | Path, library: MaterialLibrary | None = None, **kw) -> Design:
    path = Path(path)
    return design_from_svg(read_input_text(path, "an SVG crease pattern (.svg)"), str(path), library, **kw)
