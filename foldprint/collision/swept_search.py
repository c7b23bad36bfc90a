"""The swept check's searches over every non-adjacent panel pair, with the narrow phase of
:mod:`foldprint.collision.swept3d`: the earliest contact along a fold (the broad phase's
candidate pair runs advanced together in time, :func:`swept_first_contact`), the smallest
distance over given poses (branch and bound on sphere lower bounds,
:func:`min_clearance`), and the checkers kept per process and design
(:func:`checker_for`).
"""

from __future__ import annotations

import numpy as np

from ..core.jit import use_kernels
from ..core.modes import Method
from ..model.design import Design
from .broadphase import candidate_runs, pair_bounds
from .narrow_cost import check_narrow
from .polytope_distance import panel_gap
from .swept3d import FCL_REL, Contact, SweptChecker


def swept_first_contact(checker: SweptChecker, times, angles, poses, t_start: float = 0.0,
                        skip: set | None = None) -> tuple[Contact | None, list[Contact]]:
    """Earliest contact over all non-adjacent pairs (and the pairs touching initially)."""
    angles = checker.bound_coords(times, angles)
    times = np.asarray(times)
    k_start = int(np.searchsorted(times, t_start - 1e-12))
    if k_start >= len(times):
        return None, []
    runs = candidate_runs(checker, angles, poses, k_start, skip, times)
    # what the runs hold open, before the screen gathers their paths and before stepping
    check_narrow(checker, runs, poses.nbytes + angles.nbytes)
    if len(runs) and use_kernels():
        runs = screen(checker, runs, angles, poses)
    if not len(runs):  # every run certified (a strip sample's usual case): no narrow phase to set up
        return None, []
    tables = walk_tables(checker)
    if tables is not None:  # a hinge tree's plain drive: the walk compiled, every run in one call
        return walk(checker, runs, times, angles, poses, tables)
    best, initial = None, []
    # advance every candidate pair together in time (a heap on the sample each has
    # certified): once the earliest open pair is past the best contact, stop
    import heapq

    from ..core.guards import narrow_deadline

    tick = narrow_deadline()
    heap = []
    for m, (i, j, ka, kb) in enumerate(runs.tolist()):
        heapq.heappush(heap, (ka, m, i, j, kb, None))
    rounds = 0
    while heap:
        k, m, i, j, kb, gen = heapq.heappop(heap)
        rounds += 1
        if rounds % 512 == 0:  # the narrow phase's work is known only as it goes: bound its time
            tick(f"{len(runs)} panel-pair runs left by the broad phase, {len(heap)} open, certified to "
                 f"{float(times[k]):.3g} s of {float(times[-1]):.3g} s")
        if best is not None and times[k] > best.time:
            break
        if gen is None:
            gen = checker.steps((i, j), times, angles, poses, k, kb, k == 0)
        try:
            k = next(gen)
            heapq.heappush(heap, (k, m, i, j, kb, gen))
            continue
        except StopIteration as stop:
            c = stop.value
        if c is None:
            continue
        if c.method == "initial":
            initial.append(c)
            continue
        if best is None or c.time < best.time:
            best = c
    return best, initial


