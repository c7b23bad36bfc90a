"""Closure tracking of many drives at once: the predictor-corrector on the constraint
manifold as array code (``docs/loops.md``).

Every drive (n_t, n) rad is followed from the flat sheet on the closure manifold
``C(x) = 0``: at each grid time the closed configuration nearest the drive, continued from
the previous answer, found by Gauss-Newton steps ``dx = J^+ (-C) + (I - J^+ J)(rho - x)``.
This module holds the numbers only; the closure equations come in as a function
``evaluate(xs (P, n)) -> C (P, k), J (P, k, n)`` (:class:`foldprint.physics.loops.LoopSolver`),
so it imports nothing of the pipeline.

All drives advance together through a pool of *points*, one per solve in progress: a
drive's next grid step (sub-step), near the flat sheet also its restart from the drive
itself, and, away from it, the next grid steps solved ahead of time (a *window*). One
*round* evaluates C and J at every point of the pool and takes one eigen-decomposition of
the stacked normal matrices ``J^T J``; a point that converged (or ran out of steps) leaves
the pool, and a drive whose points have all left ends its step and puts its next ones in,
while the other drives go on iterating.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: closure residual accepted as closed (rad for rotation, mm for translation)
CLOSURE_TOL = 1e-9
#: a hinge whose closed angle stays this far from its driven angle "cannot follow" (rad)
FOLLOW_TOL = np.radians(2.0)
#: tracking stops when a Gauss-Newton step moves no angle more than this (rad)
OPT_TOL = 1e-5
#: how much farther than the continued answer a restart from the drive may land (rad)
JUMP = 0.05
#: below this largest angle (rad) the tracker also restarts from the drive
NEAR_FLAT = 0.2
#: a drive that moved less than this since the last solve (rad) is not re-solved
SKIP_TOL = 1e-8
#: largest change of any driven angle per continuation sub-step (rad)
MAX_STEP = 0.1
#: Gauss-Newton steps of one solve; after them it only restores closure, in at most NEWTON_STEPS
GN_STEPS = 8
NEWTON_STEPS = 20
#: a solve that ends with a residual above this lost the manifold (the configuration is held)
LOST_TOL = 1e-7
#: singular values of J below RANK_TOL times the largest (at least 1) count as zero (round-off)
RANK_TOL = 1e-7
#: away from the flat sheet, singular values below RANK_RES times the residual count as
#: zero too: a direction only the distance from the manifold makes stiff (our choice:
#: Newton then converges quadratically where the constraints are dependent on the manifold,
#: as Miura-ori's 12 vertex equations in 12 angles; no decision at a closed point changes,
#: |C| < 1e-9). Not near the flat sheet, where genuine singular values are as small as the
#: angles, hence as the residual, and the restart's path decides the branch.
RANK_RES = 1.0
#: within this of the flat sheet (largest angle, rad) every step takes the SVD of J: the
#: genuine singular values are as small as the angles there, and the eigen-decomposition of
#: J^T J resolves a singular value only to ~1e-8 of the largest (the SVD to ~1e-16), which
#: decides the branch at a bifurcation (our choice: 10 times the largest angle at which it
#: changed an answer of tests/test_loop_tracking.py, 1e-3 rad on cross_lock_uniform's
#: nominal drive)
SVD_BELOW = 1e-2
#: most grid steps of one drive solved ahead in one window (our choice)
WINDOW = 32
#: near the flat sheet, restarts from the drive of this many next grid steps run ahead (our choice)
PREFETCH = 8
#: a window's answer is kept when the step-by-step predictor lands within this of it (rad,
#: our choice: 40 times the largest such distance on the templates' check samples, 2.4e-4
#: rad on miura_3x3)
ACCEPT = 0.01


@dataclass(frozen=True)
class Solves:
    """The answers of a batch of solves, one row per point: ``x`` (P, n), ``res`` |C|
    (P,), ``null`` the null-space dimension of J, ``done`` the solve converged (a step
    below OPT_TOL at a closed point), ``basis`` (P, n, n) eigenvectors of J^T J and
    ``free`` (P, n) which of them span J's null space (the tangent space at ``x``)."""

    x: np.ndarray
    res: np.ndarray
    null: np.ndarray
    done: np.ndarray
    basis: np.ndarray
    free: np.ndarray


