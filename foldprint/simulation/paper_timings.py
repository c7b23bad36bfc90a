"""The paper's timing statements about hinges and structures, beside the model's.

Every statement Mao et al. (2015) make about *when* something happens (Fig. 1b's spreads,
Sample 1's contact and stall, Sample 2's timeline, Fig. 3b, the mailbox; the self-locking
strip has none) lives in ``foldprint/data/paper_timings.toml`` with its quote and source.
:func:`measure` gives the model's value of each, for the model of record (printed arc
hinges, nominal materials) and, where it tells something, the paper's point-hinge ROM and
``--after-contact arrest``; :func:`verdict` says whether the model meets the statement
under the file's reading of "~". The table and what it means: ``docs/structure-timings.md``.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources

import numpy as np

from ..core.constants import FOLD_LEVEL, ONSET_LEVEL
from ..core.errors import DesignError
from ..core.modes import AfterContact, HingeModel, Method
from ..model.materials import MaterialLibrary, default_library
from ..physics.recovery import recovery_curve
from ..physics.recovery_table import fold_times
from .simulate import SimulationResult, simulate

KINDS = ("about", "at_most", "at_least", "none", "qualitative")
#: "fitted": the shipped recovery parameters were fitted to the statement (agreement is by
#: construction, a calibration regression); "predicted": not used in any fit (agreement is
#: validation).
ROLES = ("fitted", "predicted")


@dataclass(frozen=True)
class Statement:
    id: str
    what: str
    kind: str
    value_s: float | None
    quote: str
    source: str
    role: str = "predicted"


@dataclass(frozen=True)
class Statements:
    approx_tol_s: float
    items: tuple[Statement, ...]

    def __getitem__(self, key: str) -> Statement:
        for s in self.items:
            if s.id == key:
                return s
        raise KeyError(key)


@lru_cache(maxsize=1)
def load_statements() -> Statements:
    """The shipped statements (``foldprint/data/paper_timings.toml``)."""
    res = resources.files("foldprint") / "data" / "paper_timings.toml"
    data = tomllib.loads(res.read_text(encoding="utf-8"))
    items = []
    for k, row in enumerate(data.get("statement", [])):
        kind = row.get("kind")
        if kind not in KINDS:
            raise DesignError(f"paper_timings.toml: statement {k + 1} ({row.get('id')!r}): kind "
                              f"{kind!r} is not one of {', '.join(KINDS)}")
        value = row.get("value_s")
        if kind in ("about", "at_most", "at_least") and not isinstance(value, (int, float)):
            raise DesignError(f"paper_timings.toml: statement {row.get('id')!r} of kind {kind} needs value_s")
        role = row.get("role")
        if role not in ROLES:
            raise DesignError(f"paper_timings.toml: statement {row.get('id')!r}: role {role!r} is not one of "
                              f"{', '.join(ROLES)}")
        items.append(Statement(row["id"], row["what"], kind, None if value is None else float(value),
                               row["quote"], row["source"], role))
    return Statements(float(data["approx_tol_s"]), tuple(items))


@dataclass(frozen=True)
class ModelValue:
    """The model's value (s) of one statement for the model of record (arc hinges,
    nominal materials; None: the event never happens), what it is, and comparisons."""

    value_s: float | None
    note: str
    compare: dict = field(default_factory=dict)


def crossing_times(result: SimulationResult, level: float) -> np.ndarray:
    """Per hinge, the first time (s) its recovery ratio reaches ``level`` on the simulated
    trajectory (linear between samples); NaN where it never does."""
    t, r = result.trajectory.times, result.trajectory.ratios
    out = np.full(r.shape[1], np.nan)
    for i in range(r.shape[1]):
        k = np.nonzero(r[:, i] >= level)[0]
        if len(k) == 0:
            continue
        j = int(k[0])
        if j == 0:
            out[i] = t[0]
        else:
            f = (level - r[j - 1, i]) / (r[j, i] - r[j - 1, i])
            out[i] = t[j - 1] + f * (t[j] - t[j - 1])
    return out


def motion_end(result: SimulationResult) -> float | None:
    """When the last hinge stops moving: arrested hinges at their arrest, the others at
    98 %; None if some free hinge is still short of 98 % at the end of the run."""
    ids = [h.id for h in result.design.hinges]
    done = crossing_times(result, FOLD_LEVEL)
    ends = []
    for i, hid in enumerate(ids):
        if hid in result.arrested:
            ends.append(result.arrested[hid])
        elif math.isnan(done[i]):
            return None
        else:
            ends.append(float(done[i]))
    return max(ends) if ends else 0.0


def _design(name: str, library: MaterialLibrary):
    from ..io.load import load_design
    from ..io.templates import resolve_design_path

    return load_design(resolve_design_path(name), library)


def sample1_contact_ratio(library: MaterialLibrary | None = None) -> float:
    """Recovery ratio of H-3 at the first contact of the paper's ROM (point hinges) on
    ``helix_uniform``. Nine identical hinges keep every angle equal, so this ratio is set
    by the geometry alone, whatever the recovery parameters."""
    lib = library or default_library()
    d = _design("helix_uniform", lib)
    res = simulate(d, hinge_model=HingeModel.POINT, library=lib)
    if res.first_collision is None:
        raise DesignError("helix_uniform: the point-hinge ROM no longer collides; "
                          "the Sample 1 contact ratio is undefined")
    h = d.hinges[0]
    curve = recovery_curve(lib[h.material], d.process.bath_temperature_c, h.thickness,
                           d.process.fix_temperature_c)
    return float(curve(res.first_collision.time))


def _r(x: float | None, nd: int = 2) -> float | None:
    return None if x is None or (isinstance(x, float) and math.isnan(x)) else round(float(x), nd)


def measure(library: MaterialLibrary | None = None) -> dict[str, ModelValue]:
    """The model's value of every statement in :func:`load_statements` (nominal; a few
    seconds)."""
    lib = library or default_library()
    out: dict[str, ModelValue] = {}

    # Fig. 1b: free hinges, 0.8 mm, from the fixing temperature 10 C
    h1 = fold_times(lib["H-1"], (80.0, 90.0, 100.0))
    h7 = fold_times(lib["H-7"], (80.0, 90.0, 100.0))
    out["fig1b_spread_80"] = ModelValue(h7[0] - h1[0], f"H-1 {h1[0]:.2f} s, H-7 {h7[0]:.2f} s")
    out["fig1b_spread_100"] = ModelValue(h7[2] - h1[2], f"H-1 {h1[2]:.2f} s, H-7 {h7[2]:.2f} s")

    # Sample 1: nine H-3
    d1 = _design("helix_uniform", lib)
    arc = simulate(d1, library=lib)
    point = simulate(d1, hinge_model=HingeModel.POINT, library=lib)
    point_arrest = simulate(d1, hinge_model=HingeModel.POINT, after_contact=AfterContact.ARREST, library=lib)
    c_arc = arc.first_collision
    c_pt = point.first_collision
    out["sample1_contact"] = ModelValue(
        None if c_arc is None else c_arc.time,
        "no contact: the printed spiral folds completely" if c_arc is None else
        f"{c_arc.panels[0]}-{c_arc.panels[1]}",
        {"point": _r(None if c_pt is None else c_pt.time, 3),
         "point_pair": None if c_pt is None else "-".join(c_pt.panels),
         "arc_fold_time": _r(arc.fold_time)})
    end_pt = motion_end(point_arrest)
    out["sample1_stop"] = ModelValue(
        None if arc.completed else motion_end(arc),
        "never stops short: completes" if arc.completed else "motion ends",
        {"point_arrest_end": _r(end_pt), "point_arrest_contact": _r(None if c_pt is None else c_pt.time, 3),
         "point_arrest_frozen": len(point_arrest.arrested), "arc_fold_time": _r(arc.fold_time)})

    # Sample 2: graded
    d2 = _design("helix_graded", lib)
    g = simulate(d2, library=lib)
    on = crossing_times(g, ONSET_LEVEL)
    fin = crossing_times(g, FOLD_LEVEL)
    gp = simulate(d2, hinge_model=HingeModel.POINT, library=lib)
    out["sample2_whole"] = ModelValue(g.fold_time, "every hinge at 98 %" if g.completed else "does not complete",
                                      {"point_completed": gp.completed})
    out["sample2_inner_start"] = ModelValue(float(np.max(on[:3])), "last of hinges 1-3 at 5 %")
    out["sample2_inner_finish"] = ModelValue(float(np.max(fin[:3])), "last of hinges 1-3 at 98 %")
    out["sample2_outer_start"] = ModelValue(float(np.min(on[-2:])), "first of hinges 8-9 at 5 %")
    out["sample2_outer_finish"] = ModelValue(float(np.max(fin[-2:])), "last of hinges 8-9 at 98 %")

    # Fig. 3b: H-1, H-4, H-7 of Sample 2 (hinges 1, 5, 8)
    half = crossing_times(g, 0.5)
    mats = [h.material for h in d2.hinges]
    picks = {m: mats.index(m) for m in ("H-1", "H-4", "H-7")}
    t50 = {m: float(half[k]) for m, k in picks.items()}
    t98 = {m: float(fin[k]) for m, k in picks.items()}
    ordered = t50["H-1"] < t50["H-4"] < t50["H-7"] and t98["H-1"] < t98["H-4"] < t98["H-7"]
    out["fig3b_order"] = ModelValue(
        None, "H-1 < H-4 < H-7 at 50 % and 98 %" if ordered else "order differs",
        {"t50": {m: _r(v) for m, v in t50.items()}, "t98": {m: _r(v) for m, v in t98.items()},
         "ordered": ordered})

    # self-locking strip: no time in the paper
    d3 = _design("self_lock", lib)
    s = simulate(d3, library=lib)
    out["self_lock"] = ModelValue(s.fold_time, "fold time (98 %)",
                                  {"goals": {r.goal.id: _r(r.time, 3) for r in s.goals}, "completed": s.completed})

    # mailbox
    d4 = _design("mailbox", lib)
    mb = simulate(d4, library=lib)
    groups = {}
    fin4 = crossing_times(mb, FOLD_LEVEL)
    for k, h in enumerate(d4.hinges):
        groups[h.material] = max(groups.get(h.material, 0.0), float(fin4[k]))
    out["mailbox_whole"] = ModelValue(mb.fold_time, "every hinge at 98 %" if mb.completed else "does not complete",
                                      {"groups": {m: _r(v) for m, v in sorted(groups.items())},
                                       "hinge_thickness_mm": sorted({h.thickness for h in d4.hinges})})
    return out


def verdict(statement: Statement, value: ModelValue, tol_s: float) -> str:
    """'meets', 'misses', 'never happens' (the model has no such event), or '-' (no number
    to compare)."""
    if statement.kind in ("none", "qualitative"):
        if statement.kind == "qualitative" and "ordered" in value.compare:
            return "meets" if value.compare["ordered"] else "misses"
        return "-"
    if value.value_s is None:
        return "never happens"
    v, x = value.value_s, statement.value_s
    ok = {"about": abs(v - x) <= tol_s + 1e-9, "at_most": v <= x + tol_s + 1e-9,
          "at_least": v >= x - tol_s - 1e-9}[statement.kind]
    return "meets" if ok else "misses"


def _arrest_sample(args):
    """One scattered Sample 1 folded with ``--after-contact arrest`` (module level: pickles)."""
    from .robust import sample_drive

    design, library, sample = args
    res = simulate(design, method=Method.FCL, after_contact=AfterContact.ARREST, library=library,
                   drive=sample_drive(design, library, sample))
    c = res.first_collision
    return (None if c is None else float(c.time), motion_end(res), len(res.arrested))


def sample1_under_scatter(samples: int = 60, seed: int = 1, library: MaterialLibrary | None = None,
                          workers: int | None = None) -> dict:
    """Sample 1 (printed geometry, arc hinges) under ``robust``'s default scatter, each
    sample folded with ``--after-contact arrest``: first-contact and motion-end times
    (5th / 50th / 95th percentile over the samples that touch)."""
    from ..core.parallel import map_ordered
    from .robust import default_scatter, draw_samples

    lib = library or default_library()
    d = _design("helix_uniform", lib)
    drawn = draw_samples(d, default_scatter(), samples, seed)
    rows = map_ordered(_arrest_sample, [(d, lib, s) for s in drawn], workers=workers)
    touched = [r for r in rows if r[0] is not None]
    contact = np.array([r[0] for r in touched])
    ended = [r for r in touched if r[1] is not None]  # None: a free hinge still moving at the end
    ends = np.array([r[1] for r in ended])
    slow = np.array([r[1] - r[0] for r in ended])

    def pct(a):
        return None if a.size == 0 else {k: round(float(v), 2) for k, v in
                                         zip(("p5", "p50", "p95"), np.percentile(a, [5, 50, 95]))}

    return {"samples": samples, "seed": seed, "touched": int(contact.size), "contact_s": pct(contact),
            "motion_end_s": pct(ends), "slow_phase_s": pct(slow), "still_moving": len(touched) - len(ended)}
