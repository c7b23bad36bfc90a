"""The studio's background work: the jam verdict of the current revision and the material
search, each in a thread of its own (the Monte-Carlo folds in the process pool
:func:`foldprint.simulation.jamtest.pool.run_batch` opens), with its state readable at any time
and every change announced to the listeners the server registers.

**The verdict is check's.** Phase 1 is the revision's own
:class:`~foldprint.apps.pipeline.Evaluation` (check's seed and most samples) running
:meth:`~foldprint.apps.pipeline.Evaluation.run_jam_tests` at 1x: the sequential test of
``foldprint check``, so the verdict, samples, estimate and interval are its numbers; the
state is ``decided`` as soon as it is. Phase 2 is check's own evaluation (the sweep's
sigma scales, :data:`~foldprint.core.constants.CHECK_SCALES`) given the nominal fold and,
as its mapper, phase 1's outcomes (:class:`~foldprint.simulation.jamtest.pool.Precomputed`: the
1x stream is not folded again): its ``check --json`` object (the findings with the jam
test's and the sweep's) completes the state.

**Cancellation.** A newer edit cancels the stale run: the run's progress callback raises
:class:`Cancelled` at the pool's next report (a chunk of samples; the pool is stopped
on the way out, :func:`foldprint.simulation.jamtest.pool.run_batch`; the first report comes
before the pool starts). A new run waits for a stale one that is folding samples to stop,
so two runs never share the cores; a stale run still waiting for its nominal fold (the
edit's own answer computes it) is not waited for: it stops before it folds a sample.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import replace
from typing import Callable

from ..checks.report import jam_test_json, robust_json
from ..core.constants import CHECK_SCALES
from ..core.errors import FoldprintError
from ..core.modes import Mechanics
from ..simulation.jamtest.pool import Precomputed
from ..simulation.jamtest.scales import JamCounts
from ..simulation.jamtest.verdict import confidence_sequence, jam_test
from .pipeline import Evaluation, check_scales

log = logging.getLogger(__name__)


class Cancelled(Exception):
    """A run was cancelled by a newer one (raised inside its progress callback)."""


class Job:
    """One background run: a thread, its state (a JSON-ready dict), its cancellation."""

    def __init__(self, kind: str, notify: Callable[[str, dict], None], previous: "Job | None" = None):
        self.kind, self.notify, self.previous = kind, notify, previous
        self.cancelled = threading.Event()
        self.pooled = threading.Event()  # set when the run starts folding samples (holds the cores)
        self.lock = threading.Lock()
        self.state: dict = {}
        self.thread: threading.Thread | None = None

    def set(self, **changes) -> None:
        with self.lock:
            self.state = {**self.state, **changes}
            snapshot = dict(self.state)
        self.notify(self.kind, snapshot)

    def read(self) -> dict:
        with self.lock:
            return dict(self.state)

    def check(self) -> None:
        if self.cancelled.is_set():
            raise Cancelled()

    def start(self, work: Callable[[], None]) -> "Job":
        def run():
            prev, self.previous = self.previous, None
            if prev is not None:  # the stale run stops at its next report: wait for it while it holds the cores
                prev.cancel()
                while prev.thread is not None and prev.thread.is_alive() and prev.pooled.is_set():
                    prev.thread.join(0.05)
            try:
                self.check()
                work()
            except Cancelled:
                self.set(state="cancelled")
            except FoldprintError as exc:
                self.set(state="failed", error=str(exc))
            except Exception as exc:  # noqa: BLE001 - a bug: said in the state, the server stays up
                log.exception("studio: %s run failed", self.kind)
                self.set(state="failed", error=f"internal error: {type(exc).__name__}: {exc}")

        self.thread = threading.Thread(target=run, name=f"studio-{self.kind}", daemon=True)
        self.thread.start()
        return self

    def cancel(self) -> None:
        self.cancelled.set()

    def join(self, timeout: float | None = None) -> None:
        if self.thread is not None:
            self.thread.join(timeout)


def verdict_job(session, revision: int, entry, notify, previous: Job | None = None) -> Job:
    """Start the jam verdict of ``entry`` (revision ``revision`` of ``session``); its state
    is ``running`` at once (no sample yet)."""
    job = Job("verdict", notify, previous)
    t = entry.evaluation.options
    level = jam_test(t.thresholds.warning, t.thresholds.error, t.samples).level
    job.set(design_revision=revision, state="running", stage="nominal fold", samples=0, max_samples=t.samples,
            jams=None, estimate=None, interval=None, level=level, verdict=None, test=None, robust=None,
            sweep={"state": "waiting", "points": None}, check=None, started=time.time())

    def report(stage: str, done: int, total: int, jams: int | None) -> None:
        job.check()
        if stage.endswith(" at 1x"):
            if job.read()["state"] == "running":  # phase 2's replay of the decided 1x stream changes nothing
                job.set(stage=stage, samples=done, max_samples=total, **running_estimate(jams, done, level))
        else:
            job.set(sweep={"state": "running", "stage": stage, "samples": done, "max_samples": total,
                           "jams": jams, "points": None})

    progress = JamCounts(report)

    def work() -> None:
        session.nominal(revision, entry)  # the fold first (computed once: the edit's answer waits on the same)
        job.check()
        ev = entry.evaluation
        job.set(stage="jam test at 1x")
        ev.progress = progress
        job.pooled.set()
        r = ev.run_jam_tests()[1.0]
        d = r.decision
        lo, hi = d.interval
        job.set(state="decided", samples=d.samples, jams=d.jams, estimate=d.estimate, interval=[lo, hi],
                verdict=str(d.verdict), test=jam_test_json(d), robust=robust_json(r),
                sweep={"state": "running", "points": None}, decided_after_s=round(time.time() - job.state["started"], 3))
        if entry.check is None:
            entry.check = sweep_evaluation(ev, r, progress).to_json(entry.setup.printer)
        job.set(sweep={"state": "done", "points": entry.check["sensitivity"]}, check=entry.check)

    return job.start(work)


def running_estimate(jams: int | None, samples: int, level: float) -> dict:
    """The running state of a test at ``samples`` samples with ``jams`` jams: the estimate
    jams/samples and the interval the verdict reports
    (:func:`~foldprint.simulation.jamtest.verdict.confidence_sequence`: anytime-valid, so it
    holds at this count as at the stop); none of them before the first sample or when the
    count is not known."""
    if jams is None or samples <= 0:
        return {"jams": jams if samples > 0 else None, "estimate": None, "interval": None}
    lo, hi = confidence_sequence(jams, samples, level)
    return {"jams": jams, "estimate": jams / samples, "interval": [lo, hi]}


def sweep_evaluation(ev: Evaluation, r, progress) -> Evaluation:
    """Check's evaluation of ``ev``'s design (the sweep at :data:`CHECK_SCALES`), given
    ``ev``'s nominal fold and its 1x test ``r`` (not folded again), with every finding
    computed: ``to_json()`` is ``foldprint check --json``."""
    o = ev.options
    opts = replace(o, scales=check_scales(CHECK_SCALES))
    mapper = None
    if o.mechanics == Mechanics.RIGID:  # the pool's precomputed outcomes hold rigid folds only
        test = jam_test(o.thresholds.warning, o.thresholds.error, o.samples)
        mapper = Precomputed(ev.design.name, test.max_samples, o.seed, r.hinge_model, o.dt,
                             ((r.scatter, tuple(r.outcomes), test),), r.method)
    check = Evaluation(ev.design, opts, library=ev.library, printer=ev.printer, scatter=ev.scatter,
                       simulation=ev.simulation, mapper=mapper, progress=progress)
    check.findings  # noqa: B018 - every stage the rules read
    return check


def assign_job(design, library, notify, previous: Job | None = None, *, objective: str = "time", top: int = 5,
               budget: int | None = None, temperatures=None) -> Job:
    """Start ``assign`` on ``design`` (the material search of ``foldprint assign``):
    state ``running`` with its evaluations so far, then ``done`` with ``assign --json``'s
    ``best`` (ranked) and the choices to apply (:meth:`Job.choice`)."""
    from .assign.search import DEFAULT_BUDGET, assign

    job = Job("assign", notify, previous)
    job.set(state="running", done=0, total=budget or DEFAULT_BUDGET, result=None, design=design.name)

    def progress(done: int, total: int) -> None:
        job.check()
        job.set(done=done, total=total)

    def work() -> None:
        job.pooled.set()
        r = assign(design, library=library, objective=objective, top=top, budget=budget or DEFAULT_BUDGET,
                   temperatures=temperatures, progress=progress)
        job.result = r
        job.set(state="done", result=r.to_json())

    job.result = None
    return job.start(work)
