"""Resource guards: estimate a run's memory and work before allocating, and refuse with a
:class:`ResourceError` (exit 2) that names the limit and how to lift it, never a MemoryError.

The estimate (``docs/robustness.md``) counts the arrays a simulation holds at once:

* the trajectory: ``n_t`` time steps x (panels x a 4x4 pose + hinges x ratios/angles and
  their temporaries), 8-byte floats;
* the paper's 2D index (``method`` index2d/both on a planar strip): ``n_t`` x panel pairs x
  (index value 8 B + contact flags 3 x 1 B), plus the side segments per step;
* the 3D swept check works pair by pair; its work is ``n_t`` x non-adjacent pairs.

The memory limit defaults to :data:`DEFAULT_MAX_MEMORY` (2 GiB, or the environment
variable ``FOLDPRINT_MAX_MEMORY``); the CLI's ``--max-memory`` sets it for one run.
"""

from __future__ import annotations

import math
import os
import re

from .errors import FoldprintError

GiB = 2 ** 30
DEFAULT_MAX_MEMORY = 2 * GiB
#: Pair-steps the 3D swept check may visit (n_t x non-adjacent pairs), or the environment
#: variable ``FOLDPRINT_MAX_WORK``. Measured with ``foldprint check`` on uniform strips:
#: 60 panels (3.4e6 pair-steps) 6 s, 120 panels (1.4e7) 47 s; 5e6 keeps a check near 10 s.
MAX_WORK = 5e6

_LIMIT = {"bytes": None}


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
    if not math.isfinite(size) or size <= 0:
        raise FoldprintError(f"--max-memory must be > 0, got {text!r}")
    return int(size)


def set_max_memory(text: str | int | float | None) -> None:
    """Set the memory limit for this process (None: back to the default)."""
    _LIMIT["bytes"] = None if text is None else parse_size(text)


def max_memory() -> int:
    if _LIMIT["bytes"] is not None:
        return _LIMIT["bytes"]
    env = os.environ.get("FOLDPRINT_MAX_MEMORY")
    return parse_size(env) if env else DEFAULT_MAX_MEMORY


