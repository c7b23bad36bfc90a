"""Restarts from the drive that cannot be taken are not run (``drive_state.RESTART_SKIP``,
docs/loops.md "Restarts that cannot be taken"): the margin a restart not taken left, the
directions it covers, and, on the templates' check drives, that a restart skipped is one that,
run, would not have been taken (the same answers bit for bit as running every restart),
while a restart that switches branch is still run and taken."""

from __future__ import annotations

import numpy as np
import pytest

from foldprint.physics.loops import drive_state as loop_state, tracker as loop_tracking
from foldprint.physics.loops.corrector import SVD_BELOW

from test_loop_tracking import _check_drives, _solvers


def _state(n_drives=1):
    return loop_state.DriveState(np.arange(2.0), np.zeros((n_drives, 2, 2)))


def test_a_restart_not_taken_covers_the_directions_within_half_its_margin():
    """Drive y = (0.1, 0): the continued answer on it, the restart's 0.05 off (margin 0.05,
    over |y| 0.5): directions within 0.25 (chord of unit vectors) are covered, at any scale
    (near flat the branches are cones); farther ones, and every drive after a restart that
    was taken, not closed, nearer, or from a drive within SVD_BELOW of flat, are not."""
    st = _state()
    i = np.array([0])
    y, xn, xb = np.array([[0.1, 0.0]]), np.array([[0.1, 0.0]]), np.array([[0.1, 0.05]])
    st.restarted(i, y, xn, xb, np.array([True]))
    assert st.margin[0] == pytest.approx(0.5) and np.array_equal(st.aside[0], [1.0, 0.0])
    half = 0.5 * loop_state.RESTART_SKIP * 0.5
    for scale in (0.05, 1.0, 3.0):
        for angle, inside in ((0.9 * half, True), (1.1 * half, False)):
            t = 2.0 * np.arcsin(angle / 2.0)  # the direction at chord ``angle`` from (1, 0)
            drive = scale * np.array([[np.cos(t), np.sin(t)]])
            assert st.needless(i, drive).tolist() == [inside], (scale, angle)
    assert st.needless(i, np.zeros((1, 2))).tolist() == [False]  # no direction: run
    for args in ((y, xn, xb, np.array([False])),  # taken (or not closed, not converged)
                 (y, xb, xn, np.array([True])),  # the restart nearer: no margin
                 (0.5 * SVD_BELOW * y / 0.1, xn, xb, np.array([True]))):  # a drive too near flat
        st.restarted(i, *args)
        assert st.margin[0] == 0.0 and st.needless(i, y).tolist() == [False]


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


def _same(a, b):
    assert np.array_equal(a.angles, b.angles) and np.array_equal(a.closure, b.closure)
    assert np.array_equal(a.locked_at, b.locked_at, equal_nan=True) and np.array_equal(a.dof, b.dof)


def test_a_skipped_restart_is_one_that_would_not_be_taken(monkeypatch):
    """miura_3x3's check drives: with RESTART_SKIP, against running every restart (0): the
    restarts not run are all ones that, run, are not taken, all from drives beyond SVD_BELOW;
    every restart taken still runs; the same answers bit for bit in fewer evaluations."""
    d, grid, drivens = _check_drives("miura_3x3", 4)
    evaluate, driven = _solvers(d)[0].residuals, np.stack(drivens)
    seen = _chosen(monkeypatch)
    skip = loop_tracking.track(evaluate, grid, driven)
    ran = dict(seen)
    seen.clear()
    monkeypatch.setattr(loop_state, "RESTART_SKIP", 0.0)
    every = loop_tracking.track(evaluate, grid, driven)
    skipped = set(seen) - set(ran)
    assert len(skipped) >= 20 and set(ran) <= set(seen)
    assert not any(seen[y] for y in skipped)
    assert min(np.abs(np.frombuffer(y)).max() for y in skipped) >= SVD_BELOW
    _same(skip, every)
    assert skip.evaluations < 0.95 * every.evaluations


def test_a_restart_that_switches_branch_is_still_taken(monkeypatch):
    """cross_lock_uniform's check sample 41 switches branch through a restart at a drive of
    0.061 rad, 1.56 times the margin of an earlier restart from it: run and taken, the same
    answers as running every restart; with the margin doubled (beyond its bound) it is
    skipped and the drive ends on the other branch."""
    d, grid, drivens = _check_drives("cross_lock_uniform", 42)
    evaluate, driven = _solvers(d)[0].residuals, np.stack(drivens[41:])
    seen = _chosen(monkeypatch)
    tracks, rule = {}, loop_state.RESTART_SKIP
    for skip in (rule, 0.0, 2.0):
        seen.clear()
        monkeypatch.setattr(loop_state, "RESTART_SKIP", skip)
        tracks[skip] = loop_tracking.track(evaluate, grid, driven)
        switched = [np.abs(np.frombuffer(y)).max() for y, taken in seen.items() if taken]
        assert (max(switched) > 0.05) == (skip < 2.0), skip
    _same(tracks[rule], tracks[0.0])
    assert np.abs(tracks[2.0].angles[0, -1] - tracks[0.0].angles[0, -1]).max() > 1.0  # the other branch
