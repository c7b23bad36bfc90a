"""One Gauss-Newton step of many closure solves at once: the corrector of the loop tracker
(:mod:`foldprint.physics.loops.tracker`, ``docs/loops.md``).

A pool holds the solves in progress, one row per *point* (a configuration x and the drive
it is solved toward). :meth:`Pool.round` evaluates C and J at every live point in one array
pass and takes one step ``dx = J^+ (-C) + (I - J^+ J)(rho - x)`` for each, the pseudo-inverse
from the stacked eigen-decomposition of ``J^T J``, the SVD of J near the flat sheet, or one
linear solve where the tangent space is a known line; a point stops when closed and still.
The closure equations come in as ``evaluate(xs (P, n)) -> C (P, k), J (P, k, n)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: closure residual accepted as closed (rad for rotation, mm for translation)
CLOSURE_TOL = 1e-9
#: tracking stops when a Gauss-Newton step moves no angle more than this (rad)
OPT_TOL = 1e-5
#: largest change of any driven angle per continuation sub-step (rad)
MAX_STEP = 0.1
#: Gauss-Newton steps of one solve; after them it only restores closure, in at most NEWTON_STEPS
GN_STEPS = 8
NEWTON_STEPS = 20
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


@dataclass(frozen=True)
class Solves:
    """The answers of a batch of solves, one row per point: ``x`` (P, n), ``res`` |C|
    (P,), ``null`` the null-space dimension of J, ``done`` the solve converged (a step
    below OPT_TOL at a closed point), ``basis`` (P, n, n) eigenvectors of J^T J and
    ``free`` (P, n) which of them span J's null space (the tangent space at ``x``);
    ``plain`` (P,) that space is by the rank rule alone (a point near the flat sheet: no
    RANK_RES; a line solve there is certified by that rule; None: all)."""

    x: np.ndarray
    res: np.ndarray
    null: np.ndarray
    done: np.ndarray
    basis: np.ndarray
    free: np.ndarray
    plain: np.ndarray | None = None


def _mv(a, v):
    """Stacked matrix-vector products a (P, i, j) @ v (P, j)."""
    return (a @ v[..., None])[..., 0]


def norms(v):
    """Euclidean norms of the rows of v (P, n): np.linalg.norm(v, axis=1), the same sums,
    without its argument handling."""
    return np.sqrt(np.add.reduce(v * v, axis=1))


def predict(x, target, basis, free):
    """The predictor: from closed configurations x (P, n) along their tangent spaces toward
    ``target``, ``N N^T (target - x)``, no angle moved more than MAX_STEP."""
    step = _mv(basis, free * _mv(basis.transpose(0, 2, 1), target - x))
    big = np.abs(step).max(axis=1, initial=0.0)
    return x + step * np.minimum(1.0, MAX_STEP / np.maximum(big, 1e-300))[:, None]


class Pool:
    """Solves in progress and their answers, one row per point; rows are reused."""

    _fields = ("x", "target", "it", "spec", "far", "plain", "res", "null", "done", "basis", "free", "alive", "line",
               "guide", "tag")

    def __init__(self, n: int, size: int = 64):
        self.n, self.size = n, 0
        self.stack, self.nfree = np.zeros(0, int), 0  # the unused rows: stack[:nfree]
        self._grow(size)

    def _grow(self, size):
        n, old = self.n, self.size
        shapes = {"x": (n,), "target": (n,), "basis": (n, n), "free": (n,), "guide": (n,)}
        kinds = {"it": int, "null": int, "tag": int, "spec": bool, "done": bool, "alive": bool, "free": bool,
                 "line": bool, "plain": bool}
        for f in self._fields:
            a = np.zeros((size,) + shapes.get(f, ()), kinds.get(f, float))
            if old:
                a[:old] = getattr(self, f)
            setattr(self, f, a)
        stack = np.zeros(size, int)
        stack[:self.nfree] = self.stack[:self.nfree]
        stack[self.nfree:self.nfree + size - old] = np.arange(old, size)
        self.stack, self.nfree, self.size = stack, self.nfree + size - old, size
        self._all = Solves(self.x, self.res, self.null, self.done, self.basis, self.free, self.plain)

    def add(self, x, target, speculative=False, far=False, taken=0, line=None, guide=None, tag=-1):
        """New points from ``x`` (m, n) toward ``target``; returns their rows. ``taken``: the
        Gauss-Newton steps already taken to reach ``x`` (a predictor's step).
        ``speculative``: dropped (not done) when not converged within GN_STEPS steps;
        ``far``: away from the flat sheet (the RANK_RES rule applies); ``line`` (m,): the
        points whose answer to start from has a tangent space that is a line, ``guide`` its
        direction, one row per point of ``line`` (they solve with it instead of the
        eigen-decomposition, :func:`_gn_line`); ``tag``: an int kept with each point for the
        caller (the tracker: its drive)."""
        m = len(x)
        if m > self.nfree:
            self._grow(max(2 * self.size, self.size + m))
        self.nfree -= m
        ids = self.stack[self.nfree:self.nfree + m].copy()
        self.x[ids], self.target[ids] = x, target
        self.it[ids], self.spec[ids], self.far[ids], self.alive[ids] = taken, speculative, far, True
        self.plain[ids] = np.logical_not(far)
        self.res[ids], self.done[ids], self.null[ids], self.tag[ids] = np.inf, False, 0, tag
        self.line[ids] = False if line is None else line
        if line is not None and len(guide):
            self.guide[ids[line]] = guide
        return ids

    def release(self, ids):
        self.alive[ids] = False
        self.stack[self.nfree:self.nfree + len(ids)] = ids
        self.nfree += len(ids)

    def solves(self) -> Solves:
        """The answers of every row (the pool's own arrays, not copies: read them before
        the rows are reused)."""
        return self._all

    def view(self, ids) -> Solves:
        return Solves(self.x[ids], self.res[ids], self.null[ids], self.done[ids], self.basis[ids], self.free[ids],
                      self.plain[ids])

    def round(self, evaluate):
        """One Gauss-Newton step of every live point: the step toward the nearest closed
        configuration for GN_STEPS steps, then only the closure correction; a point stops
        when closed and its step is below OPT_TOL (converged) or past GN_STEPS, and after
        GN_STEPS + NEWTON_STEPS steps with the residual as it is and no tangent space.
        The live points are taken in the order line solves, eigen-decompositions, SVDs (near
        the flat sheet), so each kernel works on a slice. An ``evaluate`` with a ``fused``
        method (:class:`foldprint.physics.loops.closure_kernels.CompiledClosure`) takes the
        whole round itself, point by point, compiled."""
        fused = getattr(evaluate, "fused", None)
        if fused is not None:
            fused(self)
            return
        act = self.alive.nonzero()[0]
        x0 = self.x[act]
        line0 = self.line[act]
        v0 = ~line0 & self.plain[act] & (np.abs(x0).max(axis=1, initial=0.0) < SVD_BELOW)
        nl, nv = np.count_nonzero(line0), np.count_nonzero(v0)
        if max(nl, nv, len(act) - nl - nv) < len(act):  # more than one kind: line, eigh, SVD in turn
            order = np.argsort(~line0 + v0.astype(int), kind="stable")
            act, xa = act[order], x0[order]
        else:
            xa = x0
        a = len(act) - nv  # points [0, nl) take the line solve, [nl, a) the eigen-decomposition, [a, P) the SVD
        it = self.it[act]
        c, jac = evaluate(xa)
        r = np.abs(c).max(axis=1, initial=0.0)
        d = (self.target[act] - xa) * (it < GN_STEPS)[:, None]
        # J^T J and J^T C for the points that do not take the SVD
        jn = jac[:a]
        jt = jn.transpose(0, 2, 1)
        gram, g = jt @ jn, _mv(jt, c[:a])
        step, vec = np.empty_like(xa), np.empty((len(act), self.n, self.n))
        free, null = np.zeros(xa.shape, bool), np.ones(len(act), int)
        if nl:
            step[:nl], vec[:nl] = _gn_line(gram[:nl], g[:nl], d[:nl], self.guide[act[:nl]])
            free[:nl, 0] = True
            self.guide[act[:nl]] = vec[:nl, :, 0]
        if a > nl:
            step[nl:a], vec[nl:a], free[nl:a] = _gn_eigh(gram[nl:], g[nl:], d[nl:a],
                                                         RANK_RES * r[nl:a] * self.far[act[nl:a]])
        if nv:
            step[a:], vec[a:], free[a:] = _gn_svd(jac[a:], c[a:], d[a:])
        null[nl:] = free[nl:].sum(axis=1)
        big = np.abs(step).max(axis=1, initial=0.0)
        final = it >= GN_STEPS + NEWTON_STEPS
        stop = ((r < CLOSURE_TOL) & ((big < OPT_TOL) | (it >= GN_STEPS))) | final
        moving = ~stop
        check = (stop[:nl] & ~final[:nl]).nonzero()[0]
        if check.size:  # a line solve that stopped: is the line the whole null space?
            unsure = np.zeros(len(stop), bool)
            unsure[check] = ~_certified(jac[check], gram[check], vec[check, :, 0])
            self.line[act[unsure]] = False  # evaluated again, with the eigen-decomposition
            stop &= ~unsure
            moving &= ~unsure
        drop = moving & self.spec[act] & (it + 1 >= GN_STEPS)
        s = act[stop]
        if final.any():  # out of steps: no tangent space, not converged; null as of the step before
            self.res[s], self.done[s] = r[stop], (big[stop] < OPT_TOL) & ~final[stop]
            self.basis[s], self.free[s] = vec[stop], free[stop] & ~final[stop, None]
            self.null[act[~final]] = null[~final]
        else:
            self.res[s], self.done[s] = r[stop], big[stop] < OPT_TOL
            self.basis[s], self.free[s] = vec[stop], free[stop]
            self.null[act] = null
        go = moving & ~drop
        self.x[act[go]] = xa[go] + step[go] * np.minimum(1.0, MAX_STEP / np.maximum(big[go], 1e-300))[:, None]
        self.it[act] = it + go
        self.alive[act] = ~stop & ~drop


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
    if k >= n:  # n singular values, U^T C has n rows
        s, uc = sv, _mv(u.transpose(0, 2, 1), c)
    else:
        s, uc = np.zeros((p, n)), np.zeros((p, n))
        s[:, :k], uc[:, :k] = sv, _mv(u.transpose(0, 2, 1), c)
    keep = s > (RANK_TOL * np.maximum(1.0, s[:, :1]))
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
    rhs = np.empty(guide.shape + (2,))
    rhs[..., 0], rhs[..., 1] = guide, g
    sol = np.linalg.solve(a, rhs)
    w = sol[..., 0] / norms(sol[..., 0])[:, None]
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
    ok = norms(_mv(jac, w)) <= thr
    a = gram + w[:, :, None] * w[:, None, :] - (thr ** 2)[:, None, None] * np.eye(gram.shape[1])
    try:
        np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        ok &= np.linalg.eigvalsh(a)[:, 0] > 0
    return ok


def solve(evaluate, x, target) -> Solves:
    """Gauss-Newton from ``x`` (P, n) toward ``target`` (P, n), all points at once
    (:meth:`Pool.round` until every point stopped)."""
    x = np.atleast_2d(np.asarray(x, float))
    pool = Pool(x.shape[1], len(x))
    ids = pool.add(x, np.atleast_2d(np.asarray(target, float)))
    while pool.alive.any():
        pool.round(evaluate)
    return pool.view(ids)
