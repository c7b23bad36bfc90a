"""The paper's collision index for planar designs (Mao et al. 2015, Eq. 5-6, Methods).

Every panel is a segment in the side view. For panels i and j, C_ij is the intersection of
their lines; S_i and S_j are its normalised positions along each segment, and
S_ij = S_i * S_j. The paper flags a collision when 0 < S_ij < 1 except in three cases:
(1) 0 < S_i < 1 and S_j > 1, (2) 0 < S_j < 1 and S_i > 1, (3) S_i < 0 and S_j < 0.
Parallel segments have no intersection point: collinear ones that overlap are a contact,
the others are not (their index is NaN).

Vectorised over time steps and pairs: without holes (one segment per panel) each panel's
pairs are one (pairs, steps) block; with holes one padded broadcast over segment pairs,
chunked over pairs. Hinge-adjacent panels are excluded from contact
(they share the hinge; ``docs/simulation.md``) but their index is kept for plots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.modes import HingeModel
from ..model.design import Design
from ..physics.kinematics import Trajectory
from .rigid import side_segments

_EPS = 1e-12


def index_arrays(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray):
    """S_i, S_j (any broadcastable shape (..., 2) inputs) and masks.

    Returns ``(s_i, s_j, parallel, collinear_overlap)``; s_i and s_j are NaN where the
    segments are parallel.
    """
    return index_components(p1[..., 0], p1[..., 1], p2[..., 0], p2[..., 1],
                            q1[..., 0], q1[..., 1], q2[..., 0], q2[..., 1])


def _collinear_overlap(ax, ay, bx, by, cx, cy, l0):
    """Parallel segment pairs: segment q (from p1 to its ends b, c) lies on the line of p
    (direction a, length l0) within a tolerance and overlaps p in 1-D."""
    lp = np.maximum(l0, _EPS)
    off = np.abs(bx * ay - by * ax) / lp
    ux, uy = ax / lp, ay / lp
    b0 = bx * ux + by * uy
    b1 = cx * ux + cy * uy
    overlap = np.minimum(lp, np.maximum(b0, b1)) - np.maximum(0.0, np.minimum(b0, b1)) > 1e-9
    return (off <= 1e-9 * np.maximum(lp, 1.0)) & overlap


def index_components(p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y):
    """:func:`index_arrays` on separate coordinate arrays (contiguous, so fast): Eq. 5 with
    C_ij the crossing of the two lines, S_i = (r x dq) / (dp x dq), S_j = (r x dp) / (dp x dq)."""
    dpx, dpy = p2x - p1x, p2y - p1y
    dqx, dqy = q2x - q1x, q2y - q1y
    rx, ry = q1x - p1x, q1y - p1y
    denom = dpx * dqy - dpy * dqx
    lp0 = np.sqrt(dpx * dpx + dpy * dpy)
    scale = lp0 * np.sqrt(dqx * dqx + dqy * dqy)
    parallel = np.abs(denom) <= 1e-9 * np.maximum(scale, _EPS)
    safe = np.where(parallel, 1.0, denom)
    s_i = np.where(parallel, np.nan, (rx * dqy - ry * dqx) / safe)
    s_j = np.where(parallel, np.nan, (rx * dpy - ry * dpx) / safe)
    parallel = np.asarray(parallel)
    coll = np.zeros(parallel.shape, dtype=bool)
    if parallel.ndim == 0:  # scalars: the same arithmetic on 1-element arrays
        s_i, s_j, par, c = index_components(*(np.atleast_1d(a) for a in (p1x, p1y, p2x, p2y, q1x, q1y, q2x, q2y)))
        return s_i[0], s_j[0], par[0], c[0]
    if parallel.any():  # collinear: q1 on the line of p (within a tolerance), then 1-D overlap
        sel = np.nonzero(parallel)
        b = [np.broadcast_to(a, parallel.shape)[sel] for a in (dpx, dpy, rx, ry, q2x - p1x, q2y - p1y, lp0)]
        coll[sel] = _collinear_overlap(*b)
    return s_i, s_j, parallel, coll


def paper_contact(s_i: np.ndarray, s_j: np.ndarray) -> np.ndarray:
    """The paper's rule: 0 < S_ij < 1 and none of the three exceptions (1) 0 < S_i < 1 and
    S_j > 1, (2) 0 < S_j < 1 and S_i > 1, (3) S_i < 0 and S_j < 0.

    Evaluated in the equivalent form 0 < S_ij < 1, 0 < S_i <= 1, S_j <= 1: with S_ij > 0
    the signs agree, S_i > 0 removes (3), and for two positive factors with a product
    below 1, "not (1) and not (2)" is exactly S_i <= 1 and S_j <= 1 (NaN gives False)."""
    with np.errstate(invalid="ignore"):
        s_ij = s_i * s_j
        return (s_ij > 0) & (s_ij < 1) & (s_i > 0) & (s_i <= 1) & (s_j <= 1)


@dataclass(frozen=True, eq=False)
class Index2D:
    """Per-pair collision-index history.

    ``pairs`` (n_pairs, 2) panel indices (i < j); ``s_ij`` (n_t, n_pairs) the paper's
    index (min over sub-segments where a panel has holes); ``contact`` (n_t, n_pairs);
    ``adjacent`` (n_pairs,) hinge-adjacent pairs (never counted as contact).
    """

    times: np.ndarray
    pairs: np.ndarray
    s_ij: np.ndarray
    contact: np.ndarray
    adjacent: np.ndarray

    def first_contact(self) -> tuple[int, int] | None:
        """(time index, pair index) of the first contact, or None."""
        hit = self.contact & ~self.adjacent[None]
        rows = np.nonzero(hit.any(axis=1))[0]
        if len(rows) == 0:
            return None
        k = int(rows[0])
        return k, int(np.nonzero(hit[k])[0][0])


def world_side_segments(design: Design, poses: np.ndarray, model: HingeModel):
    """World side-view segments: list over panels of (n_t, k, 2, 2) arrays in (x, z)."""
    return _world(side_segments(design, model), poses)


def _world(sheet, poses):
    out = []
    for i, segs in enumerate(sheet):
        if len(segs) == 0:
            out.append(np.zeros((poses.shape[0], 0, 2, 2)))
            continue
        x, y = segs.reshape(-1, 2).T  # sheet points at z = 0
        P = poses[:, i]
        wx = P[:, 0, 0, None] * x + P[:, 0, 1, None] * y + P[:, 0, 3, None]
        wz = P[:, 2, 0, None] * x + P[:, 2, 1, None] * y + P[:, 2, 3, None]
        out.append(np.stack([wx, wz], axis=-1).reshape(poses.shape[0], len(segs), 2, 2))
    return out


def adjacent_pairs(design: Design) -> set[tuple[int, int]]:
    idx = design.panel_index()
    return {tuple(sorted((idx[h.panels[0]], idx[h.panels[1]]))) for h in design.hinges}


#: Working memory (bytes) one chunk of pairs may use beyond the output arrays.
CHUNK_BYTES = 64 * 2**20
#: float64 temporaries alive at once per (time, pair, sub-segment pair) in one chunk.
_TEMPS = 40
#: float64 arrays per (time step, panel segment) alive for the whole call (world ends, directions, lengths, rows of poses).
_PANEL_TERMS = 18


def index_memory_bytes(n_steps: int, n_pairs: int, max_segments: int = 1,
                       chunk_bytes: int = CHUNK_BYTES) -> int:
    """Peak memory (bytes) of :func:`collision_index` for ``n_steps`` samples and ``n_pairs``
    panel pairs whose panels have at most ``max_segments`` side-view segments: the output
    (S_ij float64 and contact bool per step and pair) plus one chunk's temporaries (at
    most ``chunk_bytes``). A guard can refuse a design before it starts."""
    out = n_steps * n_pairs * (8 + 1)
    per_pair = n_steps * max_segments**2 * 8 * _TEMPS
    n_panels = round((1 + (1 + 8 * n_pairs) ** 0.5) / 2)
    per_panel = n_steps * 8 * _PANEL_TERMS * max_segments * max(n_panels, 1)  # world ends, directions, ...
    return int(out + min(chunk_bytes, per_pair * max(n_pairs, 1)) + per_panel)


def collision_index(traj: Trajectory, chunk_bytes: int = CHUNK_BYTES) -> Index2D:
    """The paper's index for every panel pair at every time step of ``traj``, vectorised
    over pairs and steps in chunks of pairs so the temporaries stay under ``chunk_bytes``
    (total memory: :func:`index_memory_bytes`). Designs without holes take
    :func:`_index_single` (no padding to the largest segment count)."""
    design = traj.design
    sheet = side_segments(design, traj.model)
    if all(len(sg) == 1 for sg in sheet):  # no holes: one segment per panel, no padding
        return _index_single(traj, np.concatenate(sheet), chunk_bytes)
    segs = _world(sheet, traj.poses)
    n = len(design.panels)
    n_t = len(traj.times)
    iu, ju = np.triu_indices(n, 1)
    pairs = np.column_stack([iu, ju]).astype(int).reshape(-1, 2)
    kmax = max([s.shape[1] for s in segs] + [1])
    S = np.full((4, n_t, n, kmax), np.nan)  # p1x, p1z, p2x, p2z: contiguous components
    valid = np.zeros((n, kmax), dtype=bool)
    for i, sg in enumerate(segs):
        S[:, :, i, :sg.shape[1]] = sg.reshape(n_t, -1, 4).transpose(2, 0, 1)
        valid[i, :sg.shape[1]] = True
    # per panel once: direction and length (the same arithmetic as index_components)
    dx, dz = S[2] - S[0], S[3] - S[1]
    length = np.sqrt(dx * dx + dz * dz)
    all_valid = bool(valid.all())
    s_ij = np.full((n_t, len(pairs)), np.nan)
    contact = np.zeros((n_t, len(pairs)), dtype=bool)
    step = max(1, int(chunk_bytes // (n_t * kmax * kmax * 8 * _TEMPS)))
    for c0 in range(0, len(pairs), step):
        I, J = iu[c0:c0 + step], ju[c0:c0 + step]
        si, sj, coll = _pair_index(S, dx, dz, length, I, J)
        P = len(I)
        with np.errstate(invalid="ignore"):
            prod = si * sj
            hit = (prod > 0) & (prod < 1) & (si > 0) & (si <= 1) & (sj <= 1)  # paper_contact
        if coll is not None:
            hit |= coll
        if not all_valid:
            ok = (valid[I][:, :, None] & valid[J][:, None, :])[None]  # (1, P, K, K)
            hit &= ok
            prod = np.where(ok, prod, np.nan)
        contact[:, c0:c0 + P] = hit.reshape(n_t, P, -1).any(axis=2)
        prod = prod.reshape(n_t, P, -1)
        if prod.shape[2] == 1:
            s_ij[:, c0:c0 + P] = prod[:, :, 0]
            continue
        with np.errstate(invalid="ignore"):
            # the value plotted: the sub-segment pair closest to the band (0, 1)
            dist = np.where(np.isnan(prod), np.inf, np.abs(prod - 0.5))
        pick = np.argmin(dist, axis=2)
        s_ij[:, c0:c0 + P] = np.take_along_axis(prod, pick[..., None], axis=2)[..., 0]
    return _finish(traj, pairs, s_ij, contact)


#: float64 temporaries alive at once per (pair, time step) in the single-segment path.
_TEMPS1 = 20


def _finish(traj: Trajectory, pairs: np.ndarray, s_ij: np.ndarray, contact: np.ndarray) -> Index2D:
    """The index with the hinge-adjacent pairs marked, every array read-only."""
    adj = adjacent_pairs(traj.design)
    adjacent = np.array([tuple(p) in adj for p in pairs.tolist()], dtype=bool)
    for arr in (s_ij, contact, adjacent):
        arr.setflags(write=False)
    return Index2D(traj.times, pairs, s_ij, contact, adjacent)


@dataclass(frozen=True)
class _Ends:
    """World (x, z) of both ends of every one-segment panel, (n, n_t) rows each, with the
    per-panel terms of :func:`index_components` computed once."""

    p1x: np.ndarray
    p1z: np.ndarray
    p2x: np.ndarray
    p2z: np.ndarray
    dx: np.ndarray
    dz: np.ndarray
    length: np.ndarray
    lp_eps: np.ndarray
    ux: np.ndarray
    uy: np.ndarray
    lim: np.ndarray


def _world_ends(poses: np.ndarray, sheet: np.ndarray) -> _Ends:
    """:class:`_Ends` of ``sheet`` (n, 2, 2) under ``poses`` (n_t, n, 4, 4)."""
    # world (x, z) of both ends, as in _world: (R00 * x + R01 * y) + t0
    x1, y1, x2, y2 = (np.ascontiguousarray(sheet[:, a, b])[:, None] for a in (0, 1) for b in (0, 1))
    rows = [np.ascontiguousarray(poses[:, :, r, c].T) for r in (0, 2) for c in (0, 1, 3)]
    a0, a1, a3, c0_, c1, c3 = rows
    p1x = a0 * x1 + a1 * y1 + a3
    p1z = c0_ * x1 + c1 * y1 + c3
    p2x = a0 * x2 + a1 * y2 + a3
    p2z = c0_ * x2 + c1 * y2 + c3
    dx, dz = p2x - p1x, p2z - p1z
    length = np.sqrt(dx * dx + dz * dz)
    lp_eps = np.maximum(length, _EPS)
    return _Ends(p1x, p1z, p2x, p2z, dx, dz, length, lp_eps, dx / lp_eps, dz / lp_eps,
                 1e-9 * np.maximum(lp_eps, 1.0))


def _block_cross(e: _Ends, i: int, J: slice, f: list, b: list) -> bool:
    """S_ij of panel i against the panels ``J`` into ``f``'s ``prod`` and the paper's contact
    into ``b``'s ``hit``, in the preallocated temporaries; True when some pair is parallel."""
    rx, rz, denom, t, si, sj, prod, cx, nj = f
    par, tb, hit = b
    dp_x, dp_z, lp0 = e.dx[i], e.dz[i], e.length[i]
    np.subtract(e.p1x[J], e.p1x[i], out=rx)
    np.subtract(e.p1z[J], e.p1z[i], out=rz)
    dqx, dqz = e.dx[J], e.dz[J]
    np.multiply(dqz, dp_x, out=denom)  # dp_x * dq_z (IEEE products commute)
    np.subtract(denom, np.multiply(dqx, dp_z, out=t), out=denom)
    # parallel: |denom| <= 1e-9 * max(lp * lq, eps)
    np.multiply(e.length[J], lp0, out=si)
    np.maximum(si, _EPS, out=si)
    np.multiply(1e-9, si, out=si)
    np.less_equal(np.abs(denom, out=t), si, out=par)
    any_par = par.any()
    if any_par:  # no C_ij: NaN through S_i, S_j, S_ij (and no paper contact)
        np.copyto(denom, np.nan, where=par)
    # S_i = (r x dq) / denom, S_j = (r x dp) / denom
    np.multiply(rx, dqz, out=si)
    np.subtract(si, np.multiply(rz, dqx, out=t), out=si)
    np.divide(si, denom, out=si)
    np.multiply(rx, dp_z, out=nj)  # r x dp: also the collinear offset below
    np.subtract(nj, np.multiply(rz, dp_x, out=t), out=nj)
    np.divide(nj, denom, out=sj)
    np.multiply(si, sj, out=prod)
    # paper_contact: S_ij > 0 and S_i > 0 as min(S_ij, S_i) > 0, S_i <= 1 and
    # S_j <= 1 as max(S_i, S_j) <= 1 (the same truth values, NaN gives False)
    np.greater(np.minimum(prod, si, out=t), 0, out=hit)
    hit &= np.less(prod, 1, out=tb)
    hit &= np.less_equal(np.maximum(si, sj, out=t), 1, out=tb)
    return bool(any_par)


