"""The Monte-Carlo of many designs, and the work that follows each, in one adaptive process pool.

``foldprint check`` runs one design's jam test at 1x and at each sweep scale; the gallery
runs that check for every template. :func:`run_batch` folds every (design, scale)
*stream* of samples in one pool: chunks are submitted as workers free up, a stream with
nothing in flight first (the costliest design first: a loop pattern's sample costs tens
of strip samples), then the follow-up work of a design whose streams are all decided
(the gallery's per-design build, which then answers its check from the
:class:`Precomputed` outcomes instead of folding again), and only when every open stream
already has a chunk in flight a second chunk of one (it may be discarded; not past where
a clean run of the samples in flight would stop its test). A stream
with a sequential test (:class:`~foldprint.simulation.jamtest.verdict.JamTest`) stops being fed
once its test decides; the chunks folded beyond the stop are discarded. Its chunks are
sized to the test: never more than the samples after which an unbroken run of clean (or
of jammed) samples would stop it (:func:`~foldprint.simulation.jamtest.streams.to_decision`; at least
:data:`~foldprint.simulation.jamtest.streams.MIN_CHUNK`, at most
:data:`~foldprint.simulation.robust.CHUNK`), so a clear strip's stream folds the samples
its test uses and no more (a loop pattern's chunks are cut only where a clean run would
stop it, at least :data:`~foldprint.simulation.jamtest.streams.LOOP_MIN_CHUNK`: its closure
tracking is cheaper a sample in bigger ones).

The samples are the ones :func:`~foldprint.simulation.robust.jam_probability` draws
(:func:`~foldprint.simulation.scatter.iter_samples`, same seed; a chunk draws its own with
:func:`~foldprint.simulation.scatter.samples_between`),
folded by the same :func:`~foldprint.simulation.robust.run_samples`, and each stream
consumes its chunks **in stream order, one sample at a time**: the outcomes kept and the
stopping index depend on the seed alone, never on the number of workers, on which chunk
came back first or on how many were folded past the stop. Workers receive the jobs once,
at start (inherited on fork); a task names (job, scale, first sample, size), so a design's FCL
geometry is built once per worker. The first chunk of each stream is timed in its worker
and the run is refused (:func:`foldprint.simulation.costs.check_samples`, on the maximum
sample count) as ``jam_probability`` would refuse it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Mapping, Sequence

from .. import costs
from ...core.constants import DEFAULT_DT_S
from ...core.jit import work_cpu_s
from ...core.modes import DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, VERDICT_METHOD, HingeModel, Mechanics, Method, parse
from ...model.design import Design, has_loops
from ...model.materials import MaterialLibrary, default_library
from ..robust import CHUNK, Outcome, n_chunks, run_samples
from ..scatter import Scatter, default_scatter, samples_between
from .streams import MIN_CHUNK, Stream, StreamStatus, sample_cost, to_decision  # noqa: F401 (re-exported)
from .verdict import JamTest
from .warmup import cold_groups, warm_group


@dataclass(frozen=True)
class MonteCarloJob:
    """One design's Monte-Carlo: up to ``samples`` samples of ``seed`` under ``scatter``
    times each of ``scales`` (1.0 is the estimate itself); with a ``test``, each scale's
    stream stops when the test decides (``samples`` is then the test's maximum)."""

    design: Design
    samples: int
    seed: int
    scales: tuple[float, ...] = (1.0,)
    scatter: Scatter | None = None
    hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL
    dt: float = DEFAULT_DT_S
    method: Method = VERDICT_METHOD
    test: JamTest | None = None
    mechanics: Mechanics = DEFAULT_MECHANICS

    def __post_init__(self):
        object.__setattr__(self, "hinge_model", parse(HingeModel, self.hinge_model, "hinge_model"))
        object.__setattr__(self, "method", parse(Method, self.method, "method"))
        object.__setattr__(self, "mechanics", parse(Mechanics, self.mechanics, "mechanics"))
        if self.test is not None and self.test.max_samples != self.samples:
            raise ValueError(f"a sequential job's samples ({self.samples}) must be its test's maximum "
                             f"({self.test.max_samples})")

    def scatter_at(self, k: float) -> Scatter:
        sc = self.scatter or default_scatter()
        return sc if k == 1.0 else sc.scaled(k)


@dataclass(frozen=True)
class Precomputed:
    """A design's folded outcomes per scatter model (for a sequential job: the samples its
    test consumed, up to the stop), to hand to ``jam_probability`` or the jam test as
    their ``mapper``: they then use these instead of folding (same design name, samples,
    seed, hinge model, time step, collision method, test and scatter, else they fold)."""

    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    dt: float
    outcomes: tuple[tuple[Scatter, tuple[Outcome, ...], JamTest | None], ...]  # per stream: its test (None: fixed)
    method: Method = VERDICT_METHOD

    def lookup(self, design: Design, scatter: Scatter, samples: int, seed: int, hinge_model: HingeModel,
               dt: float, method: Method = VERDICT_METHOD, test: JamTest | None = None) -> tuple[Outcome, ...] | None:
        if (design.name, seed, hinge_model, dt, method) != (self.design, self.seed, self.hinge_model, self.dt,
                                                           self.method):
            return None
        for sc, outs, t in self.outcomes:  # a stream's test's maximum is its sample count
            if sc == scatter and t == test and (self.samples if t is None else t.max_samples) == samples:
                return outs
        return None

    def __call__(self, fn, items, progress=None):  # a plain mapper for whatever was not precomputed
        out = []
        for k, x in enumerate(items):
            out.append(fn(x))
            if progress:
                progress(k + 1, len(items))
        return out


_STATE: dict = {}


def _init(jobs, library) -> None:
    from ...core.parallel import die_with_parent, limit_blas_threads

    limit_blas_threads(1)
    die_with_parent()
    _STATE["jobs"], _STATE["library"] = jobs, library


def _chunk_task(j: int, scatter: Scatter, start: int, size: int) -> tuple[list[Outcome], float]:
    """Fold samples ``start`` .. ``start + size - 1`` of job ``j``'s stream under ``scatter``
    (in a worker); their outcomes and the seconds per sample it took."""
    job: MonteCarloJob = _STATE["jobs"][j]
    samples = samples_between(job.design, scatter, job.seed, start, min(start + size, job.samples))
    t0 = work_cpu_s()  # this worker's CPU, as jam_probability times its first chunk
    out = run_samples((job.design, _STATE["library"], samples, job.hinge_model, job.dt, False, job.method,
                       job.mechanics))
    return out, (work_cpu_s() - t0) / max(1, len(samples))


def run_batch(jobs: Sequence[MonteCarloJob], *, library: MaterialLibrary | None = None, workers: int = 1,
              after: Callable[[int, Precomputed], tuple] | None = None, tasks: Sequence[tuple] = (),
              progress: Callable[..., None] | None = None,
              follow: Callable[[int, Precomputed], Mapping] | None = None,
              meanwhile: Callable[[], None] | None = None) -> tuple[list[Precomputed], list, list]:
    """Fold every job's streams (one per scale) in one pool of ``workers`` processes.

    ``follow(i, pre)`` -> ``{name: (scatter, test)}``: more streams of job ``i`` (the same
    design, samples and seed; their own scatter model and test), asked each time its
    streams are all finished (``pre`` its :class:`Precomputed` so far) until it returns
    none: work that depends on what the first streams decided (check's sweep after the
    test at 1x, the probes of a flip after the sweep) folds in the same pool.
    ``after(i, pre)`` -> ``(fn, args)``: a task run in the same pool once job ``i``'s
    streams are all finished (``pre`` its :class:`Precomputed`); ``tasks``: ``(fn, args)``
    run in the pool beside them. ``progress(kind, what, out)`` is called as a follow-up
    (``"after"``, job index, its result) or independent task (``"task"``, its index, its
    result) finishes, and as a stream consumes samples (``"samples"``, a
    :class:`StreamStatus`, None). ``meanwhile()``: work of this process for after the run
    (loading what its next stages import), done in a thread while the workers fold, once
    they are forked (with one worker: not at all). On a cold numba cache each group of
    kernels is first compiled by one worker, the groups in parallel, before any chunk
    (:mod:`~foldprint.simulation.jamtest.warmup`; reported as ``"warm"``, the groups' names,
    None). Returns the Precomputed per job, the
    follow-ups' results and the tasks' results (in input order)."""
    batch = _Batch(list(jobs), library or default_library(), workers, after, list(tasks), progress, follow)
    batch.meanwhile = meanwhile
    for s in batch.streams:  # every stream, at 0 of its maximum, before the first chunk
        batch.report("samples", s.status())
    if workers <= 1 or sum(n_chunks(s.max_samples) for s in batch.streams if not s.done) + len(batch.tasks) <= 1:  # no pool for one task
        batch.run_here()
    else:
        batch.run_pool()
    return batch.pre, batch.after_out, batch.task_out


class _Batch:
    """The state of one :func:`run_batch`: the streams, the follow-ups' and tasks' results."""

    def __init__(self, jobs: list[MonteCarloJob], lib: MaterialLibrary, workers: int, after, tasks: list,
                 progress, follow=None):
        for job in jobs:
            costs.check_sample_memory(job.design, job.samples)
        self.jobs, self.lib, self.workers, self.after, self.tasks = jobs, lib, workers, after, tasks
        self.progress, self.follow = progress, follow
        self.streams = []
        self.add_streams([Stream(j, float(k), job, job.scatter_at(float(k)), job.test)
                          for j, job in enumerate(jobs) for k in job.scales])
        self.meanwhile = None  # this process's work while the workers fold (run_batch)
        self.pending: dict = {}  # the pool's work in flight (run_pool)
        # (job, follow-up name) -> a first chunk folded before the follow-up asked for it:
        # ("flying", start, size) or ("back", start, (outcomes, seconds per sample))
        self.early: dict[tuple[int, str], tuple] = {}
        self.ready: list[int] = []  # jobs whose streams are all finished, follow-up not yet run
        self.pre: list[Precomputed | None] = [None] * len(jobs)
        self.after_out: list = [None] * len(jobs)
        self.task_out: list = [None] * len(tasks)

    def add_streams(self, new: list[Stream]) -> None:
        """Streams to fold, kept in order of cost (costliest design first; stable: job,
        scale and follow-up order kept)."""
        self.streams = sorted(self.streams + new, key=lambda s: -sample_cost(self.jobs[s.j].design))

    def precomputed(self, j: int) -> Precomputed:
        job = self.jobs[j]
        outs = tuple((s.scatter, tuple(s.outcomes), s.test) for s in self.streams if s.j == j)
        return Precomputed(job.design.name, job.samples, job.seed, job.hinge_model, job.dt, outs, job.method)

    def finished(self, j: int) -> None:
        """Job ``j``'s streams are all finished: its follow-up streams if it has more, else
        it is ready (its Precomputed made, its ``after`` task due)."""
        pre = self.precomputed(j)
        more = self.follow(j, pre) if self.follow is not None else None
        if not more:
            self.pre[j] = pre
            self.ready.append(j)
            return
        new = [Stream(j, name, self.jobs[j], sc, test) for name, (sc, test) in more.items()]
        self.add_streams(new)
        for s in new:
            self.report("samples", s.status())
        if all(s.done for s in new):  # nothing to fold (no samples)
            self.finished(j)
            return
        back = [got for s in new if (got := self.adopt(s)) is not None]
        for s, start, result in back:
            self.chunk_done(s, start, *result)

    def adopt(self, s: Stream) -> tuple | None:
        """Give a new follow-up stream the first chunk folded ahead for it: in flight, it
        becomes the stream's; back already, returned ``(stream, start, (outcomes, seconds
        per sample))`` to be consumed."""
        e = self.early.pop((s.j, s.k), None)
        if e is None or s.done:
            return None
        s.flying += 1
        if e[0] == "flying":
            _, start, size = e
            s.next = start + size
            fut = next(f for f, v in self.pending.items() if v[:3] == ("early", s.j, s.k))
            self.pending[fut] = ("chunk", s, start)
            return None
        _, start, result = e
        s.next = start + len(result[0])
        return s, start, result

    def ahead(self) -> tuple | None:
        """A first chunk of a stream that a job's next follow-up will ask for whatever its
        streams now decide (``follow.ahead(j)`` -> ``{name: scatter}``: check's sweep while
        the test at 1x runs), its smallest chunk: folded on a worker that would otherwise
        fold a chunk that may be discarded; None when there is none."""
        ahead = getattr(self.follow, "ahead", None)
        if ahead is None:
            return None
        for j in dict.fromkeys(s.j for s in self.streams if not s.done):
            job = self.jobs[j]
            for name, sc in ahead(j).items():
                if (j, name) in self.early or any(t.j == j and t.k == name for t in self.streams):
                    continue
                size = min(job.samples, CHUNK if has_loops(job.design) else MIN_CHUNK)
                if size < 1:
                    continue
                self.early[(j, name)] = ("flying", 0, size)
                return ("early", j, name, sc, (0, size))
        return None

    def report(self, kind: str, what) -> None:
        if self.progress:
            out = self.after_out[what] if kind == "after" else self.task_out[what] if kind == "task" else None
            self.progress(kind, what, out)

    def chunk_done(self, s: Stream, start: int, out: list[Outcome], per_sample: float) -> None:
        """Record a folded chunk (the first back of each stream times the run, refused as
        jam_probability would refuse it); a job whose streams are all finished is ready."""
        if not s.timed:
            s.timed = True
            if s.max_samples > CHUNK:
                costs.check_samples(s.max_samples, per_sample, self.workers, s.job.design.name)
        was = s.done
        s.add(start, out)
        if not was:
            self.report("samples", s.status())
        if s.done and not was and all(t.done for t in self.streams if t.j == s.j):
            self.finished(s.j)

    def run_here(self) -> None:
        outer = dict(_STATE)  # a worker of an enclosing batch (the gallery's) keeps its jobs
        _init(self.jobs, self.lib)
        try:
            for j in range(len(self.jobs)):
                if all(s.done for s in self.streams if s.j == j):  # no samples
                    self.finished(j)
            while (s := next((t for t in self.streams if t.wants), None)) is not None:
                start, size = s.take()
                self.chunk_done(s, start, *_chunk_task(s.j, s.scatter, start, size))
        finally:
            _STATE.clear()
            _STATE.update(outer)
        for j in sorted(self.ready):
            if self.after is not None:
                fn, args = self.after(j, self.pre[j])
                self.after_out[j] = fn(*args)
                self.report("after", j)
        for i, (fn, args) in enumerate(self.tasks):
            self.task_out[i] = fn(*args)
            self.report("task", i)

    def next_work(self) -> tuple | None:
        """What to submit to a free worker: a chunk whose outcome will be used (costliest
        stream first), else a finished job's follow-up, else the first chunk of a stream a
        follow-up will ask for (:meth:`ahead`), else a chunk that may be folded past its
        stream's stop, unless a clean run of the samples in flight would stop it
        (:attr:`~foldprint.simulation.jamtest.streams.Stream.open_past_clean_run`: the worker
        waits for them instead); None when there is nothing left to start."""
        for s in self.streams:
            if s.wants and s.sure:
                return ("chunk", s, s.take())
        while self.ready:
            j = self.ready.pop(0)
            if self.after is not None:
                fn, args = self.after(j, self.pre[j])
                return ("after", j, fn, args)
        early = self.ahead()
        if early is not None:
            return early
        open_ = [s for s in self.streams if s.wants and s.open_past_clean_run]
        if open_:
            s = min(open_, key=lambda t: t.flying)  # stable: the costliest among the least fed
            return ("chunk", s, s.take())
        return None

    def run_pool(self) -> None:
        import multiprocessing as mp
        import sys
        from concurrent.futures import ProcessPoolExecutor

        ctx = mp.get_context("fork") if sys.platform.startswith("linux") else None
        pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=ctx, initializer=_init,
                                   initargs=(self.jobs, self.lib))
        pending: dict = self.pending
        try:
            cold = cold_groups(any(has_loops(job.design) for job in self.jobs))
            for g in cold:  # first: one worker each
                pending[pool.submit(warm_group, g)] = ("warm", g)
            if cold:
                self.report("warm", tuple(cold))
            for i, (fn, args) in enumerate(self.tasks):  # short, independent: first, off the critical path
                pending[pool.submit(fn, *args)] = ("task", i)
            for j in range(len(self.jobs)):
                if all(s.done for s in self.streams if s.j == j):  # no samples
                    self.finished(j)
            self.drain(pool, pending)
        except BaseException:
            _stop(pool)
            raise
        _stop(pool)

    def fill(self, pool, pending: dict) -> None:
        """Start work until every worker has some (or nothing is left to start)."""
        if any(kind == "warm" for kind, *_ in pending.values()):  # a chunk now would compile a cold kernel again
            return
        while sum(1 for kind, *_ in pending.values() if kind != "stale") < self.workers:
            work = self.next_work()
            if work is None:
                return
            if work[0] == "chunk":
                _, s, (start, size) = work
                pending[pool.submit(_chunk_task, s.j, s.scatter, start, size)] = ("chunk", s, start)
            elif work[0] == "early":
                _, j, name, sc, (start, size) = work
                pending[pool.submit(_chunk_task, j, sc, start, size)] = ("early", j, name, start)
            else:
                _, j, fn, args = work
                pending[pool.submit(fn, *args)] = ("after", j)

    def drain(self, pool, pending: dict) -> None:
        from concurrent.futures import FIRST_COMPLETED, wait

        self.fill(pool, pending)
        aside = None
        if self.meanwhile is not None:  # the workers are forked by now: a thread is safe
            import threading

            aside = threading.Thread(target=self.meanwhile, name="foldprint-meanwhile", daemon=True)
            aside.start()
        try:
            self.drain_all(pool, pending, wait, FIRST_COMPLETED)
        finally:
            if aside is not None:
                aside.join()

    def drain_all(self, pool, pending: dict, wait, first_completed) -> None:
        """Take results back and start more work until nothing is in flight."""
        while any(kind != "stale" for kind, *_ in pending.values()):
            done, _ = wait(pending, return_when=first_completed)
            for fut in done:
                kind, *key = pending.pop(fut)
                if kind == "chunk":
                    self.chunk_done(key[0], key[1], *fut.result())
                    self.cancel_stale(pending)
                elif kind == "early":  # its stream not asked for yet: kept until it is
                    self.early[(key[0], key[1])] = ("back", key[2], fut.result())
                elif kind == "after":
                    self.after_out[key[0]] = fut.result()
                    self.report("after", key[0])
                elif kind == "warm":
                    fut.result()
                elif kind == "task":
                    self.task_out[key[0]] = fut.result()
                    self.report("task", key[0])
            self.fill(pool, pending)

    @staticmethod
    def cancel_stale(pending: dict) -> None:
        """Chunks of finished streams: cancelled if not started, else marked stale (their
        outcomes would be discarded; nothing waits for them)."""
        for fut, (kind, *key) in list(pending.items()):
            if kind == "chunk" and key[0].done:
                if fut.cancel():
                    key[0].flying -= 1
                    del pending[fut]
                else:
                    pending[fut] = ("stale", *key)


def _stop(pool) -> None:
    """Shut the pool down without waiting for chunks folded past their stream's stop: the
    workers still folding one are ended (``terminate_workers`` where the executor has it,
    Python >= 3.14, else each worker process is terminated)."""
    running = [p for p in (getattr(pool, "_processes", None) or {}).values() if p.is_alive()]
    pool.shutdown(wait=False, cancel_futures=True)
    if hasattr(pool, "terminate_workers"):
        pool.terminate_workers()
        return
    for p in running:
        p.terminate()
    for p in running:
        p.join()
