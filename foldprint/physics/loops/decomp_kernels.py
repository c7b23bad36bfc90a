"""Compiled small decompositions of the loop tracker's compiled round
(:mod:`foldprint.physics.loops.closure_kernels`): the SVD of a closure Jacobian J (k, n),
hand-written for the sizes the tracker meets (n up to a few tens), where LAPACK's drivers
through numba pay more for their calls, copies and workspace than for their arithmetic.

The SVD is the preconditioned one-sided Jacobi method (Drmac and Veselic, "New fast and
accurate Jacobi SVD algorithm", SIAM J. Matrix Anal. Appl. 29, 2008): a Householder QR of J
with column pivoting, ``J P = Q1 R1`` (the reflectors applied to the right-hand side C as
well, so Q1 is never formed), a QR of R1^T, ``R1^T = Q2 R2``, then one-sided Jacobi
rotations (Hestenes) on the columns of ``L = R2^T``, accumulated into ``V = P Q2``, until
every pair of columns is orthogonal to EPS of their norms: ``L W = U_L S``, so ``J = (Q1
U_L) S (P Q2 W)^T``. The two QRs leave L's columns nearly orthogonal and strongly graded,
so the rotations converge in 4-5 sweeps where J itself takes 9-10 (``miura_3x3``). The
pairs are taken in round-robin order (n/2 disjoint pairs at a time): their inner products
and rotation angles are independent, so the processor overlaps them instead of waiting on
each square root.
One-sided Jacobi resolves small singular values at least as well as LAPACK's ``gesdd``
(whose error is round-off of the largest; Jacobi's, for a graded matrix as L, round-off of
each), which is what the rank rule near the flat sheet needs (``docs/loops.md``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import njit

#: two columns count as orthogonal when their inner product is at most EPS times the
#: product of their norms (our choice: the unit round-off's order; LAPACK ``dgesvj`` takes
#: sqrt(rows) times it)
EPS = 2.0 ** -52
#: a column below TINY times the largest column is round-off of the QR: it is not rotated
#: against another (our choice: far below the rank rule's 1e-7; without it, two columns
#: of pure round-off can take rotations forever)
TINY = 1e-30
#: sweeps of the rotations at most (our choice: the tracker's Jacobians take 2-5; one that
#: has not converged keeps what it has, orthogonal to round-off)
SWEEPS = 30
#: the last sweep: one whose rotations were all below LAST (the cosine of the pair's angle)
#: leaves them orthogonal to about LAST^2 (Jacobi converges quadratically), which is EPS
#: (our choice: saves the sweep that would find no rotation to make)
LAST = 1e-8


@njit(contract=True, inline=True)
def reflect(v, f, x, lo):  # pragma: no cover - compiled
    """``x`` (m,) times the reflector ``I - f v v^T`` whose vector ``v`` (m,) is zero
    before ``lo``: x[lo:] -= f (v[lo:] . x[lo:]) v[lo:], in place."""
    dot = 0.0
    for i in range(lo, x.shape[0]):
        dot += v[i] * x[i]
    dot *= f
    for i in range(lo, x.shape[0]):
        x[i] -= dot * v[i]


@njit(contract=True)
def house(ct, b, pivot, perm, vs, fs, r):  # pragma: no cover - compiled
    """Householder QR of the m x n matrix (m >= n) whose columns are the rows of ``ct``
    (n, m; overwritten): R (n, n) into ``r`` (zeros below the diagonal), the reflectors
    ``I - fs[j] v v^T`` (v = ``vs[j, j:]``) into ``vs`` (n, m) and ``fs`` (n,), ``b`` (m,;
    skipped if empty) into Q^T b. With ``pivot`` the remaining column of largest norm comes
    first; ``perm`` (n,): the columns' order (``matrix[:, perm] = Q R``)."""
    n, m = ct.shape
    for j in range(n):
        perm[j] = j
    for j in range(n):
        best, bq = -1.0, j
        for q in range(j, n if pivot else j + 1):
            acc = 0.0
            for i in range(j, m):
                acc += ct[q, i] * ct[q, i]
            if acc > best:
                best, bq = acc, q
        if bq != j:
            for i in range(m):
                ct[j, i], ct[bq, i] = ct[bq, i], ct[j, i]
            for i in range(j):
                r[i, j], r[i, bq] = r[i, bq], r[i, j]
            perm[j], perm[bq] = perm[bq], perm[j]
        nrm = math.sqrt(best)
        fs[j] = 0.0
        for i in range(j, m):
            vs[j, i] = ct[j, i]
        r[j, j] = 0.0
        if nrm > 0.0:
            alpha = -nrm if ct[j, j] >= 0.0 else nrm
            vs[j, j] -= alpha
            fs[j] = 1.0 / (nrm * (nrm + abs(ct[j, j])))  # 2 / |v|^2
            r[j, j] = alpha
        for q in range(j + 1, n):
            reflect(vs[j], fs[j], ct[q], j)
            r[j, q] = ct[q, j]
            r[q, j] = 0.0
        if b.shape[0]:
            reflect(vs[j], fs[j], b, j)


@njit(contract=True)
def form_q(vs, fs, q):  # pragma: no cover - compiled
    """Q (n, n) = H_0 ... H_{n-1} of :func:`house`'s reflectors of a square matrix."""
    n = q.shape[0]
    for i in range(n):
        for j in range(n):
            q[i, j] = 1.0 if i == j else 0.0
    for j in range(n - 1, -1, -1):
        if fs[j] == 0.0:
            continue
        for c in range(j, n):
            reflect(vs[j], fs[j], q[:, c], j)


