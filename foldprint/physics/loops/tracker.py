"""Closure tracking of many drives at once: the predictor-corrector on the constraint
manifold as array code (``docs/loops.md``).

Every drive (n_t, n) rad is followed from the flat sheet on the closure manifold
``C(x) = 0``: at each grid time the closed configuration nearest the drive, continued from
the previous answer, found by Gauss-Newton steps ``dx = J^+ (-C) + (I - J^+ J)(rho - x)``.
This module holds the numbers only; the closure equations come in as a function
``evaluate(xs (P, n)) -> C (P, k), J (P, k, n)`` (:class:`foldprint.physics.loops.closure.LoopSolver`),
so it imports nothing of the pipeline.

All drives advance together through a pool of *points*, one per solve in progress: a
drive's next grid step (sub-step), near the flat sheet also its restart from the drive
itself, and, away from it, the next grid steps solved ahead of time (a *window*). One
*round* evaluates C and J at every point of the pool and takes one eigen-decomposition of
the stacked normal matrices ``J^T J`` (:mod:`foldprint.physics.loops.corrector`); a point that
converged (or ran out of steps) leaves the pool, and a drive whose points have all left ends
its step and puts its next ones in, while the other drives go on iterating. Each drive's
state between rounds is a row of :class:`~foldprint.physics.loops.drive_state.DriveState`.
Where the rounds are compiled (a Monte-Carlo chunk), everything between two rounds is one
compiled call too (:mod:`foldprint.physics.loops.tracker_kernels`, the same answers bit for
bit), and the loop of the two a compiled call of its own
(:mod:`foldprint.physics.loops.track_kernels`): a whole track, one call; this module's array
code is its reference and the one-drive path.
"""

from __future__ import annotations

from dataclasses import dataclass
import numpy as np

from .corrector import OPT_TOL, Pool, Solves, norms, predict
from .drive_state import ACCEPT, FOLLOW_TOL, JUMP, LINE_ABOVE, LOST_TOL, NEAR_FLAT, PREFETCH, WINDOW, DriveState

@dataclass(frozen=True)
class Tracks:
    """What :func:`track` found for S drives on one grid of n_t times: ``angles`` (S, n_t,
    n) closed angles, ``closure`` (S,) the worst residual of an accepted answer,
    ``locked_at`` (S,) the first time a drive had no motion left while asking for some
    (nan: never), ``dof`` (S,) the null-space dimension at the first folded step (-1: never
    folded), ``evaluations`` the number of configurations C and J were evaluated at and
    ``rounds`` the number of array evaluations that took."""

    angles: np.ndarray
    closure: np.ndarray
    locked_at: np.ndarray
    dof: np.ndarray
    evaluations: int
    rounds: int


class _Counted:
    """``evaluate`` counting its configurations and calls."""

    def __init__(self, evaluate):
        self.evaluate, self.evaluations, self.rounds = evaluate, 0, 0
        if hasattr(evaluate, "fused"):  # a compiled round (corrector.Pool.round)
            self.fused = self._fused

    def _fused(self, pool):
        self.evaluations += self.evaluate.fused(pool)
        self.rounds += 1

    def took(self, rounds: int, evaluations: int) -> None:
        """Count a compiled track's rounds and evaluations (``track_kernels.track_pool``)."""
        self.evaluations += self.evaluate.counted(evaluations)
        self.rounds += rounds

    def __call__(self, xs):
        self.evaluations += len(xs)
        self.rounds += 1
        return self.evaluate(xs)


def _line(st: DriveState, d):
    """The tangent direction of drives ``d`` whose tangent space is a line."""
    if not len(d):
        return st.x[:0]
    return st.basis[d, :, st.free[d].argmax(axis=1)]


def _blocks(w):
    """Owner (index into w) and offset (1, 2, ...) of the window points beyond each first."""
    owner = np.repeat(np.arange(len(w)), w - 1)
    return owner, np.arange(len(owner)) - np.repeat(np.cumsum(w - 1) - (w - 1), w - 1) + 1


