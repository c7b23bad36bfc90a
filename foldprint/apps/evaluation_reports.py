"""The JSON objects of an :class:`~foldprint.apps.pipeline.Evaluation`: ``check --json``,
``simulate --json`` and ``robust --json``, each through one function of
:mod:`foldprint.checks.report` (the stages they read are computed as needed).
"""

from __future__ import annotations

from ..model.printers import default_printer_key
from ..simulation.margin import left_out as margin_left_out
from ..simulation.jamtest.scales import on_check_stream


class ReportStages:
    """The reports of an evaluation (a mixin of :class:`~foldprint.apps.pipeline.Evaluation`)."""

    def to_json(self, printer_key: str | None = None) -> dict:
        """The ``foldprint check --json`` object (:func:`foldprint.checks.report.check_json`)."""
        from ..checks.report import check_json

        return check_json(self, printer_key or default_printer_key())

    def finding_lines(self) -> list[str]:
        """``check``'s text lines of its findings, long runs of one code counted."""
        from ..checks.report import finding_lines

        return finding_lines(self.findings)

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

    def robust_json(self, check_seed: int | None = None) -> dict:
        """The ``foldprint robust --json`` object: the estimate, and the contributions and
        the sweep when computed (:func:`foldprint.checks.report.robust_report_json`);
        with ``check_seed``, also how the estimate relates to check's figure on that seed
        (``"check"``: :func:`foldprint.checks.report.check_relation_json`)."""
        from ..checks.report import check_relation_json, robust_report_json

        out = robust_report_json(self.robust, self._stages.get("contributions"), self._stages.get("sweep"))
        if check_seed is not None:
            out["check"] = check_relation_json(self.robust, check_seed, on_check_stream(self.robust, check_seed))
        return out