@njit(contract=True)
def jacobi_rows(at, vt, cs, sn, ids):  # pragma: no cover - compiled
    """One-sided Jacobi on the columns of A whose rows of ``at`` (n, m) they are, each
    rotation applied to the rows of ``vt`` (n, n) as well, until every pair is orthogonal
    to EPS: afterwards ``at`` = (A W)^T and ``vt`` = (V W)^T, W orthogonal, A W's columns
    orthogonal (their norms the singular values, unsorted). The pairs in round-robin order,
    n/2 disjoint ones at a time; ``cs``, ``sn`` (n // 2 + 1,) and ``ids`` (n + 1,) scratch.
    Returns the sweeps taken (the last one without a rotation)."""
    n, m = at.shape
    n2 = n + (n & 1)  # an odd n plays against a dummy column n
    half = n2 // 2
    big = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(m):
            acc += at[j, i] * at[j, i]
        big = max(big, acc)
    tiny = TINY * TINY * big
    for i in range(n2):
        ids[i] = i
    for sweep in range(SWEEPS):
        rotated = False
        worst = 0.0
        for _ in range(n2 - 1):
            for k in range(half):
                p, q = ids[k], ids[n2 - 1 - k]
                cs[k], sn[k] = 1.0, 0.0
                if p >= n or q >= n:
                    continue
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(m):
                    alpha += at[p, i] * at[p, i]
                    beta += at[q, i] * at[q, i]
                    gamma += at[p, i] * at[q, i]
                if gamma * gamma <= EPS * EPS * alpha * beta or alpha <= tiny or beta <= tiny:
                    continue
                worst = max(worst, gamma * gamma / (alpha * beta))
                zeta = (beta - alpha) / (2.0 * gamma)
                t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                c = 1.0 / math.sqrt(1.0 + t * t)
                cs[k], sn[k] = c, c * t
                rotated = True
            for k in range(half):
                if sn[k] == 0.0:
                    continue
                p, q, c, s = ids[k], ids[n2 - 1 - k], cs[k], sn[k]
                for i in range(m):
                    x, y = at[p, i], at[q, i]
                    at[p, i] = c * x - s * y
                    at[q, i] = s * x + c * y
                for i in range(n):
                    x, y = vt[p, i], vt[q, i]
                    vt[p, i] = c * x - s * y
                    vt[q, i] = s * x + c * y
            last = ids[n2 - 1]
            for i in range(n2 - 1, 1, -1):
                ids[i] = ids[i - 1]
            ids[1] = last
        if not rotated or worst <= LAST * LAST:
            return sweep + 1
    return SWEEPS


@njit
def svd_work(k, n):  # pragma: no cover - compiled
    """Scratch for :func:`svd_small` of a (k, n) matrix, allocated once per round."""
    mk = max(k, n)
    return (np.empty((n, mk)), np.empty((n, mk)), np.empty((n, n)), np.empty((n, n)), np.empty((n, n)),
            np.empty((n, n)), np.empty((7, mk + 1)), np.empty((3, n + 1), np.intp))


@njit
def svd_small(jac, c, s, vec, uc, work):  # pragma: no cover - compiled
    """The SVD of ``jac`` (k, n) as the tracker takes it: singular values into ``s`` (n,),
    largest first (zeros past min(k, n)), the right singular vectors into the columns of
    ``vec`` (n, n: a full basis), U^T c into ``uc`` (n,; zeros past min(k, n)); ``work``
    from :func:`svd_work`. Returns the Jacobi sweeps taken."""
    k, n = jac.shape
    ct, vs, r1, at, q2, vt, fv, iv = work
    b, qb, fs, nrm, dots, cs, sn = fv[0], fv[1], fv[2], fv[3], fv[4], fv[5], fv[6]
    perm, order, ids = iv[0, :n], iv[1, :n], iv[2]
    pivot = k > 0  # True, known at run time only (literal flags would compile house twice)
    qb[:] = 0.0
    if k >= n:
        for j in range(n):
            for i in range(k):
                ct[j, i] = jac[i, j]
        b[:k] = c
        house(ct, b[:k], pivot, perm, vs, fs, r1)
        qb[:n] = b[:n]
    else:  # fewer equations than angles: J with zero rows below
        r1[:, :] = 0.0
        r1[:k] = jac
        qb[:k] = c
        for j in range(n):
            perm[j] = j
    house(r1, qb[:0], not pivot, order, vt, fs, at)  # R1^T = Q2 R2: L = R2^T, its columns R2's rows
    form_q(vt, fs, q2)
    for i in range(n):
        for j in range(n):
            vt[j, perm[i]] = q2[i, j]  # V = P Q2
    sweeps = jacobi_rows(at, vt, cs, sn, ids)
    for j in range(n):
        acc = 0.0
        dot = 0.0
        for i in range(n):
            acc += at[j, i] * at[j, i]
            dot += at[j, i] * qb[i]
        nrm[j] = math.sqrt(acc)
        dots[j] = dot
    for jj in range(n):  # largest first (a selection: n is small)
        best, j = -1.0, 0
        for q in range(n):
            if nrm[q] > best:
                best, j = nrm[q], q
        s[jj] = best if jj < k else 0.0
        uc[jj] = dots[j] / best if best > 0.0 and jj < k else 0.0
        nrm[j] = -2.0
        for i in range(n):
            vec[i, jj] = vt[j, i]
    return sweeps
