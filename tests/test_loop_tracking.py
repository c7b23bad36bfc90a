"""The array tracker (:mod:`foldprint.physics.loops.tracker`) against the tracker it replaced.

Two references. C and J: each cycle's closure as a product of 4x4 transforms, one cycle at
a time (:class:`Reference` below), equal to round-off. The tracking: the step-by-step
tracker kept in ``tests/loop_reference.py`` (one generator per drive, an SVD per
Gauss-Newton step, a solve at every grid step, no windows), on the templates' drives, the
check's scattered samples and drives made to cross the flat sheet, jump (sub-steps) and
lock: closed angles within ANGLE_TOL at every grid time, every answer closed, and the same
events (the hinges that cannot follow and when, the time a drive locks, the degrees of
freedom), also for drives that are exactly symmetric (every crease of a symmetric vertex on
one material), whose branches are equally near the drive at the flat sheet."""

from __future__ import annotations

from itertools import islice
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.io.fold_format import design_from_fold
from foldprint.io.load import load_design
from foldprint.model import crease_patterns as cp
from foldprint.model.materials import default_library
from foldprint.physics.loops import corrector as loop_solve, drive_state as loop_state, tracker as loop_tracking
from foldprint.physics.kinematics import hinge_frames
from foldprint.physics.hinge_drive import GRID_TOL_S, HingeDrive, loop_dt, run_times
from foldprint.physics.loops.closure import CLOSURE_TOL, OPT_TOL, LoopSolver, _rotvec
from foldprint.simulation.robust import sample_drives
from foldprint.simulation.scatter import default_scatter, iter_samples

from loop_reference import OldSolver

ROOT = Path(__file__).resolve().parent.parent
#: largest difference (rad) of a closed angle between the trackers: both stop a solve when a
#: step moves no angle more than OPT_TOL, from different starting points (measured: <= 3e-5)
ANGLE_TOL = 10 * OPT_TOL


class Reference(LoopSolver):
    """C and J the slow way: per-cycle 4x4 products."""

    def __init__(self, frames, hinge_ids):
        super().__init__(frames, hinge_ids)
        self._cyc = [(np.array([k for k, _ in cyc]), np.array([0 if sg > 0 else 1 for _, sg in cyc]),
                      np.array([sg for _, sg in cyc])) for cyc in self.cycles]

    def _factors(self, x):
        ang = np.stack([x, -x])[:, :, None, None]
        r = np.eye(3) + np.sin(ang) * self._k + (1 - np.cos(ang)) * self._k2
        g = np.zeros((2, self.n, 4, 4))
        g[..., :3, :3] = r
        g[..., :3, 3] = self.point[None] - np.einsum("snij,nj->sni", r, self.point)
        g[..., 3, 3] = 1.0
        return g

    def residual(self, x, jacobian=True):
        m = len(self.cycles)
        c = np.zeros(6 * m)
        jac = np.zeros((6 * m, self.n)) if jacobian else None
        fac = self._factors(x)
        for ci, (ks, side, sgn) in enumerate(self._cyc):
            g = np.eye(4)
            pre = np.empty((len(ks), 4, 4))
            for m_, (k, sd) in enumerate(zip(ks, side)):
                pre[m_] = g
                g = g @ fac[sd, k]
            c[6 * ci:6 * ci + 3] = _rotvec(g[:3, :3])
            p = g[:3, 3]
            c[6 * ci + 3:6 * ci + 6] = p
            if jacobian:
                rot, tr = pre[:, :3, :3], pre[:, :3, 3]
                w = np.einsum("lij,lj->li", rot, self.axis[ks])
                v = np.einsum("lij,lj->li", rot, self.twist[ks, 3:]) + np.cross(tr, w)
                v += np.cross(w, p)
                jac[6 * ci:6 * ci + 3, ks] = (sgn[:, None] * w).T
                jac[6 * ci + 3:6 * ci + 6, ks] = (sgn[:, None] * v).T
        return c, jac


def _design(name):
    if name in ("miura_3x3", "cross_lock_uniform"):
        return load_design(ROOT / "templates" / f"{name}.toml")
    return design_from_fold({"waterbomb": cp.waterbomb, "degree4": cp.degree4, "miura": cp.miura}[name]())


def _solvers(design):
    frames, ids = hinge_frames(design), [h.id for h in design.hinges]
    return LoopSolver(frames, ids), OldSolver(frames, ids)


@pytest.mark.parametrize("name", ["miura_3x3", "waterbomb", "degree4"])
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(0.0, 3.0))
def test_batched_residual_and_jacobian_equal_the_reference(name, seed, scale):
    frames, ids = hinge_frames(_design(name)), [h.id for h in _design(name).hinges]
    fast, ref = LoopSolver(frames, ids), Reference(frames, ids)
    x = scale * np.random.default_rng(seed).uniform(-1, 1, fast.n)
    c0, j0 = ref.residual(x)
    c1, j1 = fast.residual(x)
    assert np.abs(c1 - c0).max() < 1e-12 * max(1.0, np.abs(c0).max())
    assert np.abs(j1 - j0).max() < 1e-12 * max(1.0, np.abs(j0).max())
    assert fast.residual(x, False)[1] is None and np.array_equal(fast.residual(x, False)[0], c1)


