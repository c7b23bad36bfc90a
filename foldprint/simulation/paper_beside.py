"""The paper's statements about a structure beside the model's value, for one simulation.

A design taken from the paper links the statements about it
(:class:`~foldprint.model.paper_statements.PaperRef`); :func:`paper_lines` reads each
statement's value off the design's simulation (:func:`model_value`, by the statement's
``measure``), judges it under the data file's reading of "~" (:func:`verdict`) and says
both in one line: the quote and figure, the paper's number, the model's, their ratio
(model / paper). ``simulate``, ``check`` and the gallery print these lines;
:mod:`foldprint.simulation.paper_timings` uses the same values for the table of
docs/structure-timings.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.display import first_few, percent, seconds
from ..core.constants import FOLD_LEVEL, ONSET_LEVEL
from ..model.design import Design
from ..model.paper_reading import PHRASES, Reading, read
from ..model.paper_statements import Statement, load_statements
from .simulate import SimulationResult, crossing_times


@dataclass(frozen=True)
class ModelValue:
    """The model's value (s) of one statement (None: the event never happens), what it
    is, and comparisons (``holds``: a qualitative statement's verdict)."""

    value_s: float | None
    note: str
    compare: dict = field(default_factory=dict)


def motion_end(result: SimulationResult) -> float | None:
    """When the last hinge stops moving: arrested hinges at their arrest, the others at
    98 %; None if some free hinge is still short of 98 % at the end of the run."""
    ids = [h.id for h in result.design.hinges]
    done = result.hinge_fold_times
    ends = []
    for i, hid in enumerate(ids):
        if hid in result.arrested:
            ends.append(result.arrested[hid])
        elif done[i] is None:
            return None
        else:
            ends.append(float(done[i]))
    return max(ends) if ends else 0.0


def _r(x: float | None, nd: int = 2) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else round(float(x), nd)


def _hinge_times(s: Statement, result: SimulationResult) -> ModelValue:
    level = ONSET_LEVEL if s.measure.startswith("onset") else FOLD_LEVEL
    ids = [h.id for h in result.design.hinges]
    at = crossing_times(result, level) if level != FOLD_LEVEL else \
        np.array([np.nan if t is None else t for t in result.hinge_fold_times])
    t = at[[ids.index(h) for h in s.hinges]]
    never = [h for h, x in zip(s.hinges, t) if np.isnan(x)]
    if s.measure == "onset_first":  # the first that gets there; none: never
        v = None if len(never) == len(t) else float(np.nanmin(t))
    else:  # the last: never, once one of them never gets there
        v = None if never else float(np.max(t))
    if v is None:
        return ModelValue(None, f"{first_few(never)} never {'reaches' if len(never) == 1 else 'reach'} "
                                f"{100 * level:g} % within the run")
    which = "first" if s.measure == "onset_first" else "last"
    return ModelValue(v, f"the {which} of {', '.join(s.hinges)} to reach {100 * level:g} %")


def _order(s: Statement, result: SimulationResult) -> ModelValue:
    mats = [h.material for h in result.design.hinges]
    picks = {m: mats.index(m) for m in s.materials}
    half, fin = crossing_times(result, 0.5), [math.nan if t is None else t for t in result.hinge_fold_times]
    t50 = {m: float(half[k]) for m, k in picks.items()}
    t98 = {m: float(fin[k]) for m, k in picks.items()}
    holds = all(a[x] < a[y] for a in (t50, t98) for x, y in zip(s.materials, s.materials[1:]))
    order = " < ".join(s.materials)
    note = (f"{order} at 50 % ({', '.join(seconds(t50[m]) for m in s.materials)}) and 98 % "
            f"({', '.join(seconds(t98[m]) for m in s.materials)})" if holds else f"not {order}")
    return ModelValue(None, note, {"t50": {m: _r(v) for m, v in t50.items()},
                                   "t98": {m: _r(v) for m, v in t98.items()}, "holds": holds})


def _goals(result: SimulationResult) -> ModelValue:
    gs = result.goals
    holds = bool(gs) and all(g.met for g in gs)
    parts = [f"{g.goal.panel} through holes[{g.goal.hole}] of {g.goal.target} "
             + (f"at {seconds(g.time)}" if g.met else "NOT met") for g in gs]
    return ModelValue(None, "; ".join(parts) or "no goals", {"holds": holds})


def model_value(s: Statement, result: SimulationResult) -> ModelValue:
    """The model's value of statement ``s`` on ``result`` (a simulation of the structure
    the statement is about), read as its ``measure`` says."""
    m = s.measure
    if m == "first_contact":
        c = result.first_collision
        return ModelValue(None if c is None else float(c.time),
                          "no contact" if c is None else f"first contact {c.panels[0]}-{c.panels[1]}")
    if m == "motion_end":
        end = None if result.completed else motion_end(result)
        return ModelValue(end, "completes: never stops short" if result.completed else
                          "a hinge is still moving at the end of the run" if end is None else "the motion ends")
    if m == "fold_time":
        ft = result.fold_time if result.completed else None
        return ModelValue(ft, "every hinge at 98 %" if result.completed else "does not complete")
    if m in ("onset_last", "fold_last", "onset_first"):
        return _hinge_times(s, result)
    if m == "order":
        return _order(s, result)
    if m == "goals":
        return _goals(result)
    raise ValueError(f"statement {s.id!r}: measure {m!r} is not read off a structure's simulation")


def reading(statement: Statement, tol_s: float | None = None) -> Reading | None:
    """The statement's words as one interval (:mod:`foldprint.model.paper_reading`); None
    for a statement without a number."""
    if statement.kind not in PHRASES or statement.value_s is None:
        return None
    return read(statement.kind, statement.value_s, tol_s)


def verdict(statement: Statement, value: ModelValue, tol_s: float | None = None) -> str:
    """'meets', 'misses', 'never happens' (the model has no such event), or '-' (no number
    to compare); a number is judged by :func:`reading` (``tol_s`` None: the paper's)."""
    if statement.kind in ("none", "qualitative"):
        if statement.kind == "qualitative" and "holds" in value.compare:
            return "meets" if value.compare["holds"] else "misses"
        return "-"
    return reading(statement, tol_s).verdict(value.value_s)


def paper_value_text(s: Statement) -> str:
    """The paper's number as the paper says it: "~7.5 s", "within ~1 s", "after 3 s"."""
    if s.value_s is None:
        return "no time given" if s.kind == "none" else "no number"
    return PHRASES[s.kind].format(f"{s.value_s:g}")


@dataclass(frozen=True)
class PaperLine:
    """One statement of the paper beside the model's value on one simulation."""

    statement: Statement
    structure: str  # how the paper names the structure: "Sample 1"
    value: ModelValue
    verdict: str
    model: str  # the model's side, in words
    tol_s: float | None = None  # the reading's tolerance (None: the paper's)

    @property
    def ratio(self) -> float | None:
        """model / paper, when both are numbers."""
        x, v = self.statement.value_s, self.value.value_s
        return None if x is None or v is None or x == 0 else v / x

    @property
    def summary(self) -> str:
        """"paper ~7.5 s; model 2.20 s (model/paper 0.29): misses the paper (read as
        7-8 s, +/-0.5 s: ...)": the tolerance beside every verdict on a number."""
        s = self.statement
        paper = f"paper {paper_value_text(s)}; " if s.kind not in ("qualitative",) else ""
        ratio = "" if self.ratio is None else f" (model/paper {self.ratio:.2f})"
        tail = {"meets": ": meets the paper", "misses": ": misses the paper"}.get(self.verdict, "")
        rd = reading(s, self.tol_s)
        if tail and rd is not None:
            tail += f" ({rd.read_as})"
        return f"{paper}model: {self.model}{ratio}{tail}"

    def to_json(self) -> dict:
        s = self.statement
        return {"id": s.id, "structure": self.structure, "figure": s.figure, "what": s.what, "quote": s.quote,
                "source": s.source, "kind": s.kind, "paper_s": s.value_s, "paper": paper_value_text(s),
                "model_s": _r(self.value.value_s, 4),
                "ratio": _r(self.ratio, 3), "verdict": self.verdict, "model": self.model, "summary": self.summary,
                "reading": self._reading_json()}

    def _reading_json(self) -> dict | None:
        rd = reading(self.statement, self.tol_s)
        return None if rd is None else {"text": rd.text, "read_as": rd.read_as, "low_s": rd.low, "high_s": None if math.isinf(rd.high)
                                        else rd.high, "tolerance_s": rd.tol_s, "tolerance_source": rd.tol_source}


def _words(s: Statement, v: ModelValue, result: SimulationResult, clearance, jam_probability) -> str:
    """The model's side of statement ``s`` in words, with the clearance and (when known)
    the jam probability where the paper speaks of a contact the nominal model lacks."""
    if s.measure == "first_contact" and v.value_s is None:
        text = "no contact: the nominal fold completes" if result.completed else "no contact"
        if clearance is not None:
            text += f" (closest {clearance.distance:.2f} mm, {clearance.panels[0]}-{clearance.panels[1]} " \
                    f"at {seconds(clearance.time)})"
        if jam_probability is None:
            return text + "; under scatter: `foldprint check` gives the jam probability"
        return text + f"; under scatter the jam probability is {percent(jam_probability)}"
    if s.measure == "motion_end" and v.value_s is None and result.completed:
        return f"never stops short: every hinge reaches 98 % by {seconds(result.fold_time)}"
    if v.value_s is None:
        return v.note
    return f"{seconds(v.value_s)}, {v.note}"


def paper_lines(design: Design, result: SimulationResult, clearance=None,
                jam_probability: float | None = None) -> tuple[PaperLine, ...]:
    """Every statement ``design`` links (its ``paper``) beside ``result``; none for a
    design not taken from the paper."""
    ref = design.paper
    if ref is None:
        return ()
    st = load_statements()
    out = []
    for sid in ref.statements:
        s = st[sid]
        v = model_value(s, result)
        words = _words(s, v, result, clearance, jam_probability)
        bath, own = float(result.trajectory.bath_c), float(design.process.bath_temperature_c)
        if abs(bath - own) > 1e-9:  # a bath given for this run: not the paper's conditions
            words += f" (this run's bath {bath:g} C, the design's {own:g} C)"
        out.append(PaperLine(s, ref.name, v, verdict(s, v), words))
    return tuple(out)