def _fmt(n: float) -> str:
    for unit, size in (("TiB", 2 ** 40), ("GiB", GiB), ("MiB", 2 ** 20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def simulation_estimate(n_panels: int, n_hinges: int, n_steps: float, use2d: bool,
                        n_segments: int | None = None) -> dict:
    """Bytes held at once and pair-steps of work for one simulation run."""
    pairs = n_panels * (n_panels - 1) / 2
    segs = n_panels if n_segments is None else n_segments
    traj = n_steps * (n_panels * 16 * 8 * 2 + n_hinges * 8 * 12 + 8)
    index = n_steps * (pairs * (8 + 3) + segs * 4 * 8 * 3) if use2d else 0.0
    nonadj = max(0.0, pairs - max(0, n_hinges))
    return {"bytes": traj + index, "trajectory_bytes": traj, "index2d_bytes": index,
            "work": n_steps * nonadj, "steps": n_steps, "pairs": pairs}


def check_simulation(design, dt: float, duration: float | None, method: str) -> dict:
    """Refuse a simulation that would exceed the memory limit or the work bound.

    Called at the top of :func:`foldprint.simulate.simulate` (one line)."""
    dur = float(design.process.duration_s if duration is None else duration)
    if not (math.isfinite(dur) and math.isfinite(dt) and dur > 0 and dt > 0):
        return {}  # simulate() reports bad values itself
    steps = math.ceil(dur / dt) + 1
    use2d = str(getattr(method, "value", method)) in ("index2d", "both") and design.is_planar_strip
    n_seg = sum(len(p.outline) + sum(len(h) for h in p.holes) for p in design.panels)
    est = simulation_estimate(len(design.panels), len(design.hinges), steps, use2d, n_seg)
    limit = max_memory()
    src = f"{design.source}: " if design.source else f"{design.name}: "
    if est["bytes"] > limit:
        part = (f"the 2D collision index needs {_fmt(est['index2d_bytes'])} "
                f"({steps:.3g} steps x {est['pairs']:.0f} panel pairs)" if est["index2d_bytes"] > est["trajectory_bytes"]
                else f"the trajectory needs {_fmt(est['trajectory_bytes'])} ({steps:.3g} steps of {dt:g} s "
                     f"over {dur:g} s x {len(design.panels)} panels)")
        lift = "use --method fcl, " if est["index2d_bytes"] > est["trajectory_bytes"] else ""
        raise ResourceError(f"{src}simulation refused: {part}, over the {_fmt(limit)} memory limit; "
                            f"{lift}raise --dt, shorten --duration (or process.duration_s), or lift the "
                            f"limit with --max-memory (e.g. --max-memory {_fmt(est['bytes'] * 1.2).replace(' ', '')})")
    max_work = float(os.environ.get("FOLDPRINT_MAX_WORK") or MAX_WORK)
    if str(getattr(method, "value", method)) in ("fcl", "both") and est["work"] > max_work:
        raise ResourceError(f"{src}simulation refused: the 3D swept check would visit {est['work']:.3g} "
                            f"pair-steps ({steps:.3g} steps x {est['pairs'] - len(design.hinges):.0f} "
                            f"non-adjacent panel pairs), over the bound of {max_work:.3g}; raise --dt or "
                            "shorten --duration (or process.duration_s), split the design, or lift the "
                            "bound with the environment variable FOLDPRINT_MAX_WORK")
    return est


#: Exact distance queries the clearance margin (check's FP172) may make: about 0.1 ms each,
#: so 1e5 is ~10 s. Up to 200 frames are sampled; fewer when there are many panel pairs
#: (at least 10), so the margin of a large design is coarser in time but bounded in work.
MAX_DISTANCE_QUERIES = 100_000


def clearance_stride(n_times: int, n_pairs: int) -> int:
    """Sampling stride over the trajectory for the clearance margin, bounded in work."""
    frames = min(200, max(10, MAX_DISTANCE_QUERIES // max(1, n_pairs)))
    return max(1, n_times // frames)


#: Seconds a Monte-Carlo run (``robust``, ``check``'s jam probability) may be estimated to
#: take before it is refused, or the environment variable ``FOLDPRINT_MAX_SECONDS``.
#: One hour: a run that long is a decision, not a default (1000 helix samples: 54 CPU-s,
#: measured, docs/robustness-model.md).
DEFAULT_MAX_SECONDS = 3600.0


def max_seconds() -> float:
    env = os.environ.get("FOLDPRINT_MAX_SECONDS")
    if not env:
        return DEFAULT_MAX_SECONDS
    try:
        value = float(env)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise FoldprintError(f"FOLDPRINT_MAX_SECONDS must be a number of seconds > 0, got {env!r}")
    return value


def check_samples(samples: int, seconds_per_sample: float, workers: int, name: str = "") -> float:
    """Refuse ``samples`` Monte-Carlo samples when their estimated wall time (the measured
    seconds per sample of the first chunk x samples / workers) exceeds :func:`max_seconds`.
    Returns the estimate (s). Memory does not grow with the count (samples are streamed in
    chunks); only time does."""
    est = float(samples) * max(0.0, seconds_per_sample) / max(1, int(workers))
    limit = max_seconds()
    if est > limit:
        src = f"{name}: " if name else ""
        fits = max(1, int(limit * max(1, int(workers)) / max(seconds_per_sample, 1e-9)))
        raise ResourceError(f"{src}--samples {samples} refused: estimated {est:.3g} s "
                            f"({seconds_per_sample * 1e3:.3g} ms per sample measured on the first samples, "
                            f"on {workers} worker(s)), over the {limit:g} s budget; use at most about "
                            f"{fits} samples, or raise the budget with the environment variable "
                            "FOLDPRINT_MAX_SECONDS")
    return est
