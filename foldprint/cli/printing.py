"""What the command line prints on stdout and stderr: JSON, notes (silenced by --quiet),
and a simulation's text report (the verdict, fold times, clearance, contacts, hinges,
goals, notes, the paper's statements).
"""

from __future__ import annotations

import json

from typer import echo

from ..core.display import clipped, first_few, hinge_lines, seconds

#: --quiet and --verbose of this run (set by the root's callback).
OUTPUT_STATE = {"quiet": False, "verbose": False}
#: whether this process has said that the compiled kernels cannot load, and that they are
#: compiling (each said once)
_KERNELS = {"noted": False, "compiling": False}


def echo_json(obj) -> None:
    echo(json.dumps(obj, indent=2, allow_nan=False))


def noted(loaded, folds: bool = True):
    """A loaded ``(design, library)`` after its reader's notes are printed (a stray
    crease dropped, rounded loop angles closed within a tolerance), and the kernels' notes
    (``folds``: the command folds the design, so a cold cache compiles them first)."""
    d, lib = loaded
    for note in d.notes:
        echo_note(f"note: {d.source or d.name}: {note}")
    note_kernels()
    if folds:
        note_compiling(d)
    return d, lib


def note_kernels() -> None:
    """One note, once per process, when the compiled kernels were asked for but numba
    cannot load (:func:`foldprint.core.jit.fallback_note`): the numpy path runs instead.
    Called by the commands that fold designs (never by ``--help``: it tries numba)."""
    if _KERNELS["noted"]:
        return
    _KERNELS["noted"] = True
    from ..core.jit import fallback_note

    msg = fallback_note()
    if msg:
        echo_note(f"note: {msg}")


def note_compiling(design) -> None:
    """One note, once per process, when folding ``design`` will first compile the kernels
    (numba's cache is empty: the first command after an install;
    :func:`foldprint.apps.pipeline.compile_note`), so a long silent start has its reason.
    Silenced by --quiet, as every note; not read then (nothing to say)."""
    if _KERNELS["compiling"] or OUTPUT_STATE["quiet"]:
        return
    _KERNELS["compiling"] = True
    from ..apps.pipeline import compile_note

    msg = compile_note(design)
    if msg:
        echo_note(f"note: {msg}")


def echo_note(msg: str) -> None:
    """A human message on stderr (silenced by --quiet)."""
    if not OUTPUT_STATE["quiet"]:
        echo(msg, err=True)


def verdict_word(r: dict) -> str:
    if r["completed"]:
        return "completes"
    c = r["first_collision"]
    return "does NOT complete" + (f" ({c['panels'][0]}-{c['panels'][1]} at {seconds(c['time_s'])})" if c else "")


def print_simulation(r: dict) -> None:
    crossing = r.get("printed_crossings") or []
    if crossing:  # the printed part itself overlaps: no fold, no contact time to report
        pairs = first_few([f"{a!r} and {b!r}" for a, b in crossing], 5)
        echo(f"{r['design']}: can never be printed: panels {pairs} cross in the printed (permanent) state "
             "(the target angles put them through each other; no hinge order or material can fold it): "
             "change the target angles, lengths or holes")
        return
    margin = r.get("scatter_margin")
    marginal = bool(margin and margin["marginal"])
    verdict = "completes nominally, but MARGINAL: scatter closes its smallest clearance (below)" if marginal \
        else verdict_word(r)
    echo(f"{r['design']} at {r['temperature_c']:g} C ({r['hinge_model']} hinges, {r['method']}): {verdict}")
    if r["fold_time_s"] is not None:
        echo(f"  folded in {seconds(r['fold_time_s'])}")
    print_clearance(r.get("clearance"), margin, r["first_collision"] is None)
    for line in clipped([f"  contact {c['panels'][0]}-{c['panels'][1]} at {seconds(c['time_s'])} ({c['method']})"
                         for c in r["contacts"]], what="contacts (--json lists every one)") + hinge_lines(r["hinges"]):
        echo(line)
    for g in r["goals"]:
        state = f"met at {seconds(g['time_s'])}" if g["met"] else "NOT met"
        echo(f"  goal {g['id']}: {g['panel']} through holes[{g['hole']}] of {g['target']}: {state}")
    for n in r.get("notes") or []:
        echo(f"  note: {n}")
    mech = r.get("mechanics") or {}
    if mech.get("model") == "bar-hinge":
        echo(f"  bar-and-hinge: largest panel strain {mech['max_panel_strain']:.3%} (panel {mech['worst_panel']}), "
             f"largest diagonal fold {mech['max_panel_bending_deg']:.2f} deg, {mech['nodes']} nodes"
             + (f"; ABOVE the {mech['panel_strain_limit']:.1%} limit" if mech["above_limit"] else ""))
    if r.get("comparison"):
        c = r["comparison"]
        echo(f"  note: the {c['hinge_model']} hinge model disagrees: it {verdict_word(c)} "
             "(docs/simulation.md explains the two models)")
    loops = r.get("loops") or {}
    for stuck in loops.get("not_followed") or []:
        echo(f"  note: from {seconds(stuck['time_s'])} the loops' closure does not follow the drive of "
             f"{first_few(stuck['hinges'])}: they stay where the closure holds them (docs/loops.md)")
    print_paper(r.get("paper") or [])



def print_clearance(gap: dict | None, margin: dict | None, no_contact: bool) -> None:
    """The smallest clearance along the fold and whether scatter closes it."""
    if gap is None or not no_contact:
        return
    at = f"{gap['panels'][0]}-{gap['panels'][1]} at {seconds(gap['time_s'])}"
    echo(f"  smallest clearance along the fold: {gap['distance_mm']:.2f} mm ({at})")
    if margin is None:
        return
    w, n = margin["worst"], margin["samples"]
    where = f"{w['panels'][0]}-{w['panels'][1]} at {seconds(w['time_s'])}"
    if margin["marginal"]:
        echo(f"  MARGINAL: panels touch in {margin['touching']} of {n} scattered folds (the first samples "
             f"`foldprint check` draws), e.g. {where}: scatter moves them more than the "
             f"{gap['distance_mm']:.2f} mm clearance; `foldprint check` gives the jam probability")
    else:
        echo(f"  scatter: no panels touch in {n} scattered folds (the first samples `foldprint check` draws; "
             f"closest {w['distance_mm']:.2f} mm, {where}); `foldprint check` gives the jam probability")


def print_paper(lines: list[dict]) -> None:
    """The paper's statements about the design beside the model's values."""
    for p in lines:
        echo(f"  paper, {p['structure']}, {p['figure']}: \"{p['quote']}\"")
        echo(f"    {p['what']}: {p['summary']}")