def _mv(a, v):
    """Stacked matrix-vector products a (P, i, j) @ v (P, j)."""
    return (a @ v[..., None])[..., 0]


def predict(x, target, basis, free):
    """The predictor: from closed configurations x (P, n) along their tangent spaces toward
    ``target``, ``N N^T (target - x)``, no angle moved more than MAX_STEP."""
    step = _mv(basis, free * _mv(basis.transpose(0, 2, 1), target - x))
    big = np.abs(step).max(axis=1, initial=0.0)
    return x + step * np.minimum(1.0, MAX_STEP / np.maximum(big, 1e-300))[:, None]


class _Pool:
    """Solves in progress and their answers, one row per point; rows are reused."""

    _fields = ("x", "target", "it", "spec", "far", "res", "null", "done", "basis", "free", "alive", "line", "guide")

    def __init__(self, n: int, size: int = 64):
        self.n, self.size = n, 0
        self.unused = np.zeros(0, int)
        self._grow(size)

    def _grow(self, size):
        n, old = self.n, self.size
        shapes = {"x": (n,), "target": (n,), "basis": (n, n), "free": (n,), "guide": (n,)}
        kinds = {"it": int, "null": int, "spec": bool, "done": bool, "alive": bool, "free": bool, "line": bool}
        for f in self._fields:
            a = np.zeros((size,) + shapes.get(f, ()), kinds.get(f, float))
            if old:
                a[:old] = getattr(self, f)
            setattr(self, f, a)
        self.unused = np.concatenate([self.unused, np.arange(old, size)])
        self.size = size

    def add(self, x, target, speculative=False, far=False, guide=None):
        """New points from ``x`` (m, n) toward ``target``; returns their rows.
        ``speculative``: dropped (not done) when not converged within GN_STEPS steps;
        ``far``: away from the flat sheet (the RANK_RES rule applies); ``guide`` (m, n):
        the tangent direction of the answer they start from, where that tangent space is a
        line (the points then solve with it instead of the eigen-decomposition, :func:`_gn_line`)."""
        m = len(x)
        if m > len(self.unused):
            self._grow(max(2 * self.size, self.size + m))
        ids, self.unused = self.unused[:m], self.unused[m:]
        self.x[ids], self.target[ids] = x, target
        self.it[ids], self.spec[ids], self.far[ids], self.alive[ids] = 0, speculative, far, True
        self.res[ids], self.done[ids], self.null[ids] = np.inf, False, 0
        self.line[ids] = guide is not None
        if guide is not None:
            self.guide[ids] = guide
        return ids

    def release(self, ids):
        self.alive[ids] = False
        self.unused = np.concatenate([self.unused, ids])

    def view(self, ids) -> Solves:
        return Solves(self.x[ids], self.res[ids], self.null[ids], self.done[ids], self.basis[ids], self.free[ids])

    def round(self, evaluate):
        """One Gauss-Newton step of every live point: the step toward the nearest closed
        configuration for GN_STEPS steps, then only the closure correction; a point stops
        when closed and its step is below OPT_TOL (converged) or past GN_STEPS, and after
        GN_STEPS + NEWTON_STEPS steps with the residual as it is and no tangent space."""
        act = np.nonzero(self.alive)[0]
        xa, it = self.x[act], self.it[act]
        c, jac = evaluate(xa)
        r = np.abs(c).max(axis=1, initial=0.0)
        jt = jac.transpose(0, 2, 1)
        gram, g = jt @ jac, _mv(jt, c)
        d = (self.target[act] - xa) * (it < GN_STEPS)[:, None]
        line = self.line[act]
        step, vec = np.empty_like(xa), np.empty(gram.shape)
        free, null = np.zeros(xa.shape, bool), np.ones(len(act), int)
        if line.any():
            step[line], vec[line] = _gn_line(gram[line], g[line], d[line], self.guide[act[line]])
            free[line, 0] = True
            self.guide[act[line]] = vec[line, :, 0]
        v = ~line & (self.far[act] == 0) & (np.abs(xa).max(axis=1, initial=0.0) < SVD_BELOW)
        e = ~line & ~v
        if e.any():
            step[e], vec[e], free[e] = _gn_eigh(gram[e], g[e], d[e], RANK_RES * r[e] * self.far[act[e]])
        if v.any():
            step[v], vec[v], free[v] = _gn_svd(jac[v], c[v], d[v])
        null[~line] = free[~line].sum(axis=1)
        big = np.abs(step).max(axis=1, initial=0.0)
        final = it >= GN_STEPS + NEWTON_STEPS
        stop = ((r < CLOSURE_TOL) & ((big < OPT_TOL) | (it >= GN_STEPS))) | final
        check = stop & line & ~final
        unsure = np.zeros_like(stop)
        unsure[check] = ~_certified(jac[check], gram[check], vec[check, :, 0])
        self.line[act[unsure]] = False  # evaluated again, with the eigen-decomposition
        stop &= ~unsure
        drop = ~stop & ~unsure & self.spec[act] & (it + 1 >= GN_STEPS)
        s = act[stop]
        self.res[s], self.done[s] = r[stop], (big[stop] < OPT_TOL) & ~final[stop]
        self.basis[s], self.free[s] = vec[stop], free[stop] & ~final[stop, None]
        self.null[act[~final]] = null[~final]
        go = ~stop & ~drop & ~unsure
        self.x[act[go]] = xa[go] + step[go] * np.minimum(1.0, MAX_STEP / np.maximum(big[go], 1e-300))[:, None]
        self.it[act[go]] += 1
        self.alive[act[stop | drop]] = False


