"""The paper's collision index for planar designs (Mao et al. 2015, Eq. 5-6, Methods).

Every panel is a segment in the side view. For panels i and j, C_ij is the intersection of
their lines; S_i and S_j are its normalised positions along each segment, and
S_ij = S_i * S_j. The paper flags a collision when 0 < S_ij < 1 except in three cases:
(1) 0 < S_i < 1 and S_j > 1, (2) 0 < S_j < 1 and S_i > 1, (3) S_i < 0 and S_j < 0.
Parallel segments have no intersection point: collinear ones that overlap are a contact,
the others are not (their index is NaN).

Vectorised over time steps and pairs. Hinge-adjacent panels are excluded from contact
(they share the hinge; ``docs/simulation.md``) but their index is kept for plots.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .design import Design
from .kinematics import Trajectory
from .rigid import side_segments

_EPS = 1e-12


def index_arrays(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray):
    """S_i, S_j (any broadcastable shape (..., 2) inputs) and masks.

    Returns ``(s_i, s_j, parallel, collinear_overlap)``; s_i and s_j are NaN where the
    segments are parallel.
    """
    dp, dq, r = p2 - p1, q2 - q1, q1 - p1
    cross = lambda a, b: a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]  # noqa: E731
    denom = cross(dp, dq)
    scale = np.linalg.norm(dp, axis=-1) * np.linalg.norm(dq, axis=-1)
    parallel = np.abs(denom) <= 1e-9 * np.maximum(scale, _EPS)
    safe = np.where(parallel, 1.0, denom)
    s_i = np.where(parallel, np.nan, cross(r, dq) / safe)
    s_j = np.where(parallel, np.nan, cross(r, dp) / safe)
    # collinear: q1 on the line of p (distance below a tolerance), then 1-D overlap
    lp = np.maximum(np.linalg.norm(dp, axis=-1), _EPS)
    off = np.abs(cross(r, dp)) / lp
    collinear = parallel & (off <= 1e-9 * np.maximum(lp, 1.0))
    u = dp / lp[..., None]
    a0, a1 = np.zeros_like(lp), lp
    b0 = np.sum(r * u, axis=-1)
    b1 = np.sum((q2 - p1) * u, axis=-1)
    overlap = np.minimum(a1, np.maximum(b0, b1)) - np.maximum(a0, np.minimum(b0, b1)) > 1e-9
    return s_i, s_j, parallel, collinear & overlap


def paper_contact(s_i: np.ndarray, s_j: np.ndarray) -> np.ndarray:
    """The paper's rule: 0 < S_ij < 1 and none of the three exceptions."""
    with np.errstate(invalid="ignore"):
        s_ij = s_i * s_j
        flagged = (s_ij > 0) & (s_ij < 1)
        exc1 = (s_i > 0) & (s_i < 1) & (s_j > 1)
        exc2 = (s_j > 0) & (s_j < 1) & (s_i > 1)
        exc3 = (s_i < 0) & (s_j < 0)
    return flagged & ~(exc1 | exc2 | exc3)


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


def world_side_segments(design: Design, poses: np.ndarray, model: str):
    """World side-view segments: list over panels of (n_t, k, 2, 2) arrays in (x, z)."""
    out = []
    for i, segs in enumerate(side_segments(design, model)):
        if len(segs) == 0:
            out.append(np.zeros((poses.shape[0], 0, 2, 2)))
            continue
        pts = np.concatenate([segs.reshape(-1, 2), np.zeros((2 * len(segs), 1)),
                              np.ones((2 * len(segs), 1))], axis=1)  # (2k, 4) homogeneous
        w = np.einsum("tij,kj->tki", poses[:, i], pts)  # (n_t, 2k, 4)
        out.append(w[..., [0, 2]].reshape(poses.shape[0], len(segs), 2, 2))
    return out


def adjacent_pairs(design: Design) -> set[tuple[int, int]]:
    idx = design.panel_index()
    return {tuple(sorted((idx[h.panels[0]], idx[h.panels[1]]))) for h in design.hinges}


def collision_index(traj: Trajectory) -> Index2D:
    """The paper's index for every panel pair at every time step of ``traj``."""
    design = traj.design
    segs = world_side_segments(design, traj.poses, traj.model)
    n = len(design.panels)
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=int).reshape(-1, 2)
    adj = adjacent_pairs(design)
    n_t = len(traj.times)
    s_ij = np.full((n_t, len(pairs)), np.nan)
    contact = np.zeros((n_t, len(pairs)), dtype=bool)
    for k, (i, j) in enumerate(pairs):
        a, b = segs[i], segs[j]
        if a.shape[1] == 0 or b.shape[1] == 0:
            continue
        p1, p2 = a[:, :, None, 0], a[:, :, None, 1]  # (n_t, ka, 1, 2)
        q1, q2 = b[:, None, :, 0], b[:, None, :, 1]  # (n_t, 1, kb, 2)
        si, sj, _, coll = index_arrays(p1, p2, q1, q2)
        hit = paper_contact(si, sj) | coll
        contact[:, k] = hit.reshape(n_t, -1).any(axis=1)
        prod = (si * sj).reshape(n_t, -1)
        with np.errstate(invalid="ignore"):
            # the value plotted: the sub-segment pair closest to the band (0, 1)
            dist = np.where(np.isnan(prod), np.inf, np.abs(prod - 0.5))
        pick = np.argmin(dist, axis=1)
        s_ij[:, k] = prod[np.arange(n_t), pick]
    adjacent = np.array([tuple(p) in adj for p in pairs.tolist()], dtype=bool)
    for a in (s_ij, contact, adjacent):
        a.setflags(write=False)
    return Index2D(traj.times, pairs, s_ij, contact, adjacent)


def segments_intersect_loop(segs_i: np.ndarray, segs_j: np.ndarray) -> bool:
    """Reference per-pair Python loop (for tests and the benchmark)."""
    for a in segs_i:
        for b in segs_j:
            si, sj, _, coll = index_arrays(a[0], a[1], b[0], b[1])
            if bool(paper_contact(np.asarray(si), np.asarray(sj))) or bool(coll):
                return True
    return False
