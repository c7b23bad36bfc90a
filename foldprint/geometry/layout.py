"""The 2D plan in the flat sheet (shapely): hinge strips, triangular teeth and the
rigid part of each panel."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..model.design import Design, Hinge
from ..core.errors import GeometryError
from ..core.modes import Interface
from ..physics.kinematics import HingeFrame, hinge_frames
from ..model.relief import relieve
from .hinges import hinge_segments
from .solids import (
    TEETH_GAP,
    TEETH_OVERLAP,
    TOOTH_END_MARGIN,
    TOOTH_LAND_FRACTION,
    clean_region,
)

# -- 2D layout: strips, teeth, rigid panel parts ---------------------------------------

@dataclass
class _HingeLayout:
    hinge: Hinge
    frame: HingeFrame
    d: np.ndarray  # unit direction of the fold line, line[0] -> line[1]
    n: np.ndarray  # unit in-plane normal into the child
    p0: np.ndarray
    segments: list[tuple[float, float]]
    rect: Polygon
    teeth: dict[int, object]  # panel index -> the notch the teeth fill in that panel
    teeth_solid: dict[int, object]  # the same, reaching TEETH_OVERLAP into the strip


def _sheet(lay: _HingeLayout, vs: list[tuple[float, float]]) -> Polygon:
    """Polygon from (v along the line, s toward the child) coordinates."""
    return Polygon([tuple(lay.p0 + v * lay.d + s * lay.n) for v, s in vs])


def _teeth_outline(lay: _HingeLayout, side: float) -> list[Polygon]:
    """Triangular teeth on the strip edge s = side * w/2, pointing away from the strip.
    Each row of teeth stands on a land and reaches back into the strip by a margin, so
    that clipping it to the panel's rigid part gives the exact notch boundary."""
    st, w = lay.hinge.style, lay.hinge.width
    s0 = side * w / 2
    back = -side * 2 * TEETH_OVERLAP  # into the strip
    depth, land, pitch = st.tooth_depth_mm, TOOTH_LAND_FRACTION * st.tooth_depth_mm, st.tooth_pitch_mm
    out = []
    for v0, v1 in lay.segments:
        span = v1 - v0
        k = math.floor((span - 2 * TOOTH_END_MARGIN * pitch) / pitch + 1e-9)
        if k < 1:
            continue
        a = v0 + (span - k * pitch) / 2
        ring = [(a, s0 + back), (a + k * pitch, s0 + back)]
        for i in range(k, 0, -1):
            ring.append((a + i * pitch, s0 + side * land))
            ring.append((a + (i - 0.5) * pitch, s0 + side * depth))
        ring.append((a, s0 + side * land))
        out.append(_sheet(lay, ring))
    return out


def _hinge_layout(f: HingeFrame) -> _HingeLayout:
    """One hinge's strip in the sheet (without teeth); a strip too narrow to print or
    bent tighter than half its thickness is refused."""
    h = f.hinge
    if h.width < 1e-3:
        raise GeometryError(f"hinge {h.id!r}: flat width R*|angle| = {h.width:.3g} mm; a printed "
                            "curved hinge needs a width (angle 0 means no fold: merge the panels)")
    if h.radius <= h.thickness / 2:
        raise GeometryError(f"hinge {h.id!r}: bend radius {h.radius:g} mm must exceed half the hinge "
                            f"thickness ({h.thickness / 2:g} mm) or the bent strip folds through itself")
    p0, p1 = np.asarray(h.line[0], float), np.asarray(h.line[1], float)
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    n = np.asarray(f.normal[:2], float)
    lay = _HingeLayout(h, f, d, n, p0, hinge_segments(h), Polygon(), {}, {})
    lay.rect = _sheet(lay, [(0, -h.width / 2), (h.length, -h.width / 2),
                            (h.length, h.width / 2), (0, h.width / 2)])
    return lay


def _check_strip_overlaps(lays: list[_HingeLayout], rects: list, tree) -> None:
    """Two hinge strips may not overlap in the sheet."""
    pairs = tree.query(np.array(rects, dtype=object), predicate="intersects") if rects else np.zeros((2, 0), int)
    for i, j in zip(*pairs):
        if i < j and rects[i].intersection(rects[j]).area > 1e-9:
            a, b = lays[i].hinge.id, lays[j].hinge.id
            raise GeometryError(f"hinges {a!r} and {b!r}: their strips (w/2 = R|angle|/2 on each side of "
                                "the fold line) overlap in the sheet; shorten the hinge lines (line = ...), "
                                "use smaller radii or move the fold lines apart")