def _block_collinear(e: _Ends, i: int, J: slice, f: list, b: list) -> None:
    """Add the collinear overlaps of the parallel pairs to ``hit`` (index_components), with
    the per-panel terms (lp, u, 1e-9 * max(lp, 1)) computed once per panel: first the
    offset of q1 from the line of p, then the 1-D overlap only over the steps where some
    parallel pair of the block lies on one line. Uses :func:`_block_cross`'s temporaries."""
    rx, rz, denom, t, si, sj, prod, cx, nj = f
    par, tb, hit = b
    lp_i, ux_i, uy_i, lim_i = e.lp_eps[i], e.ux[i], e.uy[i], e.lim[i]
    off = np.abs(nj, out=nj)
    off /= lp_i
    np.less_equal(off, lim_i, out=tb)
    tb &= par
    steps = np.flatnonzero(tb.any(axis=0))
    if len(steps):
        T = slice(steps[0], steps[-1] + 1)
        close, lpT, uxT, uyT = tb[:, T], lp_i[T], ux_i[T], uy_i[T]
        b0 = np.multiply(rx[:, T], uxT, out=rx[:, T])
        b0 += np.multiply(rz[:, T], uyT, out=t[:, T])
        b1 = np.subtract(e.p2x[J, T], e.p1x[i, T], out=cx[:, T])
        b1 *= uxT
        q = np.subtract(e.p2z[J, T], e.p1z[i, T], out=sj[:, T])
        b1 += np.multiply(q, uyT, out=t[:, T])
        hi = np.minimum(lpT, np.maximum(b0, b1, out=sj[:, T]), out=sj[:, T])
        lo = np.maximum(0.0, np.minimum(b0, b1, out=rz[:, T]), out=rz[:, T])
        np.subtract(hi, lo, out=hi)
        close &= np.greater(hi, 1e-9, out=par[:, T])
        hit[:, T] |= close


