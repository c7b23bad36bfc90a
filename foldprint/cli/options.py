"""The command line's own options: help texts shared by commands, several values after
one flag (``--temperature 80 90``), output paths checked before anything is made, and
``--scheduler`` opened as a mapper. The inputs themselves are resolved by
:mod:`foldprint.apps.resolve` (the door every front end comes in through).
"""

from __future__ import annotations

from pathlib import Path

from ..core.constants import PLOT_FORMATS
from ..core.errors import FoldprintError

#: Options that take several values after one flag (``--temperature 80 90 100``).
_MULTI = {"--temperature"}


SCALE_HELP = "FOLD/SVG crease patterns: mm per file unit (needed when frame_unit is 'unit' or missing)."
CREASE_HELP = "FOLD/SVG crease patterns: hinge materials by assignment, e.g. 'M=H-2,V=H-5'."


#: An output path may be at most this long (bytes of its absolute form; the system's
#: PATH_MAX is 4096 and the files written inside need room) and this many levels deep
#: (the folders are created one level at a time).
MAX_OUT_PATH_BYTES = 3800
MAX_OUT_LEVELS = 128


def _check_out_path(value: str, option: str) -> None:
    """Refuse an output path the file system cannot hold, before anything is made."""
    import os

    from ..core.inputs import shown

    full = os.fsencode(os.path.abspath(value))
    parts = [c for c in full.split(b"/") if c]
    if len(full) > MAX_OUT_PATH_BYTES or any(len(c) > 255 for c in parts) or len(parts) > MAX_OUT_LEVELS:
        raise FoldprintError(f"{option} {shown(value)!r} is too long or too deep ({len(full)} bytes, {len(parts)} "
                             f"levels; at most {MAX_OUT_PATH_BYTES} bytes, {MAX_OUT_LEVELS} levels and 255 bytes a "
                             f"name); give a shorter path, e.g. {option} output/mine")


def check_out_file(value: Path | None, option: str = "--plot", formats=PLOT_FORMATS) -> Path | None:
    """An output file option: a path of a size the file system holds, ending in one of
    ``formats``."""
    if value is None:
        return None
    _check_out_path(str(value), option)
    fmt = value.suffix.lstrip(".").lower()
    if fmt not in formats:
        raise FoldprintError(f"{option} {str(value)[:80]!r}: the file name must end in "
                             f"{', '.join('.' + f for f in formats)} (the chart's format), got {fmt or 'no suffix'!r}")
    return value


def check_out_dir(value: str | None, option: str = "--out"):
    """An output directory option: refuses "" (it would mean the current folder without
    saying so), the file-system root and a path too long or deep to create."""
    import os

    if value is None:
        return None
    if not value.strip():
        raise FoldprintError(f"{option} is empty; give a directory, e.g. {option} output/mine "
                             f"(or {option} . for the current folder)")
    _check_out_path(value, option)
    p = Path(value)
    try:
        real = p.resolve()
    except (OSError, RuntimeError):  # a loop of symbolic links
        raise FoldprintError(f"{option} {value!r} cannot be resolved (a loop of symbolic links); give a directory, "
                             f"e.g. {option} output/mine") from None
    if os.path.abspath(p) == os.path.abspath(os.sep) or real == Path(real.anchor):
        raise FoldprintError(f"{option} {value!r} is the root of the file system; give a directory of its own, "
                             f"e.g. {option} output/mine")
    return p


def open_mapper(scheduler: str | None):
    """A context giving the mapper of ``--scheduler`` (a Dask cluster), or None (local cores)."""
    import contextlib

    if scheduler is None:
        return contextlib.nullcontext(None)
    from ..apps.distributed import cluster_mapper

    return cluster_mapper(scheduler)


def expand_multi(argv: list[str]) -> list[str]:
    """``--temperature 80 90`` -> ``--temperature 80 --temperature 90``."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        out.append(tok)
        i += 1
        if tok in _MULTI:
            first = True
            while i < len(argv) and (first or not argv[i].startswith("-") or _is_number(argv[i])):
                if not first:
                    out.append(tok)
                out.append(argv[i])
                first = False
                i += 1
    return out


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
