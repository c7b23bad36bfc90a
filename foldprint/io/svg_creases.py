"""An SVG pattern's line segments (:mod:`foldprint.io.svg_paths`) made a planar crease
graph: ends merged and undershoots snapped as Origami Simulator does, repeats dropped,
drawings too dense refused, the lines split where they cross, each piece given the
strongest assignment drawn over it, the faces found (holes cut out of the sheet dropped)
and every crease checked to run between two faces. :func:`foldprint.io.svg_format.fold_from_svg`
chains these steps into a FOLD crease pattern.
"""

from __future__ import annotations

import re

import numpy as np
import shapely
from shapely.geometry import LineString, MultiLineString

from ..core.errors import DesignError
from ..core.schema import MAX_FACES, MAX_PANELS
from .svg_paths import CREASE_NAMES

def cluster_points(pts: np.ndarray, tol: float) -> np.ndarray:
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
    pairs = close_pairs(uniq, tol)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    lab = label[inv]  # per input point
    counts = np.bincount(lab)
    means = np.stack([np.bincount(lab, weights=pts[:, k]) / counts for k in range(2)], axis=1)
    return means[lab]


#: distinct points up to which the close pairs come straight from a k-d tree
KDTREE_POINTS = 1000


def close_pairs(uniq: np.ndarray, tol: float) -> np.ndarray:
    """(k, 2) index pairs of distinct points closer than ``tol`` whose components are those
    of all such pairs: every pair (k-d tree) for few points, else the Delaunay edges."""
    from scipy.spatial import Delaunay, QhullError, cKDTree

    n = len(uniq)
    if n < 2 or tol <= 0:
        return np.zeros((0, 2), int)
    if n <= KDTREE_POINTS:  # query_pairs keeps pairs at exactly tol too: "closer than" is strict
        return _closer(uniq, cKDTree(uniq).query_pairs(tol, output_type="ndarray").reshape(-1, 2), tol)
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
    return _closer(uniq, edges, tol)


def _closer(uniq: np.ndarray, pairs: np.ndarray, tol: float) -> np.ndarray:
    """The index pairs of ``pairs`` whose points are closer than ``tol`` (strictly)."""
    return pairs[np.linalg.norm(uniq[pairs[:, 0]] - uniq[pairs[:, 1]], axis=1) < tol]


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


def unique_segments(segs) -> list:
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
    """(estimated faces the crossings make, its standard error), from the crossings of a
    fixed sample of 400 segments (all of them when fewer): noding and the face search grow
    with the crossings, which a few thousand segments drawn across each other make
    quadratic. k segments crossing at one point add k - 1 faces (Euler: one vertex, k more
    edges), so each sampled segment counts, per crossing point on it, g / (g + 1) for the g
    others crossing there: one face per simple crossing, and 100 diameters through one
    centre make 99, not 4950. Ends meeting, T junctions and overlaps add none here."""
    n = len(segs)
    ends = np.array([[a, b] for a, b, *_ in segs], dtype=float).reshape(n, 2, 2)
    lines = shapely.linestrings(ends)
    tree = shapely.STRtree(lines)
    idx = np.arange(n) if n <= 400 else np.random.default_rng(0).choice(n, 400, replace=False)
    hits = tree.query(lines[idx], predicate="crosses")  # interiors meet in a point
    p, q = ends[idx[hits[0]]], ends[hits[1]]
    r, d = p[:, 1] - p[:, 0], q[:, 1] - q[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):  # crossing segments are never parallel
        t = ((q[:, 0, 0] - p[:, 0, 0]) * d[:, 1] - (q[:, 0, 1] - p[:, 0, 1]) * d[:, 0]) / (
            r[:, 0] * d[:, 1] - r[:, 1] * d[:, 0])
    at = p[:, 0] + np.nan_to_num(t)[:, None] * r
    grid = 1e-9 * max(float(np.ptp(ends.reshape(-1, 2), axis=0).max()), 1e-300)
    key = np.column_stack([hits[0], np.round(at / grid)])
    _, point, g = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    share = (g / (g + 1.0))[point.ravel()] / g[point.ravel()]  # each of the g partners a share
    per = np.bincount(hits[0], weights=share, minlength=len(idx))
    scale = n / len(idx)
    est = per.sum() * scale
    se = per.std() * np.sqrt(len(idx)) * scale * (np.sqrt(1 - len(idx) / n) if n > 1 else 0.0)
    return float(est), float(se)


