"""Inverse design: choose the hinge materials (and the bath temperature) under which the
printed part folds, fast or with the widest margin or most robustly.

The search uses the physics instead of enumerating the m^n assignments
(``docs/assign.md``):

1. **Fold order is what matters.** Materials are ranked by their fold time in the bath;
   an assignment's *pattern* is the sequence of *waves* (groups of hinges sharing a
   rank), fastest first. Phase 1 searches patterns, each wave ``i`` played by the
   ``i``-th fastest material.
2. **A collision found for a partial order prunes its completions.** A prefix (the first
   waves) is simulated with every later hinge held in its programmed shape. Until the
   next material's onset this is the real motion of every completion, so a prefix that
   collides is never extended. Waves are connected groups of hinges (sharing panels) or
   "all the rest"; the search is best first (most hinges placed, then the widest
   clearance), expanding ``beam`` prefixes per round.
3. **Near-equivalent assignments share a pattern.** Phase 2 maps each feasible pattern
   onto the materials (increasing ranks, at each bath temperature of the range),
   evaluating the mappings the objective prefers first, within a budget.
4. **Screen cheap, confirm exact.** Planar strips are screened with the paper's 2D index
   over the fold's own duration; the finalists are confirmed by the full simulation of
   record (3D swept FCL check of the printed, arc-hinge geometry, every goal in order)
   and their smallest clearance along the fold is measured. ``robust`` grows many small
   waves in phase 1, ranks the screened assignments by a timing proxy (:func:`order_risk`),
   screens the best under scatter and estimates the jam probability of the finalists.

Every evaluation is a module-level function of a picklable task, run by a ``mapper``
(local processes by default, a Dask cluster with :mod:`foldprint.apps.distributed`); the
results come back in input order, so the answer does not depend on where it ran.

This module is the search; the tasks and their mappers are in
:mod:`foldprint.apps.assign.tasks`, what it reports (verdicts, choices, the result and its
JSON) in :mod:`foldprint.apps.assign.result`. Their names still import from here. The
waves a pattern is made of are in :mod:`foldprint.apps.assign.waves`, the ledger of
evaluations in :mod:`foldprint.apps.assign.ledger`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from typing import Callable, Mapping, Sequence

import numpy as np

from ...collision.clearance import permanent_crossings  # noqa: F401 (re-export)
from ...core.constants import CLEARANCE_SAMPLES
from ...model.design import Design
from ...core.constants import ASSIGN_BUDGET, ASSIGN_SAMPLES, ASSIGN_TOP, DEFAULT_DT_S, DEFAULT_SEED
from ...core.errors import DesignError
from ...model.materials import MaterialLibrary, default_library
from ...core.modes import DEFAULT_OBJECTIVE, Method, Objective, parse
from ...physics.recovery.curve import recovery_curve
from ...simulation.robust import Scatter, default_scatter, draw_samples
from ...simulation.timing import order_risk
# the results and the tasks, importable from here as before
from .result import AssignResult, Choice, Verdict, choice_from  # noqa: F401
from .tasks import (SCREEN_TAIL_S, Mapper, Task, jam_estimates, local_mapper, map_tasks, run_task,  # noqa: F401
                    warm_workers, with_local_pool, with_materials)
from .ledger import Ledger
from .waves import connected_waves, growing_waves, hinge_adjacency

#: The objectives' names (the values of :class:`~foldprint.core.modes.Objective`).
OBJECTIVES = tuple(o.value for o in Objective)
#: Evaluations (simulations) the search may spend by default.
DEFAULT_BUDGET = ASSIGN_BUDGET
#: Prefixes expanded per round of the best-first pattern search.
DEFAULT_BEAM = 6
#: Share of the budget the pattern search (phase 1) may spend; the rest maps patterns
#: onto materials and confirms the finalists.
PHASE1_SHARE = 0.5
#: ``robust``: the ROBUST_POOL (or 3 top) screened-feasible assignments of lowest
#: :func:`order_risk` are folded ROBUST_SCREEN_SAMPLES times each under scatter with the
#: cheap screen; the ROBUST_FINALISTS (or ``top + 2``) with the fewest jams are confirmed
#: and get ``samples`` folds of the printed part each (the batch Monte-Carlo made these
#: cheap: 12 finalists x 60 samples cost what 5 x 60 cost on the per-curve path).
ROBUST_POOL = 48
ROBUST_SCREEN_SAMPLES = 16
ROBUST_FINALISTS = 12
#: Search spaces up to this size (and within the budget) are enumerated outright.
EXHAUSTIVE_MAX = 128
#: Material mappings tried per feasible pattern in phase 2.
PER_PATTERN = 6
#: Poses sampled along a fold for the clearance of a prefix (ranking the queue only).
PREFIX_CLEARANCE_SAMPLES = 24
#: Bath temperatures tried across a ``--temperature-range``: every STEP_C, at most MAX_TEMPS.
TEMPERATURE_STEP_C = 5.0
MAX_TEMPS = 9


# -- the search -------------------------------------------------------------------------


def temperature_grid(lo: float, hi: float) -> tuple[float, ...]:
    """Bath temperatures tried across a range: every TEMPERATURE_STEP_C, ends included."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
        raise DesignError(f"--temperature-range: need LO <= HI, got {lo} {hi}")
    n = min(MAX_TEMPS, max(1, int(math.floor((hi - lo) / TEMPERATURE_STEP_C + 1e-9)) + 1))
    if n == 1:
        return (float(lo),) if hi == lo else (float(lo), float(hi))
    return tuple(float(x) for x in np.linspace(lo, hi, n if (hi - lo) / (n - 1) <= TEMPERATURE_STEP_C else n + 1))


