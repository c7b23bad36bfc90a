"""The checks of a design (:func:`validate`): every value of every panel, hinge, process
and goal, each refused with a message naming the file, the item and the fix.

:func:`validate` is what :meth:`foldprint.model.design.Design.replace`, the TOML, FOLD and
SVG readers and the builders end in. ``Design``, ``Panel`` and ``Hinge`` in the
annotations are :mod:`foldprint.model.design`'s dataclasses; they are not imported here,
because ``design`` imports this module (``Design.replace`` validates).
"""

from __future__ import annotations

import math
import numbers
from typing import Mapping

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..core import schema
from ..core.constants import tol
from ..core.errors import DesignError, MaterialError, where
from ..core.modes import Interface
from . import composition
from .hinge_graph import shared_edge, spanning_tree
from .materials import MaterialLibrary, default_library


def finite_value(value, what: str, src: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.number)):
        raise DesignError(f"{src}{what} must be a number, got {schema.describe(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise DesignError(f"{src}{what} must be a number, got {schema.describe(value)}") from None
    if not math.isfinite(v):
        raise DesignError(f"{src}{what} must be a finite number, got {value!r}")
    return v


def length_value(value, what: str, src: str) -> float:
    """A length in mm within the schema's sanity bounds (1 um .. 10 m)."""
    v = _positive(value, what, src)
    if not schema.MIN_LENGTH_MM <= v <= schema.MAX_LENGTH_MM:
        raise DesignError(f"{src}{what} must be in [{schema.MIN_LENGTH_MM:g}, {schema.MAX_LENGTH_MM:g}] mm "
                          "(1 um to 10 m), "
                          f"got {v:g}")
    return v


def _overlaps(design: Design) -> None:
    """Panels may only touch along edges in the flat sheet: refuse two that overlap."""
    polys = [p.polygon for p in design.panels]
    if len(polys) < 2:
        return
    tree = shapely.STRtree(polys)
    a_idx, b_idx = tree.query(polys, predicate="intersects")
    for a, b in zip(a_idx.tolist(), b_idx.tolist()):
        if a >= b:
            continue
        common = polys[a].intersection(polys[b])
        area = common.area
        if area > max(tol.area, 1e-9 * min(polys[a].area, polys[b].area)):
            c = common.representative_point()
            raise DesignError(f"{where(design.source)}panels {design.panels[a].id!r} and "
                              f"{design.panels[b].id!r} overlap in the flat sheet ({area:.3g} mm^2 in "
                              f"common, near ({c.x:.3g}, {c.y:.3g})); panels may only touch along edges: "
                              "move or shrink one of them")


def _positive(value, what: str, src: str) -> float:
    v = finite_value(value, what, src)
    if v <= 0:
        raise DesignError(f"{src}{what} must be > 0, got {v:g}")
    return v


def check_ring(ring: np.ndarray, what: str, src: str) -> None:
    if ring.ndim != 2 or ring.shape[1] != 2:
        raise DesignError(f"{src}{what} must be a list of [x, y] points, got shape {ring.shape}")
    if not np.all(np.isfinite(ring)):
        raise DesignError(f"{src}{what} has a NaN or infinite coordinate")
    if len(ring) < 3:
        raise DesignError(f"{src}{what} needs at least 3 points, got {len(ring)}")
    poly = Polygon(ring)
    rank = np.linalg.matrix_rank(ring - ring.mean(axis=0), tol=tol.length)
    if rank >= 2 and not shapely.LinearRing(ring).is_simple:
        raise DesignError(f"{src}{what} is self-intersecting; reorder its points so edges do not cross")
    if poly.area <= tol.area:
        raise DesignError(f"{src}{what} is degenerate (zero area); give at least 3 non-collinear points")
    if not poly.is_valid:
        reason = shapely.is_valid_reason(poly)
        raise DesignError(f"{src}{what} is self-intersecting ({reason}); reorder its points so edges do not cross")


def _check_ids(design: Design, src: str) -> None:
    """A name, at least one panel (not too many), and unique panel and hinge ids."""
    if not design.name or not isinstance(design.name, str):
        raise DesignError(f"{src}name must be a non-empty string")
    schema.name(design.name, schema.Where(design.source, "name"))
    if not design.panels:
        raise DesignError(f"{src}a design needs at least one panel")
    if len(design.panels) > schema.MAX_PANELS:
        raise DesignError(f"{src}{len(design.panels)} panels; at most {schema.MAX_PANELS} are accepted")
    ids = [p.id for p in design.panels]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise DesignError(f"{src}duplicate panel ids {dup}; every panel needs its own id")
    hids = [h.id for h in design.hinges]
    dup = sorted({i for i in hids if hids.count(i) > 1})
    if dup:
        raise DesignError(f"{src}duplicate hinge ids {dup}; every hinge needs its own id")


def _check_panel(p: Panel, item: str, lib: MaterialLibrary, known_panel: str) -> None:
    """One panel: its thickness, outline and holes (simple, inside, bounded) and material."""
    if not isinstance(p.id, str) or not isinstance(p.material, str):  # API-built panels
        raise DesignError(f"{item}id and material must be strings")
    length_value(p.thickness, "thickness_mm", item)
    check_ring(p.outline, "outline", item)
    if len(p.outline) > schema.MAX_POINTS or len(p.holes) > schema.MAX_HOLES:
        raise DesignError(f"{item}at most {schema.MAX_POINTS} outline points and {schema.MAX_HOLES} "
                          "holes are accepted")
    for ring in (p.outline, *p.holes):
        if ring.size and np.abs(ring).max() > schema.MAX_LENGTH_MM:
            raise DesignError(f"{item}a coordinate is {np.abs(ring).max():g} mm from the origin; at "
                              f"most {schema.MAX_LENGTH_MM:g} mm (10 m) is accepted")
    for k, hole in enumerate(p.holes):
        check_ring(hole, f"hole {k}", item)
    if not p.polygon.is_valid:
        raise DesignError(f"{item}holes must lie inside the outline and not overlap "
                          f"({shapely.is_valid_reason(p.polygon)})")
    if p.material not in lib:
        raise DesignError(f"{item}unknown material {p.material!r}; known panel materials: {known_panel}"
                          " (add your own with --materials FILE)")


def _check_hinge_values(h: Hinge, item: str, ids: list, panel_ids: set, lib: MaterialLibrary,
                        known_hinge: str) -> None:
    """One hinge's own values: ids, panels that exist, angle, sizes, fixity, line, material."""
    if not isinstance(h.id, str) or not isinstance(h.material, str) or not all(
            isinstance(x, str) for x in h.panels):
        raise DesignError(f"{item}id, material and panel ids must be strings")
    if len(h.panels) != 2 or h.panels[0] == h.panels[1]:
        raise DesignError(f"{item}panels must name two different panels, got {list(h.panels)}")
    for pid in h.panels:
        if pid not in panel_ids:
            raise DesignError(f"{item}joins panel {pid!r}, which does not exist; panels: {ids}")
    ang = finite_value(h.angle, "angle", item)
    if abs(ang) > math.pi + 1e-12:
        raise DesignError(f"{item}angle_deg {math.degrees(ang):g} is outside [-180, 180] "
                          "(FOLD convention: + valley, - mountain, 0 flat)")
    length_value(h.radius, "radius_mm", item)
    length_value(h.thickness, "thickness_mm", item)
    fx = None if h.fixity is None else finite_value(h.fixity, "fixity", item)
    if fx is not None and not 0.0 <= fx <= 1.0:
        raise DesignError(f"{item}fixity must be in [0, 1], got {fx:g}")
    if not np.all(np.isfinite(h.line)):
        raise DesignError(f"{item}fold line has a NaN coordinate")
    if h.length <= tol.length * 100:
        raise DesignError(f"{item}fold line has zero length")
    if composition.is_composition_name(h.material) and h.material not in lib:
        try:
            lib[h.material]
        except MaterialError as exc:
            raise DesignError(f"{item}{exc}") from None
    if h.material not in lib:
        raise DesignError(f"{item}unknown material {h.material!r}; known hinge materials: {known_hinge}"
                          " or a VeroWhite fraction such as 'VW0.700' / {vero_fraction = 0.7}"
                          " (add your own with --materials FILE)")
    if lib[h.material].role != "hinge":
        raise DesignError(f"{item}material {h.material!r} is a {lib[h.material].role} material, "
                          f"not a shape-memory hinge material; use one of {known_hinge}")


def _check_hinge_place(h: Hinge, item: str, by_id: Mapping[str, Panel]) -> None:
    """The hinge's fold line lies on the edge its two panels share."""
    a, b = (by_id[pid] for pid in h.panels)
    edge = shared_edge(a, b)
    line = LineString(h.line)
    if edge is None:
        if _on_common_side(line, a, b):
            return
        raise DesignError(f"{item}panels {a.id!r} and {b.id!r} share no edge; a hinge joins two "
                          "panels along a common side of their outlines")
    if (line.distance(LineString(edge)) > 1e-3 or line.length > LineString(edge).length + 1e-3) \
            and not _on_common_side(line, a, b):
        raise DesignError(f"{item}fold line {h.line.tolist()} does not lie on the edge shared by "
                          f"{a.id!r} and {b.id!r} ({edge.tolist()})")


def _on_common_side(line: LineString, a: Panel, b: Panel) -> bool:
    """The fold line lies on the common boundary of the two outlines (within 1e-3 mm): two
    panels may meet along several sides (a crease pattern's two panels joined by creases
    on two lines), and a hinge may lie on any of them, not only the longest."""
    common = a.polygon.boundary.intersection(b.polygon.boundary)
    return not common.is_empty and line.difference(common.buffer(1e-3)).length <= 1e-3


def _check_style(h: Hinge, item: str) -> None:
    """The hinge's style: a known interface, a boolean ``stepped``, sizes, and features
    above the floor."""
    st = h.style
    if st.interface not in tuple(Interface):
        raise DesignError(f"{item}style.interface must be 'flat' or 'triangular', got {st.interface!r}")
    if not isinstance(st.stepped, (bool, np.bool_)):
        raise DesignError(f"{item}style.stepped must be true or false, got {schema.describe(st.stepped)}")
    for name in ("step_period_mm", "thin_mm", "tooth_depth_mm", "tooth_pitch_mm", "slot_width_mm"):
        length_value(getattr(st, name), f"style.{name}", item)
    if finite_value(st.max_segment_mm, "style.max_segment_mm", item) < 0:
        raise DesignError(f"{item}style.max_segment_mm must be >= 0 (0 = no slots)")
    _features(h, item)


def _check_process(design: Design, src: str) -> None:
    """Finite process temperatures, a positive duration, a valid strip depth."""
    pr = design.process
    item = f"{src}process: "
    for name in ("program_temperature_c", "fix_temperature_c", "bath_temperature_c"):
        finite_value(getattr(pr, name), name, item)
    _positive(pr.duration_s, "duration_s", item)
    if design.depth:
        length_value(design.depth, "depth_mm", src)


def _check_goals(design: Design, src: str, ids: list, by_id: Mapping[str, Panel]) -> None:
    """Each goal: a known type, panels and a hole that exist, a finite tip."""
    if len(design.goals) > schema.MAX_GOALS:
        raise DesignError(f"{src}{len(design.goals)} goals; at most {schema.MAX_GOALS} are accepted")
    for g in design.goals:
        item = f"{src}goal {g.id!r}: "
        if g.type != "pass_through":
            raise DesignError(f"{item}unknown goal type {g.type!r}; supported: pass_through")
        for pid in (g.panel, g.target):
            if pid not in by_id:
                raise DesignError(f"{item}names panel {pid!r}, which does not exist; panels: {ids}")
        if not 0 <= g.hole < len(by_id[g.target].holes):
            raise DesignError(f"{item}panel {g.target!r} has {len(by_id[g.target].holes)} holes; "
                              f"hole {g.hole} does not exist (holes count from 0)")
        if not np.all(np.isfinite(g.tip)):
            raise DesignError(f"{item}tip has a NaN coordinate")
        if isinstance(g.hole, bool) or not isinstance(g.hole, (int, np.integer)):
            raise DesignError(f"{item}hole must be a whole number, got {schema.describe(g.hole)}")


def validate(design: Design, library: MaterialLibrary | None = None) -> Design:
    """Check a design; raise DesignError naming the file, item and fix. Returns it."""
    lib = library or default_library()
    src = where(design.source)
    _check_ids(design, src)
    known_hinge = ", ".join(lib.names("hinge"))
    known_panel = ", ".join(lib.names("panel") + lib.names("base"))
    for p in design.panels:
        _check_panel(p, f"{src}panel {p.id!r}: ", lib, known_panel)
    _overlaps(design)
    ids = [p.id for p in design.panels]
    panel_ids = set(ids)
    by_id = {p.id: p for p in design.panels}
    for h in design.hinges:
        item = f"{src}hinge {h.id!r}: "
        _check_hinge_values(h, item, ids, panel_ids, lib, known_hinge)
        _check_hinge_place(h, item, by_id)
        _check_style(h, item)
    if design.root not in by_id:
        raise DesignError(f"{src}root panel {design.root!r} does not exist; panels: {ids}")
    spanning_tree(design)  # raises on disconnected panels; loops are allowed (rigid origami)
    _check_process(design, src)
    _check_goals(design, src, ids, by_id)
    return design


def _features(h: Hinge, item: str) -> None:
    """Periodic hinge features: above the feature floor and a bounded number per hinge, so
    a tiny step period or tooth pitch is refused here instead of hanging the geometry."""
    st = h.style
    counts = []
    if st.stepped:
        counts.append(("style.step_period_mm", st.step_period_mm, h.width))
    if st.interface == Interface.TRIANGULAR:
        counts.append(("style.tooth_pitch_mm", st.tooth_pitch_mm, h.length))
    if st.max_segment_mm > 0:
        counts.append(("style.max_segment_mm", st.max_segment_mm, h.length))
    for key, period, span in counts:
        if key != "style.max_segment_mm" and period < schema.FEATURE_FLOOR_MM:
            raise DesignError(f"{item}{key} = {period:g} mm is below {schema.FEATURE_FLOOR_MM:g} mm, finer "
                              "than any printer resolves; use a period of at least the printer's minimum "
                              "wall (foldprint check names it)")
        if span / period > schema.MAX_FEATURES:
            raise DesignError(f"{item}{key} = {period:g} mm makes {span / period:.0f} features over "
                              f"{span:.3g} mm; at most {schema.MAX_FEATURES} per hinge are built: use at "
                              f"least {span / schema.MAX_FEATURES:.3g} mm")
