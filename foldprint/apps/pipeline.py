"""The one place the stages are chained:

    design -> simulation (once) -> assembly -> gaps and clearance -> jam probability
           -> checks (given all of these, computing none) -> writers

``cli``, ``gallery`` and ``assign`` call this module; no stage below it calls another
stage's entry point. The verdict is about the printed part: the simulation defaults to
the arc hinges that ``export`` writes (:data:`foldprint.core.modes.DEFAULT_HINGE_MODEL`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterable

from ..core import guards
from ..checks.rules import (CheckContext, Finding, Printer, Thresholds, default_printer_key, default_voxel_printer_key,
                            load_printers, run_checks)
from ..collision.clearance import Gap, gaps_in_pose, min_clearance
from ..collision.swept3d import SweptChecker
# what ``check`` runs by default, defined once (the command line and the gallery read it too)
from ..core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED  # noqa: F401 (re-exported)
from ..model.design import Design
from ..core.errors import ExportError, GeometryError
from ..exchange.voxels import TANGO_BLACK, VERO_WHITE, Pitch, Uniform, VoxelPart, VoxelRegion
from ..exchange.export import ANIMATION_DT_S, DEFAULT_FORMATS, TRAJECTORY_FORMATS, check_formats, export_assembly
from ..geometry import Assembly, build_assembly, hinge_axes
from ..physics.kinematics import forward, target_angles
from ..model.composition import fraction_profile
from ..model.materials import MaterialLibrary, default_library
from ..core.modes import (DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_METHOD, DEFAULT_STATE, AfterContact,
                    HingeModel, Method, State, parse)
from ..simulation.robust import (Outcome, RobustResult, Sample, Scatter, draw_samples, jam_probability, outcome_of,
                     sample_drive)
from ..simulation.sensitivity import SweepPoint, sweep
from ..simulation.simulate import SimulationResult, simulate



def build(design: Design, state: State | str = DEFAULT_STATE,
          library: MaterialLibrary | None = None) -> Assembly:
    """The printable part in ``state``: one watertight body per material."""
    st = parse(State, state, "state")
    return build_assembly(design, st.value, library or default_library())


def voxel_pitch(printer: str | None = None, printers_file: str | Path | None = None) -> Pitch:
    """The voxel pitch of a printer profile (``data/printers.toml``; default: the one
    marked ``voxel_default``, the J750); ExportError names printers that have one."""
    printers = load_printers(printers_file)
    key = printer or default_voxel_printer_key()
    pr = printers.get(key)
    if pr is None or pr.voxel_mm is None:
        have = sorted(k for k, p in printers.items() if p.voxel_mm is not None)
        what = "unknown printer" if pr is None else "printer without a voxel pitch (voxel_mm)"
        raise ExportError(f"--printer {key!r}: {what}; voxel print knows {have}")
    return Pitch(*pr.voxel_mm, printer=f"{key} ({pr.name})", source=pr.voxel_source)


def voxel_part(design: Design, assembly: Assembly, library: MaterialLibrary | None = None,
               pitch: Pitch | None = None, profiles: Callable | None = None) -> VoxelPart:
    """What the voxel writer writes: every panel and hinge of ``assembly`` (its units)
    with its VeroWhite fraction profile (panels: VeroWhite 1, TangoBlack 0; hinges:
    ``profiles(library, material)``, by default :func:`foldprint.model.composition.fraction_profile`)
    and, for hinges, the axes that give u (:func:`foldprint.geometry.hinge_axes`)."""
    lib = library or default_library()
    profiles = profiles or fraction_profile
    axes = hinge_axes(design, assembly.state)
    regions = []
    for u in assembly.units:
        if u.kind == "panel":
            if u.material not in (VERO_WHITE, TANGO_BLACK):
                raise ExportError(f"panel {u.owner!r}: material {u.material!r} is not a base resin; voxel print "
                                  f"jets panels in {VERO_WHITE} or {TANGO_BLACK} (set the panel's material)")
            prof = Uniform(1.0 if u.material == VERO_WHITE else 0.0)
            regions.append(VoxelRegion("panel", u.owner, u.material, u.solid, prof))
        else:
            regions.append(VoxelRegion("hinge", u.owner, u.material, u.solid, profiles(lib, u.material),
                                       axes.get(u.owner)))
    return VoxelPart(design.name, assembly.state, tuple(regions), pitch or voxel_pitch(), assembly.print_offset)


def export(design: Design, out_dir: str | Path, state: State | str = DEFAULT_STATE,
           formats: Iterable[str] = DEFAULT_FORMATS, library: MaterialLibrary | None = None,
           printer: str | None = None) -> list[dict]:
    """Build ``design`` in ``state`` and write ``formats`` into ``out_dir``; the records
    of :func:`foldprint.exchange.export.export_assembly`. The fold is simulated (arc
    hinges, the defaults) only when a format shows it over time (xdmf, glb); the voxel
    stack (``voxels``) is rasterised at ``printer``'s pitch (default: the J750)."""
    lib = library or default_library()
    formats = check_formats(formats)  # before the (slower) build
    guards.check_export(design)  # time and memory of the build, estimated from the design
    pitch = voxel_pitch(printer) if "voxels" in formats else None
    trajectory = None
    if any(f in TRAJECTORY_FORMATS for f in formats):
        trajectory = simulate(design, dt=ANIMATION_DT_S, library=lib).trajectory
    assembly = build(design, state, lib)
    voxels = None
    if pitch is not None:
        voxels = voxel_part(design, assembly, lib, pitch)
        graded = sum(1 for r in voxels.regions if r.constant is None and not r.along_length)
        guards.check_voxels(voxels.grid().shape, f"{design.source}: " if design.source else f"{design.name}: ", graded)
    return export_assembly(design, assembly, out_dir, formats, lib, trajectory, voxels)


