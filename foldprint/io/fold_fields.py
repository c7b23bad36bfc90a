"""A FOLD file's fields read and checked for :mod:`foldprint.io.fold_format`: the
crease-pattern frame (of ``file_frames`` too), the vertex coordinates in mm, the vertex
index lists of faces and edges, the per-item lists and the unit. Each refusal is a
:class:`~foldprint.core.errors.DesignError` naming the field and the fix.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..core.errors import DesignError
from ..core.schema import MAX_FACES, MAX_LENGTH_MM

UNITS = {"mm": 1.0, "cm": 10.0, "m": 1000.0, "in": 25.4, "pt": 25.4 / 72.0,
         "um": 1e-3, "nm": 1e-6}


def is_number(v) -> bool:
    """A finite int or float (an int too large for a float is not one: no OverflowError)."""
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return abs(v) < 1e300 if isinstance(v, int) else math.isfinite(v)


def _classes(frame: Mapping) -> set[str]:
    c = frame.get("frame_classes")
    return {str(x) for x in c} if isinstance(c, list) else set()


def crease_frame(data: Mapping, src: str) -> Mapping:
    """The crease-pattern frame: the top level, or the first of ``file_frames`` classed
    ``creasePattern`` (or, without classes, the first with coordinates), merged over the
    top level (``frame_inherit``). A file holding only folded states is refused."""
    frames = data.get("file_frames")
    top_cp = "vertices_coords" in data and "foldedForm" not in _classes(data)
    if frames is None or top_cp and "creasePattern" in _classes(data):
        chosen = data
    else:
        if not isinstance(frames, list) or not all(isinstance(f, Mapping) for f in frames):
            raise DesignError(f"{src}file_frames must be a list of frame objects")
        cands = [f for f in frames if "creasePattern" in _classes(f)]
        if not cands and top_cp:
            chosen = data
        else:
            cands = cands or [f for f in frames if "foldedForm" not in _classes(f)
                              and ("vertices_coords" in f or "vertices_coords" not in data)]
            if not cands:
                if "vertices_coords" in data or not frames:
                    chosen = data
                else:
                    chosen = None
            else:
                merged = {k: v for k, v in data.items() if k != "file_frames"}
                merged.update(cands[0])
                chosen = merged
    if chosen is None or "foldedForm" in _classes(chosen) and "creasePattern" not in _classes(chosen):
        raise DesignError(f"{src}this FOLD file holds only a folded state (frame_classes: foldedForm); "
                          "foldprint needs the flat crease pattern: export the crease pattern "
                          "(frame_classes: creasePattern) instead")
    return chosen


def vertex_coords(frame: Mapping, factor: float, src: str) -> np.ndarray:
    raw = frame.get("vertices_coords")
    if raw is None:
        raise DesignError(f"{src}vertices_coords is missing; a FOLD crease pattern needs vertex coordinates")
    if not isinstance(raw, list):
        raise DesignError(f"{src}vertices_coords must be a list of [x, y] points")
    if len(raw) > 4 * MAX_FACES:
        raise DesignError(f"{src}vertices_coords has {len(raw)} points; at most {4 * MAX_FACES} are accepted")
    xyz = np.zeros((len(raw), 3))
    for i, v in enumerate(raw):
        if not isinstance(v, list) or len(v) not in (2, 3) or not all(is_number(c) for c in v):
            raise DesignError(f"{src}vertices_coords[{i}] must be [x, y] or [x, y, z] finite numbers, got {v!r}")
        xyz[i, :len(v)] = v
    with np.errstate(over="ignore", invalid="ignore"):
        big = np.abs(xyz * factor).max(axis=1) if len(xyz) else np.zeros(0)
    if len(big) and not np.all(big <= MAX_LENGTH_MM):  # also inf/nan: 1e306 m overflows
        i = int(np.argmax(~(big <= MAX_LENGTH_MM)))
        raise DesignError(f"{src}vertices_coords[{i}] is {_short(raw[i])}, {big[i]:.3g} mm from the origin at "
                          f"{factor:g} mm per unit, beyond the {MAX_LENGTH_MM:g} mm foldprint accepts; check "
                          "frame_unit or --scale")
    flat = np.abs(xyz) <= 1e-9 * max(1.0, float(np.abs(xyz).max(initial=0.0)))
    if flat[:, 2].all():
        return xyz[:, :2] * factor
    if flat[:, 1].all():  # Origami Simulator writes its flat sheet in the xz plane (y up)
        return xyz[:, [0, 2]] * factor
    i = int(np.nonzero(~flat[:, 2])[0][0])
    raise DesignError(f"{src}vertices_coords is not flat: vertex {i} has z = {xyz[i, 2]:g}; foldprint "
                      "imports crease patterns (the flat sheet), not folded states")


def index_lists(frame: Mapping, key: str, nv: int, src: str, size: int | None) -> list[list[int]]:
    raw = frame.get(key)
    if not isinstance(raw, list):
        raise DesignError(f"{src}{key} must be a list of vertex index lists, got {type(raw).__name__}")
    if len(raw) > MAX_FACES:
        raise DesignError(f"{src}{key} has {len(raw)} entries; at most {MAX_FACES} are accepted "
                          "(a printable part has far fewer faces and edges)")
    out = []
    for i, item in enumerate(raw):
        if not isinstance(item, list) or (len(item) != size if size else not 3 <= len(item) <= MAX_RING):
            raise DesignError(f"{src}{key}[{i}] must be a list of {size or f'3 to {MAX_RING}'} vertex indices, "
                              f"got {_short(item)}")
        for v in item:  # FOLD indices are integers: 2.0 is a float, true is a boolean
            if isinstance(v, bool) or not isinstance(v, int):
                raise DesignError(f"{src}{key}[{i}] holds {_short(v)}, not a vertex index; indices are whole "
                                  "numbers written without a decimal point (2, not 2.0)")
            if not 0 <= v < nv:
                raise DesignError(f"{src}{key}[{i}] refers to vertex {_short(v)} but there are {nv} vertices "
                                  f"(indices 0 to {nv - 1})")
        if len(set(item)) != len(item):
            raise DesignError(f"{src}{key}[{i}] repeats a vertex: {item}")
        out.append(item)
    return out


MAX_RING = 10_000  # vertices of one face (as schema.MAX_POINTS for a TOML outline)


def _short(v) -> str:
    """A bad value for a message, never thousands of digits long."""
    if isinstance(v, int) and not isinstance(v, bool) and abs(v) >= 10 ** 30:
        return f"an integer of {len(str(abs(v)))} digits"
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


def per_item(frame: Mapping, key: str, n: int, of: str, src: str) -> list:
    raw = frame.get(key)
    if raw is None:
        return [None] * n
    if not isinstance(raw, list) or len(raw) != n:
        got = f"{len(raw)} entries" if isinstance(raw, list) else f"a {type(raw).__name__}"
        raise DesignError(f"{src}{key} has {got} but {of} has {n}; give one entry per item")
    return list(raw)


def unit_factor(frame: Mapping, scale, src: str) -> float:
    """mm per file unit: ``scale`` if given, else the known ``frame_unit``."""
    unit = str(frame.get("frame_unit", "unit")).lower()
    if scale is not None:
        if not is_number(scale) or scale <= 0:
            raise DesignError(f"{src}scale must be a number > 0 (mm per file unit), got {scale!r}")
        return float(scale)
    if unit in UNITS:
        return UNITS[unit]
    if unit == "unit":
        said = "frame_unit is \"unit\"" if "frame_unit" in frame else "frame_unit is missing"
        raise DesignError(f"{src}{said}, so the crease pattern has no physical size; give one with "
                          "--scale MM_PER_UNIT (e.g. --scale 100 makes a 1-unit square 100 mm wide) "
                          "or set frame_unit to mm, cm, m or in")
    raise DesignError(f"{src}frame_unit {unit!r} is unknown; known: {sorted(UNITS)} "
                      "(or give --scale MM_PER_UNIT)")
