"""What :func:`foldprint.apps.assign.search.assign` reports: one evaluation's :class:`Verdict`,
a feasible assignment (:class:`Choice`) and the whole search's :class:`AssignResult`,
with their JSON (``foldprint assign --json``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ...core.modes import Objective
from ...model.design import Design


@dataclass(frozen=True)
class Verdict:
    """What one evaluation found. ``pair``: the first colliding panels (ids); ``goal``:
    the first goal not met in order; ``clearance_mm``: the smallest gap between
    non-adjacent panels along the fold (when measured)."""

    completed: bool
    pair: tuple[str, str] | None
    contact_time: float | None
    goal: str | None
    fold_time: float | None
    clearance_mm: float | None
    method: str



@dataclass(frozen=True)
class Choice:
    """A feasible assignment and how good it is."""

    materials: tuple[str, ...]
    bath_c: float
    fold_time: float
    clearance_mm: float | None
    pattern: tuple[tuple[int, ...], ...]
    jam_probability: float | None = None
    jam_ci95: tuple[float, float] | None = None

    def to_json(self, design: Design) -> dict:
        return {"assignment": {h.id: m for h, m in zip(design.hinges, self.materials)},
                "temperature_c": round(self.bath_c, 3), "fold_time_s": round(self.fold_time, 4),
                "min_clearance_mm": None if self.clearance_mm is None else round(self.clearance_mm, 4),
                "jam_probability": None if self.jam_probability is None else round(self.jam_probability, 4),
                "jam_ci95": None if self.jam_ci95 is None else [round(x, 4) for x in self.jam_ci95],
                "waves": [[design.hinges[k].id for k in w] for w in self.pattern]}


@dataclass(frozen=True)
class AssignResult:
    design: Design
    objective: Objective
    materials: tuple[str, ...]
    temperatures: tuple[float, ...]
    evaluated: int
    search_space: int
    feasible: int
    best: tuple[Choice, ...]
    blocking: tuple[tuple[str, tuple, int], ...]  # (kind "pair" | "goal", what, count)
    first_feasible_at: int | None
    patterns: int
    permanent_blocked: bool = False
    confirmed: int = 0
    exhaustive: bool = False
    robust_simulations: int = 0  # Monte-Carlo folds of the finalists (not in ``evaluated``)

    def to_json(self) -> dict:
        return {"design": self.design.name, "objective": str(self.objective), "materials": list(self.materials),
                "temperatures_c": [round(t, 3) for t in self.temperatures],
                "evaluated": self.evaluated, "feasible": self.feasible, "search_space": self.search_space,
                "evaluated_fraction": self.evaluated / self.search_space,
                "first_feasible_at": self.first_feasible_at, "feasible_patterns": self.patterns,
                "confirmed": self.confirmed, "exhaustive": self.exhaustive,
                "robust_simulations": self.robust_simulations,
                "best": [c.to_json(self.design) for c in self.best],
                "blocking": [self._blocking_json(k, w, n) for k, w, n in self.blocking]}

    def _blocking_json(self, kind: str, what, n: int) -> dict:
        """One blocking entry: the pair or goal, in how many evaluations it blocked (a
        pair that crosses in the printed state blocks before any evaluation: count 0,
        ``printed_state`` true)."""
        if kind == "pair" and self.permanent_blocked:
            return {"pair": list(what), "count": 0, "kind": kind, "printed_state": True}
        return ({"pair": list(what)} if kind == "pair" else {"goal": what}) | {"count": n, "kind": kind}


def choice_from(pattern, bath_c: float, materials, v: Verdict) -> Choice:
    """A confirmed assignment as reported (an unbounded clearance reads as None)."""
    clear = None if v.clearance_mm is None or math.isinf(v.clearance_mm) else v.clearance_mm
    return Choice(tuple(materials), bath_c, v.fold_time, clear, tuple(tuple(sorted(w)) for w in pattern))
