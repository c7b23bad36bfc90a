"""SVG crease patterns in Origami Simulator's convention as input.

Origami Simulator (Ghassaei et al., 7OSME; ``js/pattern.js``) reads the stroke colour of
every ``path``, ``line``, ``rect``, ``polygon`` and ``polyline``: black border, red
mountain, blue valley, green cut, yellow facet (triangulation, flat), magenta hinge
(unassigned, flat); a crease's fold angle is ``opacity x stroke-opacity x 180`` deg
(mountain negative). Paths may use M/L/H/V/Z (absolute and relative) only, as there.

This reader nodes the segments (splits them where they cross), finds the faces of the
planar graph, writes a FOLD crease pattern and hands it to
:func:`foldprint.io.fold_format.design_from_fold`, so an SVG pattern follows exactly the FOLD
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

from ..model.design import Design
from .design_io import read_text
from ..core.errors import DesignError
from .fold_format import design_from_fold
from ..core.schema import MAX_FACES, MAX_LENGTH_MM, MAX_SVG_DEPTH, MAX_SVG_SEGMENTS
from ..model.materials import MaterialLibrary

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
#: coordinates after the transforms, in user units: 1e7 (10 km at 1 mm per unit, above the
#: schema's 10 m at any document scale down to 1 um per unit); 1e300 overflowed the clustering
MAX_USER_UNITS = 1e7
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
        if not all(math.isfinite(x) and abs(x) < 1e300 for x in a):
            raise DesignError(f"{src}transform {name}({args.strip()[:40]}) has a number out of range")
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
        if not np.isfinite(t).all():
            raise DesignError(f"{src}transform {name}({args.strip()[:40]}) has a number out of range")
        m = m @ t
    _check_matrix(m, src, f"transform {text.strip()[:60]!r}")
    return m


def _check_matrix(m: np.ndarray, src: str, what: str) -> None:
    """A transform must keep the drawing finite and two-dimensional."""
    a = m[:2, :2]
    big = float(np.abs(m).max()) if np.isfinite(m).all() else math.inf
    if big > MAX_USER_UNITS * 1e6:
        raise DesignError(f"{src}{what} scales or moves the drawing out of range (a factor above "
                          f"{MAX_USER_UNITS * 1e6:g}); give every transform a moderate, finite value")
    if abs(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) <= 1e-12 * max(float(np.abs(a).max()), 1e-300) ** 2:
        raise DesignError(f"{src}{what} collapses the drawing (its scale is 0 in some direction); give "
                          "every transform a non-zero scale")


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
            raise DesignError(f"{src}{what}: attribute {name}={v[:40]!r} is not a number")
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

    stack = [(root, np.eye(3), {}, 0)]
    while stack:  # depth first, document order, without recursion (5000 nested <g> are refused)
        el, m, inherited, depth = stack.pop()
        if depth > MAX_SVG_DEPTH:
            raise DesignError(f"{src}elements nested more than {MAX_SVG_DEPTH} levels deep (<{_tag(el)}> at level "
                              f"{depth}); a crease pattern needs a few groups: ungroup in your editor")
        if el.get("transform"):
            m = m @ _matrix(el.get("transform"), src)
            _check_matrix(m, src, f"the transforms down to <{_tag(el)}>")
        inh = dict(inherited)
        for name in ("stroke", "stroke-opacity"):
            v = _prop(el, name, inherited)
            if v is not None:
                inh[name] = v
        tag = _tag(el)
        if tag in ("defs", "metadata", "title", "desc", "namedview", "clipPath", "mask", "symbol"):
            continue
        if tag in ("line", "rect", "polygon", "polyline", "path"):
            count["n"] += 1
            what = f"<{tag}> #{count['n']}" + (f" id={el.get('id')!r}" if el.get("id") else "")
            stroke = (inh.get("stroke") or "").replace(" ", "").lower()
            if stroke in ("", "none"):
                continue
            kind = _KIND.get(stroke)
            if kind is None:
                bad.setdefault(stroke, what)
                continue
            op = _opacity(el, inherited)
            angle = {"M": -180.0 * op, "V": 180.0 * op}.get(kind, 0.0)
            for line in _element_polylines(el, src, what):
                raw = np.array(line, float).reshape(-1, 2)
                with np.errstate(over="ignore", invalid="ignore"):
                    pts = raw @ m[:2, :2].T + m[:2, 2]
                if not (np.isfinite(pts).all() and np.abs(pts).max(initial=0.0) <= MAX_USER_UNITS):
                    k = int(np.argmax(~np.isfinite(pts).all(axis=1) | (np.abs(pts) > MAX_USER_UNITS).any(axis=1)))
                    raise DesignError(f"{src}{what}: point {k} ({raw[k][0]:g}, {raw[k][1]:g}) lies at "
                                      f"({pts[k][0]:g}, {pts[k][1]:g}) after the transforms, outside +-{MAX_USER_UNITS:g} "
                                      "user units; check the coordinates and the transforms")
                for a, b in zip(pts[:-1], pts[1:]):
                    if a[0] != b[0] or a[1] != b[1]:
                        segs.append((a, b, kind, angle, what))
                if len(segs) > MAX_SVG_SEGMENTS:
                    raise DesignError(f"{src}more than {MAX_SVG_SEGMENTS} line segments (at {what}); foldprint "
                                      "reads crease patterns of at most that many segments: simplify the drawing")
        stack.extend((child, m, inh, depth + 1) for child in reversed(list(el)))

    if bad:
        stroke, what = next(iter(bad.items()))
        raise DesignError(f"{src}{what} has stroke colour {stroke!r}, which Origami Simulator's convention "
                          f"does not know ({len(bad)} unknown colour(s): {sorted(bad)}); use "
                          + ", ".join(f"{_COLOURS[k][0]} for {v}" for k, v in _NAMES.items()))
    return segs, factor


def _cluster(pts: np.ndarray, tol: float) -> np.ndarray:
    """Points closer than ``tol`` (transitively) replaced by their cluster's mean.

    The clusters are the connected components of the graph joining points closer than
    ``tol``. That graph can hold n^2/2 edges (2,000 segments drawn on a few distinct
    points: 1.2 GB of pairs), but its components are those of its edges that belong to
    the Euclidean minimum spanning tree, a subgraph of the Delaunay triangulation: so
    exact duplicates are merged first and, beyond a few thousand distinct points, only the
    Delaunay edges (at most 3n) shorter than ``tol`` are joined. O(n log n) time, O(n) memory."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    pts = np.asarray(pts, float)
    if len(pts) == 0:
        return pts.copy()
    uniq, inv = np.unique(pts, axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    n = len(uniq)
    pairs = _close_pairs(uniq, tol)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    lab = label[inv]  # per input point
    counts = np.bincount(lab)
    means = np.stack([np.bincount(lab, weights=pts[:, k]) / counts for k in range(2)], axis=1)
    return means[lab]


#: distinct points up to which the close pairs come straight from a k-d tree
_KDTREE_POINTS = 1000


def _close_pairs(uniq: np.ndarray, tol: float) -> np.ndarray:
    """(k, 2) index pairs of distinct points closer than ``tol`` whose components are those
    of all such pairs: every pair (k-d tree) for few points, else the Delaunay edges."""
    from scipy.spatial import Delaunay, QhullError, cKDTree

    n = len(uniq)
    if n < 2 or tol <= 0:
        return np.zeros((0, 2), int)
    if n <= _KDTREE_POINTS:
        return cKDTree(uniq).query_pairs(tol, output_type="ndarray").reshape(-1, 2)
    centred = uniq - uniq.mean(axis=0)
    try:
        tri = Delaunay(centred)
    except QhullError:  # all points on one line: the spanning tree joins neighbours along it
        order = np.argsort(centred @ np.linalg.svd(centred, full_matrices=False)[2][0])
        edges = np.stack([order[:-1], order[1:]], axis=1)
    else:
        sx = tri.simplices
        edges = np.concatenate([sx[:, [0, 1]], sx[:, [1, 2]], sx[:, [2, 0]]]
                               + ([tri.coplanar[:, [0, 2]]] if len(tri.coplanar) else []))
        # (qhull leaves a point almost on a vertex out of the triangulation, "coplanar";
        # it is joined to that nearest vertex)
    d = np.linalg.norm(uniq[edges[:, 0]] - uniq[edges[:, 1]], axis=1)
    return edges[d < tol]


def _close_undershoots(segs, snap: float, eps: float) -> list:
    """Move an end point that lies within ``snap`` of another segment, but on none, onto
    the nearest such segment (Origami Simulator's snapping of near intersections).
    Vectorised: one bulk tree query for all end points."""
    n = len(segs)
    lines = shapely.linestrings([[a, b] for a, b, *_ in segs])
    ends = np.array([sg[0] for sg in segs] + [sg[1] for sg in segs])
    pts = shapely.points(ends)
    tree = shapely.STRtree(lines)
    pi, sj = tree.query(pts, predicate="dwithin", distance=snap)
    keep = sj != (pi % n)  # not the point's own segment
    pi, sj = pi[keep], sj[keep]
    d = shapely.distance(lines[sj], pts[pi])
    on = np.zeros(2 * n, bool)
    on[pi[d <= eps]] = True
    cand = ~on[pi]
    pi, sj, d = pi[cand], sj[cand], d[cand]
    new = ends.copy()
    if len(pi):
        order = np.lexsort((sj, d, pi))
        first = np.unique(pi[order], return_index=True)[1]
        p_idx, s_idx = pi[order][first], sj[order][first]
        at = shapely.line_interpolate_point(lines[s_idx], shapely.line_locate_point(lines[s_idx], pts[p_idx]))
        new[p_idx] = shapely.get_coordinates(at)
    return [(new[k], new[n + k], *segs[k][2:]) for k in range(n)]


def _node(lines, size: float, src: str):
    """The lines split at every crossing (GEOS). Noding that does not converge on nearly
    overlapping segments (a GEOSException, found by the fuzz campaign) is retried on a grid
    of 1e-9 of the pattern, then refused naming the place."""
    from shapely.errors import GEOSException

    try:
        return shapely.node(lines)
    except GEOSException:
        pass
    try:
        return shapely.node(shapely.set_precision(lines, 1e-9 * max(size, 1.0)))
    except GEOSException as exc:
        near = re.search(r"near ([-\d.e+]+ [-\d.e+]+)", str(exc))
        raise DesignError(f"{src}the lines cannot be split where they cross"
                          + (f" (near {near.group(1)} user units)" if near else "")
                          + ": segments there almost overlap; merge or separate them in your editor") from None


def _unique_segments(segs) -> list:
    """Drop repeats of a segment (same ends in either direction, same kind and angle): a
    path drawn back and forth over one line 1,000 times is that line (it took 1.3 GB)."""
    seen, out = set(), []
    for sg in segs:
        a, b = tuple(sg[0]), tuple(sg[1])
        key = (min(a, b), max(a, b), sg[2], sg[3])
        if key not in seen:
            seen.add(key)
            out.append(sg)
    return out


def crossing_estimate(segs) -> tuple[float, float]:
    """(estimated crossings, its standard error) of the segments, from the crossings of a
    fixed sample of 400 (all of them when fewer): noding and the face search grow with the
    crossings, which a few thousand segments drawn across each other make quadratic. Each
    proper crossing adds one face; ends meeting, T junctions and overlaps add none."""
    n = len(segs)
    lines = shapely.linestrings([[a, b] for a, b, *_ in segs])
    tree = shapely.STRtree(lines)
    idx = np.arange(n) if n <= 400 else np.random.default_rng(0).choice(n, 400, replace=False)
    hits = tree.query(lines[idx], predicate="crosses")  # interiors meet in a point: not a shared
    per = np.bincount(hits[0], minlength=len(idx)).astype(float)  # end, a T or an overlap
    scale = n / len(idx)
    est = per.sum() * scale / 2
    se = per.std() * np.sqrt(len(idx)) * scale / 2 * (np.sqrt(1 - len(idx) / n) if n > 1 else 0.0)
    return float(est), float(se)


def _refuse_dense(segs, src: str) -> None:
    """Refuse a drawing whose crossings alone would make more than MAX_FACES faces."""
    est, se = crossing_estimate(segs)
    if est - 3 * se > MAX_FACES:
        raise DesignError(f"{src}the {len(segs)} line segments cross each other about {est:.3g} times "
                          f"(estimated from a sample, +-{3 * se:.2g}), which makes as many faces, over the "
                          f"{MAX_FACES} foldprint accepts; this is not a crease pattern a printer can "
                          "make: check that the drawing is the crease pattern")


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


_RANK = {"M": 0, "V": 0, "C": 1, "U": 2, "F": 3, "B": 4}  # which assignment wins where lines overlap


class _Vertices:
    """Vertex ids of points merged on a 1e-9 grid, in the order first seen."""

    def __init__(self) -> None:
        self.ids: dict[tuple, int] = {}
        self.coords: list = []

    def id(self, p) -> int:
        key = (round(float(p[0]) / 1e-9), round(float(p[1]) / 1e-9))
        if key not in self.ids:
            self.ids[key] = len(self.coords)
            self.coords.append((float(p[0]), float(p[1])))
        return self.ids[key]


def _svg_root(text: str, src: str):
    """The parsed ``<svg>`` root element."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DesignError(f"{src}not valid SVG/XML: {exc}") from None
    if _tag(root) != "svg":
        raise DesignError(f"{src}the root element is <{_tag(root)}>, not <svg>")
    return root


def _snapped(segs, snap: float, size: float) -> list:
    """The segments with their ends merged within ``snap`` and undershoots closed; segments
    shorter than ``snap`` dropped."""
    pts = np.array([s[0] for s in segs] + [s[1] for s in segs])
    ends = _cluster(pts, snap)
    n = len(segs)
    segs = [(ends[k], ends[n + k]) + tuple(segs[k][2:]) for k in range(n)]
    moved = _close_undershoots(segs, snap, 1e-12 * max(size, 1.0))
    return [sg for sg in moved if np.linalg.norm(sg[1] - sg[0]) > snap]


def _piece_owners(raw: list, tree, segs: list, size: float) -> np.ndarray:
    """The segment each noded piece comes from (the strongest assignment where several
    overlap; -1 for none), one bulk query instead of one per piece."""
    mids = shapely.points([(c[0] + c[-1]) / 2 for c in raw])
    pi, sj = tree.query(mids, predicate="dwithin", distance=1e-9 * max(size, 1.0))
    seg_rank = np.array([_RANK[sg[2]] for sg in segs])
    order = np.lexsort((sj, seg_rank[sj], pi))
    first = np.unique(pi[order], return_index=True)[1]
    owner = np.full(len(raw), -1)
    owner[pi[order][first]] = sj[order][first]
    return owner


def _edge_graph(segs: list, tree, size: float, snap: float, src: str, verts: _Vertices):
    """The segments noded at their crossings: FOLD edges (vertex pairs, each once), their
    assignments and fold angles, and each edge as a line for polygonize."""
    noded = _node(MultiLineString([LineString([a, b]) for a, b, *_ in segs]), size, src)
    raw = [np.asarray(g.coords) for g in getattr(noded, "geoms", [noded])]
    merged = _cluster(np.array([c[0] for c in raw] + [c[-1] for c in raw]), snap)
    piece_ends = [(merged[k], merged[len(raw) + k]) for k in range(len(raw))]
    edges, assign, angles, pieces = [], [], [], []
    seen = {}
    for (e0, e1), best in zip(piece_ends, _piece_owners(raw, tree, segs, size)):
        a, b = verts.id(e0), verts.id(e1)
        if a == b or best < 0:
            continue
        key = (min(a, b), max(a, b))
        if key in seen:
            k0 = seen[key]
            if _RANK[segs[best][2]] < _RANK[assign[k0]]:
                assign[k0], angles[k0] = segs[best][2], segs[best][3]
            continue
        seen[key] = len(edges)
        edges.append([a, b])
        assign.append(segs[best][2])
        angles.append(segs[best][3])
        pieces.append(LineString([verts.coords[a], verts.coords[b]]))
    return edges, assign, angles, pieces


def _faces(pieces: list, verts: _Vertices, size: float, edges: list, assign: list, src: str) -> list:
    """The faces the edges enclose (vertex rings), holes cut out of the sheet dropped."""
    faces = []
    for poly in getattr(shapely.polygonize(pieces), "geoms", []):
        ring = [verts.id(p) for p in np.asarray(poly.exterior.coords)[:-1]]
        if poly.area > 1e-12 * size * size and len(set(ring)) >= 3:
            faces.append(ring)
    faces = _drop_cut_holes(faces, edges, assign)
    if not faces:
        raise DesignError(f"{src}the lines enclose no face: close the border (black) around the pattern")
    return faces


def _check_creases(faces: list, edges: list, assign: list, coords: list, segs: list, tree,
                   snap: float, src: str) -> None:
    """A crease must separate two faces: name the dangling ones in SVG coordinates."""
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
            owner = segs[min(near, key=lambda k: _RANK[segs[k][2]])][4] if len(near) else "a segment"
            raise DesignError(
                f"{src}{owner}: the {_NAMES[assign[i]]} crease from ({coords[a][0]:g}, {coords[a][1]:g}) to "
                f"({coords[b][0]:g}, {coords[b][1]:g}) borders {n} face(s); a crease must run between two "
                "faces: extend it to the border or to another crease, or delete it")


def fold_from_svg(text: str, src: str = "", scale: float | None = None,
                  vertex_tol: float | None = None) -> dict:
    """A FOLD crease-pattern dict (mm) from SVG text."""
    segs, factor = svg_segments(_svg_root(text, src), src)
    if scale is not None:
        if not (isinstance(scale, (int, float)) and math.isfinite(scale) and scale > 0):
            raise DesignError(f"{src}scale must be a number > 0 (mm per SVG user unit), got {scale!r}")
        factor = float(scale)
    if not segs:
        raise DesignError(f"{src}no coloured line found; draw the crease pattern with strokes in Origami "
                          "Simulator's colours (black border, red mountain, blue valley, ...)")
    segs = _unique_segments(segs)
    pts = np.array([s[0] for s in segs] + [s[1] for s in segs])
    size = float(np.ptp(pts, axis=0).max())
    _refuse_dense(segs, src)
    # Origami Simulator merges vertices closer than vertTol = 3 user units and snaps near
    # intersections; we do the same, capped at 0.5 % of the pattern for small documents
    vtol = VERTEX_TOL if vertex_tol is None else float(vertex_tol)
    snap = min(vtol, 0.005 * size)
    segs = _snapped(segs, snap, size)
    tree = shapely.STRtree([LineString([a, b]) for a, b, *_ in segs])
    verts = _Vertices()
    edges, assign, angles, pieces = _edge_graph(segs, tree, size, snap, src, verts)
    faces = _faces(pieces, verts, size, edges, assign, src)
    _check_creases(faces, edges, assign, verts.coords, segs, tree, snap, src)
    span = size * factor
    if not (math.isfinite(factor) and factor > 0 and math.isfinite(span) and span <= MAX_LENGTH_MM):
        raise DesignError(f"{src}the pattern is {size:g} user units wide at {factor:g} mm per unit (from the "
                          f"document's width/viewBox), beyond the {MAX_LENGTH_MM:g} mm foldprint accepts; fix "
                          "width and viewBox or give --scale MM_PER_UNIT")
    xy = [[x * factor, -y * factor] for x, y in verts.coords]  # y up
    faces = [r[::-1] for r in faces]  # keep counter-clockwise after the mirror
    return {"file_spec": 1.2, "file_creator": "foldprint.io.svg_format", "frame_classes": ["creasePattern"],
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
    return design_from_svg(read_text(path, "an SVG crease pattern (.svg)", kind="svg"), str(path), library, **kw)
