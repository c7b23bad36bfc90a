"""The compiled kernels on a cold numba cache: each compiled once, the groups in parallel.

The first command after an install compiles the kernels (numba's cache is empty). Left to
the Monte-Carlo pool, every worker compiles every kernel it meets, at the same time as the
others (each folds strips that jam and patterns with loops): every compilation is paid
once per worker and the wall is their sum. Here the kernel modules are split into
:data:`GROUPS` of about the same compile time, disjoint (no kernel of one group calls one of
another, so compiling a group compiles no kernel of the others), and
:func:`~foldprint.simulation.jamtest.pool.run_batch` gives each cold group to its own
worker (:func:`warm_group`) before any chunk: each kernel is compiled by one process, which
writes it to the cache, and the others load it from there when they meet it.

Whether a group is cold is read from numba's cache index of its costliest kernels
(:data:`PROBES`; milliseconds), so a warm cache runs no warm-up at all. The command line
reads the same index (:func:`cold_kernels`, the probes of :data:`EVERY_FOLD`) to say, before
a fold, that the kernels are compiling.
"""

from __future__ import annotations

import importlib

from ...core.jit import cache_file

#: kernel module -> its group: ``strips`` the path of every sample (the recovery curves,
#: forward kinematics, the broad phase and screen, the narrow phase and the exact distance),
#: ``loops`` the closure's compiled round (with its small SVD), the tracker's bookkeeping and
#: the compiled track that calls both.
#: Compile CPU on a cold cache (docs/kernels.md): ~42 s and ~42 s.
GROUPS: dict[str, tuple[str, ...]] = {
    "strips": ("foldprint.physics.recovery.batch_kernels", "foldprint.physics.kinematics_kernels",
               "foldprint.collision.broadphase_kernels", "foldprint.collision.swept3d_kernels",
               "foldprint.collision.narrow_kernels", "foldprint.collision.polytope_distance_kernels"),
    "loops": ("foldprint.physics.loops.decomp_kernels", "foldprint.physics.loops.closure_kernels",
              "foldprint.physics.loops.pairwise_kernels", "foldprint.physics.loops.tracker_kernels",
              "foldprint.physics.loops.normal_kernels", "foldprint.physics.loops.track_kernels"),
}

#: each group's kernels called from Python that take most of its compile time: the group is
#: cold when one of them has no compiled code in numba's cache for this source
PROBES: dict[str, tuple[tuple[str, str], ...]] = {
    "strips": (("foldprint.collision.narrow_kernels", "walk_runs"),
               ("foldprint.collision.polytope_distance_kernels", "panel_bounds"),
               ("foldprint.collision.swept3d_kernels", "screen_runs"),
               ("foldprint.physics.recovery.batch_kernels", "curves_table")),
    "loops": (("foldprint.physics.loops.track_kernels", "track_pool"),),  # the round and bookkeeping in it
}


def is_cached(module: str, name: str) -> bool:
    """Whether numba's cache holds compiled code of ``module.name`` for its current source
    (its index file exists and matches the source's stamp). True when it cannot tell (a
    numba whose cache is laid out otherwise): then nothing is warmed ahead, as before."""
    try:
        return bool(cache_file(getattr(importlib.import_module(module), name))._load_index())
    except Exception:  # noqa: BLE001 - numba's private cache layout: assume warm
        return True


#: the probes every command that folds a design compiles: its nominal fold's (the swept
#: screen; with loops the compiled track, the closure's round and the tracker's bookkeeping
#: in it). The others are compiled by some folds only: the narrow phase's walk by one that
#: reaches it, the exact distance by a clearance, the recovery curves' table by scattered
#: samples (`assign`'s default search folds none)
EVERY_FOLD: frozenset[tuple[str, str]] = frozenset({
    ("foldprint.collision.swept3d_kernels", "screen_runs"),
    ("foldprint.physics.loops.track_kernels", "track_pool")})


def cold_kernels(loops: bool, *, sure: bool = False) -> list[str]:
    """The groups a fold of a design (``loops``: with closed loops) needs whose kernels
    numba's cache lacks (any number of them); none where the numpy path runs. ``sure``:
    read only the probes of :data:`EVERY_FOLD`, so a group is cold when the next command
    that folds the design compiles it, whatever the commands before it folded."""
    from ...core.jit import use_kernels

    if not use_kernels():
        return []
    need = ["strips", "loops"] if loops else ["strips"]
    return [g for g in need
            if not all(is_cached(m, f) for m, f in PROBES[g] if not sure or (m, f) in EVERY_FOLD)]