class _Requests:
    """Per drive, the points of the step it is solving: its main solve, its restart from
    the drive (near the flat sheet) and its window points. The pool tags each with its
    drive (restarts started ahead: -1 until their step takes them)."""

    def __init__(self, s: int, n: int):
        self.open = np.zeros(s, bool)
        self.main = np.zeros(s, int)
        self.restart = np.full(s, -1)
        self.window = np.zeros((s, WINDOW), int)
        self.w = np.ones(s, int)
        self.y, self.ys = np.zeros((s, n)), np.zeros((s, n))
        self.early = np.full((s, PREFETCH), -1)  # restarts started ahead: their rows ...
        self.early_k = np.full((s, PREFETCH), -1)  # ... and grid steps

    def stopped(self, pool: Pool):
        """Which open drives' current points have all stopped."""
        busy = np.zeros(len(self.open) + 1, bool)  # the last place: untagged points
        busy[pool.tag[pool.alive]] = True
        return (self.open & ~busy[:-1]).nonzero()[0]

    def forget(self, pool: Pool, i):
        """Drop the restarts drives ``i`` started ahead."""
        if not len(i):
            return
        e = self.early[i]
        some = e >= 0
        if some.any():
            pool.release(e[some])
            self.early[i], self.early_k[i] = -1, -1

    def _restarts(self, st: DriveState, pool: Pool, live, ys):
        """Rows of the live drives' restarts from their drive at step k (answer and drive
        near the flat sheet): started ahead when the step is a single one toward exactly this
        drive, else now; and the restarts of the restarting steps among the next PREFETCH
        (:attr:`DriveState.restarts`) started ahead (a restart depends on its drive alone, so
        near the flat sheet the steps wait only for their solves from the last answer)."""
        k, n_t, j = st.k[live], st.n_t, np.arange(len(live))
        ek, ei = self.early_k[live], self.early[live]  # a step's restart ahead sits in slot step % PREFETCH
        rows = np.full(len(live), -1)
        run = ~st.needless(live, ys)  # else this step's restart is not run (nor kept from ahead)
        if PREFETCH:
            own = k % PREFETCH
            h = (run & (ek[j, own] == k) & (st.nsub[live] == 1) & (st.sub[live] == 1)).nonzero()[0]
            h = h[(pool.target[ei[h, own[h]]] == ys[h]).all(axis=1)]
            rows[h] = ei[h, own[h]]
            ei[h, own[h]] = -1  # taken
        gone = (ek >= 0) & (ek <= k[:, None])  # each step's own restart (unless taken) and older ones
        if gone.any():
            old = ei[gone]
            pool.release(old[old >= 0])
            ek[gone], ei[gone] = -1, -1
        new = run & (rows < 0)
        if new.any():
            rows[new] = pool.add(ys[new], ys[new])
        pool.tag[rows[run]] = live[run]
        if PREFETCH:  # the steps ahead whose drive is near the flat sheet and that have no restart yet
            want = k[:, None] + np.arange(1, PREFETCH + 1)
            slot = want % PREFETCH
            miss = (ek[j[:, None], slot] != want) & (want < n_t)
            miss &= st.restarts[live[:, None], np.minimum(want, n_t - 1)]
            mr, mc = miss.nonzero()
            if mr.size:
                d, kk = live[mr], want[mr, mc]
                y0 = st.driven[d, kk - 1]
                y1 = y0 + (st.driven[d, kk] - y0)  # the step's target as begin() computes it
                ok = ~st.needless(d, y1)  # those that could be taken
                mr, mc, kk, y1 = mr[ok], mc[ok], kk[ok], y1[ok]
                ids = pool.add(y1, y1)
                ek[mr, slot[mr, mc]], ei[mr, slot[mr, mc]] = kk, ids
        self.early_k[live], self.early[live] = ek, ei
        return rows

    def post(self, st: DriveState, pool: Pool, live):
        """Put the live drives' next points into the pool."""
        y, ys = st.begin(live)
        x = st.x[live]
        near = st.xmax[live] < NEAR_FLAT
        start, taken, pred = _starts(st, live, near, x, ys)
        w = st.ahead(live, pred & (st.nsub[live] == 1))
        # the line solve from an answer whose tangent space is a line: away from the flat sheet, and near it
        # from LINE_ABOVE (its guide that line: docs/loops.md)
        line = st.line[live] & (pred | (st.tangent[live] & (st.xmax[live] >= LINE_ABOVE)))
        self.main[live] = pool.add(start, ys, far=pred, taken=taken, line=line, guide=_line(st, live[line]), tag=live)
        self.restart[live] = -1
        if near.any():
            flat = near & (np.abs(ys).max(axis=1, initial=0.0) < NEAR_FLAT)  # the drive too
            again = flat & st.restarts[live, st.k[live]]
            if again.any():
                self.restart[live[again]] = self._restarts(st, pool, live[again], ys[again])
            self.forget(pool, live[~flat])
        else:
            self.forget(pool, live)
        if w.max() > 1:
            owner, offset = _blocks(w)
            d = live[owner]
            k = st.k[d] + offset
            guess = predict(st.x[d], st.driven[d, k], st.basis[d], st.free[d])
            line = st.line[d]
            self.window[d, offset - 1] = pool.add(guess, st.driven[d, k], speculative=True, far=True, line=line,
                                                  guide=_line(st, d[line]), tag=d)
        self.w[live], self.y[live], self.ys[live] = w, y, ys
        self.open[live] = True


