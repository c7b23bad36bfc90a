"""The broad phase of the swept check (``swept3d``): which non-adjacent panel pairs might
touch in which sample runs, certified apart with sphere distances and the centre motion
bound over a binary hierarchy of panel groups (``candidate_runs``), and the panel pairs
and centres it works on. What survives goes to the narrow phase,
:meth:`foldprint.collision.swept3d.SweptChecker.first_contact`; the method and the proof
that no contact is missed between samples are in ``swept3d``'s docstring.

``checker`` is a :class:`foldprint.collision.swept3d.SweptChecker` (its ``tree``,
``hier``, ``design``, ``transforms``, ``drive`` and ``bound_coords``); it is not imported
here, because ``swept3d`` imports this module.
"""

from __future__ import annotations

import numpy as np

from ..core.jit import use_kernels
from ..model.design import Design


def _adjacent_codes(design: Design) -> np.ndarray:
    idx = design.panel_index()
    n = len(design.panels)
    codes = [min(idx[a], idx[b]) * n + max(idx[a], idx[b]) for a, b in (h.panels for h in design.hinges)]
    return np.array(sorted(codes), dtype=np.int64)


def _adjacent(design: Design) -> set[tuple[int, int]]:
    """Panel index pairs (i < j) that share a hinge."""
    idx = design.panel_index()
    return {tuple(sorted((idx[h.panels[0]], idx[h.panels[1]]))) for h in design.hinges}


def non_adjacent_pairs(design: Design) -> list[tuple[int, int]]:
    adj = _adjacent(design)
    n = len(design.panels)
    return [(i, j) for i in range(n) for j in range(i + 1, n) if (i, j) not in adj]


def count_non_adjacent_pairs(design: Design) -> int:
    """``len(non_adjacent_pairs(design))`` without listing them."""
    n = len(design.panels)
    return n * (n - 1) // 2 - len(_adjacent(design))


