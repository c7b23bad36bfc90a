"""Read a design file of any supported kind: the one entry point of the input layer.

``.toml`` (foldprint's own format, :mod:`foldprint.design_io`) and ``.fold`` (FOLD 1.1/1.2,
:mod:`foldprint.fold_format`).
"""

from __future__ import annotations

import tomllib
from pathlib import Path

from .design import Design
from .design_io import design_from_dict, read_text
from .errors import DesignError
from .fold_format import design_from_fold_file
from .materials import MaterialLibrary


def load_design(path: str | Path, library: MaterialLibrary | None = None, **kw) -> Design:
    """Read a design file: ``.toml`` (foldprint) or ``.fold`` (FOLD 1.1/1.2). Keyword
    arguments go to the format's reader (e.g. ``scale`` for FOLD)."""
    path = Path(path)
    if path.suffix.lower() == ".fold":
        return design_from_fold_file(path, library=library, **kw)
    text = read_text(path, "a TOML design (.toml)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DesignError(f"{path}: not valid TOML: {exc}") from None
    return design_from_dict(data, str(path), library)
