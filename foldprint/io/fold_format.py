"""FOLD crease patterns as input: read FOLD 1.1/1.2 (foldprint, Origami Simulator,
Rabbit Ear) into a :class:`~foldprint.model.design.Design`.

Faces joined by flat edges ("F", "U", "J" without a fold angle) are facets of one panel
and merged; creases between two panels become hinges (collinear ones one hinge); the
result ends in :func:`foldprint.model.design.validate`. This is the input layer: the writer,
:mod:`foldprint.exchange.fold`, imports the shared helpers from here, never the reverse.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.polygon import orient

from ..core.constants import (DEFAULT_HINGE_MATERIAL, DEFAULT_HINGE_RADIUS_MM, DEFAULT_PANEL_MATERIAL,
                              DEFAULT_THICKNESS_MM, tol)
from ..model.design import Design
from .design_io import design_from_dict
from .fold_creases import hinge_line, largest_piece, refuse_polyline, refuse_unangled, straight_runs
from ..core.inputs import read_input_text, shown, stem_text
from ..core.errors import DesignError, where
from ..model import composition
from ..model.materials import MaterialLibrary
from ..core.schema import MAX_PANELS, check_fold, parse_error
from .fold_fields import crease_frame, index_lists, is_number, per_item, unit_factor, vertex_coords

#: mm: how far a fold line may sit from its edge (as in validate); the writer splits
#: panel sides at hinge ends within it.
LINE_TOL = 1e-3
_FLAT = {"F", "U", "J"}
_KNOWN = {"B", "C", "M", "V", "F", "U", "J"}
#: The keys of ``foldprint:design`` (the design data FOLD has no field for), read here and
#: written by :mod:`foldprint.exchange.fold`.
DESIGN_KEYS = {"schema", "name", "description", "root", "process", "defaults", "goals", "hinges", "paper"}
#: The keys of one hinge's entry in ``foldprint:design.hinges``, read and written alike.
HINGE_EXTRA = {"panels", "fixity", "style"}



def index_face_edges(faces, edges: list, lookup: dict) -> list[list[int]]:
    """The faces bordering each edge. ``lookup`` maps sorted vertex pairs to indices of
    ``edges``; face sides not in it are appended to ``edges`` (both are updated)."""
    edge_faces: list[list[int]] = [[] for _ in edges]
    for f, ring in enumerate(faces):
        for a, b in ring_edges(ring):
            key = (min(a, b), max(a, b))
            if key not in lookup:
                lookup[key] = len(edges)
                edges.append([a, b])
                edge_faces.append([])
            edge_faces[lookup[key]].append(f)
    return edge_faces


def ring_edges(ring: list[int]):
    """The sides (a, b) of a closed ring of vertex indices, the last back to the first."""
    return [(ring[k], ring[(k + 1) % len(ring)]) for k in range(len(ring))]


def project_onto_line(pts: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Parameter t along a->b, distance to the line and the foot point of every point."""
    d = b - a
    t = (pts - a) @ d / (d @ d)
    foot = a + t[:, None] * d
    return t, np.hypot(*(pts - foot).T), foot


# -- import -----------------------------------------------------------------------

def _clean_ring(ring: np.ndarray) -> np.ndarray:
    """Drop repeated points and vertices lying straight on the line of their neighbours."""
    pts = [p for k, p in enumerate(ring) if np.linalg.norm(p - ring[k - 1]) > tol.length] or list(ring)
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for k in range(len(pts)):
            u, v = pts[k] - pts[k - 1], pts[(k + 1) % len(pts)] - pts[k]
            if abs(u[0] * v[1] - u[1] * v[0]) <= 1e-9 * np.linalg.norm(u) * np.linalg.norm(v) and u @ v > 0:
                del pts[k]
                changed = True
                break
    return np.array(pts)


def _fresh(prefix: str, taken: set, start: dict) -> str:
    """The first ``prefix<k>`` not taken; ``start`` remembers where the last search ended
    (ids are only added, so the ones before it stay taken: 22,500 panels took 400 s when
    every search began at 1)."""
    k = start.get(prefix, 1)
    while f"{prefix}{k}" in taken:
        k += 1
    taken.add(f"{prefix}{k}")
    start[prefix] = k + 1
    return f"{prefix}{k}"


