"""The compiled kernels (``*_kernels.py``, :mod:`foldprint.core.jit`) against the numpy
reference path they speed up: the recovery curves of scattered hinges, forward
kinematics, the panels' centres, the swept check's screen (its lower bound never above
FCL's distance) and, end to end, the Monte-Carlo outcomes of every template and of random
strips. Tolerances, stated once here and in docs/kernels.md: recovery ratios 1e-12, mean
temperatures 1e-9 degC, poses and centres 1e-12 of the sheet's size (mm), contact and
fold times one simulation step; jammed / reason / pair identical. Also: a platform where
numba cannot load runs the numpy path and the command line says so once."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from itertools import islice
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.core import jit
from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.core.modes import VERDICT_METHOD, HingeModel
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.physics.kinematics import TreeTransforms, forward
from foldprint.physics.recovery.batch import grid_until, material_batch_ratios
from foldprint.simulation import robust
from foldprint.simulation.scatter import default_scatter, iter_samples
from foldprint.simulation.simulate import simulate

pytestmark = pytest.mark.skipif(not jit.use_kernels() and jit.requested() is jit.Kernels.NUMBA,
                                reason="numba cannot load here: nothing compiled to compare")

TEMPLATES = sorted(p.stem for p in templates_dir().glob("*.toml"))
RATIO_TOL = 1e-12
MEAN_T_TOL = 1e-9
POSE_REL = 1e-12
MATERIALS = ["H-1", "H-2", "H-3", "H-4", "H-5"]


def _both(fn):
    """``fn()`` on the numpy path, then on the compiled one."""
    with mock.patch.dict(os.environ, {jit.ENV: "numpy"}):
        ref = fn()
    with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
        return ref, fn()


def _size(design) -> float:
    pts = np.concatenate([p.outline for p in design.panels])
    return float(np.ptp(pts, axis=0).max())


def random_strip(data, n_min=3, n_max=7):
    n = data.draw(st.integers(n_min, n_max))
    lengths = data.draw(st.lists(st.floats(6, 30), min_size=n, max_size=n))
    angles = data.draw(st.lists(st.sampled_from([-170, -150, -120, -90, 90, 120, 150, 170]),
                                min_size=n - 1, max_size=n - 1))
    mats = data.draw(st.lists(st.sampled_from(MATERIALS), min_size=n - 1, max_size=n - 1))
    return strip("r", lengths, angles, mats, radius=2.0)


# -- recovery curves ------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted({h.material for t in TEMPLATES
                                          for h in load_design(templates_dir() / f"{t}.toml").hinges}))
def test_recovery_curves_match_the_numpy_path(name):
    """Every hinge material of the templates (graded ones through their strips), 24
    scattered hinges, the grid of a 20 s fold."""
    mat = default_library()[name]
    rng = np.random.default_rng(len(name))
    n = 24
    args = (mat, mat.tg_c + rng.normal(0, 3, n), mat.recovery.h_w_m2k * rng.uniform(0.6, 1.4, n),
            rng.uniform(0.6, 1.4, n), 70 + rng.normal(0, 2, n), 25.0, grid_until(20.0))
    (r0, m0), (r1, m1) = _both(lambda: material_batch_ratios(*args, table=True))
    assert r0.shape == r1.shape and np.all(np.diff(r1, axis=1) >= 0)
    assert np.abs(r0 - r1).max() < RATIO_TOL
    assert np.abs(m0 - m1).max() < MEAN_T_TOL


def test_vexp_is_numpys_exp_to_round_off():
    from foldprint.physics.recovery.batch_kernels import vexp

    x = np.concatenate([np.linspace(-60, 5, 20001), np.random.default_rng(1).uniform(-700, 700, 5000)])
    out, bits = np.empty_like(x), np.empty(x.shape, np.int64)
    vexp(x, out, bits)
    assert np.max(np.abs(out / np.exp(x) - 1)) < 5e-16


# -- kinematics ----------------------------------------------------------------------------

def _check_poses(d, ang):
    scale = POSE_REL * max(1.0, _size(d))
    for model in (HingeModel.ARC, HingeModel.POINT):
        ref = forward(d, ang, model)
        assert np.abs(forward(d, ang, model, compiled=True) - ref).max() <= scale * 10
        tt = TreeTransforms(d, model)
        p0, p1 = _both(lambda: tt.poses(ang[:7]))
        assert np.abs(p0 - p1).max() <= scale * 10
        assert np.abs(p1 - ref[:7]).max() <= scale * 10


def test_sincos_is_within_one_ulp_of_libm():
    """The kinematics kernel's vectorised sin and 1 - cos (fdlibm's polynomials after one
    reduction by pi/2) against numpy's, over several turns and at the special angles."""
    from foldprint.physics.kinematics_kernels import sincos

    x = np.concatenate([np.linspace(-20.0, 20.0, 400_001), np.pi * np.arange(-8, 9) / 4,
                        [0.0, 1e-8, -1e-300, 2e5, -3e7, 1e300]]).reshape(-1, 1)
    s, c1 = sincos(x)
    assert s.shape == c1.shape == x.shape
    assert np.abs(s - np.sin(x)).max() <= np.spacing(1.0) / 2  # 1 ulp of the largest values
    assert np.abs(c1 - (1.0 - np.cos(x))).max() <= np.spacing(2.0) / 2
    big = np.abs(np.sin(x)) > 1e-3
    assert (np.abs(s - np.sin(x))[big] <= np.spacing(np.abs(np.sin(x)))[big]).all()
    with np.errstate(invalid="ignore"):
        s, c1 = sincos(np.array([[np.inf, np.nan]]))
    assert np.isnan(s).all() and np.isnan(c1).all()


