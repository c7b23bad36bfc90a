"""What the studio writes, and where: a design saved as TOML into the studio's folder, the
print files exported into its output folder, and the 3D player's page and assets (the
gallery's offline three.js viewer).

**Save** takes a file *name*, never a path: a name ending in ``.toml``, without a folder
part, ``..``, a leading dot or a control character, inside the studio's folder (``--out``,
else the design file's folder, else the current folder for a template). An existing file
is replaced only with ``overwrite`` (the page asks first), never through a symbolic link,
and never half-written: the text goes to a temp file beside it, flushed, then renamed
into place (a new file by a rename that refuses to replace one, so two saves cannot both
create it). **Export** is ``foldprint export``'s: :meth:`~foldprint.apps.pipeline.Evaluation.export`
into the output folder under :func:`foldprint.exchange.outfolder.plan`'s rules (a folder
that is not foldprint's is refused).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from ..core.errors import FoldprintError
from ..core.files import fsync_dir, write_atomic
from ..io.design_io import design_to_toml
from ..model.design import Design
from ..render import viewer

#: a saved design's name: letters, digits, ``._-`` and spaces, ending in .toml (our choice)
SAVE_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_. -]{0,120}\.toml$")


class SaveExists(FoldprintError):
    """The file exists and the save did not say ``overwrite``."""


def save_path(folder: Path, name: str) -> Path:
    """The file ``name`` inside ``folder``, or FoldprintError saying why it may not be."""
    if not isinstance(name, str) or not SAVE_NAME.match(name) or ".." in name or name.strip() != name:
        raise FoldprintError(f"save: {name!r} is not a file name the studio writes: give a name like "
                             "'my_part.toml' (letters, digits, '._-', ending in .toml; no folder, no '..')")
    real = Path(os.path.realpath(folder))
    path = real / name
    if os.path.islink(path):
        raise FoldprintError(f"save: {path} is a symbolic link; the studio does not write through links")
    if Path(os.path.realpath(path)).parent != real:
        raise FoldprintError(f"save: {name!r} is outside the studio's folder {real}")
    return path


def save_design(design: Design, folder: Path, name: str, overwrite: bool = False) -> Path:
    """Write ``design`` as TOML to ``folder/name`` (see the module docstring): the path."""
    path = save_path(folder, name)
    text = design_to_toml(design).encode("utf-8")
    if os.path.lexists(path):
        if not overwrite:
            raise SaveExists(f"save: {path} exists; confirm to overwrite it, or give another name")
        if not path.is_file():
            raise FoldprintError(f"save: {path} is not a regular file")
        return write_atomic(path, text)
    try:
        write_atomic(path, text, replace=False)
    except FileExistsError:
        raise SaveExists(f"save: {path} was created meanwhile; confirm to overwrite it") from None
    fsync_dir(path.parent)
    return path


def export_files(evaluation, out: Path, printer) -> dict:
    """``foldprint export`` of the evaluation's design into ``out``: what it wrote."""
    records = evaluation.export(out, printer=printer)
    return {"out": str(Path(os.path.realpath(out))), "files": [{"path": r["path"], "format": r["format"]}
                                                              for r in records]}


def viewer_html(evaluation, revision: int, replay=None) -> str:
    """The 3D player of the evaluation's nominal fold (the gallery's viewer page), with the
    replayed worst scatter sample when given; its scripts load from ``/viewer/``."""
    ok = evaluation.simulation.completed
    data = viewer.viewer_data(evaluation.simulation, evaluation.library, worst=replay)
    status = ("nominal fold completes" if ok else "nominal fold collides") + f" (revision {revision})"
    page = viewer.viewer_page(data, status, ok, "/", "studio")
    # inside the studio's frame: no page header, no favicon request
    return page.replace("</head>", '<link rel="icon" href="data:,"><style>header{display:none}</style></head>', 1)


def viewer_asset(name: str) -> bytes | None:
    """One of the viewer's files by name (None for any other name)."""
    return viewer.asset_bytes(name) if name in viewer.ASSETS else None


def viewer_asset_names() -> tuple[str, ...]:
    return tuple(viewer.ASSETS)
