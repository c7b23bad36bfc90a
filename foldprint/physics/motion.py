"""Motion bounds along the hinge tree, for the swept collision check.

Every hinge angle is monotone in time (recovery only grows; an arrested hinge is
constant), so over [t_a, t_b] hinge k turns by exactly |rho_k(t_b) - rho_0| - |rho_k(t_a) - rho_0|.
Turning hinge k by d rho moves a point z on one side of it, relative to the other side, by
at most |d rho| * lever(k, z), where lever is a configuration-free bound on the distance
from the hinge to z *along the sheet*:

* a hinge h of flat width w (arc model; 0 under the point model) has a parent-side point
  s_h and a child-side point e_h, the ends of its strip at the fold line's midpoint; inside
  a panel, flat distances between its own points are kept by the rigid motion;
* the arc's chord |s_h - e_h| is at most w, and its tip moves at most w/2 per radian
  (|d tip / d rho| <= w/2), so turning h moves a point z of the child side by at most
  |d rho| (w/2 + |z - e_h|) relative to the parent side, and a point of the parent side
  by at most |d rho| (3w/2 + |z - s_h|) relative to the child side.

Positions along root paths make these bounds prefix sums. With ``mp(v)`` the child-side
point of panel v's parent hinge (the root's centroid for the root), ``Qp(v)`` the summed
in-panel hops and chords from the root to mp(v), and ``Y(h) = Qp(u) + |s_h - mp(u)| + w/2``
(u the parent panel of h):

    lever(h, z in v) <= X(z) - Y(h),   X(z) = Qp(v) + |z - mp(v)|     (h on v's root path)
    dist(z_a, z_b)   <= X(z_a) + X(z_b) - 2 Qp(lca(a, b))              (any configuration)

so a pair's motion bound is O(1) from per-panel cumulative sums A(t, v) = sum |d rho_h|,
B(t, v) = sum |d rho_h| Y(h) and W(t, v) = sum |d rho_h| (Y(h) + w_h) over v's root path
(``TreeBounds.prefix``). Relative motion: any panel s on the path a..b may be held fixed,
the hinges between a and s then move a and the others move b; ``pair_motion`` holds the
panel where the two levers cross (about the middle of the path).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.modes import HingeModel
from ..model.design import Design
from .kinematics import HingeFrame, hinge_frames


@dataclass(frozen=True, eq=False)
class TreeBounds:
    """Static tree data: ``parent`` (n,) panel (-1 at the root), ``hinge`` (n,) parent hinge
    index (-1), ``depth`` (n,), ``up`` (levels, n) binary-lifting ancestors, ``qp`` (n,),
    ``y`` (n_hinges,), ``cen`` (n,) |centroid - mp|, ``reach`` (n,) max |z - mp| over the
    panel's solid (thickness included), ``rc`` (n,) max |z - centroid|, ``centroid`` (n, 3)
    sheet frame, ``order`` (n,) depth-first preorder, ``frames`` in tree order."""

    parent: np.ndarray
    hinge: np.ndarray
    depth: np.ndarray
    up: np.ndarray
    qp: np.ndarray
    y: np.ndarray
    cen: np.ndarray
    reach: np.ndarray
    rc: np.ndarray
    centroid: np.ndarray
    order: np.ndarray
    frames: tuple

    @property
    def n(self) -> int:
        return len(self.parent)

    def lca(self, a, b) -> np.ndarray:
        """Lowest common ancestors of panel arrays ``a`` and ``b`` (vectorised)."""
        a = np.asarray(a, dtype=np.int64).copy()
        b = np.asarray(b, dtype=np.int64).copy()
        swap = self.depth[a] < self.depth[b]
        a[swap], b[swap] = b[swap], a[swap].copy()
        diff = self.depth[a] - self.depth[b]
        for k in range(len(self.up)):
            m = ((diff >> k) & 1).astype(bool)
            a[m] = self.up[k][a[m]]
        for k in range(len(self.up) - 1, -1, -1):
            ua, ub = self.up[k][a], self.up[k][b]
            m = ua != ub
            a[m], b[m] = ua[m], ub[m]
        return np.where(a == b, a, self.up[0][a])

    def prefix(self, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A, B, W (n_t, n): cumulative |rho_h(t) - rho_h(t_0)|, its Y-weighted and its
        (Y + w)-weighted sums over each panel's root path. Monotone hinges make
        A(t_b) - A(t_a) the summed turning."""
        turn = np.abs(angles - angles[:1])
        n_t = len(angles)
        A = np.zeros((n_t, self.n))
        B = np.zeros((n_t, self.n))
        W = np.zeros((n_t, self.n))
        for f in self.frames:  # root outward
            tf = turn[:, f.index]
            A[:, f.child] = A[:, f.parent] + tf
            B[:, f.child] = B[:, f.parent] + tf * self.y[f.index]
            W[:, f.child] = W[:, f.parent] + tf * (self.y[f.index] + self._w[f.index])
        return A, B, W

    def split_panel(self, a, b, l, xa, xb) -> tuple[np.ndarray, np.ndarray]:
        """For pairs (a, b) with lca l and lever origins X = xa, xb: the panel s on the path
        where the levers cross, and whether it lies on a's side (else on b's side)."""
        on_a = (xa - self.qp[l]) >= (xb - self.qp[l])
        near = np.where(on_a, a, b)
        target = 0.5 * (np.where(on_a, xa - xb, xb - xa)) + self.qp[l]
        x = near.copy()
        dl = self.depth[l]
        for k in range(len(self.up) - 1, -1, -1):
            c = self.up[k][x]
            move = (self.depth[c] >= dl) & (self.qp[c] >= target)
            x = np.where(move, c, x)
        return x, on_a

    def pair_motion(self, P, k, a, b, l, xa, xb, s, on_a) -> np.ndarray:
        """Cumulative relative-motion bound F(t_k) of points xa of a and xb of b, holding
        panel s fixed (``split_panel``): the hinges between the near end and s move the
        near end, the others the far end (vectorised over pairs)."""
        A, B, W = P
        near, far = np.where(on_a, a, b), np.where(on_a, b, a)
        xn, xf = np.where(on_a, xa, xb), np.where(on_a, xb, xa)
        t1 = xn * (A[k, near] - A[k, s]) - (B[k, near] - B[k, s])
        t2 = (xf - 2 * self.qp[l]) * (A[k, s] - A[k, l]) + (W[k, s] - W[k, l])
        t3 = xf * (A[k, far] - A[k, l]) - (B[k, far] - B[k, l])
        return t1 + t2 + t3

    def path(self, a: int, b: int) -> tuple[list[int], list[int], int]:
        """Hinge indices from a up to the lca and from the lca down to b, and the lca
        (a walk on Python lists: one pair at a time, the narrow phase's case)."""
        lists = self.__dict__.get("_lists")
        if lists is None:
            lists = self.__dict__["_lists"] = (self.parent.tolist(), self.hinge.tolist(), self.depth.tolist())
        parent, hinge, depth = lists
        a, b = int(a), int(b)
        up_a, down_b = [], []
        while depth[a] > depth[b]:
            up_a.append(hinge[a])
            a = parent[a]
        while depth[b] > depth[a]:
            down_b.append(hinge[b])
            b = parent[b]
        while a != b:
            up_a.append(hinge[a])
            a = parent[a]
            down_b.append(hinge[b])
            b = parent[b]
        return up_a, down_b[::-1], a

    def pair_levers(self, a: int, b: int, xa: float, xb: float, path=None) -> tuple[np.ndarray, np.ndarray]:
        """Hinges on the path a..b and, per hinge, the smaller of its levers to a point of a
        (X = xa) and to a point of b (X = xb): the motion of a relative to b holding the
        path's panel where the two levers cross fixed. Both levers are monotone along the
        path, so one split point realises every per-hinge minimum."""
        up_a, down_b, l = path if path is not None else self.path(a, b)
        idx = np.array(up_a + down_b, dtype=int)
        qpl = self.qp[l]
        q = self.y + self._w
        ua, db = np.array(up_a, dtype=int), np.array(down_b, dtype=int)
        lev_a = np.concatenate([xa - self.y[ua], xa + q[db] - 2 * qpl])
        lev_b = np.concatenate([xb + q[ua] - 2 * qpl, xb - self.y[db]])
        return idx, np.minimum(lev_a, lev_b).reshape(-1)

    @property
    def _w(self) -> np.ndarray:
        return self.__dict__["_wvec"]

    @property
    def widths(self) -> np.ndarray:
        """Each hinge's flat width w (n_hinges,) as the bounds take it (0 under the point model)."""
        return self._w


