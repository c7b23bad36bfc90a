"""The loop tracker's compiled bookkeeping (foldprint.physics.loops.tracker_kernels) against
its numpy reference (tracker.py, drive_state.py), both around the same compiled rounds: the
same answers bit for bit (angles, closures, events, evaluations, rounds), and its pieces
that add in an order (numpy's pairwise sum, the predictor's BLAS products) the same bits as
numpy's."""

from __future__ import annotations

import os
from itertools import islice
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.core import jit
from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.materials import default_library
from foldprint.physics.hinge_drive import HingeDrive, loop_dt, run_times
from foldprint.physics.kinematics import hinge_frames
from foldprint.physics.loops import corrector, tracker
from foldprint.physics.loops.closure import LoopSolver
from foldprint.simulation.robust import sample_drives
from foldprint.simulation.scatter import default_scatter, iter_samples

from loop_patterns import loop_patterns

with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
    pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled to compare")


def _both(solver, grid, drivens):
    """The tracks of ``drivens`` with the compiled rounds, the bookkeeping in numpy and
    compiled."""
    from foldprint.physics.loops.closure_kernels import CompiledClosure

    kernel = CompiledClosure(solver)
    driven = np.stack(drivens)
    return tracker.track(kernel, grid, driven, compiled=False), tracker.track(kernel, grid, driven, compiled=True)


def _assert_identical(a: tracker.Tracks, b: tracker.Tracks):
    assert np.array_equal(a.angles, b.angles)
    assert np.array_equal(a.closure, b.closure)
    assert np.array_equal(a.locked_at, b.locked_at, equal_nan=True)
    assert np.array_equal(a.dof, b.dof)
    assert (a.evaluations, a.rounds) == (b.evaluations, b.rounds)


@pytest.mark.parametrize("name", ["miura_3x3", "cross_lock_uniform"])
def test_check_drives_tracked_bit_for_bit(name):
    d = load_design(templates_dir() / f"{name}.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 8))
    drives = sample_drives(d, default_library(), samples)
    times = run_times(d, CHECK_DT_S)
    grid = drives[0]._loop_grid(times, loop_dt(times))[0]
    a, b = _both(LoopSolver(hinge_frames(d), [h.id for h in d.hinges]), grid, [x.driven(grid) for x in drives])
    assert np.isfinite(a.locked_at).any() or (a.dof > 0).all()  # the drives folded (or locked): work was done
    _assert_identical(a, b)


@settings(max_examples=10, deadline=None, derandomize=True, database=None)
@given(design=loop_patterns(), data=st.data())
def test_random_patterns_tracked_bit_for_bit(design, data):
    """Each hinge's drive scaled by its own factor (0.5-1.5: off the folding path, so
    hinges cannot follow and drives lock, lose the manifold, restart), three drives."""
    solver = LoopSolver(hinge_frames(design), [h.id for h in design.hinges])
    t = np.arange(0.0, 3.0 + 1e-9, 0.01)
    base = HingeDrive(design).driven(t)
    drivens = [base * np.asarray(data.draw(st.lists(st.floats(0.5, 1.5), min_size=solver.n, max_size=solver.n)))
               for _ in range(3)]
    _assert_identical(*_both(solver, t, drivens))


def test_pairwise_sum_and_norms_are_numpys_bits():
    from foldprint.physics.loops.pairwise_kernels import norm, pairwise

    rng = np.random.default_rng(3)
    for n in [*range(1, 40), 127, 128, 129, 255, 256, 257, 1000, 3001]:
        for _ in range(5):
            v = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 3, n)
            u = rng.standard_normal(n)
            assert pairwise(v * v) == np.add.reduce((v * v)[None], axis=1)[0]
            assert norm(v, u) == corrector.norms((v - u)[None])[0]


def test_predictor_is_numpys_bits():
    from foldprint.physics.loops.tracker_kernels import _predict

    rng = np.random.default_rng(5)
    for n in (3, 8, 12, 24):
        x, target = rng.uniform(-2, 2, (50, n)), rng.uniform(-2, 2, (50, n))
        basis = np.linalg.qr(rng.standard_normal((50, n, n)))[0]
        free = rng.random((50, n)) < 0.4
        want = corrector.predict(x, target, basis, free)
        got = np.array([_predict(x[i], target[i], basis[i], free[i], np.empty((3, n))).copy() for i in range(50)])
        assert np.array_equal(got, want)
        assert not np.array_equal(got, x)  # the predictor moved
