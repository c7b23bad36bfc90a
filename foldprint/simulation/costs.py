"""What a simulation, a Monte-Carlo run and the scatter margin screen cost, estimated from
the design before anything is allocated, and refused through the guard
(:func:`foldprint.core.guards.enforce`) when over the memory limit or the time budget.

The estimates (``docs/input-safety.md`` has a table of estimate vs measured) count:

* the trajectory: ``n_t`` time steps x (panels x a 4x4 pose + hinges x ratios, angles and
  the drive's temporaries), 8-byte floats;
* the 3D swept check's broad phase: per step and panel the prefix sums and centroids with
  their temporaries (``BROAD_BYTES_PER_PANEL_STEP``); its narrow phase works on the pairs the
  broad phase leaves, so it is bounded while it runs (:func:`~foldprint.core.guards.narrow_deadline`),
  not before;
* the paper's 2D index (``method`` index2d/both on a planar strip): ``n_t`` x panel pairs x
  (index value 8 B + contact flags 3 x 1 B), plus the side segments per step;
* time: kinematics per hinge and step, broad phase per panel and step (measured constants).
"""

from __future__ import annotations

import math
from typing import Callable

from ..core.guards import (BASE_BYTES, enforce, fmt_bytes, fmt_seconds, held_elsewhere, lift_hint, max_memory,
                           source_of, time_budget, LIFT_TIME)
from ..core.modes import Method
from ..physics.barhinge.solve_cost import check_mechanics, solve_seconds  # noqa: F401 (check_mechanics: for callers)

# Cost model. Measured on the 2-core sandbox with benchmarks/bench_scale.py (strips of 100
# to 1000 panels, 2001 steps; peak RSS of fresh processes, docs/input-safety.md):
#: trajectory bytes per panel and step (one 4x4 pose) and per hinge and step (ratios,
#: angles, the drive's lookup temporaries)
TRAJ_BYTES_PER_PANEL_STEP = 128
TRAJ_BYTES_PER_HINGE_STEP = 64
#: broad phase of the 3D check: prefix sums (3 x 8 B), centroids (24 B) and the
#: centroid temporaries (3 x 24 B) per panel and step, held with the trajectory
BROAD_BYTES_PER_PANEL_STEP = 120
#: the hinge drive's recovery table, held with a run's trajectory: one curve per hinge on
#: the recovery model's time grid, 15,400 floats (physics.recovery.curve.curve_time_grid: 4 ms
#: steps to 60 s, then 400 to the 600 s horizon; 117 MiB of a 1000-panel strip's drive)
DRIVE_BYTES_PER_HINGE = 15_400 * 8
#: kinematics (recovery lookup, hinge transforms, forward poses) per hinge and step, s
KIN_S_PER_HINGE_STEP = 1.5e-6
#: broad phase per panel and step, s
BROAD_S_PER_PANEL_STEP = 0.6e-6
#: the 3D broad phase's descent per (group pair, interval) it examines, s: a lower bound of the
#: 0.66-0.77 CPU-us measured on 300-panel coiling strips (7.8 to 19 million such nodes a fold,
#: 6 to 12 CPU-s; a template's fold examines under 500); 0.5 us is our choice below them
BROAD_S_PER_NODE = 0.5e-6
#: memory one Monte-Carlo sample holds to the end: its Outcome (5 fields), measured at most
#: 510 B deep size on helix samples (jammed ones carry a pair and a reason), doubled
SAMPLE_BYTES = 1024
SAMPLE_BYTES_PER_HINGE = 0
#: The clearance search (check's FP172) over the kept trajectory: the non-adjacent pair
#: array (two int64 a pair, and the list it is made from, ~120 B a pair) and one chunk of
#: 2^19 pose-pair bounds (gathers, differences, squares, order: ~100 B each). It runs
#: after the simulation's broad phase is freed.
PAIR_BYTES = 136
CLEARANCE_CHUNK_BYTES = 64 * 2 ** 20

_SHORTER = "raise --dt, shorten --duration (or process.duration_s)"


def simulation_estimate(n_panels: int, n_hinges: int, n_steps: float, use2d: bool,
                        n_segments: int | None = None, use3d: bool = True) -> dict:
    """Peak bytes and seconds of one simulation run before its narrow phase (floats, so
    any size is compared, never overflowed)."""
    n, nh, steps = float(n_panels), float(n_hinges), float(n_steps)
    pairs = n * (n - 1) / 2
    segs = n if n_segments is None else float(n_segments)
    traj = steps * (n * TRAJ_BYTES_PER_PANEL_STEP + nh * TRAJ_BYTES_PER_HINGE_STEP + 8) + nh * DRIVE_BYTES_PER_HINGE
    broad = steps * n * BROAD_BYTES_PER_PANEL_STEP if use3d else 0.0
    index = steps * (pairs * (8 + 3) + segs * 4 * 8 * 3) if use2d else 0.0
    seconds = steps * nh * KIN_S_PER_HINGE_STEP + (steps * n * BROAD_S_PER_PANEL_STEP if use3d else 0.0)
    return {"bytes": BASE_BYTES + traj + max(broad, index), "trajectory_bytes": traj, "broad_bytes": broad,
            "index2d_bytes": index, "seconds": seconds, "steps": steps, "pairs": pairs}


