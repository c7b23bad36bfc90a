"""Restarts from the drive that cannot be taken are not run (``drive_state.RESTART_SIDED``,
docs/loops.md "Restarts that cannot be taken"): which drives and answers the rule covers, and,
on the templates' check drives and on a sheet programmed flat, that a restart skipped is one
that, run, would not have been taken (the same answers bit for bit as running every restart),
while the restarts that switch branch still run and are taken."""

from __future__ import annotations

from dataclasses import replace
from itertools import islice

import numpy as np

from foldprint.core.constants import CHECK_DT_S, CHECK_SEED
from foldprint.model.materials import default_library
from foldprint.physics.hinge_drive import loop_dt, run_times
from foldprint.physics.loops import drive_state as loop_state, tracker as loop_tracking
from foldprint.physics.loops.corrector import OPT_TOL, SVD_BELOW
from foldprint.simulation.robust import sample_drives
from foldprint.simulation.scatter import default_scatter, iter_samples

from test_loop_tracking import CASES, _check_drives, _design, _solvers


def test_a_restart_is_needless_only_where_every_hinge_is_folded_on_its_drives_side():
    """Drive (0.1, -0.05): the last answer (0.02, -0.01), converged, covers it; not an answer
    with a hinge on the other side of flat, one within OPT_TOL of flat, one not converged, nor
    a drive within RESTART_SIDED (SVD_BELOW) of flat."""
    assert loop_state.RESTART_SIDED == SVD_BELOW
    st = loop_state.DriveState(np.arange(2.0), np.zeros((6, 2, 2)))
    st.x[:] = [[0.02, -0.01], [0.02, 0.01], [0.02, -0.5 * OPT_TOL], [0.02, -2 * OPT_TOL], [0.02, -0.01],
               [0.02, -0.01]]
    st.tangent[:] = [True, True, True, True, False, True]
    y = np.array([[0.1, -0.05]] * 5 + [[0.99 * SVD_BELOW, -0.5 * SVD_BELOW]])
    assert st.needless(np.arange(6), y).tolist() == [True, False, False, True, False, False]
    assert st.needless(np.array([0, 0]), np.array([[0.1, 0.05], [-0.1, -0.05]])).tolist() == [False, False]


def _chosen(monkeypatch):
    """Record, by drive value, whether each restart that ran was taken."""
    seen: dict[bytes, bool] = {}
    choose = loop_tracking._choose

    def spy(sol, rows, x, ys, again, restart):
        out = choose(sol, rows, x, ys, again, restart)
        for j, b in zip(again, restart):
            seen[ys[j].tobytes()] = bool(out[j] == b)
        return out

    monkeypatch.setattr(loop_tracking, "_choose", spy)
    return seen


def _against_every_restart(monkeypatch, design, grid, driven):
    """Track with the rule and with every restart run (RESTART_SIDED infinite): the same
    answers and events bit for bit; returns the restarts run by each, drive -> taken."""
    evaluate = _solvers(design)[0].residuals
    seen = _chosen(monkeypatch)
    skip = loop_tracking.track(evaluate, grid, driven)
    ran = dict(seen)
    seen.clear()
    monkeypatch.setattr(loop_state, "RESTART_SIDED", np.inf)
    every = loop_tracking.track(evaluate, grid, driven)
    assert np.array_equal(skip.angles, every.angles) and np.array_equal(skip.closure, every.closure)
    assert np.array_equal(skip.locked_at, every.locked_at, equal_nan=True) and np.array_equal(skip.dof, every.dof)
    assert skip.evaluations <= every.evaluations
    return ran, dict(seen), skip.evaluations / every.evaluations


def _taken_beyond(seen, at):
    return [np.abs(np.frombuffer(y)).max() for y, taken in seen.items() if taken and np.abs(np.frombuffer(y)).max() > at]


def test_a_skipped_restart_is_one_that_would_not_be_taken(monkeypatch):
    """miura_3x3's check drives: the restarts not run are all ones that, run, are not taken,
    from drives beyond SVD_BELOW; every restart taken still runs; fewer evaluations."""
    d, grid, drivens = _check_drives("miura_3x3", 4)
    ran, every, ratio = _against_every_restart(monkeypatch, d, grid, np.stack(drivens))
    skipped = set(every) - set(ran)
    assert len(skipped) >= 40 and set(ran) <= set(every)
    assert not any(every[y] for y in skipped)
    assert min(np.abs(np.frombuffer(y)).max() for y in skipped) >= SVD_BELOW
    assert ratio < 0.93


def test_a_restart_that_switches_branch_is_still_taken(monkeypatch):
    """cross_lock_uniform's check sample 41 switches branch through a restart at a drive of
    0.061 rad (its non-folding creases stay within OPT_TOL of flat), and a miura_3x3 sheet
    programmed flat (fixity 1, 2x scatter, sample 23) returns to its branch through one at
    0.158 rad (its answer had creases on the other side of flat): both still run and taken."""
    d, grid, drivens = _check_drives("cross_lock_uniform", 42)
    ran, _, _ = _against_every_restart(monkeypatch, d, grid, np.stack(drivens[41:]))
    assert max(_taken_beyond(ran, 0.05)) > 0.06

    monkeypatch.undo()
    d = _design("miura_3x3")
    d = replace(d, hinges=tuple(replace(h, fixity=1.0) for h in d.hinges))
    sample = list(islice(iter_samples(d, default_scatter().scaled(2.0), 24, CHECK_SEED), 24))[23]
    drive = sample_drives(d, default_library(), [sample])[0]
    times = run_times(d, CHECK_DT_S)
    grid = drive._loop_grid(times, loop_dt(times))[0]
    ran, _, _ = _against_every_restart(monkeypatch, d, grid, drive.driven(grid)[None])
    assert max(_taken_beyond(ran, 0.1)) > 0.15


def test_a_restart_skipped_that_would_be_taken_lands_within_opt_tol_of_the_continued_answer(monkeypatch):
    """Drives made to cross the flat sheet, jump and overdrive (degree-4 vertex, miura_3x3):
    there a restart on the continued branch is sometimes taken at the corrector's resolution;
    the ones the rule skips land within OPT_TOL of the continued answer, and the tracks stay
    within OPT_TOL of those that run every restart, the events the same."""
    for case in ("made degree4", "made miura_3x3"):
        design, times, drivens = CASES[case]()
        evaluate, driven = _solvers(design)[0].residuals, np.stack(drivens)
        seen: dict[bytes, tuple[bool, float]] = {}
        choose = loop_tracking._choose

        def spy(sol, rows, x, ys, again, restart):
            out = choose(sol, rows, x, ys, again, restart)
            for j, b in zip(again, restart):
                seen[ys[j].tobytes()] = (bool(out[j] == b), float(np.abs(sol.x[b] - sol.x[rows[j]]).max()))
            return out

        monkeypatch.setattr(loop_tracking, "_choose", spy)
        skip = loop_tracking.track(evaluate, times, driven)
        ran = dict(seen)
        seen.clear()
        monkeypatch.setattr(loop_state, "RESTART_SIDED", np.inf)
        every = loop_tracking.track(evaluate, times, driven)
        monkeypatch.undo()
        apart = [seen[y][1] for y in set(seen) - set(ran) if seen[y][0]]
        assert max(apart, default=0.0) < OPT_TOL
        assert np.abs(skip.angles - every.angles).max() < OPT_TOL
        assert np.array_equal(skip.locked_at, every.locked_at, equal_nan=True) and np.array_equal(skip.dof, every.dof)
        assert skip.evaluations < every.evaluations