def _rigid_before_teeth(design: Design, rects: list, tree) -> tuple[list, list]:
    """Each panel less the hinge strips touching it, and the indices of the strips near it."""
    rigid0, near_rects = [], []
    for p in design.panels:
        idx = sorted(tree.query(p.polygon, predicate="dwithin", distance=TEETH_GAP)) if rects else []
        near = [rects[k] for k in idx if rects[k].intersects(p.polygon)]
        r = p.polygon.difference(shapely.union_all(near)) if near else p.polygon
        rigid0.append(clean_region(r))
        near_rects.append(idx)
    return rigid0, near_rects


def _place_teeth(lay: _HingeLayout, pidx: int, side: float, rigid0: list, near_rects: list,
                 rects: list, cut: list) -> None:
    """The teeth of ``lay`` in panel ``pidx``: the part of the (extended) tooth row inside
    the panel's rigid part and not yet taken by an earlier hinge; the row joins ``cut``."""
    cand = _teeth_outline(lay, side)
    if not cand:
        return
    rows = shapely.union_all(cand)
    if rigid0[pidx] is None:
        return
    # keep clear of earlier rows and of other hinges' strips: pieces of one
    # material touching only along an edge would make a non-manifold body
    others = [rects[k] for k in near_rects[pidx] if rects[k] is not lay.rect]
    avail = rigid0[pidx]
    if cut[pidx] or others:
        taken = shapely.union_all(cut[pidx] + others).buffer(TEETH_GAP, join_style="mitre",
                                                             mitre_limit=50.0)
        avail = avail.difference(taken)
    teeth = clean_region(rows.intersection(avail))
    if teeth is not None and lay.hinge.width > 4 * TEETH_OVERLAP:
        lay.teeth[pidx] = teeth
        # the solid also reaches a little into the strip: teeth and strip then
        # overlap (and merge robustly) instead of touching on nearly coplanar faces
        half = lay.hinge.width / 2
        into = _sheet(lay, [(0, side * half), (lay.hinge.length, side * half),
                            (lay.hinge.length, side * (half - TEETH_OVERLAP)),
                            (0, side * (half - TEETH_OVERLAP))])
        lay.teeth_solid[pidx] = clean_region(shapely.union_all([teeth, rows.intersection(into)]))
        cut[pidx].append(rows)


def layout(design: Design) -> tuple[list[_HingeLayout], list[object]]:
    """The 2D plan in the sheet: per-hinge strips and teeth, and each panel's rigid
    part (outline less every hinge strip and every tooth region). Vertices where hinges
    meet get a relief (:func:`relieve`) first."""
    design = relieve(design)
    lays = [_hinge_layout(f) for f in sorted(hinge_frames(design), key=lambda fr: fr.index)]
    rects = [lay.rect for lay in lays]
    tree = shapely.STRtree(np.array(rects, dtype=object))
    _check_strip_overlaps(lays, rects, tree)
    rigid0, near_rects = _rigid_before_teeth(design, rects, tree)
    # teeth: the panel keeps rigid0 minus the extended rows, so teeth and panel come from
    # the same two inputs and share their boundary
    cut: list[list] = [[] for _ in design.panels]
    for lay in lays:
        if lay.hinge.style.interface != Interface.TRIANGULAR:
            continue
        for pidx, side in ((lay.frame.parent, -1.0), (lay.frame.child, 1.0)):
            _place_teeth(lay, pidx, side, rigid0, near_rects, rects, cut)
    rigid = []
    for k, p in enumerate(design.panels):
        r = rigid0[k]
        if r is not None and cut[k]:
            r = clean_region(r.difference(shapely.union_all(cut[k])))
        if r is None:
            raise GeometryError(f"panel {p.id!r}: nothing rigid is left after removing the hinge strips "
                                "(w/2 = R|angle|/2 along each hinge); make the panel larger or the radii smaller")
        rigid.append(r)
    return lays, rigid
