"""The studio's session: the design being edited, its revisions, undo and redo, an edit
(a PATCH) applied through :meth:`~foldprint.model.design.Design.replace` with the loader's
validation, and the nominal result of each revision through one
:class:`~foldprint.apps.pipeline.Evaluation` (the fold, the clearance, the printed part,
the design rules without the jam test).

A revision is a number that grows with every change of the current design (an edit, an
undo, a redo); the history holds the designs with their evaluations, so an undo comes
back to a revision whose stages are already computed. Every method is thread-safe: the
server calls them from its worker threads, several tabs at once.

An edit (``PATCH /api/design``, docs/studio.md) is a JSON object::

    {"hinges": {"h3": {"material": "H-7", "target_deg": 80}},
     "process": {"bath_c": 80},
     "options": {"hinge_model": "arc", "mechanics": "rigid", "printer": "connex260"}}

Every key is checked first (:mod:`foldprint.core.schema`); a bad value raises the
:class:`~foldprint.core.errors.FoldprintError` the command line would print for it, and
the current design stays.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field, replace
from typing import Any, Mapping

import numpy as np

from ..checks.report import simulation_json
from ..checks.rules import CheckContext, run_checks
from ..core import schema as sc
from ..core.constants import CHECK_SAMPLES, CHECK_SEED, CLEARANCE_SAMPLES
from ..core.errors import DesignError, FoldprintError
from ..core.modes import DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, HingeModel, Mechanics, parse
from ..model import composition
from ..model.design import Design
from ..model.materials import MaterialLibrary
from ..model.printers import Printer
from . import studio_reuse
from .pipeline import EvalOptions, Evaluation

#: Most hinges one edit may change (our choice: the schema's panel limit).
MAX_EDIT_ITEMS = sc.MAX_PANELS
#: Revisions kept for undo (our choice: each keeps its evaluation's stages, a few MB).
MAX_HISTORY = 64
#: Poses of the clearance curve the page draws along the fold (our choice; the smallest
#: clearance itself is :attr:`Evaluation.clearance` over CLEARANCE_SAMPLES poses).
CURVE_POSES = 32

EDIT_KEYS = {"hinges", "process", "options"}
HINGE_KEYS = {"material", "target_deg"}
PROCESS_KEYS = {"bath_c"}
OPTION_KEYS = {"hinge_model", "mechanics", "printer"}


@dataclass(frozen=True)
class Setup:
    """The choices an evaluation is made with that the design file does not hold."""

    hinge_model: HingeModel = DEFAULT_HINGE_MODEL
    mechanics: Mechanics = DEFAULT_MECHANICS
    printer: str = ""

    def to_json(self) -> dict:
        return {"hinge_model": self.hinge_model.value, "mechanics": self.mechanics.value, "printer": self.printer}


@dataclass
class Entry:
    """One revision of the history: its design, setup and evaluation (check's options:
    the seed and most samples of the jam test; the sweep runs in the verdict's second
    evaluation, :mod:`foldprint.apps.studio_verdict`)."""

    design: Design
    setup: Setup
    evaluation: Evaluation
    nominal: dict | None = None
    parent: "Entry | None" = None  # the revision this one was edited from, until its nominal result is made
    memo: studio_reuse.Memo | None = None  # what the next revision's nominal result may take over
    check: dict | None = None  # the verdict's ``check --json`` once its sweep ran (an undo finds it)
    lock: threading.Lock = field(default_factory=threading.Lock)


class Session:
    """The studio's state: the current design (``entry``), its ``revision``, the history
    for undo and redo. ``library`` and ``printers`` are fixed for the session."""

    def __init__(self, design: Design, library: MaterialLibrary, printers: Mapping[str, Printer], printer_key: str,
                 scatter=None):
        self.library, self.printers, self.scatter = library, dict(printers), scatter
        if printer_key not in self.printers:
            raise DesignError(f"--printer {printer_key!r} is unknown; profiles: {', '.join(self.printers)}")
        self.lock = threading.RLock()
        self.history: list[Entry] = [self._entry(design, Setup(printer=printer_key))]
        self.at = 0
        self.revision = 1

    # -- the history ----------------------------------------------------------------
    def _entry(self, design: Design, setup: Setup, parent: Entry | None = None) -> Entry:
        opts = EvalOptions(hinge_model=setup.hinge_model, mechanics=setup.mechanics, samples=CHECK_SAMPLES,
                           seed=CHECK_SEED)
        ev = Evaluation(design, opts, library=self.library, printer=self.printers[setup.printer], scatter=self.scatter)
        return Entry(design, setup, ev, parent=parent)

    @property
    def entry(self) -> Entry:
        return self.history[self.at]

    def current(self) -> tuple[int, Entry]:
        """The revision and its entry, read together."""
        with self.lock:
            return self.revision, self.entry

    def _move_to(self, at: int) -> tuple[int, Entry]:
        self.at = at
        self.revision += 1
        return self.revision, self.entry

    def apply(self, edit: Any) -> tuple[int, Entry]:
        """Apply ``edit`` (the PATCH body) to the current design: the new revision and its
        entry; FoldprintError (the design unchanged) when it is not valid."""
        with self.lock:
            cur = self.entry
            design, setup = edited(cur.design, cur.setup, edit, self.library, self.printers)
            del self.history[self.at + 1:]
            self.history.append(self._entry(design, setup, cur))
            if len(self.history) > MAX_HISTORY:
                del self.history[0]
            return self._move_to(len(self.history) - 1)

    def undo(self) -> tuple[int, Entry]:
        with self.lock:
            if self.at == 0:
                raise FoldprintError("nothing to undo")
            return self._move_to(self.at - 1)

    def redo(self) -> tuple[int, Entry]:
        with self.lock:
            if self.at >= len(self.history) - 1:
                raise FoldprintError("nothing to redo")
            return self._move_to(self.at + 1)

    def replace_design(self, design: Design) -> tuple[int, Entry]:
        """A whole design (an assignment chosen) as the next revision, setup kept."""
        with self.lock:
            cur = self.entry
            del self.history[self.at + 1:]
            self.history.append(self._entry(design, cur.setup, cur))
            if len(self.history) > MAX_HISTORY:
                del self.history[0]
            return self._move_to(len(self.history) - 1)

    def state(self) -> dict:
        with self.lock:
            return {"revision": self.revision, "can_undo": self.at > 0, "can_redo": self.at < len(self.history) - 1}

    # -- what the page and the API read -----------------------------------------------
    def design_json(self) -> dict:
        """``GET /api/design``: the current design (panels, holes, hinges, process) and setup."""
        with self.lock:
            e = self.entry
            st = self.state()
        return dict(design_json(e.design, self.library), setup=e.setup.to_json(), **st,
                    choices=choices_json(self.library, self.printers))

    def nominal(self, revision: int, entry: Entry) -> dict:
        """The nominal result of ``entry`` (computed once, in the caller's thread)."""
        with entry.lock:
            if entry.nominal is None:
                parent, entry.parent = entry.parent, None
                entry.nominal = nominal_json(entry, None if parent is None else parent.memo)
        return dict(entry.nominal, revision=revision)


def edited(design: Design, setup: Setup, edit: Any, library: MaterialLibrary,
           printers: Mapping[str, Printer]) -> tuple[Design, Setup]:
    """``design`` and ``setup`` with ``edit`` applied and validated (see the module docstring)."""
    top = sc.Where("PATCH /api/design")
    edit = sc.table(edit, top, EDIT_KEYS)
    hinges = list(design.hinges)
    by_id = {h.id: k for k, h in enumerate(hinges)}
    changes = sc.table(edit.get("hinges", {}), top / "hinges")
    if len(changes) > MAX_EDIT_ITEMS:
        raise (top / "hinges").fail(f"{len(changes)} hinges; at most {MAX_EDIT_ITEMS} are accepted")
    for hid, raw in changes.items():
        at = top / f"hinges.{hid}"
        if hid not in by_id:
            raise at.fail(f"no hinge {hid!r}; hinges: {', '.join(by_id)}")
        raw = sc.table(raw, at, HINGE_KEYS)
        h = hinges[by_id[hid]]
        if "material" in raw:
            v = raw["material"]
            h = replace(h, material=composition.parse_material_spec(sc.string(v, at / "material") if isinstance(
                v, str) else v, str(at / "material")))
        if "target_deg" in raw:
            deg = sc.number(raw["target_deg"], at / "target_deg", -180.0, 180.0, "degrees")
            if deg == 0:
                raise (at / "target_deg").fail("must not be 0: a hinge folds (FOLD convention: + valley, - mountain)")
            h = replace(h, angle=math.radians(deg))
        hinges[by_id[hid]] = h
    proc = design.process
    p = sc.table(edit.get("process", {}), top / "process", PROCESS_KEYS)
    if "bath_c" in p:
        proc = replace(proc, bath_temperature_c=sc.number(p["bath_c"], top / "process.bath_c", *sc.TEMPERATURE_C,
                                                          "deg C"))
    o = sc.table(edit.get("options", {}), top / "options", OPTION_KEYS)
    if "hinge_model" in o:
        setup = replace(setup, hinge_model=_mode(HingeModel, o["hinge_model"], top / "options.hinge_model"))
    if "mechanics" in o:
        setup = replace(setup, mechanics=_mode(Mechanics, o["mechanics"], top / "options.mechanics"))
    if "printer" in o:
        key = sc.string(o["printer"], top / "options.printer")
        if key not in printers:
            raise (top / "options.printer").fail(f"{key!r} is unknown; profiles: {', '.join(printers)}")
        setup = replace(setup, printer=key)
    return design.replace(library, hinges=tuple(hinges), process=proc), setup


def _mode(enum, value, at: sc.Where):
    try:
        return parse(enum, sc.string(value, at), str(at))
    except FoldprintError:
        raise at.fail(f"must be one of {', '.join(m.value for m in enum)}, got {sc.describe(value)}") from None


def design_json(design: Design, library: MaterialLibrary) -> dict:
    """The design as the page draws it: panels (outline, holes), hinges (id, panels, fold
    line, material, its colour, target angle) and the process."""
    def colour(name: str) -> str:
        return (library[name].color if name in library else "#9a9a9a")[:7]

    return {
        "name": design.name, "description": design.description, "source": design.source,
        "panels": [{"id": p.id, "outline": np.round(p.outline, 4).tolist(),
                    "holes": [np.round(h, 4).tolist() for h in p.holes], "material": p.material}
                   for p in design.panels],
        "hinges": [{"id": h.id, "panels": list(h.panels), "line": np.round(h.line, 4).tolist(),
                    "material": h.material, "color": colour(h.material), "target_deg": round(math.degrees(h.angle), 6)}
                   for h in design.hinges],
        "process": {"bath_c": design.process.bath_temperature_c, "duration_s": design.process.duration_s},
    }


def choices_json(library: MaterialLibrary, printers: Mapping[str, Printer]) -> dict:
    """What the page's selects offer: the hinge materials (library grades and any
    ``--materials`` file's), the printers, the hinge models and mechanics."""
    return {"materials": [{"name": m.name, "tg_c": m.tg_c, "color": m.color[:7]} for m in library
                          if m.recovery is not None and m.profile is None],
            "printers": [{"key": k, "name": p.name} for k, p in printers.items()],
            "hinge_models": [m.value for m in HingeModel], "mechanics": [m.value for m in Mechanics],
            "temperature_c": list(sc.TEMPERATURE_C)}


def nominal_json(entry: Entry, before: studio_reuse.Memo | None = None) -> dict:
    """What an edit answers: the nominal fold in ``simulate --json``'s keys (``completed``,
    ``fold_time_s``, ``hinges`` with each ``onset_time_s`` and ``fold_time_s``,
    ``contacts``), the smallest ``clearance`` and the clearance along the fold, the
    printed crossings, and the design rules' ``findings`` (``check --json``'s keys;
    without the jam test, whose verdict streams from ``/api/verdict``). ``before``: the
    memo of the revision this one was edited from (:mod:`foldprint.apps.studio_reuse`:
    what the edit did not change is not searched again); this one's is left in
    ``entry.memo``."""
    ev = entry.evaluation
    sim = ev.simulation
    with ev.cache.active():
        memo, (asm, err, gaps, crossings) = studio_reuse.printed_part(ev, studio_reuse.memo_for(ev, before))
        with memo.lock:  # revisions of one geometry share its checker: one search at a time
            clear, searched = studio_reuse.nominal_clearance(ev, memo)
            curve, curve_searched = studio_reuse.curve(ev, memo, CURVE_POSES)
        findings = run_checks(CheckContext(ev.design, ev.library, ev.printer, sim, asm, err, gaps, clear, None,
                                           ev.options.thresholds, (), ()))
    entry.memo = replace(memo, clearance=searched, curve=curve_searched)
    out = simulation_json(sim)
    out.update(printed_crossings=[list(p) for p in crossings],
               clearance=None if clear is None else clear.to_json(),
               clearance_curve=dict(curve, poses=CLEARANCE_SAMPLES) if curve["time_s"] else curve,
               findings=[f.to_json() for f in findings], errors=sum(f.severity == "error" for f in findings),
               warnings=sum(f.severity == "warning" for f in findings), setup=entry.setup.to_json())
    out["fold_order"] = [h["id"] for h in sorted(out["hinges"], key=lambda h: (h["onset_time_s"] is None,
                                                                              h["onset_time_s"] or 0.0))]
    return out
