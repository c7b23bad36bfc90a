"""The normal equations of the loop tracker's compiled round
(``foldprint/physics/loops/normal_kernels.py``) and the line solve built on them, against
numpy: J^T J and J^T C over each cycle's block against ``jac.T @ jac`` (and, bit for bit,
against the sum over every row in order, which the scan over each row's nonzero entries
gave before); the Cholesky solve and the LU against ``numpy.linalg.solve`` on random systems,
positive definite ones graded up to a condition number of 1e12, indefinite and singular
ones refused; the compiled line step against ``corrector._gn_line`` (LAPACK ``gesv``),
where the Cholesky factorisation succeeds and where it falls back to the LU.

Tolerances: J^T J within 1e-13 of its largest entry (the same products, summed in another
order than BLAS's); a solve's error within 20 n eps cond(A) of the answer's norm (the
normwise forward error bound of a backward stable solve, our factor 20 on top of n eps;
measured at most 0.25 n eps cond for the Cholesky solve and 0.23 for the LU on these
systems, L L^T within 0.38 n eps of A's largest entry); the line step within 1e-10 relative
(corrector's tests hold the line solve to the eigen-decomposition's step at 1e-12)."""

from __future__ import annotations

import os
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.core import jit
from foldprint.physics.kinematics import hinge_frames
from foldprint.physics.loops import corrector
from foldprint.physics.loops.closure import LoopSolver

from loop_patterns import loop_patterns

with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
    pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled")

EPS = np.finfo(float).eps


def _kernels():
    from foldprint.physics.loops import closure_kernels, normal_kernels

    return closure_kernels, normal_kernels


def _closure(design, xs):
    """C and J at xs from the compiled closure, and its tables."""
    closure_kernels, _ = _kernels()
    cc = closure_kernels.CompiledClosure(LoopSolver(hinge_frames(design), [h.id for h in design.hinges]))
    c, jac = cc(xs)
    return c, jac, cc.tables


def _in_row_order(jac, c):
    """J^T J and J^T C with every entry a plain left-to-right sum over J's rows (Python
    floats: each addition rounded as the kernel's)."""
    k, n = jac.shape
    gram, g = np.zeros((n, n)), np.zeros(n)
    for a in range(n):
        acc = 0.0
        for r in range(k):
            acc += float(jac[r, a]) * float(c[r])
        g[a] = acc
        for b in range(a, n):
            acc = 0.0
            for r in range(k):
                acc += float(jac[r, a]) * float(jac[r, b])
            gram[a, b] = gram[b, a] = acc
    return gram, g


@settings(max_examples=15, deadline=None, derandomize=True, database=None)
@given(design=loop_patterns(), seed=st.integers(0, 2**32 - 1), scale=st.floats(0.0, 3.0))
def test_normal_equations_by_cycle_blocks(design, seed, scale):
    """At random angles of random loop patterns: every nonzero column of a cycle's rows is
    among its listed hinges; J^T J and J^T C as jac.T @ jac and jac.T @ c, J^T J
    symmetric to the bit, both equal bit for bit to the row-ordered sums."""
    _, nk = _kernels()
    n = len(design.hinges)
    xs = scale * np.random.default_rng(seed).uniform(-1, 1, (3, n))
    cs, jacs, tables = _closure(design, xs)
    pk, ln = tables[0], tables[1]
    cols, cn = nk.cycle_columns(pk, ln, n)
    for ci in range(len(ln)):
        listed = cols[ci, :cn[ci]]
        assert listed.tolist() == sorted(set(pk[ci, :ln[ci]].tolist()))
        rest = np.setdiff1d(np.arange(n), listed)
        assert not jacs[:, 6 * ci:6 * ci + 6][:, :, rest].any()
    for c, jac in zip(cs, jacs):
        gram, g = np.empty((n, n)), np.empty(n)
        nk.normal_eq(jac, c, gram, g, cols, cn)
        ref = jac.T @ jac
        assert np.abs(gram - ref).max() <= 1e-13 * max(1.0, np.abs(ref).max())
        assert np.abs(g - jac.T @ c).max() <= 1e-13 * max(1.0, np.abs(jac).max() * np.abs(c).max())
        assert np.array_equal(gram, gram.T)
        rg, rc = _in_row_order(jac, c)
        assert np.array_equal(gram, rg) and np.array_equal(g, rc)


def _spd(rng, n, cond):
    """A random symmetric positive definite matrix with eigenvalues graded from 1 to 1/cond."""
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    lam = np.logspace(0.0, -np.log10(cond), n)
    return (q * lam) @ q.T


def _error(x, ref):
    return np.linalg.norm(x - ref) / np.linalg.norm(ref)


