"""Design files: TOML load and dump (schema 1), with the strip shorthand.

Layout (see ``templates/`` and ``docs/design-file.md``)::

    schema = 1
    name = "helix_graded"
    description = "..."
    root = "p1"                      # optional: the panel that stays put
    [process]                        # deg C and s
    program_temperature_c = 90
    fix_temperature_c = 10
    bath_temperature_c = 90
    duration_s = 20
    [defaults]                       # used where a panel or hinge does not say
    thickness_mm = 0.8
    depth_mm = 6
    panel_material = "VeroWhite"
    hinge_radius_mm = 5
    hinge_thickness_mm = 0.8
    [defaults.hinge_style]           # HingeStyle fields
    [strip]                          # shorthand for the paper's strips ...
    lengths_mm = [..]
    angles_deg = [..]
    materials = [..]
    # ... or a general crease pattern:
    [[panels]]   id, outline, holes, thickness_mm, material
    [[hinges]]   id, panels, angle_deg, material, radius_mm, thickness_mm, line, fixity, style
    [[goals]]    id, type = "pass_through", panel, target, hole, tip, order
    [paper]                          # a structure of Mao et al. (2015), optional
    name = "Sample 1"                # how the paper names it
    figure = "Fig. 2b"
    statements = ["sample1_contact"] # ids in foldprint/data/paper_timings.toml: printed
                                     # beside the model's values by simulate, check, gallery
    [claims]                         # what the description says the commands print, optional
    nominal = "completes"            # (foldprint.io.templates.Claims; the templates' test)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import tomli_w

from ..core.constants import (DEFAULT_DEPTH_MM, DEFAULT_HINGE_RADIUS_MM, DEFAULT_PANEL_MATERIAL,
                        DEFAULT_THICKNESS_MM)
from ..core import schema as sc
from ..model.design import (SCHEMA_VERSION, Design, Goal, Hinge, HingeStyle, Panel, Process, check_ring,
                     shared_edge, strip, validate)
from ..core.errors import DesignError
from ..core.modes import Interface
from ..core.schema import Where
from ..model import composition
from ..model.materials import MaterialLibrary
from ..model.paper_statements import PaperRef, load_statements
from .templates import parse_claims

_TOP = {"schema", "name", "description", "root", "process", "defaults", "strip", "panels", "hinges",
        "goals", "paper", "claims"}
_PAPER = {"name", "figure", "statements"}
_DEFAULTS = {"thickness_mm", "depth_mm", "panel_material", "hinge_radius_mm", "hinge_thickness_mm",
             "hinge_style", "fixity"}
_STRIP = {"lengths_mm", "angles_deg", "materials", "thickness_mm", "hinge_radius_mm",
          "hinge_thickness_mm", "holes"}
_PANEL = {"id", "outline", "holes", "thickness_mm", "material"}
_HINGE = {"id", "panels", "angle_deg", "material", "radius_mm", "thickness_mm", "line", "fixity",
          "style"}
_GOAL = {"id", "type", "panel", "target", "hole", "tip", "order"}
_STYLE = {f.name for f in fields(HingeStyle)}
_PROCESS = {f.name for f in fields(Process)}


def _angle(value, at: Where) -> float:
    v = sc.number(value, at, unit="degrees")
    if abs(v) > 180:
        raise at.fail(f"{v:g} is outside [-180, 180] degrees (FOLD convention: + valley, - mountain, "
                      "0 flat)")
    return v


def _fixity(value, at: Where) -> float | None:
    """A hinge's shape fixity in [0, 1]; None (not given): the material's."""
    return None if value is None else sc.number(value, at, 0.0, 1.0)


def _style(raw, base: HingeStyle, at: Where) -> HingeStyle:
    """HingeStyle fields, each type- and range-checked (periods above the feature floor)."""
    if raw is None:
        return base
    raw = sc.table(raw, at, _STYLE)
    vals = {f.name: getattr(base, f.name) for f in fields(HingeStyle)}
    for key, v in raw.items():
        k = at / key
        if key == "stepped":
            vals[key] = sc.boolean(v, k)
        elif key == "interface":
            vals[key] = sc.string(v, k)
            if vals[key] not in tuple(Interface):
                raise k.fail(f"must be \"flat\" or \"triangular\", got {sc.describe(v)}")
            vals[key] = Interface(vals[key])
        elif key in ("step_period_mm", "tooth_pitch_mm"):
            vals[key] = sc.number(v, k, sc.FEATURE_FLOOR_MM, sc.MAX_LENGTH_MM, "mm")
        elif key == "max_segment_mm":
            vals[key] = sc.number(v, k, 0.0, sc.MAX_LENGTH_MM, "mm (0 = no slots)")
        else:
            vals[key] = sc.length(v, k)
    return HingeStyle(**vals)


def _per(value, at: Where, count: int, read) -> float | list[float]:
    """A number, or a list of ``count`` numbers (strip shorthand)."""
    if isinstance(value, (list, tuple)):
        vals = sc.array(value, at, count)
        if len(vals) != count:
            raise at.fail(f"needs 1 or {count} values, got {len(vals)}")
        return [read(v, at / i) for i, v in enumerate(vals)]
    return read(value, at)


@dataclass(frozen=True)
class _Defaults:
    """The ``[defaults]`` table, checked: what a panel or hinge that does not say gets."""

    thickness: float
    depth: float
    depth_given: bool
    panel_material: str
    radius: float
    hinge_thickness: float | None
    fixity: float | None
    style: HingeStyle


def _schema_and_names(data: Mapping, top: Where, source: str) -> tuple[str, str, str]:
    """The top level's keys and schema checked; the design's name, description and root."""
    sc.table(data, top.named("top level") if not source else top, _TOP)
    if "schema" in data:
        schema = sc.integer(data["schema"], top / "schema")
        if schema != SCHEMA_VERSION:
            raise (top / "schema").fail(f"{schema} is not supported; this foldprint reads schema "
                                        f"{SCHEMA_VERSION}")
    if "name" in data:
        name = sc.name(data["name"], top / "name")
    else:
        name = sc.name((Path(source).stem if source else "")[:sc.MAX_NAME] or "design", top / "name")
    description = sc.string(data.get("description", ""), top / "description", sc.MAX_TEXT)
    root = sc.ident(data["root"], top / "root") if data.get("root", "") != "" else ""
    return name, description, root


def _process(data: Mapping, top: Where) -> Process:
    """The ``[process]`` table: temperatures in deg C, the duration in s."""
    at = top / "process"
    proc_raw = sc.table(data.get("process", {}), at, _PROCESS)
    proc = {}
    for k, v in proc_raw.items():
        if k == "duration_s":
            proc[k] = sc.number(v, at / k, 0.0, sc.MAX_DURATION_S, "s", lo_open=True)
        else:
            proc[k] = sc.number(v, at / k, *sc.TEMPERATURE_C, "deg C")
    return Process(**proc)


def _defaults(data: Mapping, top: Where) -> _Defaults:
    """The ``[defaults]`` table, each value checked, the package defaults where it is silent."""
    at = top / "defaults"
    dft = sc.table(data.get("defaults", {}), at, _DEFAULTS)
    thickness = sc.length(dft.get("thickness_mm", DEFAULT_THICKNESS_MM), at / "thickness_mm")
    depth = sc.length(dft.get("depth_mm", DEFAULT_DEPTH_MM), at / "depth_mm")
    pmat = sc.string(dft.get("panel_material", DEFAULT_PANEL_MATERIAL), at / "panel_material")
    radius = sc.length(dft.get("hinge_radius_mm", DEFAULT_HINGE_RADIUS_MM), at / "hinge_radius_mm")
    hthick = (sc.length(dft["hinge_thickness_mm"], at / "hinge_thickness_mm")
              if "hinge_thickness_mm" in dft else None)
    fixity = _fixity(dft.get("fixity"), at / "fixity")
    base_style = _style(dft.get("hinge_style"), HingeStyle(), at / "hinge_style")
    return _Defaults(thickness, depth, "depth_mm" in dft, pmat, radius, hthick, fixity, base_style)


def _strip_design(data: Mapping, top: Where, name: str, description: str, root: str,
                  process: Process, dflt: _Defaults, goals: tuple, source: str) -> Design:
    """The ``[strip]`` shorthand as a design (not yet validated)."""
    at = top / "strip"
    st = sc.table(data["strip"], at, _STRIP)
    for key in ("lengths_mm", "angles_deg", "materials"):
        if key not in st:
            raise at.fail(f"needs {key} = [...]")
    lengths = [sc.length(v, (at / "lengths_mm" / i).named(f"panel 'p{i + 1}'"))
               for i, v in enumerate(sc.array(st["lengths_mm"], at / "lengths_mm", sc.MAX_PANELS))]
    n = len(lengths)
    angles = [_angle(v, (at / "angles_deg" / i).named(f"hinge 'h{i + 1}'"))
              for i, v in enumerate(sc.array(st["angles_deg"], at / "angles_deg", sc.MAX_PANELS))]
    mats = [_material(v, (at / "materials" / i).named(f"hinge 'h{i + 1}'"))
            for i, v in enumerate(sc.array(st["materials"], at / "materials", sc.MAX_PANELS))]
    holes: dict[int, list] = {}
    for k, hraw in enumerate(sc.array(st.get("holes", []), at / "holes", sc.MAX_HOLES * 16)):
        hat = at / "holes" / k
        h = sc.table(hraw, hat, {"panel", "polygon"})
        if "panel" not in h or "polygon" not in h:
            raise hat.fail("needs panel (1-based index) and polygon")
        pnum = sc.integer(h["panel"], hat / "panel", 1, max(n, 1))
        holes.setdefault(pnum, []).append(sc.ring(h["polygon"], hat / "polygon"))
    d = strip(name, lengths, angles, mats, depth=dflt.depth,
              thickness=_per(st.get("thickness_mm", dflt.thickness), at / "thickness_mm", n, sc.length),
              radius=_per(st.get("hinge_radius_mm", dflt.radius), at / "hinge_radius_mm", max(n - 1, 0),
                          sc.length),
              hinge_thickness=(_per(st["hinge_thickness_mm"], at / "hinge_thickness_mm", max(n - 1, 0),
                                    sc.length) if "hinge_thickness_mm" in st else dflt.hinge_thickness),
              panel_material=dflt.panel_material, process=process, description=description, holes=holes,
              source=source, goals=goals, style=dflt.style)
    if dflt.fixity is not None:
        d = replace(d, hinges=tuple(replace(h, fixity=dflt.fixity) for h in d.hinges))
    if root:
        d = replace(d, root=root)
    return d


def _entries(data: Mapping, top: Where, key: str, schema, prefix: str, kind: str):
    """Each ``[[key]]`` table checked against ``schema``: (where, table, id), the id
    defaulting to ``prefix`` + its 1-based position and the where named after it."""
    for i, raw in enumerate(sc.array(data.get(key, []), top / key, sc.MAX_PANELS, f"a list of [[{key}]] tables")):
        at = top / key / i
        raw = sc.table(raw, at, schema)
        ident = sc.ident(raw.get("id", f"{prefix}{i + 1}"), at / "id")
        yield at.named(f"{kind} {ident!r}"), raw, ident


def _panels(data: Mapping, top: Where, dflt: _Defaults) -> list[Panel]:
    """The ``[[panels]]`` tables as panels."""
    panels = []
    for at, raw, pid in _entries(data, top, "panels", _PANEL, "p", "panel"):
        if "outline" not in raw:
            raise at.fail("needs outline = [[x, y], ...]")
        outline = np.array(sc.ring(raw["outline"], at / "outline"))
        check_ring(outline, "outline", str(at))
        hole_list = sc.array(raw.get("holes", []), at / "holes", sc.MAX_HOLES, "a list of polygons")
        panels.append(Panel(pid, outline,
                            sc.length(raw.get("thickness_mm", dflt.thickness), at / "thickness_mm"),
                            sc.string(raw.get("material", dflt.panel_material), at / "material"),
                            tuple(np.array(sc.ring(h, at / "holes" / k)) for k, h in enumerate(hole_list))))
    return panels


def _hinge_panels(raw: Mapping, at: Where, by_id: Mapping) -> list[str]:
    """The two panel ids a ``[[hinges]]`` table joins, each an existing panel."""
    pp = raw.get("panels")
    if not isinstance(pp, (list, tuple)) or len(pp) != 2:
        raise (at / "panels").fail(f"must be a list of two panel ids, got {sc.describe(pp)}")
    pp = [sc.ident(x, at / "panels" / k) for k, x in enumerate(pp)]
    for pid in pp:
        if pid not in by_id:
            raise (at / "panels").fail(f"joins panel {pid!r}, which does not exist; "
                                       f"panels: {list(by_id)[:20]}")
    return pp


def _hinges(data: Mapping, top: Where, by_id: Mapping, dflt: _Defaults) -> list[Hinge]:
    """The ``[[hinges]]`` tables as hinges; a hinge without a line runs along the shared
    edge of its panels."""
    hinges = []
    for at, raw, hid in _entries(data, top, "hinges", _HINGE, "h", "hinge"):
        pp = _hinge_panels(raw, at, by_id)
        for key in ("angle_deg", "material"):
            if key not in raw:
                raise at.fail(f"needs {key}")
        if "line" in raw:
            line = np.array(sc.points(raw["line"], at / "line", exact=2))
        else:
            line = shared_edge(by_id[pp[0]], by_id[pp[1]]) if pp[0] != pp[1] else None
            if line is None:
                raise at.fail(f"panels {pp[0]!r} and {pp[1]!r} share no edge; a hinge joins two panels "
                              "along a common side of their outlines")
        ang = _angle(raw["angle_deg"], at / "angle_deg")
        hthick = dflt.hinge_thickness if dflt.hinge_thickness is not None else dflt.thickness
        hinges.append(Hinge(hid, (pp[0], pp[1]), line, math.radians(ang),
                            _material(raw["material"], at / "material"),
                            sc.length(raw.get("radius_mm", dflt.radius), at / "radius_mm"),
                            sc.length(raw.get("thickness_mm", hthick), at / "thickness_mm"),
                            _fixity(raw.get("fixity", dflt.fixity), at / "fixity"),
                            _style(raw.get("style"), dflt.style, at / "style")))
    return hinges


def design_from_dict(data: Mapping, source: str = "", library: MaterialLibrary | None = None) -> Design:
    """Build and validate a design from parsed TOML (or an equivalent dict, or FOLD).

    Every value passes the boundary schema (:mod:`foldprint.core.schema`) first; errors are
    DesignError naming the file, the key path and what would be right."""
    top = Where(source)
    name, description, root = _schema_and_names(data, top, source)
    process = _process(data, top)
    dflt = _defaults(data, top)
    goals_raw = sc.array(data.get("goals", []), top / "goals", sc.MAX_GOALS, "a list of [[goals]] tables")
    goals = tuple(_goal(g, top / "goals" / i, i) for i, g in enumerate(goals_raw))
    has_strip, has_general = "strip" in data, ("panels" in data or "hinges" in data)
    if has_strip and has_general:
        raise DesignError(f"{top}give either [strip] or [[panels]]/[[hinges]], not both")
    if not has_strip and not has_general:
        raise DesignError(f"{top}no geometry: add a [strip] table or [[panels]] and [[hinges]]")
    paper = _paper(data, top)
    parse_claims(data.get("claims"), top / "claims")  # checked here; read by io.templates
    if has_strip:
        d = _strip_design(data, top, name, description, root, process, dflt, goals, source)
    else:
        panels = _panels(data, top, dflt)
        hinges = _hinges(data, top, {p.id: p for p in panels}, dflt)
        d = Design(name=name, panels=tuple(panels), hinges=tuple(hinges), process=process,
                   description=description, root=root, goals=goals,
                   depth=dflt.depth if dflt.depth_given else 0.0, source=source)
    if paper is not None:
        d = replace(d, paper=_paper_fits(paper, d, top / "paper"))
    return validate(d, library)


def _paper(data: Mapping, top: Where) -> PaperRef | None:
    """The ``[paper]`` table: how Mao et al. (2015) name the structure, its figure and the
    ids of their statements about it (``foldprint/data/paper_timings.toml``)."""
    if "paper" not in data:
        return None
    at = top / "paper"
    raw = sc.table(data["paper"], at, _PAPER)
    if "name" not in raw:
        raise at.fail('needs name = "..." (how the paper names the structure, e.g. "Sample 1")')
    known = load_statements().ids
    ids = []
    for i, v in enumerate(sc.array(raw.get("statements", []), at / "statements", len(known))):
        ids.append(sc.ident(v, at / "statements" / i))
        if ids[-1] not in known:
            raise (at / "statements" / i).fail(f"{ids[-1]!r} is not a statement of foldprint/data/paper_timings.toml; "
                                               f"statements: {', '.join(known)}")
    return PaperRef(sc.string(raw["name"], at / "name"), sc.string(raw.get("figure", ""), at / "figure"), tuple(ids))


def _paper_fits(paper: PaperRef, design: Design, at: Where) -> PaperRef:
    """``paper`` when every hinge and material its statements read is in ``design``."""
    st = load_statements()
    hinge_ids, mats = {h.id for h in design.hinges}, {h.material for h in design.hinges}
    for sid in paper.statements:
        s = st[sid]
        missing = [h for h in s.hinges if h not in hinge_ids] + [m for m in s.materials if m not in mats]
        if missing or s.measure == "free_hinges":
            what = "is about free hinges, not a structure" if not missing else \
                f"reads {', '.join(map(repr, missing))}, which this design does not have"
            raise at.fail(f"statement {sid!r} {what}; link only the statements about this structure")
    return paper


def _goal(raw, at: Where, i: int) -> Goal:
    raw = sc.table(raw, at, _GOAL)
    gid = sc.ident(raw.get("id", f"g{i + 1}"), at / "id")
    at = at.named(f"goal {gid!r}")
    for key in ("type", "panel", "target", "hole", "tip"):
        if key not in raw:
            raise at.fail(f"needs {key}")
    tip = sc.points([raw["tip"]], at / "tip", exact=1)[0]
    return Goal(gid, sc.string(raw["type"], at / "type"), sc.ident(raw["panel"], at / "panel"),
                sc.ident(raw["target"], at / "target"), sc.integer(raw["hole"], at / "hole", 0, sc.MAX_HOLES),
                np.array(tip), sc.integer(raw.get("order", i), at / "order", -10**9, 10**9))


def _material(value, at: sc.Where) -> str:
    """A hinge's material: a name (``"H-3"``, ``"VW0.620"``), a VeroWhite fraction, or
    ``{vero_fraction = 0.62}`` / ``{vero_fraction = [0.6, 0.9], along = "width"}``
    (:func:`foldprint.model.composition.parse_material_spec`) -> the material's name."""
    return composition.parse_material_spec(sc.string(value, at) if isinstance(value, str) else value, str(at))


