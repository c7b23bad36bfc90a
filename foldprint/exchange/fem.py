"""Finite elements: an Abaqus input of a planar strip's side profile (``docs/geometry-and-export.md``).

The paper validated its reduced-order model against finite elements of the strip's side
view (Mao et al. 2015, "Folding simulations"). This writes that model's mesh: the strip's
profile in the xz-plane (a section at constant y; holes through the panels, which cut
the strip along y, do not show in it) in a build state, as plane-strain 4-node
quadrilaterals:

* every panel's rigid part and every curved hinge is a structured block, columns along
  the strip at most ``element_size`` apart (and, in a hinge, at most 5 deg of bend apart),
  rows through the thickness at most ``element_size`` and at most t_min / ``through``
  apart; all blocks share one set of through-thickness levels, so a thinner block's rows
  are a subset of a thicker neighbour's and the mesh is conforming at every interface;
* panels are placed with the arc-model poses of the state, which the writer is given
  (:class:`PlacedState`: the pipeline runs the kinematics), hinge nodes with the arc map
  across the strip (:func:`foldprint.geometry.arc_transform`);
* element sets: ``MAT_<material>`` per material (panels and each hinge material),
  ``HINGE_<id>`` per hinge, ``PANEL_<id>`` per panel; node sets ``ROOT`` (the clamped root
  panel) and ``ALL``;
* quality: every element's Jacobian is positive at its four corners (else ExportError);
  the worst aspect ratio (longest / shortest side) and smallest corner Jacobian are in the
  file's header comments and the export record.

Materials are element sets only: the SMPs' thermoviscoelastic model is not in the
material library, so no ``*MATERIAL``/``*SOLID SECTION`` is written (assign them in the
FE pre-processor). Stepped hinges (a thickness that jumps along the strip) are not meshed.
"""

from __future__ import annotations

import io
import math
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import meshio
import numpy as np

from ..core.version import __version__
from ..model.design import Design
from ..core.errors import ExportError
from ..geometry import MAX_SLICE_RAD, arc_transform

#: Default element size (mm) along the strip and the largest through the thickness.
ELEMENT_SIZE_MM = 0.25
#: Fewest elements through the thinnest panel or hinge.
THROUGH_THICKNESS = 4
#: Abaqus element written for the plane-strain 4-node quadrilateral (full integration).
ELEMENT_TYPE = "CPE4"


def set_name(prefix: str, text: str) -> str:
    """An Abaqus set name: a letter first, then letters, digits and underscores."""
    return f"{prefix}_" + (re.sub(r"[^A-Za-z0-9_]+", "_", text).strip("_").upper() or "X")


def _levels(thicknesses: list[float], size: float, through: int) -> np.ndarray:
    """Through-thickness levels shared by every block: the half thicknesses (and 0),
    each interval subdivided to at most ``size`` and t_min / ``through``."""
    t_min = min(thicknesses)
    step = min(size, t_min / through)
    marks = sorted({0.0} | {s * t / 2 for t in thicknesses for s in (-1.0, 1.0)})
    out = [marks[0]]
    for a, b in zip(marks[:-1], marks[1:]):
        n = max(1, math.ceil((b - a) / step - 1e-9))
        out.extend(np.linspace(a, b, n + 1)[1:].tolist())
    return np.array(out)


@dataclass(frozen=True)
class PlacedState:
    """A build state as the kinematics places it (arc hinges), given to the writer:
    ``state``, the hinge ``angles`` (rad, ``design.hinges`` order), the hinge ``frames``
    (tree order) and every panel's ``poses`` (n_panels, 4, 4)."""

    state: str
    angles: np.ndarray
    frames: tuple
    poses: np.ndarray


def check_strip(design: Design) -> None:
    """ExportError unless the inp export can mesh ``design`` (a planar strip, plain hinges)."""
    if not design.is_planar_strip:
        raise ExportError(f"design {design.name!r}: the Abaqus (inp) export meshes the side profile of a "
                          "planar strip (every fold line parallel to y); this design is not one")
    for h in design.hinges:
        if h.style.stepped:
            raise ExportError(f"design {design.name!r}: hinge {h.id!r} is stepped; the inp export meshes "
                              "plain hinges only (a thickness jump along the strip is not a structured block)")


class _Block(NamedTuple):
    """One structured block of the profile: a hinge strip or a panel's rigid part, its
    columns' sheet x (mm), thickness and ``ref`` (a hinge's frame, a panel's index)."""

    kind: str
    owner: str
    material: str
    xs: np.ndarray
    thickness: float
    ref: object


