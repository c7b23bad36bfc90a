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
so the rotations converge in 4 sweeps where J itself takes 9-10 (``miura_3x3``). The
pairs are taken in row-cyclic order: L's columns come graded, largest first, and that
order settles them in 4.00 sweeps against 4.13 for the round-robin order's disjoint pairs
(whose independent angles the processor could overlap; with the cheaper pair below, the
sweep saved pays more). A pair costs one inner product: the columns' squared norms are
carried along (Rutishauser's update, alpha - t gamma and beta + t gamma) and computed
afresh once a column has lost most of its norm; the angle takes two square roots and one
division (one division where its cosine is 1 in floating point). The rotations turn the
rows of L^T and V^T as one row of 2n. The pivoted QR picks its columns by norms downdated
the same way (LAPACK ``dgeqp3``'s rule); inner products are summed in four interleaved
parts.
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
#: a squared column norm carried along by updates is computed afresh once it falls below
#: FRESH times its last fresh value: an update's round-off is that of the larger norm, so
#: the carried one stays within ~FRESH^-1 x (updates) x EPS of itself, ~1e-13 (our choice,
#: the role of LAPACK ``dgeqp3``'s and ``dgesvj``'s recomputation tests)
FRESH = 1.0 / 16.0
#: a rotation whose tangent t = gamma / (beta - alpha) is below 2^-28 (2 gamma below
#: SMALL |beta - alpha|) has cosine 1 in floating point (1 + t^2 rounds to 1)
SMALL = 2.0 ** -27
#: the angle's squares (beta - alpha)^2 + 4 gamma^2 are used between SAFE and 1 / SAFE, far
#: from under- and overflow; outside, Rutishauser's ratio form (our choice)
SAFE = 1e-250


@njit(contract=True, inline=True)
def dot(x, y, lo, hi):  # pragma: no cover - compiled
    """``x[lo:hi] . y[lo:hi]``, summed in four interleaved parts (four additions in
    flight instead of one chain)."""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    i = lo
    while i + 4 <= hi:
        a0 += x[i] * y[i]
        a1 += x[i + 1] * y[i + 1]
        a2 += x[i + 2] * y[i + 2]
        a3 += x[i + 3] * y[i + 3]
        i += 4
    while i < hi:
        a0 += x[i] * y[i]
        i += 1
    return (a0 + a1) + (a2 + a3)


@njit(contract=True, inline=True)
def reflect(v, f, x, lo):  # pragma: no cover - compiled
    """``x`` (m,) times the reflector ``I - f v v^T`` whose vector ``v`` (m,) is zero
    before ``lo``: x[lo:] -= f (v[lo:] . x[lo:]) v[lo:], in place."""
    d = dot(v, x, lo, x.shape[0]) * f
    for i in range(lo, x.shape[0]):
        x[i] -= d * v[i]


@njit(contract=True)
def house(ct, b, pivot, perm, vs, fs, r, cn, c0):  # pragma: no cover - compiled
    """Householder QR of the m x n matrix (m >= n) whose columns are the rows of ``ct``
    (n, m; overwritten): R (n, n) into ``r`` (zeros below the diagonal), the reflectors
    ``I - fs[j] v v^T`` (v = ``vs[j, j:]``) into ``vs`` (n, m) and ``fs`` (n,), ``b`` (m,;
    skipped if empty) into Q^T b. With ``pivot`` the remaining column of largest norm comes
    first, by squared norms downdated after each reflector (``cn`` (n,); ``c0`` (n,) their
    last fresh values, see FRESH); ``perm`` (n,): the columns' order (``matrix[:, perm] = Q R``)."""
    n, m = ct.shape
    for j in range(n):
        perm[j] = j
    if pivot:
        for q in range(n):
            cn[q] = dot(ct[q], ct[q], 0, m)
            c0[q] = cn[q]
    for j in range(n):
        bq = j
        if pivot:
            best = -1.0
            for q in range(j, n):
                if cn[q] > best:
                    best, bq = cn[q], q
        if bq != j:
            for i in range(m):
                ct[j, i], ct[bq, i] = ct[bq, i], ct[j, i]
            for i in range(j):
                r[i, j], r[i, bq] = r[i, bq], r[i, j]
            perm[j], perm[bq] = perm[bq], perm[j]
            cn[j], cn[bq] = cn[bq], cn[j]
            c0[j], c0[bq] = c0[bq], c0[j]
        nrm = math.sqrt(dot(ct[j], ct[j], j, m))
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
            if pivot:
                cn[q] -= ct[q, j] * ct[q, j]
                if cn[q] <= FRESH * c0[q]:
                    cn[q] = dot(ct[q], ct[q], j + 1, m)
                    c0[q] = cn[q]
        if b.shape[0]:
            reflect(vs[j], fs[j], b, j)


@njit(contract=True)
def form_qt(vs, fs, qt):  # pragma: no cover - compiled
    """Q^T (n, n) of :func:`house`'s reflectors of a square matrix, row by row: row c is Q's
    column c, H_0 ... H_{n-1} e_c (contiguous rows for the reflectors)."""
    n = qt.shape[0]
    for i in range(n):
        for j in range(n):
            qt[i, j] = 1.0 if i == j else 0.0
    for j in range(n - 1, -1, -1):
        if fs[j] == 0.0:
            continue
        for c in range(j, n):
            reflect(vs[j], fs[j], qt[c], j)


@njit(contract=True, inline=True)
def angle(alpha, beta, gamma):  # pragma: no cover - compiled
    """The Jacobi rotation that makes two columns of squared norms ``alpha``, ``beta`` and
    inner product ``gamma`` orthogonal: (cos, sin, t gamma), t = sin / cos the tangent of
    Rutishauser's formula (the smaller root of t^2 + 2 zeta t - 1, zeta = (beta - alpha) /
    (2 gamma)), written with d = beta - alpha, g = 2 gamma, h = |(d, g)|, e = |d| + h:
    cos = e / sqrt(2 h e), sin = sign(d) g / sqrt(2 h e), t gamma = sign(d) g gamma 2 h /
    (2 h e); where h^2 nears under- or overflow, Rutishauser's own form in zeta."""
    dd = beta - alpha
    gg = 2.0 * gamma
    if abs(gg) < SMALL * abs(dd):
        t = gamma / dd
        return 1.0, t, t * gamma
    h2 = dd * dd + gg * gg
    if not SAFE < h2 < 1.0 / SAFE:  # squares near under- or overflow: the ratio form
        zeta = dd / gg
        t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
        c = 1.0 / math.sqrt(1.0 + t * t)
        return c, c * t, t * gamma
    h = math.sqrt(h2)
    e = abs(dd) + h
    r = 1.0 / math.sqrt(2.0 * h * e)
    sg = gg if dd >= 0.0 else -gg
    sn = sg * r
    return e * r, sn, sn * (gamma * r) * (2.0 * h)  # in this order, no product near 0 or inf


@njit(contract=True)
def jacobi_rows(av, n, nq, n0):  # pragma: no cover - compiled
    """One-sided Jacobi on the columns of A whose rows are the first ``n`` entries of the
    rows of ``av`` (n, w); each rotation turns the whole rows (w >= n), so ``av[:, n:]``
    holds (V W)^T afterwards when it held V^T. Until every pair is orthogonal to EPS:
    afterwards ``av[:, :n]`` = (A W)^T, W orthogonal, A W's columns orthogonal (their norms
    the singular values, unsorted). The pairs in row-cyclic order, (0, 1), (0, 2), ...,
    (n - 2, n - 1); scratch ``nq``, ``n0`` (n,: squared norms carried and their last fresh
    values). Returns the sweeps taken (the last one without a rotation above LAST)."""
    w = av.shape[1]
    big = 0.0
    for j in range(n):
        nq[j] = dot(av[j], av[j], 0, n)
        n0[j] = nq[j]
        big = max(big, nq[j])
    tiny = TINY * TINY * big
    for sweep in range(SWEEPS):
        large = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                alpha = nq[p]
                beta = nq[q]
                gamma = dot(av[p], av[q], 0, n)
                if gamma * gamma <= EPS * EPS * alpha * beta or alpha <= tiny or beta <= tiny:
                    continue
                large = large or gamma * gamma > LAST * LAST * alpha * beta
                c, s, tg = angle(alpha, beta, gamma)
                for i in range(w):
                    x, y = av[p, i], av[q, i]
                    av[p, i] = c * x - s * y
                    av[q, i] = s * x + c * y
                nq[p] -= tg
                nq[q] += tg
                if nq[p] <= FRESH * n0[p]:
                    nq[p] = dot(av[p], av[p], 0, n)
                    n0[p] = nq[p]
                if nq[q] <= FRESH * n0[q]:
                    nq[q] = dot(av[q], av[q], 0, n)
                    n0[q] = nq[q]
        if not large:
            return sweep + 1
    return SWEEPS


@njit
def svd_work(k, n):  # pragma: no cover - compiled
    """Scratch for :func:`svd_small` of a (k, n) matrix, allocated once per round; its last
    entry (3, n) is the caller's (:func:`~foldprint.physics.loops.closure_kernels._gn_svd`'s
    singular values, U^T c and coefficients)."""
    mk = max(k, n)
    return (np.empty((n, mk)), np.empty((n, mk)), np.empty((n, n)), np.empty((n, 2 * n)), np.empty((n, n)),
            np.empty((n, n)), np.empty((7, mk + 1)), np.empty((2, n), np.intp), np.empty((3, n)))


@njit
def svd_small(jac, c, s, vec, uc, work):  # pragma: no cover - compiled
    """The SVD of ``jac`` (k, n) as the tracker takes it: singular values into ``s`` (n,),
    largest first (zeros past min(k, n)), the right singular vectors into the columns of
    ``vec`` (n, n: a full basis), U^T c into ``uc`` (n,; zeros past min(k, n)); ``work``
    from :func:`svd_work`. Returns the Jacobi sweeps taken."""
    k, n = jac.shape
    ct, vs, r1, av, qt, at, fv, iv, _ = work
    b, qb, fs, nrm, dots, cn, c0 = fv[0], fv[1], fv[2], fv[3], fv[4], fv[5], fv[6]
    perm, order = iv[0], iv[1]
    pivot = k > 0  # True, known at run time only (literal flags would compile house twice)
    qb[:] = 0.0
    if k >= n:
        for j in range(n):
            for i in range(k):
                ct[j, i] = jac[i, j]
        b[:k] = c
        house(ct, b[:k], pivot, perm, vs, fs, r1, cn, c0)
        qb[:n] = b[:n]
    else:  # fewer equations than angles: J with zero rows below
        r1[:, :] = 0.0
        r1[:k] = jac
        qb[:k] = c
        for j in range(n):
            perm[j] = j
    house(r1, qb[:0], not pivot, order, vs, fs, at, cn, c0)  # R1^T = Q2 R2: L = R2^T, its columns R2's rows
    form_qt(vs, fs, qt)
    for j in range(n):  # av = [L^T | V^T], V = P Q2
        for i in range(n):
            av[j, i] = at[j, i]
            av[j, n + perm[i]] = qt[j, i]
    sweeps = jacobi_rows(av, n, nrm, dots)
    for j in range(n):
        nrm[j] = math.sqrt(dot(av[j], av[j], 0, n))
        dots[j] = dot(av[j], qb, 0, n)
    for jj in range(n):  # largest first (a selection: n is small)
        best, j = -1.0, 0
        for q in range(n):
            if nrm[q] > best:
                best, j = nrm[q], q
        s[jj] = best if jj < k else 0.0
        uc[jj] = dots[j] / best if best > 0.0 and jj < k else 0.0
        nrm[j] = -2.0
        for i in range(n):
            vec[i, jj] = av[j, n + i]
    return sweeps
