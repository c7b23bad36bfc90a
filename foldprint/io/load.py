"""Read a design file of any supported kind: the one entry point of the input layer.

``.toml`` (foldprint's own format, :mod:`foldprint.io.design_io`), ``.fold`` (FOLD 1.1/1.2,
:mod:`foldprint.io.fold_format`) and ``.svg`` (crease patterns in Origami Simulator's
convention, :mod:`foldprint.io.svg_format`).
"""

from __future__ import annotations

from pathlib import Path

from ..model.design import Design
from .design_io import design_from_dict
from ..core.errors import DesignError
from ..core.inputs import read_toml
from .fold_format import design_from_fold_file
from ..model.materials import MaterialLibrary

#: assignment letters a crease-material rule may name
RULE_KEYS = ("M", "V", "F", "U")


def parse_crease_materials(rule: str | None) -> dict[str, str] | None:
    """``"M=H-2,V=H-5"`` -> {"M": "H-2", "V": "H-5"}: hinge materials by crease assignment
    (M mountain, V valley, F/U flat or unassigned creases that carry a fold angle)."""
    if rule is None or not rule.strip():
        return None
    out = {}
    for part in rule.split(","):
        key, sep, mat = part.partition("=")
        key, mat = key.strip().upper(), mat.strip()
        if not sep or key not in RULE_KEYS or not mat:
            raise DesignError(f"--crease-materials: {part.strip()!r} is not ASSIGNMENT=MATERIAL; write e.g. "
                              f"\"M=H-2,V=H-5\" with assignments from {', '.join(RULE_KEYS)}")
        out[key] = mat
    return out


def load_design(path: str | Path, library: MaterialLibrary | None = None, *,
                scale: float | None = None, crease_materials: str | dict | None = None, **kw) -> Design:
    """Read a design file: ``.toml`` (foldprint), ``.fold`` (FOLD 1.1/1.2) or ``.svg``
    (Origami Simulator crease pattern). ``scale`` is mm per file unit (FOLD "unit", SVG
    user units); ``crease_materials`` a rule such as ``"M=H-2,V=H-5"`` (or its dict)
    giving hinge materials by crease assignment. Other keyword arguments go to the
    format's reader."""
    path = Path(path)
    rule = parse_crease_materials(crease_materials) if isinstance(crease_materials, str) else crease_materials
    suffix = path.suffix.lower()
    if suffix == ".fold":
        return design_from_fold_file(path, library=library, scale=scale, crease_materials=rule, **kw)
    if suffix == ".svg":
        from .svg_format import design_from_svg_file

        return design_from_svg_file(path, library=library, scale=scale, crease_materials=rule, **kw)
    if scale is not None or rule:
        raise DesignError(f"{path}: --scale and --crease-materials apply to FOLD and SVG crease patterns; "
                          "a TOML design gives lengths in mm and a material per hinge")
    return design_from_dict(read_toml(path, "a TOML design (.toml)"), str(path), library)