def refuse_dense(segs, src: str) -> None:
    """Refuse a drawing whose crossings alone would make more than MAX_FACES faces, or
    whose border and folding creases alone enclose more than MAX_PANELS panels, before
    the lines are split (noding and the face search of a 150 x 150 grid took 40 s)."""
    est, se = crossing_estimate(segs)
    if est - 3 * se > MAX_FACES:
        raise DesignError(f"{src}the {len(segs)} line segments cross each other about {est:.3g} times "
                          f"(estimated from a sample, +-{3 * se:.2g}), which makes as many faces, over the "
                          f"{MAX_FACES} foldprint accepts; this is not a crease pattern a printer can "
                          "make: check that the drawing is the crease pattern")
    # faces between the border and the creases that fold (flat facets and cuts left out, so
    # the count can only fall): at least crossings - segments + 1 of them (Euler), each a panel
    sep = [sg for sg in segs if sg[2] in ("B", "M", "V") or (sg[2] in ("F", "U") and sg[3] != 0)]
    if len(sep) < 2:
        return
    est, se = crossing_estimate(sep) if len(sep) < len(segs) else (est, se)
    low = est - 3 * se - len(sep) + 1
    if low > MAX_PANELS:
        raise DesignError(f"{src}the border and folding creases cross each other about {est:.3g} times "
                          f"(+-{3 * se:.2g}), which encloses at least {low:.3g} panels, over the {MAX_PANELS} "
                          "foldprint accepts; a crease pattern to print has far fewer")


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


class Vertices:
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


def snap_segments(segs, snap: float, size: float) -> list:
    """The segments with their ends merged within ``snap`` and undershoots closed; segments
    shorter than ``snap`` dropped."""
    pts = np.array([s[0] for s in segs] + [s[1] for s in segs])
    ends = cluster_points(pts, snap)
    n = len(segs)
    segs = [(ends[k], ends[n + k]) + tuple(segs[k][2:]) for k in range(n)]
    moved = _close_undershoots(segs, snap, 1e-12 * max(size, 1.0))
    return [sg for sg in moved if np.linalg.norm(sg[1] - sg[0]) > snap]


def _piece_owners(raw: list, tree, segs: list, size: float) -> np.ndarray:
    """The segment each noded piece comes from (the strongest assignment where several
    overlap; -1 for none), one bulk query instead of one per piece."""
    mids = shapely.points([(c[0] + c[-1]) / 2 for c in raw])
    eps = 1e-9 * max(size, 1.0)
    pi, sj = tree.query(mids, predicate="dwithin", distance=eps)
    # a segment that only ends at a piece's midpoint does not run along it (a crease ending
    # on the middle of a border side): it must also pass the piece's quarter points
    lines = tree.geometries
    for f in (0.25, 0.75):
        q = shapely.points([c[0] + f * (c[-1] - c[0]) for c in raw])
        on = shapely.dwithin(lines[sj], q[pi], eps) if len(pi) else np.zeros(0, bool)
        pi, sj = pi[on], sj[on]
    seg_rank = np.array([_RANK[sg[2]] for sg in segs])
    order = np.lexsort((sj, seg_rank[sj], pi))
    first = np.unique(pi[order], return_index=True)[1]
    owner = np.full(len(raw), -1)
    owner[pi[order][first]] = sj[order][first]
    return owner


def build_edge_graph(segs: list, tree, size: float, snap: float, src: str, verts: Vertices):
    """The segments noded at their crossings: FOLD edges (vertex pairs, each once), their
    assignments and fold angles, and each edge as a line for polygonize."""
    noded = _node(MultiLineString([LineString([a, b]) for a, b, *_ in segs]), size, src)
    raw = [np.asarray(g.coords) for g in getattr(noded, "geoms", [noded])]
    merged = cluster_points(np.array([c[0] for c in raw] + [c[-1] for c in raw]), snap)
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
    edges, assign, angles = split_at_dangling_ends(edges, assign, angles, verts, snap)
    pieces = [LineString([verts.coords[a], verts.coords[b]]) for a, b in edges]
    return edges, assign, angles, pieces


