"""The loop tracker's compiled bookkeeping (foldprint.physics.loops.tracker_kernels) against
its numpy reference (tracker.py, drive_state.py), both around the same compiled rounds: the
same answers bit for bit (angles, closures, events, evaluations, rounds), and its pieces
that add in an order (numpy's pairwise sum, the predictor's BLAS products) the same bits as
numpy's."""

from __future__ import annotations

import os
import subprocess
import sys
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
from foldprint.physics.kinematics import hinge_frames, target_angles
from foldprint.physics.loops import corrector, tracker
from foldprint.physics.loops.closure import LoopSolver
from foldprint.physics.loops.drive_state import DriveState
from foldprint.simulation.robust import sample_drives
from foldprint.simulation.scatter import default_scatter, iter_samples

from loop_patterns import loop_patterns

with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
    pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled to compare")


def _both(solver, grid, drivens):
    """The tracks of ``drivens`` with the compiled rounds, the bookkeeping in numpy and
    compiled (the whole track one compiled call, ``track_kernels.track_pool``); the compiled
    bookkeeping called from a Python loop, a round a turn, gives the same as the latter, and
    each path counts in the solver the evaluations it reports."""
    from foldprint.physics.loops.closure_kernels import CompiledClosure

    kernel = CompiledClosure(solver)
    driven = np.stack(drivens)
    got = []
    for run in (lambda: tracker.track(kernel, grid, driven, compiled=False),
                lambda: tracker.track(kernel, grid, driven, compiled=True),
                lambda: tracker._track_compiled(DriveState(grid, driven), tracker._Counted(kernel), fused=False)):
        before = solver.evaluations
        got.append(run())
        assert solver.evaluations - before == got[-1].evaluations > 0
    _assert_identical(got[1], got[2])
    return got[0], got[1]


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


def test_the_warm_track_is_the_chunks_own(monkeypatch):
    """The compiled track loaded before the workers fork (``tracker.warm_compiled``, no drive
    tracked) has the types a chunk's track calls it with: the chunk compiles nothing more."""
    from foldprint.physics.loops.closure_kernels import CompiledClosure
    from foldprint.physics.loops.track_kernels import track_pool

    d = load_design(templates_dir() / "miura_3x3.toml")
    solver = LoopSolver(hinge_frames(d), [h.id for h in d.hinges])
    monkeypatch.setitem(tracker._WARM, "done", False)
    before = solver.evaluations
    tracker.warm_compiled(CompiledClosure(solver))
    assert solver.evaluations == before and len(track_pool.signatures) == 1  # loaded, nothing tracked
    t = np.linspace(0.0, 1.0, 5)
    drive = np.outer(t, 0.3 * target_angles(d))  # a third of the way: the loops stay open
    solver.track_many(t, [drive, 0.9 * drive], compiled=True)
    assert solver.evaluations > before and len(track_pool.signatures) == 1


def test_a_change_to_a_compiled_in_module_makes_the_cache_stale(tmp_path):
    """numba stamps a cached function with its own file only, while its cached code holds
    the functions it calls: :func:`foldprint.core.jit.stale_with` adds their files' stamps,
    so an edit of the callee alone is compiled again (the callee's size changes with the edit)."""
    (tmp_path / "callee.py").write_text("from numba import njit\n\n@njit(cache=True)\ndef g(x):\n    return x + 1\n")
    (tmp_path / "caller.py").write_text(
        "import callee\nfrom numba import njit\nfrom foldprint.core.jit import stale_with\n\n"
        "@njit(cache=True)\ndef f(x):\n    return callee.g(x) * 10\n\nstale_with(__name__, [callee])\n")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"),
               PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    run = [sys.executable, "-c", "import caller; print(caller.f(1))"]
    assert subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout.split() == ["20"]
    assert list((tmp_path / "cache").rglob("caller.f-*.nbi"))  # cached
    (tmp_path / "callee.py").write_text((tmp_path / "callee.py").read_text().replace("x + 1", "x + 12"))
    assert subprocess.run(run, env=env, capture_output=True, text=True, check=True).stdout.split() == ["130"]


def test_every_kernel_module_is_stamped_with_what_it_compiles_in():
    """Each ``*_kernels.py`` that imports from other foldprint modules (kernels it calls,
    constants it reads: compiled into its cached code) names every one of them to
    :func:`foldprint.core.jit.stale_with`, so an edit of any of them makes its cache stale."""
    import ast
    import importlib
    import importlib.util
    from pathlib import Path

    import foldprint
    from foldprint.core import jit

    root = Path(foldprint.__file__).parent
    for path in sorted(root.rglob("*_kernels.py")):
        name = "foldprint." + ".".join(path.relative_to(root).with_suffix("").parts)
        importlib.import_module(name)
        package = name.rsplit(".", 1)[0].split(".")
        used = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
                package_ = hasattr(importlib.import_module(base), "__path__")
                names = [f"{base}.{a.name}" if package_ and importlib.util.find_spec(f"{base}.{a.name}") else base
                         for a in node.names]  # a module imported by name, else the module named
                used.update(n for n in names if n != "foldprint.core.jit")
        assert used <= set(jit.STAMPED.get(name, ())), (name, sorted(used - set(jit.STAMPED.get(name, ()))))
