"""``<name>_recipe.md``: how to print, program and fold the exported part, written beside
the files of every export.

It states, for a person at the printer and the bath: each body's material, its tool in
the slicer 3MFs and its STL; what the design needs of a printer (FDM tools, PolyJet resin
channels, :class:`~foldprint.model.printers.ToolFit`); the programming protocol and
temperatures of the design's ``[process]`` (the paper's: printed folded, pressed flat hot,
fixed cold, recovered in a hot bath); the order and times in which the hinges are expected
to fold (each hinge's 98 % recovery time in the bath, the model's numbers, handed in by the
pipeline); and the check's verdict when the exporter was handed one (:class:`CheckSummary`;
an export computes none).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

from ..core.display import seconds
from ..core.version import __version__
from ..geometry import Assembly
from ..model.design import Design
from ..model.materials import MaterialLibrary
from ..model.printers import ToolFit
from .stl import programming


@dataclass(frozen=True)
class CheckSummary:
    """What ``check`` found, as the recipe reports it: the printer it judged against and
    each finding as (severity, code, message)."""

    printer: str
    findings: tuple[tuple[str, str, str], ...]

    def count(self, severity: str) -> int:
        return sum(f[0] == severity for f in self.findings)

    @property
    def verdict(self) -> str:
        e, w = self.count("error"), self.count("warning")
        if e:
            return f"FAILS: {e} error(s), {w} warning(s) on {self.printer}"
        return f"passes on {self.printer}" + (f", with {w} warning(s)" if w else " (no errors, no warnings)")


def check_summary(printer: str, findings) -> CheckSummary:
    """A :class:`CheckSummary` of ``findings`` (objects with ``severity``, ``code`` and
    ``message``, e.g. :class:`foldprint.checks.rules.Finding`) judged on ``printer``."""
    return CheckSummary(printer, tuple((f.severity, f.code, f.message) for f in findings))


def _md(text: object) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _shared(assembly: Assembly, files: Mapping[str, Sequence[str]]) -> list[str]:
    """The files that hold every body (projects, hand-offs), in the export's order; an STL
    is one body's file even when the part has one body."""
    mats = [b.material for b in assembly.bodies]
    first = list(files.get(mats[0], ())) if mats else []
    return [f for f in first if not f.endswith(".stl") and all(f in files.get(m, ()) for m in mats)]


def _bodies(assembly: Assembly, library: MaterialLibrary, files: Mapping[str, Sequence[str]]) -> list[str]:
    shared = set(_shared(assembly, files))
    rows = ["| body | material | role | Tg (°C) | slicer tool | volume (mm³) | its own file |",
            "|---|---|---|---|---|---|---|"]
    for k, b in enumerate(assembly.bodies):
        m = library[b.material] if b.material in library else None
        role, tg = (m.role, f"{m.tg_c:g}") if m else ("?", "?")
        held = ", ".join(f"`{f}`" for f in files.get(b.material, ()) if f not in shared) or "-"
        rows.append(f"| {k + 1} | {_md(b.material)} | {role} | {tg} | extruder {k + 1} (T{k}) | {b.volume:.1f} | {held} |")
    return rows


def _projects(assembly: Assembly, files: Mapping[str, Sequence[str]]) -> list[str]:
    """What each file holding every body is for: which slicer reads it with the tools of
    the table (PrusaSlicer opens the spec 3MF with one extruder and prints every body with
    T0, checked with ``prusa-slicer --export-gcode``), which are not for slicing."""
    shared = _shared(assembly, files)
    prusa = next((f for f in shared if f.endswith("_prusa.3mf")), None)
    out = []
    for f in shared:
        if f.endswith("_prusa.3mf"):
            use = "PrusaSlicer project: one extruder per body, the tools of the table."
        elif f.endswith("_voxels.3mf"):
            use = "PolyJet voxel print (composite 3MF beside the PNG slices), not for an FDM slicer."
        elif f.endswith(".3mf"):
            use = ("OrcaSlicer / Bambu Studio project: each body its own part and filament, the tools of the table. "
                   "PrusaSlicer opens it with one extruder and prints every body with T0: "
                   + (f"use `{prusa}` there." if prusa else "export `--format prusa3mf` for it."))
        else:
            use = "a hand-off to another program (crease pattern, FE mesh or animation), not for slicing."
        out.append(f"- `{f}`: {use}")
    return ["Files that hold every body:", "", *out] if out else []


