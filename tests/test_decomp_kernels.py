"""The loop tracker's hand-written SVD (``foldprint/physics/loops/decomp_kernels.py``)
against numpy's (LAPACK ``gesdd``), on random, rank-deficient and graded matrices and on
real closure Jacobians near the flat sheet.

Tolerances (docs/loops.md, "The compiled round"): singular values within 1e-12 of the
largest (both methods err by round-off of the largest at most; measured 3e-15 on
``miura_3x3``'s Jacobians); V orthogonal to 1e-13; ``J v_j`` of length ``s_j`` to 1e-12 of
the largest; U^T c as ``(J v_j) . c / s_j`` where s_j is kept by the rank rule; the
subspaces the rank rule splits (kept / null) the same as numpy's where the gap at the
threshold is wide (projectors within 1e-8)."""

from __future__ import annotations

import os
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.core import jit
from foldprint.physics.loops.corrector import RANK_TOL

with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
    pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled")

REL = 1e-12


def _svd(jac, c):
    from foldprint.physics.loops.decomp_kernels import svd_small, svd_work

    k, n = jac.shape
    s, vec, uc = np.empty(n), np.empty((n, n)), np.empty(n)
    sweeps = svd_small(np.ascontiguousarray(jac), np.ascontiguousarray(c), s, vec, uc, svd_work(k, n))
    return s, vec, uc, sweeps


def _projector(v):
    return v @ v.T


def _assert_svd(jac, c, gap_for_subspace=1e-3):
    """The kernel's SVD of ``jac`` against numpy's, to the module's tolerances."""
    k, n = jac.shape
    s, vec, uc, sweeps = _svd(jac, c)
    ref = np.linalg.svd(jac, compute_uv=False)
    top = max(ref[0], 1e-300)
    want = np.zeros(n)
    want[:min(k, n)] = ref
    assert sweeps < 30
    assert np.all(np.diff(s) <= 0.0), "largest first"
    assert np.abs(s - want).max() <= REL * top
    assert np.abs(vec.T @ vec - np.eye(n)).max() <= 1e-13
    jv = jac @ vec
    assert np.abs(np.linalg.norm(jv, axis=0) - s).max() <= REL * top
    thr = RANK_TOL * max(1.0, s[0])
    keep = s > thr
    kept = np.flatnonzero(keep)
    if kept.size:  # U^T c: (J v_j) . c / s_j carries round-off of the largest over s_j
        ref_uc = (jv[:, kept].T @ c) / s[kept]
        assert np.all(np.abs(uc[kept] - ref_uc) <= REL * np.linalg.norm(c) * top / s[kept])
    # the split the rank rule makes, where the gap at the threshold leaves it well-defined
    lo = want[want <= thr].max(initial=0.0)
    hi = want[want > thr].min(initial=np.inf)
    if hi * gap_for_subspace >= lo and lo < thr * (1 - 1e-6) and hi > thr * (1 + 1e-6):
        _, _, vt = np.linalg.svd(jac, full_matrices=True)
        nk = int(np.count_nonzero(want > thr))
        assert nk == kept.size
        assert np.abs(_projector(vec[:, nk:]) - _projector(vt[nk:].T)).max() <= 1e-8
    return s, vec, uc


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 30), n=st.integers(1, 16), scale=st.floats(1e-3, 1e3))
def test_random_matrices_match_numpy(seed, k, n, scale):
    rng = np.random.default_rng(seed)
    _assert_svd(scale * rng.standard_normal((k, n)), rng.standard_normal(k))


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(2, 30), n=st.integers(2, 16), data=st.data())
def test_rank_deficient_and_graded_matrices_match_numpy(seed, k, n, data):
    """J = U diag(s) V^T with exact zeros (a null space), singular values down to 1e-12 of
    the largest (graded, as near the flat sheet) and near-equal pairs."""
    rng = np.random.default_rng(seed)
    m = min(k, n)
    rank = data.draw(st.integers(0, m))
    exps = np.sort(rng.uniform(-12.0, 2.0, m))[::-1]
    sv = 10.0 ** exps
    if m > 1 and data.draw(st.booleans()):
        sv[1] = sv[0] * (1.0 + 1e-9)  # a near-equal pair
    sv[rank:] = 0.0
    u = np.linalg.qr(rng.standard_normal((k, k)))[0][:, :m]
    v = np.linalg.qr(rng.standard_normal((n, n)))[0][:, :m]
    jac = (u * sv) @ v.T
    s, vec, _ = _assert_svd(jac, rng.standard_normal(k))
    if rank < n:  # the null space: J V[:, rank:] is round-off of the largest
        assert np.abs(jac @ vec[:, rank:]).max() <= REL * max(sv.max(), 1e-300)


def _near_flat_jacobians(name, count, angle):
    """Closure Jacobians and residuals of template ``name`` at ``count`` random
    configurations with every angle below ``angle`` (rad): where the tracker takes the SVD."""
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir
    from foldprint.physics.kinematics import hinge_frames
    from foldprint.physics.loops.closure import LoopSolver

    d = load_design(templates_dir() / f"{name}.toml")
    solver = LoopSolver(hinge_frames(d), [h.id for h in d.hinges])
    xs = angle * np.random.default_rng(3).uniform(-1.0, 1.0, (count, solver.n))
    return solver.residuals(xs)


@pytest.mark.parametrize("name", ["miura_3x3", "cross_lock_uniform"])
@pytest.mark.parametrize("angle", [1e-2, 1e-4, 0.0])
def test_closure_jacobians_near_the_flat_sheet_match_numpy(name, angle):
    c, jac = _near_flat_jacobians(name, 40, angle)
    for j, ci in zip(jac, c):
        _assert_svd(j, ci)


def test_rank_rule_decisions_match_numpy_on_a_graded_spectrum():
    """Singular values 1 % either side of the rank threshold are kept / dropped as numpy's."""
    rng = np.random.default_rng(11)
    n = 12
    sv = np.array([120.0, 60.0, 50.0, 30.0, 2.0, 1.8, 1.0, 0.8, 0.1, 0.07,
                   120.0 * RANK_TOL * 1.01, 120.0 * RANK_TOL * 0.99])
    u = np.linalg.qr(rng.standard_normal((24, 24)))[0][:, :n]
    v = np.linalg.qr(rng.standard_normal((n, n)))[0]
    s, _, _ = _assert_svd((u * sv) @ v.T, rng.standard_normal(24))
    thr = RANK_TOL * s[0]
    assert np.count_nonzero(s > thr) == n - 1


@pytest.mark.parametrize("scale", [1e-60, 1e-30, 1e30, 1e60])
def test_far_scales_match_numpy(scale):
    """The angle's squares stay clear of under- and overflow: graded spectra scaled far from
    1 match numpy as at scale 1 (the rotations' arithmetic is scale-free)."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        sv = 10.0 ** np.sort(rng.uniform(-12.0, 0.0, 12))[::-1]
        sv[9:] = 0.0
        u = np.linalg.qr(rng.standard_normal((24, 24)))[0][:, :12]
        v = np.linalg.qr(rng.standard_normal((12, 12)))[0]
        _assert_svd(scale * (u * sv) @ v.T, rng.standard_normal(24))
