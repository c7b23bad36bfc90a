"""SVG crease patterns in Origami Simulator's convention as input.

Origami Simulator (Ghassaei et al., 7OSME; ``js/pattern.js``) reads the stroke colour of
every ``path``, ``line``, ``rect``, ``polygon`` and ``polyline``: black border, red
mountain, blue valley, green cut, yellow facet (triangulation, flat), magenta hinge
(unassigned, flat); a crease's fold angle is ``opacity x stroke-opacity x 180`` deg
(mountain negative). Paths may use M/L/H/V/Z (absolute and relative) only, as there.

This reader nodes the segments (splits them where they cross), finds the faces of the
planar graph, writes a FOLD crease pattern and hands it to
:func:`foldprint.fold_format.design_from_fold`, so an SVG pattern follows exactly the FOLD
rules (facets joined by flat edges form one panel, hinge ids ``e<edge index>``).

Size: the document scale maps user units to mm through the root ``width``/``height``
(units mm, cm, in, pt, pc, px = 1/96 in; none = px, as in SVG) and ``viewBox``;
``scale`` (mm per user unit, ``--scale``) overrides it. The SVG y axis points down; the
pattern is mirrored to foldprint's y-up sheet (the folded shape is then the mirror image
of Origami Simulator's, with the same mountains and valleys).
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from collections.abc import Mapping

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString

from .design import Design
from .design_io import read_text
from .errors import DesignError
from .fold_format import design_from_fold
from .materials import MaterialLibrary

_COLOURS = {
    "B": ("#000000", "#000", "black", "rgb(0,0,0)"),
    "M": ("#ff0000", "#f00", "red", "rgb(255,0,0)"),
    "V": ("#0000ff", "#00f", "blue", "rgb(0,0,255)"),
    "C": ("#00ff00", "#0f0", "lime", "rgb(0,255,0)"),
    "F": ("#ffff00", "#ff0", "yellow", "rgb(255,255,0)"),
    "U": ("#ff00ff", "#f0f", "magenta", "fuchsia", "rgb(255,0,255)"),
}
_KIND = {c: k for k, cs in _COLOURS.items() for c in cs}
_KIND["green"] = "C"  # Origami Simulator accepts "green" for #00ff00
_NAMES = {"B": "border (black)", "M": "mountain (red)", "V": "valley (blue)", "C": "cut (green)",
          "F": "facet (yellow)", "U": "hinge (magenta)"}
_UNITS_MM = {"mm": 1.0, "cm": 10.0, "in": 25.4, "pt": 25.4 / 72, "pc": 25.4 / 6, "px": 25.4 / 96, "": 25.4 / 96}
#: Origami Simulator's default vertex merge tolerance (user units, ``globals.vertTol``)
VERTEX_TOL = 3.0
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _tag(el) -> str:
    return el.tag.rsplit("}", 1)[-1]


def _style(el) -> dict:
    out = {}
    for part in (el.get("style") or "").split(";"):
        k, _, v = part.partition(":")
        if k.strip():
            out[k.strip().lower()] = v.strip()
    return out


def _prop(el, name: str, inherited: dict) -> str | None:
    v = _style(el).get(name) or el.get(name)
    return v if v is not None else inherited.get(name)


def _matrix(text: str | None, src: str) -> np.ndarray:
    """3x3 matrix of an SVG ``transform`` list."""
    m = np.eye(3)
    if not text:
        return m
    for name, args in re.findall(r"(\w+)\s*\(([^)]*)\)", text):
        a = [float(x) for x in re.findall(_NUM, args)]
        t = np.eye(3)
        if name == "matrix" and len(a) == 6:
            t = np.array([[a[0], a[2], a[4]], [a[1], a[3], a[5]], [0, 0, 1]])
        elif name == "translate" and a:
            t[0, 2], t[1, 2] = a[0], a[1] if len(a) > 1 else 0.0
        elif name == "scale" and a:
            t[0, 0], t[1, 1] = a[0], a[1] if len(a) > 1 else a[0]
        elif name == "rotate" and a:
            c, s = math.cos(math.radians(a[0])), math.sin(math.radians(a[0]))
            r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
            if len(a) == 3:
                tr = np.array([[1, 0, a[1]], [0, 1, a[2]], [0, 0, 1]])
                r = tr @ r @ np.linalg.inv(tr)
            t = r
        elif name == "skewX" and a:
            t[0, 1] = math.tan(math.radians(a[0]))
        elif name == "skewY" and a:
            t[1, 0] = math.tan(math.radians(a[0]))
        else:
            raise DesignError(f"{src}transform {name}({args}) is not understood; flatten transforms in your editor")
        m = m @ t
    return m


def _path_polylines(d: str, src: str, what: str) -> list[list[tuple[float, float]]]:
    tokens = re.findall(r"[A-Za-z]|" + _NUM, d or "")
    out, cur, pos, start, cmd = [], [], (0.0, 0.0), (0.0, 0.0), None
    i = 0

    def num():
        nonlocal i
        if i >= len(tokens) or re.match(r"[A-Za-z]", tokens[i]):
            raise DesignError(f"{src}{what}: path data ends early near {' '.join(tokens[max(0, i - 3):i + 1])!r}")
        i += 1
        return float(tokens[i - 1])

    while i < len(tokens):
        if re.match(r"[A-Za-z]", tokens[i]):
            cmd = tokens[i]
            i += 1
            if cmd in "Zz":
                if cur:
                    cur.append(start)
                    out.append(cur)
                cur, pos = [], start
                continue
        if cmd is None:
            raise DesignError(f"{src}{what}: path data must start with a command (M)")
        if cmd not in "MmLlHhVv":
            raise DesignError(f"{src}{what}: path command {cmd!r} (a curve or arc) is not supported; Origami "
                              "Simulator's convention uses straight segments only: flatten curves to lines")
        rel = cmd.islower()
        c = cmd.upper()
        if c in "ML":
            x, y = num(), num()
            p = (pos[0] + x, pos[1] + y) if rel else (x, y)
        elif c == "H":
            x = num()
            p = (pos[0] + x if rel else x, pos[1])
        else:
            y = num()
            p = (pos[0], pos[1] + y if rel else y)
        if c == "M":
            if len(cur) > 1:
                out.append(cur)
            cur, start = [p], p
            cmd = "l" if rel else "L"  # implicit lineto after moveto
        else:
            if not cur:
                cur = [pos]
            cur.append(p)
        pos = p
    if len(cur) > 1:
        out.append(cur)
    return out


def _element_polylines(el, src: str, what: str) -> list[list[tuple[float, float]]]:
    tag = _tag(el)

    def f(name, default=0.0):
        v = el.get(name)
        if v is None:
            return default
        m = re.match(_NUM, v.strip())
        if not m:
            raise DesignError(f"{src}{what}: attribute {name}={v!r} is not a number")
        return float(m.group(0))

    if tag == "line":
        return [[(f("x1"), f("y1")), (f("x2"), f("y2"))]]
    if tag == "rect":
        x, y, w, h = f("x"), f("y"), f("width"), f("height")
        return [[(x, y), (x + w, y), (x + w, y + h), (x, y + h), (x, y)]]
    if tag in ("polygon", "polyline"):
        nums = [float(v) for v in re.findall(_NUM, el.get("points") or "")]
        pts = list(zip(nums[0::2], nums[1::2]))
        if tag == "polygon" and pts:
            pts.append(pts[0])
        return [pts] if len(pts) > 1 else []
    if tag == "path":
        return _path_polylines(el.get("d") or "", src, what)
    return []


def _opacity(el, inherited: dict) -> float:
    o = 1.0
    for name in ("opacity", "stroke-opacity"):
        v = _prop(el, name, {}) if name == "opacity" else _prop(el, name, inherited)
        if v is not None:
            try:
                o *= float(v.strip().rstrip("%")) / (100.0 if v.strip().endswith("%") else 1.0)
            except ValueError:
                pass
    return o


def _length_mm(v: str | None) -> float | None:
    if not v:
        return None
    m = re.fullmatch(r"\s*(" + _NUM + r")\s*([a-z%]*)\s*", v)
    if not m or m.group(2) not in _UNITS_MM:
        return None
    return float(m.group(1)) * _UNITS_MM[m.group(2)]


def svg_segments(root, src: str) -> tuple[list, float]:
    """(segments, mm per user unit): segments are (p0, p1, assignment, angle deg, element)."""
    vb = [float(x) for x in re.findall(_NUM, root.get("viewBox") or "")]
    w_mm = _length_mm(root.get("width"))
    factor = _UNITS_MM["px"]
    if len(vb) == 4 and vb[2] > 0 and w_mm:
        factor = w_mm / vb[2]
    elif w_mm and root.get("width"):
        factor = _UNITS_MM[re.sub(r"[\d.\s+-eE]", "", root.get("width")) or ""] \
            if re.sub(r"[\d.\s+-eE]", "", root.get("width")) in _UNITS_MM else factor
    segs, bad = [], {}
    count = {"n": 0}

    def walk(el, m, inherited):
        m = m @ _matrix(el.get("transform"), src)
        inh = dict(inherited)
        for name in ("stroke", "stroke-opacity"):
            v = _prop(el, name, inherited)
            if v is not None:
                inh[name] = v
        tag = _tag(el)
        if tag in ("defs", "metadata", "title", "desc", "namedview", "clipPath", "mask", "symbol"):
            return
        if tag in ("line", "rect", "polygon", "polyline", "path"):
            count["n"] += 1
            what = f"<{tag}> #{count['n']}" + (f" id={el.get('id')!r}" if el.get("id") else "")
            stroke = (inh.get("stroke") or "").replace(" ", "").lower()
            if stroke in ("", "none"):
                return
            kind = _KIND.get(stroke)
            if kind is None:
                bad.setdefault(stroke, what)
                return
            op = _opacity(el, inherited)
            angle = {"M": -180.0 * op, "V": 180.0 * op}.get(kind, 0.0)
            for line in _element_polylines(el, src, what):
                pts = np.array([m @ [x, y, 1.0] for x, y in line])[:, :2]
                for a, b in zip(pts[:-1], pts[1:]):
                    if np.linalg.norm(b - a) > 0:
                        segs.append((a, b, kind, angle, what))
        for child in el:
            walk(child, m, inh)

    walk(root, np.eye(3), {})
    if bad:
        stroke, what = next(iter(bad.items()))
        raise DesignError(f"{src}{what} has stroke colour {stroke!r}, which Origami Simulator's convention "
                          f"does not know ({len(bad)} unknown colour(s): {sorted(bad)}); use "
                          + ", ".join(f"{_COLOURS[k][0]} for {v}" for k, v in _NAMES.items()))
    return segs, factor


def _cluster(pts: np.ndarray, tol: float) -> np.ndarray:
    """Points closer than ``tol`` (transitively) replaced by their cluster's mean."""
    from scipy.spatial import cKDTree

    parent = np.arange(len(pts))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in cKDTree(pts).query_pairs(tol):
        ri, rj = root(i), root(j)
        if ri != rj:
            parent[ri] = rj
    roots = np.array([root(i) for i in range(len(pts))])
    out = pts.astype(float).copy()
    for r in np.unique(roots):
        idx = roots == r
        out[idx] = pts[idx].mean(axis=0)
    return out