def _fold_times(design: Design, lib: MaterialLibrary, mats: Sequence[str], bath_c: float) -> dict[str, float | None]:
    thick = min(h.thickness for h in design.hinges)
    return {m: recovery_curve(lib[m], bath_c, thick, design.process.fix_temperature_c).fold_time for m in mats}


def _check_request(design: Design, lib: MaterialLibrary, materials: Sequence[str] | None,
                   fixed: Mapping[str, str] | None, top: int, budget: int,
                   beam: int) -> tuple[list[str], dict[str, str]]:
    """The materials to choose from and the fixed hinges, checked (DesignError naming the
    option and what to give instead)."""
    if top < 1 or budget < 1 or beam < 1:
        raise DesignError("top, budget and beam must be >= 1")
    hinge_names = lib.names("hinge")
    mats = list(dict.fromkeys(materials)) if materials else hinge_names
    for m in mats:
        if m not in hinge_names:
            raise DesignError(f"--materials: {m!r} is not a hinge material; hinge materials: "
                              f"{', '.join(hinge_names)}")
    fixed = dict(fixed or {})
    ids = [h.id for h in design.hinges]
    for hid, m in fixed.items():
        if hid not in ids:
            raise DesignError(f"--fixed {hid}={m}: no hinge {hid!r}; hinges: {', '.join(ids)}")
        if m not in hinge_names:
            raise DesignError(f"--fixed {hid}={m}: {m!r} is not a hinge material of the library")
    return mats, fixed