def run_sizes(design, dt: float, duration: float | None) -> tuple[float, float, int] | None:
    """(duration s, time steps, outline segments) of a run, None for values simulate()
    refuses itself. Steps are a float: 1e300 of them are compared, never overflowed."""
    dur = float(design.process.duration_s if duration is None else duration)
    if not (math.isfinite(dur) and math.isfinite(dt) and dur > 0 and dt > 0):
        return None
    steps = math.floor(dur / dt) + 2.0 if dur / dt < 1e15 else dur / dt
    n_seg = sum(len(p.outline) + sum(len(h) for h in p.holes) for p in design.panels)
    return dur, steps, n_seg


def index2d_skip_reason(design, dt: float, duration: float | None) -> str | None:
    """Why ``--method both`` leaves out the paper's 2D index of a planar strip, or None.

    ``both`` means both checks where they apply: the 3D swept check is the verdict, the 2D
    index the paper's comparison. When the index alone would exceed the memory limit (less
    what the caller holds, :func:`~foldprint.core.guards.holding`) while the 3D check fits
    (a 1000-panel strip: ~11 GB of index against ~0.7 GB), the run goes on
    with the 3D check and says so; ``--method index2d`` still asks for the index (and is
    refused with the estimate)."""
    sizes = run_sizes(design, dt, duration)
    if sizes is None:
        return None
    _dur, steps, n_seg = sizes
    n, nh = len(design.panels), len(design.hinges)
    with2d = simulation_estimate(n, nh, steps, True, n_seg, use3d=True)
    without = simulation_estimate(n, nh, steps, False, n_seg, use3d=True)
    limit = max_memory()
    room = limit - held_elsewhere()  # beside what the caller already holds
    if with2d["bytes"] <= room or without["bytes"] > room:
        return None
    return (f"the paper's 2D collision index was left out: it needs {fmt_bytes(with2d['index2d_bytes'])} "
            f"({steps:.3g} steps x {with2d['pairs']:.0f} panel pairs), over the {fmt_bytes(limit)} memory limit; "
            "the verdict is the 3D swept check's (--method index2d with a larger --max-memory runs the index)")


def run_estimate(design, dt: float, duration: float | None, method: Method, runs: int = 1,
                 clearance: bool = False, extra: float = 0.0) -> dict | None:
    """:func:`simulation_estimate` of the peak of a command that holds ``runs``
    simulations at once (``simulate``: the nominal fold and the other hinge model's;
    ``check`` with samples and ``robust``: the nominal fold and one sample in this
    process), plus the clearance search after it (``clearance``), ``extra`` bytes held
    beside the last run (a Monte-Carlo chunk's recovery curves) and what
    :func:`~foldprint.core.guards.holding` says is held. None for values simulate()
    refuses itself."""
    sizes = run_sizes(design, dt, duration)
    if sizes is None:
        return None
    _dur, steps, n_seg = sizes
    m = str(method)
    use2d = m in (Method.INDEX2D, Method.BOTH) and design.is_planar_strip
    est = simulation_estimate(len(design.panels), len(design.hinges), steps, use2d, n_seg,
                              use3d=m in (Method.FCL, Method.BOTH))
    work = max(est["broad_bytes"], est["index2d_bytes"])
    clear = est["pairs"] * PAIR_BYTES + CLEARANCE_CHUNK_BYTES if clearance else 0.0
    held = held_elsewhere() + float(extra) + (
        (runs - 1) * (est["trajectory_bytes"] + est["index2d_bytes"]) if runs > 1 else 0.0)
    est.update(held_bytes=held, clearance_bytes=clear, runs=runs, run_bytes=est["bytes"],
               bytes=est["bytes"] + held + max(0.0, clear - work))
    return est


