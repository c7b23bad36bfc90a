"""Atomic file writes: a temp file in the target directory, then ``os.replace``."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from ..errors import ExportError


def ensure_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents); ExportError with the reason if impossible."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"{p}: cannot create output directory: {exc.strerror or exc}") from None
    if not os.access(p, os.W_OK):
        raise ExportError(f"{p}: output directory is not writable; choose another with --out")
    return p


def write_atomic(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` so that no half-written file is ever left behind."""
    p = Path(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    ensure_dir(p.parent)
    fd, tmp = None, None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
        with os.fdopen(fd, "wb") as fh:
            fd = None
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, p)
        tmp = None
    except OSError as exc:
        raise ExportError(f"{p}: cannot write: {exc.strerror or exc}") from None
    finally:
        if fd is not None:
            os.close(fd)
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return p
