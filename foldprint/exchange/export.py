"""Write a built part: 3MF (two flavours), STL per material + manifest.

This module only writes: the assembly comes built from :mod:`foldprint.pipeline`.

Everything is built in memory first; only then is the set written, as a whole
(:func:`~foldprint.exchange.files.write_set`: staging directory, commit journal, renames),
so a failed or killed export leaves the previous complete set or the new one.

File names (``stem`` = the design name, ``<name>_programmed`` for the flat state):
``<stem>.3mf`` (spec form + Bambu/Orca/Cura metadata), ``<stem>_prusa.3mf`` (PrusaSlicer),
``<stem>_<material>.stl`` and ``manifest.json`` (``manifest_programmed.json``).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Iterable

from ..design import Design
from ..errors import ExportError
from ..geometry import Assembly
from ..materials import MaterialLibrary, default_library
from .files import write_set
from .stl import manifest, stl_bytes
from .threemf import prusa3mf_bytes, threemf_bytes

FORMATS = ("3mf", "prusa3mf", "stl")


def safe_name(text: str) -> str:
    """A file-name-safe version of a design or material name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("._") or "part"


def stem(design: Design, state: str) -> str:
    base = safe_name(design.name)
    return base if state == "permanent" else f"{base}_{state}"


def check_formats(formats: Iterable[str]) -> list[str]:
    """The requested formats, de-duplicated; ExportError names unknown ones."""
    if isinstance(formats, str):
        formats = [formats]
    formats = list(dict.fromkeys(formats))
    unknown = [f for f in formats if f not in FORMATS]
    if unknown or not formats:
        raise ExportError(f"unknown export format(s) {unknown or 'none given'}; choose from {list(FORMATS)}")
    return formats


def _bodies(bodies) -> list[dict]:
    return [{"material": b.material, "volume_mm3": round(b.volume, 6)} for b in bodies]


def render(design: Design, assembly: Assembly, formats: Iterable[str] = FORMATS,
           library: MaterialLibrary | None = None) -> list[tuple[str, bytes, str, list[dict]]]:
    """The files of an export in memory: (file name, bytes, format, bodies)."""
    lib = library or default_library()
    formats = check_formats(formats)
    st = stem(design, assembly.state)
    out = []
    if "3mf" in formats:
        out.append((f"{st}.3mf", threemf_bytes(design, assembly, lib), "3mf", _bodies(assembly.bodies)))
    if "prusa3mf" in formats:
        out.append((f"{st}_prusa.3mf", prusa3mf_bytes(design, assembly, lib), "prusa3mf",
                    _bodies(assembly.bodies)))
    if "stl" in formats:
        names = {}
        for b in assembly.bodies:
            name = f"{st}_{safe_name(b.material)}.stl"
            names[b.material] = name
            out.append((name, stl_bytes(b, f"{design.name} {b.material} {assembly.state} mm"), "stl",
                        _bodies([b])))
        man = "manifest.json" if assembly.state == "permanent" else f"manifest_{assembly.state}.json"
        out.append((man, manifest(design, assembly, names, lib).encode("utf-8"), "manifest",
                    _bodies(assembly.bodies)))
    seen = set()
    for name, *_ in out:
        if name in seen:  # e.g. two materials that differ only in characters made safe
            raise ExportError(f"two export files would be named {name!r}; rename a material")
        seen.add(name)
    return out


def export_assembly(design: Design, assembly: Assembly, out_dir: str | Path,
                    formats: Iterable[str] = FORMATS, library: MaterialLibrary | None = None) -> list[dict]:
    """Write ``formats`` ("3mf", "prusa3mf", "stl") of a built assembly into ``out_dir``
    (created if needed; ExportError if it cannot be). Returns one record per file
    written: {path, format, bodies: [{material, volume_mm3}], bytes}; format is "3mf",
    "prusa3mf", "stl" or "manifest".

    The files land as a whole (:func:`~foldprint.exchange.files.write_set`): an
    interrupted export leaves the previous complete set or the new one, never a mix, and
    nothing is created when the export fails."""
    files = render(design, assembly, formats, library)
    paths = write_set(out_dir, [(name, data) for name, data, _, _ in files])
    return [{"path": str(path), "format": fmt, "bodies": bodies, "bytes": len(data)}
            for path, (name, data, fmt, bodies) in zip(paths, files)]
