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
"""

from __future__ import annotations

import math
from dataclasses import fields
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import tomli_w

from .constants import (DEFAULT_DEPTH_MM, DEFAULT_HINGE_RADIUS_MM, DEFAULT_PANEL_MATERIAL,
                        DEFAULT_THICKNESS_MM)
from .design import (SCHEMA_VERSION, Design, Goal, Hinge, HingeStyle, Panel, Process, check_ring,
                     shared_edge, strip, validate)
from .errors import DesignError, where
from .materials import MaterialLibrary

_TOP = {"schema", "name", "description", "root", "process", "defaults", "strip", "panels", "hinges",
        "goals"}
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


def _keys(table: Any, allowed: set[str], src: str, what: str) -> Mapping:
    if not isinstance(table, Mapping):
        raise DesignError(f"{src}{what} must be a table, got {type(table).__name__}")
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise DesignError(f"{src}{what}: unknown key(s) {unknown}; allowed: {sorted(allowed)}")
    return table


def _points(value, what: str, src: str) -> np.ndarray:
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise DesignError(f"{src}{what} must be a list of [x, y] pairs of numbers") from None
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise DesignError(f"{src}{what} must be a list of [x, y] pairs, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise DesignError(f"{src}{what} has a NaN or infinite coordinate")
    return arr


def _num(value, what: str, src: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise DesignError(f"{src}{what} must be a number, got {value!r}")
    if not math.isfinite(value):
        raise DesignError(f"{src}{what} must be a finite number, got {value!r}")
    return float(value)


def _style(raw: Mapping | None, base: HingeStyle, src: str, what: str) -> HingeStyle:
    if not raw:
        return base
    raw = _keys(raw, _STYLE, src, what)
    vals = {f.name: getattr(base, f.name) for f in fields(HingeStyle)}
    vals.update(raw)
    return HingeStyle(**vals)


def design_from_dict(data: Mapping, source: str = "", library: MaterialLibrary | None = None) -> Design:
    """Build and validate a design from parsed TOML (or an equivalent dict)."""
    src = where(source)
    _keys(data, _TOP, src, "top level")
    schema = data.get("schema", SCHEMA_VERSION)
    if schema != SCHEMA_VERSION:
        raise DesignError(f"{src}schema = {schema!r} is not supported; this foldprint reads schema {SCHEMA_VERSION}")
    name = data.get("name") or (Path(source).stem if source else "")
    if not isinstance(name, str) or not name:
        raise DesignError(f"{src}name must be a non-empty string")
    proc_raw = _keys(data.get("process", {}), _PROCESS, src, "[process]")
    process = Process(**{k: _num(v, f"process.{k}", src) for k, v in proc_raw.items()})
    dft = _keys(data.get("defaults", {}), _DEFAULTS, src, "[defaults]")
    thickness = dft.get("thickness_mm", DEFAULT_THICKNESS_MM)
    depth = dft.get("depth_mm", DEFAULT_DEPTH_MM)
    pmat = dft.get("panel_material", DEFAULT_PANEL_MATERIAL)
    radius = dft.get("hinge_radius_mm", DEFAULT_HINGE_RADIUS_MM)
    hthick = dft.get("hinge_thickness_mm", None)
    fixity = dft.get("fixity", 1.0)
    base_style = _style(dft.get("hinge_style"), HingeStyle(), src, "[defaults.hinge_style]")
    goals = tuple(_goal(g, i, src) for i, g in enumerate(data.get("goals", [])))
    has_strip, has_general = "strip" in data, ("panels" in data or "hinges" in data)
    if has_strip and has_general:
        raise DesignError(f"{src}give either [strip] or [[panels]]/[[hinges]], not both")
    if not has_strip and not has_general:
        raise DesignError(f"{src}no geometry: add a [strip] table or [[panels]] and [[hinges]]")
    if has_strip:
        st = _keys(data["strip"], _STRIP, src, "[strip]")
        for key in ("lengths_mm", "angles_deg", "materials"):
            if key not in st or not isinstance(st[key], list):
                raise DesignError(f"{src}[strip] needs {key} = [...]")
        holes: dict[int, list] = {}
        for k, hraw in enumerate(st.get("holes", [])):
            h = _keys(hraw, {"panel", "polygon"}, src, f"strip.holes[{k}]")
            if "panel" not in h or "polygon" not in h:
                raise DesignError(f"{src}strip.holes[{k}] needs panel (1-based index) and polygon")
            holes.setdefault(int(h["panel"]), []).append(_points(h["polygon"], f"strip.holes[{k}].polygon", src))
        d = strip(name, [_num(v, f"strip.lengths_mm[{i}]", src) for i, v in enumerate(st["lengths_mm"])],
                  [_num(v, f"strip.angles_deg[{i}]", src) for i, v in enumerate(st["angles_deg"])],
                  list(st["materials"]), depth=_num(depth, "defaults.depth_mm", src),
                  thickness=st.get("thickness_mm", thickness),
                  radius=st.get("hinge_radius_mm", radius),
                  hinge_thickness=st.get("hinge_thickness_mm", hthick),
                  panel_material=pmat, process=process,
                  description=str(data.get("description", "")), holes=holes, source=source,
                  goals=goals, style=base_style)
        if fixity != 1.0:
            from dataclasses import replace
            d = replace(d, hinges=tuple(replace(h, fixity=float(fixity)) for h in d.hinges))
        if data.get("root"):
            from dataclasses import replace
            d = replace(d, root=str(data["root"]))
        return validate(d, library)
    panels = []
    for i, raw in enumerate(data.get("panels", [])):
        what = f"panels[{i}]"
        raw = _keys(raw, _PANEL, src, what)
        pid = str(raw.get("id", f"p{i + 1}"))
        what = f"panel {pid!r}"
        if "outline" not in raw:
            raise DesignError(f"{src}{what}: needs outline = [[x, y], ...]")
        outline = _points(raw["outline"], f"{what}: outline", src)
        check_ring(outline, "outline", f"{src}{what}: ")
        panels.append(Panel(pid, outline,
                            _num(raw.get("thickness_mm", thickness), f"{what}: thickness_mm", src),
                            str(raw.get("material", pmat)),
                            tuple(_points(h, f"{what}: holes[{k}]", src)
                                  for k, h in enumerate(raw.get("holes", [])))))
    by_id = {p.id: p for p in panels}
    hinges = []
    for i, raw in enumerate(data.get("hinges", [])):
        raw = _keys(raw, _HINGE, src, f"hinges[{i}]")
        hid = str(raw.get("id", f"h{i + 1}"))
        what = f"hinge {hid!r}"
        pp = raw.get("panels")
        if not isinstance(pp, list) or len(pp) != 2:
            raise DesignError(f"{src}{what}: panels must be a list of two panel ids")
        pp = [str(x) for x in pp]
        for pid in pp:
            if pid not in by_id:
                raise DesignError(f"{src}{what}: joins panel {pid!r}, which does not exist; "
                                  f"panels: {list(by_id)}")
        if "angle_deg" not in raw or "material" not in raw:
            raise DesignError(f"{src}{what}: needs angle_deg and material")
        if "line" in raw:
            line = _points(raw["line"], f"{what}: line", src)
            if line.shape != (2, 2):
                raise DesignError(f"{src}{what}: line must be two points [[x0, y0], [x1, y1]]")
        else:
            line = shared_edge(by_id[pp[0]], by_id[pp[1]]) if pp[0] != pp[1] else None
            if line is None:
                raise DesignError(f"{src}{what}: panels {pp[0]!r} and {pp[1]!r} share no edge; a hinge "
                                  "joins two panels along a common side of their outlines")
        ang = _num(raw["angle_deg"], f"{what}: angle_deg", src)
        hinges.append(Hinge(hid, (pp[0], pp[1]), line, math.radians(ang), str(raw["material"]),
                            _num(raw.get("radius_mm", radius), f"{what}: radius_mm", src),
                            _num(raw.get("thickness_mm", hthick if hthick is not None else thickness),
                                 f"{what}: thickness_mm", src),
                            _num(raw.get("fixity", fixity), f"{what}: fixity", src),
                            _style(raw.get("style"), base_style, src, f"{what}: style")))
    d = Design(name=name, panels=tuple(panels), hinges=tuple(hinges), process=process,
               description=str(data.get("description", "")), root=str(data.get("root", "")),
               goals=goals, depth=float(dft.get("depth_mm", 0.0)) if "depth_mm" in dft else 0.0,
               source=source)
    return validate(d, library)


def _goal(raw, i: int, src: str) -> Goal:
    raw = _keys(raw, _GOAL, src, f"goals[{i}]")
    gid = str(raw.get("id", f"g{i + 1}"))
    for key in ("type", "panel", "target", "hole", "tip"):
        if key not in raw:
            raise DesignError(f"{src}goal {gid!r}: needs {key}")
    tip = np.array(raw["tip"], dtype=float).reshape(-1)
    if tip.shape != (2,):
        raise DesignError(f"{src}goal {gid!r}: tip must be [x, y]")
    return Goal(gid, str(raw["type"]), str(raw["panel"]), str(raw["target"]), int(raw["hole"]), tip,
                int(raw.get("order", i)))


def read_text(path: Path, expected: str) -> str:
    """A UTF-8 text file's contents; DesignError naming the path otherwise."""
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DesignError(f"{path}: file not found") from None
    except IsADirectoryError:
        raise DesignError(f"{path}: is a directory, expected {expected}") from None
    except OSError as exc:
        raise DesignError(f"{path}: cannot read: {exc.strerror}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        raise DesignError(f"{path}: not a UTF-8 text file; expected {expected}") from None


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
                 "angle_deg": math.degrees(h.angle), "material": h.material,
                 "radius_mm": float(h.radius), "thickness_mm": float(h.thickness)}
        if h.fixity != 1.0:
            entry["fixity"] = float(h.fixity)
        style = {f.name: getattr(h.style, f.name) for f in fields(HingeStyle)
                 if getattr(h.style, f.name) != getattr(default, f.name)}
        if style:
            entry["style"] = style
        out["hinges"].append(entry)
    if design.goals:
        out["goals"] = [{"id": g.id, "type": g.type, "panel": g.panel, "target": g.target,
                         "hole": g.hole, "tip": g.tip.tolist(), "order": g.order} for g in design.goals]
    return out


def design_to_toml(design: Design) -> str:
    return tomli_w.dumps(design_to_dict(design))
