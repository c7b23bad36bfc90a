"""Where the shipped design templates live and what they are."""

from __future__ import annotations

import os
from pathlib import Path

from ..core.errors import DesignError
from ..core.inputs import read_toml, shown


def templates_dir() -> Path:
    """``$FOLDPRINT_TEMPLATES``, else the checkout's top-level ``templates/``."""
    env = os.environ.get("FOLDPRINT_TEMPLATES")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "templates"


def list_templates() -> list[dict]:
    """Name, path and description of every ``templates/*.toml``, sorted by name."""
    out = []
    d = templates_dir()
    if not d.is_dir():
        return out
    for p in sorted(d.glob("*.toml")):
        try:
            data = read_toml(p, "a TOML design (.toml)")
        except DesignError:  # listed without a description; loading it says what is wrong
            data = {}
        desc = data.get("description", "")
        out.append({"name": p.stem, "path": str(p), "description": desc if isinstance(desc, str) else ""})
    return out


def resolve_design_path(name_or_path: str) -> Path:
    """A path as given, or the template of that name."""
    p = Path(name_or_path)
    if p.suffix in (".toml", ".fold", ".svg") or "/" in name_or_path or os.path.lexists(p):
        return p
    cand = templates_dir() / f"{name_or_path}.toml"
    if os.path.lexists(cand):
        return cand
    names = [t["name"] for t in list_templates()]
    raise DesignError(f"{shown(name_or_path)}: no such file, and no template of that name; templates: {', '.join(names)}")
