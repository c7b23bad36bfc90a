"""The design model: panels, hinges, process and goals, as frozen dataclasses.

Conventions (``docs/architecture.md``): the crease pattern lies in the flat sheet's
xy-plane, lengths in mm, angles in radians inside (degrees in files). A hinge's target
angle follows the FOLD convention: signed rho in [-pi, pi], 0 flat, + valley (the child
panel rotates toward +z), - mountain. The paper's theta (angle between panels, 180 deg
flat) is theta = 180 deg - |rho|.

Parsing files lives in :mod:`foldprint.io.design_io` (TOML) and
:mod:`foldprint.exchange.fold` (FOLD); both end in :func:`validate`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Sequence

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from ..core.constants import (DEFAULT_BATH_C, DEFAULT_DURATION_S, DEFAULT_FIX_C, DEFAULT_PROGRAM_C,
                        tol)
from ..core import schema
from ..core.errors import DesignError, MaterialError, where
from . import composition
from .materials import MaterialLibrary, default_library

SCHEMA_VERSION = 1


def _frozen_array(a, shape_tail: tuple[int, ...] | None = None, name: str = "array") -> np.ndarray:
    try:
        arr = np.array(a, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise DesignError(f"{name} must be numbers, got {str(a)[:60]}") from None
    if shape_tail is not None and (arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail):
        raise DesignError(f"{name} must have shape (n, {', '.join(map(str, shape_tail))}), got {arr.shape}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class Panel:
    """A rigid panel: a polygon with optional holes in the sheet plane, extruded
    symmetrically about z = 0 to ``thickness`` (mm)."""

    id: str
    outline: np.ndarray  # (n, 2) mm, counter-clockwise
    thickness: float
    material: str
    holes: tuple[np.ndarray, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "outline", _frozen_array(self.outline, (2,), f"panel {self.id!r} outline"))
        object.__setattr__(self, "holes", tuple(
            _frozen_array(h, (2,), f"panel {self.id!r} hole") for h in self.holes))

    @cached_property
    def polygon(self) -> Polygon:
        """Shapely polygon (cached; shapely geometries are immutable)."""
        return Polygon(self.outline, [h for h in self.holes])

    @property
    def area(self) -> float:
        return float(self.polygon.area)


@dataclass(frozen=True)
class HingeStyle:
    """How a hinge is built for printing (paper Fig. 6d-f). Lengths in mm.

    ``stepped``: a periodic step profile along the hinge surface, ``step_period_mm`` long,
    alternating ``thin_mm`` and the hinge thickness. ``interface``: "flat" or "triangular"
    (teeth of ``tooth_depth_mm`` and ``tooth_pitch_mm`` embedding the hinge in both
    panels). ``max_segment_mm`` > 0 cuts long hinges into segments separated by slots of
    ``slot_width_mm``.
    """

    stepped: bool = False
    step_period_mm: float = 2.0
    thin_mm: float = 0.4
    interface: str = "flat"
    tooth_depth_mm: float = 1.5
    tooth_pitch_mm: float = 3.0
    max_segment_mm: float = 0.0
    slot_width_mm: float = 1.0


@dataclass(frozen=True, eq=False)
class Hinge:
    """A hinge joining ``panels[0]`` and ``panels[1]`` along ``line`` (2, 2) mm.

    ``angle`` is the signed target fold angle rho (rad, FOLD convention), ``radius`` the
    bend radius R (mm) of the printed hinge, so its flat width is w = R |rho|.
    ``fixity`` is the shape fixity of programming (1 = the hinge stays flat).
    """

    id: str
    panels: tuple[str, str]
    line: np.ndarray
    angle: float
    material: str
    radius: float
    thickness: float
    fixity: float = 1.0
    style: HingeStyle = field(default_factory=HingeStyle)

    def __post_init__(self):
        object.__setattr__(self, "line", _frozen_array(self.line, (2,), f"hinge {self.id!r} line"))
        object.__setattr__(self, "panels", tuple(self.panels))

    @property
    def width(self) -> float:
        """Flat width of the curved hinge strip, w = R |rho| (mm)."""
        return self.radius * abs(self.angle)

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.line[1] - self.line[0]))

    @property
    def angle_deg(self) -> float:
        return math.degrees(self.angle)


@dataclass(frozen=True)
class Process:
    """The programming and recovery protocol (deg C, s). The hinge starts recovery at
    the fixing temperature (the paper cools to T_L = 10 C before the bath)."""

    program_temperature_c: float = DEFAULT_PROGRAM_C
    fix_temperature_c: float = DEFAULT_FIX_C
    bath_temperature_c: float = DEFAULT_BATH_C
    duration_s: float = DEFAULT_DURATION_S


@dataclass(frozen=True, eq=False)
class Goal:
    """A kinematic goal checked along the trajectory.

    ``pass_through``: the ``tip`` point (sheet coordinates, mm) of panel ``panel`` passes
    through hole ``hole`` of panel ``target``; goals with a lower ``order`` must be met
    first.
    """

    id: str
    type: str
    panel: str
    target: str
    hole: int
    tip: np.ndarray
    order: int = 0

    def __post_init__(self):
        object.__setattr__(self, "tip", _frozen_array(self.tip).reshape(2))


@dataclass(frozen=True, eq=False)
class Design:
    """A complete design: immutable; build variants with :func:`dataclasses.replace`."""

    name: str
    panels: tuple[Panel, ...]
    hinges: tuple[Hinge, ...]
    process: Process = field(default_factory=Process)
    description: str = ""
    root: str = ""
    goals: tuple[Goal, ...] = ()
    depth: float = 0.0  # mm, the strip depth for planar (side-view) designs; 0 = not a strip
    source: str = ""  # where it was loaded from, for messages

    def __post_init__(self):
        object.__setattr__(self, "panels", tuple(self.panels))
        object.__setattr__(self, "hinges", tuple(self.hinges))
        object.__setattr__(self, "goals", tuple(self.goals))
        if not self.root and self.panels:
            object.__setattr__(self, "root", self.panels[0].id)

    # -- lookups -------------------------------------------------------------------
    def panel(self, pid: str) -> Panel:
        for p in self.panels:
            if p.id == pid:
                return p
        raise DesignError(f"{where(self.source)}no panel {pid!r}; panels: {[p.id for p in self.panels]}")

    def hinge(self, hid: str) -> Hinge:
        for h in self.hinges:
            if h.id == hid:
                return h
        raise DesignError(f"{where(self.source)}no hinge {hid!r}; hinges: {[h.id for h in self.hinges]}")

    def panel_index(self) -> dict[str, int]:
        return {p.id: i for i, p in enumerate(self.panels)}

    @property
    def is_planar_strip(self) -> bool:
        """True when every fold line is parallel to the y axis and the panels form a
        chain: the side view (xz) then holds the whole kinematics (paper Eq. 2-4)."""
        if not self.hinges:
            return False
        for h in self.hinges:
            d = h.line[1] - h.line[0]
            if abs(d[0]) > tol.length * 10:
                return False
        return True

    @property
    def materials_used(self) -> list[str]:
        out: list[str] = []
        for m in [p.material for p in self.panels] + [h.material for h in self.hinges]:
            if m not in out:
                out.append(m)
        return out


# -- validation ----------------------------------------------------------------------

def _finite(value, what: str, src: str) -> float:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.number)):
        raise DesignError(f"{src}{what} must be a number, got {schema.describe(value)}")
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise DesignError(f"{src}{what} must be a number, got {schema.describe(value)}") from None
    if not math.isfinite(v):
        raise DesignError(f"{src}{what} must be a finite number, got {value!r}")
    return v


def _length(value, what: str, src: str) -> float:
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
    v = _finite(value, what, src)
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


def shared_edge(a: Panel, b: Panel) -> np.ndarray | None:
    """The longest common boundary segment of two panel outlines, (2, 2), or None."""
    inter = a.polygon.exterior.intersection(b.polygon.exterior)
    best, best_len = None, tol.length * 100
    for g in getattr(inter, "geoms", [inter]):
        if isinstance(g, LineString) and g.length > best_len:
            coords = np.asarray(g.coords)
            best, best_len = np.array([coords[0], coords[-1]]), g.length
        elif g.geom_type == "MultiLineString":  # pragma: no cover - flattened above
            continue
    if best is None and inter.geom_type in ("MultiLineString", "GeometryCollection"):
        merged = shapely.line_merge(shapely.union_all([g for g in inter.geoms if g.geom_type == "LineString"]))
        for g in getattr(merged, "geoms", [merged]):
            if isinstance(g, LineString) and g.length > best_len:
                coords = np.asarray(g.coords)
                best, best_len = np.array([coords[0], coords[-1]]), g.length
    return best


def spanning_tree(design: Design) -> tuple[list[tuple[Hinge, str, str]], list[tuple[Hinge, str, str]]]:
    """The hinge graph split into a breadth-first spanning tree from the root and the
    hinges that close loops (rigid origami: creases meeting at interior vertices).

    Returns ``(tree, loops)``: tree entries are (hinge, parent id, child id) root outward;
    loop entries are (hinge, panel a, panel b) with a, b = ``hinge.panels``. Raises
    DesignError when some panel is not connected to the root.
    """
    src = where(design.source)
    adj: dict[str, list[Hinge]] = {p.id: [] for p in design.panels}
    for h in design.hinges:
        for pid in h.panels:
            adj[pid].append(h)
    seen = {design.root}
    order: list[tuple[Hinge, str, str]] = []
    queue = [design.root]
    used: set[str] = set()
    while queue:
        cur = queue.pop(0)
        for h in adj[cur]:
            if h.id in used:
                continue
            other = h.panels[1] if h.panels[0] == cur else h.panels[0]
            if other in seen:
                continue  # closes a loop; collected below
            used.add(h.id)
            seen.add(other)
            order.append((h, cur, other))
            queue.append(other)
    missing = [p.id for p in design.panels if p.id not in seen]
    if missing:
        raise DesignError(
            f"{src}the hinge graph is not connected: panels {missing} are not joined to root "
            f"{design.root!r}; add a hinge joining them to the rest")
    loops = [(h, h.panels[0], h.panels[1]) for h in design.hinges if h.id not in used]
    return order, loops


def tree_order(design: Design) -> list[tuple[Hinge, str, str]]:
    """Spanning-tree hinges in breadth-first order from the root: (hinge, parent id,
    child id). Hinges closing loops are left out (see :func:`spanning_tree`)."""
    return spanning_tree(design)[0]


def tangent_factor(angle) -> np.ndarray:
    """(rho/2) / tan(rho/2): the arc length, as a share of the flat width w, of the circular
    arc tangent to two panels that turn by rho about the fold line, each set back w/2
    from it (1 at rho = 0, even in rho)."""
    a = 0.5 * np.abs(np.asarray(angle, float))
    small = a < 1e-6
    safe = np.where(small, 1.0, a)
    return np.where(small, 1.0 - a**2 / 3.0, safe / np.tan(np.minimum(safe, np.pi / 2 - 1e-12)))


def has_loops(design: Design) -> bool:
    """True when the hinge graph has cycles (more hinges than panels - 1)."""
    return len(design.hinges) > len(design.panels) - 1


def validate(design: Design, library: MaterialLibrary | None = None) -> Design:
    """Check a design; raise DesignError naming the file, item and fix. Returns it."""
    lib = library or default_library()
    src = where(design.source)
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
    known_hinge = ", ".join(lib.names("hinge"))
    known_panel = ", ".join(lib.names("panel") + lib.names("base"))
    for p in design.panels:
        item = f"{src}panel {p.id!r}: "
        if not isinstance(p.id, str) or not isinstance(p.material, str):  # API-built panels
            raise DesignError(f"{item}id and material must be strings")
        _length(p.thickness, "thickness_mm", item)
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
    _overlaps(design)
    panel_ids = set(ids)
    by_id = {p.id: p for p in design.panels}
    for h in design.hinges:
        item = f"{src}hinge {h.id!r}: "
        if not isinstance(h.id, str) or not isinstance(h.material, str) or not all(
                isinstance(x, str) for x in h.panels):
            raise DesignError(f"{item}id, material and panel ids must be strings")
        if len(h.panels) != 2 or h.panels[0] == h.panels[1]:
            raise DesignError(f"{item}panels must name two different panels, got {list(h.panels)}")
        for pid in h.panels:
            if pid not in panel_ids:
                raise DesignError(f"{item}joins panel {pid!r}, which does not exist; panels: {ids}")
        ang = _finite(h.angle, "angle", item)
        if abs(ang) > math.pi + 1e-12:
            raise DesignError(f"{item}angle_deg {math.degrees(ang):g} is outside [-180, 180] "
                              "(FOLD convention: + valley, - mountain, 0 flat)")
        _length(h.radius, "radius_mm", item)
        _length(h.thickness, "thickness_mm", item)
        fx = _finite(h.fixity, "fixity", item)
        if not 0.0 <= fx <= 1.0:
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
        a, b = (by_id[pid] for pid in h.panels)
        edge = shared_edge(a, b)
        if edge is None:
            raise DesignError(f"{item}panels {a.id!r} and {b.id!r} share no edge; a hinge joins two "
                              "panels along a common side of their outlines")
        line = LineString(h.line)
        if line.distance(LineString(edge)) > 1e-3 or line.length > LineString(edge).length + 1e-3:
            raise DesignError(f"{item}fold line {h.line.tolist()} does not lie on the edge shared by "
                              f"{a.id!r} and {b.id!r} ({edge.tolist()})")
        st = h.style
        if st.interface not in ("flat", "triangular"):
            raise DesignError(f"{item}style.interface must be 'flat' or 'triangular', got {st.interface!r}")
        if not isinstance(st.stepped, (bool, np.bool_)):
            raise DesignError(f"{item}style.stepped must be true or false, got {schema.describe(st.stepped)}")
        for name in ("step_period_mm", "thin_mm", "tooth_depth_mm", "tooth_pitch_mm", "slot_width_mm"):
            _length(getattr(st, name), f"style.{name}", item)
        if _finite(st.max_segment_mm, "style.max_segment_mm", item) < 0:
            raise DesignError(f"{item}style.max_segment_mm must be >= 0 (0 = no slots)")
        _features(h, item)
    if design.root not in panel_ids:
        raise DesignError(f"{src}root panel {design.root!r} does not exist; panels: {ids}")
    spanning_tree(design)  # raises on disconnected panels; loops are allowed (rigid origami)
    pr = design.process
    item = f"{src}process: "
    for name in ("program_temperature_c", "fix_temperature_c", "bath_temperature_c"):
        _finite(getattr(pr, name), name, item)
    _positive(pr.duration_s, "duration_s", item)
    if design.depth:
        _length(design.depth, "depth_mm", src)
    if len(design.goals) > schema.MAX_GOALS:
        raise DesignError(f"{src}{len(design.goals)} goals; at most {schema.MAX_GOALS} are accepted")
    for g in design.goals:
        item = f"{src}goal {g.id!r}: "
        if g.type != "pass_through":
            raise DesignError(f"{item}unknown goal type {g.type!r}; supported: pass_through")
        for pid in (g.panel, g.target):
            if pid not in panel_ids:
                raise DesignError(f"{item}names panel {pid!r}, which does not exist; panels: {ids}")
        if not 0 <= g.hole < len(by_id[g.target].holes):
            raise DesignError(f"{item}panel {g.target!r} has {len(by_id[g.target].holes)} holes; "
                              f"hole {g.hole} does not exist (holes count from 0)")
        if not np.all(np.isfinite(g.tip)):
            raise DesignError(f"{item}tip has a NaN coordinate")
        if isinstance(g.hole, bool) or not isinstance(g.hole, (int, np.integer)):
            raise DesignError(f"{item}hole must be a whole number, got {schema.describe(g.hole)}")
    return design


def _features(h: Hinge, item: str) -> None:
    """Periodic hinge features: above the feature floor and a bounded number per hinge, so
    a tiny step period or tooth pitch is refused here instead of hanging the geometry."""
    st = h.style
    counts = []
    if st.stepped:
        counts.append(("style.step_period_mm", st.step_period_mm, h.width))
    if st.interface == "triangular":
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


def strip(name: str, lengths: Sequence[float], angles_deg: Sequence[float],
          materials: Sequence[str | float | dict], *, depth: float = 6.0,
          thickness: float | Sequence[float] = 0.8, radius: float | Sequence[float] = 5.0,
          hinge_thickness: float | Sequence[float] | None = None,
          panel_material: str = "VeroWhite", process: Process | None = None,
          description: str = "", holes: dict[int, list] | None = None,
          source: str = "", goals: Iterable[Goal] = (), style: HingeStyle | None = None,
          ) -> Design:
    """The paper's strips: panels ``p1..pn`` of the given lengths (mm, fold line to fold
    line) along x, ``depth`` deep along y, joined by hinges ``h1..h(n-1)``.

    >>> d = strip("two", [10, 10], [90], ["H-1"])
    >>> [p.id for p in d.panels], d.hinges[0].panels
    (['p1', 'p2'], ('p1', 'p2'))
    """
    src = where(source, "strip")
    n = len(lengths)
    if n < 1:
        raise DesignError(f"{src}lengths_mm needs at least one panel length")
    if len(angles_deg) != n - 1:
        raise DesignError(f"{src}angles_deg needs {n - 1} values (one per hinge between {n} panels), "
                          f"got {len(angles_deg)}")
    if len(materials) != n - 1:
        raise DesignError(f"{src}materials needs {n - 1} values (one per hinge), got {len(materials)}")
    # a material is a name, a VeroWhite fraction or {vero_fraction = ...} (docs/composition.md)
    materials = [composition.parse_material_spec(m, f"{src}materials[{i}] (hinge 'h{i + 1}'): ")
                 for i, m in enumerate(materials)]

    def per(v, count, what):
        if not isinstance(v, (list, tuple, np.ndarray)):
            return [_length(v, what, src)] * count
        v = list(v)
        if len(v) != count:
            raise DesignError(f"{src}{what} needs 1 or {count} values, got {len(v)}")
        return [_length(x, f"{what}[{k}]", src) for k, x in enumerate(v)]

    thick = per(thickness, n, "thickness_mm")
    rad = per(radius, n - 1, "hinge_radius_mm")
    hthick = per(hinge_thickness if hinge_thickness is not None else min(thick), n - 1, "hinge_thickness_mm")
    depth = _length(depth, "depth_mm", src)
    x = 0.0
    panels = []
    for i, L in enumerate(lengths):
        L = _length(L, f"lengths_mm[{i}]", src)
        outline = [[x, 0.0], [x + L, 0.0], [x + L, depth], [x, depth]]
        hs = [np.asarray(hh, float) + [x, 0.0] for hh in (holes or {}).get(i + 1, [])]
        panels.append(Panel(f"p{i + 1}", outline, float(thick[i]), panel_material, tuple(hs)))
        x += L
    hinges = []
    xs = np.cumsum([float(v) for v in lengths])[:-1]
    for i in range(n - 1):
        ang = _finite(angles_deg[i], f"angles_deg[{i}]", src)
        hinges.append(Hinge(f"h{i + 1}", (f"p{i + 1}", f"p{i + 2}"),
                            [[xs[i], 0.0], [xs[i], depth]], math.radians(ang), materials[i],
                            float(rad[i]), float(hthick[i]), style=style or HingeStyle()))
    return Design(name=name, panels=tuple(panels), hinges=tuple(hinges),
                  process=process or Process(), description=description, root="p1",
                  goals=tuple(goals), depth=float(depth), source=source)
