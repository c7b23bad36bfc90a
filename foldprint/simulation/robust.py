"""Jam probability under manufacturing and process scatter (Monte-Carlo).

Real parts are not nominal: the bath temperature varies from run to run and the
heat-transfer coefficient of the whole part by the error of its correlation (both shared
by every hinge of a sample); Tg varies from hinge to hinge with the digital-material mix,
hinge thickness with the printer's tolerance, and h locally with the hinge's place on the
part. Each sample is drawn by :func:`foldprint.simulation.scatter.draw_samples` (the model, its
sources in ``foldprint/data/scatter.toml``, ``docs/robustness-model.md``); this module
builds every hinge's recovery curve from the perturbed values, and folds the printed
geometry (arc hinges, the 3D swept check, every goal) with
:func:`foldprint.simulation.simulate.simulate`. A sample *jams* when it does not complete: a
collision, a goal unmet or out of order, or a hinge short of 98 %.

Samples are drawn from one seeded generator, in order, streamed in chunks of
:data:`CHUNK` (memory stays bounded whatever ``--samples`` is), and evaluated in any
order on any number of processes: the same seed gives the same answer. The recovery
curves of a chunk are computed in one array pass per hinge material
(:func:`sample_drives`, :mod:`foldprint.physics.recovery.batch`, the relaxation sum read from
its table: within 2e-8 of the per-curve model); a run whose estimated time exceeds the budget of
:func:`foldprint.simulation.costs.check_samples` is refused after its first chunk.
"""

from __future__ import annotations

import ctypes
import math
import sys
from dataclasses import dataclass, replace
from functools import lru_cache
from itertools import islice
from typing import Callable, Sequence

import numpy as np

from ..model.derived import design_scope
from . import costs
from ..model.design import Design, has_loops
from ..core.constants import DEFAULT_DT_S, DEFAULT_SEED, ROBUST_SAMPLES
from ..core.errors import DesignError, MaterialError
from ..core.jit import use_kernels, work_cpu_s
from ..physics.hinge_drive import HingeDrive, run_times, solve_loops_many
from ..model.materials import MaterialLibrary, default_library
from ..core.modes import (DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, VERDICT_METHOD, HingeModel, JamReason, Mechanics,
                          Method, parse)
from ..physics.recovery.curve import RecoveryCurve, recovery_curve
from ..physics.recovery.batch import grid_until, material_batch_ratios
# What is drawn (the model, its data file, the samples) lives in foldprint.simulation.scatter; this
# module folds what it draws. Re-exported so callers keep importing them from here.
from .scatter import (Sample, Scatter, default_scatter, draw_samples, iter_samples,  # noqa: F401
                      load_scatter)
from .simulate import SimulationResult, simulate
from .jamtest.verdict import INTERVAL_NAME, JamDecision

#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054
#: Samples per task: drawn, given their curves in one array pass and folded together.
#: Fixed (not tied to the number of workers), though the answer does not depend on it.
CHUNK = 16
#: Bytes of sampled recovery curves made at once (ratio and mean temperature, 8 B each per
#: time point, twice while a batch's parts are joined): a chunk of 16 samples of a
#: 1000-hinge strip held 1.3 GB in one pass; its samples are now given their curves a few
#: at a time (one at a time there), the same curves, so memory stays bounded.
CURVE_BATCH_BYTES = 128 * 2 ** 20


#: Chunks per task of a fixed-size run after its first chunk (:func:`jam_probability`): a
#: task pays about 5 ms beside its samples (its draws, one curve call per hinge material;
#: measured on helix_graded with the compiled kernels: 7.0 CPU-ms a sample in chunks of 16,
#: 14 in chunks of 1), a tenth of a chunk of 16 strip samples at 2-3 ms each; four chunks a
#: task pay it once in 40. Our choice; a task folds its chunks as separate chunks would
#: (its curves in batches of at most a chunk), so the answer does not depend on it.
TASK_CHUNKS = 4


