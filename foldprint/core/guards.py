"""Resource guards: estimate a run's memory and time before allocating, and refuse with a
:class:`ResourceError` (exit 2) that names the estimate, the limit and how to lift it,
never a MemoryError and never a run that would fit.

The estimates (``docs/input-safety.md`` has a table of estimate vs measured) count:

* the trajectory: ``n_t`` time steps x (panels x a 4x4 pose + hinges x ratios, angles and
  the drive's temporaries), 8-byte floats;
* the 3D swept check's broad phase: per step and panel the prefix sums and centroids with
  their temporaries (``BROAD_BYTES_PER_PANEL_STEP``); its narrow phase works on the pairs the
  broad phase leaves, so it is bounded while it runs (:func:`narrow_deadline`), not before;
* the paper's 2D index (``method`` index2d/both on a planar strip): ``n_t`` x panel pairs x
  (index value 8 B + contact flags 3 x 1 B), plus the side segments per step;
* time: kinematics per hinge and step, broad phase per panel and step (measured constants).

The memory limit defaults to :data:`DEFAULT_MAX_MEMORY` (2 GiB, or the environment
variable ``FOLDPRINT_MAX_MEMORY``); the CLI's ``--max-memory`` sets it for one run. The time
budget is :data:`DEFAULT_TIME_BUDGET_S` (or ``FOLDPRINT_TIME_BUDGET`` in seconds).
Estimates are computed in floats, so absurd sizes (1e300 steps) are refused, not overflowed.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from typing import Callable

from .errors import FoldprintError
from .modes import Interface, Method

GiB = 2 ** 30
DEFAULT_MAX_MEMORY = 2 * GiB
#: Wall-time budget of one run (s): a stated bound, so a guard refuses only runs whose
#: estimate exceeds it (15 min), or the environment variable ``FOLDPRINT_TIME_BUDGET``.
DEFAULT_TIME_BUDGET_S = 900.0

# Cost model. Measured on the 2-core sandbox with benchmarks/bench_scale.py (strips of 100
# to 1000 panels, 2001 steps; peak RSS of fresh processes, docs/input-safety.md):
#: resident memory of the imported package (numpy, fcl, shapely, manifold3d), bytes
BASE_BYTES = 110 * 2 ** 20
#: trajectory bytes per panel and step (one 4x4 pose) and per hinge and step (ratios,
#: angles, the drive's lookup temporaries)
TRAJ_BYTES_PER_PANEL_STEP = 128
TRAJ_BYTES_PER_HINGE_STEP = 64
#: broad phase of the 3D check: prefix sums (3 x 8 B), centroids (24 B) and the
#: centroid temporaries (3 x 24 B) per panel and step, held with the trajectory
BROAD_BYTES_PER_PANEL_STEP = 120
#: the hinge drive's recovery table, held with a run's trajectory: one curve per hinge on
#: the recovery model's time grid, 15,400 floats (physics.recovery.curve_time_grid: 4 ms
#: steps to 60 s, then 400 to the 600 s horizon; 117 MiB of a 1000-panel strip's drive)
DRIVE_BYTES_PER_HINGE = 15_400 * 8
#: kinematics (recovery lookup, hinge transforms, forward poses) per hinge and step, s
KIN_S_PER_HINGE_STEP = 1.5e-6
#: broad phase per panel and step, s
BROAD_S_PER_PANEL_STEP = 0.6e-6
#: memory one Monte-Carlo sample holds to the end: its Outcome (5 fields), measured at most
#: 510 B deep size on helix samples (jammed ones carry a pair and a reason), doubled
SAMPLE_BYTES = 1024
SAMPLE_BYTES_PER_HINGE = 0

_LIMIT = {"bytes": None, "seconds": None}


class ResourceError(FoldprintError, MemoryError):
    """A run would need more memory or work than the limit allows (exit 2)."""


def parse_size(text: str | int | float) -> int:
    """``"4G"``, ``"512M"``, ``"1.5GiB"``, ``"2000000000"`` -> bytes."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value, unit = float(text), ""
    else:
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)(?:i?[bB])?\s*", str(text))
        if not m:
            raise FoldprintError(f"--max-memory must be a size like 4G, 512M or 2000000000 (bytes), got {text!r}")
        value, unit = float(m.group(1)), m.group(2).upper()
    size = value * {"": 1, "K": 2 ** 10, "M": 2 ** 20, "G": GiB, "T": 2 ** 40}[unit]
    if not (math.isfinite(size) and 1 <= size <= 2 ** 60):  # 1 byte .. 1 EiB
        raise FoldprintError(f"--max-memory must be a size from 1 byte to 1048576T (1 EiB), got {text!r}")
    return int(size)


