"""The Monte-Carlo of many designs, and the work that follows each, in one process pool.

``foldprint check`` runs one design's samples at 1x and at each sweep scale; the gallery
runs that check for every template. Run one design at a time, each run (and each sweep
scale) starts its own pool and ends on its slowest chunk while the other cores idle.
:func:`run_batch` instead schedules every chunk of every design and scale as one task
in one pool, the costliest first (a loop pattern's sample costs tens of strip samples),
and hands each design's outcomes, as soon as its last chunk is in, to a follow-up task
in the same pool (the gallery's per-design build, which then runs
:func:`foldprint.simulation.robust.jam_probability` on the :class:`Precomputed` outcomes
instead of folding again). Independent tasks (the material chart) go in the same pool.

The samples are the ones ``jam_probability`` draws (:func:`iter_samples`, same seed, in
chunks of :data:`~foldprint.simulation.robust.CHUNK`), folded by the same
:func:`~foldprint.simulation.robust.run_samples`; only where and in what order they are
folded changes, so the outcomes are the same. Workers receive the jobs once, at start
(inherited on fork); a task names (job, scale, chunk), so a design's FCL geometry is
built once per worker (:func:`foldprint.collision.swept3d.checker_for`), not per chunk.
The first chunk of each job and scale is timed in its worker and the run is refused
(:func:`foldprint.core.guards.check_samples`) as ``jam_probability`` would refuse it.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from itertools import islice
from typing import Callable, Sequence

from ..core import guards
from ..core.constants import DEFAULT_DT_S
from ..core.modes import DEFAULT_HINGE_MODEL, VERDICT_METHOD, HingeModel, Method, parse
from ..model.design import Design, has_loops
from ..model.materials import MaterialLibrary, default_library
from .robust import CHUNK, Outcome, n_chunks, run_samples
from .scatter import Scatter, default_scatter, iter_samples


@dataclass(frozen=True)
class MonteCarloJob:
    """One design's Monte-Carlo: ``samples`` samples of ``seed`` under ``scatter`` times
    each of ``scales`` (1.0 is the estimate itself)."""

    design: Design
    samples: int
    seed: int
    scales: tuple[float, ...] = (1.0,)
    scatter: Scatter | None = None
    hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL
    dt: float = DEFAULT_DT_S
    method: Method = VERDICT_METHOD

    def __post_init__(self):
        object.__setattr__(self, "hinge_model", parse(HingeModel, self.hinge_model, "hinge_model"))
        object.__setattr__(self, "method", parse(Method, self.method, "method"))

    def scatter_at(self, k: float) -> Scatter:
        sc = self.scatter or default_scatter()
        return sc if k == 1.0 else sc.scaled(k)


@dataclass(frozen=True)
class Precomputed:
    """A design's folded outcomes per scatter model, to hand to ``jam_probability`` as its
    ``mapper``: it then returns these instead of folding (same design name, samples, seed,
    hinge model, time step, collision method and scatter, else it folds as usual)."""

    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    dt: float
    outcomes: tuple[tuple[Scatter, tuple[Outcome, ...]], ...]
    method: Method = VERDICT_METHOD

    def lookup(self, design: Design, scatter: Scatter, samples: int, seed: int, hinge_model: HingeModel,
               dt: float, method: Method = VERDICT_METHOD) -> tuple[Outcome, ...] | None:
        if (design.name, samples, seed, hinge_model, dt, method) != (
                self.design, self.samples, self.seed, self.hinge_model, self.dt, self.method):
            return None
        return next((o for sc, o in self.outcomes if sc == scatter), None)

    def __call__(self, fn, items, progress=None):  # a plain mapper for whatever was not precomputed
        out = []
        for k, x in enumerate(items):
            out.append(fn(x))
            if progress:
                progress(k + 1, len(items))
        return out


_STATE: dict = {}


def _init(jobs, library) -> None:
    from ..core.parallel import limit_blas_threads

    limit_blas_threads(1)
    _STATE["jobs"], _STATE["library"] = jobs, library


def _chunk_task(j: int, k: float, c: int) -> tuple[list[Outcome], float]:
    """Fold chunk ``c`` of job ``j`` at scale ``k`` (in a worker); its outcomes and the
    seconds per sample it took."""
    job: MonteCarloJob = _STATE["jobs"][j]
    stream = iter_samples(job.design, job.scatter_at(k), job.samples, job.seed)
    samples = list(islice(stream, c * CHUNK, (c + 1) * CHUNK))
    t0 = time.perf_counter()  # wall, as jam_probability times its first chunk
    out = run_samples((job.design, _STATE["library"], samples, job.hinge_model, job.dt, False, job.method))
    return out, (time.perf_counter() - t0) / max(1, len(samples))


def _cost(design: Design) -> float:
    """Relative cost of one sample, for the order only (costliest first): the hinges,
    times 50 for a pattern with loops (its fold tracks the closure at every step;
    measured: miura_3x3's sample about 50x a helix strip's)."""
    return len(design.hinges) * (50.0 if has_loops(design) else 1.0)


def run_batch(jobs: Sequence[MonteCarloJob], *, library: MaterialLibrary | None = None, workers: int = 1,
              after: Callable[[int, Precomputed], tuple] | None = None, tasks: Sequence[tuple] = (),
              progress: Callable[[str, int, object], None] | None = None) -> tuple[list[Precomputed], list, list]:
    """Fold every chunk of every job and scale in one pool of ``workers`` processes.

    ``after(i, pre)`` -> ``(fn, args)``: a task run in the same pool once job ``i``'s
    outcomes are all in (``pre`` its :class:`Precomputed`); ``tasks``: ``(fn, args)``
    run in the pool beside them. ``progress(kind, i, out)`` is called as a follow-up
    ("after") or independent task ("task") ``i`` finishes with its result ``out``. Returns the Precomputed per
    job, the follow-ups' results and the tasks' results (in input order)."""
    batch = _Batch(list(jobs), library or default_library(), workers, after, list(tasks), progress)
    if workers <= 1:
        batch.run_here()
    else:
        batch.run_pool()
    return batch.pre, batch.after_out, batch.task_out


class _Batch:
    """The state of one :func:`run_batch`: the chunks still to fold, their outcomes, the
    follow-ups' and tasks' results."""

    def __init__(self, jobs: list[MonteCarloJob], lib: MaterialLibrary, workers: int, after, tasks: list,
                 progress):
        for job in jobs:
            guards.check_sample_memory(job.design, job.samples)
        self.jobs, self.lib, self.workers, self.after, self.tasks = jobs, lib, workers, after, tasks
        self.progress = progress
        chunks = [(j, float(k), c) for j, job in enumerate(jobs) if job.samples for k in job.scales
                  for c in range(n_chunks(job.samples))]
        chunks.sort(key=lambda t: -_cost(jobs[t[0]].design))  # stable: job, scale, chunk order kept
        self.chunks = chunks
        self.results: dict[tuple[int, float, int], list[Outcome]] = {}
        self.left = {j: sum(1 for t in chunks if t[0] == j) for j in range(len(jobs))}
        self.timed: set = set()
        self.pre: list[Precomputed | None] = [None] * len(jobs)
        self.after_out: list = [None] * len(jobs)
        self.task_out: list = [None] * len(tasks)

    def precomputed(self, j: int) -> Precomputed:
        job = self.jobs[j]
        n = n_chunks(job.samples)
        outs = tuple((job.scatter_at(float(k)),
                      tuple(o for c in range(n) for o in self.results.get((j, float(k), c), ())))
                     for k in job.scales) if job.samples else ()
        return Precomputed(job.design.name, job.samples, job.seed, job.hinge_model, job.dt, outs, job.method)

    def chunk_done(self, key: tuple[int, float, int], out: list[Outcome], per_sample: float) -> bool:
        """Record a folded chunk (the first of each job and scale times the run, refused
        as jam_probability would refuse it); True when it was the job's last."""
        j, k, _ = key
        if (j, k) not in self.timed:
            self.timed.add((j, k))
            if n_chunks(self.jobs[j].samples) > 1:
                guards.check_samples(self.jobs[j].samples, per_sample, self.workers, self.jobs[j].design.name)
        self.results[key] = out
        self.left[j] -= 1
        return self.left[j] == 0

    def report(self, kind: str, i: int) -> None:
        if self.progress:
            self.progress(kind, i, self.after_out[i] if kind == "after" else self.task_out[i])

    def run_here(self) -> None:
        _init(self.jobs, self.lib)
        try:
            for t in self.chunks:
                self.chunk_done(t, *_chunk_task(*t))
        finally:
            _STATE.clear()
        for j in range(len(self.jobs)):
            self.pre[j] = self.precomputed(j)
            if self.after is not None:
                fn, args = self.after(j, self.pre[j])
                self.after_out[j] = fn(*args)
                self.report("after", j)
        for i, (fn, args) in enumerate(self.tasks):
            self.task_out[i] = fn(*args)
            self.report("task", i)

    def run_pool(self) -> None:
        import multiprocessing as mp
        import sys
        from concurrent.futures import ProcessPoolExecutor

        ctx = mp.get_context("fork") if sys.platform.startswith("linux") else None
        with ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx, initializer=_init,
                                 initargs=(self.jobs, self.lib)) as pool:
            pending: dict = {}
            for i, (fn, args) in enumerate(self.tasks):  # short, independent: first, off the critical path
                pending[pool.submit(fn, *args)] = ("task", i)
            for t in self.chunks:
                pending[pool.submit(_chunk_task, *t)] = ("chunk", t)
            for j in range(len(self.jobs)):
                if self.left[j] == 0:
                    self.finish(pool, pending, j)
            try:
                self.drain(pool, pending)
            except BaseException:
                pool.shutdown(wait=True, cancel_futures=True)
                raise

    def finish(self, pool, pending: dict, j: int) -> None:
        self.pre[j] = self.precomputed(j)
        if self.after is not None:
            fn, args = self.after(j, self.pre[j])
            pending[pool.submit(fn, *args)] = ("after", j)

    def drain(self, pool, pending: dict) -> None:
        from concurrent.futures import FIRST_COMPLETED, wait

        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                kind, key = pending.pop(fut)
                if kind == "chunk":
                    if self.chunk_done(key, *fut.result()):
                        self.finish(pool, pending, key[0])
                elif kind == "after":
                    self.after_out[key] = fut.result()
                    self.report("after", key)
                else:
                    self.task_out[key] = fut.result()
                    self.report("task", key)
