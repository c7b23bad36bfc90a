"""A materials TOML file (the layout of ``foldprint/data/materials.toml`` and of every
``--materials FILE``), written from fitted materials: what ``foldprint calibrate --out``
writes. The writer is handed the materials and the provenance lines; it computes nothing.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Sequence

from ..model.materials import Material, RecoveryParams
from .fileset import write_atomic

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


@dataclass(frozen=True)
class Entry:
    """One material of the file: ``material`` as it should load; ``tg_note``, ``notes``:
    comment lines (where its Tg and parameters come from); ``new``: not in the library the
    file extends, so role, colour and description are written too; ``write_tg``: Tg written
    (measured or new)."""

    material: Material
    new: bool
    write_tg: bool
    notes: tuple[str, ...] = ()


def _key(name: str) -> str:
    return name if _BARE.match(name) else json.dumps(name, ensure_ascii=False)


def _str(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)


def _num(v: float | int) -> str:
    """An int as is; a float to 7 significant digits (a fit's last digits are noise), always
    with a decimal point or exponent so it reads back as a float."""
    if isinstance(v, int) and not isinstance(v, bool):
        return str(v)
    text = f"{float(v):.7g}"
    return text if any(c in text for c in ".en") else text + ".0"


def _comment(lines: Sequence[str]) -> str:
    return "".join(f"# {ln}".rstrip() + "\n" for text in lines for ln in str(text).splitlines() or [""])


def materials_toml(entries: Sequence[Entry], header: Sequence[str]) -> str:
    """The file's text: ``header`` as comments, then each material's table and its
    ``recovery`` table (every recovery parameter, so the file does not depend on the
    defaults of the library it extends)."""
    out = [_comment(header), "\n"]
    for e in entries:
        m = e.material
        out.append(_comment(e.notes))
        out.append(f"[materials.{_key(m.name)}]\n")
        if e.new:
            out.append(f"role = {_str(m.role)}\ncolor = {_str(m.color)}\ndescription = {_str(m.description)}\n")
            if not m.blend:
                out.append("blend = false\n")
        if e.write_tg or e.new:
            out.append(f"tg_c = {_num(m.tg_c)}\n")
        for key in ("glassy_mpa", "rubbery_mpa"):
            if getattr(m, key) is not None:
                out.append(f"{key} = {_num(getattr(m, key))}\n")
        if m.fixity is not None:
            out.append(f"fixity = {_num(m.fixity)}\nfixity_source = {_str(m.fixity_source)}\n")
        if m.recovery is not None:
            out.append(f"\n[materials.{_key(m.name)}.recovery]\n")
            rec: RecoveryParams = m.recovery
            for f in fields(rec):
                out.append(f"{f.name} = {_num(getattr(rec, f.name))}\n")
        out.append("\n")
    return "".join(out)


def write_materials(path: str | Path, entries: Sequence[Entry], header: Sequence[str]) -> Path:
    """Write :func:`materials_toml` to ``path`` atomically (no half-written file)."""
    return write_atomic(path, materials_toml(entries, header))
