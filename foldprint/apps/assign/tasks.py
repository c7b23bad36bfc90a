"""One evaluation of :func:`foldprint.apps.assign.search.assign`'s search: a picklable
:class:`Task` (a partial or complete assignment, optionally a scatter draw), the
module-level :func:`run_tasks` that folds a batch of them, each through an
:class:`~foldprint.apps.pipeline.Evaluation` (sharing the design's derived data and the
draws' curves, ``docs/assign.md``, "What an evaluation costs"), :func:`map_tasks` that
hands the batches to a mapper, and the mappers (local processes by default, a Dask
cluster with :mod:`foldprint.apps.distributed`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from ...core.constants import CLEARANCE_SAMPLES
from ...core.modes import HingeModel, Method
from ...model.design import Design
from ...model.materials import MaterialLibrary
from ...physics.hinge_drive import HingeDrive
from ...physics.recovery.curve import recovery_curve
from ...model.derived import DerivedCache, current, design_scope
from ...simulation.robust import (CHUNK, Sample, Scatter, curves_at_once, draw_samples, run_end, run_samples,
                                  sample_drives, wilson)
from .result import Choice, Verdict

#: Screening runs stop this long after the slowest active hinge reaches 98 % (s).
SCREEN_TAIL_S = 0.5
#: A screening draw's curves are made first up to this many times the nominal slowest
#: fold of its assignment (+ SCREEN_TAIL_S); a draw slower than that gets the whole run's
#: (the same curves and folds: only the cost depends on it). Our choice: on the robust helix
#: search 15 of each candidate's 16 draws fold within 1.5x nominal (seed 1's slowest draw
#: takes 1.6x and is redone), 0.57 of the curve points made before.
SAMPLE_HORIZON_FACTOR = 1.5


@dataclass(frozen=True)
class Task:
    """One simulation: ``materials`` per hinge (None = held in its programmed shape)."""

    design: Design
    library: MaterialLibrary
    materials: tuple[str | None, ...]
    bath_c: float
    method: Method
    dt: float
    duration: float | None
    clearance_samples: int
    #: a scatter draw (``robust`` screen): the hinges' materials, thicknesses and bath as
    #: drawn; the run stops SCREEN_TAIL_S after the slowest drawn hinge reaches 98 %
    sample: Sample | None = None


def with_materials(design: Design, materials: Sequence[str], bath_c: float | None = None,
                   library: MaterialLibrary | None = None) -> Design:
    """``design`` with hinge ``k`` made of ``materials[k]`` (and the bath at ``bath_c``),
    validated against ``library``."""
    hinges = tuple(replace(h, material=m) for h, m in zip(design.hinges, materials))
    proc = design.process if bath_c is None else replace(design.process, bath_temperature_c=float(bath_c))
    return design.replace(library, hinges=hinges, process=proc)


def _nominal_drive(task: Task) -> HingeDrive:
    """The drive of a task without a scatter draw: each active hinge's cached nominal
    curve (:func:`recovery_curve` keeps one per material, bath and thickness, so the
    candidates that share a hinge's material share its curve), a held hinge's at zero."""
    d = task.design
    curves = []
    for h, m in zip(d.hinges, task.materials):
        c = recovery_curve(task.library[m or h.material], task.bath_c, h.thickness, d.process.fix_temperature_c)
        curves.append(c if m is not None else replace(c, ratio=np.zeros_like(c.ratio)))
    return HingeDrive(d, task.bath_c, task.library, curves=curves)


def _drives(tasks: Sequence[Task]) -> list[HingeDrive]:
    """Every task's drive. The scatter draws of one assignment (materials, bath, step and
    run) get their curves together (:func:`_draw_drives`) and share the variant design."""
    out: list[HingeDrive | None] = [None] * len(tasks)
    groups: dict[tuple, list[int]] = {}
    for i, t in enumerate(tasks):
        if t.sample is None:
            out[i] = _nominal_drive(t)
        else:
            groups.setdefault((id(t.design), t.materials, t.bath_c, t.dt, t.duration), []).append(i)
    for idx in groups.values():
        for i, drv in zip(idx, _draw_drives(tasks[idx[0]], [tasks[i].sample for i in idx])):
            out[i] = drv
    return out  # type: ignore[return-value]


def _draw_drives(task: Task, samples: list[Sample]) -> list[HingeDrive]:
    """The drives of the scatter draws ``samples`` of ``task``'s assignment, in array
    passes of :func:`sample_drives` (each curve equal, bit for bit, to its draw's own
    pass, and on a shorter grid to the first points of the longer one). A screening fold
    of a draw stops SCREEN_TAIL_S after its slowest hinge reaches 98 %, so the curves are
    first made up to SAMPLE_HORIZON_FACTOR times the nominal slowest fold (+ the tail);
    a draw that does not reach 98 % everywhere by then, or whose run would outlast its
    curves, gets them up to the whole run, as before: the same folds, fewer curve points."""
    d, lib = task.design, task.library
    variant = with_materials(d, task.materials, task.bath_c, lib)
    full = run_end(d, task.dt, task.duration)
    nominal = [recovery_curve(lib[m], task.bath_c, h.thickness, d.process.fix_temperature_c).fold_time
               for h, m in zip(d.hinges, task.materials)]
    first = full if None in nominal else min(full, SAMPLE_HORIZON_FACTOR * max(nominal) + SCREEN_TAIL_S)
    out = _curves_upto(variant, lib, samples, first)
    if first < full:
        redo = [j for j, drv in enumerate(out) if not _covers(drv, task)]
        for j, drv in zip(redo, _curves_upto(variant, lib, [samples[j] for j in redo], full)):
            out[j] = drv
    return out


def _curves_upto(variant: Design, lib: MaterialLibrary, samples: list[Sample], until: float) -> list[HingeDrive]:
    """:func:`sample_drives` up to ``until``, as many draws a pass as the memory bound allows."""
    per = curves_at_once(variant, until, max(1, len(samples)))[0]
    return [drv for a in range(0, len(samples), per) for drv in sample_drives(variant, lib, samples[a:a + per],
                                                                              until_s=until)]


def _covers(drive: HingeDrive, task: Task) -> bool:
    """Whether ``drive``'s curves hold every hinge's 98 % and the whole screening run of its draw."""
    times = [c.fold_time for c in drive.curves]
    if None in times or not drive.curves:
        return False
    return run_end(task.design, task.dt, _screen_end(task, times)) <= drive.curves[0].t[-1]


def _screen_end(task: Task, times: Sequence[float | None]) -> float | None:
    """How long a draw's screening fold runs: SCREEN_TAIL_S after its slowest hinge reaches 98 %."""
    if all(x is not None for x in times):
        return min(task.duration or task.design.process.duration_s, max(times) + SCREEN_TAIL_S)
    return task.duration