def strip_mesh(design: Design, placed: PlacedState, element_size: float = ELEMENT_SIZE_MM,
               through: int = THROUGH_THICKNESS):
    """The side-profile mesh of the state ``placed``: ``points`` (n, 2) (world x, z) mm,
    ``quads`` (m, 4) counter-clockwise, element sets and node sets (name -> indices), and
    quality figures. Steps: the blocks along the strip (:func:`_blocks`), the shared
    through-thickness levels (:func:`_levels`), the nodes and quads placed in the state
    (:func:`_mesh_blocks`), one orientation checked (:func:`_oriented`), the quality
    figures (:func:`_quality`)."""
    if not (element_size > 0 and math.isfinite(element_size)):
        raise ExportError(f"element size must be a positive number of mm, got {element_size!r}")
    if through < 1:
        raise ExportError(f"elements through the thickness must be >= 1, got {through!r}")
    check_strip(design)
    blocks = _blocks(design, placed, element_size)
    levels = _levels([b.thickness for b in blocks], element_size, through)
    pts, quads, cell_sets, root_nodes = _mesh_blocks(design, placed, blocks, levels)
    q, c, jac = _oriented(design, pts, np.array(quads, dtype=np.int64))
    quality = _quality(pts, q, c, jac, levels, blocks, element_size)
    point_sets = {"ROOT": np.array(sorted(root_nodes), dtype=np.int64), "ALL": np.arange(len(pts))}
    return pts, q, {k: np.array(v, dtype=np.int64) for k, v in cell_sets.items()}, point_sets, quality


def _blocks(design: Design, placed: PlacedState, element_size: float) -> list[_Block]:
    """The hinge strips [xf - w/2, xf + w/2] (tree order), then the panels' rigid parts
    between them (design order), each with its columns: at most ``element_size`` apart
    and, in a hinge, at most :data:`~foldprint.geometry.MAX_SLICE_RAD` of bend apart."""
    cut: dict[int, list[float]] = {k: [float(p.outline[:, 0].min()), float(p.outline[:, 0].max())]
                                   for k, p in enumerate(design.panels)}
    blocks = []
    for f in placed.frames:
        h = f.hinge
        xf = float(h.line[0][0])
        w = h.width
        for k in (f.parent, f.child):
            lo, hi = cut[k]
            if abs(xf - lo) <= 1e-6:
                cut[k][0] = xf + w / 2
            elif abs(xf - hi) <= 1e-6:
                cut[k][1] = xf - w / 2
            else:
                raise ExportError(f"design {design.name!r}: hinge {h.id!r} (x = {xf:g} mm) is not at an end "
                                  f"of panel {design.panels[k].id!r}; the inp export needs a chain of panels")
        n = max(math.ceil(w / element_size - 1e-9),
                math.ceil(abs(float(placed.angles[f.index])) / MAX_SLICE_RAD - 1e-9), 1)
        blocks.append(_Block("hinge", h.id, h.material, np.linspace(xf - w / 2, xf + w / 2, n + 1), h.thickness, f))
    for k, p in enumerate(design.panels):
        lo, hi = cut[k]
        if hi - lo <= 1e-6:
            raise ExportError(f"panel {p.id!r}: nothing rigid is left between its hinge strips")
        n = max(math.ceil((hi - lo) / element_size - 1e-9), 1)
        blocks.append(_Block("panel", p.id, p.material, np.linspace(lo, hi, n + 1), p.thickness, k))
    return blocks


def _column_pose(block: _Block, x: float, placed: PlacedState) -> np.ndarray:
    """The pose (4, 4) of the column at sheet ``x`` of ``block``: a panel's own, or in a
    hinge the arc map at its width u from the parent's edge."""
    if block.kind == "panel":
        return placed.poses[block.ref]
    f = block.ref
    s = 1.0 if f.normal[0] > 0 else -1.0
    u = min(max(s * (x - float(f.hinge.line[0][0])) + f.width / 2, 0.0), f.width)
    return placed.poses[f.parent] @ arc_transform(f, float(placed.angles[f.index]), u)


def _mesh_blocks(design: Design, placed: PlacedState, blocks: list[_Block], levels: np.ndarray):
    """Nodes (world x, z; one per sheet column and level, shared where blocks meet),
    quads (m, 4), element sets and the root panel's nodes."""
    root = design.panel_index()[design.root]
    key_of: dict[tuple[float, int], int] = {}
    points: list[np.ndarray] = []
    quads: list[list[int]] = []
    cell_sets: dict[str, list[int]] = {}
    root_nodes: set[int] = set()
    for b in blocks:
        rows = np.nonzero(np.abs(levels) <= b.thickness / 2 + 1e-9)[0]
        ids = np.empty((len(b.xs), len(rows)), dtype=np.int64)
        for i, x in enumerate(b.xs):
            pose = _column_pose(b, x, placed)
            for j, r in enumerate(rows):
                key = (round(float(x), 9), int(r))
                if key not in key_of:
                    world = pose[:3, :3] @ np.array([x, 0.0, levels[r]]) + pose[:3, 3]
                    key_of[key] = len(points)
                    points.append(np.array([world[0], world[2]]))
                ids[i, j] = key_of[key]
        first = len(quads)
        for i in range(len(b.xs) - 1):
            for j in range(len(rows) - 1):
                quads.append([ids[i, j], ids[i + 1, j], ids[i + 1, j + 1], ids[i, j + 1]])
        members = list(range(first, len(quads)))
        cell_sets.setdefault(set_name("MAT", b.material), []).extend(members)
        cell_sets[set_name("HINGE" if b.kind == "hinge" else "PANEL", b.owner)] = members
        if b.kind == "panel" and b.ref == root:
            root_nodes.update(ids.ravel().tolist())
    return np.array(points), quads, cell_sets, root_nodes