def cold_groups(loops: bool) -> list[str]:
    """The groups a run needs (``loops``: a design with closed loops among its jobs) whose
    kernels numba's cache lacks, when there are two or more to split across workers; none
    where the numpy path runs. One cold group alone is left to the chunks that meet its
    kernels: warmed ahead, it would hold every other worker idle while it compiles, and
    for kernels a run may never need (the narrow phase of a design that never jams)."""
    cold = cold_kernels(loops)
    return cold if len(cold) >= 2 else []


def warm_group(name: str) -> str:
    """Compile (or load) every kernel of group ``name`` in this process, on the inputs the
    Monte-Carlo passes them (the same types, so the same compiled signatures); returns the
    name. ``strips``: samples of a small coil that jams (its sweep reaches the narrow phase
    and the exact distance), of a hinge tree and of ``helix_uniform``, and the coil's
    nominal fold and clearance; ``loops``: the compiled track (the closure round and the
    tracker's bookkeeping in it) on ``miura_3x3`` through its warm function, then two of
    its samples (by then the other worker has written most of the strips' kernels: they
    load)."""
    if name == "strips":
        _warm_strips()
    elif name == "loops":
        _warm_loops()
    else:
        raise ValueError(f"no kernel group {name!r}; the groups are {', '.join(GROUPS)}")
    return name


def _warm_strips() -> None:
    from ...collision.clearance import min_clearance
    from ...collision.polytope_distance import warm_kernel
    from ...collision.swept3d import SweptChecker
    from ...core.constants import CHECK_DT_S
    from ...core.modes import VERDICT_METHOD, HingeModel
    from ...io.load import load_design
    from ...io.templates import templates_dir
    from ...model.design import strip
    from ...model.materials import default_library
    from ..robust import run_samples
    from ..scatter import default_scatter, samples_between
    from ..simulate import simulate

    coil = strip("coil", [30, 10, 30, 10, 30], [170] * 4, ["H-2"] * 4, radius=2.0)  # jams: its panels meet
    stack = load_design(templates_dir() / "octagon_stack.toml")  # a hinge tree: its trajectory read-only
    helix = load_design(templates_dir() / "helix_uniform.toml")  # among its first 12: the refined broad phase
    for design, n in ((coil, 2), (stack, 1), (helix, 12)):
        samples = samples_between(design, default_scatter(), 0, 0, n)
        run_samples((design, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD))
    warm_kernel()
    # a design's build (the gallery's, after its tests): the nominal fold and its clearance
    traj = simulate(coil, dt=CHECK_DT_S, method=VERDICT_METHOD, hinge_model=HingeModel.ARC).trajectory
    min_clearance(SweptChecker(coil, HingeModel.ARC, None), traj.times, traj.poses)


def _warm_loops() -> None:
    import numpy as np

    from ...io.load import load_design
    from ...io.templates import templates_dir
    from ...physics.kinematics import hinge_frames, target_angles
    from ...physics.loops.closure import LoopSolver
    from ...core.constants import CHECK_DT_S
    from ...core.modes import VERDICT_METHOD, HingeModel
    from ...model.materials import default_library
    from ..robust import run_samples
    from ..scatter import default_scatter, samples_between

    design = load_design(templates_dir() / "miura_3x3.toml")
    solver = LoopSolver(hinge_frames(design), [h.id for h in design.hinges])
    times = np.linspace(0.0, 1.0, 5)
    drive = np.outer(times, 0.3 * target_angles(design))  # a third of the way: the loops stay open
    solver.track_many(times, [drive])  # one drive: the reference tracks it, the compiled track's warm function runs
    solver.track_many(times, [drive, 0.9 * drive], compiled=True)  # a chunk's path: every compiled call
    # then two samples: the strips' kernels on a loop pattern's read-only angles and poses
    # (their own compiled signatures); the rest the other worker has written by now
    samples = samples_between(design, default_scatter(), 0, 0, 2)
    run_samples((design, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD))
