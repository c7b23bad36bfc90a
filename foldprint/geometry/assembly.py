"""Pieces of a build state and the per-material bodies (with overlap checks)."""

from __future__ import annotations

import manifold3d as mf
import numpy as np

from ..design import Design
from ..errors import GeometryError
from ..materials import MaterialLibrary, default_library
from .hinges import _poses, state_angles, strip_solids
from .layout import layout
from .solids import VOLUME_RTOL, Assembly, Body, Piece, _checked, _extrude

# -- pieces and bodies --------------------------------------------------------------------

def build_pieces(design: Design, state: str = "permanent") -> list[Piece]:
    """Every solid piece of a build state, in a fixed order (panels, then per hinge its
    strip segments and teeth)."""
    angles = state_angles(design, state)
    lays, rigid = layout(design)
    frames = [lay.frame for lay in lays]
    poses = _poses(design, frames, angles)
    pieces: list[Piece] = []
    for k, p in enumerate(design.panels):
        solid = _extrude(rigid[k], p.thickness, poses[k], f"panel {p.id!r}")
        pieces.append(Piece("panel", p.id, p.material, solid))
    for lay in lays:
        h, f = lay.hinge, lay.frame
        rho = float(angles[f.index])
        for solid in strip_solids(h, f, lay.d, lay.p0, poses[f.parent], rho, lay.segments):
            pieces.append(Piece("strip", h.id, h.material, solid))
        for pidx in sorted(lay.teeth):
            panel = design.panels[pidx]
            solid = _extrude(lay.teeth_solid[pidx], panel.thickness, poses[pidx],
                             f"hinge {h.id!r} teeth in panel {panel.id!r}")
            if solid is not None:
                pieces.append(Piece("teeth", h.id, h.material, solid))
    return pieces


def panel_solids(design: Design, state: str = "permanent") -> dict[str, mf.Manifold]:
    """The rigid panel solids of a state, by panel id (for clearance checks)."""
    return {p.owner: p.solid for p in build_pieces(design, state) if p.kind == "panel"}


def _canonical(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sort vertices lexicographically and faces by their (rotated) indices: the same
    solid always gives identical arrays."""
    order = np.lexsort((vertices[:, 2], vertices[:, 1], vertices[:, 0]))
    inv = np.empty_like(order)
    inv[order] = np.arange(len(order))
    f = inv[faces]
    shift = np.argmin(f, axis=1)
    rows = np.arange(len(f))[:, None]
    f = f[rows, (shift[:, None] + np.arange(3)[None]) % 3]
    f = f[np.lexsort((f[:, 2], f[:, 1], f[:, 0]))]
    return vertices[order], f


def _material_order(materials: list[str], library: MaterialLibrary) -> list[str]:
    names = library.names()
    return sorted(materials, key=lambda m: (names.index(m) if m in names else len(names), m))


def _units(pieces: list[Piece]) -> list[Piece]:
    """Pieces grouped into the units that must not overlap: each panel, and each hinge
    (its strip segments and teeth, which overlap on purpose, united)."""
    units: list[Piece] = []
    hinge_parts: dict[str, list[Piece]] = {}
    for pc in pieces:
        if pc.kind == "panel":
            units.append(pc)
        else:
            hinge_parts.setdefault(pc.owner, []).append(pc)
    for owner, parts in hinge_parts.items():
        solid = parts[0].solid if len(parts) == 1 else mf.Manifold.batch_boolean(
            [p.solid for p in parts], mf.OpType.Add)
        units.append(Piece("hinge", owner, parts[0].material, _checked(solid, f"hinge {owner!r}")))
    return units


def _overlap_message(units: list[Piece], state: str) -> str:
    for i, a in enumerate(units):
        for b in units[i + 1:]:
            vol = (a.solid ^ b.solid).volume()
            if vol > VOLUME_RTOL * min(a.volume, b.volume):
                return (f"{state} state: {a.kind} {a.owner!r} ({a.material}) and {b.kind} {b.owner!r} "
                        f"({b.material}) overlap by {vol:.4g} mm^3; the printed part would not be as "
                        "designed (panels colliding when folded?)")
    return f"{state} state: pieces overlap"


def build_assembly(design: Design, state: str = "permanent", library: MaterialLibrary | None = None,
                   check: bool = True) -> Assembly:
    """One watertight body per material for a state (``permanent`` or ``programmed``).

    With ``check`` (default), raises GeometryError when panels or hinges overlap, within
    one material or across two (touching is fine): such a part would not print as
    designed (e.g. panels colliding in the folded state)."""
    lib = library or default_library()
    units = _units(build_pieces(design, state))
    by_mat: dict[str, list[Piece]] = {}
    for u in units:
        by_mat.setdefault(u.material, []).append(u)
    bodies, solids = [], []
    for mat in _material_order(list(by_mat), lib):
        group = by_mat[mat]
        solid = group[0].solid if len(group) == 1 else mf.Manifold.batch_boolean(
            [u.solid for u in group], mf.OpType.Add)
        _checked(solid, f"{state} body of {mat}")
        total = sum(u.volume for u in group)
        if check and solid.volume() < total * (1 - VOLUME_RTOL) - 1e-9:
            raise GeometryError(_overlap_message(group, state))
        mesh = solid.to_mesh64()
        v, f = _canonical(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts, dtype=np.int64))
        bodies.append(Body(mat, v, f, solid.volume(), solid))
        solids.append(solid)
    if check:
        for i in range(len(bodies)):
            for j in range(i + 1, len(bodies)):
                a, b = bodies[i].bounds, bodies[j].bounds
                if np.any(a[1] < b[0]) or np.any(b[1] < a[0]):
                    continue
                vol = (solids[i] ^ solids[j]).volume()
                if vol > VOLUME_RTOL * min(bodies[i].volume, bodies[j].volume):
                    raise GeometryError(_overlap_message(by_mat[bodies[i].material] + by_mat[bodies[j].material],
                                                         state))
    return Assembly(design.name, state, tuple(bodies))
