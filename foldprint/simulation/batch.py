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
from ..core.modes import DEFAULT_HINGE_MODEL, HingeModel, parse
from ..model.design import Design, has_loops
from ..model.materials import MaterialLibrary, default_library
from .robust import CHUNK, Outcome, run_samples
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
    dt: float = 0.01

    def scatter_at(self, k: float) -> Scatter:
        sc = self.scatter or default_scatter()
        return sc if k == 1.0 else sc.scaled(k)


@dataclass(frozen=True)
class Precomputed:
    """A design's folded outcomes per scatter model, to hand to ``jam_probability`` as its
    ``mapper``: it then returns these instead of folding (same design name, samples, seed,
    hinge model, time step and scatter, else it folds as usual)."""

    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    dt: float
    outcomes: tuple[tuple[Scatter, tuple[Outcome, ...]], ...]

    def lookup(self, design: Design, scatter: Scatter, samples: int, seed: int, hinge_model: HingeModel,
               dt: float) -> tuple[Outcome, ...] | None:
        if (design.name, samples, seed, hinge_model, dt) != (self.design, self.samples, self.seed,
                                                              self.hinge_model, self.dt):
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
    out = run_samples((job.design, _STATE["library"], samples, parse(HingeModel, job.hinge_model, "hinge_model"),
                       job.dt))
    return out, (time.perf_counter() - t0) / max(1, len(samples))


def _cost(design: Design) -> float:
    """Relative cost of one sample, for the order only (costliest first): the hinges,
    times 50 for a pattern with loops (its fold tracks the closure at every step;
    measured: miura_3x3's sample about 50x a helix strip's)."""
    return len(design.hinges) * (50.0 if has_loops(design) else 1.0)


def run_batch(jobs: Sequence[MonteCarloJob], *, library: MaterialLibrary | None = None, workers: int = 1,
              after: Callable[[int, Precomputed], tuple] | None = None, tasks: Sequence[tuple] = (),
              progress: Callable[[str, int], None] | None = None) -> tuple[list[Precomputed], list, list]:
    """Fold every chunk of every job and scale in one pool of ``workers`` processes.

    ``after(i, pre)`` -> ``(fn, args)``: a task run in the same pool once job ``i``'s
    outcomes are all in (``pre`` its :class:`Precomputed`); ``tasks``: ``(fn, args)``
    run in the pool beside them. ``progress(kind, i)`` is called as a follow-up
    ("after") or independent task ("task") ``i`` finishes. Returns the Precomputed per
    job, the follow-ups' results and the tasks' results (in input order)."""
    lib = library or default_library()
    jobs = list(jobs)
    for job in jobs:
        guards.check_sample_memory(job.design, job.samples)
    chunks = [(j, float(k), c) for j, job in enumerate(jobs) if job.samples for k in job.scales
              for c in range(-(-job.samples // CHUNK))]
    chunks.sort(key=lambda t: -_cost(jobs[t[0]].design))  # stable: job, scale, chunk order kept
    results: dict[tuple[int, float, int], list[Outcome]] = {}
    left = {j: sum(1 for t in chunks if t[0] == j) for j in range(len(jobs))}
    timed: set = set()
    pre: list[Precomputed | None] = [None] * len(jobs)
    after_out: list = [None] * len(jobs)
    task_out: list = [None] * len(tasks)

    def precomputed(j: int) -> Precomputed:
        job = jobs[j]
        model = parse(HingeModel, job.hinge_model, "hinge_model")
        n = -(-job.samples // CHUNK)
        outs = tuple((job.scatter_at(float(k)),
                      tuple(o for c in range(n) for o in results.get((j, float(k), c), ())))
                     for k in job.scales) if job.samples else ()
        return Precomputed(job.design.name, job.samples, job.seed, model, job.dt, outs)

    def check_time(j: int, k: float, per_sample: float) -> None:
        if (j, k) not in timed:
            timed.add((j, k))
            if -(-jobs[j].samples // CHUNK) > 1:
                guards.check_samples(jobs[j].samples, per_sample, workers, jobs[j].design.name)

    if workers <= 1:
        _init(jobs, lib)
        try:
            for t in chunks:
                out, per = _chunk_task(*t)
                check_time(t[0], t[1], per)
                results[t] = out
        finally:
            _STATE.clear()
        for j in range(len(jobs)):
            pre[j] = precomputed(j)
            if after is not None:
                fn, args = after(j, pre[j])
                after_out[j] = fn(*args)
                if progress:
                    progress("after", j)
        for i, (fn, args) in enumerate(tasks):
            task_out[i] = fn(*args)
            if progress:
                progress("task", i)
        return pre, after_out, task_out

    import multiprocessing as mp
    import sys
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    ctx = mp.get_context("fork") if sys.platform.startswith("linux") else None
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init,
                             initargs=(jobs, lib)) as pool:
        pending: dict = {}
        for i, (fn, args) in enumerate(tasks):  # short, independent: first, off the critical path
            pending[pool.submit(fn, *args)] = ("task", i)
        for t in chunks:
            pending[pool.submit(_chunk_task, *t)] = ("chunk", t)

        def finish(j: int) -> None:
            pre[j] = precomputed(j)
            if after is not None:
                fn, args = after(j, pre[j])
                pending[pool.submit(fn, *args)] = ("after", j)

        for j in range(len(jobs)):
            if left[j] == 0:
                finish(j)
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    kind, key = pending.pop(fut)
                    if kind == "chunk":
                        out, per = fut.result()
                        check_time(key[0], key[1], per)
                        results[key] = out
                        left[key[0]] -= 1
                        if left[key[0]] == 0:
                            finish(key[0])
                    elif kind == "after":
                        after_out[key] = fut.result()
                        if progress:
                            progress("after", key)
                    else:
                        task_out[key] = fut.result()
                        if progress:
                            progress("task", key)
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
    return pre, after_out, task_out