@pytest.mark.parametrize("name", ["miura_3x3", "cross_lock_uniform", "waterbomb"])
@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(0.0, 3.0), zero=st.floats(0.0, 1.0))
def test_scattered_jacobian_is_the_product_bit_for_bit(name, seed, scale, zero):
    """J written from its nonzero places (no hinge twice in a cycle) is exactly the dense
    product's, sign bits of its zeros included, at configurations with some angles 0."""
    frames, ids = hinge_frames(_design(name)), [h.id for h in _design(name).hinges]
    fast = LoopSolver(frames, ids)
    assert fast._scatter is not None
    rng = np.random.default_rng(seed)
    xs = scale * rng.uniform(-1, 1, (3, fast.n)) * (rng.uniform(0, 1, (3, fast.n)) >= zero)
    c1, j1 = fast.residuals(xs)
    fast._scatter = None  # the product
    c0, j0 = fast.residuals(xs)
    assert np.array_equal(c1, c0) and np.array_equal(j1, j0)
    assert np.array_equal(np.signbit(j1), np.signbit(j0))


def _check_drives(name, n=6):
    """The first ``n`` scattered drives ``check`` folds (its seed, 1x scatter) on its grid."""
    d = _design(name)
    drives = sample_drives(d, default_library(), list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES,
                                                                              CHECK_SEED), n)))
    times = run_times(d, CHECK_DT_S)
    grid = drives[0]._loop_grid(times, loop_dt(times))[0]
    return d, grid, [dr.driven(grid) for dr in drives]


def _made_drives(name):
    """Drives made to cross the flat sheet (fold, unfold past flat), to jump (a step larger
    than MAX_STEP: sub-steps) and to overdrive, on a crease-by-crease asymmetric drive."""
    d = _design(name)
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    base = HingeDrive(d).driven(t) * (1 + 0.013 * np.arange(len(d.hinges)))[None]
    s = np.sin(np.pi * t / 4.0)[:, None]
    back = base[-1][None] * (1.2 * s - 0.6 * np.clip(t[:, None] - 2.0, 0.0, None))
    jump = base.copy()
    jump[150:] = np.minimum(base[150:] * 1.6, base[-1])
    return d, t, [base, back, jump, base * 2.5]


def _rigid():
    """Three panels around one vertex: no folding motion at all (dof 0), so the drive
    locks the moment it asks for more than FOLLOW_TOL."""
    a = np.radians([0.0, 120.0, 240.0])
    fold = {"frame_unit": "mm", "vertices_coords": [[0, 0]] + [[20 * np.cos(v), 20 * np.sin(v)] for v in a],
            "faces_vertices": [[0, 1, 2], [0, 2, 3], [0, 3, 1]],
            "edges_vertices": [[0, 1], [0, 2], [0, 3], [1, 2], [2, 3], [3, 1]],
            "edges_assignment": ["V", "V", "M", "B", "B", "B"], "edges_foldAngle": [60, 60, -60, 0, 0, 0]}
    d = design_from_fold(fold)
    t = np.arange(0.0, 1.6 + 1e-9, 0.01)
    return d, t, [HingeDrive(d).driven(t) * (1 + 0.013 * np.arange(3))[None]]


def _nominal(name):
    """The nominal drive for 4 s: on ``cross_lock_uniform`` and the waterbomb exactly
    symmetric (every crease of a symmetric vertex on one material), so at the flat sheet
    the branches are equally near it."""
    d = _design(name)
    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    return d, t, [HingeDrive(d).driven(t)]


CASES = {**{f"check {n}": (lambda n=n: _check_drives(n)) for n in ("miura_3x3", "cross_lock_uniform")},
         **{f"nominal {n}": (lambda n=n: _nominal(n)) for n in ("miura_3x3", "cross_lock_uniform", "waterbomb")},
         **{f"made {n}": (lambda n=n: _made_drives(n)) for n in ("miura_3x3", "cross_lock_uniform", "waterbomb",
                                                                  "degree4")},
         "rigid vertex": _rigid}