def tree_bounds(design: Design, model: HingeModel, frames: list[HingeFrame] | None = None) -> TreeBounds:
    frames = frames if frames is not None else [f for f in hinge_frames(design) if f.tree]
    n = len(design.panels)
    nh = len(design.hinges)
    root = design.panel_index()[design.root]
    parent = np.full(n, -1, dtype=np.int64)
    hinge = np.full(n, -1, dtype=np.int64)
    depth = np.zeros(n, dtype=np.int64)
    qp = np.zeros(n)
    y = np.zeros(nh)
    wv = np.zeros(nh)
    centroid = np.zeros((n, 3))
    mp = np.zeros((n, 2))
    for i, p in enumerate(design.panels):
        c = p.polygon.centroid
        centroid[i, :2] = (c.x, c.y)
    mp[root] = centroid[root, :2]
    children: list[list[int]] = [[] for _ in range(n)]
    for f in frames:  # tree order: parents first
        w = f.width if model == HingeModel.ARC else 0.0
        m = f.origin[:2]
        parent[f.child], hinge[f.child] = f.parent, f.index
        depth[f.child] = depth[f.parent] + 1
        sh, eh = m - 0.5 * w * f.normal[:2], m + 0.5 * w * f.normal[:2]
        hop = float(np.hypot(*(sh - mp[f.parent])))
        y[f.index] = qp[f.parent] + hop + 0.5 * w
        wv[f.index] = w
        qp[f.child] = qp[f.parent] + hop + w
        mp[f.child] = eh
        children[f.parent].append(f.child)
    cen = np.hypot(*(centroid[:, :2] - mp).T)
    reach = np.zeros(n)
    rc = np.zeros(n)
    for i, p in enumerate(design.panels):
        h2 = (p.thickness / 2) ** 2
        reach[i] = np.sqrt(np.max(np.sum((p.outline - mp[i]) ** 2, axis=1)) + h2)
        rc[i] = np.sqrt(np.max(np.sum((p.outline - centroid[i, :2]) ** 2, axis=1)) + h2)
    levels = max(1, int(depth.max()).bit_length())
    up = np.zeros((levels, n), dtype=np.int64)
    up[0] = np.where(parent < 0, np.arange(n), parent)
    for k in range(1, levels):
        up[k] = up[k - 1][up[k - 1]]
    order, stack = [], [root]
    while stack:
        v = stack.pop()
        order.append(v)
        stack.extend(reversed(children[v]))
    tb = TreeBounds(parent, hinge, depth, up, qp, y, cen, reach, rc, centroid,
                    np.array(order, dtype=np.int64), tuple(frames))
    tb.__dict__["_wvec"] = wv
    return tb


