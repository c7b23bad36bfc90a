"""Pieces of a build state and the per-material bodies (with overlap checks)."""

from __future__ import annotations

from dataclasses import dataclass

import manifold3d as mf
import numpy as np

from ..model.derived import scoped
from ..model.design import Design
from ..core.errors import GeometryError
from ..core.modes import DEFAULT_STATE, State
from ..model.materials import MaterialLibrary, default_library
from .hinges import tree_poses, arc_transform, closed_targets, state_angles, strip_solids
from .layout import layout
from .solids import VOLUME_RTOL, Assembly, Body, Piece, checked_solid, extrude, apply_pose

# -- pieces and bodies --------------------------------------------------------------------

def build_pieces(design: Design, state: State = DEFAULT_STATE, resolution_mm: float | None = None) -> list[Piece]:
    """Every solid piece of a build state, in a fixed order (panels, then per hinge its
    strip segments and teeth); ``resolution_mm``: the printer's, the tolerance of closing a
    pattern's loops (:func:`~foldprint.geometry.hinges.closed_targets`)."""
    angles = state_angles(design, state, resolution_mm)
    lays, rigid = layout(design)
    frames = [lay.frame for lay in lays]
    poses = tree_poses(design, frames, angles)
    pieces: list[Piece] = []
    for k, p in enumerate(design.panels):
        solid = extrude(rigid[k], p.thickness, poses[k], f"panel {p.id!r}")
        pieces.append(Piece("panel", p.id, p.material, solid))
    for lay in lays:
        h, f = lay.hinge, lay.frame
        rho = float(angles[f.index])
        for solid in strip_solids(h, f, lay.d, lay.p0, poses[f.parent], rho, lay.segments):
            pieces.append(Piece("strip", h.id, h.material, solid))
        for pidx in sorted(lay.teeth):
            panel = design.panels[pidx]
            solid = extrude(lay.teeth_solid[pidx], panel.thickness, poses[pidx],
                             f"hinge {h.id!r} teeth in panel {panel.id!r}")
            if solid is not None:
                pieces.append(Piece("teeth", h.id, h.material, solid))
    return pieces


def panel_solids(design: Design, state: State = DEFAULT_STATE) -> dict[str, mf.Manifold]:
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
        units.append(Piece("hinge", owner, parts[0].material, checked_solid(solid, f"hinge {owner!r}")))
    return units


def _overlap_message(units: list[Piece], state: State) -> str:
    for i, a in enumerate(units):
        for b in units[i + 1:]:
            common = a.solid ^ b.solid
            vol = common.volume()
            if vol > VOLUME_RTOL * min(a.volume, b.volume):
                # a thin overlap of area A and depth d has volume A d and surface 2 A: d = 2 V / S
                depth = 2.0 * vol / max(common.surface_area(), 1e-300)
                at = np.asarray(common.bounding_box()).reshape(2, 3).mean(axis=0)
                return (f"{state} state: {a.kind} {a.owner!r} ({a.material}) and {b.kind} {b.owner!r} "
                        f"({b.material}) overlap by {vol:.4g} mm^3, about {depth:.2g} mm deep, around "
                        f"({at[0]:.1f}, {at[1]:.1f}, {at[2]:.1f}) mm; the printed part would not be as designed")
    return f"{state} state: pieces overlap"


def relabelled(pieces: list[Piece], design: Design) -> list[Piece]:
    """``pieces`` of a design of the same geometry (``build_pieces``) with ``design``'s
    materials: its pieces, without cutting them again (a material is a label of a piece)."""
    panel = {p.id: p.material for p in design.panels}
    hinge = {h.id: h.material for h in design.hinges}
    return [Piece(pc.kind, pc.owner, (panel if pc.kind == "panel" else hinge)[pc.owner], pc.solid) for pc in pieces]


@scoped
def build_assembly(design: Design, state: State = DEFAULT_STATE, library: MaterialLibrary | None = None,
                   check: bool = True, resolution_mm: float | None = None,
                   pieces: list[Piece] | None = None) -> Assembly:
    """One watertight body per material for a state (``permanent`` or ``programmed``).

    With ``check`` (default), raises GeometryError when panels or hinges overlap, within
    one material or across two (touching is fine): such a part would not print as
    designed (e.g. panels colliding in the folded state). ``resolution_mm`` (the printer's
    layer; default the default printer's) is how far closing a pattern's loops may move the
    part; when the build used it, :attr:`Assembly.notes` says so. ``pieces``: this design's
    ``build_pieces(design, state, resolution_mm)`` when the caller has them (:func:`relabelled`)."""
    lib = library or default_library()
    note = closed_targets(design, state, resolution_mm)[1]
    units = _units(build_pieces(design, state, resolution_mm) if pieces is None else pieces)
    by_mat: dict[str, list[Piece]] = {}
    for u in units:
        by_mat.setdefault(u.material, []).append(u)
    bodies, solids = [], []
    for mat in _material_order(list(by_mat), lib):
        group = by_mat[mat]
        solid = group[0].solid if len(group) == 1 else mf.Manifold.batch_boolean(
            [u.solid for u in group], mf.OpType.Add)
        checked_solid(solid, f"{state} body of {mat}")
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
    return Assembly(design.name, state, tuple(bodies), tuple(units), notes=(note,) if note else ())