class _Search:
    """The state of one :func:`assign` run: the request, the ledger of evaluations and
    the helpers that turn fold orders into tasks (the module docstring's phases)."""

    def __init__(self, design: Design, lib: MaterialLibrary, mats: list[str], temps: tuple[float, ...],
                 fixed: dict[str, str], objective: Objective, top: int, budget: int, beam: int, dt: float,
                 ledger: "Ledger"):
        self.design, self.lib, self.mats, self.temps = design, lib, mats, temps
        self.objective, self.top, self.budget, self.beam, self.dt, self.ledger = objective, top, budget, beam, dt, ledger
        ids = [h.id for h in design.hinges]
        self.fixed_idx = {ids.index(h): m for h, m in fixed.items()}
        self.free = [k for k, h in enumerate(design.hinges) if h.id not in fixed]
        self.space = len(mats) ** len(self.free) * len(temps)
        self.n_confirm = max(1, min(max(4 * top, 12), budget // 5) if objective is Objective.TIME
                             else min(max(8 * top, 24), budget // 3))
        # a space this small is cheaper to try outright than to search: exact within the budget
        self.exhaustive = self.space <= min(EXHAUSTIVE_MAX, budget - self.n_confirm)
        self.duration = float(design.process.duration_s)
        self.method = Method.INDEX2D if design.is_planar_strip else Method.FCL

    def result(self, best=(), feasible=0, patterns=0, blocked=False, confirmed=0, robust_sims=0) -> "AssignResult":
        led = self.ledger
        blocking = sorted([("pair", p, n) for p, n in led.pairs.items()] +
                          [("goal", g, n) for g, n in led.goals.items()], key=lambda x: (-x[2], str(x[1])))
        return AssignResult(self.design, self.objective, tuple(self.mats), self.temps, led.evaluated, self.space,
                            feasible, tuple(best), tuple(blocking), led.first_feasible_at, patterns, blocked,
                            confirmed, self.exhaustive, robust_sims)

    def usable(self, t: float) -> tuple[list[str], dict]:
        """The materials that fold within the run at bath ``t``, fastest first, and their fold times."""
        ft = _fold_times(self.design, self.lib, self.mats, t)
        ok = [m for m in self.mats if ft[m] is not None and ft[m] <= self.duration]
        return sorted(ok, key=lambda m: (ft[m], m)), ft

    def screen_duration(self, active: Sequence[str], ft: dict) -> float:
        times = [ft[m] for m in active if ft.get(m) is not None]
        if len(times) < len(active) or not times:
            return self.duration
        return min(self.duration, max(times) + SCREEN_TAIL_S)

    def materials_for(self, waves: Sequence[frozenset], ranks: Sequence[int], order: list[str], complete: bool):
        out: list[str | None] = [None] * len(self.design.hinges)
        last = ranks[len(waves) - 1] if waves else -1
        for w, r in zip(waves, ranks):
            for k in w:
                out[k] = order[r]
        for k, m in self.fixed_idx.items():
            r = order.index(m) if m in order else len(order)
            if complete or r <= last:
                out[k] = m
        return tuple(out)

    def task(self, mat_tuple, t, ft, clearance=0, confirm=False) -> Task:
        active = [m for m in mat_tuple if m is not None]
        dur = self.duration if confirm else self.screen_duration(active, ft)
        return Task(self.design, self.lib, mat_tuple, t, Method.FCL if confirm else self.method, self.dt, dur,
                    clearance)

    def warm_tasks(self, ranked: list[str], ft: dict, t: float, scatter: Scatter, seed: int) -> list[Task]:
        """A task of each kind the search maps (:func:`warm_workers`): the fastest material
        everywhere, screened with a prefix's clearance, folded in 3D, and one scatter draw
        (``robust``)."""
        mt = self.materials_for((frozenset(self.free),), [0], ranked, True)
        out = [self.task(mt, t, ft, PREFIX_CLEARANCE_SAMPLES), replace(self.task(mt, t, ft), method=Method.FCL)]
        if self.objective is Objective.ROBUST:
            draw = draw_samples(with_materials(self.design, mt, t, self.lib), scatter, 1, seed)[0]
            out.append(replace(self.task(mt, t, ft), duration=self.duration, sample=draw))
        return out

    def patterns(self, ranked: list[str], ft_ref: dict, t_ref: float) -> list[tuple[frozenset, ...]]:
        """Phase 1: the feasible patterns (waves of hinges), wave i played by the i-th
        fastest material; best first: a queue of every collision-free prefix, each round
        expanding the ``beam`` best (most hinges placed, then the widest clearance so far)."""
        graph = hinge_adjacency(self.design)
        all_free = frozenset(self.free)
        patterns: list[tuple[frozenset, ...]] = [] if self.free else [()]
        m = len(ranked)
        phase1 = int(self.budget * PHASE1_SHARE)
        queue: list = [] if self.exhaustive or not self.free else [((0, 0, -math.inf, ()), ())]
        while queue and self.ledger.evaluated < phase1:
            queue.sort(key=lambda x: x[0])
            batch, queue = queue[:self.beam], queue[self.beam:]
            children = []
            for _key, waves in batch:
                rest = all_free - frozenset().union(*waves) if waves else all_free
                if len(waves) == m - 1:
                    options = [rest]
                elif self.objective is Objective.ROBUST:
                    options = growing_waves(rest, all_free - rest, graph)
                else:
                    options = connected_waves(rest, graph)
                for w in options:
                    nw = waves + (w,)
                    complete = w == rest
                    mt = self.materials_for(nw, list(range(len(nw))), ranked, complete)
                    clear = 0 if complete else PREFIX_CLEARANCE_SAMPLES
                    children.append((nw, complete, self.task(mt, t_ref, ft_ref, clear)))
            verdicts = self.ledger.run([c[2] for c in children], cap=phase1)
            for (nw, complete, _t), v in zip(children, verdicts):
                if v is None or not v.completed:
                    continue
                if complete:
                    patterns.append(nw)
                    continue
                clear = v.clearance_mm if v.clearance_mm is not None else math.inf
                placed = -sum(map(len, nw))
                # robust: scatter reorders hinges that share a wave, so the most waves first
                key = ((-len(nw), placed, -clear) if self.objective is Objective.ROBUST else (placed, -clear, len(nw)))
                queue.append(((*key, [sorted(w) for w in nw]), nw))
        return patterns

    def _exhaustive_candidates(self, t: float, order: list[str], ft: dict) -> list:
        out = []
        rank = {mname: i for i, mname in enumerate(order)}
        for combo in itertools.product(self.mats, repeat=len(self.free)):
            mt = [self.fixed_idx.get(k) for k in range(len(self.design.hinges))]
            for k, mname in zip(self.free, combo):
                mt[k] = mname
            if any(x not in rank for x in combo):
                continue  # a material that does not fold in time at t
            levels = sorted({rank[x] for x in combo})
            pat = tuple(frozenset(k for k, x in zip(self.free, combo) if rank[x] == lv) for lv in levels)
            out.append((pat, None, t, tuple(mt), ft))
        return out

    def candidates(self, patterns: list[tuple[frozenset, ...]]) -> list:
        """Phase 2: the feasible patterns mapped onto materials (and temperatures):
        (pattern, ranks, bath, materials, fold times) in the order to evaluate them."""
        candidates = []
        for t in self.temps:
            order, ft = self.usable(t)
            if self.exhaustive:
                candidates += self._exhaustive_candidates(t, order, ft)
                continue
            for pat in patterns:
                k = len(pat)
                if k > len(order):
                    continue
                combos = list(itertools.combinations(range(len(order)), k)) if k else [()]
                if self.objective is Objective.TIME:
                    combos.sort(key=lambda c: (c[-1] if c else 0, sum(c), c))
                else:  # spread the waves: the widest smallest gap between consecutive ranks first
                    combos.sort(key=lambda c: (-min([b - a for a, b in zip(c, c[1:])] or [0]), c[-1] if c else 0, c))
                for j, c in enumerate(combos[:PER_PATTERN]):
                    candidates.append((j, pat, c, t, self.materials_for(pat, c, order, True), ft))
        if not self.exhaustive:  # round robin: every pattern's first mapping, then every second one...
            candidates = [c[1:] for c in sorted(candidates, key=lambda c: c[0])]
        return candidates

    def screened(self, candidates: list) -> list:
        """The candidates that fold in the screen, each assignment once (the first pattern
        that gave it): (pattern, bath, materials, verdict)."""
        verdicts = self.ledger.run([self.task(mt, t, ft) for _p, _c, t, mt, ft in candidates],
                                   cap=self.budget - self.n_confirm)
        seen, unique = set(), []
        for (p, _c, t, mt, _ft), v in zip(candidates, verdicts):
            if v is not None and v.completed and (mt, t) not in seen:
                seen.add((mt, t))
                unique.append((p, t, mt, v))
        if self.objective is Objective.TIME:
            unique.sort(key=lambda x: (x[3].fold_time, x[1], x[2]))
        return unique

    def confirm(self, unique: list) -> list["Choice"]:
        """The finalists (``time``, ``margin``) confirmed by the simulation of record, best first."""
        # margin: in screening order (spread mappings first); robust picks its own finalists
        finalists = unique[:self.n_confirm] if self.objective is not Objective.ROBUST else []
        confirmed = self.ledger.run([self.task(mt, t, {}, clearance=CLEARANCE_SAMPLES, confirm=True)
                                     for _p, t, mt, _v in finalists])
        good = [choice_from(p, t, mt, v) for (p, t, mt, _v), v in zip(finalists, confirmed)
                if v is not None and v.completed]
        if self.objective is Objective.TIME:
            good.sort(key=lambda c: (c.fold_time, -(c.clearance_mm or 0), c.materials))
        else:
            good.sort(key=lambda c: (-(c.clearance_mm if c.clearance_mm is not None else math.inf), c.fold_time,
                                     c.materials))
        return good


@with_local_pool
def assign(design: Design, *, library: MaterialLibrary | None = None, materials: Sequence[str] | None = None,
           temperatures: Sequence[float] | None = None, fixed: Mapping[str, str] | None = None,
           objective: Objective | str = DEFAULT_OBJECTIVE, top: int = ASSIGN_TOP, budget: int = DEFAULT_BUDGET, beam: int = DEFAULT_BEAM,
           samples: int = ASSIGN_SAMPLES, seed: int = DEFAULT_SEED, scatter: Scatter | None = None,
           dt: float = DEFAULT_DT_S,
           mapper: Mapper | None = None, workers: int | None = None,
           progress: Callable[[int, int], None] | None = None) -> AssignResult:
    """Search hinge-material assignments of ``design`` (see the module docstring)."""
    from ..pipeline import Evaluation

    objective = parse(Objective, objective, "objective")
    lib = library or default_library()
    mats, fixed = _check_request(design, lib, materials, fixed, top, budget, beam)
    temps = tuple(float(t) for t in (temperatures or [design.process.bath_temperature_c]))
    mapper = mapper or local_mapper(workers)
    s = _Search(design, lib, mats, temps, fixed, objective, top, budget, beam, dt, Ledger(mapper, budget, progress))
    crossing = Evaluation(design, library=lib).printed_crossings
    if crossing:
        for p in crossing:
            s.ledger.pairs[tuple(p)] = s.ledger.pairs.get(tuple(p), 0) + 1
        return s.result(blocked=True)
    t_ref = temps[len(temps) // 2]
    ranked, ft_ref = s.usable(t_ref)
    if not ranked:
        raise DesignError(f"{design.name}: none of {', '.join(mats)} folds within {s.duration:g} s at {t_ref:g} C")
    warm_workers(mapper, lambda: s.warm_tasks(ranked, ft_ref, t_ref, scatter or default_scatter(), seed))
    patterns = s.patterns(ranked, ft_ref, t_ref)
    unique = s.screened(s.candidates(patterns))
    good = s.confirm(unique)
    n_robust, n_confirmed = 0, len(good)
    if objective is Objective.ROBUST and unique:
        good, n_confirmed, n_robust = _robust_finalists(
            design, lib, unique, s.ledger, s.task, top=top, samples=samples, seed=seed,
            scatter=scatter or default_scatter(), method=s.method, dt=dt, duration=s.duration, mapper=mapper,
            progress=progress)
    return s.result(good[:top], len(unique), len(patterns), confirmed=n_confirmed, robust_sims=n_robust)


def _robust_finalists(design, lib, unique, ledger, task, *, top, samples, seed, scatter, method, dt, duration,
                      mapper, progress):
    """The ``robust`` objective: rank screened-feasible assignments by :func:`order_risk`,
    fold the ROBUST_POOL least risky ROBUST_SCREEN_SAMPLES times each under the scatter
    model with the cheap screen (common draws: the same seed for every candidate), confirm
    the ROBUST_FINALISTS (at least ``top + 2``) with the fewest screened jams in the
    simulation of record and estimate their jam probability with ``samples`` folds each
    (the draws and folds of ``foldprint robust --samples N --seed S``, so the estimate
    equals what ``robust`` gives the written design).
    Returns (choices sorted by jam probability, confirmed count, Monte-Carlo folds run)."""
    risk = [order_risk(design, lib, mt, t, scatter) for _p, t, mt, _v in unique]
    order = sorted(range(len(unique)), key=lambda i: (risk[i], i))[: max(3 * top, ROBUST_POOL)]
    n_s = min(samples, ROBUST_SCREEN_SAMPLES)
    tasks = []
    for i in order:
        _p, t, mt, _v = unique[i]
        for smp in draw_samples(with_materials(design, mt, t, lib), scatter, n_s, seed):
            tasks.append(Task(design, lib, mt, t, method, dt, duration, 0, smp))
    verdicts = map_tasks(mapper, tasks, progress, group=n_s)
    jams = {i: sum(not v.completed for v in verdicts[j * n_s:(j + 1) * n_s]) for j, i in enumerate(order)}
    ranked = sorted(order, key=lambda i: (jams[i], risk[i], i))
    n_robust = len(tasks)
    n_final = max(top + 2, ROBUST_FINALISTS)
    picks = ranked[: 2 * n_final]
    confirmed = ledger.run([task(unique[i][2], unique[i][1], {}, clearance=CLEARANCE_SAMPLES, confirm=True)
                          for i in picks])
    good = []
    for i, v in zip(picks, confirmed):
        if v is None or not v.completed or len(good) == n_final:
            continue
        p, t, mt, _v = unique[i]
        good.append(choice_from(p, t, mt, v))
    # every finalist's full estimate in one mapped pass: the same draws (seed) for each
    out = jam_estimates(design, lib, scatter, good, samples, seed, dt, mapper)
    n_robust += samples * len(good)
    out.sort(key=lambda c: (c.jam_probability, -(c.clearance_mm or 0), c.fold_time, c.materials))
    return out, sum(v is not None and v.completed for v in confirmed), n_robust
