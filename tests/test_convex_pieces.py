"""``collision.rigid.convex_pieces``: the convex pieces FCL gets of a panel with holes.

Invariants on random holed polygons (every piece convex and counter-clockwise, the pieces
disjoint, their union the polygon), the piece count against an independent reference (the
pairwise merge the one-pass Hertel-Mehlhorn replaced, kept here), and the size a
perforated panel reaches: 200 holes in well under a second."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
import shapely
from hypothesis import given, settings, strategies as st
from shapely.geometry import Polygon

from foldprint.collision.rigid import convex_pieces


def _convex_ccw(ring: np.ndarray) -> bool:
    """Every corner turns left (or goes straight on), relative tolerance 1e-9."""
    d1 = np.roll(ring, -1, axis=0) - ring
    d2 = np.roll(d1, -1, axis=0)
    cross = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    scale = np.hypot(*d1.T) * np.hypot(*d2.T)
    return len(ring) >= 3 and bool(np.all(cross >= -1e-9 * scale)) and Polygon(ring).area > 0


def _reference_pieces(poly) -> list[Polygon]:
    """The pairwise merge convex_pieces used before: constrained Delaunay triangles, any two
    touching along a side merged while their union is convex, the scan restarted after
    every merge (cubic in the triangles; a reference for the piece count only)."""
    pieces = [Polygon(t.exterior.coords) for t in shapely.constrained_delaunay_triangles(poly).geoms
              if t.area > 1e-12]
    merged = True
    while merged:
        merged = False
        for i in range(len(pieces)):
            for j in range(i + 1, len(pieces)):
                if pieces[i].touches(pieces[j]) and pieces[i].intersection(pieces[j]).length > 1e-9:
                    u = pieces[i].union(pieces[j])
                    if u.geom_type == "Polygon" and not u.interiors:
                        u = shapely.simplify(u, 1e-9)
                        ring = np.asarray(shapely.orient_polygons(u).exterior.coords)[:-1]
                        if _convex_ccw(ring):
                            pieces[i] = u
                            pieces.pop(j)
                            merged = True
                            break
            if merged:
                break
    return pieces


def _assert_partition(poly, rings):
    assert all(_convex_ccw(r) for r in rings)
    pieces = [Polygon(r) for r in rings]
    assert sum(p.area for p in pieces) == pytest.approx(poly.area, rel=1e-9)
    assert shapely.union_all(pieces).symmetric_difference(poly).area <= 1e-9 * poly.area
    tree = shapely.STRtree(pieces)
    for i, j in zip(*tree.query(pieces, predicate="intersects")):
        if i < j:
            assert pieces[i].intersection(pieces[j]).area <= 1e-9 * poly.area


@st.composite
def holed_polygons(draw):
    """A star-shaped outline of 3-13 corners and up to 6 regular holes inside it, apart."""
    n = draw(st.integers(3, 13))
    ang = np.sort(np.array(draw(st.lists(st.floats(0, 2 * math.pi), min_size=n, max_size=n, unique=True))))
    r = np.array(draw(st.lists(st.floats(4, 10), min_size=n, max_size=n)))
    outer = Polygon(np.c_[r * np.cos(ang), r * np.sin(ang)])
    inside = outer.buffer(-0.1)
    holes = []
    for _ in range(draw(st.integers(0, 6))):
        cx, cy = draw(st.floats(-6, 6)), draw(st.floats(-6, 6))
        size, k, turn = draw(st.floats(0.2, 1.5)), draw(st.integers(3, 5)), draw(st.floats(0, 2 * math.pi))
        a = turn + np.arange(k) * 2 * math.pi / k
        h = Polygon(np.c_[cx + size * np.cos(a), cy + size * np.sin(a)])
        if inside.contains(h) and all(h.distance(q) > 0.1 for q in holes):
            holes.append(h)
    poly = Polygon(outer.exterior.coords, [h.exterior.coords for h in holes])
    return poly if poly.is_valid and poly.area > 1.0 else Polygon([(0, 0), (3, 0), (0, 3)])


@settings(max_examples=60, deadline=None)
@given(holed_polygons())
def test_random_holed_polygons_are_partitioned_into_convex_pieces(poly):
    _assert_partition(poly, convex_pieces(poly))


def _grid_holes(nx: int, ny: int, half: float, dx: float = 4.6, dy: float = 9.5):
    """A 100 mm square with nx x ny square holes in rows (their corners in line: pieces
    with straight corners), the perforated panel of test_barhinge_sizes."""
    holes = [((cx - half, cy - half), (cx - half, cy + half), (cx + half, cy + half), (cx + half, cy - half))
             for cx in (4 + dx * i for i in range(nx)) for cy in (5 + dy * j for j in range(ny))]
    return Polygon(((0, 0), (100, 0), (100, 100), (0, 100)), holes)


def _random_small(seed: int):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 14))
    ang = np.sort(rng.uniform(0, 2 * math.pi, n))
    r = rng.uniform(4, 10, n)
    outer = Polygon(np.c_[r * np.cos(ang), r * np.sin(ang)])
    holes = []
    for _ in range(int(rng.integers(0, 6))):
        c, s, k = rng.uniform(-6, 6, 2), rng.uniform(0.2, 1.5), int(rng.integers(3, 6))
        a = rng.uniform(0, 2 * math.pi) + np.arange(k) * 2 * math.pi / k
        h = Polygon(c + s * np.c_[np.cos(a), np.sin(a)])
        if outer.buffer(-0.1).contains(h) and all(h.distance(q) > 0.1 for q in holes):
            holes.append(h)
    return Polygon(outer.exterior.coords, [h.exterior.coords for h in holes])


def test_piece_count_is_that_of_the_pairwise_merge_within_a_quarter():
    """Hertel-Mehlhorn is at most 4x the fewest pieces; on 40 random holed polygons and
    the grid panels it stays within 1.25x the old merge's count on each polygon (measured:
    at most 1.25x, 1.5 % fewer in total on 300 of them) and no more in total."""
    polys = [p for p in map(_random_small, range(40)) if p.is_valid]
    polys += [_grid_holes(3, 2, 1.0), _grid_holes(5, 4, 1.7)]
    new_total = old_total = 0
    for poly in polys:
        new, old = len(convex_pieces(poly)), len(_reference_pieces(poly))
        assert new <= 1.25 * old, poly.wkt
        new_total, old_total = new_total + new, old_total + old
    assert new_total <= old_total


def test_two_hundred_holes_split_in_well_under_a_second():
    """The perforated panel: 200 holes, 804 corners. The old merge took 26-30 CPU-s here
    (load 3-7); the one pass 0.06 CPU-s. The bound leaves 15x for a loaded machine."""
    poly = _grid_holes(20, 10, 1.7)
    t = time.process_time()
    rings = convex_pieces(poly)
    assert time.process_time() - t < 1.0
    _assert_partition(poly, rings)
    assert len(rings) <= 1.25 * (len(poly.interiors) + 3)  # a piece beside each hole, about


@pytest.mark.parametrize("poly,fewest", [
    (Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]), 2),  # an L: one reflex corner
    (Polygon([(0, 0), (4, 0), (4, 1), (3, 1), (3, 3), (1, 3), (1, 1), (0, 1)]), 2),  # a T: bar and stem
    (Polygon([(0, 0), (4, 0), (4, 4), (0, 4)], [[(1, 1), (1, 3), (3, 3), (3, 1)]]), 4),  # a frame
])
def test_small_shapes_get_the_fewest_pieces(poly, fewest):
    """Shapes whose fewest convex pieces are plain (L 2, T 2, a square frame 4: no convex
    piece holds two of a frame's corners across its hole); the reference finds them too."""
    rings = convex_pieces(poly)
    _assert_partition(poly, rings)
    assert len(rings) == fewest == len(_reference_pieces(poly))


def test_holes_with_corners_in_line():
    """Two holes in a strip, their sides on the lines y = 0.5 and 1.5: corners in line make
    straight corners and sides in line; no more pieces than the reference's (which unites
    pieces along any shared run)."""
    poly = Polygon([(0, 0), (6, 0), (6, 2), (0, 2)], [[(1, 0.5), (1, 1.5), (2, 1.5), (2, 0.5)],
                                                      [(4, 0.5), (4, 1.5), (5, 1.5), (5, 0.5)]])
    rings = convex_pieces(poly)
    _assert_partition(poly, rings)
    assert len(rings) <= len(_reference_pieces(poly)) <= 7


def test_a_convex_polygon_is_one_piece_and_an_empty_one_none():
    square = Polygon([(0, 0), (0, 1), (1, 1), (1, 0)])  # clockwise in
    (ring,) = convex_pieces(square)
    assert Polygon(ring).exterior.is_ccw and Polygon(ring).area == pytest.approx(1.0)
    assert convex_pieces(Polygon()) == []