def _assert_same_path(a, b, drive):
    """The two trackers' closed angles agree within ANGLE_TOL, except at near-flat steps
    (every drive angle below NEAR_FLAT): there the programmed sheet (a fixity's fraction of
    a degree from flat) sits between branches, and the array tracker may hold the closed
    configuration it continues from where the replaced one restarted from the drive. Both
    answers must then be closed and near flat, and the paths must be the same again once
    the sheet has left the flat state (the branch, hence every event, is the same)."""
    diff = np.abs(a.angles - b.angles).max(axis=1)
    apart = diff >= ANGLE_TOL
    if not apart.any():
        return
    flat = np.abs(drive).max(axis=1) < loop_state.NEAR_FLAT
    assert flat[apart].all(), "the trackers part away from the flat sheet"
    for x in (a, b):
        assert np.abs(x.angles[apart]).max() < loop_state.NEAR_FLAT
    assert diff[~flat].max(initial=0.0) < ANGLE_TOL and not apart[-1]  # the same path once folded


@pytest.mark.parametrize("case", sorted(CASES))
def test_array_tracker_gives_the_replaced_trackers_answers_and_events(case):
    design, times, drivens = CASES[case]()
    new, old = _solvers(design)
    got, want = new.track_many(times, drivens), old.track_many(times, drivens)
    for a, b, drive in zip(got, want, drivens):
        _assert_same_path(a, b, drive)
        assert (a.stuck, a.locked_at, a.dof) == (b.stuck, b.locked_at, b.dof)
        assert abs(a.closure - b.closure) < CLOSURE_TOL or a.closure < CLOSURE_TOL
        assert max(new.closure(x) for x in a.angles[::7]) <= max(b.closure, CLOSURE_TOL)
    if case == "rigid vertex":
        assert got[0].locked_at is not None and got[0].dof == 0  # the lock is exercised


def test_lockstep_tracking_of_many_drives_gives_each_drives_own_answer():
    """track_many (the Monte-Carlo's chunk: one pool, one array evaluation per round) against
    track of each drive alone and of the drives in another order: the same answers bit for
    bit (every array operation of a round is row by row, so which drives share a chunk, and
    where in the pool their points sit, changes no number)."""
    d, grid, drivens = _check_drives("miura_3x3", 5)
    solver = _solvers(d)[0]
    many = solver.track_many(grid[:400], [v[:400] for v in drivens])
    back = solver.track_many(grid[:400], [v[:400] for v in drivens[::-1]])[::-1]
    for v, got, other in zip(drivens, many, back):
        alone = solver.track_many(grid[:400], [v[:400]], compiled=True)[0]  # the chunk's path
        for x in (alone, other):
            assert np.array_equal(got.angles, x.angles) and got.closure == x.closure
            assert (got.stuck, got.locked_at, got.dof) == (x.stuck, x.locked_at, x.dof)


def test_window_widths_are_the_next_steps_that_move_by_a_step_at_most():
    """DriveState.ahead (from per-drive tables made once) against the definition, step by step:
    1 plus the number of next grid steps in a row whose drive moves by more than SKIP_TOL and
    at most MAX_STEP, at most WINDOW of them, capped by the drive's width."""
    rng = np.random.default_rng(7)
    n_t = 90
    move = rng.choice([0.0, 1e-9, 0.05, loop_solve.MAX_STEP, 0.3], size=(3, n_t - 1, 2),
                      p=[0.1, 0.05, 0.7, 0.05, 0.1])
    driven = np.concatenate([np.zeros((3, 1, 2)), np.cumsum(move, axis=1)], axis=1)
    state = loop_state.DriveState(np.arange(float(n_t)), driven)
    for k in range(n_t):
        state.k[:], state.width[:] = k, [2, 16, loop_state.WINDOW]
        got = state.ahead(np.arange(3), np.array([True, True, True]))
        for d in range(3):
            run = 0
            while run < loop_state.WINDOW and k + run + 1 < n_t:
                step = np.abs(driven[d, k + run + 1] - driven[d, k + run]).max()
                if not loop_state.SKIP_TOL < step <= loop_solve.MAX_STEP:
                    break
                run += 1
            assert got[d] == min(1 + run, state.width[d]), (d, k)
        assert state.ahead(np.arange(3), np.zeros(3, bool)).tolist() == [1, 1, 1]


def test_windows_solve_ahead_without_changing_the_answers(monkeypatch):
    """Solving grid steps ahead from the last answer (windows) against one step at a time
    (WINDOW = 1): the same answers within ANGLE_TOL, in fewer rounds."""
    d, grid, drivens = _check_drives("miura_3x3", 4)
    solver = _solvers(d)[0]
    evaluate = solver.residuals
    ahead = loop_tracking.track(evaluate, grid, np.stack(drivens))
    monkeypatch.setattr(loop_state, "WINDOW", 1)
    monkeypatch.setattr(loop_tracking, "WINDOW", 1)
    single = loop_tracking.track(evaluate, grid, np.stack(drivens))
    assert np.abs(ahead.angles - single.angles).max() < ANGLE_TOL
    assert np.array_equal(ahead.dof, single.dof) and np.array_equal(ahead.locked_at, single.locked_at, equal_nan=True)
    assert ahead.rounds < 0.7 * single.rounds