def _gn_eigh(gram, g, d, stiff):
    """Gauss-Newton steps from the eigen-decomposition of J^T J (P, n, n): the closure
    correction -J^+ C (g = J^T C) on the singular values above RANK_TOL (relative) and
    ``stiff``, the part of ``d`` in the null space of the rest. Returns the step, the
    eigenvectors and which of them span the null space."""
    lam, vec = np.linalg.eigh(gram)
    keep = lam > np.maximum(RANK_TOL ** 2 * np.maximum(1.0, lam[:, -1]), stiff ** 2)[:, None]
    vt = vec.transpose(0, 2, 1)
    coef = np.where(keep, -_mv(vt, g) / np.where(keep, lam, 1.0), _mv(vt, d))
    return _mv(vec, coef), vec, ~keep


def _gn_svd(jac, c, d):
    """Gauss-Newton steps from the SVD of J (P, k, n), the rank rule alone (SVD_BELOW).
    Returns what :func:`_gn_eigh` does."""
    p, k, n = jac.shape
    u, sv, vt = np.linalg.svd(jac, full_matrices=k < n)
    s = np.zeros((p, n))
    s[:, :min(k, n)] = sv
    keep = s > (RANK_TOL * np.maximum(1.0, s[:, :1]))
    uc = np.zeros((p, n))
    uc[:, :min(k, n)] = _mv(u.transpose(0, 2, 1), c)[:, :min(k, n)]
    vec = vt.transpose(0, 2, 1)
    coef = np.where(keep, -uc / np.where(keep, s, 1.0), _mv(vt, d))
    return _mv(vec, coef), vec, ~keep


def _gn_line(gram, g, d, guide):
    """Gauss-Newton steps where the null space of J is a line near ``guide`` (P, n): one
    linear solve with J^T J + guide guide^T gives that line exactly (inverse iteration: a
    null vector v of J solves it with right-hand side guide (guide . v)) and the closure
    correction -J^+ C orthogonal to it. Returns the step and a basis (P, n, n) whose first
    column spans the line (the other columns are not used)."""
    a = gram + guide[:, :, None] * guide[:, None, :]
    sol = np.linalg.solve(a, np.stack([guide, g], axis=2))
    w = sol[..., 0] / np.linalg.norm(sol[..., 0], axis=1)[:, None]
    dx = sol[..., 1]
    step = w * ((w * d).sum(axis=1) + (w * dx).sum(axis=1))[:, None] - dx
    vec = np.zeros(gram.shape)
    vec[:, :, 0] = w
    return step, vec