def _printer(fit: ToolFit | None, n: int) -> list[str]:
    if fit is None:
        return [f"No printer was given (`--printer`). On an FDM printer the part needs {n} tools, one filament "
                f"per material; the slicer 3MFs describe a generic FDM printer with {n} extruders. On a PolyJet "
                "printer the hinge grades are digital materials jetted from VeroWhite and TangoBlack. "
                "`foldprint check DESIGN --printer KEY` says whether a profile fits."]
    pr = fit.printer
    out = [f"Printer: **{_md(pr.name)}** (`{pr.key}`, {pr.technology}). {_md(fit.summary())}."]
    if pr.tools_source:
        out.append(f"Tool count: {_md(pr.tools_source)}.")
    if pr.fdm:
        out.append("Load one filament per tool as in the table above. The materials are the paper's PolyJet "
                   "digital SMPs: a filament stands in for each, and the fold times below are the model's for the "
                   "digital SMPs, not for filaments.")
    else:
        out.append("Assign each STL its material in the printer's software (GrabCAD Print: one digital material "
                   "per hinge grade); the slicer tools do not apply.")
    return out


def _fold(design: Design, fold_times: Mapping[str, float | None] | None, bath_c: float) -> list[str]:
    if fold_times is None:
        return ["Fold times were not given to this export."]
    rows = ["| order | hinge | material | folded (98 %) at |", "|---|---|---|---|"]
    timed = sorted(design.hinges, key=lambda h: (fold_times.get(h.id) is None, fold_times.get(h.id) or 0.0, h.id))
    for k, h in enumerate(timed):
        t = fold_times.get(h.id)
        rows.append(f"| {k + 1} | {_md(h.id)} | {_md(h.material)} | "
                    + ("does not fold in this bath |" if t is None else f"{seconds(t)} |"))
    prog = programming(design, fold_times)
    done = prog["expected_fold_time_s"]
    rows.append("")
    rows.append(f"Expected: folded in {seconds(done)} in the {bath_c:g} °C bath (the slowest hinge)." if done is not None
                else "Expected: at least one hinge does not fold in this bath.")
    rows.append("Times are the recovery model's for each hinge's material and thickness (98 % recovery, "
                "docs/recovery-model.md), not measurements; hinges that fold close together may swap under "
                "scatter (`foldprint check` gives the jam probability).")
    return rows


def recipe_markdown(design: Design, assembly: Assembly, library: MaterialLibrary, files: Mapping[str, Sequence[str]],
                    fold_times: Mapping[str, float | None] | None = None, fit: ToolFit | None = None,
                    check: CheckSummary | None = None) -> str:
    """The recipe text. ``files``: material -> the export's files that hold its body;
    ``fold_times``: each hinge's 98 % time (s) by id; ``fit``: the printer export was given
    and what the design needs of it; ``check``: the check's findings, when it ran."""
    pr = design.process
    n = len(assembly.bodies)
    out = [f"# Print recipe: {_md(design.name)} ({assembly.state} state)", "",
           f"Written by foldprint {__version__} beside the exported files. "
           + (_md(design.description) if design.description else ""), "",
           "## Check", ""]
    out.append(f"`foldprint check`: **{check.verdict}**." if check is not None else
               f"Not checked in this export: run `foldprint check {_md(design.name)}"
               + (f" --printer {fit.printer.key}" if fit else "") + "` before printing.")
    shown = [] if check is None else [f"- {s.upper()} {c}: {_md(msg)}" for s, c, msg in check.findings if s != "info"]
    if shown:
        out += ["", *shown]
    projects = _projects(assembly, files)
    out += ["", "## Printer and tools", "", *_printer(fit, n), "", *_bodies(assembly, library, files), "",
            *projects, *([""] if projects else []),
            "## Print, program, fold", "",
            "1. Print the part as exported: the permanent state, folded, as the paper prints it."
            if assembly.state == "permanent" else
            "1. These files are the programmed (flat) state, for reference: a part printed flat has a flat "
            "permanent shape and does not fold. Print the permanent state (`foldprint export DESIGN`).",
            f"2. Program: heat it to {pr.program_temperature_c:g} °C (above every hinge's Tg) and press it flat.",
            f"3. Fix: cool it to {pr.fix_temperature_c:g} °C while held flat (below every Tg), then release.",
            f"4. Fold: drop it into a {pr.bath_temperature_c:g} °C bath for up to {pr.duration_s:g} s; the hinges "
            "recover their printed angles in the order below.",
            "", "## Expected fold order", "", *_fold(design, fold_times, pr.bath_temperature_c), ""]
    return "\n".join(out)
