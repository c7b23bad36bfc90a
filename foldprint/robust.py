"""Jam probability under manufacturing and process scatter (Monte-Carlo).

Real parts are not nominal: the bath temperature varies from run to run and the
heat-transfer coefficient of the whole part by the error of its correlation (both shared
by every hinge of a sample); Tg varies from hinge to hinge with the digital-material mix,
hinge thickness with the printer's tolerance, and h locally with the hinge's place on the
part. Each sample is drawn by :func:`foldprint.scatter.draw_samples` (the model, its
sources in ``foldprint/data/scatter.toml``, ``docs/robustness-model.md``); this module
builds every hinge's recovery curve from the perturbed values, and folds the printed
geometry (arc hinges, the 3D swept check, every goal) with
:func:`foldprint.simulate.simulate`. A sample *jams* when it does not complete: a
collision, a goal unmet or out of order, or a hinge short of 98 %.

Samples are drawn up front from one seeded generator, in order, and evaluated in any
order on any number of processes: the same seed gives the same answer.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from .design import Design
from .errors import DesignError
from .kinematics import HingeDrive
from .materials import MaterialLibrary, default_library
from .modes import DEFAULT_HINGE_MODEL, HingeModel, Method, parse
from .recovery import recovery_curve
# What is drawn (the model, its data file, the samples) lives in foldprint.scatter; this
# module folds what it draws. Re-exported so callers keep importing them from here.
from .scatter import TRUNCATE_SD, Sample, Scatter, default_scatter, draw_samples, load_scatter  # noqa: F401
from .simulate import SimulationResult, simulate

#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054


def sample_drive(design: Design, library: MaterialLibrary, sample: Sample) -> HingeDrive:
    """The hinge drive of one sample: each hinge's curve from its perturbed material."""
    curves = []
    for k, h in enumerate(design.hinges):
        mat = library[h.material]
        rec = replace(mat.recovery, h_w_m2k=mat.recovery.h_w_m2k * float(sample.h_scale[k]))
        mat = replace(mat, tg_c=mat.tg_c + float(sample.tg_shift_c[k]), recovery=rec)
        curves.append(recovery_curve(mat, sample.bath_c, float(sample.thickness_mm[k]),
                                     design.process.fix_temperature_c))
    return HingeDrive(design, sample.bath_c, curves=curves)


@dataclass(frozen=True)
class Outcome:
    """What became of one sample."""

    jammed: bool
    reason: str | None  # "collision", "goal", "unfolded" or None
    pair: tuple[str, str] | None  # the first colliding panels
    time: float | None  # first contact (s)
    fold_time: float | None  # every hinge at 98 % (s), when it completed


def outcome_of(result: SimulationResult) -> Outcome:
    c = result.first_collision
    if result.completed:
        return Outcome(False, None, None, None, result.fold_time)
    if c is not None:
        return Outcome(True, "collision", tuple(sorted(c.panels)), float(c.time), None)
    if not all(g.met for g in result.goals):
        return Outcome(True, "goal", None, None, None)
    return Outcome(True, "unfolded", None, None, None)


def run_sample(args) -> Outcome:
    """Fold one sample (a module-level function, so processes and clusters can run it)."""
    design, library, sample, hinge_model, dt = args
    drive = sample_drive(design, library, sample)
    res = simulate(design, dt=dt, method=Method.FCL, hinge_model=hinge_model, drive=drive)
    return outcome_of(res)


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k / n.

    >>> [round(x, 4) for x in wilson(0, 60)]
    [0.0, 0.0602]
    """
    if n <= 0:
        raise ValueError("n must be > 0")
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class RobustResult:
    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    scatter: Scatter
    outcomes: tuple[Outcome, ...]
    nominal: SimulationResult

    @property
    def jams(self) -> int:
        return sum(o.jammed for o in self.outcomes)

    @property
    def jam_probability(self) -> float:
        return self.jams / self.samples

    @property
    def ci95(self) -> tuple[float, float]:
        return wilson(self.jams, self.samples)

    def collisions(self) -> list[tuple[tuple[str, str], int]]:
        """Colliding pairs, most frequent first (ties by name)."""
        counts: dict = {}
        for o in self.outcomes:
            if o.pair is not None:
                counts[o.pair] = counts.get(o.pair, 0) + 1
        return sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))

    def fold_time_percentiles(self) -> dict | None:
        """5th, 50th, 95th percentile of the fold time of the samples that completed."""
        ft = np.array([o.fold_time for o in self.outcomes if o.fold_time is not None])
        if ft.size == 0:
            return None
        p5, p50, p95 = np.percentile(ft, [5, 50, 95])
        return {"p5": float(p5), "p50": float(p50), "p95": float(p95)}


def jam_probability(design: Design, samples: int = 60, seed: int = 0, *, scatter: Scatter | None = None,
                    library: MaterialLibrary | None = None, hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                    dt: float = 0.01, nominal: SimulationResult | None = None, workers: int | None = None,
                    progress: Callable[[int, int], None] | None = None, mapper=None) -> RobustResult:
    """Monte-Carlo estimate of the probability that ``design`` jams.

    ``nominal``: the nominal simulation if the caller has it (else it is run here).
    ``mapper(fn, items, progress)``: how to run the samples (default: all local cores,
    :func:`foldprint.parallel.map_ordered`)."""
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise DesignError(f"samples must be a whole number >= 1, got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise DesignError(f"seed must be a whole number >= 0, got {seed!r}")
    lib = library or default_library()
    scatter = scatter or default_scatter()
    model = parse(HingeModel, hinge_model, "hinge_model")
    if nominal is None:
        nominal = simulate(design, dt=dt, method=Method.FCL, hinge_model=model, library=lib)
    drawn = draw_samples(design, scatter, samples, seed)
    tasks = [(design, lib, s, model, dt) for s in drawn]
    if mapper is None:
        from .parallel import map_ordered

        outcomes = map_ordered(run_sample, tasks, workers=workers, progress=progress)
    else:
        outcomes = mapper(run_sample, tasks, progress)
    return RobustResult(design.name, samples, seed, model, scatter, tuple(outcomes), nominal)
