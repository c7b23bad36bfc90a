"""``check``'s jam test in the stages it runs in, for a pool that folds many designs at once.

``check`` asks its questions in order: the test at the model's spreads (1x) first; then,
at each scale of the sigma-scale sweep, only whether that verdict flips
(:func:`~foldprint.simulation.jamtest.verdict.sweep_question`); then, for a flip, one probe per
scatter component (:func:`~foldprint.simulation.jamtest.flip_drivers.probe_runs`). Each stage's
streams depend on what the stage before decided. The gallery folds every design's stages
in one pool (:func:`~foldprint.simulation.jamtest.pool.run_batch` with :func:`check_follow`), and
each design's check then answers the same questions from those outcomes
(:class:`~foldprint.simulation.jamtest.pool.Precomputed`) without folding: the streams here are
the scatter models and tests :func:`~foldprint.simulation.jamtest.scales.jam_tests` and
:func:`~foldprint.simulation.jamtest.flip_drivers.flip_drivers` ask for, built by the same functions.
``check`` itself folds its stages the same way (:func:`check_pool`): one pool for the test at
1x, the sweep and the probes, so its workers start and load the design once, and a stage
starts on a worker as soon as the stage before it has decided, not after a pool is shut down.
"""

from __future__ import annotations

from typing import Callable, Sequence

from .. import costs
from ...core.modes import Mechanics, parse
from ...model.design import Design
from ...model.materials import MaterialLibrary
from ..robust import CHUNK, warm_kernels
from ..scatter import Scatter, samples_between
from ..simulate import SimulationResult
from .pool import MonteCarloJob, Precomputed, run_batch
from .streams import StreamStatus
from .flip_drivers import flipping, probe_runs
from .scales import JamCounts, StageProgress, scale_label
from .verdict import JamTest, decide, load_interval_solver, sweep_question


def check_follow(jobs: Sequence[MonteCarloJob], scales: Sequence[float]) -> Callable[[int, Precomputed], dict]:
    """``follow`` for :func:`~foldprint.simulation.jamtest.pool.run_batch` over ``jobs`` (each a
    design's test at 1x: ``scales == (1.0,)`` and check's test): after the test at 1x, the
    sweep's ``scales`` asking whether its verdict flips; after the sweep, the probes of its
    flips; then nothing."""
    stage: dict[int, int] = {}
    ks = [float(k) for k in dict.fromkeys(scales) if float(k) != 1.0]

    def follow(j: int, pre: Precomputed) -> dict:
        job = jobs[j]
        if job.test is None or not job.samples:
            return {}
        stage[j] = stage.get(j, 0) + 1
        (sc1, out1, t1), *rest = pre.outcomes
        base = decide([o.jammed for o in out1], t1)
        if stage[j] == 1:
            test = job.test.asking(sweep_question(base.verdict))
            return {scale_label(k): (sc1.scaled(k), test) for k in ks if not sc1.scaled(k).is_zero}
        if stage[j] == 2:  # a scale without spread folds nothing and has nothing to probe
            folded = {sc: (out, t) for sc, out, t in rest}
            points = {k: (decide([o.jammed for o in folded[sc][0]], folded[sc][1]), sc)
                      for k in ks if (sc := sc1.scaled(k)) in folded}
            flips = flipping(base.verdict, [(k, d) for k, (d, _) in points.items()])
            runs = probe_runs(base, sc1, [(k, *points[k]) for k in flips])
            return {name: (run.scatter, run.test) for name, run in runs.items() if not run.scatter.is_zero}
        return {}

    def ahead(j: int) -> dict:
        """The streams job ``j``'s next follow-up asks for whatever its streams decide:
        the sweep's scales, before the test at 1x is done (a probe depends on the sweep)."""
        job = jobs[j]
        if stage.get(j, 0) or job.test is None or not job.samples:
            return {}
        sc1 = job.scatter_at(1.0)
        return {scale_label(k): sc1.scaled(k) for k in ks if not sc1.scaled(k).is_zero}

    follow.ahead = ahead  # type: ignore[attr-defined]  # what the pool may fold early
    return follow


def check_pool(design: Design, test: JamTest, scales: Sequence[float], seed: int, *, scatter: Scatter,
               library: MaterialLibrary, hinge_model, dt: float, method, nominal: SimulationResult,
               workers: int | None = None, progress: StageProgress | None = None,
               mechanics=Mechanics.RIGID) -> Precomputed | None:
    """Every stage of ``check``'s jam test on ``design`` (the test at 1x, the sweep's
    ``scales``, a flip's probes) folded in one pool of ``workers`` processes (default: all
    cores), as the gallery folds them (:func:`check_follow`): the outcomes, to hand
    :func:`~foldprint.simulation.jamtest.scales.jam_tests` and
    :func:`~foldprint.simulation.jamtest.flip_drivers.flip_drivers` as their ``mapper``
    (they then decide from them: the same samples, verdicts and intervals as folding each
    stage in a pool of its own). None where a stage cannot be answered from it (no samples,
    the bar-and-hinge mechanics, no spread at 1x): they fold then. Refused before any fold
    as :func:`~foldprint.simulation.jamtest.scales.jam_tests` refuses (the sample count
    against the nominal fold's broad phase); ``progress`` as it reports."""
    from ...core.parallel import default_workers

    if not test.max_samples or parse(Mechanics, mechanics, "mechanics") != Mechanics.RIGID or scatter.is_zero:
        return None
    n_workers = default_workers() if workers is None else max(1, int(workers))
    costs.check_sample_memory(design, test.max_samples)
    if test.max_samples > CHUNK:
        costs.check_swept_samples(nominal, test.max_samples, n_workers, design.name)
    # the kernels a sample needs, loaded (on a cold cache: compiled) here, before the workers
    # fork: they inherit them, and the first chunk, which the time guard extrapolates, is
    # timed at the kernels' speed (the nominal fold does not load the curves' kernel)
    warm_kernels((design, library, samples_between(design, scatter, seed, 0, 2), hinge_model, dt, False, method,
                  Mechanics.RIGID))
    jobs = [MonteCarloJob(design, test.max_samples, seed, (1.0,), scatter, hinge_model, dt, method, test)]
    pre, _, _ = run_batch(jobs, library=library, workers=n_workers, follow=check_follow(jobs, scales),
                          progress=_reporter(progress), meanwhile=load_interval_solver)
    return pre[0]


def _reporter(progress: StageProgress | None):
    """:func:`run_batch`'s progress as ``check``'s stages report it: the stream's name (its
    scale's, ``"jam test at 1x"``, or its follow-up's), samples of the maximum, jams."""
    if progress is None:
        return None
    counts = isinstance(progress, JamCounts)

    def report(kind: str, st: StreamStatus, _out) -> None:
        if kind != "samples":  # the pool's other news (a cold cache's kernels compiling)
            return
        label = st.scale if isinstance(st.scale, str) else scale_label(st.scale)
        total = st.samples if st.done else st.max_samples
        if counts:
            progress(label, st.samples, total, st.jams)
        else:
            progress(label, st.samples, total)
    return report
