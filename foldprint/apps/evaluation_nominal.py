"""The nominal fold of an :class:`~foldprint.apps.pipeline.Evaluation`: its simulations
(one per collision method, sharing one nominal drive), the other hinge model's verdict
beside it, the printed part and its crossings and gaps, the smallest clearance along the
fold, whether scatter closes it, and the paper's statements beside the model's values.
Each is a stage of the evaluation (computed on first use, kept: ``Evaluation._stage``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..simulation import costs
from ..core.errors import FoldprintError, GeometryError
from ..core.modes import HingeModel, Mechanics, Method, State, parse
from ..collision.clearance import Gap, gaps_in_pose, min_clearance, permanent_crossings
from ..collision.swept3d import SweptChecker
from ..geometry import Assembly, build_assembly
from ..physics.kinematics import forward, target_angles
from ..physics.hinge_drive import HingeDrive, run_times, solve_loops_many
from ..simulation.margin import ScatterMargin, scatter_margin
from ..simulation.margin import left_out as margin_left_out
from ..simulation.paper_beside import PaperLine, paper_lines
from ..simulation.robust import default_scatter
from ..simulation.simulate import SimulationResult, simulate


@dataclass(frozen=True)
class Comparison:
    """The other hinge model's verdict on the same design, when it differs."""

    hinge_model: HingeModel
    result: SimulationResult


def verdict_of(r: SimulationResult):
    """A simulation's verdict as two hinge models are compared: completes or not, and the
    first colliding pair."""
    c = r.first_collision
    return r.completed, None if c is None else tuple(sorted(c.panels))


class NominalStages:
    """The nominal fold's stages of an evaluation (a mixin of
    :class:`~foldprint.apps.pipeline.Evaluation`, whose ``_stage`` keeps them)."""

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
        would track for itself, on the same grid (:func:`~foldprint.physics.hinge_drive.run_times`
        of the options). A run the simulation guard refuses is not tracked here (the
        simulation refuses it with its own message)."""
        if self._nominal_drive is None:
            o = self.options
            if o.mechanics == Mechanics.BAR_HINGE:  # its own equilibrium path, solved on first use
                from ..physics.barhinge.equilibrium import CompliantDrive  # scipy.sparse: loaded when asked for

                costs.check_mechanics(self.design)
                d = CompliantDrive(self.design, o.bath_c, self.library)
            else:
                d = HingeDrive(self.design, o.bath_c, self.library)
            if d.loops is not None:
                try:
                    costs.check_simulation(self.design, o.dt, o.duration, Method.FCL)
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
            return Comparison(other, alt) if verdict_of(alt) != verdict_of(res) else None

        return self._stage("comparison", run)

    @property
    def printed_crossings(self) -> list[tuple[str, str]]:
        """Non-adjacent panel pairs that overlap in the printed (permanent) state: the part
        can never be printed as designed (:func:`foldprint.collision.clearance.permanent_crossings`)."""
        return self._stage("printed_crossings", lambda: permanent_crossings(self.design))

    def _build(self) -> tuple[Assembly | None, str | None]:
        try:
            return build_assembly(self.design, State.PERMANENT.value, self.library,
                                  resolution_mm=self.printer.layer_mm), None
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
            left_out = margin_left_out(self.design, self.options.mechanics)
            return None if not sim.completed or gap is None or left_out else scatter_margin(
                sim, gap, self.clearance_checker, self.scatter or default_scatter(), self.library,
                seed=self.options.seed, batch=self.margin_batch())

        return self._stage("scatter_margin", run)

    def paper_lines(self) -> tuple[PaperLine, ...]:
        """The paper's statements about this design beside the model's values (none for a
        design not from the paper), with the jam probability when it was estimated."""
        r = self._stages.get("robust") or self._stages.get("jam_tests", {}).get(1.0)
        return paper_lines(self.design, self.simulation, self.clearance, None if r is None else r.jam_probability)
