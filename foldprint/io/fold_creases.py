"""The creases of a FOLD crease pattern made hinges: which crease edges between two panels
form one hinge (straight runs of one angle), the line a hinge spans, the refusal of a
crease without a fold angle, and the largest piece of a sheet cut into several. The edge
table is :mod:`foldprint.io.fold_format`'s (duck-typed: ``edges``, ``assign``, ``angle``,
``xy``)."""

from __future__ import annotations

import numpy as np
from shapely.geometry import Polygon

from ..core.constants import tol
from ..core.errors import DesignError


def refuse_unangled(et, creases: list[int], src: str) -> None:
    """A mountain or valley crease without ``edges_foldAngle`` is refused: FOLD reads a bare
    M or V as folded flat (-180 / 180 deg), a target no printed hinge of a pattern with
    loops can reach and rarely the one meant; the target angle is the design's to give
    (docs/input-safety.md)."""
    bare = sorted(i for i in creases if et.angle[i] is None and et.assign[i] in ("M", "V"))
    if not bare:
        return
    shown_ids = ", ".join(map(str, bare[:5])) + (f" and {len(bare) - 5} more" if len(bare) > 5 else "")
    where_ = ("is missing" if all(a is None for a in et.angle)
              else f"has no value (null) for {len(bare)} crease(s)")
    raise DesignError(f"{src}edges_foldAngle {where_}: the mountain/valley creases (edges_vertices {shown_ids}) "
                      "have no target angle; foldprint does not assume FOLD's flat fold (+-180 deg): give "
                      "every crease its fold angle in edges_foldAngle (degrees, + valley, - mountain)")


def straight_runs(et, ids: list[int]) -> list[list[int]]:
    """The creases between one pair of panels split into hinges: edges that meet end to end
    on one line with one fold angle form one hinge (a crease drawn in pieces); pieces on
    other lines, with other angles or separated by a gap (a cut) are hinges of their own.
    Two hinges between the same two panels close a loop of the hinge graph: whether they
    fold together is the loop closure's answer (collinear with one angle: yes; at an angle
    to each other or with opposite angles: they lock), not the reader's."""
    parent = {i: i for i in ids}

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    at_vertex: dict[int, list[int]] = {}
    for i in ids:
        for v in et.edges[i]:
            at_vertex.setdefault(v, []).append(i)
    for v, es in at_vertex.items():
        for a in es:
            for b in es:
                if a < b and et.angle[a] == et.angle[b] and et.assign[a] == et.assign[b] \
                        and collinear_pair(et, a, b):
                    parent[root(a)] = root(b)
    runs: dict[int, list[int]] = {}
    for i in ids:
        runs.setdefault(root(i), []).append(i)
    return sorted(runs.values(), key=min)


def collinear_pair(et, a: int, b: int) -> bool:
    xy = et.xy
    return hinge_line(xy, [et.edges[a], et.edges[b]]) is not None


#: straight pieces end to end between two panels from which a bent crease line is read as a
#: curved crease drawn as a polyline (our choice: two pieces at an angle are two hinges the
#: loop closure locks, a drawing's corner; three or more are the polyline idiom of a curve)
POLYLINE_PIECES = 3


def refuse_polyline(et, runs: list[list[int]], panels: list[str], src: str) -> None:
    """Refuse a curved crease drawn in straight pieces: ``POLYLINE_PIECES`` or more straight
    runs of creases between the same two panels that meet end to end. Rigid panels joined
    along a bent line cannot fold (any two of its pieces lock), and the faceted curve is
    what Origami Simulator's curved-crease examples draw."""
    if len(runs) < POLYLINE_PIECES:
        return
    of_vertex: dict[int, set[int]] = {}
    for k, run in enumerate(runs):
        for i in run:
            for v in et.edges[i]:
                of_vertex.setdefault(v, set()).add(k)
    parent = list(range(len(runs)))

    def root(k: int) -> int:
        while parent[k] != k:
            parent[k] = parent[parent[k]]
            k = parent[k]
        return k

    for ks in of_vertex.values():
        ks = sorted(ks)
        for k in ks[1:]:
            parent[root(k)] = root(ks[0])
    sizes: dict[int, int] = {}
    for k in range(len(runs)):
        sizes[root(k)] = sizes.get(root(k), 0) + 1
    chain = max(sizes.values())
    if chain >= POLYLINE_PIECES:
        raise DesignError(f"{src}panels {panels[0]!r} and {panels[1]!r} are joined along a bent line of {chain} "
                          "straight crease pieces end to end: a curved crease drawn as a polyline; rigid printed "
                          "panels cannot fold along a bent line (it bends the panels, as curved-crease folding "
                          "does): foldprint folds straight creases between rigid panels only")


def hinge_line(xy: np.ndarray, segs: list[list[int]]) -> np.ndarray | None:
    """The segment spanning collinear edges, or None if they are not collinear."""
    pts = xy[np.array(segs).reshape(-1)]
    d = pts[1] - pts[0]
    d = d / np.linalg.norm(d)
    s = (pts - pts[0]) @ d
    off = np.abs((pts - pts[0]) @ np.array([-d[1], d[0]]))
    if off.max() > max(tol.length, 1e-9 * float(np.ptp(s))):
        return None
    return np.array([pts[int(np.argmin(s))], pts[int(np.argmax(s))]])


def largest_piece(panels: list, hinges: list, notes: list) -> tuple[list, list]:
    """The panels joined by creases to the most others (the largest piece of the sheet) and
    their hinges; the other pieces are named in ``notes``. An SVG in Origami Simulator's
    convention may cut a sheet into pieces (black lines inside it, kirigami cuts): each
    piece is a part of its own, and a design is one part."""
    comp = {p["id"]: p["id"] for p in panels}

    def root(x):
        while comp[x] != x:
            comp[x] = comp[comp[x]]
            x = comp[x]
        return x

    for h in hinges:
        comp[root(h["panels"][0])] = root(h["panels"][1])
    sizes: dict[str, int] = {}
    for p in panels:
        sizes[root(p["id"])] = sizes.get(root(p["id"]), 0) + 1
    if len(sizes) < 2:
        return panels, hinges
    area: dict[str, float] = {}
    for p in panels:
        area[root(p["id"])] = area.get(root(p["id"]), 0.0) + Polygon(p["outline"]).area
    big = max(sizes, key=lambda r: (sizes[r], area[r]))  # the most panels, then the most area
    dropped = [p["id"] for p in panels if root(p["id"]) != big]
    notes.append(f"the lines cut the sheet into {len(sizes)} pieces joined by no crease; a design is one part: "
                 f"kept the largest ({sizes[big]} panels), dropped {len(dropped)} panel(s) "
                 f"({', '.join(dropped[:5])}{', ...' if len(dropped) > 5 else ''}); draw one piece per file")
    return ([p for p in panels if root(p["id"]) == big],
            [h for h in hinges if root(h["panels"][0]) == big])