def test_restarts_ahead_cut_the_rounds_near_the_flat_sheet(monkeypatch):
    """Restarts from the drive started PREFETCH steps ahead against each started with its
    step: the same answers (a restart depends on its drive alone), in fewer rounds."""
    d, grid, drivens = _check_drives("cross_lock_uniform", 4)
    evaluate = _solvers(d)[0].residuals
    ahead = loop_tracking.track(evaluate, grid[:250], np.stack(drivens)[:, :250])
    monkeypatch.setattr(loop_tracking, "PREFETCH", 0)
    each = loop_tracking.track(evaluate, grid[:250], np.stack(drivens)[:, :250])
    assert np.array_equal(ahead.angles, each.angles)
    assert ahead.rounds < 0.7 * each.rounds


def test_the_loop_grid_holds_each_simulation_time_once():
    """The continuation grid (LOOP_DT) and the simulation's times (another rounding of the
    same instants) merge without near-duplicates, and every simulation time is a grid time."""
    d = _design("miura_3x3")
    times = run_times(d, CHECK_DT_S)
    grid = HingeDrive(d)._loop_grid(times, loop_dt(times))[0]
    assert np.diff(grid).min() >= GRID_TOL_S and np.isin(times, grid).all()
    assert len(grid) == len(times)


@pytest.mark.parametrize("model", ["arc", "point"])
def test_held_configurations_give_the_poses_and_gap_of_every_time(model):
    """simulate_kinematics computes the poses (and the arc gap) of a pattern with loops once
    per distinct configuration: the same arrays as forward() and loop_gap_mm() of every time."""
    from foldprint.core.modes import HingeModel
    from foldprint.physics.kinematics import forward
    from foldprint.physics.hinge_drive import loop_gap_mm, simulate_kinematics

    d = _design("miura_3x3")
    traj = simulate_kinematics(d, model=model)
    assert (np.diff(traj.angles, axis=0) == 0).all(axis=1).sum() > 100  # it does hold still
    assert np.array_equal(traj.poses, forward(d, traj.angles, HingeModel(model), compiled=True))  # the simulation's path
    if model == "arc":
        assert traj.loops.arc_gap_mm == loop_gap_mm(d, traj.angles, HingeModel.ARC)


def test_the_arc_gap_is_computed_when_read_not_for_the_monte_carlo(monkeypatch):
    """A loop pattern's arc gap is a report's number: the Monte-Carlo's folds (outcomes only)
    never compute it, a trajectory computes it once, when first read, and then holds it."""
    from foldprint.core.modes import VERDICT_METHOD, HingeModel
    from foldprint.physics import hinge_drive
    from foldprint.simulation.robust import run_samples

    d = _design("miura_3x3")
    calls = []
    real = hinge_drive.loop_gap_mm
    monkeypatch.setattr(hinge_drive, "loop_gap_mm", lambda *a, **k: calls.append(1) or real(*a, **k))
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 2))
    assert len(run_samples((d, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD))) == 2
    assert calls == []
    traj = hinge_drive.simulate_kinematics(d, model="arc")
    assert calls == []
    first = traj.loops.arc_gap_mm
    assert calls == [1] and traj.loops.arc_gap_mm == first == real(d, traj.angles, HingeModel.ARC)
    assert calls == [1]  # read again: held


class _Toy(OldSolver):
    """A closure of two angles given as functions: the reference tracker runs on it as on a
    crease pattern (and the array tracker on ``residuals``)."""

    def __init__(self, closure, jacobian):
        self.n, self.ids, self.cycles = 2, ["a", "b"], [[(0, 1.0)]]
        self._c, self._j = closure, jacobian

    def residuals(self, xs, jacobian=True):
        xs = np.asarray(xs, float)
        return self._c(xs), (self._j(xs) if jacobian else None)


def test_on_a_parabola_the_tracker_finds_the_nearest_closed_point():
    """Closure x1 = x0^2, drive (a(t), 0): the answer is the point of the parabola nearest
    the drive, x0 the root of 2 (x0 - a) + 4 x0^3 = 0 (one real root), an independent
    reference; and the replaced tracker gives the same answers and events. The tangent
    space is a line, so away from the flat sheet the line solve runs (near it, the restarts)."""
    toy = _Toy(lambda x: (x[:, 1] - x[:, 0] ** 2)[:, None],
               lambda x: np.stack([-2 * x[:, 0], np.ones(len(x))], axis=1)[:, None, :])
    t = np.linspace(0.0, 3.0, 301)
    drive = np.stack([1.5 * np.sin(t / 2), np.zeros_like(t)], axis=1)
    got = loop_tracking.track(toy.residuals, t, drive[None])
    x = got.angles[0]
    exact = [min(np.roots([4.0, 0.0, 2.0, -2 * a]), key=lambda r: abs(r.imag)).real for a in drive[:, 0]]
    assert np.abs(x[:, 0] - exact).max() < ANGLE_TOL and np.abs(x[:, 1] - x[:, 0] ** 2).max() < CLOSURE_TOL
    ref = toy.track(t, drive)
    assert np.abs(ref.angles - x).max() < ANGLE_TOL and (got.dof[0], np.isnan(got.locked_at[0])) == (1, True)


