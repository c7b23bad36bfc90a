"""The verdict of an :class:`~foldprint.apps.pipeline.Evaluation`: check's sequential
jam test at 1x and every sigma scale (in one pool), or ``robust``'s fixed-size estimate;
the sweep over sigma scales, what drives a flip of the verdict, each scatter component's
share; and the design rules' findings given every stage they read. Each is a stage of the
evaluation (computed on first use, kept: ``Evaluation._stage``).
"""

from __future__ import annotations

from typing import Callable

from ..checks.rules import CheckContext, Finding, run_checks
from ..core.modes import VERDICT_METHOD, SampleRule
from ..simulation.jamtest.flip_drivers import FlipDrivers, flip_drivers, flips_of
from ..simulation.robust import RobustResult, default_scatter, jam_probability
from ..simulation.sensitivity import Contributions, SweepPoint, contributions, sweep
from ..simulation.jamtest.scales import jam_test, jam_tests
from ..simulation.jamtest.stages import check_pool


class VerdictStages:
    """The jam verdict's and the design rules' stages of an evaluation (a mixin of
    :class:`~foldprint.apps.pipeline.Evaluation`, whose ``_stage`` keeps them)."""

    def run_jam_tests(self) -> dict[float, RobustResult]:
        """Check's jam test (:func:`jam_tests`) at 1x and each of ``options.scales``, by scale."""
        o, sim, th = self.options, self.simulation, self.options.thresholds
        if "jam_tests" not in self._stages:
            self.guard(2, samples=True)  # the nominal fold held while a sample folds in this process
        return self._stage("jam_tests", lambda: jam_tests(
            self.design, jam_test(th.warning, th.error, o.samples), (1.0, *o.scales), o.seed, scatter=self.scatter,
            library=self.library, hinge_model=o.hinge_model, dt=o.dt, nominal=sim, workers=o.workers,
            mapper=self.jam_mapper, progress=self.progress, mechanics=o.mechanics))

    @property
    def jam_mapper(self):
        """What the jam test's stages fold with: the evaluation's ``mapper``, else the
        outcomes of :meth:`fold_check_stages` once it ran, else None (each stage its pool)."""
        return self.mapper if self.mapper is not None else self._stages.get("check_pool")

    def fold_check_stages(self) -> None:
        """Fold every stage of check's jam test (1x, the sweep, a flip's probes) in one pool
        before they are asked (:func:`~foldprint.simulation.jamtest.stages.check_pool`), when
        this evaluation has no mapper of its own and runs check's sequential test; the
        stages then decide from those outcomes: the same answers, one pool's start-up."""
        o = self.options
        if (self.mapper is not None or not o.samples or o.sample_rule != SampleRule.SEQUENTIAL
                or "jam_tests" in self._stages or "check_pool" in self._stages):
            return
        sim, th = self.simulation, o.thresholds
        self.guard(2, samples=True)  # the nominal fold held while a sample folds in this process
        self._stage("check_pool", lambda: check_pool(
            self.design, jam_test(th.warning, th.error, o.samples), o.scales, o.seed,
            scatter=self.scatter or default_scatter(), library=self.library, hinge_model=o.hinge_model, dt=o.dt,
            method=VERDICT_METHOD, nominal=sim, workers=o.workers, progress=self.progress, mechanics=o.mechanics))

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
        mapper (:func:`~foldprint.simulation.jamtest.flip_drivers.flip_drivers`); none without a
        flip or a sequential test."""
        def run():
            r, o = self.robust, self.options
            if r is None or r.decision is None or not self.sweep:
                return ()
            points = flips_of(r, self.sweep)
            return flip_drivers(self.design, r, points, library=self.library, dt=o.dt, workers=o.workers,
                                mapper=self.jam_mapper, progress=self.progress) if points else ()

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
            self.fold_check_stages()
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