def task_chunks(design: Design, dt: float, samples: int, workers: int) -> int:
    """Chunks per task of a fixed-size run of ``samples`` after its first chunk: up to
    :data:`TASK_CHUNKS`, fewer when that would leave a worker of ``workers`` without two
    tasks, one when a chunk's curves are made in more than one batch (a large design: its
    tasks keep the chunks' batches, and a chunk's overhead is small beside its samples)."""
    if curve_batch(design, dt)[0] < CHUNK:
        return 1
    return max(1, min(TASK_CHUNKS, n_chunks(max(0, samples - CHUNK)) // (2 * max(1, workers))))


def n_chunks(samples: int) -> int:
    """How many chunks of :data:`CHUNK` hold ``samples`` samples (the last may be short)."""
    return -(-samples // CHUNK)



def sample_drive(design: Design, library: MaterialLibrary, sample: Sample, *, until_s: float | None = None,
                 exact: bool = False) -> HingeDrive:
    """The hinge drive of one sample: each hinge's curve from its perturbed material.

    ``exact``: the reference path, one cached :func:`~foldprint.physics.recovery.curve.recovery_curve`
    per hinge over the whole model horizon (``until_s`` ignored); otherwise
    :func:`sample_drives`, equal to it to round-off up to ``until_s``."""
    if not exact:
        return sample_drives(design, library, [sample], until_s=until_s)[0]
    curves = []
    for k, h in enumerate(design.hinges):
        mat = library[h.material]
        rec = replace(mat.recovery, h_w_m2k=mat.recovery.h_w_m2k * float(sample.h_scale[k]))
        mat = replace(mat, tg_c=mat.tg_c + float(sample.tg_shift_c[k]), recovery=rec)
        curves.append(recovery_curve(mat, sample.bath_c, float(sample.thickness_mm[k]),
                                     design.process.fix_temperature_c))
    return HingeDrive(design, sample.bath_c, library, curves=curves)


def run_end(design: Design, dt: float, duration: float | None = None) -> float:
    """The last time (s) a simulation of ``design`` at step ``dt`` reaches (its times are
    0, dt, ... up to the first at or past the duration): the curves are needed up to here."""
    return float(run_times(design, dt, duration)[-1])


def sample_drives(design: Design, library: MaterialLibrary, samples: Sequence[Sample],
                  until_s: float | None = None) -> list[HingeDrive]:
    """The hinge drives of ``samples``: the recovery curves of every hinge of every sample
    in one array pass per hinge material (:func:`foldprint.physics.recovery.batch.batch_ratios`),
    on the recovery model's grid up to ``until_s`` (default: the whole horizon; a curve
    holds its last value past it, and its ``time_to`` sees only up to it).

    This is the boundary between drawing the parameters (:func:`iter_samples`) and the
    physics: a sample is per hinge a Tg shift, a thickness, an h multiplier, and a bath."""
    samples = list(samples)
    n_s, n_h = len(samples), len(design.hinges)
    if n_s == 0:
        return []
    t = grid_until(float("inf") if until_s is None else float(until_s))
    t.setflags(write=False)
    fix_c = float(design.process.fix_temperature_c)
    tg_shift = np.array([s.tg_shift_c for s in samples], float).reshape(n_s, n_h)
    thick = np.array([s.thickness_mm for s in samples], float).reshape(n_s, n_h)
    h_scale = np.array([s.h_scale for s in samples], float).reshape(n_s, n_h)
    bath = np.array([s.bath_c for s in samples], float)
    for name, arr in (("bath temperature", bath), ("Tg shift", tg_shift), ("hinge thickness", thick),
                      ("heat-transfer multiplier", h_scale)):
        if not np.all(np.isfinite(arr)):
            raise MaterialError(f"{design.name}: a drawn {name} is not finite")
    if np.any(thick <= 0):
        raise MaterialError(f"{design.name}: a drawn hinge thickness is <= 0 mm")
    curves: list[list] = [[None] * n_h for _ in range(n_s)]
    stacks = np.empty((n_s, n_h, len(t)))  # each sample's ratios, a row per hinge: its drive's lookup
    by_material: dict[str, list[int]] = {}
    for k, h in enumerate(design.hinges):
        by_material.setdefault(h.material, []).append(k)
    for name, ks in by_material.items():
        mat = library[name]
        p = mat.recovery
        if p is None:
            raise MaterialError(f"material {name!r} (role {mat.role}) has no recovery model; "
                                "hinges need a hinge material such as H-1..H-7")
        cols = np.array(ks)
        tg = (mat.tg_c + tg_shift[:, cols]).ravel()  # (n_s * len(ks),), sample-major
        hw = (p.h_w_m2k * h_scale[:, cols]).ravel()
        th = thick[:, cols].ravel()
        tb = np.repeat(bath, len(ks))
        ratio, mean_t = material_batch_ratios(mat, tg, hw, th, tb, fix_c, t, table=True)
        ratio.setflags(write=False)
        mean_t.setflags(write=False)
        stacks[:, cols] = ratio.reshape(n_s, len(ks), len(t))
        for j, (tg_j, tb_j, th_j, r_j, m_j) in enumerate(zip(tg.tolist(), tb.tolist(), th.tolist(), ratio, mean_t)):
            s, k = divmod(j, len(ks))
            curves[s][ks[k]] = RecoveryCurve(name, tg_j, tb_j, th_j, fix_c, t, r_j, m_j)
    stacks.setflags(write=False)
    first = HingeDrive(design, samples[0].bath_c, library, curves=curves[0], stack=stacks[0].T)
    return [first] + [HingeDrive(design, smp.bath_c, library, curves=c, stack=st.T, statics=first.statics())
                      for smp, c, st in zip(samples[1:], curves[1:], stacks[1:])]


@dataclass(frozen=True)
class Outcome:
    """What became of one sample."""

    jammed: bool
    reason: JamReason | None  # None: it did not jam
    pair: tuple[str, str] | None  # the first colliding panels
    time: float | None  # first contact (s)
    fold_time: float | None  # every hinge at 98 % (s), when it completed


def outcome_of(result: SimulationResult) -> Outcome:
    c = result.first_collision
    if result.completed:
        return Outcome(False, None, None, None, result.fold_time)
    if c is not None:
        return Outcome(True, JamReason.COLLISION, tuple(sorted(c.panels)), float(c.time), None)
    if not all(g.met for g in result.goals):
        return Outcome(True, JamReason.GOAL, None, None, None)
    return Outcome(True, JamReason.UNFOLDED, None, None, None)


def run_sample(args) -> Outcome:
    """Fold one sample with the exact per-curve drive (the reference path; a module-level
    function, so processes and clusters can run it). ``args``: (design, library, sample,
    hinge_model, dt[, method[, mechanics]]), the method :data:`~foldprint.core.modes.VERDICT_METHOD`
    and rigid mechanics by default."""
    design, library, sample, hinge_model, dt, *rest = args
    method = rest[0] if rest else VERDICT_METHOD
    drive = sample_drive(design, library, sample, exact=True)
    res = simulate(design, dt=dt, method=method, hinge_model=hinge_model, drive=drive,
                   mechanics=rest[1] if len(rest) > 1 else DEFAULT_MECHANICS)
    return outcome_of(res)


def warm_kernels(args) -> None:
    """Load (or, on a cold numba cache, compile: seconds, once per install) every compiled
    kernel a fold of ``args`` (:func:`run_samples`' arguments) uses, by folding its first
    sample, so that a run's first chunk, which the time guard extrapolates, is timed at
    the kernels' speed and not at the compiler's. Nothing where the numpy path runs. A
    pattern with loops folds its first two samples: the closure's compiled round tracks
    two or more drives (one takes the reference tracker, 0.13 CPU-s on ``miura_3x3``,
    against 0.06 for two compiled), and processes forked after it inherit that kernel."""
    if use_kernels() and len(args[2]):
        run_samples((args[0], args[1], list(args[2])[:2 if has_loops(args[0]) else 1], *args[3:]))
        from ..collision.polytope_distance import warm_kernel

        warm_kernel()  # the narrow phase's distance: a sample the screen certifies never asks for it


#: glibc's malloc: blocks up to this size come from the heap, not from fresh mappings
#: (its largest setting on 64 bits), and up to ``HEAP_KEEP_BYTES`` freed at the heap's top
#: stay with the process (our choice: a chunk's curves and trajectories are ~20 MB)
MMAP_BYTES = 32 * 2 ** 20
HEAP_KEEP_BYTES = 64 * 2 ** 20


@lru_cache(maxsize=1)
def keep_heap() -> bool:
    """Keep the memory a sample frees for the next one (glibc's ``mallopt``; True where it
    took). By default glibc maps a large block afresh or gives the heap's freed top back,
    so a jamming strip sample touched ~165 new pages (its trajectory's 2.5 MB of poses
    among them) and spent 0.5 ms of its ~2.5 in the kernel's page faults; the next sample's
    arrays now reuse them. Other C libraries: nothing (False)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
        return bool(libc.mallopt(-3, MMAP_BYTES) and libc.mallopt(-1, HEAP_KEEP_BYTES))  # M_MMAP_, M_TRIM_THRESHOLD
    except (OSError, AttributeError):
        return False


def run_samples(args) -> list[Outcome]:
    """Fold a chunk of samples: their curves in one pass (:func:`sample_drives`), the
    closure of a pattern with loops tracked for all of them in lockstep
    (:func:`foldprint.physics.hinge_drive.solve_loops_many`), then one fold each. ``args``:
    (design, library, samples, hinge_model, dt[, exact[, method[, mechanics]]]), the method
    :data:`~foldprint.core.modes.VERDICT_METHOD` and rigid mechanics by default (``bar-hinge``:
    each sample folds the bar-and-hinge model on its own curves). The design's derived data
    (hinge frames, spanning tree, rigid polygons) and FCL geometry are made once per
    process and design content (:func:`foldprint.model.derived.design_scope`), not per chunk."""
    keep_heap()
    with design_scope(args[0]) as design:
        return _run_samples((design, *args[1:]))


def _run_samples(args) -> list[Outcome]:
    design, library, samples, hinge_model, dt, *rest = args
    method = rest[1] if len(rest) > 1 else VERDICT_METHOD
    mech = parse(Mechanics, rest[2] if len(rest) > 2 else DEFAULT_MECHANICS, "mechanics")
    if rest and rest[0]:
        return [run_sample((design, library, s, hinge_model, dt, method, mech)) for s in samples]
    samples, until = list(samples), run_end(design, dt)
    per = curve_batch(design, dt)[0]
    out = []
    for a in range(0, len(samples), per):
        drives = sample_drives(design, library, samples[a:a + per], until_s=until)
        if mech == Mechanics.RIGID:
            solve_loops_many(drives, run_times(design, dt))  # a pattern with loops: closure tracked in lockstep
        out += [outcome_of(simulate(design, dt=dt, method=method, hinge_model=hinge_model, drive=d, mechanics=mech))
                for d in drives]
    return out


def curve_batch(design: Design, dt: float, samples: int = CHUNK) -> tuple[int, float]:
    """(samples given their curves at once, the bytes those curves hold while made) of a
    chunk of ``samples`` folded at step ``dt``: :func:`curves_at_once` up to the run's end
    (what the memory guard adds for a sample's fold)."""
    return curves_at_once(design, run_end(design, dt), samples)


def curves_at_once(design: Design, until_s: float, samples: int) -> tuple[int, float]:
    """(samples given their curves at once, the bytes those curves hold while made) of
    ``samples`` whose curves run to ``until_s``: ratio and mean temperature, 8 B each per
    hinge and time point, twice while a batch's parts are joined; at most
    CURVE_BATCH_BYTES, or one sample when one is larger."""
    one = 32.0 * len(design.hinges) * len(grid_until(until_s))
    per = max(1, min(int(samples), int(CURVE_BATCH_BYTES // max(1.0, one))))
    return per, per * one


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k / n.

    >>> [round(x, 4) for x in wilson(0, 60)]
    [0.0, 0.0602]
    """
    if n <= 0:
        raise ValueError("n must be > 0")
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass(frozen=True)
class RobustResult:
    """A jam probability: the ``samples`` outcomes of the stream of ``seed``; with a
    ``decision`` (``check``'s sequential test, :mod:`foldprint.simulation.jamtest.verdict`) they
    are the samples the test used, up to its stop, and the interval is its anytime-valid
    confidence sequence; without, a fixed count and its Wilson interval."""

    design: str
    samples: int
    seed: int
    hinge_model: HingeModel
    scatter: Scatter
    outcomes: tuple[Outcome, ...]
    nominal: SimulationResult
    method: Method = VERDICT_METHOD
    decision: JamDecision | None = None
    mechanics: Mechanics = DEFAULT_MECHANICS

    @property
    def jams(self) -> int:
        return sum(o.jammed for o in self.outcomes)

    @property
    def jam_probability(self) -> float:
        return self.jams / self.samples

    @property
    def ci95(self) -> tuple[float, float]:
        """The 95 % interval: the test's confidence sequence, else Wilson's."""
        return self.decision.interval if self.decision is not None else wilson(self.jams, self.samples)

    @property
    def interval_name(self) -> str:
        return INTERVAL_NAME if self.decision is not None else "Wilson score interval"

    def collisions(self) -> list[tuple[tuple[str, str], int]]:
        """Colliding pairs, most frequent first (ties by name)."""
        counts: dict = {}
        for o in self.outcomes:
            if o.pair is not None:
                counts[o.pair] = counts.get(o.pair, 0) + 1
        return sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))

    def fold_time_percentiles(self) -> dict | None:
        """5th, 50th, 95th percentile of the fold time of the samples that completed."""
        ft = np.array([o.fold_time for o in self.outcomes if o.fold_time is not None])
        if ft.size == 0:
            return None
        p5, p50, p95 = np.percentile(ft, [5, 50, 95])
        return {"p5": float(p5), "p50": float(p50), "p95": float(p95)}


def jam_probability(design: Design, samples: int = ROBUST_SAMPLES, seed: int = DEFAULT_SEED, *, scatter: Scatter | None = None,
                    library: MaterialLibrary | None = None, hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                    dt: float = DEFAULT_DT_S, nominal: SimulationResult | None = None, workers: int | None = None,
                    progress: Callable[[int, int], None] | None = None, mapper=None,
                    exact: bool = False, method: Method | str = VERDICT_METHOD,
                    mechanics: Mechanics | str = DEFAULT_MECHANICS) -> RobustResult:
    """Monte-Carlo estimate of the probability that ``design`` jams.

    ``nominal``: the nominal simulation if the caller has it (else it is run here).
    ``mapper(fn, items, progress)``: how to run the chunks of samples (default: all local
    cores, :func:`foldprint.core.parallel.map_ordered`); a
    :class:`foldprint.simulation.jamtest.pool.Precomputed` mapper that holds these samples' outcomes
    (folded in a shared pool, :func:`~foldprint.simulation.jamtest.pool.run_batch`) returns them
    without folding. ``exact``: the reference path (one
    cached curve per hinge over the whole horizon, as before the batch path), for
    comparisons. ``method``: the collision check of the nominal fold and of every sample;
    ``mechanics``: theirs (``bar-hinge``: slow, the first chunk's time guards the rest).
    The first chunk runs here and times the run: a sample count whose
    estimated time exceeds the budget (:func:`foldprint.simulation.costs.check_samples`) is refused."""
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise DesignError(f"samples must be a whole number >= 1, got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise DesignError(f"seed must be a whole number >= 0, got {seed!r}")
    from ..core.parallel import default_workers, map_ordered

    lib = library or default_library()
    scatter = scatter or default_scatter()
    model = parse(HingeModel, hinge_model, "hinge_model")
    method = parse(Method, method, "method")
    mech = parse(Mechanics, mechanics, "mechanics")
    costs.check_sample_memory(design, samples)  # refuse before any fold: the outcomes are held
    if nominal is None:
        nominal = simulate(design, dt=dt, method=method, hinge_model=model, library=lib, mechanics=mech)
    # simulation.jamtest.pool.Precomputed (folded in a shared pool) holds rigid folds only
    lookup = getattr(mapper, "lookup", None) if mech == Mechanics.RIGID else None
    done_before = lookup(design, scatter, samples, seed, model, dt, method) if lookup is not None else None
    if done_before is not None:
        if progress:
            progress(samples, samples)
        return RobustResult(design.name, samples, seed, model, scatter, tuple(done_before), nominal, method,
                            mechanics=mech)
    if mech == Mechanics.BAR_HINGE and samples > 1:  # minutes before a first chunk of compliant folds is timed
        costs.check_mechanics_samples(nominal, samples, default_workers() if workers is None else max(1, int(workers)),
                                      design.name)
    if mech == Mechanics.RIGID and samples > CHUNK:  # a fold whose search alone puts them over: refused before
        costs.check_swept_samples(nominal, samples, default_workers() if workers is None else max(1, int(workers)),
                                  design.name)
    stream = iter_samples(design, scatter, samples, seed)
    n_workers = default_workers() if workers is None else max(1, int(workers))
    task = CHUNK * task_chunks(design, dt, samples, n_workers)  # after the first chunk, which times the run
    chunks = ((design, lib, chunk, model, dt, exact, method, mech)
              for chunk in iter(lambda: list(islice(stream, task)), []))
    chunks_total = 1 + -(-max(0, samples - CHUNK) // task)
    done = [0]

    def report(n: int) -> None:
        done[0] = min(samples, done[0] + n)
        if progress:
            progress(done[0], samples)

    head = (design, lib, list(islice(stream, CHUNK)), model, dt, exact, method, mech)
    warm_kernels(head)  # the guard times kernels, not the compiler
    start = work_cpu_s()  # CPU: the budget is work, not the load of a shared machine (nor the compiler's)
    first = run_samples(head)  # here: it times the run before the rest is started
    report(len(first))
    if chunks_total > 1:
        costs.check_samples(samples, (work_cpu_s() - start) / len(first), n_workers, design.name)
        chunk_done = lambda _d, _n: report(task)  # noqa: E731 - progress in samples, not tasks
        if mapper is None:
            rest = map_ordered(run_samples, chunks, workers=workers, progress=chunk_done, total=chunks_total - 1)
        else:
            rest = mapper(run_samples, list(chunks), chunk_done)
    else:
        rest = []
    outcomes = tuple(o for chunk in [first, *rest] for o in chunk)
    return RobustResult(design.name, samples, seed, model, scatter, outcomes, nominal, method, mechanics=mech)