def _edge_id(edge: int, taken: set) -> str:
    """A hinge read from FOLD edge ``edge`` is called ``e<edge>`` (``_k`` if taken)."""
    hid, k = f"e{edge}", 1
    while hid in taken:
        hid, k = f"e{edge}_{k}", k + 1
    taken.add(hid)
    return hid


def _first(values: list, default):
    return next((v for v in values if v is not None), default)


@dataclass
class _EdgeTable:
    """Every edge of the crease pattern with its per-edge fields, the face sides missing
    from ``edges_vertices`` appended as "U" edges without fields; ``faces`` are the faces
    bordering each edge."""

    edges: list
    assign: list
    angle: list
    hinge_id: list
    material: list
    radius: list
    thickness: list
    faces: list
    xy: np.ndarray | None = None  # the vertices (file units), for the straight runs of creases


def _edge_table(frame: Mapping, faces: list, nv: int, src: str) -> _EdgeTable:
    """The edges, their assignments, fold angles and foldprint fields, checked, and the
    faces bordering each edge."""
    edges = index_lists(frame, "edges_vertices", nv, src, 2) if "edges_vertices" in frame else []
    ne = len(edges)
    assign = [str(a).upper() if a is not None else "U"
              for a in per_item(frame, "edges_assignment", ne, "edges_vertices", src)]
    for i, a in enumerate(assign):
        if a not in _KNOWN:
            raise DesignError(f"{src}edges_assignment[{i}] is {a!r}; FOLD knows {sorted(_KNOWN)}")
    angle = per_item(frame, "edges_foldAngle", ne, "edges_vertices", src)
    for i, a in enumerate(angle):
        if a is not None and not (is_number(a) and abs(a) <= 180 + 1e-9):
            raise DesignError(f"{src}edges_foldAngle[{i}] must be a number of degrees in [-180, 180], got {a!r}")
    e_hid, e_mat, e_rad, e_thk = (per_item(frame, f"edges_foldprint:{k}", ne, "edges_vertices", src)
                                  for k in ("hinge_id", "material", "radius_mm", "thickness_mm"))
    # which faces border which edge; face sides missing from edges_vertices count as "U"
    lookup = {}
    for i, (a, b) in enumerate(edges):
        lookup.setdefault((min(a, b), max(a, b)), i)
    edge_faces = index_face_edges(faces, edges, lookup)
    assign += ["U"] * (len(edges) - ne)
    for col in (angle, e_hid, e_mat, e_rad, e_thk):
        col += [None] * (len(edges) - ne)
    return _EdgeTable(edges, assign, angle, e_hid, e_mat, e_rad, e_thk, edge_faces)


def _face_polygons(faces: list, xy: np.ndarray, src: str) -> list:
    """Each face as a shapely polygon; a face that is not a simple polygon is refused."""
    polys = []
    for f, ring in enumerate(faces):
        poly = Polygon(xy[ring])
        if not poly.is_valid or poly.area <= tol.area:
            why = shapely.is_valid_reason(poly) if not poly.is_valid else "zero area"
            raise DesignError(f"{src}faces_vertices[{f}] is not a simple polygon ({why})")
        polys.append(poly)
    return polys


def _facet_groups(et: _EdgeTable, nf: int, src: str) -> tuple[list[int], list[list[int]]]:
    """The crease edges, and the faces grouped into panels: facets joined by flat edges
    form one panel (union-find); groups in the order of their smallest face."""
    parent = list(range(nf))

    def root(f: int) -> int:
        while parent[f] != f:
            parent[f] = parent[parent[f]]  # path halving: a long chain of facets stays cheap
            f = parent[f]
        return f

    crease = []
    for i, fs in enumerate(et.faces):
        if len(fs) > 2:
            raise DesignError(f"{src}edges_vertices[{i}] borders {len(fs)} faces; an edge of a crease "
                              "pattern borders at most 2")
        is_crease = (et.hinge_id[i] is not None or et.assign[i] in ("M", "V")
                     or (et.assign[i] in _FLAT and et.angle[i] not in (None, 0)))
        if is_crease:
            if len(fs) != 2:
                raise DesignError(f"{src}edges_vertices[{i}] is a {et.assign[i]} crease but borders {len(fs)} "
                                  "face(s); a hinge must lie between two faces")
            crease.append(i)
        elif et.assign[i] in _FLAT and len(fs) == 2:
            parent[root(fs[0])] = root(fs[1])
    groups: dict[int, list[int]] = {}
    for f in range(nf):
        groups.setdefault(root(f), []).append(f)
    return crease, sorted(groups.values(), key=min)


