"""``foldprint calibrate``: fit the hinge recovery model to a lab's measurements and write
a materials file every command accepts with ``--materials`` (``docs/calibrate.md``)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from .lazy import summary
from .root import app
from .printing import echo_json, echo_note
from .progress import with_progress


def _print_dma(d: dict, conf: str) -> None:
    from rich.console import Console
    from rich.table import Table

    f = d["fit"]
    peak = "no 1 Hz row" if d["data_tan_delta_peak_c"] is None else f"{d['data_tan_delta_peak_c']:g} C"
    echo(f"  DMA of {d['material']}: {d['rows']} rows; chi2 {f['chi2']:.3g} for {f['dof']} degrees of freedom")
    echo(f"    Tg {d['tg_c']:.2f} C: the model's 1 Hz tan-delta peak ({d['model_tan_delta_peak_c']:.2f} C on the model) "
         f"and its shift's reference temperature; the data's largest 1 Hz tan delta: {peak}")
    echo(f"    glassy {d['glassy_mpa']:.4g} MPa, rubbery {d['rubbery_mpa']:.4g} MPa, log10_tau_ref_s "
         f"{d['log10_tau_ref_s']:.4g} (the centre that puts the peak at Tg)")
    table = Table(title=f"{d['material']}: viscoelastic model fitted to DMA")
    for col in ("parameter", "value", conf, "identified", "bounds"):
        table.add_column(col)
    for p in d["parameters"]:
        iv = "-" if p["low"] is None else f"{p['low']:.4g} .. {p['high']:.4g}"
        table.add_row(p["name"], f"{p['value']:.4g} {p['unit']}".strip(), iv, p["identified"] or "-",
                      f"{p['bounds'][0]:g} .. {p['bounds'][1]:g} ({p['bound_kind']})")
    Console(file=sys.stdout, width=130).print(table)
    for k, v in d["held"].items():
        echo(f"    held: {k} = {v:g}")
    for c in d["curves"]:
        freq = f" {c['frequency_hz']:g} Hz" if c["frequency_hz"] else ""
        echo(f"    {c['kind']}{freq}: RMS {c['rms_log']:.3g} in ln ({c['rms_sigma']:.2f} sigma, {c['rows']} rows)")


def _print(out: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    f = out["fit"]
    conf = f"{out['confidence']:.0%} interval" if out["uncertainty"] == "profile" else "interval (--no-profile)"
    echo(f"{out['data']}: {len(out['rows'])} recovery rows, {sum(d['rows'] for d in out['dma'])} DMA rows, "
         f"materials {', '.join(out['materials'])}")
    for d in out["dma"]:
        _print_dma(d, conf)
    if f is None:
        for fd in out["findings"]:
            echo(f"  note: {fd['message']}")
        return
    echo(f"  least squares: chi2 {f['chi2']:.3g} for {f['dof']} degrees of freedom; the data fix {f['rank']} of "
         f"{len(out['parameters'])} parameter combinations; the starting library: chi2 {out['start']['chi2']:.3g}"
         + (" (inside the joint confidence region)" if out["start"]["inside_joint_region"] else
            " (outside the joint confidence region)"))
    if len(f["start_ends"]) > 1:
        echo(f"  best of {len(f['start_ends'])} starts; chi2 where each ended: "
             + ", ".join(f"{c:.4g}" for c in f["start_ends"]) + " (the first from the starting library)")
    table = Table(title="fitted recovery parameters")
    for col in ("parameter", "value", conf, "identified", "bounds"):
        table.add_column(col)
    for p in out["parameters"]:
        label = p["name"] + (f"[{p['material']}]" if p["material"] else "")
        iv = "-" if p["low"] is None else f"{p['low']:.4g} .. {p['high']:.4g}"
        mark = f" (at {p['at_bound']} bound)" if p["at_bound"] else ""
        ident = (p["identified"] or "-") + (" (0 dof)" if f["dof"] <= 0 and p["identified"] else "")
        table.add_row(label, f"{p['value']:.4g} {p['unit']}".strip() + mark, iv, ident,
                      f"{p['bounds'][0]:g} .. {p['bounds'][1]:g} ({p['bound_kind']})")
    Console(file=sys.stdout, width=130).print(table)
    if out["held"]:
        echo("  held, not fitted (--fit NAME fits one):")
        for h in out["held"]:
            echo(f"    {h['name']} = {h['value']:g}: {h['source']}")
    echo("  per curve (RMS residual; in sigmas):")
    for c in out["curves"]:
        ref = f" - {c['reference']}" if c["reference"] else ""
        lvl = f" to {c['level']:.0%}" if c["level"] is not None else ""
        echo(f"    {c['kind']} {c['material']}{ref} {c['bath_c']:g} C {c['thickness_mm']:g} mm{lvl}: "
             f"{c['rms']:.3g} {c['unit']} ({c['rms_sigma']:.2f} sigma, {c['rows']} rows)")
    timed = [r for r in out["rows"] if r["verdict"] is not None]
    if timed:
        echo("  time rows, read as the paper's words are (docs/structure-timings.md):")
        for r in timed:
            what = f"{r['kind']} {r['material']}" + (f" - {r['reference']}" if r["reference"] else "")
            echo(f"    line {r['line']}: {what} at {r['bath_c']:g} C: {r['reading']}; model {r['model']:.2f} s: "
                 f"{r['verdict']}")
    for fd in out["findings"]:
        echo(f"  note: {fd['message']}")


@app.command(short_help=summary('calibrate'))
def calibrate(
    data: Path = typer.Argument(..., help="CSV of hinge measurements (layout: docs/calibrate.md)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Write the fitted materials TOML here."),
    plot: Optional[Path] = typer.Option(None, "--plot", help="Write the data-against-model figure (PNG/SVG/PDF)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials",
                                                        help="Extra material TOML file(s): the library the fit "
                                                             "starts from."),
    fix: Optional[List[str]] = typer.Option(None, "--fix", metavar="NAME[=VALUE]",
                                            help="Hold a recovery parameter (at the library's value or VALUE)."),
    fit: Optional[List[str]] = typer.Option(None, "--fit", metavar="NAME",
                                            help="Fit a parameter data/calibration.toml holds by default (c1, c2, "
                                                 "spectrum_span_decades)."),
    per_material: Optional[List[str]] = typer.Option(None, "--per-material", metavar="NAME",
                                                     help="Fit this parameter once per material (default: shared)."),
    no_profile: bool = typer.Option(False, "--no-profile",
                                    help="Skip the profile-likelihood intervals (the point and residuals only)."),
):
    """Fit the recovery model to hinge measurements; write a materials file for --materials.

    Example: foldprint calibrate foldprint/data/paper_hinge_data.csv --out mine.toml --plot fit.png
    """
    from ..apps import calibrate as cal
    from ..apps.calibrate_library import change_lines
    from ..apps.resolve import load_library

    cal.check_outputs(out, plot)
    lib = load_library(materials_file)
    fixed, fit_names = cal.parse_fixed(fix), cal.parse_fit(fit)
    result = with_progress("fitting the recovery model",
                           lambda: cal.run(data, lib, fixed, per_material or (), not no_profile, fit_names))
    if out is not None:
        command = " ".join(["foldprint calibrate", str(data), "--out", str(out)]
                           + [f"--fix {x}" for x in fix or ()] + [f"--fit {x}" for x in fit_names]
                           + [f"--per-material {x}" for x in per_material or ()]
                           + [f"--materials {x}" for x in materials_file or ()])
        cal.write(result, out, data, command)
        echo_note(f"wrote {out}: the library's materials unchanged, except:")
        for line in change_lines(cal.changes(result)):
            echo_note("  " + line)
    if plot is not None:
        cal.plot(result, plot)
        echo_note(f"wrote {plot}")
    payload = cal.to_json(result)
    payload["out"] = None if out is None else str(out)
    payload["plot"] = None if plot is None else str(plot)
    if json_out:
        echo_json(payload)
    else:
        _print(payload)
