"""The design model: panels, hinges, process and goals, as frozen dataclasses.

Conventions (``docs/architecture.md``): the crease pattern lies in the flat sheet's
xy-plane, lengths in mm, angles in radians inside (degrees in files). A hinge's target
angle follows the FOLD convention: signed rho in [-pi, pi], 0 flat, + valley (the child
panel rotates toward +z), - mountain. The paper's theta (angle between panels, 180 deg
flat) is theta = 180 deg - |rho|.

Parsing files lives in :mod:`foldprint.io.design_io` (TOML) and
:mod:`foldprint.exchange.fold` (FOLD); both end in :func:`validate`.

This module holds the dataclasses, the arc factor of a hinge and the paper's strip builder
(:func:`strip`); the checks of a design are in :mod:`foldprint.model.validation`, the
hinge graph (spanning tree, loops, shared edges) in :mod:`foldprint.model.hinge_graph`.
Their public names (``validate``, ``check_ring``, ``spanning_tree``, ``tree_order``,
``has_loops``, ``shared_edge``) still import from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Iterable, Sequence

import numpy as np
from shapely.geometry import Polygon

from ..core.constants import (DEFAULT_BATH_C, DEFAULT_DEPTH_MM, DEFAULT_DURATION_S, DEFAULT_FIX_C,
                              DEFAULT_HINGE_RADIUS_MM, DEFAULT_PANEL_MATERIAL, DEFAULT_PROGRAM_C,
                              DEFAULT_THICKNESS_MM, tol)
from ..core.errors import DesignError, where
from ..core.modes import DEFAULT_INTERFACE, Interface
from . import composition
from .hinge_graph import has_loops, shared_edge, spanning_tree, tree_order  # noqa: F401  (importable from here)
from .materials import MaterialLibrary
from .paper_statements import PaperRef
from .validation import finite_value, length_value, check_ring, validate  # noqa: F401  (importable from here)

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
    interface: Interface = DEFAULT_INTERFACE
    tooth_depth_mm: float = 1.5
    tooth_pitch_mm: float = 3.0
    max_segment_mm: float = 0.0
    slot_width_mm: float = 1.0


@dataclass(frozen=True, eq=False)
class Hinge:
    """A hinge joining ``panels[0]`` and ``panels[1]`` along ``line`` (2, 2) mm.

    ``angle`` is the signed target fold angle rho (rad, FOLD convention), ``radius`` the
    bend radius R (mm) of the printed hinge, so its flat width is w = R |rho|.
    ``fixity`` is the shape fixity of programming (1 = the hinge stays flat; None, the
    default: its material's, :attr:`foldprint.model.materials.Material.shape_fixity`): the
    programmed hinge keeps rho_target (1 - fixity) of its printed angle.
    """

    id: str
    panels: tuple[str, str]
    line: np.ndarray
    angle: float
    material: str
    radius: float
    thickness: float
    fixity: float | None = None
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
    """A complete design: immutable; build variants with :meth:`replace` (validated)."""

    name: str
    panels: tuple[Panel, ...]
    hinges: tuple[Hinge, ...]
    process: Process = field(default_factory=Process)
    description: str = ""
    root: str = ""
    goals: tuple[Goal, ...] = ()
    depth: float = 0.0  # mm, the strip depth for planar (side-view) designs; 0 = not a strip
    source: str = ""  # where it was loaded from, for messages
    paper: PaperRef | None = None  # a structure of the paper: its name, figure and statements
    #: what a reader changed in the file to make it a design (strays dropped, a crease on
    #: the sheet's edge read as its border), one sentence each; the CLI prints them
    notes: tuple[str, ...] = field(default=(), compare=False)

    def __post_init__(self):
        object.__setattr__(self, "panels", tuple(self.panels))
        object.__setattr__(self, "hinges", tuple(self.hinges))
        object.__setattr__(self, "goals", tuple(self.goals))
        if not self.root and self.panels:
            object.__setattr__(self, "root", self.panels[0].id)

    def replace(self, library: MaterialLibrary | None = None, **changes) -> "Design":
        """A variant of this design with ``changes`` (fields of :class:`Design`), validated
        like a loaded design (:func:`validate`, against ``library``, default: the shipped
        one); :func:`dataclasses.replace` alone would skip the validation."""
        from dataclasses import replace

        return validate(replace(self, **changes), library)

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


def tangent_factor(angle) -> np.ndarray:
    """(rho/2) / tan(rho/2): the arc length, as a share of the flat width w, of the circular
    arc tangent to two panels that turn by rho about the fold line, each set back w/2
    from it (1 at rho = 0, even in rho)."""
    a = 0.5 * np.abs(np.asarray(angle, float))
    small = a < 1e-6
    safe = np.where(small, 1.0, a)
    return np.where(small, 1.0 - a**2 / 3.0, safe / np.tan(np.minimum(safe, np.pi / 2 - 1e-12)))


def strip(name: str, lengths: Sequence[float], angles_deg: Sequence[float],
          materials: Sequence[str | float | dict], *, depth: float = DEFAULT_DEPTH_MM,
          thickness: float | Sequence[float] = DEFAULT_THICKNESS_MM,
          radius: float | Sequence[float] = DEFAULT_HINGE_RADIUS_MM,
          hinge_thickness: float | Sequence[float] | None = None,
          panel_material: str = DEFAULT_PANEL_MATERIAL, process: Process | None = None,
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
            return [length_value(v, what, src)] * count
        v = list(v)
        if len(v) != count:
            raise DesignError(f"{src}{what} needs 1 or {count} values, got {len(v)}")
        return [length_value(x, f"{what}[{k}]", src) for k, x in enumerate(v)]

    thick = per(thickness, n, "thickness_mm")
    rad = per(radius, n - 1, "hinge_radius_mm")
    hthick = per(hinge_thickness if hinge_thickness is not None else min(thick), n - 1, "hinge_thickness_mm")
    depth = length_value(depth, "depth_mm", src)
    x = 0.0
    panels = []
    for i, L in enumerate(lengths):
        L = length_value(L, f"lengths_mm[{i}]", src)
        outline = [[x, 0.0], [x + L, 0.0], [x + L, depth], [x, depth]]
        hs = [np.asarray(hh, float) + [x, 0.0] for hh in (holes or {}).get(i + 1, [])]
        panels.append(Panel(f"p{i + 1}", outline, float(thick[i]), panel_material, tuple(hs)))
        x += L
    hinges = []
    xs = np.cumsum([float(v) for v in lengths])[:-1]
    for i in range(n - 1):
        ang = finite_value(angles_deg[i], f"angles_deg[{i}]", src)
        hinges.append(Hinge(f"h{i + 1}", (f"p{i + 1}", f"p{i + 2}"),
                            [[xs[i], 0.0], [xs[i], depth]], math.radians(ang), materials[i],
                            float(rad[i]), float(hthick[i]), style=style or HingeStyle()))
    return Design(name=name, panels=tuple(panels), hinges=tuple(hinges),
                  process=process or Process(), description=description, root="p1",
                  goals=tuple(goals), depth=float(depth), source=source)
