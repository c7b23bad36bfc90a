"""``check``'s jam test run on a design: the sequential test of
:mod:`foldprint.simulation.jamtest.verdict` on the stream of samples of one seed, at the model's
spreads and at each sigma scale of the sweep (the same draws scaled: common random
numbers), each stream stopping when its test decides.

:func:`jam_tests` is the one function ``check`` and the gallery get their verdicts from.
The streams are folded in one adaptive pool (:func:`foldprint.simulation.jamtest.pool.run_batch`:
all scales at once, chunks submitted as workers free up, none after a stream's stop), or
answered from the outcomes the gallery's shared pool folded
(:class:`~foldprint.simulation.jamtest.pool.Precomputed`), or, with another mapper (a cluster), in
rounds of chunks. Every path consumes outcomes in stream order, so the samples used, the
jams, the verdict and the interval are the same on any number of workers.
"""

from __future__ import annotations

from dataclasses import replace
from itertools import islice
from typing import Callable, Mapping, Sequence

from .. import costs
from ...core.constants import CHECK_DT_S, CHECK_SEED
from ...core.errors import DesignError
from ...core.jit import work_cpu_s
from ...core.modes import DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, VERDICT_METHOD, HingeModel, Mechanics, Method, parse
from ...model.design import Design
from ...model.materials import MaterialLibrary, default_library
from .pool import MonteCarloJob, run_batch
from .streams import StreamStatus
from ..robust import CHUNK, Outcome, RobustResult, outcome_of, run_samples, warm_kernels
from ..scatter import Scatter, default_scatter, iter_samples
from ..simulate import SimulationResult, simulate
from .verdict import JamDecision, JamTest, decide, jam_test, sweep_question  # noqa: F401 (jam_test re-exported for the pipeline)

