"""Write a built part: 3MF (two flavours), STL per material + manifest, and the
hand-offs: FOLD crease pattern, Abaqus input (FEM), XDMF time series (ParaView),
animated glTF binary.

This module only writes: the assembly comes built from :mod:`foldprint.apps.pipeline`.

Everything is built in memory first; only then is the set written, as a whole
(:func:`~foldprint.exchange.fileset.write_set`: staged beside the folder, published by one
rename), so a failed or killed export leaves the previous complete set or the new one.

File names (``stem`` = the design name, ``<name>_programmed`` for the flat state):
``<stem>.3mf`` (spec form + Bambu/Orca/Cura metadata), ``<stem>_prusa.3mf`` (PrusaSlicer),
``<stem>_<material>.stl`` and ``manifest.json`` (``manifest_programmed.json``),
``<stem>.fold``, ``<stem>.inp``, ``<stem>_fold.xdmf``, ``<stem>_fold.glb``; always
``<stem>_recipe.md`` (how to print, program and fold it, :mod:`.recipe`).

Every record lists the bodies it holds, each with its material, extruder (1-based, as
slicers number them), every file of the export that holds it, volume, z range in the
print frame and the panels/hinges that need support on the bed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from ..model.derived import scoped
from ..model.design import Design
# ANIMATION_DT_S: the frames' time step (core.constants), importable from here as before
from ..core.constants import ANIMATION_DT_S, EXPORT_FORMATS  # noqa: F401
from ..core.errors import ExportError
from ..core.modes import State
from ..geometry import Assembly, bed_report
from ..geometry.surfaces import Frames
from ..model.materials import MaterialLibrary, default_library
from ..model.printers import Printer, fdm_setup, tool_fit
from .fem import PlacedState, inp_bytes
from .fileset import write_set
from .fold import fold_bytes
from .gltf import glb_bytes
from .recipe import CheckSummary, recipe_markdown
from .slicer_config import BedLayout, bed_layout
from .stl import manifest, stl_bytes
from .threemf import composite3mf_bytes, prusa3mf_bytes, threemf_bytes
from .voxels import slice_files
from .voxel_regions import VoxelPart
from .xdmf import xdmf_files

def safe_name(text: str) -> str:
    """A file-name-safe version of a design or material name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "part"


def stem(design: Design, state: State) -> str:
    base = safe_name(design.name)
    return base if state == State.PERMANENT else f"{base}_{state}"


def check_formats(formats: Iterable[str]) -> list[str]:
    """The requested formats, de-duplicated; ExportError names unknown ones."""
    if isinstance(formats, str):
        formats = [formats]
    formats = list(dict.fromkeys(formats))
    unknown = [f for f in formats if f not in FORMATS]
    if unknown or not formats:
        raise ExportError(f"unknown export format(s) {unknown or 'none given'}; choose from {list(FORMATS)}")
    return formats


def body_records(assembly: Assembly, files: dict[str, list[str]] | None = None) -> list[dict]:
    """Per body: material, extruder (1-based, the order of the 3MF volumes), files that
    hold it, volume, z range in the print frame (part on the bed, ``Assembly.print_offset``)
    and the panels and hinges of that body that need support (:func:`bed_report`; None
    for an assembly made without its units)."""
    support: dict[str, list[dict]] = {}
    for r in (bed_report(assembly) if assembly.units else []):
        if r["needs_support"]:
            support.setdefault(r["material"], []).append(
                {"kind": r["kind"], "id": r["id"], "z_min_mm": r["z_min_mm"],
                 "unsupported_area_mm2": r["unsupported_area_mm2"]})
    out = []
    for k, b in enumerate(assembly.bodies):
        lo, hi = assembly.print_z_range(b)
        out.append({"material": b.material, "extruder": k + 1, "files": list((files or {}).get(b.material, [])),
                    "volume_mm3": round(b.volume, 6), "z_range_mm": [round(lo, 6), round(hi, 6)],
                    "needs_support": support.get(b.material, []) if assembly.units else None})
    return out


