"""assign's evaluations in batches (foldprint.apps.assign.tasks): a batch shares its
design's derived data and its draws' curves, and its verdicts are the ones each task gets
alone by the path that made one Evaluation and one whole-run drive per task; the timing
proxy's short curves give the whole horizon's times."""

import math
from dataclasses import replace

import numpy as np
import pytest

import foldprint.apps.assign.tasks as T
from foldprint.core.constants import DEFAULT_DT_S
from foldprint.core.modes import Method
from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.robust import default_scatter, draw_samples, run_end, sample_drive


@pytest.fixture(scope="module")
def helix():
    return load_design(resolve_design_path("helix_uniform"))


def _alone(task: T.Task) -> T.Verdict:
    """A task's verdict as one task was folded before batches: its own Evaluation (its own
    derived data) and, for a draw, its own curves over the whole run."""
    if task.sample is None:
        drive = T._nominal_drive(task)
    else:
        variant = T.with_materials(task.design, task.materials, task.bath_c, task.library)
        drive = sample_drive(variant, task.library, task.sample,
                             until_s=run_end(task.design, task.dt, task.duration))
    return T._fold(task, drive, None)


def _tasks(design, lib):
    """Screens of partial and complete assignments (one with a prefix's clearance), a 3D
    fold, and draws of two assignments, one of them slow enough that some draws need the
    whole run's curves."""
    n = len(design.hinges)
    dur = float(design.process.duration_s)
    fast, slow = ("H-1",) * n, ("H-2",) * (n - 2) + ("H-7", "H-7")
    half = ("H-1",) * 4 + (None,) * (n - 4)
    out = [T.Task(design, lib, half, 90.0, Method.INDEX2D, DEFAULT_DT_S, 4.0, 24),
           T.Task(design, lib, fast, 90.0, Method.INDEX2D, DEFAULT_DT_S, 5.0, 0),
           T.Task(design, lib, slow, 90.0, Method.INDEX2D, DEFAULT_DT_S, 8.0, 0),
           T.Task(design, lib, ("H-7",) + fast[1:], 90.0, Method.FCL, DEFAULT_DT_S, dur, 0)]
    sc = default_scatter()
    for mt in (slow, fast):
        for smp in draw_samples(T.with_materials(design, mt, 90.0, lib), sc, 12, 1):
            out.append(T.Task(design, lib, mt, 90.0, Method.INDEX2D, DEFAULT_DT_S, dur, 0, smp))
    return out


def test_a_batch_gives_each_task_its_own_verdict(helix, monkeypatch):
    lib = default_library()
    tasks = _tasks(helix, lib)
    passes = []
    upto = T._curves_upto
    monkeypatch.setattr(T, "_curves_upto", lambda v, lb, s, u: passes.append((len(s), u)) or upto(v, lb, s, u))
    batch = T.run_tasks(tasks)
    alone = [_alone(t) for t in tasks]
    assert batch == alone
    # both kinds of outcome are in there, and the draws did take the short horizon first
    assert any(v.completed for v in batch) and not all(v.completed for v in batch)
    full = run_end(helix, DEFAULT_DT_S, float(helix.process.duration_s))
    assert any(u < full for _n, u in passes)
    # a draw the short curves do not cover got the whole run's
    assert any(u == full and n < 12 for n, u in passes), passes


def test_map_tasks_batches_in_order_and_keeps_groups_whole(helix):
    lib = default_library()
    tasks = _tasks(helix, lib)[4:]  # the draws: two groups of 12

    class Mapper:
        workers = 2

        def __init__(self):
            self.sizes = []

        def __call__(self, fn, items, progress=None):
            self.sizes = [len(b) for b in items]
            out = [fn(b) for b in items]
            if progress:
                progress(len(items), len(items))
            return out

    m = Mapper()
    seen = []
    got = T.map_tasks(m, tasks, lambda done, total: seen.append((done, total)), group=3)
    assert got == T.run_tasks(tasks)
    assert sum(m.sizes) == len(tasks) and all(s % 3 == 0 and s <= T.BATCH_MAX for s in m.sizes), m.sizes
    assert seen[-1] == (len(tasks), len(tasks))
    # without a group: at least BATCHES_PER_WORKER batches a worker when the tasks allow
    T.map_tasks(m, tasks)
    assert len(m.sizes) == min(len(tasks), T.BATCHES_PER_WORKER * m.workers)


def _log_times_whole(material, bath_c, thickness, fix_c):
    c = recovery_curve(material, bath_c, thickness, fix_c)  # the whole horizon
    return np.array([math.log(x) if x else math.inf for x in (c.time_to(0.5), c.time_to(0.98))])


@pytest.mark.parametrize("name,bath_c,thickness", [("H-1", 90.0, 0.8), ("H-7", 75.0, 0.82), ("H-7", 66.0, 0.8), ("H-7", 62.0, 0.8)])
def test_order_risk_times_are_the_whole_horizons(name, bath_c, thickness):
    """The proxy's curves made up to FIRST_HORIZON_S first: the same ln t50 and ln t98,
    bit for bit, also where 98 % comes after that horizon (the cold bath) and the whole
    horizon's curve is made."""
    from foldprint.simulation.timing import FIRST_HORIZON_S, _log_times

    m = default_library()[name]
    got = _log_times(m, bath_c, thickness, 10.0)
    want = _log_times_whole(m, bath_c, thickness, 10.0)
    assert np.array_equal(got, want)
    warmer = replace(m, tg_c=m.tg_c + 0.5)
    assert np.array_equal(_log_times(warmer, bath_c, thickness, 10.0), _log_times_whole(warmer, bath_c, thickness, 10.0))
    if name == "H-7" and bath_c < 70:
        assert math.exp(want[1]) > FIRST_HORIZON_S  # the case the fallback is for
