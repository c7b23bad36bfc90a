"""3D swept-panel collision with python-fcl: conservative advancement on ``fcl.distance``.

Panels are real solids: the rigid part of the outline (holes kept) extruded to the panel
thickness, split into convex prisms (``fcl.Convex``; python-fcl 0.7's continuous
collision on BVH meshes is unreliable, ``shared/design.md``).

Why no contact is missed between samples: between times t0 and t1 every hinge angle is
monotone (recovery only grows; an arrested hinge is constant), so a point of panel i moves
relative to panel j by at most

    D(t0, t1) = sum over hinges k on the tree path i..j of |rho_k(t1) - rho_k(t0)| * r_k

where r_k bounds the distance of the moving panel's points from hinge k's axis (the
chain of panel diameters and hinge widths from the hinge to the panel, plus the arc
hinge's own translation). If the distance d(t0) exceeds D(t0, t1), the panels cannot touch
in [t0, t1]. Each pair advances by the largest such step (on the trajectory's grid, then
by bisection in continuous time), so far-apart pairs take few distance queries and the
first contact is found to within ``contact_tol_mm`` and refined to <= 1 ms.

With loops (rigid origami, :mod:`foldprint.loops`) the closed angles need not be
monotone: they are piecewise linear between the loop solver's grid times, and the bound
uses each angle's cumulative total variation instead of |rho_k(t1) - rho_k(t0)|, which is
exact for that piecewise linear motion (``docs/loops.md``).

Hinge-adjacent panels are not checked: they share the hinge, and under the arc model their
rigid parts stay apart for |rho| <= 180 deg as long as 2R exceeds the thickness (a
design-rule check). Pairs already touching at the start are reported as ``initial``
and skipped.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import fcl
import numpy as np

from .design import Design
from .kinematics import HingeDrive, forward, hinge_frames
from .rigid import convex_pieces, prism, rigid_polygon


@dataclass(frozen=True)
class Contact:
    """First contact of a panel pair: time (s), panel indices and ids, a point (mm, world)."""

    time: float
    pair: tuple[int, int]
    panels: tuple[str, str]
    point: tuple[float, float, float]
    distance: float
    method: str = "fcl"


@dataclass
class SweptChecker:
    """Holds the FCL geometry of a design and checks pairs along a hinge drive."""

    design: Design
    model: str
    drive: HingeDrive
    contact_tol_mm: float = 0.01
    time_tol_s: float = 1e-3
    pieces: list = field(default_factory=list)
    n_distance_calls: int = 0

    def __post_init__(self):
        d = self.design
        self.frames = hinge_frames(d)
        self.pieces = []
        for i, p in enumerate(d.panels):
            objs = []
            for ring in convex_pieces(rigid_polygon(d, i, self.model)):
                v, f = prism(ring, p.thickness)
                objs.append(fcl.CollisionObject(fcl.Convex(v, len(f) and _count_faces(f), f)))
            self.pieces.append(objs)
        self._path, self._radius = self._motion_bounds()

    # -- static bounds --------------------------------------------------------------
    def _motion_bounds(self):
        d = self.design
        n = len(d.panels)
        parent_of = {f.child: f for f in self.frames if f.tree}
        diam = np.array([_diameter(p.outline) for p in d.panels])

        def chain(i):  # hinges from root down to panel i (frames)
            out = []
            while i in parent_of:
                f = parent_of[i]
                out.append(f)
                i = f.parent
            return out[::-1]

        chains = [chain(i) for i in range(n)]
        path, radius = {}, {}
        for i in range(n):
            for j in range(i + 1, n):
                ci, cj = chains[i], chains[j]
                common = 0
                while common < min(len(ci), len(cj)) and ci[common] is cj[common]:
                    common += 1
                idx, rad = [], []
                for side in (ci[common:], cj[common:]):
                    for pos, f in enumerate(side):
                        # panels from this hinge's child down to the end of this side
                        r = sum(diam[g.child] + g.width for g in side[pos:]) + 1.5 * f.width
                        r = min(r, self._flat_radius(f, [g.child for g in side[pos:]]) + 1.5 * f.width)
                        idx.append(f.index)
                        rad.append(r)
                path[(i, j)] = np.array(idx, dtype=int)
                radius[(i, j)] = np.array(rad)
        return path, radius

    def _flat_radius(self, frame, chain_panels: list[int]) -> float:
        """Distance from the hinge axis to the farthest point of the chain's last panel,
        measured in the flat sheet: a valid bound when the chain's region is convex (then
        the straight path lies in the chain, whose rigid pieces and hinges only shorten
        distances when folded); infinity otherwise."""
        import shapely

        key = (frame.index, tuple(chain_panels))
        cache = self.__dict__.setdefault("_flat_cache", {})
        if key in cache:
            return cache[key]
        region = shapely.union_all([self.design.panels[k].polygon for k in chain_panels]
                                   + [self.design.panels[frame.parent].polygon])
        hull = region.convex_hull
        if region.geom_type != "Polygon" or hull.area - region.area > 1e-6 * hull.area:
            cache[key] = np.inf
            return np.inf
        pts = self.design.panels[chain_panels[-1]].outline
        a, b = frame.hinge.line
        d = (b - a) / np.linalg.norm(b - a)
        rel = pts - a
        cache[key] = float(np.max(np.abs(rel[:, 0] * d[1] - rel[:, 1] * d[0])))
        return cache[key]

    # -- queries ----------------------------------------------------------------------
    def poses_at(self, t: float) -> np.ndarray:
        return forward(self.design, self.drive.angles([t]), self.model, self.frames)[0]

    def distance(self, i: int, j: int, pose_i: np.ndarray, pose_j: np.ndarray):
        """Minimum distance (mm; <= 0 when touching) and the nearest point (world)."""
        best, point = np.inf, None
        ti = fcl.Transform(pose_i[:3, :3], pose_i[:3, 3])
        tj = fcl.Transform(pose_j[:3, :3], pose_j[:3, 3])
        for a in self.pieces[i]:
            a.setTransform(ti)
            for b in self.pieces[j]:
                b.setTransform(tj)
                req = fcl.DistanceRequest(enable_nearest_points=True)
                res = fcl.DistanceResult()
                dist = fcl.distance(a, b, req, res)
                self.n_distance_calls += 1
                if dist < best:
                    best = dist
                    point = 0.5 * (np.asarray(res.nearest_points[0]) + np.asarray(res.nearest_points[1]))
                if best <= 0:
                    return 0.0, point
        return float(best), point

    def _bound(self, pair, ang0: np.ndarray, ang: np.ndarray) -> np.ndarray:
        idx = self._path[pair]
        return np.abs(ang[..., idx] - ang0[idx]) @ self._radius[pair]

    def cumulative_motion(self, pair, angles: np.ndarray, times: np.ndarray | None = None) -> np.ndarray:
        """F(t) = sum_k r_k |rho_k(t) - rho_k(0)| on the samples (n_t,). Every hinge angle
        of a tree is monotone, so the motion bound over [ta, tb] is exactly F(tb) - F(ta).
        With loops the closed angles need not be monotone: F then sums the cumulative
        total variation of each angle (``HingeDrive.variation``), still a valid bound."""
        if getattr(self.drive, "loops", None) is not None and times is not None:
            return self.drive.variation(times)[:, self._path[pair]] @ self._radius[pair]
        return self._bound(pair, angles[0], angles)

    def first_contact(self, pair: tuple[int, int], times: np.ndarray, angles: np.ndarray,
                      poses: np.ndarray, t_start: float = 0.0) -> Contact | None:
        """Earliest contact of ``pair`` in [t_start, times[-1]], or None.

        Far apart, a pair jumps from sample to sample as far as the one-sided bound
        d(t0) > F(t1) - F(t0) allows. Close, an interval [ta, tb] is safe when
        d(ta) + d(tb) > F(tb) - F(ta) (a contact inside would need both distances to
        be covered by the motion); otherwise it is split in continuous time."""
        i, j = pair
        cum = self.cumulative_motion(pair, angles, times)
        k = int(np.searchsorted(times, t_start - 1e-12))
        n = len(times)
        if k >= n:
            return None
        d, point = self.distance(i, j, poses[k][i], poses[k][j])
        if d <= self.contact_tol_mm:
            if k == 0:
                return Contact(float(times[k]), pair, self._ids(pair), _pt(point), d, "initial")
            return self._refine(pair, float(times[k]), d, point)
        while k < n - 1:
            kk = int(np.searchsorted(cum, cum[k] + 0.9 * d, side="right")) - 1
            if kk >= n - 1:
                return None  # safe to the end of the trajectory
            if kk > k:
                k = kk
                d, point = self.distance(i, j, poses[k][i], poses[k][j])
                if d <= self.contact_tol_mm:
                    return self._refine(pair, float(times[k]), d, point)
                continue
            d1, p1 = self.distance(i, j, poses[k + 1][i], poses[k + 1][j])
            if d + d1 <= cum[k + 1] - cum[k]:
                hit = self._split(pair, angles[0], float(times[k]), d, point, float(cum[k]),
                                  float(times[k + 1]), d1, p1, float(cum[k + 1]), 0)
                if hit is not None:
                    return hit
            if d1 <= self.contact_tol_mm:
                return self._refine(pair, float(times[k + 1]), d1, p1)
            k, d, point = k + 1, d1, p1
        return None

    def _split(self, pair, ang0, ta, da, pa, fa, tb, db, pb, fb, depth) -> Contact | None:
        """Earliest contact in [ta, tb] by recursive two-sided certification."""
        if da <= self.contact_tol_mm:
            return self._refine(pair, ta, da, pa)
        if da + db > fb - fa:
            return None
        if depth > 40 or tb - ta < 1e-7:
            return self._refine(pair, ta, da, pa) if min(da, db) <= 10 * self.contact_tol_mm else None
        # split into 8 sub-intervals at once (one batched kinematics call)
        ts = np.linspace(ta, tb, 9)[1:-1]
        ang = self.drive.angles(ts)
        poses = forward(self.design, ang, self.model, self.frames)
        fs = self.cumulative_motion(pair, np.vstack([ang0[None], ang]), np.concatenate([[0.0], ts]))[1:]
        prev = (ta, da, pa, fa)
        for m in range(len(ts) + 1):
            if m < len(ts):
                dm, pm = self.distance(pair[0], pair[1], poses[m][pair[0]], poses[m][pair[1]])
                cur = (float(ts[m]), dm, pm, float(fs[m]))
            else:
                cur = (tb, db, pb, fb)
            hit = self._split(pair, ang0, *prev, *cur, depth + 1)
            if hit is not None:
                return hit
            prev = cur
        return None

    def _refine(self, pair, t: float, d: float, point) -> Contact:
        """``t`` is a safe time with distance <= tol; find the time of actual touching
        (distance <= 0) to within ``time_tol_s`` if it happens within a short window."""
        i, j = pair
        lo, hi = t, None
        step = self.time_tol_s
        for _ in range(12):  # look ahead up to ~4 s in doubling steps
            cand = lo + step
            pose = self.poses_at(cand)
            dc, pc = self.distance(i, j, pose[i], pose[j])
            if dc <= 0:
                hi = cand
                break
            point = pc
            step *= 2
        safe_point = point
        if hi is not None:
            while hi - lo > self.time_tol_s:
                mid = 0.5 * (lo + hi)
                pose = self.poses_at(mid)
                dm, pm = self.distance(i, j, pose[i], pose[j])
                if dm <= 0:
                    hi = mid
                else:
                    lo, safe_point = mid, pm
            t, d = hi, 0.0
        point = safe_point if safe_point is not None else point
        return Contact(float(t), pair, self._ids(pair), _pt(point), float(d), "fcl")

    def _ids(self, pair):
        return (self.design.panels[pair[0]].id, self.design.panels[pair[1]].id)


def _pt(point) -> tuple[float, float, float]:
    return tuple(float(x) for x in point) if point is not None else (float("nan"),) * 3


def _count_faces(flat: np.ndarray) -> int:
    n, pos = 0, 0
    while pos < len(flat):
        pos += int(flat[pos]) + 1
        n += 1
    return n


def _diameter(pts: np.ndarray) -> float:
    d = pts[:, None, :] - pts[None, :, :]
    return float(np.sqrt((d**2).sum(-1)).max())


def non_adjacent_pairs(design: Design) -> list[tuple[int, int]]:
    idx = design.panel_index()
    adj = {tuple(sorted((idx[h.panels[0]], idx[h.panels[1]]))) for h in design.hinges}
    n = len(design.panels)
    return [(i, j) for i in range(n) for j in range(i + 1, n) if (i, j) not in adj]


def swept_first_contact(checker: SweptChecker, times, angles, poses, t_start: float = 0.0,
                        skip: set | None = None) -> tuple[Contact | None, list[Contact]]:
    """Earliest contact over all non-adjacent pairs (and the pairs touching initially)."""
    best, initial = None, []
    horizon = times
    for pair in non_adjacent_pairs(checker.design):
        if skip and pair in skip:
            continue
        if best is not None:  # only search up to the best contact found so far
            n = int(np.searchsorted(times, best.time, side="right")) + 1
            horizon = times[:n]
        else:
            n = len(times)
        c = checker.first_contact(pair, horizon, angles[:n], poses[:n], t_start)
        if c is None:
            continue
        if c.method == "initial":
            initial.append(c)
            continue
        if best is None or c.time < best.time:
            best = c
    return best, initial
