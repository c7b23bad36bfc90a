"""The loop tracker's compiled round (``foldprint/physics/loops/closure_kernels.py``) against
the numpy reference (``corrector.Pool.round`` with ``LoopSolver.residuals``).

Tolerances (docs/kernels.md, docs/loops.md): C and J within 1e-12 of their largest entry;
one round from the same pool: the same decisions (which points stop, drop, stay lines,
their null-space dimension), new angles within STEP_TOL, tangent spaces (their projectors)
within 1e-6; whole tracks on the templates' check drives and on random loop patterns:
the same events (hinges that cannot follow and when, the lock time, the degrees of
freedom) and closed angles within ANGLE_TOL, except at near-flat steps, where a restart's
choice between branches equally near the drive may go either way on round-off (the rule
``tests/test_loop_tracking.py`` holds the array tracker to against the replaced one)."""

from __future__ import annotations

import copy
import functools
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
from foldprint.physics.loops import corrector, drive_state
from foldprint.physics.loops.closure import CLOSURE_TOL, OPT_TOL, LoopSolver
from foldprint.simulation.robust import sample_drives
from foldprint.simulation.scatter import default_scatter, iter_samples

from loop_patterns import loop_patterns



def _numba():
    """The compiled path asked for (whatever FOLDPRINT_KERNELS the run has)."""
    return mock.patch.dict(os.environ, {jit.ENV: "numba"})


with _numba():
    pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled to compare")

#: closed angles of the two paths away from the flat sheet (rad): both stop a solve when a
#: step moves no angle more than OPT_TOL (measured: within 1e-10 on the check drives)
ANGLE_TOL = 10 * OPT_TOL
TEMPLATES = ["miura_3x3", "cross_lock_uniform"]
#: one round's new angles (rad): the eigen-decomposition of J^T J resolves a singular value
#: only to ~1e-8 of the largest (docs/loops.md), so a step along a direction with a small
#: kept singular value carries that round-off on either path (measured: up to 3.9e-7 rad on
#: points of miura_3x3 between 0.01 and 0.2 rad from flat; the tracks' answers agree to 1e-10).
#: A point past it must be one where the reference's own step moves that far when its angles
#: move by 1e-14 of themselves (within 10 times that: measured 7.3e-6 rad against 2.9e-6 at a
#: point 0.036 rad from flat whose J^T J has an eigenvalue of 2.2e-4 beside its null space)
STEP_TOL = 1e-6


def _round_off_spread(pool, solver, live, rel=1e-14, draws=3):
    """How far the numpy round's new angles move when the pool's angles move by ``rel``
    of themselves (a few ulps): what round-off alone does to a step at each live point."""
    ref = copy.deepcopy(pool)
    ref.round(solver._evaluate)
    rng = np.random.default_rng(7)
    spread = np.zeros(len(live))
    for _ in range(draws):
        c = copy.deepcopy(pool)
        c.x = c.x * (1.0 + rel * rng.standard_normal(c.x.shape))
        c.round(solver._evaluate)
        spread = np.maximum(spread, np.abs(ref.x[live] - c.x[live]).max(axis=1))
    return spread


def _solver(design) -> LoopSolver:
    return LoopSolver(hinge_frames(design), [h.id for h in design.hinges])


def on_numba(fn):
    """Run the test with the compiled path asked for (``compiled=True`` would otherwise
    fall back to the numpy round under FOLDPRINT_KERNELS=numpy, and compare it with itself)."""
    @functools.wraps(fn)
    def run(*args, **kwargs):
        with _numba():
            return fn(*args, **kwargs)
    return run


@settings(max_examples=20, deadline=None, derandomize=True, database=None)
@given(design=loop_patterns(), seed=st.integers(0, 2**32 - 1), scale=st.floats(0.0, 3.0))
@on_numba
def test_residuals_and_jacobian_match_the_numpy_path(design, seed, scale):
    from foldprint.physics.loops.closure_kernels import CompiledClosure

    solver = _solver(design)
    xs = scale * np.random.default_rng(seed).uniform(-1, 1, (4, solver.n))
    c0, j0 = solver.residuals(xs)
    c1, j1 = CompiledClosure(solver)(xs)
    assert c1.shape == c0.shape and j1.shape == j0.shape
    assert np.abs(c1 - c0).max(initial=0.0) <= 1e-12 * max(1.0, np.abs(c0).max(initial=0.0))
    assert np.abs(j1 - j0).max(initial=0.0) <= 1e-12 * max(1.0, np.abs(j0).max(initial=0.0))


def _check_drives(name, n):
    d = load_design(templates_dir() / f"{name}.toml")
    drives = sample_drives(d, default_library(), list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES,
                                                                              CHECK_SEED), n)))
    times = run_times(d, CHECK_DT_S)
    grid = drives[0]._loop_grid(times, loop_dt(times))[0]
    return d, grid, [dr.driven(grid) for dr in drives]


def _projector(basis, free):
    n = basis[:, free]
    return n @ n.T


