"""``foldprint materials`` and ``foldprint templates``: what the material library and the
shipped templates hold.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from ..apps.resolve import check_number, check_temperature, check_thickness, load_library
from ..core.constants import DEFAULT_THICKNESS_MM
from ..core.display import seconds
from .lazy import summary
from .options import check_out_file
from .printing import echo_json, echo_note, print_paper
from .root import app


@app.command(short_help=summary('materials'))
def materials(
    temperature: Optional[List[str]] = typer.Option(None, "--temperature", "-t", metavar="C ...",
                                                    help="Bath temperature(s) in deg C (default 80 90 100)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write a Fig. 1b-style chart (PNG/SVG/PDF)."),
    plot_model: Optional[Path] = typer.Option(
        None, "--plot-model", help="Write each hinge material's model: E'(T) and tan delta(T) at 1 Hz, R(t) in the "
                                   "first --temperature bath (PNG/SVG/PDF)."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    thickness: float = typer.Option(DEFAULT_THICKNESS_MM, "--thickness", help="Hinge thickness in mm."),
):
    """Each material's Tg, its viscoelastic model (moduli, the temperature of the model's tan
    delta peak at 1 Hz) and its hinge fold time (98 % recovery) at each bath temperature.

    Example: foldprint materials --temperature 80 90 100 --plot-model model.png
    """
    from ..apps.catalog import fig1b_paper_lines, fold_time_chart, material_rows, model_chart, tg_note

    plot = check_out_file(plot, "--plot")
    plot_model = check_out_file(plot_model, "--plot-model")
    lib = load_library(materials_file)
    temps_raw = list(temperature) if temperature else ["80", "90", "100"]
    temps = [(_t, check_temperature(check_number(_t, "--temperature"), "--temperature")) for _t in temps_raw]
    check_thickness(thickness, "--thickness")
    rows = material_rows(lib, temps, thickness)
    if plot is not None:
        fold_time_chart(lib, [v for _, v in temps], thickness, plot)
        echo_note(f"wrote {plot}")
    if plot_model is not None:
        model_chart(lib, temps[0][1], thickness, plot_model)
        echo_note(f"wrote {plot_model}")
    note = tg_note(rows)
    # Fig. 1b's statements (free hinges at the paper's 0.8 mm) beside the model's values
    paper = fig1b_paper_lines(lib, thickness)
    if json_out:
        echo_json({"materials": rows, "paper": paper, "notes": [note] if note else []})
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"materials: fold time to 98 %, hinge {thickness:g} mm")
    table.add_column("material")
    table.add_column("role")
    table.add_column("Tg (°C)", justify="right")
    table.add_column("model tan δ peak 1 Hz (°C)", justify="right")
    table.add_column("E_g / E_r (MPa)", justify="right")
    table.add_column("fixity", justify="right")
    for key, _ in temps:
        table.add_column(f"{key} °C", justify="right")
    for r in rows:
        cells = ["-" if r["role"] != "hinge" else ("does not fold" if v is None else seconds(v))
                 for v in r["fold_time_s"].values()]
        fx = "-" if r["fixity"] is None else f"{r['fixity']:.4g}"
        peak = "-" if r["tan_delta_peak_c"] is None else f"{r['tan_delta_peak_c']:.1f}"
        mod = "-" if r["glassy_mpa"] is None else f"{r['glassy_mpa']:g} / {r['rubbery_mpa']:g}"
        table.add_row(r["name"], r["role"], f"{r['tg_c']:.1f}", peak, mod, fx, *cells)
    Console(file=sys.stdout, width=140).print(table)
    if note:
        echo_note(note)
    print_paper(paper)


@app.command(short_help=summary('templates'))
def templates(json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout.")):
    """List the shipped design templates.

    Example: foldprint templates --json
    """
    from ..apps.catalog import templates as list_templates, templates_dir

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