def run_task(task: Task) -> Verdict:
    """Fold one (partial) assignment; a module-level function so processes and Dask
    workers can run it (:func:`run_tasks` of one task)."""
    return run_tasks([task])[0]


def run_tasks(tasks: Sequence[Task]) -> list[Verdict]:
    """Fold a batch of tasks (a module-level function for the mappers), in order. The
    tasks of one design share its derived data (hinge frames, reliefs, rigid polygons and
    the side view: geometry, which no material changes), kept per process and design
    content (:func:`~foldprint.model.derived.design_scope`), and the scatter draws of one
    assignment share their curves' pass (:func:`_drives`); each verdict is the one the
    task gets alone."""
    tasks = list(tasks)
    if not tasks:
        return []
    first = tasks[0].design
    with design_scope(first) as kept:
        cache = current()
        tasks = [replace(t, design=kept) if t.design is first else t for t in tasks]
        return [_fold(t, drv, cache if t.design is kept else None) for t, drv in zip(tasks, _drives(tasks))]


def _fold(task: Task, drive: HingeDrive, cache: DerivedCache | None) -> Verdict:
    """One task's verdict: its simulation (and clearance) through an
    :class:`~foldprint.apps.pipeline.Evaluation` whose derived data is ``cache`` (when given)."""
    d = task.design
    duration = task.duration
    if task.sample is not None:
        duration = _screen_end(task, [c.fold_time for c in drive.curves])
    from ..pipeline import EvalOptions, Evaluation

    opts = EvalOptions(hinge_model=HingeModel.ARC, method=task.method, dt=task.dt, bath_c=task.bath_c,
                       duration=duration, samples=0, clearance_samples=task.clearance_samples or CLEARANCE_SAMPLES)
    ev = Evaluation(d, opts, library=task.library, drive=drive)
    if cache is not None:
        ev.cache = cache
    res = ev.simulation
    c = res.first_collision
    partial = any(m is None for m in task.materials)
    goal = None
    if c is None and not partial:
        goal = next((g.goal.id for g in res.goals if not g.met), None)
    clearance = None
    if task.clearance_samples and c is None:  # the clearance along the whole fold (no contact)
        g = ev.clearance
        clearance = math.inf if g is None else float(g.distance)
    done = (c is None) and (partial or res.completed)
    ft = None
    if not partial:
        ft = res.fold_time
    return Verdict(bool(done), None if c is None else tuple(c.panels), None if c is None else float(c.time),
                   goal, ft, clearance, str(task.method))


