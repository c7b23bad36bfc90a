"""What the design-rule checks (:mod:`foldprint.checks.rules`) read and report: a
:class:`Finding`, the jam :class:`Thresholds`, the :class:`CheckContext` the pipeline computes
once, and :func:`finding` that builds a finding from a rule's parts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..model.design import Design
from ..core.constants import JAM_ERROR_ABOVE, JAM_WARN_ABOVE
from ..core.schema import jam_thresholds
from ..model.materials import MaterialLibrary
from ..model.printers import Printer

SEVERITIES = ("error", "warning", "info")


@dataclass(frozen=True)
class Finding:
    code: str
    severity: str
    message: str
    hint: str = ""
    where: dict = field(default_factory=dict)  # panel / hinge / body ids
    point_mm: tuple[float, float, float] | None = None

    def to_json(self) -> dict:
        out = {"code": self.code, "severity": self.severity, "message": self.message,
               "where": dict(self.where), "hint": self.hint}
        if self.point_mm is not None:
            out["point_mm"] = [round(float(v), 3) for v in self.point_mm]
        return out


@dataclass(frozen=True)
class Thresholds:
    """When the jam probability makes the pre-print check fail.

    ``error``: the check fails (exit 1) when the *lower* end of the 95 % interval is above
    this: the part jams more often than this even on the most favourable reading of the
    samples. ``warning``: a warning when the estimate itself is above this."""

    error: float = JAM_ERROR_ABOVE
    warning: float = JAM_WARN_ABOVE

    def __post_init__(self):
        jam_thresholds(self.error, self.warning)  # DesignError naming --error-above / --warn-above


@dataclass(frozen=True)
class CheckContext:
    """What the rules read. Every result is computed once, upstream, by
    :mod:`foldprint.apps.pipeline`; rules compute no simulation and no geometry.

    ``simulation``: the nominal :class:`~foldprint.simulation.simulate.SimulationResult` (or None
    when it could not run); ``assembly``: the printed part (None with
    ``assembly_error`` when it could not be built); ``printed_gaps``: panel pairs closer
    than the printer's minimum gap in the permanent state; ``clearance``: the smallest
    gap along the fold; ``robust``: the jam probability (or None when not run);
    ``sweep``: the same estimate with the scatter spreads scaled (points with ``.scale``
    and ``.result``, :func:`foldprint.simulation.sensitivity.sweep`; empty when not run);
    ``flip_drivers``: what drives each flip FP183 reports
    (:func:`foldprint.simulation.jamtest.flip_drivers.flip_drivers`; empty when not run)."""

    design: Design
    library: MaterialLibrary
    printer: Printer
    simulation: object | None = None
    assembly: object | None = None
    assembly_error: str | None = None
    printed_gaps: tuple = ()
    clearance: object | None = None
    robust: object | None = None
    thresholds: Thresholds = Thresholds()
    sweep: tuple = ()
    flip_drivers: tuple = ()


def finding(code, sev, msg, hint="", point=None, **where):
    """A :class:`Finding`: ``where``'s ids that are not None, ``point`` as floats."""
    return Finding(code, sev, msg, hint, {k: v for k, v in where.items() if v is not None},
                   None if point is None else tuple(float(x) for x in point))