def _panel_entries(frame: Mapping, members: list, polys: list, factor: float, src: str,
                   default_panel_material: str, default_thickness_mm: float) -> tuple[list, list]:
    """The design's panels (outline, holes, thickness, material) and their ids, one per
    group of faces."""
    nf = len(polys)
    f_id, f_mat, f_thk, f_holes = (per_item(frame, f"faces_foldprint:{k}", nf, "faces_vertices", src)
                                   for k in ("id", "material", "thickness_mm", "holes"))
    taken = {str(v) for v in f_id if v is not None}
    panels, pid_of, start = [], [], {}
    for fs in members:
        pid = str(_first([f_id[f] for f in fs], None) or _fresh("p", taken, start))
        pid_of.append(pid)
        shape = polys[fs[0]] if len(fs) == 1 else shapely.union_all([polys[f] for f in fs])
        if shape.geom_type != "Polygon":
            raise DesignError(f"{src}faces {fs} are joined by flat edges but do not form one polygon")
        shape = orient(shape, 1.0)
        holes = [_clean_ring(np.asarray(r.coords)[:-1]).tolist() for r in shape.interiors]
        for f in fs:
            for k, hole in enumerate(f_holes[f] or []):
                arr = np.array(hole, dtype=object)
                if arr.ndim != 2 or arr.shape[1] != 2 or not all(is_number(c) for c in arr.flat):
                    raise DesignError(f"{src}faces_foldprint:holes[{f}][{k}] must be a list of [x, y] points")
                holes.append((arr.astype(float) * factor).tolist())
        entry = {"id": pid, "outline": _clean_ring(np.asarray(shape.exterior.coords)[:-1]).tolist(),
                 "thickness_mm": _first([f_thk[f] for f in fs], default_thickness_mm),
                 "material": str(_first([f_mat[f] for f in fs], default_panel_material))}
        if holes:
            entry["holes"] = holes
        panels.append(entry)
    return panels, pid_of


def _crease_groups(et: _EdgeTable, crease: list, group_of: dict, pid_of: list, src: str) -> dict:
    """The crease edges of each hinge: those with the same hinge id, keyed by it, or the
    straight runs of creases between the same two panels (:func:`_straight_runs`), keyed by
    the pair of panel groups and the run's number."""
    hgroups: dict[Any, list[int]] = {}
    for i in crease:
        ga, gb = sorted(group_of[f] for f in et.faces[i])
        if ga == gb:
            raise DesignError(f"{src}edges_vertices[{i}] is a {et.assign[i]} crease inside panel {pid_of[ga]!r}: "
                              "flat (facet) edges join the faces on its two sides into that one panel, and a "
                              "rigid printed panel cannot fold along a crease inside it (its facets would have to "
                              "bend); a foldprint hinge must run between separate panels")
        hgroups.setdefault(str(et.hinge_id[i]) if et.hinge_id[i] is not None else (ga, gb), []).append(i)
    out: dict[Any, list[int]] = {}
    for key, ids in hgroups.items():
        if isinstance(key, str):  # a named hinge is one hinge (one line, one angle), checked later
            out[key] = ids
            continue
        runs = straight_runs(et, ids)
        refuse_polyline(et, runs, [pid_of[g] for g in key], src)
        for k, run in enumerate(runs):
            out[key + (k,)] = run
    return out


def _design_extras(frame: Mapping, src: str) -> tuple[Mapping, Mapping]:
    """The ``foldprint:design`` object and its per-hinge extras, checked."""
    fp = frame.get("foldprint:design") or {}
    if not isinstance(fp, Mapping):
        raise DesignError(f"{src}foldprint:design must be an object, got {type(fp).__name__}")
    unknown = sorted(set(fp) - DESIGN_KEYS)
    if unknown:
        raise DesignError(f"{src}foldprint:design: unknown key(s) {unknown}; allowed: {sorted(DESIGN_KEYS)}")
    extras = fp.get("hinges") or {}
    if not isinstance(extras, Mapping):
        raise DesignError(f"{src}foldprint:design.hinges must be an object keyed by hinge id")
    return fp, extras