def _memory_reason(design, est: dict, dt: float, dur: float, steps: float, runs: int, extra: float) -> tuple[str, str]:
    """(need, fix) of a simulation refused by memory: the part that is large, what is held."""
    held = ", ".join(([f"{runs} runs held at once"] if runs > 1 else [])
                     + ([f"{fmt_bytes(extra)} of sampled recovery curves"] if extra else [])
                     + ([f"{fmt_bytes(held_elsewhere())} of earlier results held"] if held_elsewhere() else [])
                     + ([f"{fmt_bytes(est['clearance_bytes'])} for the clearance search"]
                        if est["bytes"] > est["run_bytes"] + est["held_bytes"] else []))
    held = f" ({held}: {fmt_bytes(est['bytes'])} in all)" if held else ""
    index = est["index2d_bytes"] > est["trajectory_bytes"]
    part = (f"the 2D collision index needs {fmt_bytes(est['index2d_bytes'])} "
            f"({steps:.3g} steps x {est['pairs']:.0f} panel pairs)" if index
            else f"the trajectory and the 3D check's broad phase need {fmt_bytes(est['run_bytes'])} "
                 f"({steps:.3g} steps of {dt:g} s over {dur:g} s x {len(design.panels)} panels)"
                 .replace("inf steps", "more than 1e308 steps"))
    return part + held, f"{'use --method fcl, ' if index else ''}{_SHORTER}, or lift the limit with {lift_hint(est)}"


def check_simulation(design, dt: float, duration: float | None, method: Method, runs: int = 1,
                     clearance: bool = False, extra: float = 0.0) -> dict:
    """Refuse a simulation whose memory estimate (:func:`run_estimate`: with ``runs``
    simulations held at once, the clearance search and what the caller holds) exceeds the
    memory limit, or whose time estimate (kinematics and the 3D broad phase) exceeds the
    time budget.

    Called at the top of :func:`foldprint.simulation.simulate.simulate` (one line) and up
    front, through :func:`check_runs`, by the commands that hold more than one run."""
    est = run_estimate(design, dt, duration, method, runs, clearance, extra)
    if est is None:
        return {}  # simulate() reports bad values itself

    def memory():
        dur, steps = run_sizes(design, dt, duration)[:2]
        return _memory_reason(design, est, dt, dur, steps, runs, extra)

    def time_need():
        steps = run_sizes(design, dt, duration)[1]
        return (f"estimated {fmt_seconds(est['seconds'])} for {steps:.3g} steps x {len(design.hinges)} hinges",
                f"{_SHORTER}, or {LIFT_TIME}")

    # the refusals' sentences are written only for a refusal (every sample's fold asks)
    return enforce(est, f"{source_of(design)}simulation", memory, time_need)


def check_runs(design, dt: float, duration: float | None, method: Method, runs: int, clearance: bool = False,
               curves: Callable[[], float] | None = None) -> None:
    """:func:`check_simulation` of a command up front: ``runs`` simulations held at once
    (``both`` counts the 2D index only where a run keeps it), the clearance search, and
    ``curves()`` bytes of a Monte-Carlo chunk's recovery curves, asked only once the runs
    alone fit (finding the run's end allocates its time grid)."""
    m = Method.FCL if str(method) == Method.BOTH and index2d_skip_reason(design, dt, duration) else method
    check_simulation(design, dt, duration, m, runs, clearance)
    if curves is not None:
        check_simulation(design, dt, duration, m, runs, clearance, curves())


def check_margin(design, dt: float, duration: float | None, method: Method, batch_bytes: Callable[[int], float],
                 samples: int, upfront: bool = False, poses: int | None = None) -> int:
    """How many of the margin screen's ``samples`` scattered folds
    (:mod:`foldprint.simulation.margin`) get their recovery curves at once: the most whose
    ``batch_bytes(k)`` (curves and their making) fit beside one sample's kinematic
    trajectory, its clearance search and what is held (what
    :func:`~foldprint.core.guards.holding` says, and ``upfront``: the nominal fold of
    ``method``, before it runs). A sample's trajectory holds ``poses`` poses when given (a
    fold without loops is made only at the poses its clearance search samples), else every
    step. ResourceError, naming the estimate, when not even one fits."""
    sizes = run_sizes(design, dt, duration)
    if sizes is None or samples < 1:
        return max(1, samples)
    _dur, steps, n_seg = sizes
    n, nh = len(design.panels), len(design.hinges)
    kin = (steps if poses is None else min(steps, poses)) * (n * TRAJ_BYTES_PER_PANEL_STEP + nh * TRAJ_BYTES_PER_HINGE_STEP + 8)
    clear = n * (n - 1) / 2 * PAIR_BYTES + CLEARANCE_CHUNK_BYTES
    held = held_elsewhere()
    if upfront:
        m = Method.FCL if str(method) == Method.BOTH and index2d_skip_reason(design, dt, duration) else method
        nominal = run_estimate(design, dt, duration, m)
        held += nominal["trajectory_bytes"] + nominal["index2d_bytes"]
    fixed = BASE_BYTES + held + kin + clear
    limit = max_memory()
    for k in range(int(samples), 0, -1):
        if fixed + batch_bytes(k) <= limit:
            return k
    one = kin + clear + batch_bytes(1)
    est = {"bytes": fixed + batch_bytes(1)}
    enforce(est, f"{source_of(design)}simulation",
            (f"the scatter margin screen folds {samples} scattered samples, one at a time at least, and one needs "
             f"{fmt_bytes(one)} (its trajectory, recovery curves and clearance search) beside {fmt_bytes(held)} of "
             f"the nominal fold held: {fmt_bytes(est['bytes'])} in all", f"{_SHORTER}, or lift the limit with "
             f"{lift_hint(est)}"))
    return 1  # not reached: the estimate is over the limit


