"""Write a built part: 3MF (two flavours), STL per material + manifest, and the
hand-offs: FOLD crease pattern, Abaqus input (FEM), XDMF time series (ParaView),
animated glTF binary.

This module only writes: the assembly comes built from :mod:`foldprint.apps.pipeline`.

Everything is built in memory first; only then is the set written, as a whole
(:func:`~foldprint.exchange.files.write_set`: staged beside the folder, published by one
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
from pathlib import Path
from typing import Iterable

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
from .files import write_set
from .fold import fold_bytes
from .gltf import glb_bytes
from .recipe import CheckSummary, recipe_markdown
from .slicer_config import bed_layout
from .stl import manifest, stl_bytes
from .threemf import composite3mf_bytes, prusa3mf_bytes, threemf_bytes
from .voxels import VoxelPart, slice_files
from .xdmf import xdmf_files

#: Every format ``export`` writes; ``DEFAULT_FORMATS`` when none is asked for.
FORMATS = ("3mf", "prusa3mf", "stl", "fold", "inp", "xdmf", "glb", "voxels")
DEFAULT_FORMATS = EXPORT_FORMATS
#: Formats that show the fold over time: they need its :class:`~foldprint.geometry.surfaces.Frames`
#: (the surfaces placed along the simulated trajectory).
TRAJECTORY_FORMATS = ("xdmf", "glb")
#: Formats written from a :class:`~foldprint.exchange.voxels.VoxelPart` (the regions with
#: their VeroWhite fraction profiles and hinge axes): the PNG slice stack, its manifest
#: and the 3MF with composite materials.
VOXEL_FORMATS = ("voxels",)


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


def _needs_given(formats, frames, fold_times=None, placed=None, voxels=None) -> None:
    """Refuse a format whose input the caller did not hand over (the writers compute none)."""
    need = [f for f in formats if f in TRAJECTORY_FORMATS]
    if need and frames is None:
        raise ExportError(f"format(s) {need} show the fold over time and need its frames (the surfaces "
                          "placed along the simulated trajectory, geometry.surfaces.fold_frames); export "
                          "through foldprint.apps.pipeline.export, which runs the simulation")
    if "stl" in formats and fold_times is None:
        raise ExportError("format stl writes a manifest with each hinge's fold time and needs them "
                          "(foldprint.physics.recovery.hinge_fold_times); export through "
                          "foldprint.apps.pipeline.export, which computes them")
    if "inp" in formats and placed is None:
        raise ExportError("format inp meshes the strip in its placed state and needs it (fem.PlacedState); "
                          "export through foldprint.apps.pipeline.export, which places it")
    if "voxels" in formats and voxels is None:
        raise ExportError("format 'voxels' rasterises the part with each hinge's VeroWhite fraction and "
                          "needs them; export through foldprint.apps.pipeline.Evaluation.export, which supplies them")


def render(design: Design, assembly: Assembly, formats: Iterable[str] = DEFAULT_FORMATS,
           library: MaterialLibrary | None = None,
           frames: Frames | None = None,
           fold_times: dict | None = None,
           placed: PlacedState | None = None,
           voxels: VoxelPart | None = None,
           printer: Printer | None = None,
           check: CheckSummary | None = None) -> list[tuple[str, bytes, str, list[dict], dict]]:
    """The files of an export in memory: (file name, bytes, format, bodies, extra record
    fields). ``frames`` (the fold's surfaces over time) are needed by :data:`TRAJECTORY_FORMATS`,
    ``fold_times`` (each hinge's, by id) by stl's manifest, ``placed`` (the state's poses)
    by inp, ``voxels`` (the regions with their VeroWhite fractions) by :data:`VOXEL_FORMATS`:
    the writers compute none of them. The voxel slices are callables that make their bytes
    when :func:`~foldprint.exchange.files.write_set` stages them (streamed). ``printer``: the
    profile the export is for (the slicer 3MFs describe it when it is an FDM printer, else a
    generic FDM printer; the recipe says what the design needs of it); ``check``: the
    check's findings for the recipe, when it ran. Every export ends with its recipe
    (``<stem>_recipe.md``, format ``recipe``)."""
    lib = library or default_library()
    formats = check_formats(formats)
    _needs_given(formats, frames, fold_times, placed, voxels)
    st = stem(design, assembly.state)
    every = [b.material for b in assembly.bodies]
    out: list[tuple[str, bytes, str, list[str]]] = []  # (name, data, format, materials held)
    extra: dict[str, dict] = {}
    layout = bed_layout(assembly, fdm_setup(printer))
    if "3mf" in formats:
        out.append((f"{st}.3mf", threemf_bytes(design, assembly, lib, layout), "3mf", every))
    if "prusa3mf" in formats:
        out.append((f"{st}_prusa.3mf", prusa3mf_bytes(design, assembly, lib, layout), "prusa3mf", every))
    if "stl" in formats:
        names = {}
        for b in assembly.bodies:
            name = f"{st}_{safe_name(b.material)}.stl"
            names[b.material] = name
            out.append((name, stl_bytes(b, f"{design.name} {b.material} {assembly.state} mm"), "stl",
                        [b.material]))
        man = "manifest.json" if assembly.state == State.PERMANENT else f"manifest_{assembly.state}.json"
        out.append((man, manifest(design, assembly, names, fold_times, lib).encode("utf-8"), "manifest", every))
    if "fold" in formats:  # the crease pattern: the same for both states
        out.append((f"{safe_name(design.name)}.fold", fold_bytes(design), "fold", every))
    if "inp" in formats:  # FE mesh of the strip's side profile (panels and hinges)
        data, quality = inp_bytes(design, placed)
        extra[f"{st}.inp"] = {"mesh": quality}
        out.append((f"{st}.inp", data, "inp", every))
    if frames is not None and any(f in TRAJECTORY_FORMATS for f in formats):
        dt = float(np.median(np.diff(frames.times))) if len(frames.times) > 1 else 0.0
        span = {"steps": int(len(frames.times)), "dt_s": round(dt, 9), "hinge_model": frames.model}
    if "xdmf" in formats:  # ParaView: the flat surfaces + displacement per time step
        files, more = xdmf_files(design, frames, every, f"{safe_name(design.name)}_fold.xdmf")
        for k, (name, data) in enumerate(files.items()):
            extra[name] = {**span, **more} if k == 0 else {}
            out.append((name, data, "xdmf" if k == 0 else "h5", every))
    if "glb" in formats:  # any 3D viewer: nodes per panel and hinge segment, keyframes
        data, more = glb_bytes(design, frames, lib)
        name = f"{safe_name(design.name)}_fold.glb"
        extra[name] = {**span, **more}
        out.append((name, data, "glb", every))
    if "voxels" in formats:  # PNG slice stack (streamed), its manifest, the composite 3MF
        for name, make in slice_files(voxels, st):
            # a slice's record lists no bodies (the stack's manifest and 3MF do): 700 layers
            # would repeat every body 700 times in --json
            out.append((name, make, "voxels", every) if name.endswith(".json") else (name, make, "png", []))
        out.append((f"{st}_voxels.3mf", composite3mf_bytes(design, assembly, voxels, lib), "3mf-composite", every))
    fit = None if printer is None else tool_fit(printer, [b.material for b in assembly.bodies], lib)
    out.append((f"{st}_recipe.md", recipe_markdown(design, assembly, lib, _held(out), fold_times, fit, check).encode(),
                "recipe", every))
    seen = set()
    for name, *_ in out:
        if name in seen:  # e.g. two materials that differ only in characters made safe
            raise ExportError(f"two export files would be named {name!r}; rename a material")
        seen.add(name)
    records = {r["material"]: r for r in body_records(assembly, _held(out))}
    return [(name, data, fmt, [records[m] for m in mats if m in records], extra.get(name, {}))
            for name, data, fmt, mats in out]


def _held(out) -> dict[str, list[str]]:
    """Material -> the files (of ``out``: name, data, format, materials) that hold its body."""
    held: dict[str, list[str]] = {}
    for name, _, fmt, mats in out:
        if fmt not in ("manifest", "recipe"):
            for m in mats:
                held.setdefault(m, []).append(name)
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

    The files land as a whole (:func:`~foldprint.exchange.files.write_set`): an
    interrupted export leaves the previous complete set or the new one, never a mix, and
    nothing is created when the export fails. A folder that holds other files is refused
    unless ``force`` (then the set's files are added beside them, each by its own rename)."""
    files = render(design, assembly, formats, library, frames, fold_times, placed, voxels, printer, check)
    paths = write_set(out_dir, [(name, data) for name, data, *_ in files], force=force)
    return [{"path": str(path), "format": fmt, "bodies": bodies,
             "bytes": len(data) if isinstance(data, bytes) else path.stat().st_size, **more}
            for path, (name, data, fmt, bodies, more) in zip(paths, files)]