@dataclass(frozen=True)
class Rendered:
    """One file of an export, in memory: its name, its bytes (or, for a voxel slice, a
    callable that makes them when :func:`~foldprint.exchange.fileset.write_set` stages it),
    its format, the bodies it holds (records of :func:`body_records`) and the extra fields
    of its record (``mesh`` for inp; ``steps``, ``dt_s``, ... for xdmf and glb)."""
    name: str
    data: bytes | Callable[[], bytes]
    fmt: str
    bodies: list[dict]
    extra: dict


@dataclass(frozen=True)
class Piece:
    """A file as a writer makes it: like :class:`Rendered`, with the names of the
    materials whose bodies it holds (their records are made once every file is known)."""
    name: str
    data: bytes | Callable[[], bytes]
    fmt: str
    materials: tuple[str, ...]
    extra: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Inputs:
    """What the writers are handed (they compute none of it): ``stem`` names the files of
    the part's state, ``every`` is every body's material, ``layout`` the slicer bed's."""
    design: Design
    assembly: Assembly
    library: MaterialLibrary
    stem: str
    every: tuple[str, ...]
    layout: BedLayout
    frames: Frames | None = None
    fold_times: dict | None = None
    placed: PlacedState | None = None
    voxels: VoxelPart | None = None


@dataclass(frozen=True)
class Format:
    """One export format: its name (``--format``), the writer that makes its files from
    the :class:`Inputs`, and the input it needs beyond the assembly (a field of
    :class:`Inputs`, None for none)."""
    name: str
    writer: Callable[[Inputs], list[Piece]]
    needs: str | None = None


def _3mf(i: Inputs) -> list[Piece]:
    return [Piece(f"{i.stem}.3mf", threemf_bytes(i.design, i.assembly, i.library, i.layout), "3mf", i.every)]


def _prusa3mf(i: Inputs) -> list[Piece]:
    return [Piece(f"{i.stem}_prusa.3mf", prusa3mf_bytes(i.design, i.assembly, i.library, i.layout), "prusa3mf",
                  i.every)]


def _stl(i: Inputs) -> list[Piece]:
    """One STL per body and the manifest (each hinge's fold time)."""
    out, names = [], {}
    for b in i.assembly.bodies:
        name = f"{i.stem}_{safe_name(b.material)}.stl"
        names[b.material] = name
        out.append(Piece(name, stl_bytes(b, f"{i.design.name} {b.material} {i.assembly.state} mm"), "stl",
                         (b.material,)))
    man = "manifest.json" if i.assembly.state == State.PERMANENT else f"manifest_{i.assembly.state}.json"
    out.append(Piece(man, manifest(i.design, i.assembly, names, i.fold_times, i.library).encode("utf-8"),
                     "manifest", i.every))
    return out


def _fold(i: Inputs) -> list[Piece]:
    """The crease pattern: the same for both states."""
    return [Piece(f"{safe_name(i.design.name)}.fold", fold_bytes(i.design), "fold", i.every)]


def _inp(i: Inputs) -> list[Piece]:
    """The FE mesh of the strip's side profile (panels and hinges)."""
    data, quality = inp_bytes(i.design, i.placed)
    return [Piece(f"{i.stem}.inp", data, "inp", i.every, {"mesh": quality})]


def _span(frames: Frames) -> dict:
    """The record fields of a time series: its steps, time step and hinge model."""
    dt = float(np.median(np.diff(frames.times))) if len(frames.times) > 1 else 0.0
    return {"steps": int(len(frames.times)), "dt_s": round(dt, 9), "hinge_model": frames.model}


def _xdmf(i: Inputs) -> list[Piece]:
    """ParaView: the flat surfaces and their displacement per time step (the .xdmf and its .h5)."""
    files, more = xdmf_files(i.design, i.frames, list(i.every), f"{safe_name(i.design.name)}_fold.xdmf")
    return [Piece(name, data, "xdmf" if k == 0 else "h5", i.every, {**_span(i.frames), **more} if k == 0 else {})
            for k, (name, data) in enumerate(files.items())]