def test_a_solve_that_cannot_close_holds_the_last_configuration_and_locks():
    """A closure that holds for x0 <= 0.5 and fails beyond (residual 1, no Jacobian): the
    drive is followed to 0.5, then every solve loses the manifold, the last closed
    configuration is held and the drive is locked at the first step beyond; as the
    replaced tracker does."""
    toy = _Toy(lambda x: (x[:, :1] > 0.5).astype(float), lambda x: np.zeros((len(x), 1, 2)))
    t = np.linspace(0.0, 1.0, 101)
    drive = np.stack([t, 0.2 * t], axis=1)
    got = loop_tracking.track(toy.residuals, t, drive[None])
    ref = toy.track(t, drive)
    first = int(np.argmax(t > 0.5))
    assert got.locked_at[0] == ref.locked_at == t[first]
    assert np.array_equal(got.angles[0, first:], np.repeat(drive[first - 1][None], len(t) - first, axis=0))
    assert np.abs(ref.angles - got.angles[0]).max() < ANGLE_TOL


def _solves(x, res=None, null=None, done=None, free=None):
    """Answers of solves in two angles, tangent spaces along the first axis by default."""
    x = np.asarray(x, float)
    p = len(x)
    free = np.array([[True, False]] * p) if free is None else np.asarray(free)
    return loop_solve.Solves(x, np.full(p, 1e-12) if res is None else np.asarray(res, float),
                                np.full(p, 1) if null is None else np.asarray(null),
                                np.full(p, True) if done is None else np.asarray(done),
                                np.repeat(np.eye(2)[None], p, axis=0), free)


def test_a_window_answer_is_kept_only_where_the_step_by_step_tracker_gives_it():
    """Row 0 is the answer before; the predictor from it toward the drive (0.6, 0.3) moves
    along its tangent (the first axis) to (0.6, 0.3). Kept: an answer within ACCEPT of that
    predictor. Not kept: one farther, one not converged, not closed, with another tangent
    dimension, or after an answer near the flat sheet (row 7)."""
    a = loop_tracking.ACCEPT
    sol = _solves([[0.5, 0.3], [0.6, 0.3 + 0.5 * a], [0.6, 0.3 + 2 * a], [0.6, 0.3], [0.6, 0.3], [0.6, 0.3],
                   [0.1, 0.05], [0.15, 0.05]],
                  res=[1e-12, 1e-12, 1e-12, 1e-12, 1e-6, 1e-12, 1e-12, 1e-12],
                  null=[1, 1, 1, 1, 1, 2, 1, 1], done=[True, True, True, False, True, True, True, True])
    prev, row = np.array([0, 0, 0, 0, 0, 6]), np.array([1, 2, 3, 4, 5, 7])
    y = np.array([[0.6, 0.3]] * 5 + [[0.15, 0.05]])
    assert loop_tracking._acceptable(sol, prev, row, y).tolist() == [True, False, False, False, False, False]


def test_near_the_flat_sheet_the_restart_is_taken_only_when_it_closed_nearer_without_a_jump():
    """Drive ys = (0.1, 0); last answer x = 0. Rows 0-4: the continued solves; rows 5-9 the
    restarts. Taken: a closed restart nearer the drive (row 5). Not: a restart that jumps
    more than JUMP beyond the continued answer (6), one not closed (7), one nearer a drive
    the continued answer already met within OPT_TOL (8), one no nearer (9), one nearer but
    with a hinge on the other side of flat from its drive (row 10, for row 5's drive)."""
    j = loop_tracking.JUMP
    main = [[0.05, 0.0], [0.05, 0.0], [0.05, 0.0], [0.1 + 0.5 * OPT_TOL, 0.0], [0.05, 0.0], [0.05, 0.01]]
    restart = [[0.09, 0.0], [0.1, -0.05 - 2 * j], [0.09, 0.0], [0.1, 0.0], [0.05, 0.0], [0.09, -0.001]]
    sol = _solves(main + restart, res=[1e-12] * 8 + [1e-6] + [1e-12] * 3)
    ys = np.array([[0.1, 0.0]] * 5 + [[0.1, 0.002]])
    ys[1] = [0.1, -0.02 - 2 * j]  # a drive the restart reaches nearer, but far off the continued answer
    rows = loop_tracking._choose(sol, np.arange(6), np.zeros((6, 2)), ys, np.arange(6), 6 + np.arange(6))
    assert rows.tolist() == [6, 1, 2, 3, 4, 5]


