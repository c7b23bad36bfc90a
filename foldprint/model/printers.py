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

import math
import tomllib
from dataclasses import dataclass, replace
from importlib import resources
from pathlib import Path
from typing import Iterable

from ..core.errors import DesignError
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


def _positive(src: str, key: str, raw: dict, name: str, kind=float):
    v = raw.get(name)
    if v is None:
        return None
    try:
        x = kind(v)
    except (TypeError, ValueError):
        x = None
    if x is None or isinstance(v, bool) or not (math.isfinite(x) and x > 0) or (kind is int and x != v):
        raise DesignError(f"{src}: printers.{key}: {name} must be a positive {'whole number' if kind is int else 'number'}, "
                          f"got {v!r}")
    return x


def _profile(src: str, key: str, raw: dict) -> Printer:
    try:
        build = tuple(float(v) for v in raw["build_mm"])
        vox = raw.get("voxel_mm")
        vox = None if vox is None else tuple(float(v) for v in vox)
        resins = tuple(str(r) for r in raw.get("base_resins", ()))
        pr = Printer(key, str(raw.get("name", key)), str(raw.get("technology", "")), build,
                     float(raw.get("layer_mm", 0.1)), float(raw["min_wall_mm"]), float(raw["min_gap_mm"]),
                     vox, str(raw.get("voxel_source", "")), _positive(src, key, raw, "tools", int),
                     str(raw.get("tools_source", "")), resins, bool(raw.get("single_nozzle", False)),
                     _positive(src, key, raw, "nozzle_mm"), _positive(src, key, raw, "filament_mm"))
    except (KeyError, TypeError, ValueError) as exc:
        raise DesignError(f"{src}: printers.{key}: needs build_mm = [x, y, z], min_wall_mm and "
                          f"min_gap_mm ({exc})") from None
    if vox is not None and (len(vox) != 3 or not all(math.isfinite(v) and v > 0 for v in vox)):
        raise DesignError(f"{src}: printers.{key}: voxel_mm must be three positive lengths [x, y, z] in mm")
    if len(build) != 3 or min(build) <= 0 or pr.min_wall_mm <= 0 or pr.min_gap_mm <= 0:
        raise DesignError(f"{src}: printers.{key}: sizes must be positive")
    if resins and pr.fdm:
        raise DesignError(f"{src}: printers.{key}: base_resins are PolyJet resins; an fdm printer has one filament "
                          "per tool (remove base_resins or set technology = \"polyjet\")")
    return pr


def load_printers(extra: str | Path | None = None) -> dict[str, Printer]:
    """Shipped printer profiles plus a user TOML file of the same layout."""
    tables = [(PRINTERS_DATA, tomllib.loads(_data_text()))]
    if extra is not None:
        p = Path(extra)
        try:
            tables.append((str(p), tomllib.loads(p.read_text(encoding="utf-8"))))
        except FileNotFoundError:
            raise DesignError(f"{p}: printer file not found") from None
        except ValueError as exc:  # also a >4300-digit integer
            raise DesignError(f"{p}: not valid TOML: {exc}") from None
    out: dict[str, Printer] = {}
    for src, data in tables:
        for key, raw in data.get("printers", {}).items():
            out[key] = _profile(src, key, raw)
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
    feeds: list[str] = []
    for m in mats:
        for r in (DIGITAL_SMP_RESINS if m in hinges else (m,)):
            if r not in feeds:
                feeds.append(r)
    return ToolFit(printer, mats, tuple(feeds), hinges, hinges)
