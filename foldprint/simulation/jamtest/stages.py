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
"""

from __future__ import annotations

from typing import Callable, Sequence

from .pool import MonteCarloJob, Precomputed
from .flip_drivers import flipping, probe_runs
from .scales import scale_label
from .verdict import decide, sweep_question


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

    return follow