def screen(checker: SweptChecker, runs: np.ndarray, angles: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """The candidate runs (m, 4: i, j, ka, kb) each started at its first sample the compiled
    screen cannot certify apart (:func:`foldprint.collision.swept3d_kernels.screen_runs`:
    vertex-projection lower bounds and the pair's motion bound), runs certified to their
    end dropped, sorted by their first sample as before. Only the samples it leaves reach
    FCL; the narrow phase walks them as it walked the whole run."""
    from .swept3d_kernels import screen_runs

    idx, lev, lo, hi = run_levers(checker, runs)
    start = screen_runs(runs, np.ascontiguousarray(angles, float), np.ascontiguousarray(poses, float),
                        checker.hull_pts, checker.hull_off, idx, lev, np.ascontiguousarray(lo),
                        np.ascontiguousarray(hi), float(checker.tol), 1e-9 * (checker.extent + 1.0))
    out = runs.copy()
    out[:, 2] = start
    out = out[start < runs[:, 3]]
    return out[np.argsort(out[:, 2], kind="stable")]


def run_levers(checker: SweptChecker, runs: np.ndarray):
    """(path hinges, levers, where run r's start, where they end): every pair's levers
    tabled once per design (:meth:`SweptChecker.lever_table`), or for a large design its
    runs' levers gathered here."""
    table = checker.lever_table()
    if table is not None:
        idx, lev, first = table
        code = runs[:, 0] * len(checker.design.panels) + runs[:, 1]
        return idx, lev, np.ascontiguousarray(first[code]), np.ascontiguousarray(first[code + 1])
    idx, lev, off = [], [], [0]
    for i, j in runs[:, :2].tolist():
        a, b = checker.levers((i, j))
        idx.append(np.asarray(a, np.int64))
        lev.append(np.asarray(b, float))
        off.append(off[-1] + len(a))
    off = np.array(off, np.int64)
    return np.concatenate(idx), np.concatenate(lev), off[:-1].copy(), off[1:].copy()


def walk_tables(checker: SweptChecker):
    """The drive's tables the compiled walk reads (:meth:`~foldprint.physics.hinge_drive.HingeDrive.compiled_tables`),
    or None: the kernels do not run, or the drive has loops, arrests or angles of its own
    (the reference walk, :meth:`SweptChecker.steps`, then runs)."""
    if not use_kernels():
        return None
    return getattr(checker.drive, "compiled_tables", lambda: None)()


#: distances one call of the compiled walk computes before the time guard is asked
#: (our choice: about 40 ms of distances; the reference asks every 512 steps)
WALK_BUDGET = 4096


def walk(checker: SweptChecker, runs: np.ndarray, times, angles, poses, tables):
    """:func:`swept_first_contact`'s narrow phase compiled
    (:func:`foldprint.collision.narrow_kernels.walk_runs`), for a drive whose angles the
    kernels read (``tables``: :meth:`~foldprint.physics.hinge_drive.HingeDrive.compiled_tables`):
    the same earliest contact (the earliest time; between equal times, the run the
    reference's heap finishes first) and the same initial contacts."""
    from ..core.guards import narrow_deadline
    from .narrow_kernels import INITIAL, walk_runs
    from .polytope_distance import CERT_ABS, CERT_REL, prism_set

    idx, lev, lo, hi = run_levers(checker, runs)
    tr, s = checker.transforms, prism_set(checker)
    kin = tr.chain_tables(tr.root)
    geo = (s.ring, s.piece_off, s.panel_off, s.half, s.cen, s.rad, CERT_ABS, CERT_REL)
    m = len(runs)
    at, dist, status, out = np.full(m, -1, np.int64), np.zeros(m), np.zeros(m, np.int64), np.zeros((m, 3))
    best = np.array([-1.0, np.inf])  # the earliest contact's run and time
    times, poses = np.ascontiguousarray(times, float), np.ascontiguousarray(poses, float)
    angles = np.ascontiguousarray(angles, float)
    tick = narrow_deadline()
    while True:
        done, calls = walk_runs(WALK_BUDGET, runs, times, angles, poses, idx, lev, lo, hi, tables, kin, geo,
                                float(checker.tol), float(checker.time_tol_s), FCL_REL, at, dist, status, out, best)
        checker.n_distance_calls += int(calls)
        if done:
            break
        tick(f"{m} panel-pair runs left by the broad phase, {int(np.sum((status == 0) & (at < runs[:, 3])))} open")
    initial = [_contact(checker, runs[q], poses[runs[q, 2]], float(times[runs[q, 2]]), out[q, 1], "initial")
               for q in np.flatnonzero(status == INITIAL).tolist()]
    if best[0] < 0:
        return None, initial
    q = int(best[0])
    i, j, at_t = int(runs[q, 0]), int(runs[q, 1]), float(out[q, 2])

    def point():  # the nearest points at the last safe time, when read (a sample's outcome never does)
        from ..physics.kinematics import kernels

        pose = checker.transforms.poses(kernels().driven_at(*tables[:2], at_t, *tables[2:]))[0]
        return checker.point_of(i, j, pose[i], pose[j])()

    return Contact(float(out[q, 0]), (i, j), checker.panel_ids((i, j)), point, float(out[q, 1]), Method.FCL), initial


def _contact(checker: SweptChecker, run, pose, t: float, d: float, method) -> Contact:
    i, j = int(run[0]), int(run[1])
    return Contact(t, (i, j), checker.panel_ids((i, j)), checker.point_of(i, j, pose[i], pose[j]), float(d), method)


def min_clearance(checker: SweptChecker, poses: np.ndarray, chunk: int = 1 << 19, block: int = 4096):
    """Smallest distance between non-adjacent panels over the given poses (n_t, n, 4, 4):
    ``(distance, (i, j), time index)``, or None without pairs. Exact (the distances are
    :func:`~foldprint.collision.polytope_distance.panel_gap`'s, not FCL's):
    sphere lower bounds order the candidates and end the search (branch and bound).

    Streamed over time in chunks of about ``chunk`` (pose, pair) bounds: a chunk keeps only
    the candidates below the smallest distance found so far and visits them in order,
    ``block`` at a time, so memory stays at one chunk (~100 B a bound) whatever the design
    (all bounds at once held 24 B per pose and pair, 6.5 GB for a 1000-panel strip at 200
    poses). Any candidate below the final answer is below the running best when its chunk
    is searched, so the result is the same minimum."""
    bounds = pair_bounds(checker, poses)
    if bounds is None:
        return None
    pairs, C, r_pair = bounds
    n_t, n_p = len(poses), len(pairs)
    best = (np.inf, None, None)
    step = max(1, chunk // n_p)
    for k0 in range(0, n_t, step):
        k = np.arange(k0, min(n_t, k0 + step))
        diff = C[k][:, pairs[:, 0]] - C[k][:, pairs[:, 1]]
        d2 = np.einsum("tpi,tpi->tp", diff, diff).ravel()
        del diff
        # lb = |c_i - c_j| - r_i - r_j < best, compared squared (no root of every pair)
        keep = np.flatnonzero(d2 < np.tile(r_pair + best[0], len(k)) ** 2) if np.isfinite(best[0]) \
            else np.arange(len(d2))
        lb = np.sqrt(d2[keep]) - r_pair[keep % n_p]
        del d2
        order = keep[np.argsort(lb, kind="stable")]
        lb.sort(kind="stable")
        for b0 in range(0, len(order), block):
            m = order[b0:b0 + block]
            for bound, i, j, t in zip(lb[b0:b0 + block].tolist(), pairs[m % n_p, 0].tolist(),
                                      pairs[m % n_p, 1].tolist(), k[m // n_p].tolist()):
                if bound >= best[0]:
                    break
                d = panel_gap(checker, i, j, poses[t, i], poses[t, j])  # exact, no point
                if d < best[0]:
                    best = (d, (i, j), t)
            else:
                continue
            break
    return best


#: designs whose geometry :func:`checker_for` keeps per process (the designs of one run)
CHECKER_CACHE = 16
_checkers: dict = {}


def checker_for(design: Design, model, drive) -> SweptChecker:
    """A :class:`SweptChecker` of ``design`` under ``model`` for ``drive``, its geometry
    built once per process and design object (the Monte-Carlo folds one design many
    times; each sample used to rebuild its FCL geometry): :meth:`SweptChecker.with_drive`
    of a cached checker. The cache holds the design itself, so its id stays its own."""
    key = (id(design), str(model))
    hit = _checkers.get(key)
    if hit is None or hit[0] is not design:
        if len(_checkers) >= CHECKER_CACHE:
            _checkers.pop(next(iter(_checkers)))
        hit = _checkers[key] = (design, SweptChecker(design, model, None))
    return hit[1].with_drive(drive)