def _index_single(traj: Trajectory, sheet: np.ndarray, chunk_bytes: int) -> Index2D:
    """:func:`collision_index` when every panel is one segment (``sheet`` (n, 2, 2)): each
    per-panel term is a contiguous (n, n_t) row block, each chunk of pairs a (P, n_t)
    broadcast with preallocated temporaries. The arithmetic is that of
    :func:`index_components` operation for operation, so the values are bit-identical."""
    n = len(traj.design.panels)
    n_t = len(traj.times)
    e = _world_ends(traj.poses, sheet)
    iu, ju = np.triu_indices(n, 1)
    pairs = np.column_stack([iu, ju]).astype(int).reshape(-1, 2)
    n_p = len(pairs)
    s_ij = np.empty((n_t, n_p))
    contact = np.empty((n_t, n_p), dtype=bool)
    s_rows, c_rows = s_ij.T, contact.T  # (n_p, n_t) views: pair rows
    # pairs (i, j > i) are consecutive rows: panel i is one broadcast row, panels j a slice
    # (views, nothing gathered); blocks of at most `step` rows bound the temporaries
    step = max(1, int(chunk_bytes // (n_t * 8 * _TEMPS1)))
    m_max = max(1, min(step, n - 1))
    f = [np.empty((m_max, n_t)) for _ in range(9)]
    b = [np.empty((m_max, n_t), dtype=bool) for _ in range(3)]
    k = 0
    with np.errstate(divide="ignore", invalid="ignore"):
        for i in range(n - 1):
            for j0 in range(i + 1, n, step):
                j1 = min(j0 + step, n)
                m = j1 - j0
                J = slice(j0, j1)
                fm, bm = [a[:m] for a in f], [a[:m] for a in b]
                if _block_cross(e, i, J, fm, bm):
                    _block_collinear(e, i, J, fm, bm)
                s_rows[k:k + m] = fm[6]  # prod
                c_rows[k:k + m] = bm[2]  # hit
                k += m
    return _finish(traj, pairs, s_ij, contact)


def _pair_index(S, dx, dz, length, I, J):
    """S_i, S_j (n_t, P, K, K) and the collinear-overlap mask (or None) for pairs (I, J):
    :func:`index_components` with the per-panel terms computed once."""
    p1x, p1z = S[0][:, I, :, None], S[1][:, I, :, None]
    dpx, dpz, lp0 = dx[:, I, :, None], dz[:, I, :, None], length[:, I, :, None]
    q1x, q1z = S[0][:, J, None, :], S[1][:, J, None, :]
    dqx, dqz, lq0 = dx[:, J, None, :], dz[:, J, None, :], length[:, J, None, :]
    rx, rz = q1x - p1x, q1z - p1z
    denom = dpx * dqz - dpz * dqx
    parallel = np.abs(denom) <= 1e-9 * np.maximum(lp0 * lq0, _EPS)
    with np.errstate(divide="ignore", invalid="ignore"):
        s_i = (rx * dqz - rz * dqx) / denom
        s_j = (rx * dpz - rz * dpx) / denom
    coll = None
    if parallel.any():
        np.copyto(s_i, np.nan, where=parallel)
        np.copyto(s_j, np.nan, where=parallel)
        sel = np.nonzero(parallel)
        q2x = S[2][:, J, None, :]
        q2z = S[3][:, J, None, :]
        part = [np.broadcast_to(a, parallel.shape)[sel] for a in (dpx, dpz, rx, rz, q2x - p1x, q2z - p1z, lp0)]
        coll = np.zeros(parallel.shape, dtype=bool)
        coll[sel] = _collinear_overlap(*part)
    return s_i, s_j, coll
