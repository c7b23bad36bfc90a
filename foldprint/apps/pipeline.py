"""The one place the stages are chained:

    design -> simulation (once) -> assembly -> gaps and clearance -> jam probability
           -> checks (given all of these, computing none) -> writers

:class:`Evaluation` ``(design, options)`` computes each stage on first use and keeps it:
``simulation``, ``assembly``, ``printed_gaps``, ``clearance``, ``robust``, ``sweep``,
``findings``, ``export(dir)``, ``to_json()``. The derived per-design data every stage
needs (hinge frames, spanning tree, reliefs, rigid polygons) live in the evaluation's
one :class:`~foldprint.model.derived.DerivedCache`, active while a stage is computed.
The stages live in four modules along their seams, one mixin each: the nominal fold
(:mod:`.evaluation_nominal`), the verdict (:mod:`.evaluation_verdict`), what the writers
are handed and ``export`` (:mod:`.evaluation_exports`), the JSON reports
(:mod:`.evaluation_reports`); this module holds the options, the one-computation-per-stage
cache (``_stage``), the resource guards' calls and the one-evaluation wrappers.
``cli``, ``gallery`` and ``assign`` call this module; no stage below it calls another
stage's entry point. The verdict is about the printed part: the simulation defaults to
the arc hinges that ``export`` writes (:data:`foldprint.core.modes.DEFAULT_HINGE_MODEL`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable

from ..core import guards
from ..simulation import costs
from ..checks.rules import Printer, Thresholds, default_printer_key, load_printers
# what ``check`` runs by default, defined once (the command line and the gallery read it too)
from ..core.constants import EXPORT_FORMATS as DEFAULT_FORMATS  # the export's default (exchange.export loads on export)
from ..core.constants import (ANIMATION_DT_S, CHECK_DT_S, CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED, DEFAULT_DT_S,  # noqa: F401 (re-exported)
                              CLEARANCE_SAMPLES, MARGIN_SAMPLES)
from ..model.derived import DerivedCache
from ..model.design import Design
from ..geometry import Assembly, build_assembly
from ..physics.hinge_drive import HingeDrive
from ..model.materials import MaterialLibrary, default_library
from ..core.modes import (DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, DEFAULT_METHOD, DEFAULT_STATE,
                          VERDICT_METHOD, AfterContact, HingeModel, Mechanics, Method, SampleRule, State, parse)
from ..simulation.margin import margin_batch_bytes, screened_poses
from ..simulation.robust import Scatter, curve_batch, curves_at_once, run_end
from ..simulation.simulate import SimulationResult
from .evaluation_exports import ExportStages
from .evaluation_nominal import Comparison, NominalStages, verdict_of  # noqa: F401 (re-exported: the pipeline's API)
from .evaluation_reports import ReportStages
from .evaluation_verdict import VerdictStages
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



class Evaluation(NominalStages, VerdictStages, ExportStages, ReportStages):
    """Everything known about a design before printing, each stage computed on first use
    and kept.

    ``Evaluation(design, options)``; ``library`` (default: the shipped one), ``printer``
    (default: the default profile), ``scatter`` (default: the shipped model), ``drive``
    (the hinges' recovery, default nominal: e.g. a scattered sample), ``simulation`` (a
    result the caller already has, for ``options.method``), ``mapper`` and ``progress``
    (how and with what report the Monte-Carlo runs). ``computed`` counts each stage's
    computations; ``cache`` holds the derived per-design data of this evaluation. The
    stages come from the mixins (the nominal fold, the verdict, the exports, the reports);
    each keeps its value through :meth:`_stage`."""

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
        self.build_notes: tuple[str, ...] = ()  # of the part export built (loops closed within a tolerance)
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
        """Refuse up front what ``runs`` runs held at once (a sample's, ``samples``) would need (costs.check_runs)."""
        o = self.options
        costs.check_runs(self.design, o.dt, o.duration, o.method, runs, clearance,
                         (lambda: curve_batch(self.design, o.dt, o.samples)[1]) if samples else None)

    def margin_batch(self, upfront: bool = False) -> int:
        """Samples of the margin screen given their curves at once: in the memory left (costs.check_margin),
        at most CURVE_BATCH_BYTES of curves (robust.curves_at_once)."""
        o = self.options
        per = costs.check_margin(self.design, o.dt, o.duration, o.method, lambda k: margin_batch_bytes(
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


#: what compiling the kernels costs on a cold cache, as the note says it (docs/kernels.md:
#: ``check helix_uniform`` 43-49 s wall, ``check miura_3x3`` 55-56 s on two cores, load 1-2)
COMPILE_WALL = {False: "about 45 s", True: "about a minute"}


def compile_note(design: Design) -> str | None:
    """One line for the user when folding ``design`` will compile kernels first (numba's
    cache lacks those every fold of it compiles: the first command after an install), else
    None (a warm cache, or the numpy path). Reading the cache costs about a millisecond
    once numba is imported, which any command that folds does anyway."""
    from ..model.hinge_graph import has_loops
    from ..simulation.jamtest.warmup import cold_kernels

    loops = has_loops(design)
    if not cold_kernels(loops, sure=True):
        return None
    return (f"compiling the kernels, once after an install ({COMPILE_WALL[loops]}); "
            "later runs load them from the cache")