@on_numba
def test_one_round_makes_the_numpy_rounds_decisions(monkeypatch):
    """Pools met while tracking miura_3x3's and cross_lock_uniform's check drives (points of
    every kind: line solves and their certification, eigen-decompositions, SVDs near the flat
    sheet, window points, points out of steps): one numpy round and one compiled round from
    the same pool give the same decisions and steps to round-off."""
    from foldprint.physics.loops.closure_kernels import CompiledClosure

    kinds = np.zeros(3, int)  # line, eigen-decomposition, SVD points compared
    worst = [0.0]
    for name in TEMPLATES:
        d, grid, drivens = _check_drives(name, 4)
        solver = _solver(d)
        fused = CompiledClosure(solver)
        pools = []
        real = corrector.Pool.round

        def spy(pool, evaluate):
            if len(pools) < 400 and len(pools) % 3 == 0:
                pools.append(copy.deepcopy(pool))
            elif len(pools) < 400:
                pools.append(None)
            return real(pool, evaluate)

        monkeypatch.setattr(corrector.Pool, "round", spy)
        solver.track_many(grid, drivens, compiled=False)
        monkeypatch.setattr(corrector.Pool, "round", real)
        for pool in filter(None, pools):
            a, b = copy.deepcopy(pool), copy.deepcopy(pool)
            live = pool.alive.nonzero()[0]
            line = pool.line[live]
            svd = ~line & pool.plain[live] & (np.abs(pool.x[live]).max(axis=1) < corrector.SVD_BELOW)
            kinds += [np.count_nonzero(line), np.count_nonzero(~line & ~svd), np.count_nonzero(svd)]
            a.round(solver._evaluate)
            b.round(fused)
            for f in ("alive", "it", "line", "done", "null"):
                assert np.array_equal(getattr(a, f)[live], getattr(b, f)[live]), (name, f)
            dx = np.abs(a.x[live] - b.x[live]).max(axis=1)
            worst[0] = max(worst[0], dx.max())
            over = dx > STEP_TOL
            if over.any():  # is the reference itself that sensitive to round-off there?
                assert (dx[over] <= 10 * _round_off_spread(pool, solver, live)[over]).all(), (name, dx[over])
            stop = live[~a.alive[live]]
            assert np.abs(a.res[stop] - b.res[stop]).max(initial=0.0) <= 1e-12
            for i in stop:
                assert np.count_nonzero(a.free[i]) == np.count_nonzero(b.free[i])
                assert np.abs(_projector(a.basis[i], a.free[i]) - _projector(b.basis[i], b.free[i])).max() <= 1e-6
    assert (kinds > 0).all(), kinds  # every kind of point was compared


def _assert_same_track(a, b, drive):
    """The same events; closed angles within ANGLE_TOL except at near-flat steps (both
    answers near flat there), the same path once folded; both closed."""
    assert (a.stuck, a.locked_at, a.dof) == (b.stuck, b.locked_at, b.dof)
    assert a.closure <= CLOSURE_TOL * 1.0001 and b.closure <= CLOSURE_TOL * 1.0001
    diff = np.abs(a.angles - b.angles).max(axis=1)
    apart = diff >= ANGLE_TOL
    flat = np.abs(drive).max(axis=1) < drive_state.NEAR_FLAT
    assert flat[apart].all(), "the paths part away from the flat sheet"
    for x in (a, b):
        assert np.abs(x.angles[apart]).max(initial=0.0) < drive_state.NEAR_FLAT
    assert not apart[-1]


@pytest.mark.parametrize("name", TEMPLATES)
@on_numba
def test_tracks_of_the_check_drives_match(name):
    d, grid, drivens = _check_drives(name, 16)
    solver = _solver(d)
    ref, got = solver.track_many(grid, drivens, compiled=False), solver.track_many(grid, drivens, compiled=True)
    for a, b, drive in zip(ref, got, drivens):
        _assert_same_track(a, b, drive)


@settings(max_examples=10, deadline=None, derandomize=True, database=None)
@given(design=loop_patterns(), data=st.data())
@on_numba
def test_tracks_match_on_random_loop_patterns(design, data):
    """Random patterns, each hinge's drive scaled by its own factor (0.5-1.5: off the
    folding path, so hinges cannot follow and drives lock), two drives in lockstep."""
    solver = _solver(design)
    t = np.arange(0.0, 3.0 + 1e-9, 0.01)
    base = HingeDrive(design).driven(t)
    drivens = [base * np.asarray(data.draw(st.lists(st.floats(0.5, 1.5), min_size=solver.n, max_size=solver.n)))
               for _ in range(2)]
    ref, got = solver.track_many(t, drivens, compiled=False), solver.track_many(t, drivens, compiled=True)
    for a, b, drive in zip(ref, got, drivens):
        _assert_same_track(a, b, drive)


@on_numba
def test_one_drive_is_the_reference_and_a_chunk_is_compiled(monkeypatch):
    """By default one drive (the nominal fold the reports print) takes the numpy round, bit
    for bit, and only loads the compiled track (rounds and bookkeeping); two or more (a
    Monte-Carlo chunk) use it."""
    from foldprint.physics.loops import track_kernels, tracker

    d, grid, drivens = _check_drives("miura_3x3", 2)
    solver = _solver(d)
    calls = []  # each compiled track's (first call, rounds)
    real = track_kernels.track_pool

    def spy(first, *arrays):
        got = real(first, *arrays)
        calls.append((first, got[0]))
        return got

    monkeypatch.setattr(track_kernels, "track_pool", spy)
    monkeypatch.setitem(tracker._WARM, "done", False)
    one = solver.track(grid[:300], drivens[0][:300])
    assert calls == [(False, 0)]  # loaded for the chunks to come (warm: no drive has points), not used
    ref = solver.track_many(grid[:300], [drivens[0][:300]], compiled=False)[0]
    assert np.array_equal(one.angles, ref.angles) and one.closure == ref.closure
    solver.track_many(grid[:300], [v[:300] for v in drivens])
    assert len(calls) == 2 and calls[1][0] and calls[1][1] > 0