@dataclass(frozen=True, eq=False)
class Hierarchy:
    """Binary hierarchy over contiguous runs of the depth-first order. Node k holds the
    panels ``order[lo[k]:hi[k]]``, all inside the sphere of radius ``rad[k]`` about the
    centroid of panel ``ref[k]`` in every configuration (a tree-path bound). Leaves have
    ``left == -1`` and are single panels (``ref`` is the panel)."""

    ref: np.ndarray
    rad: np.ndarray
    left: np.ndarray
    right: np.ndarray
    root: int


def build_hierarchy(tb: TreeBounds) -> Hierarchy:
    order = tb.order
    ref, rad, left, right = [], [], [], []

    def node(lo: int, hi: int) -> int:
        k = len(ref)
        ref.append(0)
        rad.append(0.0)
        left.append(-1)
        right.append(-1)
        if hi - lo == 1:
            v = int(order[lo])
            ref[k], rad[k] = v, float(tb.rc[v])
            return k
        r = int(order[(lo + hi) // 2])
        members = order[lo:hi]
        l = tb.lca(np.full(len(members), r), members)
        bound = (tb.qp[r] + tb.cen[r]) + (tb.qp[members] + tb.reach[members]) - 2 * tb.qp[l]
        bound = np.where(members == r, tb.rc[r], bound)
        ref[k], rad[k] = r, float(bound.max())
        mid = (lo + hi) // 2
        left[k] = node(lo, mid)
        right[k] = node(mid, hi)
        return k

    import sys

    old = sys.getrecursionlimit()
    sys.setrecursionlimit(max(old, 10000))
    try:
        root = node(0, len(order))
    finally:
        sys.setrecursionlimit(old)
    return Hierarchy(np.array(ref, dtype=np.int64), np.array(rad), np.array(left, dtype=np.int64),
                     np.array(right, dtype=np.int64), root)
