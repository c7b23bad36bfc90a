"""Benchmark: how fast `foldprint assign` evaluates candidates, and how few it needs.

    python benchmarks/bench_assign.py [--candidates 24] [--budget 600]

Prints, in one run on the helix (Mao 2015 Sample 1, 9 hinges, 7 materials: 7^9 ~ 40 M
assignments):

1. candidate assignments evaluated per second on one core and on all cores, with the
   search's screening evaluation (2D index over the fold's own duration) one task at a
   time and in the batches the search maps (``map_tasks``: one message a batch, the
   design's derived data shared), against the baseline a user would write: a loop
   calling ``simulate`` (default method, the design's whole duration) on each
   assignment, measured on the same candidates;
2. evaluations until the search meets its first feasible assignment, and in all, as a
   fraction of 7^9, against random sampling (the feasible share it measures on
   ``--random`` draws).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from foldprint.apps.assign.search import Task, assign, run_task, with_materials
from foldprint.apps.assign.tasks import LocalPool, map_tasks
from foldprint.io.load import load_design
from foldprint.model.materials import default_library
from foldprint.core.modes import Method
from foldprint.core.parallel import default_workers, map_ordered
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.simulate import simulate
from foldprint.io.templates import resolve_design_path


def _naive(args):
    design, mats = args
    return simulate(with_materials(design, mats)).completed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--candidates", type=int, default=24, help="random assignments timed per mode")
    ap.add_argument("--random", type=int, default=48, help="random draws for the feasible share")
    ap.add_argument("--budget", type=int, default=600)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()

    lib = default_library()
    d = load_design(resolve_design_path("helix_uniform"), lib)
    names = lib.names("hinge")
    rng = np.random.default_rng(a.seed)
    cands = [tuple(rng.choice(names, len(d.hinges))) for _ in range(a.candidates)]
    ft = {m: recovery_curve(lib[m], 90.0, 0.8, 10.0).time_to(0.98) for m in names}
    tasks = [Task(d, lib, c, 90.0, Method.INDEX2D, 0.01, min(d.process.duration_s, max(ft[m] for m in c) + 0.5), 0)
             for c in cands]
    cores = default_workers()
    print(f"helix_uniform: {len(d.hinges)} hinges, {len(names)} materials, space {len(names) ** len(d.hinges)}, "
          f"{cores} cores")
    run_task(tasks[0])  # this process's kernels and the design's derived data, before any row is timed
    _naive((d, cands[0]))
    rows = []
    for label, fn, items in (("baseline: simulate() loop", _naive, [(d, c) for c in cands]),
                             ("assign screening, one a task", run_task, tasks),
                             ("assign screening, batched", None, tasks)):
        for w in (1, cores):
            t0 = time.perf_counter()
            if fn is None:
                pool = LocalPool(w)
                map_tasks(pool, items)
                pool.close()
            else:
                map_ordered(fn, items, workers=w)
            dt = time.perf_counter() - t0
            rows.append((label, w, len(items) / dt))
            print(f"  {label:<30} {w} core(s): {len(items) / dt:6.2f} candidates/s")
    base1, ours1, oursn, batch1 = rows[0][2], rows[2][2], rows[3][2], rows[4][2]
    print(f"  screening vs baseline on one core: x{ours1 / base1:.2f}; all cores vs one: x{oursn / ours1:.2f}; "
          f"batched vs one a task on one core: x{batch1 / ours1:.2f}")

    # random sampling: the feasible share (a brute-force search's hit rate)
    draws = [tuple(rng.choice(names, len(d.hinges))) for _ in range(a.random)]
    ok = sum(map_ordered(_naive, [(d, c) for c in draws]))
    print(f"random sampling: {ok} feasible in {a.random} draws"
          + ("" if ok else f" (a brute-force search expects > {a.random} evaluations per feasible one)"))

    t0 = time.perf_counter()
    r = assign(d, library=lib, objective="time", budget=a.budget)
    dt = time.perf_counter() - t0
    space = r.search_space
    print(f"assign --objective time --budget {a.budget}: {r.evaluated} evaluations ({r.evaluated / space:.2e} of 7^9) "
          f"in {dt:.1f} s, first feasible at evaluation {r.first_feasible_at} "
          f"({(r.first_feasible_at or 0) / space:.2e} of 7^9), {r.feasible} feasible, "
          f"{r.confirmed} confirmed in 3D, {r.patterns} feasible fold orders")


if __name__ == "__main__":
    main()