StageProgress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: stage ``"jam test at 1x"`` (each scale), its samples so
far of the maximum, then ``(n, n)`` once its test decided at n (the evaluation's progress).
A :class:`JamCounts` is also told the jams among those samples."""


class JamCounts:
    """A :data:`StageProgress` that is also told each stream's jams so far:
    ``fn(stage, done, total, jams)``, ``jams`` None from a stage that is not a jam test's
    stream (the evaluation's other Monte-Carlo stages). With them a caller can show the
    running estimate and its interval
    (:func:`~foldprint.simulation.jamtest.verdict.confidence_sequence`, anytime-valid: it
    holds at every sample count, not only at the stop)."""

    def __init__(self, fn: Callable[[str, int, int, int | None], None]):
        self.fn = fn

    def __call__(self, stage: str, done: int, total: int, jams: int | None = None) -> None:
        self.fn(stage, done, total, jams)


def _stage(progress: StageProgress | None, labels: Sequence[str]):
    """A :class:`~foldprint.simulation.jamtest.pool.StreamStatus` callback reporting to ``progress``
    (a stream's job indexes ``labels``; a :class:`JamCounts` gets the jams too)."""
    if progress is None:
        return None
    counts = isinstance(progress, JamCounts)

    def report(st: StreamStatus) -> None:
        total = st.samples if st.done else st.max_samples
        if counts:
            progress(labels[st.job], st.samples, total, st.jams)
        else:
            progress(labels[st.job], st.samples, total)
    return report


def jam_tests(design: Design, test: JamTest, scales: Sequence[float] = (1.0,), seed: int = CHECK_SEED, *,
              scatter: Scatter | None = None, library: MaterialLibrary | None = None,
              hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL, dt: float = CHECK_DT_S,
              method: Method | str = VERDICT_METHOD, nominal: SimulationResult | None = None,
              workers: int | None = None, mapper=None, progress: StageProgress | None = None,
              mechanics: Mechanics | str = DEFAULT_MECHANICS) -> dict[float, RobustResult]:
    """The jam test of ``design`` with every spread of ``scatter`` times each of ``scales``
    (1 is the model's own): per scale a :class:`~foldprint.simulation.robust.RobustResult`
    whose outcomes are the samples its test used and whose ``decision`` is the verdict.
    With 1 among ``scales`` its test runs first and the other scales then ask only whether
    its verdict flips (:func:`~foldprint.simulation.jamtest.verdict.sweep_question`: after a pass,
    whether p is above the warning threshold; after an error, below the error one).

    ``nominal``: the nominal simulation if the caller has it (a scale at which every
    spread is zero folds nothing: each sample is the nominal part). ``workers``: the
    pool's processes (default: all cores; 1 folds here). ``mapper``: a
    :class:`~foldprint.simulation.jamtest.pool.Precomputed` answers from its outcomes; another
    mapper ``(fn, items, progress)`` folds rounds of ``workers`` chunks. ``progress``: see
    :data:`StageProgress`. ``mechanics``: the samples' (and the nominal fold's); a
    ``Precomputed`` mapper holds rigid folds only."""
    scatter = scatter or default_scatter()
    ks = tuple(dict.fromkeys(float(k) for k in scales))
    kw = dict(library=library, hinge_model=hinge_model, dt=dt, method=method, workers=workers, mapper=mapper,
              progress=progress, mechanics=mechanics)
    first = (1.0,) if 1.0 in ks else ks
    got = jam_tests_of(design, test, {scale_label(k): scatter if k == 1.0 else scatter.scaled(k) for k in first}, seed,
                       nominal=nominal, **kw)
    rest = [k for k in ks if k not in first]
    if rest:  # the sweep asks only whether the verdict at 1x flips
        base = got[scale_label(1.0)]
        got.update(jam_tests_of(design, test.asking(sweep_question(base.decision.verdict)),
                                {scale_label(k): scatter.scaled(k) for k in rest}, seed, nominal=base.nominal, **kw))
    return {k: got[scale_label(k)] for k in ks}


def scale_label(scale: float) -> str:
    """A sweep scale's test as progress names it (and the gallery's pool its stream)."""
    return f"jam test at {scale:g}x"


def jam_tests_of(design: Design, test: JamTest | Mapping[str, JamTest], models: Mapping[str, Scatter],
                 seed: int = CHECK_SEED, *,
                 library: MaterialLibrary | None = None, hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                 dt: float = CHECK_DT_S, method: Method | str = VERDICT_METHOD,
                 nominal: SimulationResult | None = None, workers: int | None = None, mapper=None,
                 progress: StageProgress | None = None,
                 mechanics: Mechanics | str = DEFAULT_MECHANICS) -> dict[str, RobustResult]:
    """The jam test of ``design`` under each scatter model of ``models`` (by the name its
    progress reports, e.g. ``"jam test at 2x"``), all on the draws of ``seed`` (common
    random numbers) and, folded here, in one pool: :func:`jam_tests` with the models
    given (the sweep's scales, or a flip's components removed, :mod:`.flip_drivers`).
    ``test``: one test for every model, or one per model's name (a probe asks only its
    flip's threshold: :meth:`~foldprint.simulation.jamtest.verdict.JamTest.asking`)."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise DesignError(f"seed must be a whole number >= 0, got {seed!r}")
    from ...core.parallel import default_workers

    labels = tuple(models)
    tests = {name: test[name] if isinstance(test, Mapping) else test for name in labels}
    lib, report = library or default_library(), _stage(progress, labels)
    model, method = parse(HingeModel, hinge_model, "hinge_model"), parse(Method, method, "method")
    mech = parse(Mechanics, mechanics, "mechanics")
    n_workers = default_workers() if workers is None else max(1, int(workers))
    costs.check_sample_memory(design, max(t.max_samples for t in tests.values()))  # refuse before any fold
    if nominal is None:
        nominal = simulate(design, dt=dt, method=method, hinge_model=model, library=lib, mechanics=mech)
    found: dict[str, tuple[Outcome, ...]] = {}
    # simulation.jamtest.pool.Precomputed (folded in a shared pool) holds rigid folds only
    lookup = getattr(mapper, "lookup", None) if mech == Mechanics.RIGID else None
    for name, sc in models.items():
        test = tests[name]
        if sc.is_zero:  # no scatter: every sample is the nominal part
            found[name] = (outcome_of(nominal),) * test.max_samples
        elif lookup is not None:
            got = lookup(design, sc, test.max_samples, seed, model, dt, method, test)
            if got is not None:
                found[name] = tuple(got)
    missing = [name for name in labels if name not in found]
    if mech == Mechanics.BAR_HINGE and missing:  # minutes before a first chunk of compliant folds is timed
        costs.check_mechanics_samples(nominal, sum(tests[name].max_samples for name in missing), n_workers,
                                      design.name)
    most = max((tests[name].max_samples for name in missing), default=0)
    if mech == Mechanics.RIGID and most > CHUNK:  # as the first chunk's rate would, before it is folded
        costs.check_swept_samples(nominal, most, n_workers, design.name)
    if missing and (mapper is None or lookup is not None):
        jobs = [MonteCarloJob(design, tests[name].max_samples, seed, (1.0,), models[name], model, dt, method,
                              tests[name], mech) for name in missing]
        order = [labels.index(name) for name in missing]
        pre, _, _ = run_batch(jobs, library=lib, workers=n_workers,
                              progress=(lambda kind, st, _out: kind == "samples" and report(replace(st, job=order[st.job])))
                              if report else None)
        found.update((name, p.outcomes[0][1]) for name, p in zip(missing, pre))
    for name in missing if mapper is not None and lookup is None else ():
        j = labels.index(name)
        found[name] = _rounds(design, lib, models[name], seed, tests[name], (model, dt, method, mech), mapper, n_workers,
                              (lambda st, j=j: report(StreamStatus(j, 1.0, *st))) if report else None)
    out = {}
    for j, name in enumerate(labels):
        test = tests[name]
        d = decide([o.jammed for o in found[name]], test)
        if not d.decided:
            raise RuntimeError(f"{design.name}: the {name} did not decide on its {len(found[name])} samples")
        outs = found[name][:d.samples]
        if report is not None and name not in missing:
            report(StreamStatus(j, 1.0, d.samples, test.max_samples, True, d.jams))
        out[name] = RobustResult(design.name, d.samples, seed, model, models[name], outs, nominal, method, d, mech)
    return out


def _rounds(design: Design, lib: MaterialLibrary, scatter: Scatter, seed: int, test: JamTest, fold: tuple,
            mapper, workers: int, progress: Callable[[tuple], None] | None) -> tuple[Outcome, ...]:
    """One stream through a plain ``mapper``: the first chunk here (it times the run for
    the guard), then rounds of ``workers`` chunks until the test decides. ``fold``: how
    each sample is folded, (hinge model, dt, method, mechanics)."""
    model, dt, method, mech = fold
    stream = iter_samples(design, scatter, test.max_samples, seed)
    chunks = iter(lambda: list(islice(stream, CHUNK)), [])
    outcomes: list[Outcome] = []
    first = next(chunks)
    warm_kernels((design, lib, first, model, dt, False, method, mech))  # the guard times kernels, not the compiler
    start = work_cpu_s()  # CPU: the budget is work, not the load of a shared machine (nor the compiler's)
    outcomes += run_samples((design, lib, first, model, dt, False, method, mech))
    if test.max_samples > CHUNK:
        costs.check_samples(test.max_samples, (work_cpu_s() - start) / len(first), workers, design.name)
    while True:
        d = decide([o.jammed for o in outcomes], test)
        if progress:
            n = min(len(outcomes), d.samples) if d.decided else len(outcomes)
            progress((n, test.max_samples, d.decided, sum(o.jammed for o in outcomes[:n])))
        if d.decided:
            return tuple(outcomes[:d.samples])
        items = [(design, lib, c, model, dt, False, method, mech) for c in islice(chunks, workers)]
        for part in mapper(run_samples, items, None):
            outcomes += part


def on_check_stream(r: RobustResult, seed: int = CHECK_SEED, test: JamTest | None = None) -> JamDecision | None:
    """What ``check``'s test (default thresholds and maximum) makes of a fixed-size
    estimate's samples when they are check's stream (its seed; the same scatter model,
    hinge model and time step assumed): its first n samples are the ones check uses.
    None for another seed; undecided when check needs more samples than ``r`` has."""
    if r.seed != seed or r.decision is not None:
        return None
    return decide([o.jammed for o in r.outcomes], test or jam_test())