def check_sample_memory(design, samples: float, what: str = "the Monte-Carlo jam probability") -> dict:
    """Refuse ``samples`` Monte-Carlo folds whose outcomes (held to the end) would not fit in
    memory, before any is drawn. Time is bounded by :func:`check_samples`, on the rate
    measured on the first chunk (an a-priori rate went stale when the curves got 10x cheaper)."""
    nh = len(design.hinges)
    samples = float(samples)
    per_b = SAMPLE_BYTES + nh * SAMPLE_BYTES_PER_HINGE
    est = {"bytes": BASE_BYTES + samples * per_b, "per_sample_bytes": per_b}
    return enforce(est, f"{source_of(design)}{what}",
                   (f"{samples:.3g} samples hold {fmt_bytes(est['bytes'])} ({fmt_bytes(per_b)} each)",
                    f"use fewer --samples or lift the limit with {lift_hint(est)} (check) or the environment "
                    "variable FOLDPRINT_MAX_MEMORY"))


def check_samples(samples: int, seconds_per_sample: float, workers: int, name: str = "",
                  basis: str = "measured on the first samples") -> float:
    """Refuse ``samples`` Monte-Carlo samples when their estimated time (the measured CPU
    seconds per sample of the first chunk x samples / workers) exceeds the time budget.
    Returns the estimate (s). Memory does not grow with the count (samples are streamed in
    chunks); only time does. ``basis``: where the rate comes from, as the message says it."""
    return _rate_guard(samples, seconds_per_sample, workers, name, basis)


def _rate_guard(samples: int, seconds_per_sample: float, workers: int, name: str, basis: str) -> float:
    workers = max(1, int(workers))
    est = float(samples) * max(0.0, seconds_per_sample) / workers
    fits = max(1, int(time_budget() * workers / max(seconds_per_sample, 1e-9)))
    enforce({"seconds": est}, f"{name + ': ' if name else ''}--samples {samples}", time=(
        f"estimated {est:.3g} s ({seconds_per_sample * 1e3:.3g} ms per sample {basis}, "
        f"on {workers} worker(s))", f"use at most about {fits} samples, or raise the budget with the environment "
        "variable FOLDPRINT_TIME_BUDGET (seconds)"))
    return est


def check_mechanics_samples(nominal, samples: int, workers: int, name: str = "") -> float | None:
    """Refuse ``samples`` bar-and-hinge Monte-Carlo folds before the first is folded: each
    solves its own equilibrium path, about as many Newton iterations as the nominal fold's
    (``nominal.compliant``), at :func:`~foldprint.physics.barhinge.solve_cost.solve_seconds`
    each, plus the rigid part of a run (collision check). A first chunk of such samples
    takes minutes (16 folds of octagon_stack), so its measured rate comes too late to
    refuse early. None (nothing checked) for a rigid nominal fold."""
    sol = getattr(nominal, "compliant", None)
    if sol is None or samples < 1:
        return None
    d = nominal.design
    per = (solve_seconds(sol.model, max(sol.iterations, 1))
           + simulation_estimate(len(d.panels), len(d.hinges), len(nominal.trajectory.times), False)["seconds"])
    return check_samples(samples, per, workers, name, basis=f"estimated from the nominal fold's {sol.iterations} "
                         f"Newton iterations on {len(sol.model.nodes)} nodes")


def check_swept_samples(nominal, samples: int, workers: int, name: str = "") -> float | None:
    """Refuse ``samples`` rigid Monte-Carlo folds before the first is folded when the
    nominal fold's 3D broad phase alone (``nominal.broad_nodes``, to its first contact, x
    :data:`BROAD_S_PER_NODE`, a lower bound) already puts them over the time budget: each
    sample repeats that search, and a first chunk of 16 such folds (a 300-panel coiling
    strip: 6 to 12 CPU-s each) runs minutes before its measured rate is checked. The
    estimate is a lower bound, so it refuses only what the first chunk's rate would
    (:func:`check_samples`); cheaper folds are left to that. None (nothing checked)
    without a 3D check's work."""
    nodes = int(getattr(nominal, "broad_nodes", 0) or 0)
    if nodes < 1 or samples < 1:
        return None
    return _rate_guard(samples, nodes * BROAD_S_PER_NODE, workers, name,
                       f"estimated from the nominal fold's {nodes} broad-phase nodes of its 3D check")
