"""Clearances between non-adjacent panels of the printed geometry: in one pose (the
printed, permanent state: do panels print fused?) and along a trajectory (the margin by
which a fold misses a collision).

Distances are exact (:mod:`foldprint.collision.polytope_distance`, certified to 1e-9 mm
plus 1e-12 of the coordinates) between the solids of
:class:`foldprint.collision.swept3d.SweptChecker` (the rigid parts of the panels under the
hinge model, holes kept, as convex prisms); FCL's GJK read coplanar prisms up to 16 % too
far apart, and 0.80 mm for 0.068 mm near contact, so no reported figure comes from it. In
one pose a vectorised axis-aligned-box prefilter skips the pairs whose boxes are farther
apart than the distance of interest. Along a trajectory the clearance is sampled
(``n_samples`` evenly spaced poses plus the last) and searched by the swept check's own
branch and bound (:func:`foldprint.collision.swept_search.min_clearance`); the earliest
sampled time at which the smallest gap is reached (to :data:`~foldprint.core.constants.tol`
``.length``) is reported. Between samples the swept check, not this module, guarantees that
nothing touches.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.constants import CLEARANCE_SAMPLES, tol
from ..model.derived import scoped
from .broadphase import pair_bounds
from .broadphase import non_adjacent_pairs
from .polytope_distance import panel_distance, panel_gap
from .swept3d import SweptChecker
from .swept_search import min_clearance as swept_min_clearance
from .rigid import rigid_polygons


@dataclass(frozen=True)
class Gap:
    """Distance (mm, 0 when touching) between panels ``pair`` (indices) / ``panels``
    (ids) at ``time`` (s, or None for a static pose), nearest point (world, mm)."""

    distance: float
    pair: tuple[int, int]
    panels: tuple[str, str]
    time: float | None
    point: tuple[float, float, float] | None

    def to_json(self) -> dict:
        out = {"distance_mm": round(float(self.distance), 4), "panels": list(self.panels)}
        if self.time is not None:
            out["time_s"] = round(float(self.time), 4)
        return out


def _piece_vertices(checker: SweptChecker) -> tuple[np.ndarray, np.ndarray]:
    """The vertices of every panel's rigid solid in the sheet frame (m, 3) and the panel
    of each (m,): the same solids the checker's FCL pieces are built from. A panel whose
    hinge strips cover it whole (strips R |rho| wide on a small panel: FP140) has no rigid
    solid and no vertices here; when no panel has one, both arrays are empty."""
    cached = checker.__dict__.get("_clearance_vertices")
    if cached is None:
        pts, owner = [], []
        for i, (p, poly) in enumerate(zip(checker.design.panels, rigid_polygons(checker.design, checker.model))):
            if poly.is_empty:
                continue
            ring = np.asarray(poly.exterior.coords)[:-1]
            for z in (-p.thickness / 2, p.thickness / 2):
                pts.append(np.column_stack([ring, np.full(len(ring), z)]))
                owner.append(np.full(len(ring), i))
        cached = ((np.concatenate(pts), np.concatenate(owner)) if pts
                  else (np.zeros((0, 3)), np.zeros(0, dtype=int)))
        checker.__dict__["_clearance_vertices"] = cached
    return cached


def _boxes(checker: SweptChecker, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World axis-aligned boxes (n_panels, 3) lo and hi of every panel's rigid solid."""
    pts, owner = _piece_vertices(checker)
    world = np.einsum("mij,mj->mi", poses[owner, :3, :3], pts) + poses[owner, :3, 3]
    n = len(poses)
    lo = np.full((n, 3), np.inf)
    hi = np.full((n, 3), -np.inf)
    np.minimum.at(lo, owner, world)
    np.maximum.at(hi, owner, world)
    return lo, hi


def gaps_in_pose(checker: SweptChecker, poses: np.ndarray, within_mm: float,
                 pairs: list[tuple[int, int]] | None = None, time: float | None = None) -> list[Gap]:
    """Every non-adjacent pair closer than ``within_mm`` in one pose ``poses``
    (n_panels, 4, 4), nearest first."""
    design = checker.design
    pairs = pairs if pairs is not None else non_adjacent_pairs(design)
    if not pairs:
        return []
    lo, hi = _boxes(checker, poses)
    a = np.array(pairs)
    sep = np.maximum(lo[a[:, 0]] - hi[a[:, 1]], lo[a[:, 1]] - hi[a[:, 0]]).max(axis=1)
    out = []
    for k in np.nonzero(sep < within_mm)[0]:
        i, j = (int(x) for x in a[k])
        d, point = panel_distance(checker, i, j, poses[i], poses[j])
        if d < within_mm:
            out.append(Gap(max(float(d), 0.0), (i, j), (design.panels[i].id, design.panels[j].id), time,
                           None if point is None else tuple(float(x) for x in point)))
    return sorted(out, key=lambda g: g.distance)