@dataclass(frozen=True)
class Comparison:
    """The other hinge model's verdict on the same design, when it differs."""

    hinge_model: HingeModel
    result: SimulationResult


def run_simulation(design: Design, *, library: MaterialLibrary | None = None, bath_c: float | None = None,
                   duration: float | None = None, dt: float = 0.01, method: Method | str = DEFAULT_METHOD,
                   hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                   after_contact: AfterContact | str = DEFAULT_AFTER_CONTACT,
                   compare: bool = False) -> tuple[SimulationResult, Comparison | None]:
    """The simulation, and (``compare``) the other hinge model's result when its verdict
    (completes or not, first colliding pair) differs."""
    lib = library or default_library()
    kw = dict(bath_c=bath_c, duration=duration, dt=dt, method=method, after_contact=after_contact, library=lib)
    model = parse(HingeModel, hinge_model, "hinge_model")
    res = simulate(design, hinge_model=model, **kw)
    if not compare:
        return res, None
    other = HingeModel.POINT if model == HingeModel.ARC else HingeModel.ARC
    alt = simulate(design, hinge_model=other, **kw)

    def verdict(r):
        c = r.first_collision
        return r.completed, None if c is None else tuple(sorted(c.panels))

    return res, (Comparison(other, alt) if verdict(alt) != verdict(res) else None)


def printed_crossings(design: Design) -> list[tuple[str, str]]:
    """Non-adjacent panel pairs that overlap in the printed (permanent) state: the part
    can never be printed as designed (:func:`foldprint.collision.clearance.permanent_crossings`)."""
    from ..collision.clearance import permanent_crossings

    return permanent_crossings(design)


def worst_sample(robust: RobustResult) -> int | None:
    """Index of the worst Monte-Carlo sample of ``robust``: the earliest first contact
    among the samples that collide; else the first sample that jams another way (a goal
    missed, a hinge short of 98 %); else the slowest fold. None when there is no sample."""
    outs = robust.outcomes
    hits = [k for k, o in enumerate(outs) if o.reason == "collision" and o.time is not None]
    if hits:
        return min(hits, key=lambda k: (outs[k].time, k))
    jammed = [k for k, o in enumerate(outs) if o.jammed]
    if jammed:
        return jammed[0]
    done = [k for k, o in enumerate(outs) if o.fold_time is not None]
    return max(done, key=lambda k: (outs[k].fold_time, -k)) if done else None


@dataclass(frozen=True)
class Replay:
    """One Monte-Carlo sample folded again with its whole trajectory kept (the
    Monte-Carlo keeps only each sample's :class:`~foldprint.simulation.robust.Outcome`)."""

    index: int
    sample: Sample  # its drawn parameters
    outcome: Outcome  # what the Monte-Carlo recorded for it
    result: SimulationResult

    @property
    def agrees(self) -> bool:
        """The replay gives the recorded verdict (jams or not, first colliding pair)."""
        o = outcome_of(self.result)
        return (o.jammed, o.reason, o.pair) == (self.outcome.jammed, self.outcome.reason, self.outcome.pair)