def _drop_cut_holes(faces, edges, assign):
    """Faces bounded only by cut or border edges that share no crease with the rest are
    holes cut out of the sheet (Origami Simulator's removeBorderFaces)."""
    kind = {(min(a, b), max(a, b)): k for (a, b), k in zip(edges, assign)}
    out = []
    for ring in faces:
        ks = {kind.get((min(ring[i], ring[i - 1]), max(ring[i], ring[i - 1]))) for i in range(len(ring))}
        if ks <= {"C", "B"} and "C" in ks:
            continue
        out.append(ring)
    return out


def fold_from_svg(text: str, src: str = "", scale: float | None = None,
                  vertex_tol: float | None = None) -> dict:
    """A FOLD crease-pattern dict (mm) from SVG text."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DesignError(f"{src}not valid SVG/XML: {exc}") from None
    if _tag(root) != "svg":
        raise DesignError(f"{src}the root element is <{_tag(root)}>, not <svg>")
    segs, factor = svg_segments(root, src)
    if scale is not None:
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise DesignError(f"{src}scale must be a number > 0 (mm per SVG user unit), got {scale!r}")
        factor = float(scale)
    if not segs:
        raise DesignError(f"{src}no coloured line found; draw the crease pattern with strokes in Origami "
                          "Simulator's colours (black border, red mountain, blue valley, ...)")
    pts = np.array([s[0] for s in segs] + [s[1] for s in segs])
    size = float(np.ptp(pts, axis=0).max())
    # Origami Simulator merges vertices closer than vertTol = 3 user units and snaps near
    # intersections; we do the same, capped at 0.5 % of the pattern for small documents
    vtol = VERTEX_TOL if vertex_tol is None else float(vertex_tol)
    snap = min(vtol, 0.005 * size)
    ends = _cluster(pts, snap)
    n = len(segs)
    segs = [(ends[k], ends[n + k]) + tuple(segs[k][2:]) for k in range(n)]
    lines = [LineString([a, b]) for a, b, *_ in segs]
    tree = shapely.STRtree(lines)
    moved = []
    for k, (a, b, *rest) in enumerate(segs):  # close undershoots: end points near another segment
        new = []
        for p in (a, b):
            pt = shapely.Point(p)
            near = [j for j in tree.query(pt, predicate="dwithin", distance=snap) if j != k]
            hit = [j for j in near if lines[j].distance(pt) > 1e-12 * max(size, 1.0)]
            if hit and not any(lines[j].distance(pt) <= 1e-12 * max(size, 1.0) for j in near):
                j = min(hit, key=lambda j: lines[j].distance(pt))
                q = lines[j].interpolate(lines[j].project(pt))
                p = np.array([q.x, q.y])
            new.append(p)
        moved.append((new[0], new[1], *rest))
    segs = [sg for sg in moved if np.linalg.norm(sg[1] - sg[0]) > snap]
    lines = [LineString([a, b]) for a, b, *_ in segs]
    noded = shapely.node(MultiLineString(lines))
    tree = shapely.STRtree(lines)
    raw = [np.asarray(g.coords) for g in getattr(noded, "geoms", [noded])]
    allpts = np.array([c[0] for c in raw] + [c[-1] for c in raw])
    merged = _cluster(allpts, snap)
    verts: dict[tuple, int] = {}
    coords: list = []

    def vid(p) -> int:
        key = (round(float(p[0]) / 1e-9), round(float(p[1]) / 1e-9))
        if key not in verts:
            verts[key] = len(coords)
            coords.append((float(p[0]), float(p[1])))
        return verts[key]

    piece_ends = [(merged[k], merged[len(raw) + k]) for k in range(len(raw))]
    edges, assign, angles, pieces = [], [], [], []
    rank = {"M": 0, "V": 0, "C": 1, "U": 2, "F": 3, "B": 4}
    seen = {}
    for c0, (e0, e1) in zip(raw, piece_ends):
        a, b = vid(e0), vid(e1)
        if a == b:
            continue
        c = c0
        mid = shapely.Point((c[0] + c[-1]) / 2)
        owners = [k for k in tree.query(mid, predicate="dwithin", distance=1e-9 * max(size, 1.0))]
        if not owners:
            continue
        best = min(owners, key=lambda k: rank[segs[k][2]])
        key = (min(a, b), max(a, b))
        if key in seen:
            k0 = seen[key]
            if rank[segs[best][2]] < rank[assign[k0]]:
                assign[k0], angles[k0] = segs[best][2], segs[best][3]
            continue
        seen[key] = len(edges)
        edges.append([a, b])
        assign.append(segs[best][2])
        angles.append(segs[best][3])
        pieces.append(LineString([coords[a], coords[b]]))
    faces = []
    for poly in getattr(shapely.polygonize(pieces), "geoms", []):
        ring = [vid(p) for p in np.asarray(poly.exterior.coords)[:-1]]
        if poly.area > 1e-12 * size * size and len(set(ring)) >= 3:
            faces.append(ring)
    faces = _drop_cut_holes(faces, edges, assign)
    if not faces:
        raise DesignError(f"{src}the lines enclose no face: close the border (black) around the pattern")
    # a crease must separate two faces: name the dangling ones in SVG coordinates
    count = {}
    for ring in faces:
        for k in range(len(ring)):
            e = (min(ring[k], ring[k - 1]), max(ring[k], ring[k - 1]))
            count[e] = count.get(e, 0) + 1
    for i, (a, b) in enumerate(edges):
        n = count.get((min(a, b), max(a, b)), 0)
        if assign[i] in "MVU" and n != 2:
            near = tree.query(shapely.Point(np.mean([coords[a], coords[b]], axis=0)),
                              predicate="dwithin", distance=snap)
            owner = segs[min(near, key=lambda k: rank[segs[k][2]])][4] if len(near) else "a segment"
            raise DesignError(
                f"{src}{owner}: the {_NAMES[assign[i]]} crease from ({coords[a][0]:g}, {coords[a][1]:g}) to "
                f"({coords[b][0]:g}, {coords[b][1]:g}) borders {n} face(s); a crease must run between two "
                "faces: extend it to the border or to another crease, or delete it")
    xy = [[x * factor, -y * factor] for x, y in coords]  # y up
    faces = [r[::-1] for r in faces]  # keep counter-clockwise after the mirror
    return {"file_spec": 1.2, "file_creator": "foldprint.svg_format", "frame_classes": ["creasePattern"],
            "frame_unit": "mm", "vertices_coords": xy, "faces_vertices": faces, "edges_vertices": edges,
            "edges_assignment": assign, "edges_foldAngle": angles}


def design_from_svg(text: str, source: str = "", library: MaterialLibrary | None = None,
                    scale: float | None = None, crease_materials: Mapping[str, str] | None = None,
                    **kw) -> Design:
    src = f"{source}: " if source else ""
    fold = fold_from_svg(text, src, scale)
    if not kw.get("default_thickness_mm"):
        kw.pop("default_thickness_mm", None)
    fold["frame_title"] = Path(source).stem if source else "svg"
    return design_from_fold(fold, source=source, library=library, crease_materials=crease_materials, **kw)


def design_from_svg_file(path: str | Path, library: MaterialLibrary | None = None, **kw) -> Design:
    path = Path(path)
    return design_from_svg(read_text(path, "an SVG crease pattern (.svg)"), str(path), library, **kw)
