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
(the same LAPACK drivers ``syevd`` and ``gesv``, the SVD hand-written in
:mod:`~foldprint.physics.loops.decomp_kernels`; the sums in another order).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import njit
from .corrector import CLOSURE_TOL, GN_STEPS, MAX_STEP, NEWTON_STEPS, OPT_TOL, RANK_RES, RANK_TOL, SVD_BELOW
from .decomp_kernels import svd_small, svd_work

#: hinges up to which the line solve takes the hand-written LU (:func:`_lu_solve`), LAPACK's
#: above (our choice: a 12-hinge solve costs 0.5 us by hand against 1.4 us through LAPACK;
#: LAPACK's blocked factorisation wins on the large patterns' hundreds of hinges)
SMALL = 32


@njit
def closure_at(x, pk, ln, sg, kk, kk2, kq, k2q, axis, point, c, jac, wq):  # pragma: no cover - compiled
    """C (6 m,) into ``c`` and J (6 m, n) into ``jac`` (zeroed here) at angles x (n,): cycle
    ci is the places l < ln[ci], hinge pk[ci, l] with sign sg[ci, l]; kk, kk2 (n, 3, 3)
    each hinge's axis cross-product matrix and its square, kq, k2q (n, 3) those times its
    point, ``axis`` and ``point`` (n, 3) its fold line; ``wq`` (L, 6) scratch: each place's
    axis and point moved by its prefix."""
    m = pk.shape[0]
    jac[:, :] = 0.0
    gr = np.empty((3, 3))
    nr = np.empty((3, 3))
    r = np.empty((3, 3))
    gt = np.empty(3)
    tl = np.empty(3)
    for ci in range(m):
        for l in range(ln[ci]):
            h = pk[ci, l]
            th = x[h] * (-1.0 if sg[ci, l] < 0 else 1.0)
            sn = math.sin(th)
            c1 = 1.0 - math.cos(th)
            for a in range(3):
                for b in range(3):
                    r[a, b] = sn * kk[h, a, b] + c1 * kk2[h, a, b]
                r[a, a] += 1.0
                tl[a] = -(sn * kq[h, a] + c1 * k2q[h, a])
            if l == 0:
                for a in range(3):
                    wq[0, a] = axis[h, a]
                    wq[0, 3 + a] = point[h, a]
                    gt[a] = tl[a]
                    for b in range(3):
                        gr[a, b] = r[a, b]
                continue
            for a in range(3):
                wq[l, a] = gr[a, 0] * axis[h, 0] + gr[a, 1] * axis[h, 1] + gr[a, 2] * axis[h, 2]
                wq[l, 3 + a] = (gr[a, 0] * point[h, 0] + gr[a, 1] * point[h, 1] + gr[a, 2] * point[h, 2]) + gt[a]
            m0 = gr[0, 0] * tl[0] + gr[0, 1] * tl[1] + gr[0, 2] * tl[2]
            m1 = gr[1, 0] * tl[0] + gr[1, 1] * tl[1] + gr[1, 2] * tl[2]
            m2 = gr[2, 0] * tl[0] + gr[2, 1] * tl[1] + gr[2, 2] * tl[2]
            gt[0] += m0
            gt[1] += m1
            gt[2] += m2
            for a in range(3):
                for b in range(3):
                    nr[a, b] = gr[a, 0] * r[0, b] + gr[a, 1] * r[1, b] + gr[a, 2] * r[2, b]
            for a in range(3):
                for b in range(3):
                    gr[a, b] = nr[a, b]
        # the cycle's residual: rotation vector of gr (closure._rotvecs), translation gt
        row = 6 * ci
        tr = (gr[0, 0] + gr[1, 1] + gr[2, 2] - 1.0) / 2.0
        ang = math.acos(min(max(tr, -1.0), 1.0))
        v0, v1, v2 = gr[2, 1] - gr[1, 2], gr[0, 2] - gr[2, 0], gr[1, 0] - gr[0, 1]
        if math.pi - ang < 1e-6:  # half-turn residuals never occur near closure (closure._rotvec)
            mk, best = 0, -1.0
            for a in range(3):
                if (gr[a, a] + 1.0) / 2.0 > best:
                    best, mk = (gr[a, a] + 1.0) / 2.0, a
            nrm = math.sqrt(max(best, 1e-300))
            v0 = ang * ((gr[0, mk] + (1.0 if mk == 0 else 0.0)) / 2.0 / nrm)
            v1 = ang * ((gr[1, mk] + (1.0 if mk == 1 else 0.0)) / 2.0 / nrm)
            v2 = ang * ((gr[2, mk] + (1.0 if mk == 2 else 0.0)) / 2.0 / nrm)
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
def _normal(jac, c, gram, g, nz):  # pragma: no cover - compiled
    """J^T J into ``gram`` (symmetric to the bit) and J^T C into ``g``, row by row of J over
    its nonzero entries (a row is one cycle's: at most its length of them; ``nz`` (n,)
    scratch for their columns)."""
    k, n = jac.shape
    gram[:, :] = 0.0
    g[:] = 0.0
    for r in range(k):
        cnt = 0
        for a in range(n):
            if jac[r, a] != 0.0:
                nz[cnt] = a
                cnt += 1
        cr = c[r]
        for i in range(cnt):
            a = nz[i]
            ja = jac[r, a]
            g[a] += ja * cr
            for j in range(i, cnt):
                gram[a, nz[j]] += ja * jac[r, nz[j]]
    for a in range(n):
        for b in range(a + 1, n):
            gram[b, a] = gram[a, b]


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
def _lu_solve(a, b):  # pragma: no cover - compiled
    """``np.linalg.solve(a, b)`` for a small square ``a`` (n, n) and b (n, r), both
    overwritten: LU with partial pivoting (LAPACK getrf's pivot, the first largest in its
    column), forward and back substitution; returns b. A zero pivot gives inf or nan, where
    LAPACK raises (J^T J + t t^T is positive definite wherever the line solve runs)."""
    n, nr = b.shape
    for j in range(n):
        p, big = j, abs(a[j, j])
        for i in range(j + 1, n):
            if abs(a[i, j]) > big:
                p, big = i, abs(a[i, j])
        if p != j:
            for q in range(n):
                a[j, q], a[p, q] = a[p, q], a[j, q]
            for q in range(nr):
                b[j, q], b[p, q] = b[p, q], b[j, q]
        inv = 1.0 / a[j, j]
        for i in range(j + 1, n):
            f = a[i, j] * inv
            a[i, j] = f
            for q in range(j + 1, n):
                a[i, q] -= f * a[j, q]
            for q in range(nr):
                b[i, q] -= f * b[j, q]
    for q in range(nr):
        for i in range(n - 1, -1, -1):
            acc = b[i, q]
            for k in range(i + 1, n):
                acc -= a[i, k] * b[k, q]
            b[i, q] = acc / a[i, i]
    return b