def _glb(i: Inputs) -> list[Piece]:
    """Any 3D viewer: nodes per panel and hinge segment, keyframes."""
    data, more = glb_bytes(i.design, i.frames, i.library)
    return [Piece(f"{safe_name(i.design.name)}_fold.glb", data, "glb", i.every, {**_span(i.frames), **more})]


def _voxels(i: Inputs) -> list[Piece]:
    """The PNG slice stack (streamed), its manifest and the composite 3MF. A slice lists no
    bodies (the stack's manifest and 3MF do): 700 layers would repeat every body 700 times
    in --json."""
    out = [Piece(name, make, "voxels", i.every) if name.endswith(".json") else Piece(name, make, "png", ())
           for name, make in slice_files(i.voxels, i.stem)]
    out.append(Piece(f"{i.stem}_voxels.3mf", composite3mf_bytes(i.design, i.assembly, i.voxels, i.library),
                     "3mf-composite", i.every))
    return out


#: Every format ``export`` writes, by name, in the order its files are written (and
#: listed); ``DEFAULT_FORMATS`` when none is asked for. Every export ends with its recipe
#: (``<stem>_recipe.md``, format ``recipe``), which is not a format one asks for.
REGISTRY: dict[str, Format] = {f.name: f for f in (
    Format("3mf", _3mf),
    Format("prusa3mf", _prusa3mf),
    Format("stl", _stl, needs="fold_times"),
    Format("fold", _fold),
    Format("inp", _inp, needs="placed"),
    Format("xdmf", _xdmf, needs="frames"),
    Format("glb", _glb, needs="frames"),
    Format("voxels", _voxels, needs="voxels"),
)}
FORMATS = tuple(REGISTRY)
#: The formats written when none is asked for (the files a printer needs), each in REGISTRY.
DEFAULT_FORMATS = EXPORT_FORMATS
#: Formats that show the fold over time: they need its :class:`~foldprint.geometry.surfaces.Frames`
#: (the surfaces placed along the simulated trajectory).
TRAJECTORY_FORMATS = tuple(f.name for f in REGISTRY.values() if f.needs == "frames")
#: Formats written from a :class:`~foldprint.exchange.voxel_regions.VoxelPart` (the regions with
#: their VeroWhite fraction profiles and hinge axes): the PNG slice stack, its manifest
#: and the 3MF with composite materials.
VOXEL_FORMATS = tuple(f.name for f in REGISTRY.values() if f.needs == "voxels")
#: Why a format refuses without its input, in the order they are checked ({list}: the
#: formats that need it, {names}: the same joined, {quoted}: each quoted).
NEEDS = {
    "frames": "format(s) {list} show the fold over time and need its frames (the surfaces placed along the "
              "simulated trajectory, geometry.surfaces.fold_frames); export through "
              "foldprint.apps.pipeline.export, which runs the simulation",
    "fold_times": "format {names} writes a manifest with each hinge's fold time and needs them "
                  "(foldprint.physics.recovery.curve.hinge_fold_times); export through "
                  "foldprint.apps.pipeline.export, which computes them",
    "placed": "format {names} meshes the strip in its placed state and needs it (fem.PlacedState); "
              "export through foldprint.apps.pipeline.export, which places it",
    "voxels": "format {quoted} rasterises the part with each hinge's VeroWhite fraction and "
              "needs them; export through foldprint.apps.pipeline.Evaluation.export, which supplies them",
}


def _needs_given(formats: list[str], inputs: Inputs) -> None:
    """Refuse a format whose input the caller did not hand over (the writers compute none)."""
    for need, why in NEEDS.items():
        names = [f for f in formats if REGISTRY[f].needs == need]
        if names and getattr(inputs, need) is None:
            raise ExportError(why.format(list=names, names=", ".join(names), quoted=", ".join(map(repr, names))))


