"""The normal equations of the loop tracker's compiled round
(:mod:`foldprint.physics.loops.closure_kernels`), small and dense: J^T J and J^T C summed
over each cycle's block of the closure Jacobian, and the solves of the line step and its
certification (:func:`~foldprint.physics.loops.corrector._gn_line`,
:func:`~foldprint.physics.loops.corrector._certified`): a Cholesky factorisation of
J^T J + u u^T, its two right-hand sides substituted together, and the LU with partial
pivoting that ``numpy.linalg.solve`` takes, kept for a matrix that is not positive
definite after all.

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import njit


@njit
def cycle_columns(pk, ln, n):  # pragma: no cover - compiled
    """Each cycle's hinges, ascending, each once: cycle ci's are ``cols[ci, :cn[ci]]``, the
    only columns its six rows of J fill (:func:`closure_at`). Returns (cols, cn)."""
    m = pk.shape[0]
    cols = np.zeros((m, max(pk.shape[1], 1)), np.intp)
    cn = np.zeros(m, np.intp)
    seen = np.zeros(n, np.bool_)
    for ci in range(m):
        seen[:] = False
        for l in range(ln[ci]):
            seen[pk[ci, l]] = True
        for a in range(n):
            if seen[a]:
                cols[ci, cn[ci]] = a
                cn[ci] += 1
    return cols, cn


@njit
def normal_eq(jac, c, gram, g, cols, cn):  # pragma: no cover - compiled
    """J^T J into ``gram`` (symmetric to the bit) and J^T C into ``g``, cycle by cycle over
    its 6 x cn block of J (:func:`cycle_columns`); each entry summed over J's rows in order
    (what a sum over every row's nonzero entries gives, bit for bit)."""
    gram[:, :] = 0.0
    g[:] = 0.0
    for ci in range(cols.shape[0]):
        r0 = 6 * ci
        for i in range(cn[ci]):
            a = cols[ci, i]
            acc = g[a]
            for r in range(r0, r0 + 6):
                acc += jac[r, a] * c[r]
            g[a] = acc
            for j in range(i, cn[ci]):
                b = cols[ci, j]
                acc = gram[a, b]
                for r in range(r0, r0 + 6):
                    acc += jac[r, a] * jac[r, b]
                gram[a, b] = acc
    n = g.shape[0]
    for a in range(n):
        for b in range(a + 1, n):
            gram[b, a] = gram[a, b]


@njit
def lu_solve(a, b):  # pragma: no cover - compiled
    """``np.linalg.solve(a, b)`` for a small square ``a`` (n, n) and b (n, r), both
    overwritten: LU with partial pivoting (LAPACK getrf's pivot, the first largest in its
    column), forward and back substitution; returns b. A zero pivot gives inf or nan, where
    LAPACK raises. The line solve's fallback where :func:`cholesky` meets a pivot not positive."""
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
def cholesky(a):  # pragma: no cover - compiled
    """a = L L^T for a symmetric ``a`` (n, n), in place: L in its lower triangle, except that
    each diagonal entry holds 1 / L_jj (:func:`cholesky_solve` multiplies by it). Returns
    whether every pivot is positive (LAPACK potrf's test); where one is not, ``a`` is left
    part-factored."""
    n = a.shape[0]
    for j in range(n):
        s = a[j, j]
        for p in range(j):
            s -= a[j, p] * a[j, p]
        if not s > 0.0:
            return False
        inv = 1.0 / math.sqrt(s)
        a[j, j] = inv
        for i in range(j + 1, n):
            t = a[i, j]
            for p in range(j):
                t -= a[i, p] * a[j, p]
            a[i, j] = t * inv
    return True


@njit
def cholesky_solve(f, b):  # pragma: no cover - compiled
    """Solve ``a x = b`` for two right-hand sides b (n, 2), overwritten with x, with a's
    factor ``f`` from :func:`cholesky` (L y = b, then L^T x = y); returns b."""
    n = b.shape[0]
    for i in range(n):
        acc0, acc1 = b[i, 0], b[i, 1]
        for p in range(i):
            acc0 -= f[i, p] * b[p, 0]
            acc1 -= f[i, p] * b[p, 1]
        b[i, 0], b[i, 1] = acc0 * f[i, i], acc1 * f[i, i]
    for i in range(n - 1, -1, -1):
        acc0, acc1 = b[i, 0], b[i, 1]
        for p in range(i + 1, n):
            acc0 -= f[p, i] * b[p, 0]
            acc1 -= f[p, i] * b[p, 1]
        b[i, 0], b[i, 1] = acc0 * f[i, i], acc1 * f[i, i]
    return b


@njit
def shifted(a, gram, u, shift):  # pragma: no cover - compiled
    """``a`` = J^T J + u u^T - shift I."""
    n = a.shape[0]
    for i in range(n):
        for j in range(n):
            a[i, j] = gram[i, j] + u[i] * u[j]
        a[i, i] -= shift
