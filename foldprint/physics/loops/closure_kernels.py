"""Compiled kernel of the loop tracker's corrector (:meth:`foldprint.physics.loops.corrector.Pool.round`):
one Gauss-Newton round of every live point of the pool in one call.

Per live point, as the numpy round takes it: the closure residual C and Jacobian J of
:meth:`foldprint.physics.loops.closure.LoopSolver.residuals` (each cycle's product of
point-hinge rotations, rotations and translations kept apart, J written place by place);
the step ``J^+ (-C) + (I - J^+ J) d`` from one linear solve where the point's tangent space
is a known line (:func:`~foldprint.physics.loops.corrector._gn_line`, certified at the
answer by :func:`~foldprint.physics.loops.corrector._certified`), the SVD of J within
SVD_BELOW of the flat sheet (:func:`~foldprint.physics.loops.corrector._gn_svd`), the
eigen-decomposition of J^T J otherwise (:func:`~foldprint.physics.loops.corrector._gn_eigh`);
then the stop, drop and step rules, written into the pool's rows. The points are
independent, so the loop over them gives what the numpy round's slices give, to round-off
(the same LAPACK driver ``syevd``; the line solve by Cholesky where numpy takes ``gesv``'s
LU, J^T J over each cycle's block, :mod:`~foldprint.physics.loops.normal_kernels`; the SVD
hand-written in :mod:`~foldprint.physics.loops.decomp_kernels`; the sums in another order).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import njit, stale_with
from . import corrector, decomp_kernels, normal_kernels
from .corrector import CLOSURE_TOL, GN_STEPS, MAX_STEP, NEWTON_STEPS, OPT_TOL, RANK_RES, RANK_TOL, SVD_BELOW
from .decomp_kernels import svd_small, svd_work
from .normal_kernels import cholesky, cholesky_solve, cycle_columns, lu_solve, normal_eq, shifted

#: hinges up to which the line solve is hand-written (:func:`cholesky`), LAPACK's ``gesv``
#: above (our choice: a 12-hinge solve with two right-hand sides costs 0.35 us by Cholesky,
#: 0.85 us by the hand-written LU, 1.4 us through LAPACK, measured on miura_3x3's line
#: points; LAPACK's blocked factorisation wins on the large patterns' hundreds of hinges)
SMALL = 32


@njit
def _turn(kk, kk2, kq, k2q, h, sn, c1):  # pragma: no cover - compiled
    """Hinge h's rotation ``I + sn K + c1 K^2`` (a 9-tuple, row by row) and translation
    ``-(sn K + c1 K^2) q`` (a 3-tuple), sn and c1 the sine and 1 - cosine of its angle."""
    r = (sn * kk[h, 0, 0] + c1 * kk2[h, 0, 0] + 1.0, sn * kk[h, 0, 1] + c1 * kk2[h, 0, 1],
         sn * kk[h, 0, 2] + c1 * kk2[h, 0, 2], sn * kk[h, 1, 0] + c1 * kk2[h, 1, 0],
         sn * kk[h, 1, 1] + c1 * kk2[h, 1, 1] + 1.0, sn * kk[h, 1, 2] + c1 * kk2[h, 1, 2],
         sn * kk[h, 2, 0] + c1 * kk2[h, 2, 0], sn * kk[h, 2, 1] + c1 * kk2[h, 2, 1],
         sn * kk[h, 2, 2] + c1 * kk2[h, 2, 2] + 1.0)
    return r, (-(sn * kq[h, 0] + c1 * k2q[h, 0]), -(sn * kq[h, 1] + c1 * k2q[h, 1]),
               -(sn * kq[h, 2] + c1 * k2q[h, 2]))


@njit
def _mv3(g, v0, v1, v2):  # pragma: no cover - compiled
    """The 3 x 3 ``g`` (a 9-tuple, row by row) times (v0, v1, v2), a 3-tuple."""
    return (g[0] * v0 + g[1] * v1 + g[2] * v2, g[3] * v0 + g[4] * v1 + g[5] * v2,
            g[6] * v0 + g[7] * v1 + g[8] * v2)


@njit
def _mm3(g, r):  # pragma: no cover - compiled
    """The product of two 3 x 3 9-tuples (row by row), each entry summed left to right."""
    return (g[0] * r[0] + g[1] * r[3] + g[2] * r[6], g[0] * r[1] + g[1] * r[4] + g[2] * r[7],
            g[0] * r[2] + g[1] * r[5] + g[2] * r[8], g[3] * r[0] + g[4] * r[3] + g[5] * r[6],
            g[3] * r[1] + g[4] * r[4] + g[5] * r[7], g[3] * r[2] + g[4] * r[5] + g[5] * r[8],
            g[6] * r[0] + g[7] * r[3] + g[8] * r[6], g[6] * r[1] + g[7] * r[4] + g[8] * r[7],
            g[6] * r[2] + g[7] * r[5] + g[8] * r[8])


@njit
def closure_at(x, pk, ln, sg, kk, kk2, kq, k2q, axis, point, c, jac, wq):  # pragma: no cover - compiled
    """C (6 m,) into ``c`` and J (6 m, n) into ``jac`` (zeroed here) at angles x (n,): cycle
    ci is the places l < ln[ci], hinge pk[ci, l] with sign sg[ci, l]; kk, kk2 (n, 3, 3)
    each hinge's axis cross-product matrix and its square, kq, k2q (n, 3) those times its
    point, ``axis`` and ``point`` (n, 3) its fold line; ``wq`` (L, 6) scratch: each place's
    axis and point moved by its prefix. The prefix's rotation and translation are tuples
    (kept in registers)."""
    m = pk.shape[0]
    jac[:, :] = 0.0
    for ci in range(m):
        for l in range(ln[ci]):
            h = pk[ci, l]
            th = x[h] * (-1.0 if sg[ci, l] < 0 else 1.0)
            r, tl = _turn(kk, kk2, kq, k2q, h, math.sin(th), 1.0 - math.cos(th))
            if l == 0:
                gr, gt = r, tl
                for a in range(3):
                    wq[0, a] = axis[h, a]
                    wq[0, 3 + a] = point[h, a]
                continue
            wq[l, 0], wq[l, 1], wq[l, 2] = _mv3(gr, axis[h, 0], axis[h, 1], axis[h, 2])
            wp = _mv3(gr, point[h, 0], point[h, 1], point[h, 2])
            wq[l, 3], wq[l, 4], wq[l, 5] = wp[0] + gt[0], wp[1] + gt[1], wp[2] + gt[2]
            mt = _mv3(gr, tl[0], tl[1], tl[2])
            gt = (gt[0] + mt[0], gt[1] + mt[1], gt[2] + mt[2])
            gr = _mm3(gr, r)
        # the cycle's residual: rotation vector of gr (closure._rotvecs), translation gt
        row = 6 * ci
        tr = (gr[0] + gr[4] + gr[8] - 1.0) / 2.0
        ang = math.acos(min(max(tr, -1.0), 1.0))
        v0, v1, v2 = gr[7] - gr[5], gr[2] - gr[6], gr[3] - gr[1]
        if math.pi - ang < 1e-6:  # half-turn residuals never occur near closure (closure._rotvec)
            mk, best = 0, -1.0
            for a in range(3):
                if (gr[4 * a] + 1.0) / 2.0 > best:
                    best, mk = (gr[4 * a] + 1.0) / 2.0, a
            nrm = math.sqrt(max(best, 1e-300))
            v0 = ang * ((gr[mk] + (1.0 if mk == 0 else 0.0)) / 2.0 / nrm)
            v1 = ang * ((gr[3 + mk] + (1.0 if mk == 1 else 0.0)) / 2.0 / nrm)
            v2 = ang * ((gr[6 + mk] + (1.0 if mk == 2 else 0.0)) / 2.0 / nrm)
        else:
            f = 0.5 if ang < 1e-6 else ang / (2.0 * math.sin(ang))
            v0, v1, v2 = v0 * f, v1 * f, v2 * f
        c[row], c[row + 1], c[row + 2] = v0, v1, v2
        c[row + 3], c[row + 4], c[row + 5] = gt[0], gt[1], gt[2]
        # d C / d x_h: each place's twist moved by its prefix, (w, (q - p) x w), signed
        for l in range(ln[ci]):
            s = sg[ci, l]
            if s == 0.0:
                continue
            h = pk[ci, l]
            a0, a1, a2 = wq[l, 0], wq[l, 1], wq[l, 2]
            b0, b1, b2 = wq[l, 3] - gt[0], wq[l, 4] - gt[1], wq[l, 5] - gt[2]
            jac[row, h] += a0 * s
            jac[row + 1, h] += a1 * s
            jac[row + 2, h] += a2 * s
            jac[row + 3, h] += (b1 * a2 - b2 * a1) * s
            jac[row + 4, h] += (b2 * a0 - b0 * a2) * s
            jac[row + 5, h] += (b0 * a1 - b1 * a0) * s


@njit
def residuals(xs, pk, ln, sg, kk, kk2, kq, k2q, axis, point):  # pragma: no cover - compiled
    """C (S, 6 m) and J (S, 6 m, n) at configurations xs (S, n): :func:`closure_at` of each
    (``LoopSolver.residuals``' values to round-off)."""
    s_, n = xs.shape
    k = 6 * pk.shape[0]
    c = np.zeros((s_, k))
    jac = np.zeros((s_, k, n))
    wq = np.empty((max(pk.shape[1], 1), 6))
    for i in range(s_):
        closure_at(xs[i], pk, ln, sg, kk, kk2, kq, k2q, axis, point, c[i], jac[i], wq)
    return c, jac


@njit
def _along(basis, j, x):  # pragma: no cover - compiled
    """``basis[:, j] . x``, summed in index order."""
    acc = 0.0
    for a in range(x.shape[0]):
        acc += basis[a, j] * x[a]
    return acc


@njit
def _combine(basis, coef, vec, step):  # pragma: no cover - compiled
    """``vec`` = ``basis`` (its columns the directions) and ``step`` = ``basis @ coef``."""
    n = coef.shape[0]
    for a in range(n):
        acc = 0.0
        for j in range(n):
            vec[a, j] = basis[a, j]
            acc += basis[a, j] * coef[j]
        step[a] = acc


@njit
def _gn_eigh(gram, g, d, stiff, step, vec, fr):  # pragma: no cover - compiled
    """corrector._gn_eigh of one point: step, eigenvectors into ``vec``, null directions
    into ``fr``."""
    n = gram.shape[0]
    lam, v = np.linalg.eigh(gram)
    thr = max(RANK_TOL ** 2 * max(1.0, lam[n - 1]), stiff ** 2)
    coef = np.empty(n)
    for j in range(n):
        keep = lam[j] > thr
        fr[j] = not keep
        coef[j] = -_along(v, j, g) / lam[j] if keep else _along(v, j, d)
    _combine(v, coef, vec, step)


@njit
def _gn_svd(jac, c, d, step, vec, fr, work):  # pragma: no cover - compiled
    """corrector._gn_svd of one point (the rank rule alone), by :func:`svd_small` (``work``
    its scratch)."""
    n = jac.shape[1]
    s, uc, coef = work[8][0], work[8][1], work[8][2]
    svd_small(jac, c, s, vec, uc, work)
    thr = RANK_TOL * max(1.0, s[0])
    for j in range(n):
        keep = s[j] > thr
        fr[j] = not keep
        coef[j] = -uc[j] / s[j] if keep else _along(vec, j, d)
    _combine(vec, coef, vec, step)


@njit
def _gn_line(gram, g, d, guide, step, w, a, rhs):  # pragma: no cover - compiled
    """corrector._gn_line of one point: the step, and the null line into ``w``; ``a`` (n, n)
    and ``rhs`` (n, 2) scratch. J^T J + t t^T is positive definite wherever the line solve
    runs: a Cholesky solve up to SMALL hinges (half the LU's arithmetic), the LU where a
    pivot is not positive after all, LAPACK's ``gesv`` above SMALL."""
    n = gram.shape[0]
    shifted(a, gram, guide, 0.0)
    for i in range(n):
        rhs[i, 0] = guide[i]
        rhs[i, 1] = g[i]
    if n > SMALL:
        sol = np.linalg.solve(a, rhs)
    elif cholesky(a):
        sol = cholesky_solve(a, rhs)
    else:
        shifted(a, gram, guide, 0.0)
        sol = lu_solve(a, rhs)
    nrm = 0.0
    for i in range(n):
        nrm += sol[i, 0] * sol[i, 0]
    nrm = math.sqrt(nrm)
    wd = 0.0
    wx = 0.0
    for i in range(n):
        w[i] = sol[i, 0] / nrm
        wd += w[i] * d[i]
        wx += w[i] * sol[i, 1]
    for i in range(n):
        step[i] = w[i] * (wd + wx) - sol[i, 1]


@njit
def _certified(jac, gram, w, a, cols, cn):  # pragma: no cover - compiled
    """corrector._certified of one point: J's null space is exactly the line w (``a`` (n, n)
    scratch; J w over each cycle's columns, :func:`cycle_columns`: the same sums)."""
    n = w.shape[0]
    tr = 0.0
    for i in range(n):
        tr += gram[i, i]
    thr = RANK_TOL * max(1.0, math.sqrt(tr))
    jw = 0.0
    for ci in range(cols.shape[0]):
        for r in range(6 * ci, 6 * ci + 6):
            acc = 0.0
            for b in range(cn[ci]):
                acc += jac[r, cols[ci, b]] * w[cols[ci, b]]
            jw += acc * acc
    if not math.sqrt(jw) <= thr:
        return False
    shifted(a, gram, w, thr * thr)
    if cholesky(a):
        return True
    shifted(a, gram, w, thr * thr)
    return np.linalg.eigvalsh(a)[0] > 0.0


@njit
def round_pool(x, target, it, spec, far, plain, res, null, done, basis, free, alive, line, guide,
               pk, ln, sg, kk, kk2, kq, k2q, axis, point):  # pragma: no cover - compiled
    """corrector.Pool.round on the pool's arrays (one row a point, the live rows ``alive``)
    with the closure tables of :func:`closure_at`; returns the number of points evaluated."""
    size, n = x.shape
    k = 6 * pk.shape[0]
    c = np.empty(k)
    jac = np.empty((k, n))
    wq = np.empty((max(pk.shape[1], 1), 6))
    gram, sq, rhs = np.empty((n, n)), np.empty((n, n)), np.empty((n, 2))
    g = np.empty(n)
    d = np.empty(n)
    step = np.empty(n)
    vec = np.empty((n, n))
    fr = np.zeros(n, np.bool_)
    w = np.empty(n)
    cols, cn = cycle_columns(pk, ln, n)
    work = svd_work(k, n)
    count = 0
    for i in range(size):
        if not alive[i]:
            continue
        count += 1
        xi = x[i]
        closure_at(xi, pk, ln, sg, kk, kk2, kq, k2q, axis, point, c, jac, wq)
        r = 0.0
        for j in range(k):
            r = max(r, abs(c[j]))
        gn = 1.0 if it[i] < GN_STEPS else 0.0
        xmax = 0.0
        for j in range(n):
            d[j] = (target[i, j] - xi[j]) * gn
            xmax = max(xmax, abs(xi[j]))
        isline = line[i]
        if isline:
            normal_eq(jac, c, gram, g, cols, cn)
            _gn_line(gram, g, d, guide[i], step, w, sq, rhs)
            vec[:, :] = 0.0
            fr[:] = False
            for j in range(n):
                vec[j, 0] = w[j]
                guide[i, j] = w[j]
            fr[0] = True
            nul = 1
        else:
            if plain[i] and xmax < SVD_BELOW:
                _gn_svd(jac, c, d, step, vec, fr, work)
            else:
                normal_eq(jac, c, gram, g, cols, cn)
                _gn_eigh(gram, g, d, RANK_RES * r * (1.0 if far[i] else 0.0), step, vec, fr)
            nul = 0
            for j in range(n):
                nul += 1 if fr[j] else 0
        big = 0.0
        for j in range(n):
            big = max(big, abs(step[j]))
        final = it[i] >= GN_STEPS + NEWTON_STEPS
        stop = (r < CLOSURE_TOL and (big < OPT_TOL or it[i] >= GN_STEPS)) or final
        moving = not stop
        if isline and stop and not final and not _certified(jac, gram, w, sq, cols, cn):
            line[i] = False  # evaluated again, with the eigen-decomposition
            stop = False
            moving = False
        drop = moving and spec[i] and it[i] + 1 >= GN_STEPS
        if stop:
            res[i] = r
            done[i] = big < OPT_TOL and not final
            for a in range(n):
                free[i, a] = fr[a] and not final
                for b in range(n):
                    basis[i, a, b] = vec[a, b]
        if not final:
            null[i] = nul
        if moving and not drop:
            f = min(1.0, MAX_STEP / max(big, 1e-300))
            for j in range(n):
                x[i, j] = xi[j] + step[j] * f
            it[i] += 1
        alive[i] = not stop and not drop
    return count


class CompiledClosure:
    """The closure of a :class:`~foldprint.physics.loops.closure.LoopSolver` for the tracker:
    called with xs (S, n) it gives C and J (``evaluate``); :meth:`fused` takes a whole
    corrector round of a :class:`~foldprint.physics.loops.corrector.Pool` in one call."""

    def __init__(self, solver):
        m = len(solver.cycles)
        self.solver = solver
        pk = np.zeros((m, max((len(c) for c in solver.cycles), default=1)), np.intp)
        ln = np.zeros(m, np.intp)
        sg = np.zeros(pk.shape)
        for ci, cyc in enumerate(solver.cycles):
            ln[ci] = len(cyc)
            for l, (h, s) in enumerate(cyc):
                pk[ci, l], sg[ci, l] = h, s
        a = solver.axis  # each axis's cross-product matrix K and K^2, as LoopSolver makes them
        zero = np.zeros(len(a))
        k = np.stack([np.stack([zero, -a[:, 2], a[:, 1]], 1), np.stack([a[:, 2], zero, -a[:, 0]], 1),
                      np.stack([-a[:, 1], a[:, 0], zero], 1)], 1)
        k2 = k @ k
        kq = np.einsum("nij,nj->ni", k, solver.point)
        k2q = np.einsum("nij,nj->ni", k2, solver.point)
        self.tables = tuple(np.ascontiguousarray(t) for t in (pk, ln, sg, k, k2, kq, k2q, a, solver.point))

    def __call__(self, xs):
        self.solver.evaluations += len(xs)
        return residuals(np.ascontiguousarray(xs, dtype=float), *self.tables)

    def fused(self, pool) -> int:
        """One round of every live point of ``pool``; returns how many were evaluated."""
        count = round_pool(pool.x, pool.target, pool.it, pool.spec, pool.far, pool.plain, pool.res, pool.null,
                           pool.done, pool.basis, pool.free, pool.alive, pool.line, pool.guide, *self.tables)
        return self.counted(count)

    def counted(self, evaluations: int) -> int:
        """Count ``evaluations`` (of a round, or of a whole compiled track:
        :mod:`~foldprint.physics.loops.track_kernels`) in the solver's; returns them."""
        self.solver.evaluations += evaluations
        return evaluations


stale_with(__name__, (corrector, decomp_kernels, normal_kernels))
