"""``foldprint export`` and ``foldprint gallery``: the files of one printable part, and the
offline HTML gallery of many designs.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from ..apps.resolve import (MAX_WORKERS, check_count, load_designs, load_input, load_library, load_printer,
                            template_paths)
from ..core.constants import EXPORT_FORMATS
from ..core.modes import DEFAULT_MECHANICS, DEFAULT_STATE, Mechanics, State, parse
from ..core.errors import FoldprintError
from .lazy import summary
from .options import CREASE_HELP, SCALE_HELP, check_out_dir
from .printing import OUTPUT_STATE, echo_json, echo_note, note_kernels, noted
from .progress import with_progress
from .root import app

FORCE_HELP = ("Write into a folder that holds other files: the output's files are added beside them one by one "
              "(files of other names are left as they are, files of the same names replaced; a kill can leave "
              "a mix). Without it such a folder is refused.")


def _plan_out(out_dir: Path, force: bool, what: str):
    """Refuse ``out_dir`` before anything is built (the library checks again when it
    publishes); say when the output will land file by file. The plan
    (:class:`foldprint.exchange.outfolder.Plan`)."""
    from ..apps.outputs import plan_out
    from ..core.modes import Publish

    p = plan_out(out_dir, force)
    if p.publish == Publish.FILE_BY_FILE:
        echo_note(f"{out_dir}: the {what}'s files go in one by one, not as one set: {p.why}")
    return p


@app.command(short_help=summary('export'))
def export(
    design: str = typer.Argument(..., help="Design file (.toml, .fold, .svg) or template name."),
    out: Optional[str] = typer.Option(None, "--out", help="Output directory (default: output/<design>/)."),
    state: str = typer.Option(DEFAULT_STATE.value, "--state", help="permanent (folded, printed) | programmed (flat)"),
    formats: str = typer.Option(",".join(EXPORT_FORMATS), "--format",
                                help="Comma-separated: 3mf, prusa3mf, stl (to print); fold (crease pattern), "
                                     "inp (Abaqus, planar strips), xdmf (ParaView series), glb (animated glTF), "
                                     "voxels (PolyJet voxel print: PNG slices, manifest, composite 3MF)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    scale: Optional[float] = typer.Option(None, "--scale", help=SCALE_HELP),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=CREASE_HELP),
    printer: Optional[str] = typer.Option(None, "--printer",
                                          help="Printer profile the files are for (data/printers.toml): refused "
                                               "(exit 2) when the design needs more materials than it has tools; "
                                               "an FDM profile's bed and tools go into the slicer 3MFs; --format "
                                               "voxels uses its voxel pitch (default j750: 600 x 300 dpi, 27 um layers)."),
    printers_file: Optional[Path] = typer.Option(None, "--printers", help="Extra printer profiles (TOML) for --printer."),
    force: bool = typer.Option(False, "--force", help=FORCE_HELP),
    mechanics: str = typer.Option(DEFAULT_MECHANICS.value, "--mechanics",
                                  help="rigid | bar-hinge: the fold xdmf/glb draw (bar-hinge adds each panel's "
                                       "strain per step to the xdmf series; docs/mechanics.md)"),
):
    """Build the printable part (one watertight body per material) and write multi-body
    3MF (spec + Bambu/Orca/Cura metadata and an OrcaSlicer project with one filament per
    material), a PrusaSlicer 3MF (one extruder per material), one STL per material, and a
    print recipe (<name>_recipe.md: tools, programming temperatures, expected fold order).

    Example: foldprint export helix_graded --format 3mf,stl --json
    """
    from ..apps.outputs import known_formats
    from ..apps.pipeline import EvalOptions, Evaluation

    try:
        state = parse(State, state, "--state").value
    except FoldprintError:
        raise FoldprintError(f"--state must be permanent or programmed, got {state!r}") from None
    fmts = [f.strip() for f in formats.split(",") if f.strip()]
    known = known_formats()
    bad = [f for f in fmts if f not in known]
    if bad or not fmts:
        raise FoldprintError(f"--format: unknown format(s) {bad or formats!r}; choose from {', '.join(known)}")
    out = check_out_dir(out)
    # the part's files fold nothing (xdmf and glb fold it nominally: a part of the kernels)
    d, lib = noted(load_input(design, materials_file, scale, crease_materials, scale_what="--scale"), folds=False)
    out_dir = out if out is not None else Path("output") / d.name
    published = _plan_out(out_dir, force, "export").publish
    profile = None if printer is None else load_printer(printer, printers_file)[1]
    ev = Evaluation(d, EvalOptions(state=state, formats=tuple(fmts), mechanics=parse(Mechanics, mechanics, "--mechanics")),
                    library=lib)
    records = with_progress(f"building {d.name} ({state})", lambda: ev.export(out_dir, printer=profile, force=force))
    for note in ev.build_notes:
        echo_note(f"note: {note}")
    if json_out:
        from ..apps.outputs import manifest_name

        echo_json({"design": d.name, "state": state, "out": str(out_dir), "files": records,
                   "manifest": str(out_dir / manifest_name()), "published": str(published)})
    else:
        slices = [r for r in records if r["format"] == "png"]
        for r in records:
            if r["format"] == "png":
                if r is slices[0]:
                    size = sum(s["bytes"] for s in slices)
                    echo(f"{r['path']} ... {Path(slices[-1]['path']).name}  (voxel slices: {len(slices)} PNG, "
                         f"{size / 1e6:.1f} MB)")
                continue
            if r["format"] == "recipe":
                echo(f"{r['path']}  (print recipe: tools, programming, fold order)")
                continue
            vol = sum(b["volume_mm3"] for b in r["bodies"])
            echo(f"{r['path']}  ({r['format']}, {len(r['bodies'])} bodies, {vol:.1f} mm3)")


@app.command(short_help=summary('gallery'))
def gallery(
    designs: Optional[List[str]] = typer.Argument(None, help="Designs or template names (default: every template)."),
    out: str = typer.Option(str(Path("output") / "gallery"), "--out", help="Output directory."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    jobs: Optional[int] = typer.Option(None, "--jobs", min=1, help="Worker processes (default: one per CPU)."),
    force: bool = typer.Option(False, "--force", help="Build every design again (a design whose design, materials "
                               "and foldprint did not change is otherwise kept from the gallery in --out). " + FORCE_HELP),
):
    """Simulate, check, render and export designs into an offline HTML gallery
    (index.html with an interactive 3D viewer per design, renders, fold animations, plots,
    and 3MF/STL links). Each design gets the same check as `foldprint check` (its jam test
    and seed): the summary gives its verdict and jam probability. Designs are built in
    parallel processes.

    Example: foldprint gallery --out output/gallery
    """
    note_kernels()
    from ..apps.gallery.runner import build_gallery

    out = check_out_dir(out)
    if jobs is not None:
        check_count(jobs, "--jobs", 1, MAX_WORKERS)
    lib = load_library(materials_file)
    names = list(designs) if designs else template_paths()
    if not names:
        raise FoldprintError("no designs given and no templates found")
    loaded = load_designs(names, lib)
    _plan_out(out, force, "gallery")
    if OUTPUT_STATE["quiet"]:
        index = build_gallery(loaded, out, library=lib, jobs=jobs, force=force, cache=not force)
    elif not sys.stderr.isatty():  # a log: one line per finished part
        index = build_gallery(loaded, out, library=lib, jobs=jobs, force=force, cache=not force,
                              progress=lambda done, total, msg: print(f"[{done}/{total}] {msg}", file=sys.stderr))
    else:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        with Progress(TextColumn("gallery"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      TextColumn("{task.description}"), transient=True, console=Console(stderr=True)) as bar:
            task = bar.add_task(f"building {len(loaded)} design(s): nominal folds, then the jam tests",
                                total=len(loaded) + 2)
            tests = bar.add_task("jam tests: starting", total=None)  # the Monte-Carlo, live
            index = build_gallery(loaded, out, library=lib, jobs=jobs, force=force, cache=not force,
                                  progress=lambda done, total, msg: bar.update(task, completed=done, total=total,
                                                                               description=msg),
                                  activity=lambda text: bar.update(tests, description=text))
    echo_note(f"gallery: {index}")  # written, or already current (every design kept, nothing written)
