"""What drives a jam probability, and how it moves with the scatter model's spreads.

* :func:`contributions`: one component at a time (:data:`foldprint.simulation.scatter.COMPONENTS`):
  the jam probability with that component **alone** (the others at zero) and with **all
  but** that one. "Alone" says what a component can do by itself; the drop from the full
  model to "all but" says what the others cannot do without it (interactions count in
  both, so the parts need not add up to the whole).
* :func:`sweep`: the jam probability with every spread scaled by k (0.5, 1, 2 ...): how
  much a verdict depends on the scatter model's numbers, most of which are choices
  (``docs/robustness-model.md``).

Every run draws the same underlying samples (same seed; :mod:`foldprint.simulation.scatter` scales
the same standard normals), so differences between runs are differences of the model, not
of the draw. Cost: one Monte-Carlo run per component switched on, two per contribution;
a component whose spread is zero is not folded again (alone it is the nominal part, and
all-but-it is the full model).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Sequence

from ..model.design import Design
from ..core.constants import DEFAULT_DT_S, SWEEP_SCALES
from ..core.errors import DesignError
from ..model.materials import MaterialLibrary
from .robust import RobustResult, jam_probability, outcome_of
from .scatter import COMPONENTS, MAX_SCALE, Component, Scatter



@dataclass(frozen=True)
class Contribution:
    """One component's share: the estimate with it alone and with all but it."""

    component: Component
    spread: float
    alone: RobustResult
    without: RobustResult


@dataclass(frozen=True)
class Contributions:
    full: RobustResult
    items: tuple[Contribution, ...]


@dataclass(frozen=True)
class SweepPoint:
    scale: float
    result: RobustResult


def _nominal_only(base: RobustResult, scatter: Scatter) -> RobustResult:
    """No scatter: every sample is the nominal part (no fold needed)."""
    o = outcome_of(base.nominal)
    return RobustResult(base.design, base.samples, base.seed, base.hinge_model, scatter, (o,) * base.samples,
                        base.nominal, base.method, mechanics=base.mechanics)


class _Runner:
    """Runs the same Monte-Carlo as ``base`` under another scatter model, reporting
    progress over all the runs of one request."""

    def __init__(self, design: Design, base: RobustResult, runs: int, library: MaterialLibrary | None, dt: float,
                 workers: int | None, mapper, progress: Callable[[int, int], None] | None):
        self.design, self.base, self.library, self.dt = design, base, library, dt
        self.workers, self.mapper, self.progress = workers, mapper, progress
        self.total, self.done = runs * base.samples, 0

    def __call__(self, scatter: Scatter) -> RobustResult:
        if scatter.is_zero:
            r = _nominal_only(self.base, scatter)
        else:
            cb = None
            if self.progress is not None:
                offset, total, prog = self.done, self.total, self.progress
                cb = lambda done, _n: prog(offset + done, total)  # noqa: E731
            r = jam_probability(self.design, self.base.samples, self.base.seed, scatter=scatter,
                                library=self.library, hinge_model=self.base.hinge_model, dt=self.dt,
                                nominal=self.base.nominal, workers=self.workers, progress=cb, mapper=self.mapper,
                                method=self.base.method, mechanics=self.base.mechanics)
        self.done += self.base.samples
        return r


def contributions(design: Design, full: RobustResult, *, library: MaterialLibrary | None = None,
                  dt: float = DEFAULT_DT_S, workers: int | None = None, mapper=None,
                  progress: Callable[[int, int], None] | None = None) -> Contributions:
    """Each component alone and all but each, with the samples, seed and hinge model of
    ``full`` (the estimate under the whole model)."""
    sc = full.scatter
    active = [c for c in COMPONENTS if sc.spread(c.key) > 0]
    run = _Runner(design, full, 2 * len(active), library, dt, workers, mapper, progress)
    items = []
    for c in COMPONENTS:
        spread = sc.spread(c.key)
        if spread == 0:
            items.append(Contribution(c, 0.0, _nominal_only(full, sc.only([c.key])), full))
            continue
        items.append(Contribution(c, spread, run(sc.only([c.key])), run(sc.without(c.key))))
    return Contributions(full, tuple(items))


#: Sigma scales one sweep may ask for (the defaults sweep 2 or 3).
MAX_SCALES = 16


def parse_scales(text: str, option: str = "--scales") -> tuple[float, ...]:
    """``"0.5,1,2"`` -> (0.5, 1.0, 2.0): in [0, MAX_SCALE], sorted, no repeats."""
    try:
        vals = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise DesignError(f"{option}: expected numbers separated by commas (e.g. 0.5,1,2), got {text!r}") from None
    if not vals or any(not (0 <= v <= MAX_SCALE) for v in vals):
        raise DesignError(f"{option}: scales must be numbers in [0, {MAX_SCALE:g}] (e.g. 0.5,1,2: multiples of "
                          f"the scatter model's spreads), got {text[:60]!r}")
    if len(set(vals)) > MAX_SCALES:
        raise DesignError(f"{option}: {len(set(vals))} scales; at most {MAX_SCALES} (each is one more "
                          "Monte-Carlo run of every sample)")
    return tuple(sorted(set(vals)))


def sweep(design: Design, base: RobustResult, scales: Sequence[float] = SWEEP_SCALES, *,
          library: MaterialLibrary | None = None, dt: float = DEFAULT_DT_S, workers: int | None = None, mapper=None,
          progress: Callable[[int, int], None] | None = None) -> tuple[SweepPoint, ...]:
    """The estimate with every spread of ``base.scatter`` times each scale (1 reuses
    ``base``), the same samples, seed and hinge model."""
    scales = tuple(sorted(set(float(k) for k in scales)))
    run = _Runner(design, base, sum(k != 1.0 for k in scales), library, dt, workers, mapper, progress)
    return tuple(SweepPoint(k, base if k == 1.0 else run(base.scatter.scaled(k))) for k in scales)
