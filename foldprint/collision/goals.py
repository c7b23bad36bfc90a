"""Goals checked along a trajectory. ``pass_through``: a tip point of one panel passes
through a hole of another panel (its local z changes sign at a point inside the hole)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from shapely.geometry import Point, Polygon

from ..model.design import Design, Goal


@dataclass(frozen=True)
class GoalResult:
    goal: Goal
    met: bool
    time: float | None  # first pass (s)
    in_order: bool
    passes: tuple[float, ...]  # every time the tip crossed the hole (s)

    def to_json(self) -> dict:
        g = self.goal
        return {"id": g.id, "type": g.type, "panel": g.panel, "target": g.target, "hole": g.hole,
                "order": g.order, "met": self.met, "time_s": None if self.time is None else round(self.time, 4),
                "in_order": self.in_order, "passes_s": [round(t, 4) for t in self.passes]}


def _tip_in_target(design: Design, goal: Goal, times: np.ndarray, poses: np.ndarray) -> np.ndarray:
    idx = design.panel_index()
    a, b = idx[goal.panel], idx[goal.target]
    tip = np.array([goal.tip[0], goal.tip[1], 0.0, 1.0])
    world = poses[:, a] @ tip  # (n_t, 4)
    inv = np.linalg.inv(poses[:, b])
    return np.einsum("tij,tj->ti", inv, world)[:, :3]


def evaluate_goals(design: Design, times: np.ndarray, poses: np.ndarray) -> list[GoalResult]:
    """Check every goal; a goal is met when its tip passes through its hole and every goal
    with a lower ``order`` was met earlier."""
    raw = []
    for g in design.goals:
        local = _tip_in_target(design, g, times, poses)
        hole = Polygon(design.panel(g.target).holes[g.hole])
        z = local[:, 2]
        passes = []
        for k in np.nonzero(np.sign(z[1:]) != np.sign(z[:-1]))[0]:
            if z[k] == 0 and z[k + 1] == 0:
                continue
            f = z[k] / (z[k] - z[k + 1])
            xy = local[k, :2] + f * (local[k + 1, :2] - local[k, :2])
            if hole.contains(Point(xy)):
                passes.append(float(times[k] + f * (times[k + 1] - times[k])))
        raw.append((g, passes))
    out = []
    for g, passes in raw:
        t = passes[0] if passes else None
        in_order = t is not None
        for g2, p2 in raw:
            if g2.order < g.order and (not p2 or (t is not None and p2[0] > t)):
                in_order = False
        out.append(GoalResult(g, t is not None and in_order, t, in_order, tuple(passes)))
    return out