def sampled_poses(n: int, n_samples: int = CLEARANCE_SAMPLES) -> np.ndarray:
    """Indices of the poses :func:`min_clearance` searches among ``n``: ``n_samples``
    evenly spaced, the last always in (a caller that needs only these poses makes only
    these: the margin screen's scattered folds)."""
    n = max(int(n), 1)
    return np.unique(np.r_[np.linspace(0, n - 1, min(n, n_samples)).round().astype(int), n - 1])


def min_clearance(checker: SweptChecker, times: np.ndarray, poses: np.ndarray,
                  n_samples: int = CLEARANCE_SAMPLES, t_end: float | None = None) -> Gap | None:
    """The smallest gap between non-adjacent panels over ``n_samples`` poses of the
    trajectory up to ``t_end`` (default: its end), or None for a design with no such pair
    (or none whose panels both keep a rigid part beside their hinge strips).
    The search over those poses is :func:`foldprint.collision.swept_search.min_clearance` (exact,
    branch and bound on sphere bounds); this adds the sampling, the time and the point."""
    n = len(times) if t_end is None else int(np.searchsorted(times, t_end, side="right"))
    ks = sampled_poses(n, n_samples)
    found = swept_min_clearance(checker, poses[ks])
    if found is None or found[1] is None:  # no pair, or no pair with a rigid solid on both sides
        return None
    best, (i, j), k = found
    k, (i, j) = earliest_within(checker, poses[ks[:k + 1]], float(best) + tol.length) or (k, (i, j))
    pose = poses[ks[k]]
    dist, point = panel_distance(checker, i, j, pose[i], pose[j])
    design = checker.design
    return Gap(max(float(dist), 0.0), (i, j), (design.panels[i].id, design.panels[j].id), float(times[ks[k]]),
               None if point is None else tuple(float(x) for x in point))


def earliest_within(checker: SweptChecker, poses: np.ndarray, within_mm: float, chunk: int = 1 << 19):
    """``(pose index, (i, j))`` of the first of ``poses`` (n_t, n, 4, 4) where a
    non-adjacent pair is at most ``within_mm`` apart (exact distance; sphere bounds
    skip the pairs that cannot be), or None. A fold often rests on its smallest gap for a
    while (a lid on its stop): this is when that gap is first reached, not whichever pose
    of the plateau holds its last bits of round-off. The bounds are made about ``chunk``
    (pose, pair) bounds at a time, in time order, as the clearance search makes them
    (all at once they held 24 B per pose and pair: 810 MiB for a 1000-panel strip)."""
    bounds = pair_bounds(checker, poses)
    if bounds is None:
        return None
    pairs, C, r_pair = bounds
    step = max(1, chunk // len(pairs))
    for k0 in range(0, len(poses), step):
        lb = np.linalg.norm(C[k0:k0 + step, pairs[:, 0]] - C[k0:k0 + step, pairs[:, 1]], axis=-1) - r_pair
        for dk, row in enumerate(lb):
            k = k0 + dk
            for m in np.nonzero(row <= within_mm)[0]:
                i, j = (int(x) for x in pairs[m])
                if panel_gap(checker, i, j, poses[k][i], poses[k][j]) <= within_mm:
                    return k, (i, j)
    return None


@scoped
def permanent_crossings(design) -> list[tuple[str, str]]:
    """Pairs of non-adjacent panels that overlap in the printed (permanent) state of the
    printed geometry (arc hinges at their target angles): such a part can never be printed
    as designed, and no hinge order or material can fold it."""
    from ..physics.kinematics import forward, target_angles
    from ..core.modes import HingeModel

    checker = SweptChecker(design, HingeModel.ARC, None)
    poses = forward(design, target_angles(design)[None], HingeModel.ARC)[0]
    # within a hair of 0: overlapping solids are at distance 0
    return [g.panels for g in gaps_in_pose(checker, poses, 1e-9) if g.distance <= 0.0]
