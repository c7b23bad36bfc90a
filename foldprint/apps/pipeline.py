"""The one place the stages are chained:

    design -> simulation (once) -> assembly -> gaps and clearance -> jam probability
           -> checks (given all of these, computing none) -> writers

:class:`Evaluation` ``(design, options)`` computes each stage on first use and keeps it:
``simulation``, ``assembly``, ``printed_gaps``, ``clearance``, ``robust``, ``sweep``,
``findings``, ``export(dir)``, ``to_json()``. The derived per-design data every stage
needs (hinge frames, spanning tree, reliefs, rigid polygons) live in the evaluation's
one :class:`~foldprint.model.derived.DerivedCache`, active while a stage is computed.
``cli``, ``gallery`` and ``assign`` call this module; no stage below it calls another
stage's entry point. The verdict is about the printed part: the simulation defaults to
the arc hinges that ``export`` writes (:data:`foldprint.core.modes.DEFAULT_HINGE_MODEL`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterable

from ..core import guards
from ..checks.rules import CheckContext, Finding, Printer, Thresholds, default_printer_key, load_printers, run_checks
from ..collision.clearance import Gap, gaps_in_pose, min_clearance, permanent_crossings
from ..collision.swept3d import SweptChecker
# what ``check`` runs by default, defined once (the command line and the gallery read it too)
from ..core.constants import (ANIMATION_DT_S, CHECK_DT_S, CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED, DEFAULT_DT_S,  # noqa: F401 (re-exported)
                              CLEARANCE_SAMPLES, MARGIN_SAMPLES)
from ..model.derived import DerivedCache
from ..model.design import Design
from ..core.errors import ExportError, FoldprintError, GeometryError
from ..exchange.voxels import Pitch, VoxelPart
from ..exchange.export import DEFAULT_FORMATS, TRAJECTORY_FORMATS, check_formats, export_assembly
from ..exchange.recipe import check_summary
from ..exchange.fem import PlacedState, check_strip
from ..geometry import Assembly, build_assembly, state_angles
from ..geometry.surfaces import Frames, fold_frames
from ..physics.barhinge_solve import CompliantDrive
from ..physics.kinematics import HingeDrive, forward, hinge_frames, run_times, solve_loops_many, target_angles
from ..physics.recovery import hinge_fold_times
from ..model.materials import MaterialLibrary, default_library
from ..model.printers import find_printer, tool_fit
from ..core.modes import (DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, DEFAULT_METHOD, DEFAULT_STATE,
                          VERDICT_METHOD, AfterContact, HingeModel, Mechanics, Method, SampleRule, State, parse)
from ..simulation.flip_drivers import FlipDrivers, flip_drivers, flips_of
from ..simulation.margin import ScatterMargin, margin_batch_bytes, scatter_margin
from ..simulation.margin import left_out as margin_left_out, screened_poses
from ..simulation.paper_beside import PaperLine, paper_lines
from ..simulation.robust import (RobustResult, Scatter, curve_batch, curves_at_once, default_scatter, jam_probability,
                                 run_end)
from ..simulation.sensitivity import Contributions, SweepPoint, contributions, sweep
from ..simulation.sequential import jam_test, jam_tests
from ..simulation.simulate import SimulationResult, simulate
from .replay import Replay, replay_sample, worst_sample  # noqa: F401 (re-exported: the pipeline's API)
from .voxel_part import voxel_part, voxel_pitch  # noqa: F401 (re-exported: the pipeline's API)

Progress = Callable[[str, int, int], None]
"""``progress(stage, done, total)``: the Monte-Carlo stages report their samples."""


@dataclass(frozen=True)
class EvalOptions:
    """How a design is evaluated; the defaults are ``foldprint check``'s
    (:mod:`foldprint.core.constants`). ``method`` is the collision method of the
    evaluation's simulation (check: the 3D swept check; ``simulate`` passes ``both``);
    ``samples`` = 0 skips the jam probability, else the most of check's sequential test
    (``sample_rule``; FIXED: robust's count); ``scales``: the sigma scales of the
    sensitivity sweep beside the estimate (empty: none; 1 is the estimate itself, check
    sweeps :data:`CHECK_SCALES` and 1); ``state``, ``formats``: what
    :meth:`Evaluation.export` writes by default."""

    hinge_model: HingeModel = DEFAULT_HINGE_MODEL
    mechanics: Mechanics = DEFAULT_MECHANICS
    method: Method = VERDICT_METHOD
    after_contact: AfterContact = DEFAULT_AFTER_CONTACT
    dt: float = CHECK_DT_S
    bath_c: float | None = None
    duration: float | None = None
    samples: int = CHECK_SAMPLES
    sample_rule: SampleRule = SampleRule.SEQUENTIAL
    seed: int = CHECK_SEED
    scales: tuple[float, ...] = ()
    thresholds: Thresholds = field(default_factory=Thresholds)
    clearance_samples: int = CLEARANCE_SAMPLES
    workers: int | None = None
    state: State = DEFAULT_STATE
    formats: tuple[str, ...] = tuple(DEFAULT_FORMATS)

    def __post_init__(self):
        object.__setattr__(self, "hinge_model", parse(HingeModel, self.hinge_model, "hinge_model"))
        object.__setattr__(self, "method", parse(Method, self.method, "method"))
        object.__setattr__(self, "mechanics", parse(Mechanics, self.mechanics, "mechanics"))
        object.__setattr__(self, "after_contact", parse(AfterContact, self.after_contact, "after_contact"))
        object.__setattr__(self, "state", parse(State, self.state, "state"))
        object.__setattr__(self, "sample_rule", parse(SampleRule, self.sample_rule, "sample_rule"))
        object.__setattr__(self, "scales", tuple(float(k) for k in self.scales))
        object.__setattr__(self, "formats", tuple(self.formats))


@dataclass(frozen=True)
class Comparison:
    """The other hinge model's verdict on the same design, when it differs."""

    hinge_model: HingeModel
    result: SimulationResult


def _verdict(r: SimulationResult):
    c = r.first_collision
    return r.completed, None if c is None else tuple(sorted(c.panels))


class Evaluation:
    """Everything known about a design before printing, each stage computed on first use
    and kept.

    ``Evaluation(design, options)``; ``library`` (default: the shipped one), ``printer``
    (default: the default profile), ``scatter`` (default: the shipped model), ``drive``
    (the hinges' recovery, default nominal: e.g. a scattered sample), ``simulation`` (a
    result the caller already has, for ``options.method``), ``mapper`` and ``progress``
    (how and with what report the Monte-Carlo runs). ``computed`` counts each stage's
    computations; ``cache`` holds the derived per-design data of this evaluation."""

    def __init__(self, design: Design, options: EvalOptions | None = None, *,
                 library: MaterialLibrary | None = None, printer: Printer | None = None,
                 scatter: Scatter | None = None, drive: HingeDrive | None = None,
                 simulation: SimulationResult | None = None, mapper=None, progress: Progress | None = None):
        self.design = design
        self.options = options or EvalOptions()
        self.library = library or default_library()
        self.scatter = scatter
        self.drive = drive
        self._nominal_drive: HingeDrive | None = None
        self.mapper = mapper
        self.progress = progress
        self.cache = DerivedCache()
        self.computed: Counter = Counter()
        self._stages: dict = {}
        self._printer = printer
        if simulation is not None:
            self._stages[("simulation", self.options.method)] = simulation

    # -- the machinery ---------------------------------------------------------------
    def _stage(self, key, compute: Callable):
        """The value of stage ``key``: ``compute()`` (with this evaluation's cache active)
        the first time, kept after."""
        if key not in self._stages:
            with self.cache.active(), guards.holding(self.held_bytes, id(self)):
                self._stages[key] = compute()
            self.computed[key[0] if isinstance(key, tuple) else key] += 1
        return self._stages[key]

    @property
    def held_bytes(self) -> int:
        """Bytes of the simulations kept (own, comparison, replay): every later run's guard counts them."""
        runs = [getattr(v, "result", v) for v in self._stages.values()]
        return sum(r.nbytes for r in runs if isinstance(r, SimulationResult))

    def guard(self, runs: int, clearance: bool = False, samples: bool = False) -> None:
        """Refuse up front what ``runs`` runs held at once (a sample's, ``samples``) would need (guards.check_runs)."""
        o = self.options
        guards.check_runs(self.design, o.dt, o.duration, o.method, runs, clearance,
                          (lambda: curve_batch(self.design, o.dt, o.samples)[1]) if samples else None)

    def margin_batch(self, upfront: bool = False) -> int:
        """Samples of the margin screen given their curves at once: in the memory left (guards.check_margin),
        at most CURVE_BATCH_BYTES of curves (robust.curves_at_once)."""
        o = self.options
        per = guards.check_margin(self.design, o.dt, o.duration, o.method, lambda k: margin_batch_bytes(
            self.design, run_end(self.design, o.dt, o.duration), k), MARGIN_SAMPLES, upfront,
            screened_poses(self.design) if o.mechanics == Mechanics.RIGID else None)
        return per if per == 1 else min(per, curves_at_once(self.design, run_end(self.design, o.dt, o.duration), per)[0])

    def has(self, stage: str) -> bool:
        """Whether ``stage`` was computed (or given)."""
        return any((k[0] if isinstance(k, tuple) else k) == stage for k in self._stages)

    def _report(self, stage: str, progress):
        if progress is not None:
            return progress
        if self.progress is None:
            return None
        return lambda done, total: self.progress(stage, done, total)

    # -- stages ------------------------------------------------------------------------
    @property
    def printer(self) -> Printer:
        if self._printer is None:
            self._printer = load_printers()[default_printer_key()]
        return self._printer

    def simulation_for(self, method: Method | str) -> SimulationResult:
        """The simulation with collision method ``method`` (the other options as given)."""
        m = parse(Method, method, "method")
        o = self.options
        if m == Method.BOTH and not self.design.is_planar_strip and ("simulation", m) not in self._stages:
            # 'both' adds the paper's 2D index only on a planar strip: elsewhere it is the 3D
            # check's simulation itself (the gallery asks for both), computed once
            return self._stage(("simulation", m), lambda: replace(self.simulation_for(Method.FCL), method=m))
        return self._stage(("simulation", m), lambda: simulate(
            self.design, bath_c=o.bath_c, duration=o.duration, dt=o.dt, method=m, hinge_model=o.hinge_model,
            after_contact=o.after_contact, library=self.library,
            drive=self.drive if self.drive is not None else self._nominal()))

    def _nominal(self) -> HingeDrive:
        """The nominal drive of this evaluation's simulations (each ``simulate`` arrests on
        its own copy), the closure of a pattern with loops tracked once for all of them
        (every hinge model uses the point model's closed angles): what each simulation
        would track for itself, on the same grid (:func:`~foldprint.physics.kinematics.run_times`
        of the options). A run the simulation guard refuses is not tracked here (the
        simulation refuses it with its own message)."""
        if self._nominal_drive is None:
            o = self.options
            if o.mechanics == Mechanics.BAR_HINGE:  # its own equilibrium path, solved on first use
                guards.check_mechanics(self.design)
                d = CompliantDrive(self.design, o.bath_c, self.library)
            else:
                d = HingeDrive(self.design, o.bath_c, self.library)
            if d.loops is not None:
                try:
                    guards.check_simulation(self.design, o.dt, o.duration, Method.FCL)
                except FoldprintError:
                    pass
                else:
                    solve_loops_many([d], run_times(self.design, o.dt, o.duration))
            self._nominal_drive = d
        return self._nominal_drive

    @property
    def simulation(self) -> SimulationResult:
        """The simulation of record: ``options.method``, ``options.hinge_model``."""
        return self.simulation_for(self.options.method)

    @property
    def comparison(self) -> Comparison | None:
        """The other hinge model's simulation when its verdict (completes or not, first
        colliding pair) differs from :attr:`simulation`'s."""
        res = self.simulation

        def run():
            o = self.options
            other = HingeModel.POINT if o.hinge_model == HingeModel.ARC else HingeModel.ARC
            alt = simulate(self.design, bath_c=o.bath_c, duration=o.duration, dt=o.dt, method=o.method,
                           hinge_model=other, after_contact=o.after_contact, library=self.library,
                           drive=self._nominal())
            return Comparison(other, alt) if _verdict(alt) != _verdict(res) else None

        return self._stage("comparison", run)

    @property
    def printed_crossings(self) -> list[tuple[str, str]]:
        """Non-adjacent panel pairs that overlap in the printed (permanent) state: the part
        can never be printed as designed (:func:`foldprint.collision.clearance.permanent_crossings`)."""
        return self._stage("printed_crossings", lambda: permanent_crossings(self.design))

    def _build(self) -> tuple[Assembly | None, str | None]:
        try:
            return build_assembly(self.design, State.PERMANENT.value, self.library), None
        except GeometryError as exc:
            return None, str(exc)

    @property
    def assembly(self) -> Assembly | None:
        """The printed part (permanent state), None when it cannot be built."""
        return self._stage("assembly", self._build)[0]

    @property
    def assembly_error(self) -> str | None:
        """Why the printed part cannot be built (None when it can)."""
        return self._stage("assembly", self._build)[1]

    @property
    def printed_checker(self) -> SweptChecker:
        """The swept checker of the printed state (arc hinges: the geometry export writes,
        whatever model the fold was simulated with)."""
        return self._stage("printed_checker", lambda: SweptChecker(self.design, HingeModel.ARC, None))

    @property
    def printed_gaps(self) -> tuple[Gap, ...]:
        """Gaps narrower than the printer's smallest gap in the printed state."""
        def run():
            poses = forward(self.design, target_angles(self.design)[None], HingeModel.ARC)[0]
            return tuple(gaps_in_pose(self.printed_checker, poses, self.printer.min_gap_mm))

        return self._stage("printed_gaps", run)

    @property
    def clearance_checker(self) -> SweptChecker:
        """The solids the clearance is measured on: the printed state's under arc hinges."""
        model = self.options.hinge_model
        return self.printed_checker if model == HingeModel.ARC else self._stage(
            "clearance_checker", lambda: SweptChecker(self.design, model, None))

    @property
    def clearance(self) -> Gap | None:
        """The smallest clearance between non-adjacent panels along the fold, up to the
        first collision (``options.clearance_samples`` poses)."""
        def run():
            traj, first = self.simulation.trajectory, self.simulation.first_collision
            return min_clearance(self.clearance_checker, traj.times, traj.poses, n_samples=self.options.clearance_samples,
                                 t_end=None if first is None else first.time)

        return self._stage("clearance", run)

    @property
    def scatter_margin(self) -> ScatterMargin | None:
        """Whether scatter closes :attr:`clearance`: the closest approach of check's first
        scattered folds (:mod:`foldprint.simulation.margin`); None unless the fold completes."""
        def run():
            sim, gap = self.simulation, self.clearance
            return None if not sim.completed or gap is None or margin_left_out(self.design, self.options.mechanics) \
                else scatter_margin(
                sim, gap, self.clearance_checker, self.scatter or default_scatter(), self.library,
                seed=self.options.seed, batch=self.margin_batch())

        return self._stage("scatter_margin", run)

    def paper_lines(self) -> tuple[PaperLine, ...]:
        """The paper's statements about this design beside the model's values (none for a
        design not from the paper), with the jam probability when it was estimated."""
        r = self._stages.get("robust") or self._stages.get("jam_tests", {}).get(1.0)
        return paper_lines(self.design, self.simulation, self.clearance, None if r is None else r.jam_probability)

    def run_jam_tests(self) -> dict[float, RobustResult]:
        """Check's jam test (:func:`jam_tests`) at 1x and each of ``options.scales``, by scale."""
        o, sim, th = self.options, self.simulation, self.options.thresholds
        if "jam_tests" not in self._stages:
            self.guard(2, samples=True)  # the nominal fold held while a sample folds in this process
        return self._stage("jam_tests", lambda: jam_tests(
            self.design, jam_test(th.warning, th.error, o.samples), (1.0, *o.scales), o.seed, scatter=self.scatter,
            library=self.library, hinge_model=o.hinge_model, dt=o.dt, nominal=sim, workers=o.workers,
            mapper=self.mapper, progress=self.progress, mechanics=o.mechanics))

    def run_robust(self, progress: Callable[[int, int], None] | None = None) -> RobustResult | None:
        """:attr:`robust`, reporting to ``progress(done, total)`` if it is computed now."""
        o = self.options
        if not o.samples:
            return None
        if o.sample_rule == SampleRule.SEQUENTIAL:
            return self.run_jam_tests()[1.0]
        if "robust" not in self._stages:
            self.guard(2, samples=True)  # the nominal fold held while a sample folds in this process
        sim = self.simulation
        return self._stage("robust", lambda: jam_probability(
            self.design, o.samples, o.seed, scatter=self.scatter, library=self.library, hinge_model=o.hinge_model,
            dt=o.dt, nominal=sim, workers=o.workers, progress=self._report("samples", progress),
            mapper=self.mapper, mechanics=o.mechanics))

    @property
    def robust(self) -> RobustResult | None:
        """The jam probability under scatter (None when ``options.samples`` is 0)."""
        return self.run_robust()

    def run_sweep(self, progress: Callable[[int, int], None] | None = None) -> tuple[SweepPoint, ...]:
        """:attr:`sweep`, reporting to ``progress(done, total)`` if it is computed now."""
        r = self.robust
        if r is None or not self.options.scales:
            return ()
        o = self.options
        if o.sample_rule == SampleRule.SEQUENTIAL:
            return tuple(SweepPoint(k, self.run_jam_tests()[k]) for k in sorted({1.0, *o.scales}))
        return self._stage("sweep", lambda: sweep(
            self.design, r, o.scales, library=self.library, dt=o.dt, workers=o.workers,
            mapper=self.mapper, progress=self._report("sigma scales", progress)))

    @property
    def sweep(self) -> tuple[SweepPoint, ...]:
        """The estimate with the spreads times each of ``options.scales`` (1 reuses :attr:`robust`)."""
        return self.run_sweep()

    @property
    def flip_drivers(self) -> tuple[FlipDrivers, ...]:
        """What drives each flip of the jam verdict that FP183 reports: check's test at the
        flipping scale with each scatter component removed, in this evaluation's pool or
        mapper (:func:`~foldprint.simulation.flip_drivers.flip_drivers`); none without a
        flip or a sequential test."""
        def run():
            r, o = self.robust, self.options
            if r is None or r.decision is None or not self.sweep:
                return ()
            points = flips_of(r, self.sweep)
            return flip_drivers(self.design, r, points, library=self.library, dt=o.dt, workers=o.workers,
                                mapper=self.mapper, progress=self.progress) if points else ()

        return self._stage("flip_drivers", run)

    def run_contributions(self, progress: Callable[[int, int], None] | None = None) -> Contributions | None:
        """Each scatter component's share of :attr:`robust` (opt-in: about 11x its cost)."""
        r = self.robust
        if r is None:
            return None
        o = self.options
        return self._stage("contributions", lambda: contributions(
            self.design, r, library=self.library, dt=o.dt, workers=o.workers, mapper=self.mapper,
            progress=self._report("contributions", progress)))

    @property
    def findings(self) -> tuple[Finding, ...]:
        """Every design rule's findings, given the stages above (computed as needed)."""
        if "findings" not in self._stages:  # the fold, a sample beside it, the clearance search
            self.guard(2 if self.options.samples else 1, clearance=True, samples=bool(self.options.samples))

        def run():
            sim = self.simulation
            asm, err = self.assembly, self.assembly_error
            gaps, clear = self.printed_gaps, self.clearance
            robust = self.robust
            ctx = CheckContext(self.design, self.library, self.printer, sim, asm, err, gaps, clear, robust,
                               self.options.thresholds, self.sweep, self.flip_drivers)
            return tuple(run_checks(ctx))

        return self._stage("findings", run)

    @property
    def errors(self) -> int:
        return sum(f.severity == "error" for f in self.findings)

    @property
    def ok(self) -> bool:
        return self.errors == 0

    @property
    def animation(self) -> SimulationResult:
        """The fold at the time step of the files that show it over time (xdmf, glb):
        arc hinges, the default collision method and bath."""
        return self._stage("animation", lambda: simulate(self.design, dt=ANIMATION_DT_S, library=self.library,
                                                         mechanics=self.options.mechanics))

    @property
    def frames(self) -> Frames:
        """The fold's surfaces placed at every step of :attr:`animation`: what the xdmf
        and glb writers draw (:func:`foldprint.geometry.surfaces.fold_frames`)."""
        return self._stage("frames", lambda: fold_frames(self.design, self.animation.trajectory,
                                                         self.animation.compliant))

    @property
    def fold_times(self) -> dict[str, float | None]:
        """Each hinge's 98 % recovery time in the design's bath (s, by hinge id; None where
        it does not fold): what the export's manifest reports."""
        return self._stage("fold_times", lambda: hinge_fold_times(self.design, self.library))

    def placed_state(self, state: State | str) -> PlacedState:
        """``state`` placed by the kinematics (arc hinges): its angles, hinge frames and panel
        poses, what the inp writer meshes (refused first when the design is not a strip)."""
        st = parse(State, state, "state")

        def run():
            check_strip(self.design)
            angles = state_angles(self.design, st.value)
            frames = tuple(hinge_frames(self.design))
            poses = forward(self.design, angles[None], HingeModel.ARC.value, list(frames))[0]
            return PlacedState(st.value, angles, frames, poses)

        return self._stage(("placed_state", st), run)

    @property
    def worst_replay(self) -> "Replay | None":
        """The worst Monte-Carlo sample (:func:`worst_sample`) folded again, None without samples."""
        def run():
            r = self.robust
            k = None if r is None else worst_sample(r)
            if k is None:
                return None
            return replay_sample(self.design, r, k, library=self.library, dt=self.options.dt,
                                 after_contact=self.options.after_contact)

        return self._stage("worst_replay", run)

    # -- writers -----------------------------------------------------------------------
    def export(self, out_dir: str | Path, state: State | str | None = None, formats: Iterable[str] | None = None,
               assembly: Assembly | None = None, printer: str | Printer | None = None, force: bool = False) -> list[dict]:
        """Write ``formats`` of the part in ``state`` (default: ``options``) into
        ``out_dir``; the records of :func:`foldprint.exchange.export.export_assembly`
        (``force``: into a folder of other files, beside them).
        The part is ``assembly`` when given, else the evaluation's printed part when it was
        already built (permanent state), else built here (after the size guard). The fold
        is simulated only when a format shows it over time (xdmf, glb). ``printer`` (a
        profile or its key): the printer the files are for: ExportError when the design
        needs more materials than it has tools (:func:`~foldprint.model.printers.tool_fit`);
        the slicer 3MFs describe it when it is an FDM printer; the voxel stack
        (``voxels``) is rasterised at its pitch (default: the J750). The recipe gets the
        check's findings when this evaluation has computed them."""
        st = parse(State, self.options.state if state is None else state, "state")
        fmts = check_formats(self.options.formats if formats is None else formats)  # before the (slower) build
        profile = find_printer(printer) if isinstance(printer, str) else printer
        fit = None if profile is None else tool_fit(profile, self.design.materials_used, self.library)
        if fit is not None and not fit.ok:
            raise ExportError(fit.refusal(self.design.source or self.design.name))
        pitch = voxel_pitch(profile) if "voxels" in fmts else None
        if assembly is None and st == State.PERMANENT and self.has("assembly"):
            assembly = self.assembly
            if assembly is None:
                raise GeometryError(self.assembly_error)
        if assembly is None:
            guards.check_export(self.design)  # time and memory of the build, estimated from the design
        frames = self.frames if any(f in TRAJECTORY_FORMATS for f in fmts) else None
        check = check_summary(self.printer.name, self.findings) if self.has("findings") else None
        with self.cache.active():
            if assembly is None:
                assembly = build_assembly(self.design, st.value, self.library)
            placed = self.placed_state(st) if "inp" in fmts else None
            voxels = None if pitch is None else self._voxels(assembly, pitch)
            return export_assembly(self.design, assembly, out_dir, fmts, self.library, frames, self.fold_times,
                                   placed, voxels, profile, check, force=force)

    def _voxels(self, assembly: Assembly, pitch: Pitch) -> VoxelPart:
        """The part's voxel regions at ``pitch``, after the voxel grid's guard."""
        d = self.design
        voxels = voxel_part(d, assembly, self.library, pitch)
        graded = sum(1 for r in voxels.regions if r.constant is None and not r.along_length)
        guards.check_voxels(voxels.grid().shape, f"{d.source}: " if d.source else f"{d.name}: ", graded)
        return voxels

    def to_json(self, printer_key: str | None = None) -> dict:
        """The ``foldprint check --json`` object (:func:`foldprint.checks.report.check_json`)."""
        from ..checks.report import check_json

        return check_json(self, printer_key or default_printer_key())

    def simulation_json(self) -> dict:
        """The ``foldprint simulate --json`` object: the simulation, the printed crossings
        and the other hinge model's verdict (:func:`foldprint.checks.report.simulate_json`)."""
        from ..checks.report import simulate_json

        if "comparison" not in self._stages:
            self.guard(2, clearance=True)  # the fold and the other hinge model's, held at once, and the clearance search
            if not margin_left_out(self.design, self.options.mechanics):
                self.margin_batch(upfront=True)  # the margin screen's samples, one at a time at least, beside the fold
        sim, other, crossing = self.simulation, self.comparison, self.printed_crossings
        report = simulate_json(sim, other, crossing, self.clearance, None if crossing else self.scatter_margin,
                               self.paper_lines())
        if (why := margin_left_out(self.design, self.options.mechanics)) and sim.completed and not crossing:
            report["notes"] = [*report.get("notes", []), why]
        return report

    def robust_json(self) -> dict:
        """The ``foldprint robust --json`` object: the estimate, and the contributions and
        the sweep when computed (:func:`foldprint.checks.report.robust_report_json`)."""
        from ..checks.report import robust_report_json

        return robust_report_json(self.robust, self._stages.get("contributions"), self._stages.get("sweep"))


# -- functions kept for callers of the earlier API (each one evaluation) --------------

def check_scales(scales: Iterable[float] = CHECK_SCALES) -> tuple[float, ...]:
    """The sweep ``check`` runs for ``scales``: each of them and 1 (none when empty)."""
    ks = tuple(float(k) for k in scales)
    return ks + (1.0,) if ks else ()


def evaluate(design: Design, *, library: MaterialLibrary | None = None, printer: Printer | None = None,
             hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL, dt: float = CHECK_DT_S,
             samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED, scatter: Scatter | None = None,
             thresholds: Thresholds = Thresholds(), simulation: SimulationResult | None = None,
             workers: int | None = None, mapper=None, scales: Iterable[float] = (),
             progress: Progress | None = None) -> Evaluation:
    """Every stage of ``check`` computed now: ``Evaluation(design, EvalOptions(...))``
    with its findings evaluated (``samples`` = 0 skips the jam probability; ``scales``:
    the sensitivity sweep, ``check`` passes :data:`CHECK_SCALES`)."""
    opts = EvalOptions(hinge_model=hinge_model, dt=dt, samples=samples, seed=seed, scales=check_scales(scales),
                       thresholds=thresholds, workers=workers)
    ev = Evaluation(design, opts, library=library, printer=printer, scatter=scatter, simulation=simulation,
                    mapper=mapper, progress=progress)
    ev.findings  # noqa: B018 - computes every stage the rules read
    return ev


def build(design: Design, state: State | str = DEFAULT_STATE,
          library: MaterialLibrary | None = None) -> Assembly:
    """The printable part in ``state``: one watertight body per material."""
    st = parse(State, state, "state")
    return build_assembly(design, st.value, library or default_library())


def export(design: Design, out_dir: str | Path, state: State | str = DEFAULT_STATE,
           formats: Iterable[str] = DEFAULT_FORMATS, library: MaterialLibrary | None = None,
           assembly: Assembly | None = None, printer: str | None = None, force: bool = False) -> list[dict]:
    """Build ``design`` in ``state`` (or take the built ``assembly``) and write
    ``formats`` into ``out_dir``: :meth:`Evaluation.export`."""
    return Evaluation(design, library=library).export(out_dir, state, formats, assembly, printer, force)


def run_simulation(design: Design, *, library: MaterialLibrary | None = None, bath_c: float | None = None,
                   duration: float | None = None, dt: float = DEFAULT_DT_S, method: Method | str = DEFAULT_METHOD,
                   hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
                   after_contact: AfterContact | str = DEFAULT_AFTER_CONTACT,
                   compare: bool = False) -> tuple[SimulationResult, Comparison | None]:
    """The simulation, and (``compare``) the other hinge model's result when its verdict
    (completes or not, first colliding pair) differs."""
    ev = Evaluation(design, EvalOptions(hinge_model=hinge_model, method=method, after_contact=after_contact,
                                        dt=dt, bath_c=bath_c, duration=duration), library=library)
    return ev.simulation, (ev.comparison if compare else None)


def printed_crossings(design: Design) -> list[tuple[str, str]]:
    """:attr:`Evaluation.printed_crossings` of ``design``."""
    return Evaluation(design).printed_crossings
