"""3D swept-panel collision: a broad phase over a panel hierarchy, then conservative
advancement on exact panel distances (:mod:`foldprint.collision.polytope_distance`; FCL's
GJK read coplanar prisms too far apart) for the pairs that come close.

Panels are real solids: the rigid part of the outline (holes kept) extruded to the panel
thickness, split into convex prisms (``fcl.Convex``; python-fcl 0.7's continuous
collision on BVH meshes is unreliable, ``shared/design.md``).

Why no contact is missed between samples: a point of panel i moves relative to panel j by
at most F(t1) - F(t0), F(t) = sum_k lever_k V_k(t) over the hinges k on the tree path i..j,
with configuration-free levers (``motion.py``) and V_k the cumulative total variation of
hinge k's angle (``HingeDrive.variation``). For a hinge tree every angle is monotone
(recovery only grows; an arrested hinge is constant), so V_k(t) = |rho_k(t) - rho_k(0)|;
the closed angles of a loop pattern need not be monotone, and V_k still bounds them.
``SweptChecker.bound_coords`` picks the coordinate: callers pass the trajectory's angles.
An interval [ta, tb] is safe when d(ta) + d(tb) > F(tb) - F(ta): a contact inside would
need both distances to be covered by the motion.

* Broad phase (``candidate_runs``, in ``broadphase``): a binary hierarchy of panel groups, each inside a
  sphere of fixed radius about one of its panels' centroid in every configuration. Pairs of
  groups and time intervals are certified with the sphere distances and the centre motion
  bound (prefix sums along the tree, O(1) per pair), all pairs of one level at once;
  uncertified ones split the bigger group or the interval. A far-apart group pair still
  uncertified over one sample step (long tree paths: the bound grows with the path length
  squared) is re-tested between the samples on 4, 16, 64 sub-intervals before it is split
  into panel pairs. What survives is a list of (panel pair, sample interval) runs.
* Narrow phase (``SweptChecker.first_contact``): per run, exact distances; far apart a pair
  jumps from sample to sample while d(t0) > F(t1) - F(t0); close, an interval is split
  (bisection in continuous time; every panel's pose at a split time by prefix products
  along the tree, computed once per time and shared by the pairs). The pair lever is the
  smaller of the two sides' levers per hinge (the motion relative to the panel in the
  middle of the path). A contact is declared at distance <= the contact tolerance and
  refined to the first touching time within ``time_tol_s``. Splitting stops at
  time_tol_s / 16: an interval that cannot be certified there is reported as a contact
  (conservative), so the work is bounded whatever the coordinates.

Hinge-adjacent panels are not checked: they share the hinge, and under the arc model their
rigid parts stay apart for |rho| <= 180 deg as long as 2R exceeds the thickness (a
design-rule check). Pairs already touching at the start are reported as ``initial``
and skipped.

The searches over every pair (the earliest contact, the smallest distance over poses) and
the checkers kept per process are in :mod:`foldprint.collision.swept_search`.
"""

from __future__ import annotations

import copy

from bisect import bisect_right
from dataclasses import dataclass, field

import fcl
import numpy as np

from ..core.modes import HingeModel, Method
from ..model.derived import scope
from ..model.design import Design
from ..physics.kinematics import TreeTransforms, hinge_frames
from ..physics.hinge_drive import HingeDrive
from ..physics.motion import build_hierarchy, tree_bounds
from .polytope_distance import panel_distance, panel_gap
from .rigid import convex_pieces, prism, rigid_polygons