def render(design: Design, assembly: Assembly, formats: Iterable[str] = DEFAULT_FORMATS,
           library: MaterialLibrary | None = None,
           frames: Frames | None = None,
           fold_times: dict | None = None,
           placed: PlacedState | None = None,
           voxels: VoxelPart | None = None,
           printer: Printer | None = None,
           check: CheckSummary | None = None) -> list[Rendered]:
    """The files of an export in memory, in :data:`REGISTRY` order, each written by its
    format's writer. ``frames`` (the fold's surfaces over time) are needed by
    :data:`TRAJECTORY_FORMATS`, ``fold_times`` (each hinge's, by id) by stl's manifest,
    ``placed`` (the state's poses) by inp, ``voxels`` (the regions with their VeroWhite
    fractions) by :data:`VOXEL_FORMATS`: the writers compute none of them. The voxel
    slices are callables that make their bytes when
    :func:`~foldprint.exchange.fileset.write_set` stages them (streamed). ``printer``: the
    profile the export is for (the slicer 3MFs describe it when it is an FDM printer, else a
    generic FDM printer; the recipe says what the design needs of it); ``check``: the
    check's findings for the recipe, when it ran. Every export ends with its recipe
    (``<stem>_recipe.md``, format ``recipe``)."""
    lib = library or default_library()
    formats = check_formats(formats)
    inputs = Inputs(design, assembly, lib, stem(design, assembly.state), tuple(b.material for b in assembly.bodies),
                    bed_layout(assembly, fdm_setup(printer)), frames, fold_times, placed, voxels)
    _needs_given(formats, inputs)
    out = [piece for f in REGISTRY.values() if f.name in formats for piece in f.writer(inputs)]
    fit = None if printer is None else tool_fit(printer, [b.material for b in assembly.bodies], lib)
    out.append(Piece(f"{inputs.stem}_recipe.md",
                     recipe_markdown(design, assembly, lib, _held(out), fold_times, fit, check).encode(),
                     "recipe", inputs.every))
    seen = set()
    for p in out:
        if p.name in seen:  # e.g. two materials that differ only in characters made safe
            raise ExportError(f"two export files would be named {p.name!r}; rename a material")
        seen.add(p.name)
    records = {r["material"]: r for r in body_records(assembly, _held(out))}
    return [Rendered(p.name, p.data, p.fmt, [records[m] for m in p.materials if m in records], p.extra)
            for p in out]


def _held(out: list[Piece]) -> dict[str, list[str]]:
    """Material -> the files (of ``out``) that hold its body."""
    held: dict[str, list[str]] = {}
    for p in out:
        if p.fmt not in ("manifest", "recipe"):
            for m in p.materials:
                held.setdefault(m, []).append(p.name)
    return held


@scoped
def export_assembly(design: Design, assembly: Assembly, out_dir: str | Path,
                    formats: Iterable[str] = DEFAULT_FORMATS, library: MaterialLibrary | None = None,
                    frames: Frames | None = None, fold_times: dict | None = None,
                    placed: PlacedState | None = None, voxels: VoxelPart | None = None,
                    printer: Printer | None = None, check: CheckSummary | None = None,
                    force: bool = False) -> list[dict]:
    """Write ``formats`` (see :data:`FORMATS`) of a built assembly into ``out_dir``
    (created if needed; ExportError if it cannot be). Returns one record per file
    written: {path, format, bodies, bytes, ...}; format is one of :data:`FORMATS`,
    "manifest" (with stl) or "h5" (the arrays of xdmf); bodies as :func:`body_records`;
    ``mesh`` (inp) and ``steps``, ``dt_s``, ... (xdmf, glb) describe the file.

    The files land as a whole (:func:`~foldprint.exchange.fileset.write_set`): an
    interrupted export leaves the previous complete set or the new one, never a mix, and
    nothing is created when the export fails. A folder that holds other files is refused
    unless ``force`` (then the set's files are added beside them, each by its own rename)."""
    files = render(design, assembly, formats, library, frames, fold_times, placed, voxels, printer, check)
    paths = write_set(out_dir, [(f.name, f.data) for f in files], force=force)
    return [{"path": str(path), "format": f.fmt, "bodies": f.bodies,
             "bytes": len(f.data) if isinstance(f.data, bytes) else path.stat().st_size, **f.extra}
            for path, f in zip(paths, files)]