@pytest.mark.parametrize("cond", [1.0, 1e4, 1e8, 1e12])
@pytest.mark.parametrize("n", [1, 4, 12, 40])
def test_cholesky_solve_against_numpy(n, cond):
    """Positive definite systems, graded: the factor reproduces the matrix, the solve of two
    right-hand sides numpy's within the forward error bound."""
    _, nk = _kernels()
    rng = np.random.default_rng(n * 31 + int(np.log10(cond)))
    for _ in range(20):
        a = _spd(rng, n, cond)
        b = rng.standard_normal((n, 2))
        f = a.copy()
        assert nk.cholesky(f)
        low = np.tril(f, -1) + np.diag(1.0 / np.diag(f))  # the diagonal holds 1 / L_jj
        assert np.abs(low @ low.T - a).max() <= 20 * n * EPS * np.abs(a).max()
        x = nk.cholesky_solve(f, b.copy())
        kappa = np.linalg.cond(a)
        assert _error(x, np.linalg.solve(a, b)) <= 20 * n * EPS * kappa


def test_cholesky_refuses_what_is_not_positive_definite():
    """Indefinite and negative definite matrices (numpy's Cholesky raises), a zero pivot and
    a NaN: False; positive definite ones with an eigenvalue of 1e-10: True."""
    _, nk = _kernels()
    rng = np.random.default_rng(11)
    q, _ = np.linalg.qr(rng.standard_normal((6, 6)))
    for lam in ([1.0, 2.0, 3.0, 4.0, 5.0, -1e-3], -np.arange(1.0, 7.0)):
        a = (q * np.asarray(lam)) @ q.T
        with pytest.raises(np.linalg.LinAlgError):
            np.linalg.cholesky(a)
        assert not nk.cholesky(a.copy())
    assert not nk.cholesky(np.diag([1.0, 0.0, 1.0]))
    assert not nk.cholesky(np.diag([1.0, np.nan, 1.0]))
    assert nk.cholesky((q * np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1e-10])) @ q.T)


@pytest.mark.parametrize("n", [2, 5, 12, 33])
def test_lu_solve_against_numpy(n):
    """Random nonsymmetric systems, some with small leading entries (pivoting needed)."""
    _, nk = _kernels()
    rng = np.random.default_rng(n)
    for i in range(20):
        a = rng.standard_normal((n, n))
        if i % 2:
            a[0, 0] = 1e-14
        b = rng.standard_normal((n, 2))
        x = nk.lu_solve(a.copy(), b.copy())
        assert _error(x, np.linalg.solve(a, b)) <= 20 * n * EPS * np.linalg.cond(a)


def _line_problem(rng, n, k):
    """J (k, n) whose null space is the line w, C, the drive's part d and a guide near w."""
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    w = q[:, 0]
    jac = rng.standard_normal((k, n)) @ (np.eye(n) - np.outer(w, w))
    guide = w + 0.05 * rng.standard_normal(n)
    return jac, rng.standard_normal(k), rng.standard_normal(n), guide / np.linalg.norm(guide)


def _compiled_line(gram, g, d, guide):
    ck, _ = _kernels()
    n = len(g)
    step, w = np.empty(n), np.empty(n)
    ck._gn_line(gram, g, d, guide, step, w, np.empty((n, n)), np.empty((n, 2)))
    return step, w


@pytest.mark.parametrize("n", [3, 12, 40])
def test_line_step_against_the_numpy_round(n):
    """The compiled line step (Cholesky up to SMALL hinges, LAPACK above) against
    corrector._gn_line's (``gesv``), on J with a null line and with none."""
    rng = np.random.default_rng(n + 100)
    for i in range(10):
        jac, c, d, guide = _line_problem(rng, n, 2 * n)
        if i % 3 == 2:
            jac = rng.standard_normal((2 * n, n))  # no null line: the solve is the same algebra
        gram, g = jac.T @ jac, jac.T @ c
        step, w = _compiled_line(gram, g, d, guide)
        ref, vec = corrector._gn_line(gram[None], g[None], d[None], guide[None])
        assert _error(step, ref[0]) <= 1e-10 and _error(w, vec[0, :, 0]) <= 1e-10


def test_line_step_falls_back_to_the_lu():
    """Where J^T J + t t^T is not positive definite (a matrix the tracker does not pass:
    J^T J with a negative eigenvalue), the Cholesky refuses and the LU gives numpy's step."""
    ck, nk = _kernels()
    rng = np.random.default_rng(8)
    n = 8
    q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    gram = (q * np.array([4.0, 3.0, 2.0, 1.0, 0.5, 0.2, 0.1, -0.3])) @ q.T
    guide = q[:, 0]  # t t^T leaves the negative eigenvalue: not positive definite
    assert not nk.cholesky(gram + np.outer(guide, guide))
    g, d = rng.standard_normal(n), rng.standard_normal(n)
    step, w = _compiled_line(gram, g, d, guide)
    ref, vec = corrector._gn_line(gram[None], g[None], d[None], guide[None])
    assert np.isfinite(step).all()
    assert _error(step, ref[0]) <= 1e-12 and _error(w, vec[0, :, 0]) <= 1e-12