def _certified(jac, gram, w):
    """Whether J's null space is exactly the line ``w`` (P, n) by the rank rule: J w below
    RANK_TOL times the largest singular value (at least 1), every other singular value above
    it (J^T J + w w^T less that threshold squared positive definite). The largest singular
    value is bounded by the Frobenius norm, so the test errs toward "no"."""
    thr = RANK_TOL * np.maximum(1.0, np.sqrt(np.trace(gram, axis1=1, axis2=2)))
    ok = np.linalg.norm(_mv(jac, w), axis=1) <= thr
    a = gram + w[:, :, None] * w[:, None, :] - (thr ** 2)[:, None, None] * np.eye(gram.shape[1])
    try:
        np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        ok &= np.linalg.eigvalsh(a)[:, 0] > 0
    return ok


def solve(evaluate, x, target) -> Solves:
    """Gauss-Newton from ``x`` (P, n) toward ``target`` (P, n), all points at once
    (:meth:`_Pool.round` until every point stopped)."""
    x = np.atleast_2d(np.asarray(x, float))
    pool = _Pool(x.shape[1], len(x))
    ids = pool.add(x, np.atleast_2d(np.asarray(target, float)))
    while pool.alive.any():
        pool.round(evaluate)
    return pool.view(ids)


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


class _State:
    """Per drive: the last answer and its tangent space, the grid step to solve next and
    what was met on the way (the step-by-step tracker's variables, one row per drive)."""

    def __init__(self, times, driven):
        self.times, self.driven = times, driven
        s, self.n_t, n = driven.shape
        self.x = np.zeros((s, n))
        self.basis = np.zeros((s, n, n))
        self.free = np.zeros((s, n), bool)
        self.tangent = np.zeros(s, bool)  # the last answer converged: predict along its tangent
        self.settled = np.ones(s, bool)
        self.prev = np.zeros((s, n))  # the drive at the last solved step
        self.k = np.zeros(s, int)  # the next grid step
        self.sub = np.zeros(s, int)  # the continuation sub-step within step k (0: none begun)
        self.nsub = np.ones(s, int)
        self.locked = np.full(s, np.nan)
        self.dof = np.full(s, -1)
        self.worst = np.zeros(s)
        self.res_x = np.zeros(s)
        self.width = np.full(s, 2)
        self.out = np.zeros_like(driven)

    def skip(self, i):
        """Advance the settled drives ``i`` over steps whose drive moved at most SKIP_TOL
        since the last solve (their answer is the last one)."""
        k = np.minimum(self.k[i], self.n_t - 1)
        idle = (self.k[i] < self.n_t) & (k > 0) & self.settled[i] & (self.sub[i] == 0) & (
            np.abs(self.driven[i, k] - self.prev[i]).max(axis=1) <= SKIP_TOL)
        for i in i[idle]:
            moved = np.abs(self.driven[i, self.k[i]:] - self.prev[i]).max(axis=1) > SKIP_TOL
            nxt = self.k[i] + (int(moved.argmax()) if moved.any() else len(moved))
            self.out[i, self.k[i]:nxt] = self.x[i]
            self.k[i] = nxt

    def begin(self, live):
        """Targets of the live drives' next solve: their step's (sub-step's) drive."""
        k = self.k[live]
        y = self.driven[live, k]
        fresh = self.sub[live] == 0
        delta = np.abs(y - self.prev[live]).max(axis=1, initial=0.0)
        self.nsub[live] = np.where(fresh, np.maximum(1, np.ceil(delta / MAX_STEP)).astype(int), self.nsub[live])
        self.sub[live] = np.where(fresh, 1, self.sub[live])
        frac = (self.sub[live] / self.nsub[live])[:, None]
        return y, self.prev[live] + (y - self.prev[live]) * frac

    def ahead(self, live, far):
        """Window widths (len(live),): how many grid steps from k each live drive solves now;
        1 unless ``far`` (away from the flat sheet, with a tangent, no sub-steps): then the
        next steps whose drive moves (by more than SKIP_TOL, at most MAX_STEP) up to the
        drive's current width."""
        w = np.ones(len(live), int)
        if not far.any():
            return w
        i = live[far]
        idx = np.minimum(self.k[i, None] + np.arange(WINDOW + 1), self.n_t - 1)
        y = self.driven[i[:, None], idx]
        d = np.abs(np.diff(y, axis=1)).max(axis=2)
        ok = (d > SKIP_TOL) & (d <= MAX_STEP) & (self.k[i, None] + np.arange(1, WINDOW + 1) < self.n_t)
        w[far] = np.minimum(1 + np.cumprod(ok, axis=1).sum(axis=1), self.width[i])
        return w

    def finish(self, i, y, x, res, null):
        """End grid step k of drives ``i``: their answer ``x`` (len(i), n) for drive ``y``."""
        k = self.k[i]
        stop = np.isnan(self.locked[i]) & (null == 0) & (np.abs(x - y).max(axis=1, initial=0.0) > FOLLOW_TOL)
        self.locked[i[stop]] = self.times[k[stop]]
        self.worst[i] = np.maximum(self.worst[i], res)
        self.prev[i] = y
        self.out[i, k] = x
        self.k[i] = k + 1
        self.sub[i] = 0

    def settle(self, i, sol: Solves, rows):
        """Take the converged answers ``sol`` rows ``rows`` as the drives' ``i`` configuration."""
        self.x[i], self.res_x[i] = sol.x[rows], sol.res[rows]
        self.settled[i] = self.tangent[i] = sol.done[rows]
        self.basis[i], self.free[i] = sol.basis[rows], sol.free[rows]
        first = (self.dof[i] < 0) & (np.abs(sol.x[rows]).max(axis=1, initial=0.0) > 1e-3)
        self.dof[i[first]] = sol.null[rows][first]