@pytest.mark.parametrize("name", TEMPLATES)
def test_forward_kinematics_match_on_every_template(name):
    d = load_design(templates_dir() / f"{name}.toml")
    ang = np.random.default_rng(3).uniform(-math.pi, math.pi, (40, len(d.hinges)))
    ang[0] = 0.0
    ang[1] = 1e-8  # the series branches near a flat hinge
    _check_poses(d, ang)


@settings(max_examples=15, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_forward_kinematics_match_on_random_strips(data):
    d = random_strip(data)
    ang = np.array(data.draw(st.lists(st.lists(st.floats(-3.1, 3.1), min_size=len(d.hinges),
                                                max_size=len(d.hinges)), min_size=1, max_size=5)))
    _check_poses(d, ang)


@pytest.mark.parametrize("name", ["helix_graded", "miura_3x3", "self_lock"])
def test_the_drives_fold_and_onset_times_are_its_curves(name):
    """``HingeDrive.level_times`` (one compiled call a level on the stacked curves) gives
    each curve's own ``fold_time`` and ``onset_time``, exactly, for sampled and nominal drives."""
    from foldprint.physics.hinge_drive import HingeDrive

    d = load_design(templates_dir() / f"{name}.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 6))
    drives = robust.sample_drives(d, default_library(), samples, until_s=robust.run_end(d, CHECK_DT_S))
    for dr in drives + [HingeDrive(d)]:
        ref = (tuple(c.fold_time for c in dr.curves), tuple(c.onset_time for c in dr.curves))
        assert dr.level_times() == ref
        assert any(t is not None for t in ref[0])


# -- the swept check's screen ---------------------------------------------------------------

@settings(max_examples=15, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_the_screens_bound_is_never_above_fcls_distance(data):
    """The vertex-projection bound the screen certifies with is a lower bound of the
    distance between the panels (FCL's, which GJK only ever overestimates by FCL_REL)."""
    from foldprint.collision.broadphase import non_adjacent_pairs
    from foldprint.collision.swept3d import SweptChecker
    from foldprint.collision.swept3d_kernels import lower_bound
    from foldprint.physics.hinge_drive import HingeDrive

    d = random_strip(data)
    ch = SweptChecker(d, "arc", HingeDrive(d))
    ang = np.array([data.draw(st.lists(st.floats(-3.1, 3.1), min_size=len(d.hinges), max_size=len(d.hinges)))])
    poses = forward(d, ang, HingeModel.ARC)[0]
    off = ch.hull_off
    for i, j in non_adjacent_pairs(d):
        lb = lower_bound(poses[i], poses[j], ch.hull_pts[off[i]:off[i + 1]], ch.hull_pts[off[j]:off[j + 1]])
        dist = ch.gap(i, j, poses[i], poses[j])
        assert lb <= max(dist, 0.0) + 1e-9 * (1 + _size(d)), (i, j, lb, dist)


# -- the broad phase's compiled descent and the screen against FCL ---------------------------

def _folded(d, dt=0.05):
    from foldprint.collision.swept3d import SweptChecker
    from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics

    drive = HingeDrive(d)
    return SweptChecker(d, "arc", drive), simulate_kinematics(d, model=HingeModel.ARC, dt=dt, drive=drive)


def _runs_both(ch, traj):
    from foldprint.collision.broadphase import candidate_runs

    def runs():
        ch.n_broad_nodes = 0
        return candidate_runs(ch, traj.angles, traj.poses, 0, None, traj.times), ch.n_broad_nodes

    (r0, n0), (r1, n1) = _both(runs)
    assert np.array_equal(r0, r1) and n0 == n1, (len(r0), len(r1), n0, n1)
    return r1


@settings(max_examples=10, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_the_compiled_descent_leaves_the_numpy_descents_runs(data):
    """The same candidate runs (and node count) on both paths: the compiled descent tests
    the same (group pair, interval)s on the same numbers, depth first."""
    _runs_both(*_folded(random_strip(data, 3, 16)))


def test_the_compiled_descent_refines_as_the_numpy_one():
    """A 30-panel strip whose far pairs are re-tested between samples (the refinement's
    descents run, on both paths) leaves the same runs."""
    from foldprint.collision import broadphase

    rng = np.random.default_rng(0)
    d = strip("long", list(rng.uniform(6, 30, 30)), list(rng.choice([-170, -120, 90, 150, 170], 29)),
              ["H-2"] * 29, radius=2.0)
    calls = []
    refine = broadphase._refine  # noqa: SLF001 -- counted, not replaced
    with mock.patch.object(broadphase, "_refine", lambda *a, **k: calls.append(1) or refine(*a, **k)):
        _runs_both(*_folded(d))
    assert len(calls) >= 2  # on each path


def _fcl_contacts_kept(d) -> int:
    """Every (pair, sample) FCL finds within the contact tolerance (every 5th sample) lies in
    a run the broad phase leaves and the screen starts at or before; returns how many."""
    from foldprint.collision.broadphase import candidate_runs, non_adjacent_pairs
    from foldprint.collision.swept_search import screen

    ch, tr = _folded(d)
    runs = candidate_runs(ch, tr.angles, tr.poses, 0, None, tr.times)
    left = screen(ch, runs, tr.angles, tr.poses).tolist() if len(runs) else []
    touching = 0
    for i, j in non_adjacent_pairs(d):
        for k in range(0, len(tr.times), 5):
            if ch.gap(i, j, tr.poses[k, i], tr.poses[k, j]) <= ch.tol:
                touching += 1
                assert any(r[:2] == [i, j] and r[2] <= k <= r[3] for r in left), (i, j, k)
    return touching


@settings(max_examples=8, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_broad_phase_and_screen_never_certify_an_fcl_contact(data):
    _fcl_contacts_kept(random_strip(data, 3, 8))


@pytest.mark.parametrize("lengths, angles", [([30, 10, 30, 10, 30], [170] * 4), ([20] * 4, [170] * 3)])
def test_a_strip_folding_onto_itself_keeps_its_fcl_contacts(lengths, angles):
    """The same on strips that fold onto themselves (so the check has contacts to keep)."""
    assert _fcl_contacts_kept(strip("coil", lengths, angles, ["H-2"] * len(angles), radius=2.0)) > 0


# -- panel centres --------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["miura_3x3", "mailbox"])
def test_panel_centres_match(name):
    from foldprint.collision.broadphase import panel_centres
    from foldprint.collision.swept3d import SweptChecker
    from foldprint.physics.hinge_drive import HingeDrive

    d = load_design(templates_dir() / f"{name}.toml")
    ch = SweptChecker(d, "arc", HingeDrive(d))
    poses = forward(d, np.random.default_rng(5).uniform(-3, 3, (30, len(d.hinges))), HingeModel.ARC)
    c0, c1 = _both(lambda: panel_centres(ch, poses))
    assert np.abs(c0 - c1).max() <= POSE_REL * 10 * max(1.0, _size(d))


# -- end to end: the Monte-Carlo outcomes -----------------------------------------------------

def _same_outcomes(a, b, step):
    assert [(o.jammed, o.reason, o.pair) for o in a] == [(o.jammed, o.reason, o.pair) for o in b]
    for x, y in zip(a, b):
        for u, v in ((x.time, y.time), (x.fold_time, y.fold_time)):
            assert (u is None) == (v is None) and (u is None or abs(u - v) <= step + 1e-9), (u, v)


@pytest.mark.parametrize("name", TEMPLATES)
def test_monte_carlo_outcomes_match_on_every_template(name):
    """``check``'s first 8 samples, folded by ``run_samples`` (curves, loops, kinematics,
    swept check with the screen) on both paths."""
    d = load_design(templates_dir() / f"{name}.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 8))
    args = (d, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)
    a, b = _both(lambda: robust.run_samples(args))
    _same_outcomes(a, b, CHECK_DT_S)


@settings(max_examples=8, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_simulation_matches_on_random_strips(data):
    d = random_strip(data)
    dt = 0.05
    a, b = _both(lambda: simulate(d, dt=dt, method=VERDICT_METHOD))
    assert a.completed == b.completed and (a.fold_time is None) == (b.fold_time is None)
    assert a.fold_time is None or abs(a.fold_time - b.fold_time) <= dt + 1e-9
    ca, cb = a.first_collision, b.first_collision
    assert (ca is None) == (cb is None)
    if ca is not None:
        assert sorted(ca.panels) == sorted(cb.panels) and abs(ca.time - cb.time) <= dt + 1e-9
    assert np.abs(a.trajectory.poses - b.trajectory.poses).max() <= POSE_REL * 10 * max(1.0, _size(d))


# -- start-up and fallback -------------------------------------------------------------------

_NO_NUMBA = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("numba", "llvmlite"):
            raise ImportError("simulated: no llvmlite library for this platform")
sys.meta_path.insert(0, Block())
from foldprint.cli.commands import main
raise SystemExit(main(sys.argv[1:]))
"""


def test_without_numba_the_numpy_path_runs_with_one_note():
    """numba that cannot load (an import failure, simulated): the command still answers,
    on the numpy path, and says so in one note line."""
    env = dict(os.environ, FOLDPRINT_KERNELS="numba")
    out = subprocess.run([sys.executable, "-c", _NO_NUMBA, "simulate", "helix_uniform", "--dt", "0.05"],
                         capture_output=True, text=True, timeout=300, env=env)
    assert out.returncode in (0, 1), out.stderr
    notes = [ln for ln in out.stderr.splitlines() if "compiled kernels unavailable" in ln]
    assert len(notes) == 1 and notes[0].startswith("note: ") and "numpy path" in notes[0], out.stderr


def test_fallback_in_process(monkeypatch):
    """``use_kernels`` is False and ``fallback_note`` names the failure when numba does
    not import; asking for the numpy path gives no note."""
    monkeypatch.setitem(sys.modules, "numba", None)  # import numba -> ImportError
    jit._numba_error.cache_clear()  # noqa: SLF001 -- the once-per-process cache under test
    try:
        monkeypatch.setenv(jit.ENV, "numba")
        assert not jit.use_kernels()
        note = jit.fallback_note()
        assert "numba" in note and "numpy path" in note
        monkeypatch.setenv(jit.ENV, "numpy")
        assert jit.fallback_note() is None
    finally:  # numba comes back when monkeypatch undoes; it is tried again then
        jit._numba_error.cache_clear()  # noqa: SLF001


def test_kernel_modules_are_imported_lazily():
    """Importing the numpy modules the kernels speed up loads no kernel and no numba."""
    code = ("import sys; import foldprint.physics.kinematics, foldprint.physics.recovery.batch, "
            "foldprint.collision.swept_search, foldprint.collision.broadphase; "
            "bad = [m for m in sys.modules if m.startswith('numba') or m.endswith('_kernels')]; "
            "print(bad); raise SystemExit(1 if bad else 0)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stdout + out.stderr