def test_a_line_is_certified_only_as_the_whole_null_space():
    """J with the null line w (certified), with a second null direction, with no null
    direction, and a w that is not null (none certified)."""
    rng = np.random.default_rng(3)
    q, _ = np.linalg.qr(rng.standard_normal((4, 4)))
    w = q[:, 0]
    full = rng.standard_normal((6, 4)) @ (np.eye(4) - np.outer(w, w))  # rank 3, null space w
    two = full @ (np.eye(4) - np.outer(q[:, 1], q[:, 1]))  # null space w and q1
    rank4 = rng.standard_normal((6, 4))
    jac = np.stack([full, two, rank4, full])
    gram = jac.transpose(0, 2, 1) @ jac
    ws = np.stack([w, w, w, q[:, 1]])
    assert loop_solve._certified(jac, gram, ws).tolist() == [True, False, False, False]


def test_the_line_solve_takes_the_eigen_decompositions_step():
    """Where J's null space is the line w, the solve with J^T J + t t^T (t near w) takes
    the same Gauss-Newton step as the eigen-decomposition: -J^+ C orthogonal to w plus the
    drive's part along w, and returns w itself (inverse iteration, exact in one solve)."""
    rng = np.random.default_rng(5)
    q, _ = np.linalg.qr(rng.standard_normal((5, 5)))
    w = q[:, 0]
    jac = (rng.standard_normal((8, 5)) @ (np.eye(5) - np.outer(w, w)))[None]
    gram = jac.transpose(0, 2, 1) @ jac
    c, d = rng.standard_normal((1, 8)), rng.standard_normal((1, 5))
    g = (jac.transpose(0, 2, 1) @ c[..., None])[..., 0]
    guide = w + 0.05 * rng.standard_normal(5)
    line, vec = loop_solve._gn_line(gram, g, d, (guide / np.linalg.norm(guide))[None])
    eig, _, free = loop_solve._gn_eigh(gram, g, d, np.zeros(1))
    assert free.sum() == 1 and np.allclose(line, eig, atol=1e-12)
    assert abs(abs(vec[0, :, 0] @ w) - 1.0) < 1e-12


def test_near_the_flat_sheet_a_line_tangent_takes_the_line_solve(monkeypatch):
    """From converged answers of a Miura pattern 0.01-0.2 rad from flat (LINE_ABOVE to
    NEAR_FLAT; a one-dimensional tangent space there) the next step's solve takes the line
    solve, its guide the answer's tangent, and ends certified (still a line solve) at the
    eigen-decomposition's answer within 1e-9 rad with the same tangent: the same equations
    from the same start, the normal equations resolving J's small singular values (>= 0.18
    of 123 there) to ~1e-10 (measured 6e-14). From an answer below LINE_ABOVE it does not."""
    d, grid, drivens = _check_drives("miura_3x3", 1)
    evaluate, drive = _solvers(d)[0].residuals, drivens[0]
    angles = loop_tracking.track(evaluate, grid, drive[None]).angles[0]
    big = np.abs(angles).max(axis=1)
    near = ((big >= loop_state.LINE_ABOVE) & (big < loop_state.NEAR_FLAT)).nonzero()[0]
    assert loop_state.LINE_ABOVE == loop_solve.SVD_BELOW and len(near) > 10

    def next_step(k):
        """The solve of step k + 1 from the answer of step k: whether it took the line solve,
        how it ended (its angles, tangent, whether still a line solve) and its guide."""
        sol = loop_solve.solve(evaluate, angles[k][None], drive[k][None])  # the answer's tangent space
        state = loop_state.DriveState(grid, drive[None])
        state.settle(np.array([0]), sol, np.array([0]))
        state.k[0], state.prev[0] = k + 1, drive[k]
        pool, req = loop_solve.Pool(drive.shape[1], 16), loop_tracking._Requests(1, drive.shape[1])
        req.post(state, pool, np.array([0]))
        m = req.main[0]
        took, guide = pool.line[m], pool.guide[m].copy()
        while pool.alive[m]:
            pool.round(evaluate)
        assert pool.done[m] and pool.res[m] < CLOSURE_TOL and pool.free[m].sum() == 1
        return took, pool.x[m].copy(), pool.basis[m][:, pool.free[m]][:, 0], pool.line[m], guide, sol

    for k in near[::4]:
        took, x, t, certified, guide, sol = next_step(k)
        assert took and certified and sol.plain[0] and sol.null[0] == 1
        assert abs(abs(guide @ sol.basis[0][:, sol.free[0]][:, 0]) - 1.0) < 1e-12  # the answer's tangent
        with monkeypatch.context() as m:
            m.setattr(loop_tracking, "LINE_ABOVE", np.inf)  # the eigen-decomposition
            took_e, x_e, t_e, _, _, _ = next_step(k)
        assert not took_e
        assert np.abs(x - x_e).max() < 1e-9 and abs(abs(t @ t_e) - 1.0) < 1e-9
    below = (big < loop_state.LINE_ABOVE) & (big > 1e-3)
    assert below.any() and not next_step(below.nonzero()[0][-1])[0]