def design_to_dict(design: Design) -> dict:
    """The general ([[panels]]/[[hinges]]) form; ``design_from_dict`` reads it back."""
    default = HingeStyle()
    out: dict[str, Any] = {"schema": SCHEMA_VERSION, "name": design.name}
    if design.description:
        out["description"] = design.description
    out["root"] = design.root
    out["process"] = {f.name: float(getattr(design.process, f.name)) for f in fields(Process)}
    if design.depth:
        out["defaults"] = {"depth_mm": float(design.depth)}
    out["panels"] = []
    for p in design.panels:
        entry: dict[str, Any] = {"id": p.id, "outline": p.outline.tolist(), "thickness_mm": float(p.thickness),
                                 "material": p.material}
        if p.holes:
            entry["holes"] = [h.tolist() for h in p.holes]
        out["panels"].append(entry)
    out["hinges"] = []
    for h in design.hinges:
        entry = {"id": h.id, "panels": list(h.panels), "line": h.line.tolist(),
                 "angle_deg": math.degrees(h.angle), "material": composition.material_spec(h.material),
                 "radius_mm": float(h.radius), "thickness_mm": float(h.thickness)}
        if h.fixity is not None:
            entry["fixity"] = float(h.fixity)
        style = {f.name: getattr(h.style, f.name) for f in fields(HingeStyle)
                 if getattr(h.style, f.name) != getattr(default, f.name)}
        if style:
            entry["style"] = style
        out["hinges"].append(entry)
    if design.paper is not None:
        out["paper"] = {"name": design.paper.name, "figure": design.paper.figure,
                        "statements": list(design.paper.statements)}
    if design.goals:
        out["goals"] = [{"id": g.id, "type": g.type, "panel": g.panel, "target": g.target,
                         "hole": g.hole, "tip": g.tip.tolist(), "order": g.order} for g in design.goals]
    return out


def design_to_toml(design: Design) -> str:
    return tomli_w.dumps(design_to_dict(design))
