"""Where the printed part sits on the print bed: each panel's and hinge's lowest point and
the area of its bottom faces that rest neither on the bed nor on the part (the slicer must
support or bridge them). A report on a built :class:`~foldprint.geometry.solids.Assembly`
(what the writers may read), apart from the builder (:mod:`.assembly`).
"""

from __future__ import annotations

import manifold3d as mf
import numpy as np

from ..core.errors import GeometryError
from .solids import BED_TOL, BOTTOM_FACE_RAD, Assembly

#: Depth (mm) of the probe under a bottom face: a face with part material within this
#: distance below it rests on that material.
SUPPORT_PROBE_MM = 0.01
#: Bottom faces smaller than this (mm^2) in total are left to the slicer's bridging.
SUPPORT_AREA_MIN = 0.5

def _prisms(tri: np.ndarray, depth: float) -> mf.Manifold:
    """Thin prisms (``depth`` mm) hanging under triangles (n, 3, 3), as one solid."""
    n = len(tri)
    v = np.concatenate([tri, tri - np.array([0.0, 0.0, depth])], axis=1).reshape(-1, 3)
    base = (np.arange(n) * 6)[:, None]
    local = np.array([[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]])
    f = (base[:, None, :] + local[None]).reshape(-1, 3)
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    if np.einsum("ij,ij->i", a, np.cross(b, c)).sum() < 0:
        f = f[:, ::-1]
    return mf.Manifold(mf.Mesh64(vert_properties=np.ascontiguousarray(v),
                                 tri_verts=np.ascontiguousarray(f, dtype=np.uint64)))


def bed_report(assembly: Assembly) -> list[dict]:
    """Where each panel and hinge of the part sits on the print bed (print frame, mm).

    One record per unit (panel or hinge, in build order): ``kind``, ``id``, ``material``,
    ``z_min_mm`` (its lowest point above the bed), ``on_bed`` (it starts on the bed) and
    ``unsupported_area_mm2``: the area of its bottom faces (facing down within
    :data:`BOTTOM_FACE_RAD`) that rest neither on the bed nor on another part of the
    print (probed by a prism :data:`SUPPORT_PROBE_MM` deep under each face).
    ``needs_support`` is true when that area is over :data:`SUPPORT_AREA_MIN`: the slicer
    must put support (or bridge) under it. Typical case: hinges thicker than the panels,
    both centred on the sheet's mid-plane, so the flat panels float
    (t_hinge - t_panel) / 2 above the bed (``docs/geometry-and-export.md``, "On the bed").
    """
    if not assembly.units:
        raise GeometryError(f"design {assembly.design_name!r}: the assembly was built without its units")
    dz = float(assembly.print_offset[2])
    cos_down = float(np.cos(BOTTOM_FACE_RAD))
    # the part is the union of the units: a probe can only meet the units whose boxes it
    # overlaps, so each probe is cut against those (O(n) for n units, not O(n^2))
    boxes = np.array([u.solid.bounding_box() for u in assembly.units]).reshape(-1, 6)
    out = []
    for u in assembly.units:
        mesh = u.solid.to_mesh64()
        v = np.asarray(mesh.vert_properties)[:, :3]
        tri = v[np.asarray(mesh.tri_verts, dtype=np.int64)]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(n, axis=1)
        z_min = float(v[:, 2].min()) + dz
        sel = (n[:, 2] < -cos_down * area2) & (tri[:, :, 2].min(axis=1) + dz > BED_TOL)
        area = float(0.5 * area2[sel].sum())
        if area > 0:
            probe = tri[sel]
            lo = probe.reshape(-1, 3).min(axis=0) - [0.0, 0.0, SUPPORT_PROBE_MM]
            hi = probe.reshape(-1, 3).max(axis=0)
            eps = 1e-6 * (1.0 + float(np.abs(boxes).max()))
            near = np.nonzero(np.all(boxes[:, :3] <= hi + eps, axis=1) & np.all(boxes[:, 3:] >= lo - eps, axis=1))[0]
            # the probe's part in the union of those units is the union of its parts in each
            # (small solids: cheaper than uniting the units first: mailbox 0.15 to 0.09 CPU-s)
            prism = _prisms(probe, SUPPORT_PROBE_MM)
            cut = [prism ^ assembly.units[k].solid for k in near]
            part = cut[0] if len(cut) == 1 else mf.Manifold.batch_boolean(cut, mf.OpType.Add)
            resting = part.volume() / SUPPORT_PROBE_MM
            area = max(0.0, area - resting)
        out.append({"kind": u.kind, "id": u.owner, "material": u.material, "z_min_mm": round(z_min, 6),
                    "on_bed": z_min <= BED_TOL, "unsupported_area_mm2": round(area, 3),
                    "needs_support": area > SUPPORT_AREA_MIN})
    return out