def _starts(st: DriveState, live, near, x, ys):
    """Where the live drives' solves from their converged answers x start, and the
    Gauss-Newton steps that took (0 or 1): away from the flat sheet the predictor along the
    tangent space (:func:`predict`); near it, the first Gauss-Newton step from an answer
    whose basis is that of the evaluation it converged at (the rank rule a point near the
    flat sheet takes: an eigen-decomposition's, an SVD's or a certified line's), taken
    without evaluating C and J at x again (closed: the step is its tangent space's part of
    the drive), where it moves an angle by OPT_TOL or more (below, the solve stops at x in
    one evaluation). Returns the starts, the steps taken and which
    drives predicted (away from the flat sheet, with a tangent)."""
    tangent = st.tangent[live]
    pred = ~near & tangent
    first = near & tangent & st.plain[live]
    start, taken = x.copy(), np.zeros(len(live), int)
    u = (pred | first).nonzero()[0]
    if u.size:
        i = live[u]
        p = predict(x[u], ys[u], st.basis[i], st.free[i])
        moved = pred[u] | (np.abs(p - x[u]).max(axis=1, initial=0.0) >= OPT_TOL)
        start[u[moved]] = p[moved]
        taken[u[moved & first[u]]] = 1
    return start, taken, pred


def track(evaluate, times, driven, compiled: bool | None = None) -> Tracks:
    """Follow S drives ``driven`` (S, n_t, n) rad on the grid ``times`` (n_t,) s on the
    closure manifold from the flat sheet, all at once (module docstring). ``compiled``: the
    bookkeeping between rounds compiled and the whole track one compiled call
    (:mod:`foldprint.physics.loops.track_kernels`, the same answers bit for bit); None:
    where ``evaluate`` takes compiled rounds (a ``fused`` method)."""
    st = DriveState(np.asarray(times, float), np.asarray(driven, float))
    s, _, n = st.driven.shape
    if compiled is None:
        compiled = hasattr(evaluate, "fused")
    if compiled:
        return _track_compiled(st, _Counted(evaluate))
    pool, req, ev = Pool(n, 4 * s), _Requests(s, n), _Counted(evaluate)
    todo = np.arange(s)
    while True:
        if todo.size:
            st.skip(todo)
            over = st.k[todo] >= st.n_t
            if over.any():
                req.forget(pool, todo[over])
                live = todo[~over]
            else:
                live = todo
            if live.size:
                req.post(st, pool, live)
        if not pool.alive.any():
            break
        pool.round(ev)
        todo = req.stopped(pool)
        if todo.size:
            _ended(st, pool, req, todo)
    return Tracks(st.out, st.worst, st.locked, st.dof, ev.evaluations, ev.rounds)


def _track_compiled(st: DriveState, ev: _Counted, fused: bool = True) -> Tracks:
    """:func:`track`'s loop with its bookkeeping compiled (``tracker_kernels.between``), the
    whole loop one compiled call (``track_kernels.track_pool``: a track is one dispatch, not
    two a round). ``fused=False``: the loop in Python, a call of the bookkeeping and a
    compiled round a turn, the same calls in the same order (the driver's reference in tests)."""
    pool, arrays = _compiled_state(st)
    if fused:
        from .track_kernels import track_pool

        ev.took(*track_pool(True, *arrays, ev.evaluate.tables))
    else:
        from .tracker_kernels import between

        first = True
        while between(first, *arrays):
            first = False
            pool.round(ev)
    return Tracks(st.out, st.worst, st.locked, st.dof, ev.evaluations, ev.rounds)


