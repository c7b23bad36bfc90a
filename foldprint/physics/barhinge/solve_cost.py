"""What a bar-and-hinge run costs (``--mechanics bar-hinge``, :mod:`foldprint.physics.barhinge.equilibrium`),
estimated from the design's size before the model is built, and refused through the guard
(:func:`foldprint.core.guards.enforce`) when over the memory limit or the time budget, or
over :data:`MAX_MECHANICS_NODES`.

The model (``docs/mechanics.md``) has a node at every panel vertex (counted here before
nodes on shared fold lines merge: an upper bound), bars on the edges of each panel's
triangulation and a rotational spring on each interior edge. A panel ring of V vertices
with h holes triangulates into V + 2h - 2 triangles, so (3T + V) / 2 edges, V of them on
its boundary. A run solves the equilibrium at each time of an adaptive grid, a few Newton
iterations each; one iteration assembles the sparse Hessian (36 entries a bar, 144 a
spring) and factorises it.
"""

from __future__ import annotations

from ...core.constants import DEFAULT_DT_S
from ...core.guards import (BASE_BYTES, LIFT_TIME, ResourceError, enforce, fmt_bytes, fmt_seconds, lift_memory_env,
                           source_of)

#: Most panel vertices ``--mechanics bar-hinge`` takes (our choice: a 20 x 20 Miura sheet, 441
#: nodes, folds in ~25 CPU-s; one Newton iteration's sparse solve grows about linearly with
#: the nodes, and a run solves ~2-3 per grid time, ~100-300 grid times)
MAX_MECHANICS_NODES = 5000
#: Newton iterations of a run: benchmarks/bench_barhinge.py measured 253-450 on Miura sheets
#: of 4 x 4 to 20 x 20 panels (105 solved grid times); 500 is that, rounded up
ITERATIONS = 500
#: CPU seconds of one Newton iteration (assembly, factorisation, line search): a fixed part
#: and a part per Hessian entry; fitted to bench_barhinge.json's ms per iteration (4.9 ms at
#: 5,800 entries, 52.8 ms at 211,700: 4.5 ms + 0.23 us an entry, above every row)
S_PER_ITERATION = 4.5e-3
S_PER_ENTRY = 0.23e-6
#: bytes a Hessian entry costs while an iteration holds it: the triplets (8 B value, two
#: 8 B indices), the CSR copy, the free-dof slice and the factor's fill (our choice, 4x the
#: triplets; tests/test_guards_scale.py measures a run's peak under it)
BYTES_PER_ENTRY = 96
#: bytes a node holds per solved grid time (its position, 3 x 8 B, and the strain and angle
#: tables made from them), over the grid times of a run (the 105 of the benchmarks, 3x)
BYTES_PER_NODE_STEP = 48
GRID_TIMES = 320
#: bytes per hinge: its recovery curve on the model's grid (15,400 floats,
#: physics.recovery.curve.curve_time_grid) and, per time of the run, its rest angle, stiffness
#: and log stiffness (3 x 8 B) on the run's times at the default 10 ms step
CURVE_BYTES_PER_HINGE = 15_400 * 8
BYTES_PER_HINGE_STEP = 24


def model_size(design) -> dict:
    """Nodes, bars, springs and Hessian entries of ``design``'s bar-and-hinge model,
    counted from its panels' rings (before shared nodes merge: an upper bound)."""
    nodes = bars = springs = 0.0
    for p in design.panels:
        v = len(p.outline) + sum(len(h) for h in p.holes)
        tri = max(1.0, v + 2 * len(p.holes) - 2.0)
        edges = (3 * tri + v) / 2
        nodes, bars, springs = nodes + v, bars + edges, springs + max(0.0, edges - v)
    springs += sum(1.0 for _ in design.hinges)  # a fold spring at least per hinge
    return {"nodes": nodes, "bars": bars, "springs": springs, "entries": 36 * bars + 144 * springs}


def solve_seconds(model, iterations: float) -> float:
    """CPU seconds of ``iterations`` Newton iterations on a built ``model`` (its bars and
    springs): what a Monte-Carlo sample costs once the nominal fold has counted them."""
    entries = 36.0 * len(model.bars) + 144.0 * len(model.springs)
    return float(iterations) * (S_PER_ITERATION + S_PER_ENTRY * entries)


def mechanics_estimate(design) -> dict:
    """Peak bytes and CPU seconds of a bar-and-hinge run on ``design`` (:func:`model_size`)."""
    size = model_size(design)
    seconds = ITERATIONS * (S_PER_ITERATION + S_PER_ENTRY * size["entries"])
    steps = float(design.process.duration_s) / DEFAULT_DT_S + 2
    per_hinge = CURVE_BYTES_PER_HINGE + BYTES_PER_HINGE_STEP * steps
    nbytes = (BASE_BYTES + BYTES_PER_ENTRY * size["entries"] + BYTES_PER_NODE_STEP * GRID_TIMES * size["nodes"]
              + per_hinge * len(design.hinges))
    return {**size, "bytes": nbytes, "seconds": seconds}


def check_mechanics(design) -> dict:
    """Refuse a bar-and-hinge run on a design with more than :data:`MAX_MECHANICS_NODES`
    panel vertices, or whose estimate (:func:`mechanics_estimate`) is over the memory
    limit or the time budget, before the model is built."""
    est = mechanics_estimate(design)
    what = f"{source_of(design)}--mechanics bar-hinge"
    if est["nodes"] > MAX_MECHANICS_NODES:
        raise ResourceError(f"{what} refused: {est['nodes']:.0f} panel vertices, over the {MAX_MECHANICS_NODES} "
                            "the bar-and-hinge solver takes; use --mechanics rigid or simplify the panels' outlines")
    model = (f"{est['nodes']:.0f} nodes, {est['bars']:.0f} bars and {est['springs']:.0f} springs "
             f"({ITERATIONS} Newton iterations)")
    fix = "use --mechanics rigid or simplify the panels' outlines (fewer vertices and holes)"
    return enforce(est, what, (f"its model of {model} needs about {fmt_bytes(est['bytes'])}",
                               f"{fix}, or {lift_memory_env(est)}"),
                   (f"its model of {model} takes about {fmt_seconds(est['seconds'])}", f"{fix}, or {LIFT_TIME}"))