def _hinge_entries(et: _EdgeTable, xy: np.ndarray, hgroups: dict, group_of: dict, pid_of: list,
                   extras: Mapping, src: str, crease_materials: Mapping[str, str] | None,
                   default_hinge_material: str, default_radius_mm: float,
                   default_thickness_mm: float) -> list:
    """The design's hinges, one per group of creases: one line, one angle, its panels."""
    refuse_unangled(et, [i for ids in hgroups.values() for i in ids], src)
    htaken = {k for k in hgroups if isinstance(k, str)}
    hinges = []
    for key, ids in hgroups.items():
        pairs = {tuple(sorted(group_of[f] for f in et.faces[i])) for i in ids}
        if len(pairs) > 1:
            raise DesignError(f"{src}hinge {key!r} has edges between different pairs of panels "
                              f"({sorted({tuple(pid_of[g] for g in p) for p in pairs})})")
        ga, gb = pairs.pop()
        hid = key if isinstance(key, str) else _edge_id(min(ids), htaken)
        degs = [et.angle[i] if et.angle[i] is not None else 0.0 for i in ids]
        if max(degs) - min(degs) > 1e-6:
            raise DesignError(f"{src}panels {pid_of[ga]!r} and {pid_of[gb]!r} are joined by creases with "
                              f"different fold angles {sorted(set(degs))} (edges_vertices {ids}); one "
                              "hinge has one angle: split a panel or give the creases one angle")
        line = hinge_line(xy, [et.edges[i] for i in ids])
        if line is None:
            raise DesignError(f"{src}panels {pid_of[ga]!r} and {pid_of[gb]!r} are joined by creases that "
                              f"do not lie on one line (edges_vertices {ids}); a hinge is straight")
        extra = extras.get(hid) or {}
        if not isinstance(extra, Mapping) or set(extra) - HINGE_EXTRA:
            raise DesignError(f"{src}foldprint:design.hinges.{hid} may only hold {sorted(HINGE_EXTRA)}")
        pp = [pid_of[ga], pid_of[gb]]
        if sorted(map(str, extra.get("panels") or [])) == sorted(pp):
            pp = [str(p) for p in extra["panels"]]
        entry = {"id": hid, "panels": pp, "line": line.tolist(), "angle_deg": float(degs[0]),
                 "material": composition.parse_material_spec(
                     _first([et.material[i] for i in ids], None)
                     or (crease_materials or {}).get(et.assign[ids[0]], default_hinge_material),
                     f"{src}edges_foldprint:material of hinge {hid!r}: "),
                 "radius_mm": _first([et.radius[i] for i in ids], default_radius_mm),
                 "thickness_mm": _first([et.thickness[i] for i in ids], default_thickness_mm)}
        entry.update({k: extra[k] for k in ("fixity", "style") if k in extra})
        hinges.append(entry)
    return hinges


def _design_dict(frame: Mapping, fp: Mapping, source: str, panels: list, hinges: list,
                 factor: float) -> dict:
    """The design as the dict :func:`design_from_dict` reads: ``foldprint:design``'s keys,
    the name and description from the frame, the panels and hinges, scaled to mm."""
    name = (frame.get("frame_title") or frame.get("file_title") or fp.get("name")
            or (stem_text(source) if source else "") or "fold")
    d = {k: v for k, v in fp.items() if k not in ("hinges", "schema", "name")}
    d.update(name=str(name), panels=panels, hinges=hinges)
    if "description" not in d and frame.get("frame_description"):
        d["description"] = str(frame["frame_description"])
    if factor != 1.0:
        d = _scaled(d, factor)
    return d