Mapper = Callable[[Callable, list, Callable | None], list]


def local_mapper(workers: int | None = None) -> Mapper:
    """Run on ``workers`` local processes (default: all cores), a pool per call."""
    from ...core.parallel import map_ordered

    def mapper(fn, items, progress=None):
        return map_ordered(fn, items, workers=workers, progress=progress)

    return mapper


#: Tasks a batch of :func:`map_tasks` holds at most: a batch pays one message to a worker
#: and shares its design's derived data and its draws' curves; our choice, a dozen
#: screening folds (about 0.1 CPU-s) per message.
BATCH_MAX = 16
#: Batches per worker at least, so that the last ones still spread over the workers (our choice).
BATCHES_PER_WORKER = 3
#: Workers assumed of a mapper that does not say (a Dask cluster's): our choice.
WORKERS_UNKNOWN = 4


def map_tasks(mapper: Mapper, tasks: Sequence[Task], progress: Callable[[int, int], None] | None = None,
              group: int = 1) -> list[Verdict]:
    """The verdicts of ``tasks`` in order, run by ``mapper`` in batches of consecutive
    tasks (:func:`run_tasks`): at most BATCH_MAX, at least BATCHES_PER_WORKER batches per
    worker (``mapper.workers``, else WORKERS_UNKNOWN), a multiple of ``group`` tasks (the
    draws of one assignment) when that fits. ``progress(tasks done, tasks)``. The answer
    does not depend on the batches."""
    tasks = list(tasks)
    if not tasks:
        return []
    workers = getattr(mapper, "workers", None) or WORKERS_UNKNOWN
    size = max(1, min(BATCH_MAX, -(-len(tasks) // (BATCHES_PER_WORKER * workers))))
    if group > 1:
        size = max(1, size // group) * group if size >= group else size
    batches = [tasks[a:a + size] for a in range(0, len(tasks), size)]
    cb = None
    if progress is not None:
        cb = lambda done, _n: progress(min(len(tasks), done * size), len(tasks))  # noqa: E731
    return [v for part in mapper(run_tasks, batches, cb) for v in part]


def _worker_start() -> None:
    from ...core.parallel import die_with_parent, limit_blas_threads

    limit_blas_threads(1)
    die_with_parent()


class LocalPool:
    """A mapper on ``workers`` local processes (default: all cores) that keeps its pool
    from its first map to :meth:`close`: a search maps tens of batches, and a pool per
    batch forked workers that each loaded the compiled kernels (about 0.45 CPU-s) and
    derived each design's data again. Results in the order of the items, at most
    ``2 x workers`` in flight, as :func:`foldprint.core.parallel.map_ordered` (one worker:
    here, in order)."""

    def __init__(self, workers: int | None = None):
        from ...core.parallel import default_workers

        self.workers = default_workers() if workers is None else max(1, int(workers))
        self.pool = None

    def __call__(self, fn, items, progress=None) -> list:
        from concurrent.futures import FIRST_COMPLETED, wait

        from ...core.parallel import map_ordered

        items = list(items)
        if self.workers == 1 or not items:
            return map_ordered(fn, items, workers=1, progress=progress)
        if self.pool is None:
            import multiprocessing as mp
            import sys
            from concurrent.futures import ProcessPoolExecutor

            ctx = mp.get_context("fork") if sys.platform.startswith("linux") else None
            self.pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx, initializer=_worker_start)
        results: dict[int, object] = {}
        pending: dict = {}
        todo = iter(enumerate(items))
        while True:
            while len(pending) < 2 * self.workers and (nxt := next(todo, None)) is not None:
                pending[self.pool.submit(fn, nxt[1])] = nxt[0]
            if not pending:
                return [results[k] for k in range(len(items))]
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                results[pending.pop(fut)] = fut.result()
                if progress:
                    progress(len(results), len(items))

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
            self.pool = None


def warm_workers(mapper: Mapper, tasks: Callable[[], Sequence[Task]]) -> None:
    """Fold ``tasks()`` here and throw the verdicts away, when ``mapper`` is a
    :class:`LocalPool` of several workers that has not forked them yet and the compiled
    kernels are used: its workers then inherit every kernel those folds loaded (numba
    and its cache, about 0.5 CPU-s a worker) instead of each loading them again. Give a
    task of each kind the search runs (a screen, a 3D fold, a scatter draw)."""
    from ...core.errors import FoldprintError
    from ...core.jit import use_kernels

    if isinstance(mapper, LocalPool) and mapper.pool is None and mapper.workers > 1 and use_kernels():
        try:
            run_tasks(tasks())
        except FoldprintError:  # a refusal (a guard's): the search meets it, or not, where it would have
            pass


def with_local_pool(fn):
    """Run a search ``fn(..., mapper=None, workers=None, ...)`` with a :class:`LocalPool` of
    ``workers`` as its mapper when it is given none, closed when it returns."""
    import functools

    @functools.wraps(fn)
    def run(*args, **kwargs):
        if kwargs.get("mapper") is not None:
            return fn(*args, **kwargs)
        pool = LocalPool(kwargs.get("workers"))
        try:
            return fn(*args, **{**kwargs, "mapper": pool})
        finally:
            pool.close()

    return run


def jam_estimates(design: Design, library: MaterialLibrary, scatter: Scatter, choices: Sequence[Choice],
                  samples: int, seed: int, dt: float, mapper) -> list[Choice]:
    """Every choice with its jam probability and Wilson interval: the draws and folds of
    ``foldprint robust --samples N --seed S`` on the design in that choice's materials and
    bath (the same draws for each), the chunks of all of them mapped in one pass so they
    spread over the workers at once. In the order given."""
    chunks, owner = [], []
    for j, c in enumerate(choices):
        variant = with_materials(design, c.materials, c.bath_c, library)
        drawn = draw_samples(variant, scatter, samples, seed)
        for a in range(0, samples, CHUNK):
            chunks.append((variant, library, drawn[a:a + CHUNK], HingeModel.ARC, dt))
            owner.append(j)
    results = mapper(run_samples, chunks, None) if chunks else []
    counts = [0] * len(choices)
    for j, outcomes in zip(owner, results):
        counts[j] += sum(o.jammed for o in outcomes)
    return [replace(c, jam_probability=k / samples, jam_ci95=wilson(k, samples)) for c, k in zip(choices, counts)]