def split_at_dangling_ends(edges: list, assign: list, angles: list, verts: Vertices, snap: float):
    """Edges split where another edge ends on them: an end that touches no other end but
    lies within ``snap`` of an edge's interior (a T junction) joins it there. Noding splits
    lines only where GEOS finds them crossing, and an end drawn onto a line (or snapped
    onto it) lies off it by round-off (1e-15 to 1e-3 user units in Origami Simulator's
    examples): unsplit, the crease dangles and borders no face."""
    deg = np.zeros(len(verts.coords), int)
    for a, b in edges:
        deg[a] += 1
        deg[b] += 1
    ends = np.nonzero(deg == 1)[0]
    if not len(ends) or not edges:
        return edges, assign, angles
    xy = np.asarray(verts.coords, float)
    lines = shapely.linestrings(xy[np.asarray(edges)])
    pts = shapely.points(xy[ends])
    pi, ej = shapely.STRtree(lines).query(pts, predicate="dwithin", distance=snap)
    e_arr = np.asarray(edges)
    own = (e_arr[ej, 0] == ends[pi]) | (e_arr[ej, 1] == ends[pi])
    pi, ej = pi[~own], ej[~own]
    inserts: dict[int, list] = {}
    if len(pi):
        d = shapely.distance(lines[ej], pts[pi])
        order = np.lexsort((ej, d, pi))
        first = np.unique(pi[order], return_index=True)[1]
        for k in order[first]:
            e, v = int(ej[k]), int(ends[pi[k]])
            a, b = e_arr[e]
            t = float(shapely.line_locate_point(lines[e], pts[pi[k]], normalized=True))
            near_end = min(np.linalg.norm(xy[v] - xy[a]), np.linalg.norm(xy[v] - xy[b]))
            if 0.0 < t < 1.0 and near_end > snap:
                inserts.setdefault(e, []).append((t, v))
    if not inserts:
        return edges, assign, angles
    out_e, out_a, out_g = [], [], []
    for i, (a, b) in enumerate(edges):
        chain = [a] + [v for _, v in sorted(inserts.get(i, []))] + [b]
        for u, w in zip(chain[:-1], chain[1:]):
            out_e.append([u, w])
            out_a.append(assign[i])
            out_g.append(angles[i])
    return out_e, out_a, out_g


def find_faces(pieces: list, verts: Vertices, size: float, edges: list, assign: list, src: str) -> list:
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


def check_creases(faces: list, edges: list, assign: list, coords: list, segs: list, tree,
                  snap: float, src: str, notes: list | None = None) -> list[int]:
    """What each crease separates: a crease between two faces is kept; one bordering a
    single face lies on the sheet's outline (or a cut's), where nothing is on its other
    side to fold, and is read as border; one bordering none (a stray inside a face, or in
    a hole cut out of the sheet) folds nothing of a rigid panel and is dropped. Both are
    counted in ``notes``. Returns the indices of the edges kept; ``assign`` is updated in
    place. Without ``notes`` any such crease is refused, named in SVG coordinates."""
    count = {}
    for ring in faces:
        for k in range(len(ring)):
            e = (min(ring[k], ring[k - 1]), max(ring[k], ring[k - 1]))
            count[e] = count.get(e, 0) + 1
    keep, on_edge, stray = [], [], []
    for i, (a, b) in enumerate(edges):
        n = count.get((min(a, b), max(a, b)), 0)
        if assign[i] in "MVU" and n != 2:
            if notes is None:
                _refuse_crease(i, n, edges, assign, coords, segs, tree, snap, src)
            (on_edge if n == 1 else stray).append(i)
            if n == 0:
                continue
            assign[i] = "B"
        keep.append(i)
    if on_edge:
        notes.append(f"{len(on_edge)} crease segment(s) lie on the sheet's outline (first from "
                     f"{_at(coords, edges[on_edge[0]])}): nothing is on their other side to fold; read as border")
    if stray:
        notes.append(f"{len(stray)} crease segment(s) separate no two faces (first from "
                     f"{_at(coords, edges[stray[0]])}: a stray inside a face or in a cut-out hole); a rigid "
                     "panel cannot fold along them: dropped")
    return keep


def _at(coords: list, edge) -> str:
    a, b = edge
    return f"({coords[a][0]:g}, {coords[a][1]:g}) to ({coords[b][0]:g}, {coords[b][1]:g}) user units"


def _refuse_crease(i: int, n: int, edges: list, assign: list, coords: list, segs: list, tree, snap: float,
                   src: str) -> None:
    a, b = edges[i]
    near = tree.query(shapely.Point(np.mean([coords[a], coords[b]], axis=0)), predicate="dwithin", distance=snap)
    owner = segs[min(near, key=lambda k: _RANK[segs[k][2]])][4] if len(near) else "a segment"
    raise DesignError(
        f"{src}{owner}: the {CREASE_NAMES[assign[i]]} crease from ({coords[a][0]:g}, {coords[a][1]:g}) to "
        f"({coords[b][0]:g}, {coords[b][1]:g}) borders {n} face(s); a crease must run between two "
        "faces: extend it to the border or to another crease, or delete it")
