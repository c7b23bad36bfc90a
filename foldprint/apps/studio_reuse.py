"""What the studio's next revision takes over from the one it was edited from: what the
edit did not change is not built or searched again.

**The geometry.** Two designs that differ only in hinge materials (and the bath) have the
same solids: the printed part's pieces (:func:`foldprint.geometry.build_pieces`, the
permanent state: the hinges at their target angles) are relabelled with the new materials
(:func:`foldprint.geometry.assembly.relabelled`) and united per material again, and the
clearance checker's FCL solids, the printed part's gaps and its crossings are the same.

**The clearance.** An edit of one hinge's material changes that hinge's fold and nothing
else of a rigid part without loops: every other hinge folds as before (the same angles at
the same moments), so every panel pair whose path through the hinge tree crosses no
changed hinge keeps its relative pose at every moment, and with it its distance. The
smallest clearance (:func:`foldprint.collision.clearance.min_clearance`, check's) is the
minimum over all pairs; when the previous revision's minimum was reached by such an
unchanged pair, the minimum over the unchanged pairs is still that value, and only the
changed pairs are searched, with it as the bound to beat (the same branch and bound on
sphere lower bounds as :func:`foldprint.collision.swept_search.min_clearance`, over
those pairs). The same holds pose by pose for the clearance curve the page draws.

What is taken over is a bound, never a reported number: the clearance's pair, moment and
distance are then found and measured on the new fold as ``min_clearance`` does (the
earliest pose within the minimum plus ``tol.length``, its exact distance). An unchanged
pair's distance on the new poses equals the old one up to floating round-off (its world
poses differ in the last bits), far below ``tol.length``. Nothing is taken over when the
geometry changed (a target angle, the hinge model), the sampled moments moved (an earlier
first contact), the part has loops (closing them couples the hinges), the mechanics is
not rigid, more than :data:`MAX_CHANGED` hinges fold differently (the bath), or the
previous minimum was reached by a changed pair: then it is check's search, whole.
``tests/test_studio_reuse.py`` compares edits with fresh evaluations.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass

import numpy as np

from ..collision.broadphase import non_adjacent_pairs, panel_centres
from ..collision.clearance import Gap, earliest_within, sampled_poses
from ..collision.polytope_distance import panel_distance, panel_gap
from ..collision.swept3d import SweptChecker
from ..collision.swept_search import min_clearance as swept_min_clearance
from ..core.constants import tol
from ..core.errors import GeometryError
from ..core.modes import Mechanics, State
from ..geometry import build_assembly, build_pieces
from ..geometry.assembly import relabelled
from ..model.derived import content_key
from ..model.design import Design, Process
from ..model.hinge_graph import spanning_tree

#: (pose, pair) sphere bounds made at once by :func:`search_pairs` (as the library's search).
CHUNK = 1 << 19
#: Most changed hinges a search is bounded for (our choice: an edit of a few hinges; one of
#: the bath changes every hinge's fold, and then every pair is searched anyway).
MAX_CHANGED = 8


@dataclass(frozen=True)
class Searched:
    """One search's answer kept for the next revision: the moments searched, the hinge
    angles there, and the minimum ``(distance, (i, j), pose index)`` (None: no pair)."""

    times: np.ndarray
    angles: np.ndarray
    best: tuple | None
    split: np.ndarray | None = None  # the pairs searched when bounded (None: all, the library's search)
    earliest: tuple | None = None  # (pose index, (i, j)) the clearance was reported at


@dataclass(frozen=True)
class Memo:
    """What a revision's nominal result leaves for the next: its geometry's key, the
    clearance checker (FCL solids of that geometry) and its non-adjacent pairs, the
    printed part's pieces, gaps and crossings (geometry alone, per printer), the
    clearance search and each curve pose's (when they may bound the next revision's)."""

    key: bytes
    checker: SweptChecker
    lock: threading.Lock  # the checker's: its FCL objects take each pose in turn (one search at a time)
    pairs: np.ndarray
    printed: tuple  # (printer, pieces or None, printed gaps, printed crossings)
    clearance: Searched | None = None
    curve: tuple[Searched, ...] = ()


def geometry_key(design: Design, model) -> bytes:
    """Equal for two designs that differ only in hinge materials, process and names under
    the same hinge model: the same solids and pairs (:func:`foldprint.model.derived.content_key`)."""
    bare = dataclasses.replace(design, name="", description="", source="", process=Process(),
                               hinges=tuple(dataclasses.replace(h, material="") for h in design.hinges))
    return content_key((bare, str(model)))


def memo_for(ev, before: Memo | None) -> Memo:
    """This revision's memo before its searches: ``before``'s checker, pairs and printed
    part when the geometry (and printer) is the same, its searches when they can bound this
    revision's (rigid, no loops); else ``ev``'s own."""
    key = geometry_key(ev.design, ev.options.hinge_model)
    same = before is not None and before.key == key
    if same:
        checker, lock, pairs = before.checker, before.lock, before.pairs
    else:  # the memos' own (the evaluation's may be in use in another thread: an export)
        checker, lock = SweptChecker(ev.design, ev.options.hinge_model, None), threading.Lock()
        pairs = np.array(non_adjacent_pairs(ev.design), dtype=np.int64).reshape(-1, 2)
    printed = before.printed if same and before.printed[0] is ev.printer else (ev.printer, None, None, None)
    if not (same and ev.options.mechanics == Mechanics.RIGID and not spanning_tree(ev.design)[1]):
        return Memo(key, checker, lock, pairs, printed)
    return Memo(key, checker, lock, pairs, printed, before.clearance, before.curve)


def printed_part(ev, memo: Memo) -> tuple[Memo, tuple]:
    """The printed part as :attr:`Evaluation.assembly` builds it (the permanent state at the
    printer's layer), from ``memo``'s pieces relabelled when it has them, its gaps and
    crossings: ``(memo with them, (assembly, its error, gaps, crossings))``."""
    printer, pieces, gaps, crossings = memo.printed
    res = ev.printer.layer_mm
    try:
        pieces = build_pieces(ev.design, State.PERMANENT, res) if pieces is None else relabelled(pieces, ev.design)
        asm, err = build_assembly(ev.design, State.PERMANENT.value, ev.library, resolution_mm=res, pieces=pieces), None
    except GeometryError as exc:
        pieces, asm, err = None, None, str(exc)
    if gaps is None:
        gaps, crossings = ev.printed_gaps, tuple(ev.printed_crossings)
    return dataclasses.replace(memo, printed=(printer, pieces, gaps, crossings)), (asm, err, gaps, crossings)


def changed_pairs(design: Design, pairs: np.ndarray, changed: np.ndarray) -> np.ndarray:
    """Per pair (rows of ``pairs``, panel indices): whether its path through the hinge tree
    crosses a hinge of ``changed`` (a bool per hinge): a pair is split by a tree hinge
    when exactly one of its panels lies beyond it."""
    idx = design.panel_index()
    col = {design.hinges[k].id: c for c, k in enumerate(np.flatnonzero(changed))}
    below = np.zeros((len(design.panels), len(col)), dtype=bool)  # panel i lies beyond changed hinge c
    for h, parent, child in spanning_tree(design)[0]:  # root outward: a parent is done before its children
        below[idx[child]] = below[idx[parent]]
        if h.id in col:
            below[idx[child], col[h.id]] = True
    return (below[pairs[:, 0]] != below[pairs[:, 1]]).any(axis=1)


def search_pairs(checker: SweptChecker, poses: np.ndarray, pairs: np.ndarray, bound: float):
    """The smallest (exact) distance below ``bound`` of ``pairs`` over ``poses``:
    ``(distance, (i, j), pose index)``, or None when none is below it (branch and bound on
    sphere lower bounds, in time chunks, as :func:`~foldprint.collision.swept_search.min_clearance`)."""
    if len(pairs) == 0:
        return None
    C = panel_centres(checker, poses)
    rc = checker.tree.rc
    r_pair = rc[pairs[:, 0]] + rc[pairs[:, 1]]
    best = (float(bound), None, None)
    n_p = len(pairs)
    step = max(1, CHUNK // n_p)
    for k0 in range(0, len(poses), step):
        k = np.arange(k0, min(len(poses), k0 + step))
        diff = C[k][:, pairs[:, 0]] - C[k][:, pairs[:, 1]]
        lb = (np.sqrt(np.einsum("tpi,tpi->tp", diff, diff)) - r_pair).ravel()
        keep = np.flatnonzero(lb < best[0])
        for m in keep[np.argsort(lb[keep], kind="stable")].tolist():
            if lb[m] >= best[0]:
                break
            i, j, t = int(pairs[m % n_p, 0]), int(pairs[m % n_p, 1]), int(k[m // n_p])
            d = panel_gap(checker, i, j, poses[t, i], poses[t, j])
            if d < best[0]:
                best = (d, (i, j), t)
    return best if best[1] is not None else None


def minimum(memo: Memo, design: Design, times: np.ndarray, angles: np.ndarray, poses: np.ndarray,
            before: Searched | None) -> Searched:
    """The minimum over ``poses`` (at ``times``, hinge ``angles``): bounded by ``before``
    (the previous revision's search) when its minimum's pair is unchanged (the module
    docstring), else the library's search whole."""
    if before is not None and before.best is not None and before.best[1] is not None \
            and len(before.times) == len(times) and np.array_equal(before.times, times):
        changed = ~np.all(before.angles == angles, axis=0)
        if changed.sum() <= MAX_CHANGED:
            split = changed_pairs(design, memo.pairs, changed)
            row = row_of(memo.pairs, before.best[1])
            if row >= 0 and not split[row]:
                found = search_pairs(memo.checker, poses, memo.pairs[split], before.best[0])
                return Searched(times, angles, found or before.best, split)
    return Searched(times, angles, swept_min_clearance(memo.checker, poses))


def fold_end(sim) -> int:
    """How many of the nominal fold's poses the clearance looks at: up to its first contact."""
    traj, first = sim.trajectory, sim.first_collision
    return len(traj.times) if first is None else int(np.searchsorted(traj.times, first.time, side="right"))


def nominal_clearance(ev, memo: Memo) -> tuple[Gap | None, Searched]:
    """:attr:`Evaluation.clearance <foldprint.apps.evaluation_nominal.NominalStages.clearance>`
    of ``ev``'s fold, bounded by ``memo`` where it can be (the module docstring), and its
    search for the next revision."""
    traj = ev.simulation.trajectory
    ks = sampled_poses(fold_end(ev.simulation), ev.options.clearance_samples)
    checker = memo.checker
    poses = traj.poses[ks]
    s = minimum(memo, ev.design, traj.times[ks], traj.angles[ks], poses, memo.clearance)
    if s.best is None or s.best[1] is None:
        return None, s
    best, (i, j), k = s.best
    k, (i, j) = earliest(memo, poses, s, memo.clearance) or (k, (i, j))
    s = dataclasses.replace(s, split=None, earliest=(k, (i, j)))
    dist, point = panel_distance(checker, i, j, poses[k][i], poses[k][j])
    panels = ev.design.panels
    return Gap(max(float(dist), 0.0), (i, j), (panels[i].id, panels[j].id), float(traj.times[ks[k]]),
               None if point is None else tuple(float(x) for x in point)), s


def row_of(pairs: np.ndarray, pair: tuple[int, int]) -> int:
    """The row of ``pair`` in ``pairs`` (i < j), -1 when it is not there."""
    i, j = min(pair), max(pair)
    rows = np.flatnonzero((pairs[:, 0] == i) & (pairs[:, 1] == j))
    return int(rows[0]) if len(rows) else -1


def earliest(memo: Memo, poses: np.ndarray, s: Searched, before: Searched | None):
    """The first pose, and in it the first pair in ``memo.pairs``' order, within
    ``tol.length`` of the minimum ``s.best`` (:func:`~foldprint.collision.clearance.earliest_within`,
    where the clearance is reported): when the minimum was taken over unchanged from
    ``before`` (the same value, so the same threshold) and so was the pair ``before``
    reported, that pose and pair unless a changed pair is within the threshold before it;
    else the library's scan whole."""
    best, _pair, k = s.best
    within = float(best) + tol.length
    taken = s.split is not None and before is not None and s.best is before.best
    prev = before.earliest if taken else None
    m_prev = -1 if prev is None else row_of(memo.pairs, prev[1])
    if m_prev < 0 or s.split[m_prev]:
        return earliest_within(memo.checker, poses[:k + 1], within)
    k_prev = prev[0]
    rows = np.flatnonzero(s.split)
    pairs = memo.pairs[rows]
    rc = memo.checker.tree.rc
    r_pair = rc[pairs[:, 0]] + rc[pairs[:, 1]]
    step = max(1, CHUNK // max(len(rows), 1))
    for k0 in range(0, k_prev + 1, step):
        C = panel_centres(memo.checker, poses[k0:min(k_prev + 1, k0 + step)])
        lb = np.linalg.norm(C[:, pairs[:, 0]] - C[:, pairs[:, 1]], axis=-1) - r_pair
        for dk, line in enumerate(lb):
            t = k0 + dk
            for m in np.flatnonzero(line <= within):
                if t == k_prev and rows[m] > m_prev:
                    break
                i, j = (int(x) for x in pairs[m])
                if panel_gap(memo.checker, i, j, poses[t][i], poses[t][j]) <= within:
                    return t, (i, j)
    return prev


def curve(ev, memo: Memo, poses_wanted: int) -> tuple[dict, tuple[Searched, ...]]:
    """The clearance along ``ev``'s nominal fold at ``poses_wanted`` moments up to its first
    contact (the page's curve: the smallest gap at each moment), each pose's search
    bounded by the previous revision's at the same moment (:func:`minimum`)."""
    traj = ev.simulation.trajectory
    n = fold_end(ev.simulation)
    ks = np.unique(np.linspace(0, max(n - 1, 0), min(max(n, 1), poses_wanted)).round().astype(int))
    before = memo.curve if len(memo.curve) == len(ks) else (None,) * len(ks)
    times, dist, kept = [], [], []
    for k, prev in zip(ks, before):
        s = minimum(memo, ev.design, traj.times[k:k + 1], traj.angles[k:k + 1], traj.poses[k:k + 1], prev)
        if s.best is None:
            return {"time_s": [], "distance_mm": []}, ()
        kept.append(dataclasses.replace(s, split=None))
        times.append(round(float(traj.times[k]), 4))
        dist.append(round(max(float(s.best[0]), 0.0), 4))
    return {"time_s": times, "distance_mm": dist}, tuple(kept)