def test_away_from_the_flat_sheet_a_drive_that_barely_moved_keeps_its_answer(monkeypatch):
    """SKIP_FAR: a converged answer away from the flat sheet is kept while its drive moves
    less than SKIP_FAR (OPT_TOL); near the flat sheet (and after an unconverged answer) only
    SKIP_TOL holds it. Against solving every moving step (SKIP_FAR = SKIP_TOL): answers within
    ANGLE_TOL, the same events, fewer evaluations."""
    times, drive = np.arange(3.0), np.zeros((1, 3, 2))
    state = loop_state.DriveState(times, np.repeat(drive, 3, axis=0))
    state.x[:] = [[0.5, 0.1], [0.05, 0.1], [0.5, 0.1]]
    state.xmax[:] = np.abs(state.x).max(axis=1)  # as settle keeps it
    state.tangent[:] = [True, True, False]
    assert state.skip_tol(np.arange(3)).tolist() == [loop_state.SKIP_FAR, loop_state.SKIP_TOL,
                                                     loop_state.SKIP_TOL]
    assert loop_state.SKIP_TOL < loop_state.SKIP_FAR <= OPT_TOL

    d, grid, drivens = _check_drives("miura_3x3", 4)
    evaluate = _solvers(d)[0].residuals
    held = loop_tracking.track(evaluate, grid, np.stack(drivens))
    monkeypatch.setattr(loop_state, "SKIP_FAR", loop_state.SKIP_TOL)
    every = loop_tracking.track(evaluate, grid, np.stack(drivens))
    assert np.abs(held.angles - every.angles).max() < ANGLE_TOL
    assert np.array_equal(held.dof, every.dof) and np.array_equal(held.locked_at, every.locked_at, equal_nan=True)
    assert held.evaluations < 0.97 * every.evaluations
    # the held steps: far from the flat sheet, drive moved less than SKIP_FAR, answer unchanged
    a, v = held.angles, np.stack(drivens)
    same = (np.abs(np.diff(a, axis=1)).max(axis=2) == 0) & (np.abs(a[:, :-1]).max(axis=2) >= loop_state.NEAR_FLAT)
    assert (same & (np.abs(np.diff(v, axis=1)).max(axis=2) > loop_state.SKIP_TOL)).any()


def test_near_the_flat_sheet_the_first_step_is_the_evaluated_one():
    """From a converged answer near the flat sheet whose tangent space is by the plain rank
    rule, _starts starts the solve where one Gauss-Newton step from that answer
    (evaluating C and J there) goes, and counts that step; a step below OPT_TOL is not taken
    (the solve then stops at the answer in one evaluation).
    On the parabola x1 = x0^2 (closed points exact, tangent (1, 2 x0))."""
    toy = _Toy(lambda x: (x[:, 1] - x[:, 0] ** 2)[:, None],
               lambda x: np.stack([-2 * x[:, 0], np.ones(len(x))], axis=1)[:, None, :])
    x = np.array([[0.1, 0.01], [0.1, 0.01]])
    ys = np.array([[0.15, 0.0], [0.1 + 1e-7, 0.01]])
    pool = loop_solve.Pool(2, 4)
    ids = pool.add(x, ys)
    pool.round(toy.residuals)  # one step from x: C and J evaluated at x
    assert pool.alive[ids].tolist() == [True, False] and pool.it[ids[0]] == 1
    state = loop_state.DriveState(np.arange(2.0), np.zeros((2, 2, 2)))
    state.x[:], state.tangent[:], state.plain[:] = x, True, True
    state.basis[:], state.free[:] = pool.basis[ids[1]], pool.free[ids[1]]  # the tangent at x
    near = np.array([True, True])
    start, taken, pred = loop_tracking._starts(state, np.arange(2), near, x, ys)
    assert taken.tolist() == [1, 0] and np.array_equal(start[1], x[1]) and not pred.any()
    p0 = start[0].copy()
    assert np.abs(start[0] - pool.x[ids[0]]).max() < 1e-12
    again = loop_solve.Pool(2, 2)
    row = again.add(start[:1], ys[:1], taken=taken[:1])
    assert again.it[row].tolist() == [1]
    state.plain[:] = False  # by the far rank rule (RANK_RES, a far line solve): evaluated again
    assert loop_tracking._starts(state, np.arange(2), near, x, ys)[1].tolist() == [0, 0]
    state.plain[:], state.tangent[:] = True, False  # an unconverged answer: no step from its tangent space
    start, taken, _ = loop_tracking._starts(state, np.arange(2), near, x, ys)
    assert taken.tolist() == [0, 0] and np.array_equal(start, x)
    state.plain[:], state.tangent[:] = False, True  # away from the flat sheet: the predictor, no step counted
    start, taken, pred = loop_tracking._starts(state, np.arange(2), ~near, x, ys)
    assert taken.tolist() == [0, 0] and pred.all() and np.abs(start[0] - p0).max() < 1e-12
    assert pool.view(ids).plain.tolist() == [True, True]  # the pool's points near flat (not far)


