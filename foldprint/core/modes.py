"""Every mode foldprint has, as an enum with one default, validated in one place.

The enums are ``str`` subclasses, so ``HingeModel.ARC == "arc"`` and they serialise to
JSON as their value. :func:`parse` turns user text (CLI, files, API) into a member or
raises :class:`~foldprint.core.errors.DesignError` naming the choices.
"""

from __future__ import annotations

from enum import Enum
from typing import TypeVar

from .errors import DesignError


class Mode(str, Enum):
    """The base of every mode: a ``str`` enum that prints as its value (``str(Method.FCL)``
    is ``"fcl"``, in messages and JSON alike)."""

    def __str__(self) -> str:
        return self.value


class HingeModel(Mode):
    """How the ROM moves a child panel about its hinge.

    ``ARC``: the printed hinge, a strip of flat width w = R |rho| bending with uniform
    curvature (panels translate as they rotate; in a pattern with loops the child turns
    about the fold line and the strip is the tangent arc, docs/loops.md): the model of
    record. ``POINT``: the
    paper's Eq. 2-4, a hinge of zero size (Mao et al. 2015): for comparison."""

    ARC = "arc"
    POINT = "point"


class Mechanics(Mode):
    """How the panels and creases carry load while the hinges recover. ``RIGID``: rigid
    panels and ideal creases, each hinge at its recovered angle (loops: the closed angles
    nearest the drive, docs/loops.md): exact and fast where it applies, the default.
    ``BAR_HINGE``: the bar-and-hinge model (docs/mechanics.md): panels stretch and bend a
    little, each crease is a rotational spring whose rest angle is its recovered angle and
    whose stiffness is its material's modulus at its temperature, so loops settle at the
    torque balance and patterns that need panel bending fold."""

    RIGID = "rigid"
    BAR_HINGE = "bar-hinge"


class Method(Mode):
    """Collision method: the paper's 2D index, the FCL swept check of the 3D panels, or
    both (the index only where the design is a planar strip)."""

    INDEX2D = "index2d"
    FCL = "fcl"
    BOTH = "both"


class AfterContact(Mode):
    """After the first contact: ``STOP`` reports it; ``ARREST`` freezes the hinges between
    the touching panels and goes on."""

    STOP = "stop"
    ARREST = "arrest"


class ScatterScope(Mode):
    """Over what a scattered quantity takes one value (:mod:`foldprint.simulation.scatter`):
    ``SHARED`` one draw per sample that every hinge sees (the bath of a run, the error of
    the heat-transfer correlation for the whole part); ``HINGE`` one independent draw per
    hinge (Tg, thickness, local heat transfer)."""

    SHARED = "shared"
    HINGE = "hinge"


class SpreadBasis(Mode):
    """What a scatter spread rests on (``basis`` of each table of ``data/scatter.toml``):
    ``MEASURED`` on parts, hinges or baths like these; a vendor's ``DATASHEET``; published
    data on comparable systems (``LITERATURE``); or our ``CHOICE``, no measurement behind
    it (a value inside a plausible range is still a choice)."""

    MEASURED = "measured"
    DATASHEET = "datasheet"
    LITERATURE = "literature"
    CHOICE = "choice"


class State(Mode):
    """Which shape the geometry is built in: ``PERMANENT`` (printed, folded) or
    ``PROGRAMMED`` (the flat sheet after programming)."""

    PERMANENT = "permanent"
    PROGRAMMED = "programmed"


class Interface(Mode):
    """How a hinge strip meets its panels: ``FLAT`` a straight seam; ``TRIANGULAR`` teeth
    of the panel material reaching into the strip (:mod:`foldprint.geometry.layout`)."""

    FLAT = "flat"
    TRIANGULAR = "triangular"


class JamReason(Mode):
    """Why a Monte-Carlo sample jams: a ``COLLISION`` of two panels, a ``GOAL`` not met (a
    pass-through out of order), or the fold ``UNFOLDED`` (not finished in the run)."""

    COLLISION = "collision"
    GOAL = "goal"
    UNFOLDED = "unfolded"


