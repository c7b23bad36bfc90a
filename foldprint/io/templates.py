"""Where the shipped design templates live and what they are."""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from ..core.errors import DesignError


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
            data = tomllib.loads(p.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            data = {}
        out.append({"name": p.stem, "path": str(p), "description": data.get("description", "")})
    return out


def resolve_design_path(name_or_path: str) -> Path:
    """A path as given, or the template of that name."""
    p = Path(name_or_path)
    if p.exists() or p.suffix in (".toml", ".fold") or "/" in name_or_path:
        return p
    cand = templates_dir() / f"{name_or_path}.toml"
    if cand.exists():
        return cand
    names = [t["name"] for t in list_templates()]
    raise DesignError(f"{name_or_path}: no such file, and no template of that name; templates: {', '.join(names)}")
