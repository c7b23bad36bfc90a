"""Binary STL, one file per material in one shared frame (mm), and ``manifest.json``.

This is the PolyJet practice (GrabCAD Print and the Objet Connex it drives): each
material shell is its own STL, all in the same coordinates, assigned a material on
import. The manifest records what each file is and how to program and recover the part.
"""

from __future__ import annotations

import json
import math
from typing import Mapping

import numpy as np

from ..core.constants import JSON_DECIMALS
from ..core.version import __version__
from ..model.design import Design
from ..geometry import Assembly, Body
from ..model.materials import MaterialLibrary, default_library

_RECORD = np.dtype([("normal", "<f4", (3,)), ("vertices", "<f4", (3, 3)), ("attr", "<u2")])


def stl_bytes(body: Body, header: str = "") -> bytes:
    """A binary STL of one body (80-byte header, never starting with 'solid')."""
    tri = body.vertices[body.faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    rec = np.zeros(len(tri), dtype=_RECORD)
    rec["normal"] = normal
    rec["vertices"] = tri
    head = f"foldprint {__version__} {header}".encode("ascii", "replace")[:80].ljust(80, b" ")
    return head + np.uint32(len(tri)).tobytes() + rec.tobytes()


def read_stl_volume(data: bytes) -> float:
    """Volume (mm^3) of a binary STL, by the divergence theorem (for tests and checks)."""
    n = int(np.frombuffer(data, dtype="<u4", count=1, offset=80)[0])
    rec = np.frombuffer(data, dtype=_RECORD, count=n, offset=84)
    v = rec["vertices"].astype(np.float64)
    return float(np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0)


def _finite_or_none(x):
    return None if x is None or not math.isfinite(x) else round(float(x), JSON_DECIMALS)


def programming(design: Design, fold_times: Mapping[str, float | None]) -> dict:
    """The programming and recovery protocol, with the expected fold time: the slowest
    hinge's 98 % recovery time (s), or None when a hinge does not fold in the bath.
    ``fold_times``: each hinge's 98 % time by id
    (:func:`foldprint.physics.recovery.curve.hinge_fold_times`, passed by the pipeline)."""
    pr = design.process
    per_hinge = {}
    for h in design.hinges:
        per_hinge[h.id] = _finite_or_none(fold_times[h.id])
    times = list(per_hinge.values())
    expected = None if (not times or any(t is None for t in times)) else max(times)
    return {
        "program_temperature_c": float(pr.program_temperature_c),
        "fix_temperature_c": float(pr.fix_temperature_c),
        "bath_temperature_c": float(pr.bath_temperature_c),
        "duration_s": float(pr.duration_s),
        "expected_fold_time_s": expected,
        "hinge_fold_times_s": per_hinge,
        "steps": [
            f"heat the printed (permanent, folded) part to {pr.program_temperature_c:g} C and press it flat",
            f"cool it to {pr.fix_temperature_c:g} C while held flat, then release",
            f"drop it into a {pr.bath_temperature_c:g} C bath to recover the folded shape",
        ],
    }


def _bbox(lo, hi) -> dict:
    return {"min": [round(float(x), 6) for x in lo], "max": [round(float(x), 6) for x in hi]}


def manifest(design: Design, assembly: Assembly, files: dict[str, str], fold_times: Mapping[str, float | None],
             library: MaterialLibrary | None = None) -> str:
    """``manifest.json`` text: bodies (file, material, volume), materials, bounding box,
    programming protocol with the hinges' ``fold_times`` (s, by hinge id). ``files`` maps
    material -> STL file name."""
    lib = library or default_library()
    bodies, materials = [], []
    for k, b in enumerate(assembly.bodies):
        m = lib[b.material] if b.material in lib else None
        lo, hi = assembly.print_z_range(b)
        bodies.append({"material": b.material, "file": files.get(b.material), "extruder": k + 1,
                       "role": m.role if m else None, "volume_mm3": round(b.volume, 6),
                       "triangles": int(len(b.faces)), "vertices": int(len(b.vertices)),
                       "bounding_box": _bbox(*b.bounds), "z_range_print_mm": [round(lo, 6), round(hi, 6)]})
        materials.append({"name": b.material, "role": m.role if m else None,
                          "tg_c": m.tg_c if m else None, "color": m.color if m else None,
                          "description": m.description if m else ""})
    lo, hi = assembly.bounds
    doc = {
        "foldprint_version": __version__,
        "design": design.name,
        "description": design.description,
        "state": assembly.state,
        "units": "mm",
        "frame": ("the design's sheet frame: the root panel lies flat with its mid-plane at z = 0; "
                  "all STL files share it; add print_offset_mm to put the part on the bed"),
        "print_offset_mm": [round(float(x), 6) for x in assembly.print_offset],
        "bodies": bodies,
        "materials": materials,
        "total_volume_mm3": round(assembly.volume, 6),
        "bounding_box": _bbox(lo, hi),
        "programming": programming(design, fold_times),
    }
    return json.dumps(doc, indent=2, sort_keys=False) + "\n"