def pair_bounds(checker, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """What a sphere lower bound |c_i - c_j| - r_i - r_j of every non-adjacent pair needs
    over ``poses`` (n_t, n, 4, 4): the pairs (m, 2), the panels' world centres (n_t, n, 3)
    and each pair's summed bounding radius (m,); None for a design with no such pair."""
    pairs = np.array(non_adjacent_pairs(checker.design), dtype=np.int64).reshape(-1, 2)
    if len(pairs) == 0:
        return None
    rc = checker.tree.rc
    return pairs, panel_centres(checker, poses), rc[pairs[:, 0]] + rc[pairs[:, 1]]


def panel_centres(checker: SweptChecker, poses: np.ndarray) -> np.ndarray:
    """World centroids (n_t, n, 3) of every panel (the compiled kernel of
    :mod:`foldprint.collision.broadphase_kernels` where :func:`~foldprint.core.jit.use_kernels`)."""
    c = checker.tree.centroid
    if use_kernels() and poses.ndim == 4:
        from .broadphase_kernels import centres

        return centres(np.ascontiguousarray(poses, float), np.ascontiguousarray(c, float))
    R = poses[..., :3, :3]
    return R[..., 0] * c[:, 0, None] + R[..., 1] * c[:, 1, None] + R[..., 2] * c[:, 2, None] + poses[..., :3, 3]


def prefix(tb, angles: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:meth:`foldprint.physics.motion.TreeBounds.prefix` (the compiled kernel of
    :mod:`foldprint.collision.broadphase_kernels` where :func:`~foldprint.core.jit.use_kernels`:
    the same sums in the same order)."""
    if not use_kernels():
        return tb.prefix(angles)
    from .broadphase_kernels import prefix_sums

    h, p, c, y, yw = _prefix_arrays(tb)
    return prefix_sums(np.ascontiguousarray(angles, float), h, p, c, tb.n, y, yw)


def _prefix_arrays(tb):
    """The tree's hinges root outward, as :meth:`TreeBounds.prefix` walks them (index,
    parent, child), and the weights y and y + w: kept with the tree bounds."""
    arrays = tb.__dict__.get("_prefix_arrays")
    if arrays is None:
        fr = tb.frames
        arrays = tb.__dict__["_prefix_arrays"] = (
            np.array([f.index for f in fr], np.int64), np.array([f.parent for f in fr], np.int64),
            np.array([f.child for f in fr], np.int64), np.ascontiguousarray(tb.y, float),
            np.ascontiguousarray(tb.y + tb.widths, float))
    return arrays


#: Sub-intervals per sample interval at each refinement level of the broad phase, and
#: the levels: a far-apart group pair the motion bound cannot certify over one sample step
#: (long tree paths: the bound grows with the square of the path length) is re-tested on
#: 4, 16, 64 sub-intervals (poses by prefix products, in chunks) before it is split into
#: panel pairs for the narrow phase.
REFINE_SUB = 4
REFINE_LEVELS = 3
#: Bytes of world poses the refinement evaluates at once (its working memory).
REFINE_CHUNK_BYTES = 32 * 2 ** 20


def candidate_runs(checker: SweptChecker, angles: np.ndarray, poses: np.ndarray, k_start: int = 0,
                   skip=None, times: np.ndarray | None = None) -> np.ndarray:
    """Broad phase: (m, 4) rows (i, j, ka, kb), i < j, sorted by ka: the sample runs in which
    non-adjacent panels i and j might touch. Every other pair and interval is certified
    apart (sphere distances at both ends exceed the motion bound between them). With
    ``times`` (the samples' times), group pairs that are far apart but not certified over
    one sample step are re-tested between the samples (``REFINE_SUB`` ** level
    sub-intervals) before they reach the narrow phase."""
    tb, H = checker.tree, checker.hier
    n, n_t = tb.n, len(angles)
    excl = _adjacent_codes(checker.design)
    if skip:
        excl = np.union1d(excl, [min(p) * n + max(p) for p in skip]).astype(np.int64)
    angles = np.asarray(angles)
    refine = times is not None
    out, pend = _descend(checker, (angles, angles[0], poses), excl, np.array([H.root]), np.array([H.root]),
                         np.array([k_start]), np.array([n_t - 1]), refine)
    if refine and len(pend[0]):
        times = np.asarray(times, float)
        a, b, ka = pend[0], pend[1], pend[2]
        t0, t1, korig = times[ka], times[ka + 1], ka
        for level in range(REFINE_LEVELS):
            last = level == REFINE_LEVELS - 1
            rows, nxt = _refine(checker, angles[0], excl, a, b, t0, t1, korig, refine=not last)
            out += rows
            a, b, t0, t1, korig = nxt
            if not len(a):
                break
    if not out:
        return np.zeros((0, 4), dtype=np.int64)
    rows = np.concatenate(out).astype(np.int64)
    return _merge_runs(rows, n)


def _refine(checker, ang0, excl, a, b, t0, t1, korig, refine: bool):
    """Re-test group pairs (a, b) on (t0, t1) (inside the sample interval korig) on
    ``REFINE_SUB`` sub-intervals; returns narrow rows on the samples (korig, korig + 1)
    and the pairs still pending (on their sub-intervals)."""
    n = checker.tree.n
    sub = REFINE_SUB
    iv, inv = np.unique(np.column_stack([t0, t1]), axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    per = max(1, REFINE_CHUNK_BYTES // (n * 16 * 8 * 3 * (sub + 1)))  # intervals per chunk
    rows_out, nxt = [], [[], [], [], [], []]
    frac = np.linspace(0.0, 1.0, sub + 1)
    order = np.argsort(inv, kind="stable")
    bounds = np.searchsorted(inv[order], np.arange(0, len(iv) + per, per))
    for c0 in range(0, len(iv), per):
        sel = order[bounds[c0 // per]:bounds[c0 // per + 1]]
        if not len(sel):
            continue
        ivc = iv[c0:c0 + per]
        tg = (ivc[:, :1] + (ivc[:, 1:] - ivc[:, :1]) * frac[None]).ravel()
        coords = checker.bound_coords(tg)
        src = (coords, ang0, checker.transforms.poses(checker.drive.angles(tg)))
        base = (inv[sel] - c0) * (sub + 1)
        out, pend = _descend(checker, src, excl, a[sel], b[sel], base, base + sub, refine)
        ko = korig[sel]
        # local grid index -> interval (block) -> the original sample interval
        blk_k = np.full(len(ivc), -1, dtype=np.int64)
        blk_k[inv[sel] - c0] = ko
        for r in out:
            k = blk_k[r[:, 2] // (sub + 1)]
            rows_out.append(np.column_stack([r[:, 0], r[:, 1], k, k + 1]))
        if len(pend[0]):
            pa, pb, pk = pend
            nxt[0].append(pa)
            nxt[1].append(pb)
            nxt[2].append(tg[pk])
            nxt[3].append(tg[pk + 1])
            nxt[4].append(blk_k[pk // (sub + 1)])
    nxt = [np.concatenate(x) if x else np.zeros(0) for x in nxt]
    nxt[0], nxt[1], nxt[4] = (x.astype(np.int64) for x in (nxt[0], nxt[1], nxt[4]))
    return rows_out, nxt


#: Node pairs of the hierarchy whose static data (:func:`_pair_statics`) the broad phase
#: keeps in tables, filled as the descent meets them (our choice: up to 2**18 pairs, a
#: 256-panel design, ~5 MB; larger designs compute them at every level as they did).
PAIR_TABLE_MAX = 2 ** 18


def _pair_statics(tb, H, excl, a, b):
    """What the descent needs of group pairs (a, b) that does not change with time: the
    reference panels' lca, split panel and side (``TreeBounds.split_panel``), and whether
    the pair is two leaves that must not be checked (adjacent or skipped)."""
    ra, rb = H.ref[a], H.ref[b]
    xc = tb.qp + tb.cen
    l = tb.lca(ra, rb)
    sp, on_a = tb.split_panel(ra, rb, l, xc[ra], xc[rb])
    code = np.minimum(ra, rb) * tb.n + np.maximum(ra, rb)
    dropped = (H.left[a] < 0) & (H.left[b] < 0) & np.isin(code, excl)
    return l, sp, on_a, dropped


class _PairTable:
    """:func:`_pair_statics` of every node pair met, kept in (nodes x nodes) tables for
    one set of exclusions (computed directly, every time, past :data:`PAIR_TABLE_MAX`)."""

    def __init__(self, checker, excl):
        m = len(checker.hier.ref)
        self.tree, self.hier, self.excl, self.m = checker.tree, checker.hier, excl, m
        self.on = m * m <= PAIR_TABLE_MAX
        if self.on:
            self.done = np.zeros(m * m, bool)
            self.l = np.zeros(m * m, np.int64)
            self.sp = np.zeros(m * m, np.int64)
            self.on_a = np.zeros(m * m, bool)
            self.dropped = np.zeros(m * m, bool)

    def get(self, a, b):
        if not self.on:
            return _pair_statics(self.tree, self.hier, self.excl, a, b)
        code = a * self.m + b
        miss = np.unique(code[~self.done[code]])
        if len(miss):
            got = _pair_statics(self.tree, self.hier, self.excl, miss // self.m, miss % self.m)
            for table, v in zip((self.l, self.sp, self.on_a, self.dropped), got):
                table[miss] = v
            self.done[miss] = True
        return self.l[code], self.sp[code], self.on_a[code], self.dropped[code]

    def dense(self):
        """The four tables filled for every node pair (the compiled descent reads them)."""
        if not self.done.all():
            m = self.m
            self.get(np.repeat(np.arange(m), m), np.tile(np.arange(m), m))
        return self.l, self.sp, self.on_a, self.dropped


def _pair_table(checker, excl) -> _PairTable:
    """The checker's :class:`_PairTable` for these exclusions, kept with its geometry (the
    samples of a Monte-Carlo run share it; a few exclusion sets, the latest kept)."""
    tables = checker.pair_tables
    key = excl.tobytes()
    hit = tables.get(key)
    if hit is None:
        if len(tables) >= 4:
            tables.pop(next(iter(tables)))
        hit = tables[key] = _PairTable(checker, excl)
    return hit


def _descend(checker, src, excl, a, b, ka, kb, refine: bool):
    """The hierarchy descent over the grid of ``src`` = (bound coordinates (n_t, n_hinges),
    the coordinates the motion is counted from (n_hinges,), world poses (n_t, n, 4, 4)):
    certified (group pair, interval)s are dropped, others split the interval or the bigger
    group. Returns narrow rows (i, j, ka, kb) and, with ``refine``, the pairs (a, b, k) that
    are far apart but uncertified over one grid step (else they are split down to panel
    pairs)."""
    tb, H = checker.tree, checker.hier
    xc = tb.qp + tb.cen
    margin = 1e-9 * float(H.rad[H.root] + 1.0)
    table = _pair_table(checker, excl)
    if table.on and use_kernels():
        return _descend_compiled(checker, src, table, a, b, ka, kb, refine, xc, margin)
    coords, ref0, poses = src
    P = tuple(x[1:] for x in prefix(tb, np.vstack([np.asarray(ref0)[None], coords])))
    C = panel_centres(checker, poses)
    out, pend = [], [[], [], []]
    while len(a):
        checker.n_broad_nodes += len(a)  # its work: what a Monte-Carlo sample's cost is estimated from
        selfp = a == b
        nxt = []
        s = a[selfp]
        s_ka, s_kb = ka[selfp], kb[selfp]
        inner = H.left[s] >= 0
        s, s_ka, s_kb = s[inner], s_ka[inner], s_kb[inner]
        L, R = H.left[s], H.right[s]
        nxt += [(L, L, s_ka, s_kb), (R, R, s_ka, s_kb), (L, R, s_ka, s_kb)]
        a, b, ka, kb = a[~selfp], b[~selfp], ka[~selfp], kb[~selfp]
        if len(a):
            ra, rb = H.ref[a], H.ref[b]
            l, sp, on_a, dropped = table.get(a, b)
            rsum = H.rad[a] + H.rad[b]
            both_k = np.stack([ka, kb])  # the two ends at once (elementwise: the same numbers)
            dab = np.linalg.norm(C[both_k, ra] - C[both_k, rb], axis=-1) - rsum
            da, db = dab[0], dab[1]
            F = tb.pair_motion(P, both_k, ra, rb, l, xc[ra], xc[rb], sp, on_a)
            dF = F[1] - F[0]
            keep = ~(da + db > dF * (1 + 1e-9) + margin) & ~dropped
            leaf_a, leaf_b = H.left[a] < 0, H.left[b] < 0
            both = leaf_a & leaf_b
            span = kb - ka
            dmin = np.minimum(da, db)
            rmax = np.maximum(np.where(leaf_a, 0.0, H.rad[a]), np.where(leaf_b, 0.0, H.rad[b]))
            far = keep & (dmin > 0) & (both | (dmin > rmax))
            if refine:
                later = far & (span == 1)
                if later.any():
                    pend[0].append(a[later])
                    pend[1].append(b[later])
                    pend[2].append(ka[later])
                    keep &= ~later
            tsplit = far & keep & (span > 1)
            narrow = keep & both & ~tsplit
            nsplit = keep & ~both & ~tsplit
            if narrow.any():
                out.append(np.column_stack([np.minimum(ra, rb)[narrow], np.maximum(ra, rb)[narrow],
                                            ka[narrow], kb[narrow]]))
            if tsplit.any():
                km = (ka[tsplit] + kb[tsplit]) // 2
                nxt += [(a[tsplit], b[tsplit], ka[tsplit], km), (a[tsplit], b[tsplit], km, kb[tsplit])]
            if nsplit.any():
                sa = nsplit & ~leaf_a & (leaf_b | (H.rad[a] >= H.rad[b]))
                sb = nsplit & ~sa
                for m, x, y in ((sa, a, b), (sb, b, a)):
                    if m.any():
                        nxt += [(H.left[x[m]], y[m], ka[m], kb[m]), (H.right[x[m]], y[m], ka[m], kb[m])]
        if not nxt:
            break
        a = np.concatenate([t[0] for t in nxt])
        b = np.concatenate([t[1] for t in nxt])
        ka = np.concatenate([t[2] for t in nxt])
        kb = np.concatenate([t[3] for t in nxt])
    pend = [np.concatenate(x) if x else np.zeros(0, dtype=np.int64) for x in pend]
    return out, pend


def _descend_compiled(checker, src, table, a, b, ka, kb, refine, xc, margin):
    """:func:`_descend` by the compiled kernel (:func:`foldprint.collision.broadphase_kernels.descend`,
    centres and prefix sums at the grid indices it reads): the same rows and pending pairs."""
    from .broadphase_kernels import descend

    H, tb = checker.hier, checker.tree
    coords, ref0, poses = src
    hinge, parent, child, y, yw = _prefix_arrays(tb)
    l, sp, on_a, dropped = table.dense()
    f64 = lambda x: np.ascontiguousarray(x, float)  # noqa: E731
    i64 = lambda x: np.ascontiguousarray(x, np.int64)  # noqa: E731
    rows, pend, nodes = descend(f64(coords), f64(ref0), f64(poses), f64(tb.centroid), hinge, parent, child, y, yw,
                                H.ref, H.rad, H.left, H.right, f64(xc), f64(tb.qp), l, sp, on_a, dropped,
                                i64(a), i64(b), i64(ka), i64(kb), bool(refine), float(margin))
    checker.n_broad_nodes += int(nodes)
    return ([rows] if len(rows) else []), [pend[:, 0], pend[:, 1], pend[:, 2]]


def _merge_runs(rows: np.ndarray, n: int) -> np.ndarray:
    """Merge touching intervals of one pair into runs, sorted by their first sample."""
    code = rows[:, 0] * n + rows[:, 1]
    o = np.lexsort((rows[:, 2], code))
    rows, code = rows[o], code[o]
    start = np.ones(len(rows), dtype=bool)
    start[1:] = (code[1:] != code[:-1]) | (rows[1:, 2] > np.maximum.accumulate(rows[:, 3])[:-1])
    first = np.nonzero(start)[0]
    runs = rows[first].copy()
    runs[:, 3] = np.maximum.reduceat(rows[:, 3], first)
    return runs[np.argsort(runs[:, 2], kind="stable")]