def _compiled_state(st: DriveState):
    """A pool for the drives of ``st`` and the arrays the compiled bookkeeping reads, as its
    three tuples: the pool holds every point the drives can have at once (a main solve, a
    restart, a window and PREFETCH restarts ahead each), so the kernel never grows it."""
    s, _, n = st.driven.shape
    pool, req = Pool(n, s * (WINDOW + PREFETCH + 2)), _Requests(s, n)
    sts = (st.times, st.driven, st.x, st.basis, st.free, st.tangent, st.plain, st.settled, st.xmax, st.line, st.prev,
           st.k, st.sub, st.nsub, st.locked, st.dof, st.worst, st.res_x, st.width, st.out, st.restarts, st.run)
    rq = (req.open, req.main, req.restart, req.window, req.w, req.y, req.ys, req.early, req.early_k)
    pl = (pool.x, pool.target, pool.it, pool.spec, pool.far, pool.plain, pool.res, pool.null, pool.done, pool.basis,
          pool.free, pool.alive, pool.line, pool.guide, pool.tag, pool.stack, np.array([pool.nfree]))
    return pool, (sts, rq, pl)


_WARM = {"done": False}


def warm_compiled(evaluate) -> None:
    """Load the compiled track (``track_kernels.track_pool``; on a cold cache compile it,
    with the bookkeeping and the round it calls) for the compiled closure ``evaluate``
    without tracking anything (no drive has points to post, so no round runs), so a pool of
    workers forked after this finds it loaded. Once per process: its types are the same
    whatever the pattern (one hinge here)."""
    if _WARM["done"]:
        return
    from .track_kernels import track_pool

    track_pool(False, *_compiled_state(DriveState(np.zeros(2), np.zeros((1, 2, 1))))[1], evaluate.tables)
    _WARM["done"] = True


def _ended(st: DriveState, pool: Pool, req: _Requests, live):
    """The live drives' points have all stopped: choose each one's answer (the restart
    near the flat sheet), end its step, keep what its window allows, free the rows."""
    w, main = req.w[live], req.main[live]
    again = (req.restart[live] >= 0).nonzero()[0]
    restart = req.restart[live[again]]
    sol = pool.solves()
    chosen = _choose(sol, main, st.x[live], req.ys[live], again, restart)
    ok = _after_main(st, live, req.y[live], sol, chosen)
    rows = [main, restart]
    if w.max() > 1:
        owner, offset = _blocks(w)
        rows.append(req.window[live[owner], offset - 1])
        _window(st, live, w, ok, sol, chosen, owner, offset, rows[-1])
    pool.release(np.concatenate(rows))
    req.open[live] = False


def _choose(sol: Solves, rows, x, ys, again, restart):
    """Rows of ``sol`` holding each drive's answer: its solve from the last answer ``x``
    (``rows``), or, near the flat sheet (drives ``again``, whose restart from the drive is
    row ``restart``), the restart where the continued answer missed the drive and the restart
    closed nearer to it without jumping more than JUMP farther (a drive starting on a
    branch's tangent does not stall at the bifurcation), and puts no hinge on the other side
    of flat from its drive (a drive keeps its target's sign at every instant; the other
    side is another branch, the one a scattered drive would flip to)."""
    if not len(again):
        return rows
    rows, b = rows.copy(), restart
    xn, xb, yb, x0 = sol.x[rows[again]], sol.x[b], ys[again], x[again]
    miss = xn - yb
    take = ((np.abs(miss).max(axis=1) > OPT_TOL) & (sol.res[b] <= LOST_TOL) & (norms(xb - yb) < norms(miss) - 1e-9)
            & (np.abs(xb - x0).max(axis=1) <= np.abs(xn - x0).max(axis=1) + JUMP) & ~(xb * yb < 0.0).any(axis=1))
    rows[again[take]] = b[take]
    return rows