def set_max_memory(text: str | int | float | None) -> None:
    """Set the memory limit for this process (None: back to the default)."""
    _LIMIT["bytes"] = None if text is None else parse_size(text)


def set_time_budget(seconds: float | None) -> None:
    """Set the time budget (s) for this process (None: back to the default)."""
    if seconds is not None and not (math.isfinite(float(seconds)) and float(seconds) > 0):
        raise FoldprintError(f"the time budget must be a number of seconds > 0, got {seconds!r}")
    _LIMIT["seconds"] = None if seconds is None else float(seconds)


def time_budget() -> float:
    if _LIMIT["seconds"] is not None:
        return _LIMIT["seconds"]
    env = os.environ.get("FOLDPRINT_TIME_BUDGET")
    if env:
        try:
            value = float(env)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise FoldprintError(f"FOLDPRINT_TIME_BUDGET must be a number of seconds > 0, got {env!r}")
        return value
    return DEFAULT_TIME_BUDGET_S


def max_memory() -> int:
    if _LIMIT["bytes"] is not None:
        return _LIMIT["bytes"]
    env = os.environ.get("FOLDPRINT_MAX_MEMORY")
    return parse_size(env) if env else DEFAULT_MAX_MEMORY


def _fmt(n: float) -> str:
    if not math.isfinite(n):
        return "more than 1e308 bytes"
    for unit, size in (("TiB", 2 ** 40), ("GiB", GiB), ("MiB", 2 ** 20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def _fmt_s(sec: float) -> str:
    if not math.isfinite(sec):
        return "more than 1e308 s"
    if sec >= 3600 * 24 * 365:
        return f"{sec / (3600 * 24 * 365):.3g} years"
    if sec >= 3600:
        return f"{sec / 3600:.3g} h"
    if sec >= 60:
        return f"{sec / 60:.3g} min"
    return f"{sec:.3g} s"


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


def _lift(est: dict) -> str:
    if not est["bytes"] * 1.2 < 2.0 ** 60:  # beyond any machine (or not finite): no size to suggest
        return "--max-memory (no machine holds this run)"
    return f"--max-memory {_fmt(est['bytes'] * 1.2).replace(' ', '')}"


def _run_sizes(design, dt: float, duration: float | None) -> tuple[float, float, int] | None:
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
    what the caller holds, :func:`holding`) while the 3D check fits (a 1000-panel strip:
    ~11 GB of index against ~0.7 GB), the run goes on
    with the 3D check and says so; ``--method index2d`` still asks for the index (and is
    refused with the estimate)."""
    sizes = _run_sizes(design, dt, duration)
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
    return (f"the paper's 2D collision index was left out: it needs {_fmt(with2d['index2d_bytes'])} "
            f"({steps:.3g} steps x {with2d['pairs']:.0f} panel pairs), over the {_fmt(limit)} memory limit; "
            "the verdict is the 3D swept check's (--method index2d with a larger --max-memory runs the index)")


#: The bytes of results each evaluation holds while it computes another stage (its earlier
#: simulations' trajectories and indexes), set by :func:`holding` and added to every
#: simulation's estimate: what is held stays allocated while the next run allocates.
_HOLDERS: dict = {}


def held_elsewhere() -> float:
    """Bytes the callers of this process say they hold (:func:`holding`)."""
    return float(sum(_HOLDERS.values()))


@contextlib.contextmanager
def holding(nbytes: float, owner=None):
    """Within the block, :func:`check_simulation` counts ``nbytes`` already held by
    ``owner`` (an evaluation: nested stages of one owner replace its count, owners add)."""
    key = owner if owner is not None else object()
    before = _HOLDERS.get(key)
    _HOLDERS[key] = float(nbytes)
    try:
        yield
    finally:
        if before is None:
            _HOLDERS.pop(key, None)
        else:
            _HOLDERS[key] = before


#: The clearance search (check's FP172) over the kept trajectory: the non-adjacent pair
#: array (two int64 a pair, and the list it is made from, ~120 B a pair) and one chunk of
#: 2^19 pose-pair bounds (gathers, differences, squares, order: ~100 B each). It runs
#: after the simulation's broad phase is freed.
PAIR_BYTES = 136
CLEARANCE_CHUNK_BYTES = 64 * 2 ** 20


def run_estimate(design, dt: float, duration: float | None, method: Method, runs: int = 1,
                 clearance: bool = False, extra: float = 0.0) -> dict | None:
    """:func:`simulation_estimate` of the peak of a command that holds ``runs``
    simulations at once (``simulate``: the nominal fold and the other hinge model's;
    ``check`` with samples and ``robust``: the nominal fold and one sample in this
    process), plus the clearance search after it (``clearance``), ``extra`` bytes held
    beside the last run (a Monte-Carlo chunk's recovery curves) and what :func:`holding`
    says is held. None for values simulate() refuses itself."""
    sizes = _run_sizes(design, dt, duration)
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
    dur, steps = _run_sizes(design, dt, duration)[:2]
    limit = max_memory()
    src = f"{design.source}: " if design.source else f"{design.name}: "
    if est["bytes"] > limit:
        held = ", ".join(([f"{runs} runs held at once"] if runs > 1 else [])
                         + ([f"{_fmt(extra)} of sampled recovery curves"] if extra else [])
                         + ([f"{_fmt(held_elsewhere())} of earlier results held"] if held_elsewhere() else [])
                         + ([f"{_fmt(est['clearance_bytes'])} for the clearance search"]
                            if est["bytes"] > est["run_bytes"] + est["held_bytes"] else []))
        held = f" ({held}: {_fmt(est['bytes'])} in all)" if held else ""
        part = (f"the 2D collision index needs {_fmt(est['index2d_bytes'])} "
                f"({steps:.3g} steps x {est['pairs']:.0f} panel pairs)" if est["index2d_bytes"] > est["trajectory_bytes"]
                else f"the trajectory and the 3D check's broad phase need {_fmt(est['run_bytes'])} "
                     f"({steps:.3g} steps of {dt:g} s over {dur:g} s x {len(design.panels)} panels)"
                     .replace("inf steps", "more than 1e308 steps"))
        lift = "use --method fcl, " if est["index2d_bytes"] > est["trajectory_bytes"] else ""
        raise ResourceError(f"{src}simulation refused: {part}{held}, over the {_fmt(limit)} memory limit; "
                            f"{lift}raise --dt, shorten --duration (or process.duration_s), or lift the "
                            f"limit with {_lift(est)}")
    budget = time_budget()
    if est["seconds"] > budget:
        raise ResourceError(f"{src}simulation refused: estimated {_fmt_s(est['seconds'])} for {steps:.3g} steps x "
                            f"{len(design.hinges)} hinges, over the {_fmt_s(budget)} time budget; raise --dt, "
                            "shorten --duration (or process.duration_s), or lift the budget with the "
                            "environment variable FOLDPRINT_TIME_BUDGET (seconds)")
    return est


#: Most panel vertices ``--mechanics bar-hinge`` takes (our choice: a 20 x 20 Miura sheet, 441
#: nodes, folds in ~10 CPU-s; one Newton iteration's sparse solve grows about linearly with
#: the nodes, and a run solves ~2-3 per grid time, ~100-300 grid times)
MAX_MECHANICS_NODES = 5000


def check_mechanics(design) -> int:
    """Refuse a bar-and-hinge run on a design with more than :data:`MAX_MECHANICS_NODES`
    panel vertices (counted before nodes on shared fold lines merge)."""
    n = sum(len(p.outline) + sum(len(h) for h in p.holes) for p in design.panels)
    if n > MAX_MECHANICS_NODES:
        src = f"{design.source}: " if design.source else f"{design.name}: "
        raise ResourceError(f"{src}--mechanics bar-hinge refused: {n} panel vertices, over the "
                            f"{MAX_MECHANICS_NODES} the bar-and-hinge solver takes; use --mechanics rigid or "
                            "simplify the panels' outlines")
    return n


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


def narrow_deadline(what: str = "the 3D swept check"):
    """A callable ``tick(progress)`` for a long loop: refuses (ResourceError) once the
    loop has run past the time budget, naming how far it got. The narrow phase's work
    depends on how close the panels come, known only while it runs: it is bounded here,
    at the budget, not estimated ahead."""
    import time

    budget = time_budget()
    t0 = time.perf_counter()

    def tick(progress: str = "") -> None:
        spent = time.perf_counter() - t0
        if spent > budget:
            raise ResourceError(f"{what} refused after {_fmt_s(spent)}, over the {_fmt_s(budget)} time budget"
                                f"{' (' + progress + ')' if progress else ''}; raise --dt, shorten --duration, "
                                "or lift the budget with the environment variable FOLDPRINT_TIME_BUDGET (seconds)")

    return tick


def check_sample_memory(design, samples: float, what: str = "the Monte-Carlo jam probability") -> dict:
    """Refuse ``samples`` Monte-Carlo folds whose outcomes (held to the end) would not fit in
    memory, before any is drawn. Time is bounded by :func:`check_samples`, on the rate
    measured on the first chunk (an a-priori rate went stale when the curves got 10x cheaper)."""
    nh = len(design.hinges)
    samples = float(samples)
    per_b = SAMPLE_BYTES + nh * SAMPLE_BYTES_PER_HINGE
    est = {"bytes": BASE_BYTES + samples * per_b, "per_sample_bytes": per_b}
    src = f"{design.source}: " if design.source else f"{design.name}: "
    limit = max_memory()
    if est["bytes"] > limit:
        raise ResourceError(f"{src}{what} refused: {samples:.3g} samples hold {_fmt(est['bytes'])} "
                            f"({_fmt(per_b)} each), over the {_fmt(limit)} memory limit; use fewer --samples "
                            f"or lift the limit with {_lift(est)} (check) or the environment variable "
                            "FOLDPRINT_MAX_MEMORY")
    return est


#: export: seconds and bytes per geometric feature (panel outline points, hinge bend
#: slices per segment, teeth), measured with benchmarks/bench_scale.py (docs/input-safety.md)
EXPORT_S_PER_FEATURE = 1.5e-3
EXPORT_BYTES_PER_FEATURE = 8_000


def export_features(design) -> float:
    """Geometric features of the printed part, counted from the design alone (no
    geometry built): outline points of every panel, and per hinge its segments (slots)
    x its bend slices (5 deg each, plus the step edges of a stepped hinge) and teeth."""
    feats = 0.0
    for p in design.panels:
        feats += len(p.outline) + sum(len(h) for h in p.holes)
    for h in design.hinges:
        st = h.style
        length = float(h.length)
        segs = 1.0
        if st.max_segment_mm > 0 and length > st.max_segment_mm:
            segs = max(2.0, math.ceil((length + st.slot_width_mm) / (st.max_segment_mm + st.slot_width_mm)))
        slices = max(1.0, math.ceil(abs(float(h.angle)) / math.radians(5.0)))
        if st.stepped and st.step_period_mm > 0:
            slices += 2 * max(1.0, round(float(h.width) / st.step_period_mm))
        teeth = 2 * length / st.tooth_pitch_mm if st.interface == Interface.TRIANGULAR and st.tooth_pitch_mm > 0 else 0.0
        feats += segs * (slices + 2) + teeth
    return feats


def check_export(design) -> dict:
    """Refuse an export whose estimated time (booleans and meshing grow with the part's
    features) or memory exceeds the limits, before any geometry is built."""
    feats = export_features(design)
    est = {"features": feats, "seconds": feats * EXPORT_S_PER_FEATURE,
           "bytes": BASE_BYTES + feats * EXPORT_BYTES_PER_FEATURE}
    src = f"{design.source}: " if design.source else f"{design.name}: "
    limit, budget = max_memory(), time_budget()
    what = (f"{len(design.panels)} panels and {len(design.hinges)} hinges ({feats:.3g} features: outline "
            "points, hinge slices x segments, teeth)")
    if est["bytes"] > limit:
        raise ResourceError(f"{src}export refused: {what} need about {_fmt(est['bytes'])}, over the "
                            f"{_fmt(limit)} memory limit; split the design, or lift the limit with the "
                            f"environment variable FOLDPRINT_MAX_MEMORY (e.g. {_fmt(est['bytes'] * 1.2).replace(' ', '')})")
    if est["seconds"] > budget:
        raise ResourceError(f"{src}export refused: {what} take about {_fmt_s(est['seconds'])} to build, over "
                            f"the {_fmt_s(budget)} time budget; split the design, use a plain hinge style "
                            "(fewer slices and teeth), or lift the budget with the environment variable "
                            "FOLDPRINT_TIME_BUDGET (seconds)")
    return est


def check_samples(samples: int, seconds_per_sample: float, workers: int, name: str = "") -> float:
    """Refuse ``samples`` Monte-Carlo samples when their estimated wall time (the measured
    seconds per sample of the first chunk x samples / workers) exceeds :func:`time_budget`.
    Returns the estimate (s). Memory does not grow with the count (samples are streamed in
    chunks); only time does."""
    est = float(samples) * max(0.0, seconds_per_sample) / max(1, int(workers))
    limit = time_budget()
    if est > limit:
        src = f"{name}: " if name else ""
        fits = max(1, int(limit * max(1, int(workers)) / max(seconds_per_sample, 1e-9)))
        raise ResourceError(f"{src}--samples {samples} refused: estimated {est:.3g} s "
                            f"({seconds_per_sample * 1e3:.3g} ms per sample measured on the first samples, "
                            f"on {workers} worker(s)), over the {limit:g} s budget; use at most about "
                            f"{fits} samples, or raise the budget with the environment variable "
                            "FOLDPRINT_TIME_BUDGET (seconds)")
    return est


#: voxel export (``export --format voxels``), measured with benchmarks/bench_voxels.py on
#: the 150 x 150 x 20 mm plate (docs/voxels.md: the writer of e4bbc23, 180 MB peak, 39.8
#: CPU-s for 4.65e9 voxels = 0.86e-8 s, rounded up; the pre-change writer's 309 MB /
#: 105 CPU-s set the memory figures below, kept as an upper bound):
#: bytes per pixel of one slice (the label image, a region's mask, its thresholds and
#: fraction, the scan-line counts and their cumulative sum, the packed rows); per graded
#: hinge its u table (<= 2e6 cells, 16 MB) and, while it is made, the cell centres and
#: their search (48 MB, one at a time); CPU seconds per voxel. Slices are streamed, so
#: memory does not grow with the layer count.
VOXEL_BYTES_PER_PIXEL = 20
VOXEL_TABLE_BYTES = 16 * 2 ** 20
VOXEL_TABLE_BUILD_BYTES = 48 * 2 ** 20
VOXEL_S_PER_VOXEL = 0.9e-8


def check_voxels(shape: tuple[int, int, int], src: str = "", graded: int = 0) -> dict:
    """Refuse a voxel stack whose memory (one slice, plus the u tables of ``graded``
    hinges graded across their width) or whole-stack time would exceed the limits, before
    any slice is made. ``shape``: (nx, ny, layers)."""
    nx, ny, nz = (float(v) for v in shape)
    tables = graded * VOXEL_TABLE_BYTES + (VOXEL_TABLE_BUILD_BYTES if graded else 0)
    est = {"bytes": BASE_BYTES + nx * ny * VOXEL_BYTES_PER_PIXEL + tables,
           "seconds": nx * ny * nz * VOXEL_S_PER_VOXEL}
    limit, budget = max_memory(), time_budget()
    what = f"a {nx:.0f} x {ny:.0f} pixel x {nz:.0f} layer voxel stack"
    if est["bytes"] > limit:
        raise ResourceError(f"{src}voxel export refused: {what} needs about {_fmt(est['bytes'])} per slice, over the "
                            f"{_fmt(limit)} memory limit; print the part in pieces, or lift the limit with the "
                            f"environment variable FOLDPRINT_MAX_MEMORY (e.g. {_fmt(est['bytes'] * 1.2).replace(' ', '')})")
    if est["seconds"] > budget:
        raise ResourceError(f"{src}voxel export refused: {what} takes about {_fmt_s(est['seconds'])}, over the "
                            f"{_fmt_s(budget)} time budget; print the part in pieces, or lift the budget with the "
                            "environment variable FOLDPRINT_TIME_BUDGET (seconds)")
    return est
