"""What tracking a pattern's loop closure holds (:mod:`foldprint.physics.loops.closure`,
:mod:`foldprint.physics.loops.tracker`), estimated from the loops and hinges before the
solver's arrays are made, and refused through the guard
(:func:`foldprint.core.guards.enforce`) over the memory limit.

The solver keeps, per fundamental cycle and place along it, the signed hinge column of
the Jacobian (``_p_onto``: m cycles x L places x (n + 1) hinges, 8 B each), and every round
evaluates the closure's dense Jacobian (6 rows a cycle x n hinges) at 4 configurations a
drive (``Pool(n, 4 s)``), with its product temporary and the solve's copies. A 1,500-face
Miura sheet (1,421 loops over 2,920 hinges) needs 760 MiB for one of these arrays.
"""

from __future__ import annotations

from ...core.guards import BASE_BYTES, enforce, fmt_bytes, lift_hint

#: configurations evaluated at once per drive (loop_tracking.track: ``Pool(n, 4 * s)``)
STATES_PER_DRIVE = 4
#: dense Jacobians a round holds at once: the product's temporary, the result, and the
#: solve's normal matrix and factor copies (our choice from the code: 4)
JACOBIAN_COPIES = 4


def loop_estimate(n_hinges: int, cycles: int, places: int, drives: int = 1) -> dict:
    """Peak bytes of tracking ``cycles`` loops of at most ``places`` hinges each over
    ``n_hinges`` hinges, ``drives`` drives in lockstep (floats: any size compares)."""
    n, m, L = float(n_hinges), float(cycles), float(places)
    table = m * L * (n + 1) * 8
    jac = STATES_PER_DRIVE * float(drives) * 6 * m * n * 8
    return {"bytes": BASE_BYTES + table + JACOBIAN_COPIES * jac, "table_bytes": table, "jacobian_bytes": jac}


def check_loops(n_hinges: int, cycles: int, places: int, drives: int = 1) -> dict:
    """Refuse a loop closure whose :func:`loop_estimate` is over the memory limit, before
    its arrays are made."""
    est = loop_estimate(n_hinges, cycles, places, drives)
    return enforce(est, "the loop closure", (
        f"{cycles} loops (up to {places} hinges each) over {n_hinges} hinges need a "
        f"{fmt_bytes(est['table_bytes'])} table and dense Jacobians of {fmt_bytes(est['jacobian_bytes'])} "
        f"({fmt_bytes(est['bytes'])} in all)", "fold a smaller sheet (fewer panels closing loops), or lift the "
        f"limit with {lift_hint(est)}"))