@njit
def _gn_line(gram, g, d, guide, step, w):  # pragma: no cover - compiled
    """corrector._gn_line of one point: the step, and the null line into ``w``."""
    n = gram.shape[0]
    a = np.empty((n, n))
    rhs = np.empty((n, 2))
    for i in range(n):
        for j in range(n):
            a[i, j] = gram[i, j] + guide[i] * guide[j]
        rhs[i, 0] = guide[i]
        rhs[i, 1] = g[i]
    sol = _lu_solve(a, rhs) if n <= SMALL else np.linalg.solve(a, rhs)
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
def _positive_definite(a):  # pragma: no cover - compiled
    """Whether the Cholesky factorisation of the symmetric ``a`` succeeds (every pivot
    positive, LAPACK potrf's test), on a copy."""
    n = a.shape[0]
    f = a.copy()
    for j in range(n):
        s = f[j, j]
        for p in range(j):
            s -= f[j, p] * f[j, p]
        if not s > 0.0:
            return False
        s = math.sqrt(s)
        f[j, j] = s
        for i in range(j + 1, n):
            t = f[i, j]
            for p in range(j):
                t -= f[i, p] * f[j, p]
            f[i, j] = t / s
    return True


@njit
def _certified(jac, gram, w):  # pragma: no cover - compiled
    """corrector._certified of one point: J's null space is exactly the line w."""
    k, n = jac.shape
    tr = 0.0
    for i in range(n):
        tr += gram[i, i]
    thr = RANK_TOL * max(1.0, math.sqrt(tr))
    jw = 0.0
    for r in range(k):
        acc = 0.0
        for a in range(n):
            acc += jac[r, a] * w[a]
        jw += acc * acc
    if not math.sqrt(jw) <= thr:
        return False
    a = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            a[i, j] = gram[i, j] + w[i] * w[j]
        a[i, i] -= thr * thr
    if _positive_definite(a):
        return True
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
    gram = np.empty((n, n))
    g = np.empty(n)
    d = np.empty(n)
    step = np.empty(n)
    vec = np.empty((n, n))
    fr = np.zeros(n, np.bool_)
    w = np.empty(n)
    nz = np.empty(n, np.intp)
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
            _normal(jac, c, gram, g, nz)
            _gn_line(gram, g, d, guide[i], step, w)
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
                _normal(jac, c, gram, g, nz)
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
        if isline and stop and not final and not _certified(jac, gram, w):
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
        self.solver, self._warm = solver, False
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

    def warm(self) -> None:
        """Load the compiled round (compile it on a cold cache) without a point to evaluate."""
        if not self._warm:
            from .corrector import Pool

            self.fused(Pool(self.solver.n, 1))
            self._warm = True

    def fused(self, pool) -> int:
        """One round of every live point of ``pool``; returns how many were evaluated."""
        count = round_pool(pool.x, pool.target, pool.it, pool.spec, pool.far, pool.plain, pool.res, pool.null,
                           pool.done, pool.basis, pool.free, pool.alive, pool.line, pool.guide, *self.tables)
        self.solver.evaluations += count
        return count
