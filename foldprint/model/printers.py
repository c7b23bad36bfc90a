"""Printer profiles (``foldprint/data/printers.toml``) and what a design needs of one.

A profile holds the build volume, the smallest wall and gap the process prints, and how
many materials one print can hold (``tools``):

- **FDM** (``technology = "fdm"``): one filament per tool (a toolhead of a tool changer, a
  slot of a filament changer feeding one nozzle, ``single_nozzle``). Every material of the
  design is a filament of its own, so a design needs one tool per material.
- **PolyJet** (``technology = "polyjet"``): ``tools`` model-resin channels loaded with
  ``base_resins``; digital materials are jetted from them in fixed ratios (the paper's
  H-1..H-7 are VeroWhite/TangoBlack mixtures, Mao 2015 Methods), so a hinge material takes
  no channel of its own: it needs VeroWhite and TangoBlack loaded. A design needs one
  channel per distinct base resin.

:func:`tool_fit` answers both; ``check`` reports it (FP103, FP104) and ``export --printer``
refuses a design that does not fit.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Iterable

from ..core import schema as sc
from ..core.errors import DesignError
from ..core.inputs import read_toml, shown
from .materials import MaterialLibrary

#: The base resins every digital SMP of the library is jetted from (Mao 2015, Methods:
#: "mixing two base model materials, i.e., VeroWhite and Tangoblack").
DIGITAL_SMP_RESINS = ("VeroWhite", "TangoBlack")
PRINTERS_DATA = "foldprint/data/printers.toml"


@dataclass(frozen=True)
class Printer:
    key: str
    name: str
    technology: str
    build_mm: tuple[float, float, float]
    layer_mm: float
    min_wall_mm: float
    min_gap_mm: float
    #: voxel pitch (x, y, z mm) for voxel print, and its source; None: not a voxel printer
    voxel_mm: tuple[float, float, float] | None = None
    voxel_source: str = ""
    #: materials one print holds: FDM tools (toolheads or filament slots), PolyJet model-resin
    #: channels; None: the profile does not say (no tool check)
    tools: int | None = None
    tools_source: str = ""
    #: PolyJet: the resins loaded, which digital materials are mixed from
    base_resins: tuple[str, ...] = ()
    #: FDM: one nozzle fed by a filament changer (MMU3, AMS) rather than one nozzle per tool
    single_nozzle: bool = False
    nozzle_mm: float | None = None
    filament_mm: float | None = None

    @property
    def fdm(self) -> bool:
        return self.technology == "fdm"

    @property
    def unit(self) -> str:
        """What ``tools`` counts, in words."""
        return "resin channels" if self.base_resins else "tools"


@dataclass(frozen=True)
class FdmSetup:
    """The FDM printer the slicer 3MFs describe when export is given none
    (``[generic_fdm]`` of printers.toml)."""

    build_mm: tuple[float, float, float]
    layer_mm: float
    nozzle_mm: float
    filament_mm: float
    purge_mm3: float
    tower_width_mm: float
    margin_mm: float
    source: str = ""
    single_nozzle: bool = False


def _data_text() -> str:
    return (resources.files("foldprint") / "data" / "printers.toml").read_text(encoding="utf-8")


#: Printer profiles one file may hold (the shipped file has 8).
MAX_PRINTERS = 256
#: Tools (or resin channels) a profile may state: no changer holds more.
MAX_TOOLS = 64
_PRINTER_KEYS = {"name", "technology", "build_mm", "layer_mm", "min_wall_mm", "min_gap_mm", "voxel_mm",
                 "voxel_source", "default", "voxel_default", "tools", "tools_source", "base_resins",
                 "single_nozzle", "nozzle_mm", "filament_mm", "source"}


def _lengths(raw, at: sc.Where, name: str) -> tuple[float, float, float]:
    vals = sc.array(raw[name], at / name, 3, "three lengths [x, y, z] in mm")
    if len(vals) != 3:
        raise (at / name).fail(f"must be three lengths [x, y, z] in mm, got {len(vals)}")
    return tuple(sc.length(v, at / name / i) for i, v in enumerate(vals))


def _optional_length(raw, at: sc.Where, name: str) -> float | None:
    return None if name not in raw else sc.length(raw[name], at / name)


def _profile(key: str, raw, at: sc.Where) -> Printer:
    """One ``[printers.KEY]`` table, every value through the boundary schema (lengths from
    1 um to 10 m, names and texts bounded, tools a whole number)."""
    sc.ident(key, at)
    raw = sc.table(raw, at, _PRINTER_KEYS)
    for need in ("build_mm", "min_wall_mm", "min_gap_mm"):
        if need not in raw:
            raise at.fail(f"needs build_mm = [x, y, z], min_wall_mm and min_gap_mm (missing {need})")
    technology = sc.string(raw.get("technology", ""), at / "technology")
    resins = tuple(sc.string(r, at / "base_resins" / i)
                   for i, r in enumerate(sc.array(raw.get("base_resins", []), at / "base_resins", MAX_TOOLS)))
    if resins and technology == "fdm":
        raise (at / "base_resins").fail("are PolyJet resins; an fdm printer has one filament per tool (remove "
                                        "base_resins or set technology = \"polyjet\")")
    return Printer(key, sc.string(raw.get("name", key), at / "name"), technology, _lengths(raw, at, "build_mm"),
                   sc.length(raw.get("layer_mm", 0.1), at / "layer_mm"), sc.length(raw["min_wall_mm"], at / "min_wall_mm"),
                   sc.length(raw["min_gap_mm"], at / "min_gap_mm"),
                   _lengths(raw, at, "voxel_mm") if "voxel_mm" in raw else None,
                   sc.string(raw.get("voxel_source", ""), at / "voxel_source", sc.MAX_TEXT),
                   None if "tools" not in raw else sc.integer(raw["tools"], at / "tools", 1, MAX_TOOLS),
                   sc.string(raw.get("tools_source", ""), at / "tools_source", sc.MAX_TEXT), resins,
                   sc.boolean(raw.get("single_nozzle", False), at / "single_nozzle"),
                   _optional_length(raw, at, "nozzle_mm"), _optional_length(raw, at, "filament_mm"))


def load_printers(extra: str | Path | None = None) -> dict[str, Printer]:
    """Shipped printer profiles plus a user TOML file of the same layout, read through the
    one input door (:func:`foldprint.core.inputs.read_toml`) and the boundary schema."""
    tables = [(PRINTERS_DATA, tomllib.loads(_data_text()))]
    if extra is not None:
        tables.append((shown(extra), read_toml(extra, "printer profiles (TOML, [printers.KEY] tables)")))
    out: dict[str, Printer] = {}
    for src, data in tables:
        top = sc.Where(src)
        profiles = sc.table(data.get("printers", {}), top / "printers")
        if len(profiles) > MAX_PRINTERS:
            raise (top / "printers").fail(f"{len(profiles)} profiles; at most {MAX_PRINTERS} are accepted")
        for key, raw in profiles.items():
            out[key] = _profile(key, raw, top / f"printers.{key}")
    return out


def find_printer(key: str, printers_file: str | Path | None = None) -> Printer:
    """The profile ``key`` (shipped or from ``printers_file``); DesignError lists the profiles."""
    printers = load_printers(printers_file)
    if key not in printers:
        raise DesignError(f"--printer {key!r} is unknown; profiles: {', '.join(printers)} "
                          "(add your own with --printers FILE)")
    return printers[key]


def default_voxel_printer_key() -> str:
    """The shipped printer voxel print uses by default (``voxel_default = true``)."""
    data = tomllib.loads(_data_text())["printers"]
    return next(k for k, v in data.items() if v.get("voxel_default"))


def default_printer_key() -> str:
    data = tomllib.loads(_data_text())["printers"]
    return next(k for k, v in data.items() if v.get("default"))


def generic_fdm() -> FdmSetup:
    """``[generic_fdm]``: what the slicer 3MFs describe without an FDM printer profile."""
    g = tomllib.loads(_data_text())["generic_fdm"]
    return FdmSetup(tuple(float(v) for v in g["build_mm"]), float(g["layer_mm"]), float(g["nozzle_mm"]),
                    float(g["filament_mm"]), float(g["purge_mm3"]), float(g["tower_width_mm"]),
                    float(g["margin_mm"]), str(g.get("source", "")))


def fdm_setup(printer: Printer | None) -> FdmSetup:
    """The FDM setup a slicer 3MF describes: ``printer``'s when it is an FDM profile, else
    the generic one (its missing values filled from the generic one too)."""
    g = generic_fdm()
    if printer is None or not printer.fdm:
        return g
    return replace(g, build_mm=printer.build_mm, layer_mm=printer.layer_mm, nozzle_mm=printer.nozzle_mm or g.nozzle_mm,
                   filament_mm=printer.filament_mm or g.filament_mm, source=f"printer profile {printer.key} ({printer.name})",
                   single_nozzle=printer.single_nozzle)


@dataclass(frozen=True)
class ToolFit:
    """What a design's materials need of a printer.

    ``feeds``: what must be loaded: FDM one filament per material; PolyJet the base resins
    (a hinge material's are :data:`DIGITAL_SMP_RESINS`, another material is a resin of its
    own). ``mixed``: PolyJet digital materials jetted from the resins (no channel of their own)."""

    printer: Printer
    materials: tuple[str, ...]
    feeds: tuple[str, ...]
    mixed: tuple[str, ...] = ()
    hinges: tuple[str, ...] = ()

    @property
    def needed(self) -> int:
        return len(self.feeds)

    @property
    def ok(self) -> bool:
        return self.printer.tools is None or self.needed <= self.printer.tools

    def summary(self) -> str:
        """One line: what the design needs and what the printer has."""
        pr, n = self.printer, len(self.materials)
        has = "no tool count in its profile" if pr.tools is None else f"{pr.tools} {pr.unit}"
        if pr.base_resins:
            mix = (f"{len(self.mixed)} digital material(s) ({', '.join(self.mixed)}) jetted from "
                   f"{' and '.join(DIGITAL_SMP_RESINS)}; " if self.mixed else "")
            return (f"{n} material(s): {mix}resins needed: {', '.join(self.feeds)} ({self.needed}); "
                    f"{pr.name} has {has} ({', '.join(pr.base_resins) or 'none'} loaded)")
        return f"{n} material(s) ({', '.join(self.materials)}) need {n} tools; {pr.name} has {has}"

    def alternatives(self, others: Iterable[Printer] = ()) -> str:
        """What to do when the design does not fit: merge grades (FDM) or use fewer resins
        (PolyJet), a printer with enough tools, the PolyJet route, the voxel export."""
        pr = self.printer
        bigger = sorted(p.key for p in others if p.fdm == pr.fdm and p.tools is not None and p.tools >= self.needed
                        and p.key != pr.key)
        if pr.base_resins:
            out = [f"print the panels in a resin already loaded ({', '.join(DIGITAL_SMP_RESINS)}): the hinge grades "
                   "take no channel of their own"]
        else:
            room = max((pr.tools or 0) - (len(self.materials) - len(self.hinges)), 1)
            out = [f"merge grades: at most {room} hinge grade(s) (foldprint assign DESIGN --materials "
                   "H-a,H-b,... --write merged.toml, then check it)"]
        if bigger:
            out.append(f"a printer with enough {pr.unit} (--printer {' / '.join(bigger)})")
        if not pr.base_resins:
            out.append("a PolyJet profile (--printer connex260 or j750: every H-n grade is a digital material jetted "
                       "from VeroWhite and TangoBlack)")
        out.append("the voxel export (--format voxels --printer j750: VeroWhite and TangoBlack only)")
        return "; ".join(out)

    def refusal(self, what: str) -> str:
        """The one-line reason an export for this printer is refused (``what``: the design)."""
        pr = self.printer
        feeds = "resins" if pr.base_resins else "one filament per material"
        return (f"{what}: needs {self.needed} {pr.unit} ({feeds}: {', '.join(self.feeds)}), "
                f"--printer {pr.key} ({pr.name}) has {pr.tools}; instead: "
                f"{self.alternatives(load_printers().values())}")


def tool_fit(printer: Printer, materials: Iterable[str], library: MaterialLibrary) -> ToolFit:
    """The feeds ``materials`` (a design's, e.g. ``Design.materials_used``) need on ``printer``."""
    mats = tuple(dict.fromkeys(materials))
    hinges = tuple(m for m in mats if m in library and library[m].role == "hinge")
    if not printer.base_resins:
        return ToolFit(printer, mats, mats, (), hinges)
    # a hinge material that is not a VeroWhite/TangoBlack blend (Material.blend) is a resin of its own
    mixed = tuple(m for m in hinges if library[m].blend)
    feeds: list[str] = []
    for m in mats:
        for r in (DIGITAL_SMP_RESINS if m in mixed else (m,)):
            if r not in feeds:
                feeds.append(r)
    return ToolFit(printer, mats, tuple(feeds), mixed, hinges)