class _Counted:
    """``evaluate`` counting its configurations and calls."""

    def __init__(self, evaluate):
        self.evaluate, self.evaluations, self.rounds = evaluate, 0, 0

    def __call__(self, xs):
        self.evaluations += len(xs)
        self.rounds += 1
        return self.evaluate(xs)


def _line(st: _State, d):
    """The tangent direction of drives ``d`` whose tangent space is a line."""
    return st.basis[d, :, st.free[d].argmax(axis=1)]


def _blocks(w):
    """Owner (index into w) and offset (1, 2, ...) of the window points beyond each first."""
    owner = np.repeat(np.arange(len(w)), w - 1)
    return owner, np.arange(len(owner)) - np.repeat(np.cumsum(w - 1) - (w - 1), w - 1) + 1


class _Requests:
    """Per drive, the points of the step it is solving: its main solve, its restart from
    the drive (near the flat sheet) and its window points."""

    def __init__(self, s: int, n: int):
        self.open = np.zeros(s, bool)
        self.main = np.zeros(s, int)
        self.restart = np.full(s, -1)
        self.window = np.zeros((s, WINDOW), int)
        self.w = np.ones(s, int)
        self.y, self.ys = np.zeros((s, n)), np.zeros((s, n))
        self.early = np.full((s, PREFETCH), -1)  # restarts started ahead: their rows ...
        self.early_k = np.full((s, PREFETCH), -1)  # ... and grid steps

    def busy(self, pool: _Pool):
        """Which drives' current points are not all stopped."""
        win = (np.arange(WINDOW)[None] < self.w[:, None] - 1) & pool.alive[self.window]
        return self.open & (pool.alive[self.main] | ((self.restart >= 0) & pool.alive[self.restart]) | win.any(axis=1))

    def forget(self, pool: _Pool, i):
        """Drop the restarts drives ``i`` started ahead."""
        pool.release(self.early[i][self.early[i] >= 0])
        self.early[i], self.early_k[i] = -1, -1

    def _restarts(self, st: _State, pool: _Pool, live, ys):
        """Rows of the live drives' restarts from their drive at step k (all near the flat
        sheet): started ahead when the step is a single one toward exactly this drive,
        else now; and the restarts of the next PREFETCH grid steps started ahead (a restart
        depends on its drive alone, so near the flat sheet, where every step restarts, the
        steps wait only for their solves from the last answer)."""
        k, n_t = st.k[live], st.n_t
        ek, ei = self.early_k[live], self.early[live]
        hit = (ek == k[:, None]) & ((st.nsub[live] == 1) & (st.sub[live] == 1))[:, None]
        r, c = np.nonzero(hit)
        good = np.all(pool.target[ei[r, c]] == ys[r], axis=1)
        rows = np.full(len(live), -1)
        rows[r[good]] = ei[r[good], c[good]]
        taken = np.zeros_like(hit)
        taken[r[good], c[good]] = True
        stale = (ek >= 0) & (ek <= k[:, None]) & ~taken
        pool.release(ei[stale])
        ek, ei = np.where(stale | taken, -1, ek), np.where(stale | taken, -1, ei)
        new = rows < 0
        rows[new] = pool.add(ys[new], ys[new])
        want = k[:, None] + 1 + np.arange(PREFETCH)
        miss = ~(ek[:, None, :] == want[:, :, None]).any(axis=2) & (want < n_t)
        slot = np.argsort(ek >= 0, axis=1, kind="stable")  # free slots first
        rank = np.cumsum(miss, axis=1) - 1
        mr, mc = np.nonzero(miss)
        if mr.size:
            d, kk = live[mr], want[mr, mc]
            y0 = st.driven[d, kk - 1]
            ids = pool.add(y0 + (st.driven[d, kk] - y0), y0 + (st.driven[d, kk] - y0))
            ek[mr, slot[mr, rank[mr, mc]]], ei[mr, slot[mr, rank[mr, mc]]] = kk, ids
        self.early_k[live], self.early[live] = ek, ei
        return rows

    def post(self, st: _State, pool: _Pool, live):
        """Put the live drives' next points into the pool."""
        y, ys = st.begin(live)
        x = st.x[live]
        near = np.abs(x).max(axis=1, initial=0.0) < NEAR_FLAT
        pred = ~near & st.tangent[live]
        w = st.ahead(live, pred & (st.nsub[live] == 1))
        start = x.copy()
        i = live[pred]
        start[pred] = predict(x[pred], ys[pred], st.basis[i], st.free[i])
        line = pred & (st.free[live].sum(axis=1) == 1)
        self.main[live[~line]] = pool.add(start[~line], ys[~line], far=pred[~line])
        self.main[live[line]] = pool.add(start[line], ys[line], far=True, guide=_line(st, live[line]))
        self.restart[live] = -1
        self.restart[live[near]] = self._restarts(st, pool, live[near], ys[near])
        self.forget(pool, live[~near])
        owner, offset = _blocks(w)
        if len(owner):
            d = live[owner]
            k = st.k[d] + offset
            guess = predict(st.x[d], st.driven[d, k], st.basis[d], st.free[d])
            line = st.free[d].sum(axis=1) == 1
            self.window[d[~line], offset[~line] - 1] = pool.add(guess[~line], st.driven[d[~line], k[~line]],
                                                                speculative=True, far=True)
            self.window[d[line], offset[line] - 1] = pool.add(guess[line], st.driven[d[line], k[line]],
                                                              speculative=True, far=True, guide=_line(st, d[line]))
        self.w[live], self.y[live], self.ys[live] = w, y, ys
        self.open[live] = True


