"""Continuous inverse design: choose every hinge's glass transition (its
VeroWhite fraction) and the bath temperature directly, for the lowest jam probability
under scatter (``foldprint assign DESIGN --continuous``, ``docs/assign.md``).

The seven-grade search (:mod:`foldprint.apps.assign.search`) maps fold orders onto seven fixed
materials; here the materials are a continuum, so the search splits what the geometry
decides from what the timing decides:

1. **Fold order (geometry, simulated).** A best-first search over chains grows the
   folded region one hinge at a time (the first hinge any, each next one touching the
   hinges already placed), every prefix simulated with the later hinges held flat and the
   ``k``-th hinge of the chain at the ``k``-th of ``n`` evenly spaced Tg levels; a prefix
   that collides is not extended (the prune of the seven-grade search). Each step is also
   folded with its last two hinges swapped; a step whose swap collides is *critical*, and
   prefixes with fewer critical steps are expanded first (:func:`find_chains`). It stops
   after :data:`ORDER_CHAINS` complete feasible chains.
2. **Levels and bath (timing, no simulation).** For a chain, the surrogate of the jam
   probability is the signed order risk (:func:`chain_risk`): the expected number of hinge
   pairs whose order of half recovery scatter reverses against the chain, plus the chance
   that a hinge misses 98 % within the run, weighted by the number of pairs (the terms of
   :func:`foldprint.simulation.timing.order_risk`, with the variances of the same
   linearised scatter model). It is smooth in the Tg levels: they are optimised with
   L-BFGS-B on a cubic spline of a timing table computed in one array pass per bath
   (:func:`timing_table`); the bath by a coarse grid and a golden-section refinement.
3. **Confirm with the record.** Each candidate (chain x optimised levels, at the
   optimised bath, at the next warmer bath of the coarse grid and at the design's own) is
   confirmed by the simulation of record (3D
   swept check, every goal), screened with :data:`SCREEN_SAMPLES` Monte-Carlo folds and
   the :data:`FINALISTS` best get the full ``samples`` estimate, all under the same seed
   (common random numbers), exactly the estimate ``foldprint robust --samples N --seed S``
   makes of the written design.

Evaluations are counted as :func:`foldprint.apps.assign.search.assign` counts them: every
nominal simulation (prefixes, confirmations) in ``evaluated``; Monte-Carlo folds in
``robust_simulations``.

This module is the search (steps 1 and 3); the timing side of step 2 (materials of any
Tg, the timing table, the surrogate and its optimisers) is in
:mod:`foldprint.apps.assign.surrogate`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from ...core.errors import DesignError
from ...core.modes import Method, Objective, parse
from ...model.design import Design
from ...model.composition import composition_model, parse_name
from ...model.materials import MaterialLibrary, default_library
from ...simulation.robust import Scatter, default_scatter, draw_samples
from ...collision.clearance import permanent_crossings
from .search import PREFIX_CLEARANCE_SAMPLES
from .ledger import Ledger
from .waves import hinge_adjacency
from .result import AssignResult, Choice
from .surrogate import (BATH_STEP_C, BATH_TOL_C, canonical_tg, material_name, optimise_bath,
                               optimise_levels, tg_bounds, timing_table)
from .tasks import (SCREEN_TAIL_S, Mapper, Task, jam_estimates, local_mapper, map_tasks,  # noqa: F401
                    with_local_pool, with_materials)

#: Spacing (C) of the Tg grid of the timing table the surrogate interpolates.
TG_GRID_STEP_C = 0.5
#: The timing table's curves run to this multiple of the design's duration (a hinge that
#: has not reached 98 % by then misses the run whatever the scatter).
TABLE_HORIZON_FACTOR = 2.0
#: Order search: prefixes expanded per round, complete chains wanted.
ORDER_BEAM = 3
ORDER_CHAINS = 4
#: Monte-Carlo folds per candidate in the screen, and candidates given the full estimate.
SCREEN_SAMPLES = 16
FINALISTS = 4
#: Default budget of nominal simulations.
DEFAULT_BUDGET = 120


# -- the search --------------------------------------------------------------------------------


@dataclass(frozen=True)
class ContinuousResult(AssignResult):
    """:class:`~foldprint.apps.assign.search.AssignResult` of a continuous search: the search space
    is a continuum (``search_space`` inf, None in JSON); ``chains`` the feasible fold orders
    found, ``candidates`` every (chain, bath, levels, surrogate risk) confirmed;
    ``surrogate_baths`` the (bath, risk) pairs the bath search tried."""

    chains: tuple[tuple[int, ...], ...] = ()
    candidates: tuple[dict, ...] = ()
    surrogate_baths: tuple[tuple[float, float], ...] = ()

    def to_json(self) -> dict:
        out = super().to_json()
        model = composition_model()
        out.update(search_space=None, evaluated_fraction=None, continuous=True,
                   chains=[[self.design.hinges[k].id for k in c] for c in self.chains],
                   candidates=list(self.candidates),
                   surrogate_baths=[[round(b, 3), round(r, 4)] for b, r in self.surrogate_baths])
        for c, js in zip(self.best, out["best"]):
            tgs = [canonical_tg(model.tg_c(parse_name(m).knots[0])) for m in c.materials]
            js["tg_c"] = {h.id: round(t, 3) for h, t in zip(self.design.hinges, tgs)}
            js["vero_fraction"] = {h.id: parse_name(m).knots[0] for h, m in zip(self.design.hinges, c.materials)}
        return out


def _levels_for(chain: Sequence[int], n: int, tgs: Sequence[float]) -> tuple[str, ...]:
    """Per hinge the material of its place in ``chain`` (hinge ``chain[k]`` gets ``tgs[k]``)."""
    out = [None] * n
    for k, h in enumerate(chain):
        out[h] = material_name(tgs[k])
    return tuple(out)


def find_chains(design: Design, lib: MaterialLibrary, ledger: Ledger, bath_c: float, dt: float, cap: int,
                want: int = ORDER_CHAINS, beam: int = ORDER_BEAM) -> list[tuple[tuple[int, ...], int, float]]:
    """Feasible fold orders (chains of single hinges) of ``design`` at ``bath_c``, with the
    number of their steps that scatter could undo and their clearance.

    Prefixes are simulated with the ``k``-th hinge of a chain at the ``k``-th of ``n``
    evenly spaced supported Tg levels and later hinges held flat; a colliding prefix is
    never extended; the children of a prefix are the hinges touching those placed (any
    hinge first). Each child is also folded with its last two hinges swapped (the swap
    scatter makes most often): a step whose swap collides is *critical*. Best first with
    backtracking: every feasible prefix stays queued, each round expands the ``beam`` with
    most hinges placed, then fewest critical steps, then widest clearance along their
    motion. Returns up to ``want`` complete chains as (chain,
    critical steps, clearance), best first; stops at ``want`` chains or ``cap`` evaluations."""
    n = len(design.hinges)
    lo, hi = tg_bounds()
    levels = np.linspace(lo, hi, n)
    method = Method.INDEX2D if design.is_planar_strip else Method.FCL
    duration = float(design.process.duration_s)
    thick = min(h.thickness for h in design.hinges)
    from ...physics.recovery.curve import recovery_curve

    ft = {}
    for tg in levels:
        name = material_name(tg)
        ft[name] = recovery_curve(lib[name], bath_c, thick, design.process.fix_temperature_c).fold_time
    graph = hinge_adjacency(design)

    def task(chain):
        mats = _levels_for(chain, n, levels)
        active = [ft[m] for m in mats if m is not None]
        dur = duration if any(x is None for x in active) else min(duration, max(active) + SCREEN_TAIL_S)
        return Task(design, lib, mats, float(bath_c), method, dt, dur, PREFIX_CLEARANCE_SAMPLES)

    queue: list[tuple[tuple[int, ...], int, float]] = [((), 0, math.inf)]
    done: list[tuple[tuple[int, ...], int, float]] = []
    while queue and len(done) < want and ledger.evaluated < cap:
        queue.sort(key=lambda x: (-len(x[0]), x[1], -x[2], x[0]))
        batch, queue = queue[:beam], queue[beam:]
        children = []
        for chain, crit, _clear in batch:
            placed = set(chain)
            for k in range(n):
                if k not in placed and (not placed or graph[k] & placed):
                    nc = chain + (k,)
                    swapped = nc[:-2] + (nc[-1], nc[-2]) if len(nc) >= 2 else None
                    children.append((nc, crit, swapped))
        tasks = [task(c) for c, _k, _s in children] + [task(s) for _c, _k, s in children if s is not None]
        verdicts = ledger.run(tasks, cap=cap)
        by_task = dict(zip((t.materials for t in tasks), verdicts))
        for nc, crit, swapped in children:
            v = by_task[task(nc).materials]
            if v is None or not v.completed:
                continue
            sv = by_task[task(swapped).materials] if swapped is not None else v
            if sv is None:
                continue  # beyond the budget: the step's swap was not tested
            crit += not sv.completed
            clear = v.clearance_mm if v.clearance_mm is not None else math.inf
            (done if len(nc) == n else queue).append((nc, crit, clear))
    done.sort(key=lambda x: (x[1], -x[2], x[0]))
    return done[:want]


@with_local_pool
def assign_continuous(design: Design, *, library: MaterialLibrary | None = None,
                      bath_range: tuple[float, float] | None = None, top: int = 3, budget: int = DEFAULT_BUDGET,
                      samples: int = 40, seed: int = 0, scatter: Scatter | None = None, dt: float = 0.01,
                      mapper: Mapper | None = None, workers: int | None = None,
                      progress: Callable[[int, int], None] | None = None) -> ContinuousResult:
    """Choose every hinge's VeroWhite fraction (its Tg) and the bath in ``bath_range``
    (default: the design's bath) for the lowest jam probability (module docstring)."""
    lib = library or default_library()
    scatter = scatter or default_scatter()
    if top < 1 or budget < 1:
        raise DesignError("top and budget must be >= 1")
    b0 = float(design.process.bath_temperature_c)
    blo, bhi = (b0, b0) if bath_range is None else (float(bath_range[0]), float(bath_range[1]))
    if not (math.isfinite(blo) and math.isfinite(bhi)) or bhi < blo:
        raise DesignError(f"--temperature-range: need LO <= HI, got {blo:g} {bhi:g}")
    mapper = mapper or local_mapper(workers)
    ledger = Ledger(mapper, budget, progress)

    def result(best=(), chains=(), confirmed=0, robust_sims=0, cands=(), baths=(), blocked=False):
        blocking = sorted([("pair", p, c) for p, c in ledger.pairs.items()] +
                          [("goal", g, c) for g, c in ledger.goals.items()], key=lambda x: (-x[2], str(x[1])))
        mats = tuple(sorted({m for c in best for m in c.materials}))
        temps = tuple(sorted({c.bath_c for c in best})) or (blo,)
        return ContinuousResult(design, Objective.ROBUST, mats, temps, ledger.evaluated, math.inf, len(chains),
                                tuple(best), tuple(blocking), ledger.first_feasible_at, len(chains), blocked,
                                confirmed, False, robust_sims, tuple(tuple(c) for c in chains), tuple(cands),
                                tuple(baths))

    crossing = permanent_crossings(design)
    if crossing:
        for p in crossing:
            ledger.pairs[tuple(p)] = ledger.pairs.get(tuple(p), 0) + 1
        return result(blocked=True)
    b_ref = min(max(b0, blo), bhi)
    # 1. fold orders, simulated (at most half the budget; the rest confirms candidates)
    found = find_chains(design, lib, ledger, b_ref, dt, cap=max(1, budget - 2 * ORDER_CHAINS))
    chains = [c for c, _k, _cl in found]
    critical = {c: k for c, k, _cl in found}
    if not chains:
        return result()
    # 2. levels and bath from the surrogate (no simulation)
    cands, tried = _surrogate_candidates(design, lib, scatter, chains, (blo, bhi))
    # 3. confirm with the simulation of record (3D, every goal, whole duration, clearance)
    duration = float(design.process.duration_s)
    confirmed = ledger.run([Task(design, lib, mats, lv.bath_c, Method.FCL, dt, duration, 200)
                            for _c, lv, mats in cands])
    good = []
    for (chain, lv, mats), v in zip(cands, confirmed):
        if v is not None and v.completed:
            clear = None if v.clearance_mm is None or math.isinf(v.clearance_mm) else v.clearance_mm
            good.append((chain, lv, Choice(mats, lv.bath_c, v.fold_time, clear, tuple((k,) for k in chain))))
    # 4. a short Monte-Carlo screen when there are many, then the full estimate
    good, n_screen = _screen(design, lib, scatter, good, samples, seed, dt, top, mapper, progress)
    out = _estimate(design, lib, scatter, good, samples, seed, dt, mapper)
    cand_json = [{"waves": [[design.hinges[k].id] for k in chain], "temperature_c": round(lv.bath_c, 3),
                  "tg_c": [round(canonical_tg(t), 3) for t in lv.tg_c], "surrogate_risk": round(lv.risk, 4),
                  "critical_steps": critical[chain],
                  "confirmed": bool(v is not None and v.completed)}
                 for (chain, lv, _m), v in zip(cands, confirmed)]
    baths = sorted((b, lv.risk) for b, lv in tried.items())
    return result(out[:top], chains, sum(v is not None and v.completed for v in confirmed),
                  n_screen + samples * len(good), cand_json, baths)


def _surrogate_candidates(design: Design, lib: MaterialLibrary, scatter: Scatter, chains: list,
                          bath_range: tuple[float, float]) -> tuple[list, dict]:
    """Per fold order, the Tg levels and bath the surrogate chooses (no simulation): its
    best bath, the next warmer bath of the coarse grid (the linearised scatter model
    underrates the tail of the slowest hinge's time, docs/assign.md) and the design's own
    bath; the Monte-Carlo decides between them. Returns the candidates (chain, levels,
    materials) and every bath the surrogate tried."""
    blo, bhi = bath_range
    b0 = float(design.process.bath_temperature_c)
    n = len(design.hinges)
    lo, hi = tg_bounds()
    duration = float(design.process.duration_s)
    log_dur = math.log(duration)
    fix_c = float(design.process.fix_temperature_c)
    grid = np.arange(lo, hi + 1e-9, TG_GRID_STEP_C)
    if grid[-1] < hi - 1e-9:
        grid = np.append(grid, hi)
    tables: dict = {}

    def table(b, th):
        key = (round(b, 3), th)
        if key not in tables:
            tables[key] = timing_table(lib, b, th, fix_c, scatter, grid, TABLE_HORIZON_FACTOR * duration)
        return tables[key]

    thick = {round(h.thickness, 6) for h in design.hinges}
    if len(thick) > 1:
        raise DesignError(f"{design.name}: --continuous needs hinges of one thickness (the surrogate's "
                          f"timing table), got {sorted(thick)} mm")
    th = thick.pop()
    best_lv, tried = optimise_bath(lambda b: table(b, th), n, lo, hi, log_dur, blo, bhi)
    warmer = sorted(b for b in tried if b > best_lv.bath_c + BATH_TOL_C)
    options = [best_lv] + ([tried[min(warmer, key=lambda b: (abs(b - best_lv.bath_c - BATH_STEP_C), b))]]
                           if warmer else [])
    if blo <= b0 <= bhi and all(abs(lv.bath_c - b0) > 1e-9 for lv in options):
        options.append(tried.get(round(b0, 3)) or optimise_levels(table(b0, th), n, lo, hi, log_dur))
    cands = [(chain, lv, _levels_for(chain, n, lv.tg_c)) for lv in options for chain in chains]
    return cands, tried


def _screen(design: Design, lib: MaterialLibrary, scatter: Scatter, good: list, samples: int, seed: int,
            dt: float, top: int, mapper: Mapper, progress) -> tuple[list, int]:
    """When more candidates confirm than the finalists, the ones that jam least in a short
    Monte-Carlo (then lowest surrogate risk); and the folds that took."""
    if len(good) <= max(FINALISTS, top):
        return good, 0
    duration = float(design.process.duration_s)
    method = Method.INDEX2D if design.is_planar_strip else Method.FCL
    n_s = min(samples, SCREEN_SAMPLES)
    tasks = []
    for _chain, lv, c in good:
        for smp in draw_samples(with_materials(design, c.materials, c.bath_c), scatter, n_s, seed):
            tasks.append(Task(design, lib, c.materials, c.bath_c, method, dt, duration, 0, smp))
    verdicts = map_tasks(mapper, tasks, progress, group=n_s)
    jams = [sum(not v.completed for v in verdicts[j * n_s:(j + 1) * n_s]) for j in range(len(good))]
    order = sorted(range(len(good)), key=lambda j: (jams[j], good[j][1].risk, j))
    return [good[j] for j in order[:max(FINALISTS, top)]], len(tasks)


def _estimate(design: Design, lib: MaterialLibrary, scatter: Scatter, good: list, samples: int, seed: int,
              dt: float, mapper: Mapper) -> list:
    """The finalists with their jam probability: the draws and folds of ``foldprint robust
    --samples N --seed S``, best first (then surrogate risk, clearance, fold time)."""
    out = jam_estimates(design, lib, scatter, [c for _ch, _lv, c in good], samples, seed, dt, mapper)
    risk = {c.materials: lv.risk for _ch, lv, c in good}
    out.sort(key=lambda c: (c.jam_probability, risk[c.materials], -(c.clearance_mm or 0), c.fold_time, c.materials))
    return out


def continuous_objective(objective: Objective | str, materials: Sequence[str] | None = None,
                         fixed: dict | None = None) -> Objective:
    """The objective of a continuous search (``Objective.ROBUST``), refusing the ``foldprint
    assign`` options that do not apply to it (``objective`` ``TIME`` is the CLI's default)."""
    if materials:
        raise DesignError("--materials does not apply to --continuous: it chooses every hinge's VeroWhite "
                          "fraction in the supported range (docs/composition.md)")
    if fixed:
        raise DesignError("--fixed does not apply to --continuous (every hinge's fraction is chosen); "
                          "drop --fixed or drop --continuous")
    objective = parse(Objective, objective, "--objective")
    if objective not in (Objective.TIME, Objective.ROBUST):
        raise DesignError(f"--continuous ranks by jam probability (robust); --objective {objective} "
                          "does not apply to it")
    return Objective.ROBUST


def search_options(design: Design, *, materials: Sequence[str] | None = None,
                   temperatures: Sequence[float] | None = None, fixed: dict | None = None,
                   objective: Objective | str = Objective.ROBUST,
                   **kwargs) -> ContinuousResult:
    """:func:`assign_continuous` called with the options of ``foldprint assign`` (the bath
    range spans ``temperatures``; :func:`continuous_objective` refuses the others)."""
    continuous_objective(objective, materials, fixed)
    rng = None if not temperatures else (min(temperatures), max(temperatures))
    return assign_continuous(design, bath_range=rng, **kwargs)