def test_the_first_step_from_the_tangent_space_saves_rounds_not_answers(monkeypatch):
    """Tracking with the near-flat first step from the stored tangent space against evaluating
    C and J at the answer again: the same answers (the step differs by its |C| < 1e-9
    correction), the same events, in fewer rounds."""
    d, grid, drivens = _check_drives("cross_lock_uniform", 4)
    evaluate = _solvers(d)[0].residuals
    fast = loop_tracking.track(evaluate, grid[:300], np.stack(drivens)[:, :300])
    starts = loop_tracking._starts

    def without(st, live, near, x, ys):  # near the flat sheet every solve starts at the answer
        start, taken, pred = starts(st, live, near, x, ys)
        start[near] = x[near]
        return start, np.zeros_like(taken), pred

    monkeypatch.setattr(loop_tracking, "_starts", without)
    slow = loop_tracking.track(evaluate, grid[:300], np.stack(drivens)[:, :300])
    assert np.abs(fast.angles - slow.angles).max() < ANGLE_TOL
    assert np.array_equal(fast.dof, slow.dof) and np.array_equal(fast.locked_at, slow.locked_at, equal_nan=True)
    assert fast.rounds < 0.8 * slow.rounds


def test_the_drive_is_restarted_from_only_while_it_too_is_near_the_flat_sheet():
    """Near the flat sheet every RESTART_EVERY-th grid step also restarts from its drive, and
    the restarts of the next such steps start ahead; not where the drive itself is NEAR_FLAT
    or more from flat (the answer may lag there: a lock, a lagging crease), nor ahead for such
    steps, nor at the steps between (those start none ahead either: the restarting steps
    before them did), unless the drive is within RESTART_ALL of flat: then every step."""
    flat, every = loop_state.NEAR_FLAT, loop_state.RESTART_EVERY
    assert every > 1
    ramp = np.linspace(0.0, 2.0 * flat, 21)  # crosses NEAR_FLAT at step 10
    tiny = ramp * (0.5 * loop_state.RESTART_ALL / ramp.max())  # every step within RESTART_ALL
    driven = np.stack([np.stack([r, 0.5 * r], axis=1) for r in (ramp, ramp, ramp, tiny)])
    state = loop_state.DriveState(np.arange(21.0), driven)
    k0 = every  # a restarting step near the flat sheet (drive below NEAR_FLAT)
    state.k[:] = [k0, 12, k0 + 1, k0 + 1]  # near, beyond, near between restarting steps, tiny; answers at flat
    state.prev[:] = driven[[0, 1, 2, 3], [k0 - 1, 11, k0, k0]]  # the drives of the steps before: one sub-step each
    pool, req = loop_solve.Pool(2, 8), loop_tracking._Requests(4, 2)
    req.post(state, pool, np.arange(4))
    assert req.restart[0] >= 0 and np.array_equal(pool.target[req.restart[0]], driven[0, k0])
    assert req.restart[1] == -1 and req.restart[2] == -1
    assert req.restart[3] >= 0 and np.array_equal(pool.target[req.restart[3]], driven[3, k0 + 1])
    want = [k for k in range(k0 + 1, min(k0 + loop_tracking.PREFETCH, 9) + 1) if k % every == 0]
    # ahead, with a step's own restart: the restarting steps still near the flat sheet (the
    # drive is below NEAR_FLAT up to step 9)
    assert want and sorted(req.early_k[0][req.early_k[0] >= 0].tolist()) == want
    assert (req.early_k[1:3] < 0).all()
    assert sorted(req.early_k[3].tolist()) == list(range(k0 + 2, k0 + 2 + loop_tracking.PREFETCH))


@pytest.mark.parametrize("seed", range(20))
def test_interp_rows_is_np_interp_of_every_column(seed):
    """LoopSolution.at reads all hinges with one search: the same numbers as np.interp of
    each column, bit for bit, inside, outside and exactly on the grid."""
    from foldprint.physics.loops.closure import interp_rows

    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 60))
    grid = np.round(np.arange(n) * 0.01, 10) if seed % 2 else np.cumsum(rng.random(n) + 1e-3)
    values = rng.normal(size=(n, 7))
    t = np.concatenate([rng.uniform(grid[0] - 1, grid[-1] + 1, 40), grid[rng.integers(0, n, 6)], grid[[0, -1]]])
    want = np.stack([np.interp(t, grid, values[:, k]) for k in range(values.shape[1])], axis=1)
    np.testing.assert_array_equal(interp_rows(t, grid, values), want)