def design_from_fold(data: dict, source: str = "", library: MaterialLibrary | None = None,
                     scale: float | None = None, default_hinge_material: str = DEFAULT_HINGE_MATERIAL,
                     default_panel_material: str = DEFAULT_PANEL_MATERIAL,
                     default_thickness_mm: float = DEFAULT_THICKNESS_MM,
                     default_radius_mm: float = DEFAULT_HINGE_RADIUS_MM,
                     crease_materials: Mapping[str, str] | None = None) -> Design:
    """Build and validate a design from a parsed FOLD 1.1/1.2 crease pattern.

    ``scale`` (mm per file unit) overrides ``frame_unit``; without it a known unit
    (mm, cm, m, in, pt, um, nm) is converted, and "unit" (or no unit) is an error that
    asks for a scale. Hinges from plain FOLD edges are called ``e<edge index>``.
    ``crease_materials`` maps an assignment letter (M, V, F, U) to the hinge material of
    creases that name none (``edges_foldprint:material``); others get
    ``default_hinge_material``. Coordinates (vertices, holes, goal
    tips, strip depth) are scaled; the ``*_mm`` quantities are mm already.
    """
    src = where(source)
    if not isinstance(data, Mapping):
        raise DesignError(f"{src}a FOLD file must hold a JSON object, got {type(data).__name__}")
    frame = crease_frame(data, src)
    check_fold(frame, source)  # the types of the foldprint per-item fields
    if "faces_vertices" not in frame:
        raise DesignError(f"{src}faces_vertices is missing; foldprint needs faces (its panels), "
                          "re-export the crease pattern with faces")
    factor = unit_factor(frame, scale, src)
    xy = vertex_coords(frame, factor, src)
    faces = index_lists(frame, "faces_vertices", len(xy), src, None)
    if not faces:
        raise DesignError(f"{src}faces_vertices is empty; a design needs at least one face")
    et = _edge_table(frame, faces, len(xy), src)
    et.xy = xy
    crease, members = _facet_groups(et, len(faces), src)
    if len(members) > MAX_PANELS:  # counted before any polygon is built
        raise DesignError(f"{src}the {len(faces)} faces form {len(members)} panels (faces joined by flat edges "
                          f"are one); at most {MAX_PANELS} are accepted")
    polys = _face_polygons(faces, xy, src)
    group_of = {f: g for g, fs in enumerate(members) for f in fs}
    panels, pid_of = _panel_entries(frame, members, polys, factor, src,
                                    default_panel_material, default_thickness_mm)
    hgroups = _crease_groups(et, crease, group_of, pid_of, src)
    fp, extras = _design_extras(frame, src)
    hinges = _hinge_entries(et, xy, hgroups, group_of, pid_of, extras, src, crease_materials,
                            default_hinge_material, default_radius_mm, default_thickness_mm)
    notes = list(frame.get("foldprint:notes") or []) if isinstance(frame.get("foldprint:notes"), list) else []
    if frame.get("foldprint:pieces") == "largest":
        panels, hinges = largest_piece(panels, hinges, notes)
    design = design_from_dict(_design_dict(frame, fp, source, panels, hinges, factor), source, library)
    if notes:
        design = dataclasses.replace(design, notes=design.notes + tuple(str(n) for n in notes))
    return design


def _scaled(d: dict, factor: float) -> dict:
    """Scale the sheet coordinates kept in foldprint:design (goal tips, strip depth)."""
    d = dict(d)
    if isinstance(d.get("goals"), list):
        d["goals"] = [dict(g, tip=[c * factor for c in g["tip"]]) if isinstance(g, Mapping)
                      and isinstance(g.get("tip"), list) and all(map(is_number, g["tip"])) else g
                      for g in d["goals"]]
    if isinstance(d.get("defaults"), Mapping) and is_number(d["defaults"].get("depth_mm")):
        d["defaults"] = dict(d["defaults"], depth_mm=d["defaults"]["depth_mm"] * factor)
    return d


def design_from_fold_file(path: str | Path, library: MaterialLibrary | None = None, **kw) -> Design:
    """Read a ``.fold`` file (FOLD 1.1/1.2); the design is named after ``frame_title``,
    ``file_title`` or the file stem. Keyword arguments go to :func:`design_from_fold`."""
    path = Path(path)
    text = read_input_text(path, "a FOLD (JSON) file (.fold)", "json")
    try:
        data = json.loads(text)
    except ValueError as exc:  # JSONDecodeError, or an integer of more than 4300 digits
        raise DesignError(parse_error(exc, text, shown(path), "json")) from None
    return design_from_fold(data, source=str(path), library=library, **kw)
