"""The ledger of :func:`foldprint.apps.assign.search.assign`'s searches (seven grades and
continuous): every evaluation run through the mapper once, cached by what decides its
verdict, counted against the budget, and its blocking pairs and goals tallied.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

from .result import Verdict
from .tasks import Mapper, Task, map_tasks


@dataclass
class Ledger:
    """Every evaluation, cached, counted and tallied."""

    mapper: Mapper
    budget: int
    progress: Callable[[int, int], None] | None
    cache: dict = field(default_factory=dict)
    evaluated: int = 0
    pairs: dict = field(default_factory=dict)
    goals: dict = field(default_factory=dict)
    first_feasible_at: int | None = None

    def run(self, tasks: list[Task], cap: int | None = None) -> list[Verdict]:
        """Verdicts of ``tasks`` (None for those beyond the budget, or ``cap`` evaluations)."""
        cap = self.budget if cap is None else min(cap, self.budget)
        todo = []
        for t in tasks:
            key = (t.materials, t.bath_c, t.method, t.duration, t.clearance_samples)
            if key not in self.cache and key not in {k for k, _ in todo}:
                todo.append((key, t))
        todo = todo[: max(0, cap - self.evaluated)]
        if todo:
            base = self.evaluated
            cb = (lambda done, _n: self.progress(base + done, self.budget)) if self.progress else None
            results = map_tasks(self.mapper, [t for _, t in todo], cb)
            for (key, t), v in zip(todo, results):
                self.cache[key] = v
                self.evaluated += 1
                complete = all(m is not None for m in t.materials)
                if v.pair is not None:
                    self.pairs[v.pair] = self.pairs.get(v.pair, 0) + 1
                elif v.goal is not None:
                    self.goals[v.goal] = self.goals.get(v.goal, 0) + 1
                if complete and v.completed and self.first_feasible_at is None:
                    self.first_feasible_at = self.evaluated
        out = []
        for t in tasks:
            key = (t.materials, t.bath_c, t.method, t.duration, t.clearance_samples)
            out.append(self.cache.get(key))
        return out
