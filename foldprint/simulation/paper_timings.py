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

import numpy as np

from ..core.display import seconds
from ..core.errors import DesignError
from ..core.modes import AfterContact, HingeModel, Method
from ..model.materials import MaterialLibrary, default_library
# the statements and a simulation's value of each live beside what reads them; re-exported here
from ..model.paper_statements import Statement, load_statements  # noqa: F401
from ..physics.recovery.curve import recovery_curve
from ..physics.recovery.table import fold_times
from .paper_beside import ModelValue, PaperLine, model_value, motion_end, verdict  # noqa: F401
from .simulate import simulate


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
    return None if x is None or (isinstance(x, float) and np.isnan(x)) else round(float(x), nd)


#: The template each structure's statements are measured on.
STRUCTURES = {"helix_uniform": ("sample1_contact", "sample1_stop"),
              "helix_graded": ("sample2_whole", "sample2_inner_start", "sample2_inner_finish", "sample2_outer_start",
                               "sample2_outer_finish", "fig3b_order"),
              "self_lock": ("self_lock", "self_lock_threads"),
              "mailbox": ("mailbox_whole",)}


def measure(library: MaterialLibrary | None = None) -> dict[str, ModelValue]:
    """The model's value of every statement in :func:`load_statements` (nominal; a few
    seconds): the free hinges' spreads, and each structure's statements read off its
    template's simulation (:func:`~foldprint.simulation.paper_beside.model_value`, what
    ``simulate`` prints), with the paper's point-hinge ROM and ``arrest`` beside them."""
    lib = library or default_library()
    st = load_statements()
    out: dict[str, ModelValue] = fig1b_values(lib)
    runs = {}
    for name, ids in STRUCTURES.items():
        d = _design(name, lib)
        runs[name] = (d, simulate(d, library=lib))
        for sid in ids:
            out[sid] = model_value(st[sid], runs[name][1])
    _compare(out, runs, lib)
    return out


def fig1b_values(library: MaterialLibrary) -> dict[str, ModelValue]:
    """Fig. 1b's statements (H-7 minus H-1 fold time, free hinges 0.8 mm thick from the
    fixing temperature 10 C, at 80 and 100 C): the model's values."""
    out = {}
    for sid, bath in (("fig1b_spread_80", 80.0), ("fig1b_spread_100", 100.0)):
        t1, t7 = fold_times(library["H-1"], (bath,))[0], fold_times(library["H-7"], (bath,))[0]
        value = None if t1 is None or t7 is None else t7 - t1
        out[sid] = ModelValue(value, f"H-1 {_fold(t1)}, H-7 {_fold(t7)}")
    return out


def _fold(t: float | None) -> str:
    return "does not fold" if t is None else seconds(t)


def fig1b_lines(library: MaterialLibrary | None = None) -> tuple[PaperLine, ...]:
    """Fig. 1b's statements beside the model's values (``foldprint materials`` prints them
    as ``simulate`` prints a structure's); none when the library has no H-1 or H-7."""
    lib = library or default_library()
    if "H-1" not in lib or "H-7" not in lib:
        return ()
    st = load_statements()
    out = []
    for sid, v in fig1b_values(lib).items():
        s = st[sid]
        words = "a hinge does not fold" if v.value_s is None else f"{v.value_s:.2f} s ({v.note})"
        out.append(PaperLine(s, "free hinges", v, verdict(s, v), words))
    return tuple(out)


def _compare(out: dict[str, ModelValue], runs: dict, lib: MaterialLibrary) -> None:
    """What the paper's point-hinge ROM (and ``arrest``) and the hinge groups add to the
    structures' values (the notes of docs/structure-timings.md)."""
    from dataclasses import replace

    d1, arc = runs["helix_uniform"]
    point = simulate(d1, hinge_model=HingeModel.POINT, library=lib)
    point_arrest = simulate(d1, hinge_model=HingeModel.POINT, after_contact=AfterContact.ARREST, library=lib)
    c_pt = point.first_collision
    t_pt = _r(None if c_pt is None else c_pt.time, 3)
    out["sample1_contact"] = replace(out["sample1_contact"], compare={
        "point": t_pt, "point_pair": None if c_pt is None else "-".join(c_pt.panels), "arc_fold_time": _r(arc.fold_time)})
    out["sample1_stop"] = replace(out["sample1_stop"], compare={
        "point_arrest_end": _r(motion_end(point_arrest)), "point_arrest_contact": t_pt,
        "point_arrest_frozen": len(point_arrest.arrested), "arc_fold_time": _r(arc.fold_time)})
    d2, _ = runs["helix_graded"]
    gp = simulate(d2, hinge_model=HingeModel.POINT, library=lib)
    out["sample2_whole"] = replace(out["sample2_whole"], compare={"point_completed": gp.completed})
    _, s = runs["self_lock"]
    out["self_lock"] = replace(out["self_lock"], compare={"goals": {r.goal.id: _r(r.time, 3) for r in s.goals},
                                                          "completed": s.completed})
    d4, mb = runs["mailbox"]
    groups: dict[str, float] = {}
    fin4 = mb.hinge_fold_times
    for k, h in enumerate(d4.hinges):
        groups[h.material] = max(groups.get(h.material, 0.0), float("nan") if fin4[k] is None else fin4[k])
    out["mailbox_whole"] = replace(out["mailbox_whole"], compare={
        "groups": {m: _r(v) for m, v in sorted(groups.items())},
        "hinge_thickness_mm": sorted({h.thickness for h in d4.hinges})})


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