class JamVerdict(Mode):
    """What the jam test of ``check`` concludes (:mod:`foldprint.simulation.jamtest.verdict`):
    ``PASS`` below the warning threshold (FP182), ``WARNING`` between the two (FP181),
    ``ERROR`` above the error threshold (FP180)."""

    PASS = "pass"
    WARNING = "warning"
    ERROR = "error"


class JamQuestion(Mode):
    """What a jam test asks (:mod:`foldprint.simulation.jamtest.verdict`): ``VERDICT`` which of
    pass, warning or error (both thresholds' tests; ``check``'s verdict and its sweep);
    ``WARNING`` or ``ERROR`` only which side of that one threshold p is on (that threshold's
    test alone: a probe of what drives a flip asks no more, :mod:`foldprint.simulation.jamtest.flip_drivers`)."""

    VERDICT = "verdict"
    WARNING = "warning"
    ERROR = "error"


class Side(Mode):
    """Which hypothesis one threshold's sequential test accepted: the jam probability is
    ``BELOW`` the lower end of its indifference region or ``ABOVE`` the upper end."""

    BELOW = "below"
    ABOVE = "above"


class SampleRule(Mode):
    """How many Monte-Carlo samples a jam probability takes: ``SEQUENTIAL`` (``check``
    and the gallery) until its test decides, at most the maximum; ``FIXED`` (``robust``,
    ``assign``) exactly the count asked for, an estimate with a Wilson interval."""

    SEQUENTIAL = "sequential"
    FIXED = "fixed"


class Objective(Mode):
    """What ``foldprint assign`` optimises (:mod:`foldprint.apps.assign.search`): ``TIME`` the
    fastest fold, ``MARGIN`` the widest smallest clearance along the fold, ``ROBUST`` the
    lowest jam probability of the finalists under scatter (``--continuous`` ranks by it
    too)."""

    TIME = "time"
    MARGIN = "margin"
    ROBUST = "robust"


class OutFolder(Mode):
    """What an output folder holds before a set is written into it
    (:mod:`foldprint.exchange.outfolder`): nothing yet (``NEW``: missing; ``EMPTY``), an
    earlier foldprint ``EXPORT`` (its ``foldprint-set.json`` names every file in it), a
    ``LEGACY`` export of links into ``.foldprint-sets``, or ``FOREIGN`` files."""

    NEW = "new"
    EMPTY = "empty"
    EXPORT = "export"
    LEGACY = "legacy"
    FOREIGN = "foreign"


class Publish(Mode):
    """How a staged set lands in its folder: ``WHOLE`` (the staged folder renamed or
    swapped into place: one step) or ``FILE_BY_FILE`` (into a folder that holds other
    files, with ``--force``: each file by its own rename)."""

    WHOLE = "whole"
    FILE_BY_FILE = "file by file"


DEFAULT_HINGE_MODEL = HingeModel.ARC
DEFAULT_MECHANICS = Mechanics.RIGID
DEFAULT_METHOD = Method.BOTH
#: The collision method of the verdicts that fold a design many times or judge it (``check``,
#: ``robust``, every Monte-Carlo sample, a replayed sample): the 3D swept check of the
#: printed panels, whatever the design. ``simulate`` defaults to :data:`DEFAULT_METHOD`.
VERDICT_METHOD = Method.FCL
DEFAULT_AFTER_CONTACT = AfterContact.STOP
DEFAULT_STATE = State.PERMANENT
DEFAULT_INTERFACE = Interface.FLAT
DEFAULT_OBJECTIVE = Objective.TIME

E = TypeVar("E", bound=Enum)


def parse(enum: type[E], value, what: str | None = None) -> E:
    """``value`` (a member or its text, any case) as a member of ``enum``."""
    if isinstance(value, enum):
        return value
    text = str(value).strip().lower() if value is not None else ""
    for m in enum:
        if m.value == text:
            return m
    choices = ", ".join(m.value for m in enum)
    raise DesignError(f"{what or enum.__name__}: {value!r} is not one of {choices}")
