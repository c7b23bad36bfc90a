"""One small error hierarchy. The CLI maps ``FoldprintError`` to exit code 2."""

from __future__ import annotations


class FoldprintError(Exception):
    """Base for every error foldprint raises on purpose (bad input, not a bug)."""


class DesignError(FoldprintError, ValueError):
    """A design (TOML, FOLD, API) is invalid. The message names the file, key or item."""


class MaterialError(FoldprintError, ValueError):
    """A material library entry is missing or invalid."""


class GeometryError(FoldprintError, RuntimeError):
    """A solid could not be built (degenerate input, failed boolean)."""


class DataError(FoldprintError, ValueError):
    """A measurement file (``foldprint calibrate``'s CSV) is invalid. The message names the
    file, the line and the column."""


class ExportError(FoldprintError, OSError):
    """A file could not be written."""


def where(source: str | None, key: str | None = None) -> str:
    """Format the location prefix of an error message: ``file: key: ``."""
    parts = [p for p in (source, key) if p]
    return ": ".join(parts) + ": " if parts else ""
