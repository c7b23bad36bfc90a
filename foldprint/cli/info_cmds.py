"""``foldprint materials`` and ``foldprint templates``: what the material library and the
shipped templates hold.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from ..core.constants import DEFAULT_THICKNESS_MM, JSON_DECIMALS
from ..core.display import seconds
from .lazy import summary
from .root import app
from .support import check_out_file, echo_json, check_in_range, echo_note, check_number, check_temperature, print_paper


@app.command(short_help=summary('materials'))
def materials(
    temperature: Optional[List[str]] = typer.Option(None, "--temperature", "-t", metavar="C ...",
                                                    help="Bath temperature(s) in deg C (default 80 90 100)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write a Fig. 1b-style chart (PNG/SVG/PDF)."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    thickness: float = typer.Option(DEFAULT_THICKNESS_MM, "--thickness", help="Hinge thickness in mm."),
):
    """Each material's Tg and its hinge fold time (98 % recovery) at each bath temperature.

    Example: foldprint materials --temperature 80 90 100 --json
    """
    from ..model.materials import load_library
    from ..physics.recovery import fold_time
    from ..simulation.paper_timings import fig1b_lines

    plot = check_out_file(plot, "--plot")
    lib = load_library(materials_file or None)
    temps_raw = list(temperature) if temperature else ["80", "90", "100"]
    temps = [(_t, check_temperature(check_number(_t, "--temperature"))) for _t in temps_raw]
    from ..core.schema import MAX_LENGTH_MM, MIN_LENGTH_MM

    check_in_range(thickness, "--thickness", MIN_LENGTH_MM, MAX_LENGTH_MM, "mm")
    rows = []
    for m in lib:
        ft = {}
        for key, val in temps:
            if m.role == "hinge":
                v = fold_time(m, val, thickness)
                ft[key] = None if v is None else round(v, JSON_DECIMALS)
            else:
                ft[key] = None
        rows.append({"name": m.name, "role": m.role, "tg_c": m.tg_c, "color": m.color, "fold_time_s": ft,
                     "fixity": m.shape_fixity if m.role == "hinge" else None,
                     "fixity_source": (m.fixity_source or "measured") if m.fixity is not None else
                     ("default: E_g / (E_g + E_r), docs/calibrate.md" if m.role == "hinge" else None)})
    if plot is not None:
        from ..render.figures import fold_time_chart, save_figure

        save_figure(fold_time_chart(lib, [v for _, v in temps], thickness), plot)
        echo_note(f"wrote {plot}")
    # Fig. 1b's statements (free hinges at the paper's 0.8 mm) beside the model's values
    paper = [] if thickness != DEFAULT_THICKNESS_MM else [ln.to_json() for ln in fig1b_lines(lib)]
    if json_out:
        echo_json({"materials": rows, "paper": paper})
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"materials: fold time to 98 %, hinge {thickness:g} mm")
    table.add_column("material")
    table.add_column("role")
    table.add_column("Tg (°C)", justify="right")
    table.add_column("fixity", justify="right")
    for key, _ in temps:
        table.add_column(f"{key} °C", justify="right")
    for r in rows:
        cells = ["-" if r["role"] != "hinge" else ("does not fold" if v is None else seconds(v))
                 for v in r["fold_time_s"].values()]
        fx = "-" if r["fixity"] is None else f"{r['fixity']:.4g}"
        table.add_row(r["name"], r["role"], f"{r['tg_c']:.1f}", fx, *cells)
    Console(file=sys.stdout, width=120).print(table)
    print_paper(paper)


@app.command(short_help=summary('templates'))
def templates(json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout.")):
    """List the shipped design templates.

    Example: foldprint templates --json
    """
    from ..io.templates import list_templates, templates_dir

    items = list_templates()
    if json_out:
        echo_json({"templates": items})
        return
    if not items:
        echo(f"no templates found in {templates_dir()}", err=True)
        return
    width = max(len(t["name"]) for t in items)
    for t in items:
        echo(f"{t['name']:<{width}}  {t['description']}")