def track(evaluate, times, driven) -> Tracks:
    """Follow S drives ``driven`` (S, n_t, n) rad on the grid ``times`` (n_t,) s on the
    closure manifold from the flat sheet, all at once (module docstring)."""
    st = _State(np.asarray(times, float), np.asarray(driven, float))
    s, _, n = st.driven.shape
    pool, req, ev = _Pool(n, 4 * s), _Requests(s, n), _Counted(evaluate)
    todo = np.arange(s)
    while True:
        if todo.size:
            st.skip(todo)
            live = todo[st.k[todo] < st.n_t]
            req.forget(pool, todo[st.k[todo] >= st.n_t])
            if live.size:
                req.post(st, pool, live)
        if not pool.alive.any():
            break
        pool.round(ev)
        todo = np.nonzero(req.open & ~req.busy(pool))[0]
        if todo.size:
            _ended(st, pool, req, todo)
    return Tracks(st.out, st.worst, st.locked, st.dof, ev.evaluations, ev.rounds)


def _ended(st: _State, pool: _Pool, req: _Requests, live):
    """The live drives' points have all stopped: choose each one's answer (the restart
    near the flat sheet), end its step, keep what its window allows, free the rows."""
    w = req.w[live]
    owner, offset = _blocks(w)
    again = np.nonzero(req.restart[live] >= 0)[0]
    rows = np.concatenate([req.main[live], req.window[live[owner], offset - 1], req.restart[live[again]]])
    sol = pool.view(rows)
    main = _choose(sol, st.x[live], req.ys[live], again, len(live) + len(owner))
    ok = _after_main(st, live, req.y[live], sol, main)
    if len(owner):
        _window(st, live, w, ok, sol, main, owner, offset)
    pool.release(rows)
    req.open[live] = False