#: Relative contact tolerance: a fraction of the sheet's size (coordinates of 1e15 mm
#: cannot be resolved to 0.01 mm in double precision).
REL_TOL = 1e-9
#: Certification shrinks every distance by this fraction (the one-sided jump keeps 10 %),
#: and the narrow phase never lets a distance exceed the previous one plus the motion bound
#: between them. The distances are exact (:mod:`~foldprint.collision.polytope_distance`);
#: the margin was sized for FCL's GJK, which read coplanar prisms up to 16 % high far from
#: contact and 0.80 mm for 0.068 mm near it, and is kept as a margin (our choice: it costs
#: a few more splits).
FCL_REL = 0.02
#: The narrow phase computes a pair's motion bound over its first 64 samples, then over
#: BOUND_GROW times as many as it has each time the pair steps past them (our choice: 8
#: needs 3 array passes for a 2000-sample run where doubling needed 6; a pair stopped
#: early computes at most 8 times the samples it reached).
BOUND_GROW = 8
#: Panels up to which every pair's levers are tabled once per design for the compiled
#: screen (our choice: 2,016 pairs, at most 63 hinges a path, <= 2 MB); larger designs
#: gather the levers of their candidate runs at each screen.
LEVER_TABLE_PANELS = 64


class _Lazy:
    """A field given as a value or as a function of nothing that makes it, called on first
    read and its value kept: :attr:`Contact.point` (the centre of the nearest points costs
    more than the narrow phase's walk, and a Monte-Carlo sample's outcome never reads it).
    Equality, ``repr`` and pickling read the value."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return self
        v = obj.__dict__[self.name]
        if callable(v):
            v = obj.__dict__[self.name] = v()
        return v

    def __set__(self, obj, value):
        obj.__dict__[self.name] = value


@dataclass(frozen=True)
class Contact:
    """First contact of a panel pair: time (s), panel indices and ids, a point (mm, world;
    may be given as a function that computes it, called when first read)."""

    time: float
    pair: tuple[int, int]
    panels: tuple[str, str]
    point: tuple[float, float, float]
    distance: float
    method: Method = Method.FCL

    def __getstate__(self):
        return {**self.__dict__, "point": self.point}


Contact.point = _Lazy()  # after the dataclass made its fields (the field has no default)
Contact.point.__set_name__(Contact, "point")


@dataclass
class SweptChecker:
    """Holds the FCL geometry and motion bounds of a design; checks pairs along a drive."""

    design: Design
    model: HingeModel
    drive: HingeDrive | None
    contact_tol_mm: float = 0.01
    time_tol_s: float = 1e-3
    pieces: list = field(default_factory=list)
    n_distance_calls: int = 0
    n_broad_nodes: int = 0  # (group pair, interval)s the broad phase's descent examined

    def __post_init__(self):
        with scope():  # its panels' rigid polygons share one relief of the design, not one each
            self._build()

    def _build(self):
        d = self.design
        self.model = HingeModel(str(self.model))
        self.frames = hinge_frames(d)
        self.pieces = []
        self.rings = []  # each panel's convex pieces (rings, sheet frame): the exact distance's prisms
        verts, offsets = [], [0]  # every panel's prism vertices (panel frame): the compiled screen's
        for i, (p, poly) in enumerate(zip(d.panels, rigid_polygons(d, self.model))):  # bounds (swept3d_kernels)
            objs = []
            self.rings.append(convex_pieces(poly))
            for ring in self.rings[-1]:
                v, f = prism(ring, p.thickness)
                objs.append(fcl.CollisionObject(fcl.Convex(v, len(f) and _count_faces(f), f)))
                verts.append(v.copy())  # a copy: holding FCL's own array changed its distances (measured)
            self.pieces.append(objs)
            offsets.append(offsets[-1] + sum(len(v) for v in verts[len(verts) - len(objs):]))
        self.hull_pts = np.ascontiguousarray(np.concatenate(verts) if verts else np.zeros((0, 3)), float)
        self.hull_off = np.array(offsets, dtype=np.int64)
        # bounds follow the spanning tree; hinges closing loops (tree=False) move nothing
        self.tree = tree_bounds(d, self.model, [f for f in self.frames if f.tree])
        self.hier = build_hierarchy(self.tree)
        pts = np.concatenate([p.outline for p in d.panels])
        extent = float(np.max(np.abs(pts))) + float(np.ptp(pts, axis=0).max())
        self.tol = max(self.contact_tol_mm, REL_TOL * extent)
        self.extent = extent
        self._pairs: dict = {}
        self._lever_table: list = []  # every pair's levers at once (lever_table), shared by with_drive
        self.transforms = TreeTransforms(d, self.model, self.frames)
        self._world: dict = {}  # time -> world poses of every panel (bounded cache)
        self.pair_tables: dict = {}  # the broad phase's static data of group pairs (shared by with_drive)
        self.shared: dict = {}  # the exact distance's prisms (polytope_distance; shared by with_drive)

    def with_drive(self, drive) -> "SweptChecker":
        """This checker's geometry (FCL pieces, tree bounds, hierarchy, transforms, pair
        levers: a function of the design and hinge model only) for another drive, with
        its own per-run state (pose cache, distance count)."""
        other = copy.copy(self)
        other.drive, other._world, other.n_distance_calls, other.n_broad_nodes = drive, {}, 0, 0
        return other

    # -- geometry ---------------------------------------------------------------------
    def bound_coords(self, times, angles: np.ndarray | None = None) -> np.ndarray:
        """Each hinge's monotone coordinate at ``times`` (n_t, n_hinges), which the motion
        bounds difference: the angle itself for a hinge tree (``angles`` when given:
        recovery only grows), the cumulative total variation for a pattern with loops
        (its closed angles need not be monotone)."""
        if getattr(self.drive, "loops", None) is not None:
            return self.drive.variation(times)
        return np.asarray(angles) if angles is not None else self.drive.angles(times)

    def poses_at(self, t: float) -> np.ndarray:
        """World poses (n_panels, 4, 4) at time ``t``: every hinge's transform once and
        prefix products along the tree (:class:`~foldprint.physics.kinematics.TreeTransforms`),
        cached per time, so the pairs bisecting the same sample interval (at the same
        dyadic times) share them."""
        return self._at(t)[0]

    def _at(self, t: float):
        """(world poses, bound coordinates (1, n_hinges)) at time ``t``, cached per time
        with the drive's arrests (they change poses); the angles are evaluated once for both."""
        key = (float(t), tuple(sorted(getattr(self.drive, "frozen_at", {}).items())))
        hit = self._world.get(key)
        if hit is None:
            if len(self._world) >= 64:
                self._world.pop(next(iter(self._world)))
            ang = self.drive.angles_at(t) if hasattr(self.drive, "angles_at") else self.drive.angles([t])
            hit = self._world[key] = (self.transforms.poses(ang)[0], self.bound_coords([t], ang))
        return hit

    def gap(self, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray) -> float:
        """:meth:`distance` without the nearest point. The exact distance of
        :mod:`~foldprint.collision.polytope_distance`, not FCL's: near contact FCL's GJK
        read 0.80 mm for 0.068 mm between coplanar prisms, more than the narrow phase's
        FCL_REL and its 0.9 step factor allow for."""
        self.n_distance_calls += 1
        return panel_gap(self, i, j, pose_i, pose_j)

    def gap_at(self, pair, t: float) -> float:
        """:meth:`gap` of ``pair`` at time ``t`` (poses by :meth:`poses_at`)."""
        w = self.poses_at(t)
        return self.gap(pair[0], pair[1], w[pair[0]], w[pair[1]])

    def distance(self, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray):
        """Minimum distance (mm; 0 when touching) and the nearest point (world): exact
        (:func:`~foldprint.collision.polytope_distance.panel_distance`; :meth:`gap`)."""
        self.n_distance_calls += 1
        return panel_distance(self, i, j, pose_i, pose_j)

    # -- motion bounds ------------------------------------------------------------------
    def _path(self, pair):
        hit = self._pairs.get(pair)
        if hit is None:
            i, j = pair
            t = self.tree
            up_i, down_j, l = path = t.path(i, j)
            idx, lev = t.pair_levers(i, j, t.qp[i] + t.reach[i], t.qp[j] + t.reach[j], path)
            hit = self._pairs[pair] = (up_i, down_j, l, idx, lev)
        return hit

    def levers(self, pair) -> tuple[np.ndarray, np.ndarray]:
        """The hinges on ``pair``'s tree path and their levers (the motion bound's terms:
        F = sum lever |rho - rho_0|), computed once per pair."""
        return self._path(pair)[3:]

    def lever_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """Every panel pair's path hinges and levers (:meth:`levers`) concatenated, and
        where pair (i, j), i < j, starts in them (entry i * n + j, ends at the next
        entry): computed once per design and hinge model, for the compiled screen. None
        past :data:`LEVER_TABLE_PANELS` panels (the screen then gathers its runs' levers)."""
        n = len(self.design.panels)
        if n > LEVER_TABLE_PANELS:
            return None
        if not self._lever_table:
            idx, lev, start = [], [], np.zeros(n * n + 1, np.int64)
            for i in range(n):
                for j in range(n):
                    start[i * n + j] = sum(len(x) for x in idx)
                    if i < j:
                        a, b = self.levers((i, j))
                        idx.append(np.asarray(a, np.int64))
                        lev.append(np.asarray(b, float))
            start[n * n] = sum(len(x) for x in idx)
            self._lever_table.append((np.concatenate(idx) if idx else np.zeros(0, np.int64),
                                      np.concatenate(lev) if lev else np.zeros(0), start))
        return self._lever_table[0]

    def _bound(self, pair, ang0: np.ndarray, ang: np.ndarray) -> np.ndarray:
        _, _, _, idx, lev = self._path(pair)
        if len(idx) == 0:
            return np.zeros(ang.shape[:-1])
        return np.abs(ang[..., idx] - ang0[idx]) @ lev

    def cumulative_motion(self, pair, angles: np.ndarray) -> np.ndarray:
        """F(t) = sum_k lever_k |rho_k(t) - rho_k(0)| on the samples (n_t,). Every hinge
        angle is monotone, so the motion bound over [ta, tb] is exactly F(tb) - F(ta)."""
        return self._bound(pair, angles[0], angles)

    # -- narrow phase -------------------------------------------------------------------
    def first_contact(self, pair: tuple[int, int], times: np.ndarray, angles: np.ndarray,
                      poses: np.ndarray, t_start: float = 0.0) -> Contact | None:
        """Earliest contact of ``pair`` in [t_start, times[-1]], or None."""
        k = int(np.searchsorted(times, t_start - 1e-12))
        if k >= len(times):
            return None
        return self._run(pair, times, angles, poses, k, len(times) - 1, k == 0)

    def _run(self, pair, times, angles, poses, k0: int, k1: int, at_start: bool) -> Contact | None:
        """Earliest contact of ``pair`` in [times[k0], times[k1]] (world poses at samples)."""
        steps = self.steps(pair, times, angles, poses, k0, k1, at_start)
        while True:
            try:
                next(steps)
            except StopIteration as stop:
                return stop.value

    def steps(self, pair, times, angles, poses, k0: int, k1: int, at_start: bool):
        """Generator: yields the sample index each step has certified up to; returns the
        earliest contact in [times[k0], times[k1]] or None.

        Far apart, a pair jumps from sample to sample as far as d(t0) > F(t1) - F(t0)
        allows. Close, [ta, tb] is safe when d(ta) + d(tb) > F(tb) - F(ta); otherwise it
        is split in continuous time."""
        i, j = pair
        ang0 = angles[k0]
        n_run = k1 - k0 + 1
        # the motion bound over the run (Python floats: bisect below), computed as far as the
        # pair gets (64 samples, then GROW times as many): a pair stopped early (a contact
        # elsewhere first) costs about its steps, not its run
        cum = self._bound(pair, ang0, angles[k0:k0 + min(n_run, 64)]).tolist()

        def upto(c):
            while len(cum) <= c < n_run:
                m = len(cum)
                cum.extend(self._bound(pair, ang0, angles[k0 + m:k0 + min(n_run, BOUND_GROW * m)]).tolist())

        k = k0
        d = self.gap(i, j, poses[k, i], poses[k, j])
        if d <= self.tol:
            if at_start:
                point = self.distance(i, j, poses[k][i], poses[k][j])[1]
                return Contact(float(times[k]), pair, self.panel_ids(pair), _pt(point), d, "initial")
            return self._refine(pair, float(times[k]), d)
        while k < k1:
            yield k
            c = k - k0
            target = cum[c] + 0.9 * d
            while True:
                jump = bisect_right(cum, target) - 1
                if jump < len(cum) - 1 or len(cum) >= n_run:
                    break
                upto(len(cum))
            kk = k0 + jump
            if kk >= k1:
                return None  # safe to the end of the run
            if kk > k:
                dprev, cprev = d, cum[c]
                k = kk
                d = self.gap(i, j, poses[k, i], poses[k, j])
                d = min(d, dprev + cum[k - k0] - cprev)  # Lipschitz: no GJK overestimate
                if d <= self.tol:
                    return self._refine(pair, float(times[k]), d)
                continue
            d1 = self.gap(i, j, poses[k + 1, i], poses[k + 1, j])
            upto(c + 1)
            d1 = min(d1, d + cum[c + 1] - cum[c])
            if (d + d1) * (1 - FCL_REL) <= cum[c + 1] - cum[c]:
                hit = self._split(pair, ang0, float(times[k]), d, cum[c],
                                  float(times[k + 1]), d1, cum[c + 1])
                if hit is not None:
                    return hit
            if d1 <= self.tol:
                return self._refine(pair, float(times[k + 1]), d1)
            k, d = k + 1, d1
        return None

    def _split(self, pair, ang0, ta, da, fa, tb, db, fb) -> Contact | None:
        """Earliest contact in [ta, tb] by recursive two-sided certification."""
        if da <= self.tol:
            return self._refine(pair, ta, da)
        if (da + db) * (1 - FCL_REL) > fb - fa:
            return None
        if tb - ta <= self.time_tol_s / 16:
            # not certified at the time resolution: a contact (conservative), bounded work
            return self._refine(pair, ta, da)
        tm = 0.5 * (ta + tb)  # bisect: each level costs one distance
        dm = self.gap_at(pair, tm)
        fm = float(self._bound(pair, ang0, self._at(tm)[1])[0])
        dm = min(dm, da + fm - fa, db + fb - fm)  # Lipschitz: no GJK overestimate
        return (self._split(pair, ang0, ta, da, fa, tm, dm, fm)
                or self._split(pair, ang0, tm, dm, fm, tb, db, fb))

    def _refine(self, pair, t: float, d: float) -> Contact:
        """``t`` is a time with distance <= tol (or uncertified); find the time of actual
        touching (distance <= 0) to within ``time_tol_s`` if it happens within ~4 s."""
        i, j = pair
        lo, hi = t, None
        step = self.time_tol_s
        if d > 0:
            for _ in range(12):  # look ahead in doubling steps
                cand = lo + step
                if self.gap_at(pair, cand) <= 0:
                    hi = cand
                    break
                step *= 2
            if hi is not None:
                while hi - lo > self.time_tol_s:
                    mid = 0.5 * (lo + hi)
                    if self.gap_at(pair, mid) <= 0:
                        hi = mid
                    else:
                        lo = mid
        pose = self.poses_at(lo)  # world point: nearest points at the last safe time
        if hi is not None:
            t, d = hi, 0.0
        return Contact(float(t), pair, self.panel_ids(pair), self.point_of(i, j, pose[i], pose[j]), float(d),
                       Method.FCL)

    def point_of(self, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray):
        """A function giving the nearest point of panels i and j at these poses (a
        :class:`Contact`'s point, computed when read)."""
        pose_i, pose_j = np.array(pose_i, float), np.array(pose_j, float)
        return lambda: _pt(self.distance(i, j, pose_i, pose_j)[1])

    def panel_ids(self, pair):
        return (self.design.panels[pair[0]].id, self.design.panels[pair[1]].id)


def _pt(point) -> tuple[float, float, float]:
    return tuple(float(x) for x in point) if point is not None else (float("nan"),) * 3


def _count_faces(flat: np.ndarray) -> int:
    n, pos = 0, 0
    while pos < len(flat):
        pos += int(flat[pos]) + 1
        n += 1
    return n
