"""What the studio is started with, resolved from the command line's words: the design (a
file or a template name), the material library (with ``--materials`` files), the printer
profiles, and the folders it may write into.

These go through the door every front end uses (:mod:`foldprint.apps.resolve`: the design
by path or template name, the library with ``--materials`` files), the same calls the
command line makes for ``check`` and ``export``, so a bad input gives the studio the command
line's one-line error before a server starts.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from ..core.errors import FoldprintError
from . import resolve
from ..io.templates import templates_dir
from ..model.design import Design
from ..model.materials import MaterialLibrary
from ..model.printers import Printer, default_printer_key, load_printers


@dataclass(frozen=True)
class StudioInputs:
    """The design the studio opens, its library and printers, and where it writes:
    ``folder`` (saved designs: ``--out``, else the design file's folder, else for a
    template the current folder) and ``out`` (exports: ``--out``, else ``output/<name>``)."""

    design: Design
    library: MaterialLibrary
    printers: dict[str, Printer]
    printer_key: str
    folder: Path
    out: Path
    source: Path


def resolve_inputs(design: str, materials: Sequence[str | Path] | None = None, out: str | Path | None = None,
                   printers_file: str | Path | None = None) -> StudioInputs:
    """The studio's inputs (FoldprintError with the command line's message when one is bad)."""
    path = resolve.design_path(design)
    d, lib = resolve.load_input(path, list(materials) if materials else None)
    printers = load_printers(printers_file)
    is_template = path.resolve().parent == templates_dir().resolve()
    if out is not None:
        folder = Path(out)
        if folder.exists() and not folder.is_dir():
            raise FoldprintError(f"--out {out}: not a folder")
    else:
        folder = Path(os.getcwd()) if is_template else path.resolve().parent
    export_out = Path(out) / d.name if out is not None else Path("output") / d.name
    return StudioInputs(d, lib, printers, default_printer_key(), folder.resolve(), export_out, path)
