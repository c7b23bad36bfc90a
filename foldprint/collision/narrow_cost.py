"""What the 3D swept check's narrow phase holds, estimated once the broad phase has left
its candidate pair runs and before any is stepped, and refused through the guard
(:func:`foldprint.core.guards.enforce`) when it would not fit in the memory limit.

The narrow phase (:func:`foldprint.collision.swept_search.swept_first_contact`) advances every
candidate run together in time: each run open at once holds its stepping generator, its
motion bound on up to 64 samples (Python floats) and, cached per pair, the hinges on the
pair's tree path with one lever each (two lists of Python ints, two float arrays). So
its memory grows with the runs x the length of their tree paths, which the simulation's
estimate (:mod:`foldprint.simulation.costs`, per step and panel) does not see: on a strip
whose every pair is a candidate (a 1000-panel strip folded onto itself: 498,501 runs with
333 hinges between a pair on average) it is n^3.
"""

from __future__ import annotations

import numpy as np

from ..core.guards import BASE_BYTES, enforce, fmt_bytes, held_elsewhere, lift_hint, max_memory, source_of

#: bytes an open run holds whatever its path (generator frame and closure, the heap entry,
#: the motion bound's 64 Python floats, the pair cache's tuple, lists and arrays headers):
#: measured with tracemalloc on coiled strips (every pair a candidate) of 60, 100 and 200
#: panels, 5.1, 2.9 and 2.4 KB a run with everything the phase allocates, our choice
#: between them (tests/test_guards_costs.py)
RUN_BYTES = 4_000
#: bytes per hinge on a run's tree path: a Python int in one of the path lists (8 B
#: pointer, 28 B object) and its entry in the index and lever arrays (2 x 8 B)
PATH_BYTES_PER_HINGE = 56


def path_hinges(tree, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Hinges on the tree path between panels ``i`` and ``j`` (arrays), vectorised."""
    lca = tree.lca(i, j)
    return tree.depth[i] + tree.depth[j] - 2 * tree.depth[lca]


def narrow_estimate(checker, runs: np.ndarray, held: float = 0.0) -> dict:
    """Peak bytes of the narrow phase over ``runs`` (rows i, j, ka, kb), every run open at
    once (an upper bound: a run that starts after the first contact is never opened),
    beside ``held`` bytes (the trajectory the caller holds) and what callers hold."""
    runs = np.asarray(runs)
    n = float(len(runs))
    path = float(path_hinges(checker.tree, runs[:, 0], runs[:, 1]).sum()) if len(runs) else 0.0
    narrow = n * RUN_BYTES + path * PATH_BYTES_PER_HINGE
    return {"bytes": BASE_BYTES + held + held_elsewhere() + narrow, "narrow_bytes": narrow, "runs": n,
            "path_hinges": path}


def check_narrow(checker, runs: np.ndarray, held: float = 0.0) -> dict | None:
    """Refuse the narrow phase over ``runs`` when :func:`narrow_estimate` is over the
    memory limit, before any run is stepped. None (nothing estimated) when even every
    run's path through every hinge fits: a Monte-Carlo sample's few runs, checked in
    microseconds instead of a tree search per run."""
    most = len(runs) * (RUN_BYTES + PATH_BYTES_PER_HINGE * len(checker.design.hinges))
    if BASE_BYTES + held + held_elsewhere() + most <= max_memory():
        return None
    est = narrow_estimate(checker, runs, held)
    mean = est["path_hinges"] / max(est["runs"], 1.0)
    return enforce(est, f"{source_of(checker.design)}the 3D swept check", (
        f"its narrow phase holds {est['runs']:.0f} candidate panel-pair runs open at once, {mean:.0f} hinges "
        f"between a pair on average ({fmt_bytes(est['narrow_bytes'])}; {fmt_bytes(est['bytes'])} in all)",
        "fold fewer panels onto each other (longer panels or smaller angles), split the design, or lift the "
        f"limit with {lift_hint(est)}"))