def _after_main(st: DriveState, live, y, sol: Solves, rows):
    """The live drives' solves of their next step (sub-step): a solve that lost the manifold
    holds the last closed configuration and ends the step (the drive is locked there);
    otherwise its answer is taken. Returns which drives ended their step converged."""
    lost = sol.res[rows] > LOST_TOL
    if lost.any():
        i = live[lost]
        st.settled[i] = True
        st.locked[i] = np.where(np.isnan(st.locked[i]), st.times[st.k[i]], st.locked[i])
        st.settle(live[~lost], sol, rows[~lost])
    else:
        st.settle(live, sol, rows)
    ended = lost | (st.sub[live] >= st.nsub[live])
    st.sub[live[~ended]] += 1
    e = live[ended]
    st.finish(e, y[ended], st.x[e], st.res_x[e], sol.null[rows][ended])
    return ~lost & ended & sol.done[rows]


def _window(st: DriveState, live, w, ok, sol: Solves, main, owner, offset, row):
    """Keep each window's answers (rows ``row`` of ``sol``, drive ``live[owner]``'s
    ``offset``-th) up to the first one the step-by-step tracker might not have given
    (:func:`_acceptable`, the answer before it being the one kept last)."""
    prev = np.where(offset == 1, main[owner], np.concatenate([row[-1:], row[:-1]]))  # the point before
    yw = st.driven[live[owner], st.k[live[owner]] + offset - 1]
    _keep(st, live, w, owner, offset, ok[owner] & _acceptable(sol, prev, row, yw), sol, row, yw)


def _acceptable(sol: Solves, prev, row, y):
    """Whether the answers ``row`` of ``sol`` (toward drives ``y``) are what the step-by-step
    tracker gives from the answers ``prev``: both converged, the answer closed, the one
    before away from the flat sheet, the same tangent space dimension, and the answer within
    ACCEPT of the predictor from the one before (so the corrector from there has this answer
    to converge to)."""
    xp, xr = sol.x[prev], sol.x[row]
    p = predict(xp, y, sol.basis[prev], sol.free[prev])
    return (sol.done[prev] & sol.done[row] & (sol.res[row] <= LOST_TOL)
            & (np.abs(xp).max(axis=1, initial=0.0) >= NEAR_FLAT) & (sol.null[row] == sol.null[prev])
            & (np.abs(p - xr).max(axis=1) <= ACCEPT))


def _keep(st: DriveState, live, w, owner, offset, acc, sol: Solves, row, yw):
    """Take each window's accepted prefix (``acc`` per point, in order): its steps end with
    those answers; the drive continues from the last one. Widths double while whole
    windows are kept and shrink to what was kept otherwise."""
    fail = np.cumsum(~acc)
    first = np.cumsum(w - 1) - (w - 1)  # each live drive's first window point
    kept = fail - np.where(first > 0, fail[np.maximum(first - 1, 0)], 0)[owner] == 0
    nacc = np.bincount(owner, weights=kept, minlength=len(live)).astype(int)
    has = w > 1
    d = live[has]
    st.width[d] = np.where(nacc[has] == w[has] - 1, np.minimum(2 * st.width[d], WINDOW), np.maximum(2, nacc[has] + 1))
    q = kept.nonzero()[0]
    if not q.size:
        return
    d, k = live[owner[q]], st.k[live[owner[q]]] + offset[q] - 1
    x, y, r = sol.x[row[q]], yw[q], row[q]
    st.out[d, k] = x
    rigid = sol.null[r] == 0
    if rigid.any():
        t = np.where(rigid & (np.abs(x - y).max(axis=1) > FOLLOW_TOL), st.times[k], np.inf)
        first_stop = np.full(len(st.k), np.inf)
        np.minimum.at(first_stop, d, t)
        st.locked = np.where(np.isnan(st.locked) & np.isfinite(first_stop), first_stop, st.locked)
    np.maximum.at(st.worst, d, sol.res[r])
    unfolded = st.dof[d] < 0
    if unfolded.any():
        folded = np.where(unfolded & (np.abs(x).max(axis=1) > 1e-3), q, len(owner))
        at = np.full(len(st.k), len(owner))
        np.minimum.at(at, d, folded)
        f = (at < len(owner)).nonzero()[0]
        st.dof[f] = sol.null[row[at[f]]]
    g = nacc.nonzero()[0]
    last = first[g] + nacc[g] - 1
    st.settle(live[g], sol, row[last])
    st.prev[live[g]] = yw[last]
    st.k[live[g]] += nacc[g]