def replay_sample(design: Design, robust: RobustResult, index: int, *, library: MaterialLibrary | None = None,
                  dt: float = CHECK_DT_S, after_contact: AfterContact | str = DEFAULT_AFTER_CONTACT) -> Replay:
    """Sample ``index`` of ``robust`` (a result for ``design`` run with time step ``dt``)
    drawn again from the same seed and spreads and folded as the Monte-Carlo folds it,
    keeping the trajectory, e.g. to show the :func:`worst_sample` beside the nominal fold."""
    if not 0 <= index < robust.samples:
        raise ValueError(f"sample index {index} is outside 0..{robust.samples - 1}")
    lib = library or default_library()
    sample = draw_samples(design, robust.scatter, robust.samples, robust.seed)[index]
    res = simulate(design, dt=dt, method=Method.FCL, hinge_model=robust.hinge_model, after_contact=after_contact,
                   drive=sample_drive(design, lib, sample))
    return Replay(index, sample, robust.outcomes[index], res)


@dataclass(frozen=True)
class Evaluation:
    """Everything known about a design before printing."""

    design: Design
    printer: Printer
    simulation: SimulationResult
    assembly: Assembly | None
    assembly_error: str | None
    printed_gaps: tuple[Gap, ...]
    clearance: Gap | None
    robust: RobustResult | None
    findings: tuple[Finding, ...]
    sweep: tuple[SweepPoint, ...] = ()

    @property
    def errors(self) -> int:
        return sum(f.severity == "error" for f in self.findings)

    @property
    def ok(self) -> bool:
        return self.errors == 0


def evaluate(design: Design, *, library: MaterialLibrary | None = None, printer: Printer | None = None,
             hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL, dt: float = CHECK_DT_S,
             samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED, scatter: Scatter | None = None,
             thresholds: Thresholds = Thresholds(), simulation: SimulationResult | None = None,
             workers: int | None = None, mapper=None, scales: Iterable[float] = (),
             progress: Callable[[str, int, int], None] | None = None) -> Evaluation:
    """Simulate once, build the printed part, measure its gaps and clearance, estimate
    the jam probability (``samples`` = 0 skips it), and again with the scatter spreads
    times each of ``scales`` (``check`` passes :data:`CHECK_SCALES`), and run every
    design rule.

    ``progress(stage, done, total)`` reports the Monte-Carlo samples."""
    lib = library or default_library()
    pr = printer or load_printers()[default_printer_key()]
    model = parse(HingeModel, hinge_model, "hinge_model")
    if simulation is None:
        simulation = simulate(design, dt=dt, method=Method.FCL, hinge_model=model, library=lib)
    try:
        assembly, assembly_error = build_assembly(design, State.PERMANENT.value, lib), None
    except GeometryError as exc:
        assembly, assembly_error = None, str(exc)
    # gaps of the printed state: the geometry export writes (arc hinges), whatever model
    # the fold was simulated with
    printed = SweptChecker(design, HingeModel.ARC, None)
    poses = forward(design, target_angles(design)[None], HingeModel.ARC)[0]
    gaps = tuple(gaps_in_pose(printed, poses, pr.min_gap_mm))
    traj = simulation.trajectory
    first = simulation.first_collision
    checker = printed if model == HingeModel.ARC else SweptChecker(design, model, None)
    clearance = min_clearance(checker, traj.times, traj.poses, t_end=None if first is None else first.time)
    robust = None
    if samples:
        cb = (lambda done, total: progress("samples", done, total)) if progress else None
        robust = jam_probability(design, samples, seed, scatter=scatter, library=lib, hinge_model=model,
                                 dt=dt, nominal=simulation, workers=workers, progress=cb, mapper=mapper)
    points: tuple[SweepPoint, ...] = ()
    if robust is not None and tuple(scales):
        cb = (lambda done, total: progress("sigma scales", done, total)) if progress else None
        points = sweep(design, robust, tuple(scales) + (1.0,), library=lib, dt=dt, workers=workers, mapper=mapper,
                       progress=cb)
    ctx = CheckContext(design, lib, pr, simulation, assembly, assembly_error, gaps, clearance, robust,
                       thresholds, points)
    return Evaluation(design, pr, simulation, assembly, assembly_error, gaps, clearance, robust,
                      tuple(run_checks(ctx)), points)