# -- hinge axes: where a point of a hinge body lies across and along its hinge ------------

#: mid-line samples per hinge for :class:`HingeAxes` (the bent strip's mid-line is a
#: circular arc; 65 chords of a <= 180 deg arc are within R (1 - cos(1.4 deg)) = 3e-4 R of it)
AXES_SAMPLES = 65


@dataclass(frozen=True)
class HingeAxes:
    """The frame that maps a point of a hinge's body (sheet frame, mm) to u in [0, 1]:

    * across the hinge (``Along.WIDTH``, the arc direction): u = s of the nearest point of
      the hinge's mid-line ``mid`` (``mid[k]`` is the mid-surface line at fraction
      k / (K - 1) of the flat width, 0 = the parent's edge, bent as printed), measured in
      the plane perpendicular to the fold line;
    * along the fold line (``Along.LENGTH``): u = (p - origin) . direction / length, from
      ``line[0]`` (0) to ``line[1]`` (1).

    Points beyond the strip (teeth reaching into the panels) clip to 0 or 1."""

    hinge: str
    origin: np.ndarray      # (3,) the mid-line point at u = 0 on line[0]
    direction: np.ndarray   # (3,) unit fold-line direction, line[0] -> line[1]
    length: float           # mm, the fold line's length
    mid: np.ndarray         # (K, 3) the mid-line at v = 0 (line[0]), u = 0 .. 1

    def width_u(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=float).reshape(-1, 3)
        d = self.direction
        m = self.mid - self.origin
        m = m - np.outer(m @ d, d)
        k_n = len(m) - 1
        mm = np.einsum("ij,ij->i", m, m)
        out = np.empty(len(p))
        for lo in range(0, len(p), 65536):  # chunks: the (n, K) distance table stays small
            q = p[lo:lo + 65536] - self.origin
            q = q - np.outer(q @ d, d)
            near = np.argmin(mm[None, :] - 2.0 * (q @ m.T), axis=1)  # nearest sample
            best = np.full(len(q), np.inf)
            s = np.zeros(len(q))
            for seg in (np.maximum(near - 1, 0), np.minimum(near, k_n - 1)):  # its two chords
                a, ab = m[seg], m[seg + 1] - m[seg]
                t = np.clip(np.einsum("ij,ij->i", q - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300),
                            0.0, 1.0)
                r = q - a - t[:, None] * ab
                dist = np.einsum("ij,ij->i", r, r)
                better = dist < best
                best = np.where(better, dist, best)
                s = np.where(better, (seg + t) / k_n, s)
            out[lo:lo + 65536] = s
        return out

    def length_u(self, p: np.ndarray) -> np.ndarray:
        p = np.asarray(p, dtype=float).reshape(-1, 3)
        return np.clip(((p - self.origin) @ self.direction) / self.length, 0.0, 1.0)


def hinge_axes(design: Design, state: str = "permanent") -> dict[str, HingeAxes]:
    """:class:`HingeAxes` of every hinge in a build state (the same poses and arc map as
    the hinge bodies :func:`build_pieces` makes)."""
    angles = state_angles(design, state)
    lays, _ = layout(design)
    poses = tree_poses(design, [lay.frame for lay in lays], angles)
    out = {}
    for lay in lays:
        h, f = lay.hinge, lay.frame
        rho = float(angles[f.index])
        w = h.width
        n3 = f.normal
        d3 = np.array([lay.d[0], lay.d[1], 0.0])
        base = np.array([lay.p0[0], lay.p0[1], 0.0])
        parent = poses[f.parent]
        mid = []
        for s in np.linspace(0.0, 1.0, AXES_SAMPLES):
            local = arc_transform(f, rho, float(s) * w)
            pt = base + (s * w - 0.5 * w) * n3
            mid.append(apply_pose(parent @ local, pt[None])[0])
        mid = np.array(mid)
        direction = parent[:3, :3] @ d3
        out[h.id] = HingeAxes(h.id, mid[0].copy(), direction / np.linalg.norm(direction), float(h.length), mid)
    return out
