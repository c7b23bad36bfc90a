"""``foldprint export`` and ``foldprint gallery``: the files of one printable part, and the
offline HTML gallery of many designs.
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from ..core.constants import EXPORT_FORMATS
from ..core.modes import DEFAULT_STATE, State, parse
from ..core.errors import FoldprintError
from .root import app
from .support import (MAX_WORKERS, CREASE_HELP, SCALE_HELP, OUTPUT_STATE, check_count, echo_json, load_input, echo_note, check_out_dir,
                      with_progress)


@app.command()
def export(
    design: str = typer.Argument(..., help="Design file (.toml, .fold) or template name."),
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
                                          help="Printer profile whose voxel pitch --format voxels uses "
                                               "(data/printers.toml; default j750: 600 x 300 dpi, 27 um layers)."),
):
    """Build the printable part (one watertight body per material) and write multi-body
    3MF (spec + Bambu/Orca/Cura metadata), a PrusaSlicer 3MF, and one STL per material.

    Example: foldprint export helix_graded --format 3mf,stl --json
    """
    from ..exchange.export import FORMATS
    from ..apps.pipeline import EvalOptions, Evaluation

    try:
        state = parse(State, state, "--state").value
    except FoldprintError:
        raise FoldprintError(f"--state must be permanent or programmed, got {state!r}") from None
    fmts = [f.strip() for f in formats.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FORMATS]
    if bad or not fmts:
        raise FoldprintError(f"--format: unknown format(s) {bad or formats!r}; choose from {', '.join(FORMATS)}")
    out = check_out_dir(out)
    d, lib = load_input(design, materials_file, scale, crease_materials)
    out_dir = out if out is not None else Path("output") / d.name
    if printer is not None and "voxels" not in fmts:
        raise FoldprintError("--printer sets the voxel pitch of --format voxels; add voxels to --format")
    records = with_progress(f"building {d.name} ({state})",
                             lambda: Evaluation(d, EvalOptions(state=state, formats=tuple(fmts)),
                                                library=lib).export(out_dir, printer=printer))
    if json_out:
        echo_json({"design": d.name, "state": state, "out": str(out_dir), "files": records})
    else:
        slices = [r for r in records if r["format"] == "png"]
        for r in records:
            if r["format"] == "png":
                if r is slices[0]:
                    size = sum(s["bytes"] for s in slices)
                    echo(f"{r['path']} ... {Path(slices[-1]['path']).name}  (voxel slices: {len(slices)} PNG, "
                         f"{size / 1e6:.1f} MB)")
                continue
            vol = sum(b["volume_mm3"] for b in r["bodies"])
            echo(f"{r['path']}  ({r['format']}, {len(r['bodies'])} bodies, {vol:.1f} mm3)")


@app.command()
def gallery(
    designs: Optional[List[str]] = typer.Argument(None, help="Designs or template names (default: every template)."),
    out: str = typer.Option(str(Path("output") / "gallery"), "--out", help="Output directory."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    jobs: Optional[int] = typer.Option(None, "--jobs", min=1, help="Worker processes (default: one per CPU)."),
):
    """Simulate, check, render and export designs into an offline HTML gallery
    (index.html with an interactive 3D viewer per design, renders, fold animations, plots,
    and 3MF/STL links). Each design gets the same check as `foldprint check` (its samples
    and seed): the summary gives its verdict and jam probability. Designs are built in
    parallel processes.

    Example: foldprint gallery --out output/gallery
    """
    from ..io.load import load_design
    from ..exchange.files import ensure_dir
    from ..model.materials import load_library
    from ..io.templates import list_templates, resolve_design_path

    out = check_out_dir(out)
    if jobs is not None:
        check_count(jobs, "--jobs", 1, MAX_WORKERS)
    lib = load_library(materials_file or None)
    names = list(designs) if designs else [t["path"] for t in list_templates()]
    if not names:
        raise FoldprintError("no designs given and no templates found")
    loaded = [load_design(resolve_design_path(n), lib) for n in names]
    made = not out.exists()
    ensure_dir(out)
    try:
        index = _gallery(loaded, out, lib, jobs)
    except BaseException:  # a refused or failed gallery leaves no folder it made (exit 2 writes nothing)
        if made:
            shutil.rmtree(out, ignore_errors=True)
        raise
    echo_note(f"wrote {index}")


def _gallery(loaded, out, lib, jobs):
    from ..apps.gallery import build_gallery

    if OUTPUT_STATE["quiet"]:
        index = build_gallery(loaded, out, library=lib, jobs=jobs)
    elif not sys.stderr.isatty():  # a log: one line per finished part
        index = build_gallery(loaded, out, library=lib, jobs=jobs,
                              progress=lambda done, total, msg: print(f"[{done}/{total}] {msg}", file=sys.stderr))
    else:
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        with Progress(TextColumn("gallery"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      TextColumn("{task.description}"), transient=True, console=Console(stderr=True)) as bar:
            task = bar.add_task(f"building {len(loaded)} design(s)", total=len(loaded) + 2)
            index = build_gallery(loaded, out, library=lib, jobs=jobs, progress=lambda done, total, msg: bar.update(
                task, completed=done, total=total, description=msg))
    return index