def _choose(sol: Solves, x, ys, again, base):
    """Rows of ``sol`` holding each drive's answer: its solve from the last answer ``x``
    (row j), or, near the flat sheet (drives ``again``, whose restart from the drive is row
    base + j), the restart where the continued answer missed the drive and the restart
    closed nearer to it without jumping more than JUMP farther (a drive starting on a
    branch's tangent does not stall at the bifurcation), and puts no hinge on the other side
    of flat from its drive (a drive keeps its target's sign at every instant; the other
    side is another branch, the one a scattered drive would flip to)."""
    rows = np.arange(len(x))
    if not len(again):
        return rows
    b = base + np.arange(len(again))
    xn, xb, yb, x0 = sol.x[rows[again]], sol.x[b], ys[again], x[again]
    take = ((np.abs(xn - yb).max(axis=1) > OPT_TOL) & (sol.res[b] <= LOST_TOL)
            & (np.linalg.norm(xb - yb, axis=1) < np.linalg.norm(xn - yb, axis=1) - 1e-9)
            & (np.abs(xb - x0).max(axis=1) <= np.abs(xn - x0).max(axis=1) + JUMP) & ~np.any(xb * yb < 0.0, axis=1))
    rows[again[take]] = b[take]
    return rows


def _after_main(st: _State, live, y, sol: Solves, rows):
    """The live drives' solves of their next step (sub-step): a solve that lost the manifold
    holds the last closed configuration and ends the step (the drive is locked there);
    otherwise its answer is taken. Returns which drives ended their step converged."""
    res = sol.res[rows]
    lost = res > LOST_TOL
    i = live[lost]
    st.settled[i] = True
    st.locked[i] = np.where(np.isnan(st.locked[i]), st.times[st.k[i]], st.locked[i])
    st.settle(live[~lost], sol, rows[~lost])
    ended = lost | (st.sub[live] >= st.nsub[live])
    st.sub[live[~ended]] += 1
    e = live[ended]
    st.finish(e, y[ended], st.x[e], st.res_x[e], sol.null[rows][ended])
    return ~lost & ended & sol.done[rows]


def _window(st: _State, live, w, ok, sol: Solves, main, owner, offset):
    """Keep each window's answers up to the first one the step-by-step tracker might not
    have given (:func:`_acceptable`, the answer before it being the one kept last)."""
    row = len(live) + np.arange(len(owner))
    prev = np.where(offset == 1, main[owner], row - 1)
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


def _keep(st: _State, live, w, owner, offset, acc, sol: Solves, row, yw):
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
    q = np.nonzero(kept)[0]
    if not q.size:
        return
    d, k = live[owner[q]], st.k[live[owner[q]]] + offset[q] - 1
    x, y, r = sol.x[row[q]], yw[q], row[q]
    st.out[d, k] = x
    t = np.where((sol.null[r] == 0) & (np.abs(x - y).max(axis=1) > FOLLOW_TOL), st.times[k], np.inf)
    first_stop = np.full(len(st.k), np.inf)
    np.minimum.at(first_stop, d, t)
    st.locked = np.where(np.isnan(st.locked) & np.isfinite(first_stop), first_stop, st.locked)
    np.maximum.at(st.worst, d, sol.res[r])
    folded = np.where((st.dof[d] < 0) & (np.abs(x).max(axis=1) > 1e-3), q, len(owner))
    at = np.full(len(st.k), len(owner))
    np.minimum.at(at, d, folded)
    f = np.nonzero(at < len(owner))[0]
    st.dof[f] = sol.null[row[at[f]]]
    g = np.nonzero(nacc)[0]
    last = first[g] + nacc[g] - 1
    st.settle(live[g], sol, row[last])
    st.prev[live[g]] = yw[last]
    st.k[live[g]] += nacc[g]
