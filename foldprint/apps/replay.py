"""Monte-Carlo samples shown again: which sample of a jam estimate is the worst
(:func:`worst_sample`) and that sample folded again with its whole trajectory kept
(:func:`replay_sample`, a :class:`Replay`), e.g. for the viewer's worst-sample mode beside
the nominal fold. The Monte-Carlo keeps only each sample's outcome; a replay draws the
same sample from the same seed and spreads and folds it as the Monte-Carlo did.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..core.constants import CHECK_DT_S
from ..core.modes import DEFAULT_AFTER_CONTACT, AfterContact
from ..model.design import Design
from ..model.materials import MaterialLibrary, default_library
from ..simulation.robust import Outcome, RobustResult, Sample, draw_samples, outcome_of, sample_drive
from ..simulation.simulate import SimulationResult, simulate


def worst_sample(robust: RobustResult) -> int | None:
    """Index of the worst Monte-Carlo sample of ``robust``: the earliest first contact
    among the samples that collide; else the first sample that jams another way (a goal
    missed, a hinge short of 98 %); else the slowest fold. None when there is no sample."""
    outs = robust.outcomes
    hits = [k for k, o in enumerate(outs) if o.reason == "collision" and o.time is not None]
    if hits:
        return min(hits, key=lambda k: (outs[k].time, k))
    jammed = [k for k, o in enumerate(outs) if o.jammed]
    if jammed:
        return jammed[0]
    done = [k for k, o in enumerate(outs) if o.fold_time is not None]
    return max(done, key=lambda k: (outs[k].fold_time, -k)) if done else None


@dataclass(frozen=True)
class Replay:
    """One Monte-Carlo sample folded again with its whole trajectory kept (the
    Monte-Carlo keeps only each sample's :class:`~foldprint.simulation.robust.Outcome`)."""

    index: int
    sample: Sample  # its drawn parameters
    outcome: Outcome  # what the Monte-Carlo recorded for it
    result: SimulationResult

    @property
    def agrees(self) -> bool:
        """The replay gives the recorded verdict (jams or not, first colliding pair)."""
        o = outcome_of(self.result)
        return (o.jammed, o.reason, o.pair) == (self.outcome.jammed, self.outcome.reason, self.outcome.pair)


def replay_sample(design: Design, robust: RobustResult, index: int, *, library: MaterialLibrary | None = None,
                  dt: float = CHECK_DT_S, after_contact: AfterContact | str = DEFAULT_AFTER_CONTACT) -> Replay:
    """Sample ``index`` of ``robust`` (a result for ``design`` run with time step ``dt``)
    drawn again from the same seed and spreads and folded as the Monte-Carlo folds it,
    keeping the trajectory, e.g. to show the :func:`worst_sample` beside the nominal fold."""
    if not 0 <= index < robust.samples:
        raise ValueError(f"sample index {index} is outside 0..{robust.samples - 1}")
    lib = library or default_library()
    sample = draw_samples(design, robust.scatter, robust.samples, robust.seed)[index]
    res = simulate(design, dt=dt, method=robust.method, hinge_model=robust.hinge_model, after_contact=after_contact,
                   drive=sample_drive(design, lib, sample))
    return Replay(index, sample, robust.outcomes[index], res)