def _oriented(design: Design, pts: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quads counter-clockwise in (x, z) of the sheet (all flipped if the world view
    mirrors), their corners and corner Jacobians; ExportError on an inverted element."""
    c = pts[q]
    jac = _corner_jacobians(c)
    if np.median(jac) < 0:
        q = q[:, ::-1]
        c = pts[q]
        jac = _corner_jacobians(c)
    if not np.all(jac > 0):
        bad = int(np.argmin(jac.min(axis=1)))
        raise ExportError(f"design {design.name!r}: inp mesh element {bad + 1} is inverted or degenerate "
                          f"(corner Jacobian {jac.min():.3g} mm^2); use a smaller element size")
    return q, c, jac


def _quality(pts: np.ndarray, q: np.ndarray, c: np.ndarray, jac: np.ndarray, levels: np.ndarray,
             blocks: list[_Block], element_size: float) -> dict:
    """Nodes, elements, worst aspect ratio, smallest corner Jacobian, element size and the
    fewest elements through any block."""
    edges = np.linalg.norm(np.roll(c, -1, axis=1) - c, axis=2)
    aspect = edges.max(axis=1) / edges.min(axis=1)
    return {"nodes": int(len(pts)), "elements": int(len(q)), "worst_aspect_ratio": round(float(aspect.max()), 4),
            "min_corner_jacobian_mm2": float(f"{jac.min():.6g}"), "element_size_mm": float(element_size),
            "elements_through_thinnest": int(min(np.count_nonzero(np.abs(levels) <= b.thickness / 2 + 1e-9) - 1
                                                 for b in blocks))}


def _corner_jacobians(c: np.ndarray) -> np.ndarray:
    """(m, 4): 2 x the signed area spanned at each corner of each quad (positive = CCW)."""
    a = np.roll(c, -1, axis=1) - c
    b = np.roll(c, 1, axis=1) - c
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def inp_bytes(design: Design, placed: PlacedState, element_size: float = ELEMENT_SIZE_MM,
              through: int = THROUGH_THICKNESS) -> tuple[bytes, dict]:
    """The Abaqus input (bytes) of the state ``placed`` and its mesh quality figures."""
    state = placed.state
    pts, q, cell_sets, point_sets, quality = strip_mesh(design, placed, element_size, through)
    mesh = meshio.Mesh(pts, [("quad", q)], cell_sets={k: [v] for k, v in cell_sets.items()},
                       point_sets=point_sets)
    # meshio names a "quad" CAX4P (an axisymmetric pore-pressure element) and has no
    # plane-strain name (its reader does not know CPE4 either: nschloe/meshio#320): write the
    # cell type untranslated and name the element here. meshio writes through a file name.
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mesh.inp"
        meshio.abaqus.write(str(path), mesh, float_fmt=".9g", translate_cell_names=False)
        text = path.read_text()
    if text.count("*ELEMENT, TYPE=quad\n") != 1:
        raise ExportError("meshio's Abaqus writer changed its element line; cannot name the elements")
    text = text.replace("*ELEMENT, TYPE=quad\n", f"*ELEMENT, TYPE={ELEMENT_TYPE}\n")
    body = text.split("*NODE\n", 1)[1]
    head = io.StringIO()
    head.write("*HEADING\n")
    head.write(f"{design.name} {state}: side profile (x, z), plane strain, mm; foldprint {__version__}\n")
    head.write(f"** written by foldprint {__version__} through meshio {meshio.__version__}\n")
    head.write(f"** strip depth (plane-strain thickness) {design.depth:g} mm; units mm\n")
    head.write(f"** {quality['nodes']} nodes, {quality['elements']} {ELEMENT_TYPE} elements, element size "
               f"{element_size:g} mm, >= {quality['elements_through_thinnest']} through the thinnest part\n")
    head.write(f"** worst aspect ratio {quality['worst_aspect_ratio']:g}; smallest corner Jacobian "
               f"{quality['min_corner_jacobian_mm2']:g} mm^2 (all positive)\n")
    head.write("** sets: MAT_<material>, HINGE_<id>, PANEL_<id> (elements); ROOT (clamp), ALL (nodes)\n")
    head.write("*NODE\n")
    return (head.getvalue() + body).encode("ascii"), quality
