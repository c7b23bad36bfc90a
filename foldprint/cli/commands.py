"""Command line: a thin layer over the library.

Exit codes: 0 ok, 1 the design fails (collision, goal, rule), 2 bad input or usage,
3 an internal error (a bug, with a short report), 130 interrupted.
Machine output (``--json``) goes to stdout; human messages to stderr.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import List, Optional, Tuple

import typer
from typer import echo

from .. import __version__
from ..core import guards
from ..core.constants import (ASSIGN_BUDGET, ASSIGN_SAMPLES, ASSIGN_TOP, CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED,
                              DEFAULT_DT_S, DEFAULT_SEED, DEFAULT_THICKNESS_MM, EXPORT_FORMATS, JAM_ERROR_ABOVE,
                              JAM_WARN_ABOVE, ROBUST_SAMPLES, SWEEP_SCALES)
from ..core.modes import DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_METHOD, DEFAULT_STATE
from ..core.errors import FoldprintError
from .support import (
    ExitCode, _CLICK_ERRORS, _CREASE, _SCALE, _STATE, _echo_json, _err, _expand_multi,
    _count, _fraction, _in_range, _internal, _load, _out_dir, _temperature, _time_options,
    MAX_BUDGET, MAX_SAMPLES, MAX_TOP, MAX_WORKERS, _mapper, _mode, _note, _number, _print_simulation, _printer,
    _samples_progress, _verdict, _with_progress)

app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                  help="foldprint: design, simulate, check and export sequentially self-folding "
                       "structures printed with digital shape-memory polymers.")




def _version(value: bool):
    if value:
        echo(f"foldprint {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(version: bool = typer.Option(False, "--version", is_eager=True, callback=_version,
                                       help="Print the version and exit."),
          quiet: bool = typer.Option(False, "--quiet", "-q", help="Only errors and machine output."),
          verbose: bool = typer.Option(False, "--verbose", "-v", help="Log what foldprint does (stderr).")):
    """foldprint: design, simulate, check and export self-folding structures."""
    import logging

    _STATE["quiet"], _STATE["verbose"] = quiet, verbose
    if verbose and not quiet:
        logging.basicConfig(level=logging.INFO, format="foldprint: %(name)s: %(message)s")


@app.command()
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

    lib = load_library(materials_file or None)
    temps_raw = list(temperature) if temperature else ["80", "90", "100"]
    temps = [(_t, _temperature(_number(_t, "--temperature"))) for _t in temps_raw]
    from ..core.schema import MAX_LENGTH_MM, MIN_LENGTH_MM

    _in_range(thickness, "--thickness", MIN_LENGTH_MM, MAX_LENGTH_MM, "mm")
    rows = []
    for m in lib:
        ft = {}
        for key, val in temps:
            if m.role == "hinge":
                v = fold_time(m, val, thickness)
                ft[key] = None if v is None else round(v, 3)
            else:
                ft[key] = None
        rows.append({"name": m.name, "role": m.role, "tg_c": m.tg_c, "color": m.color, "fold_time_s": ft})
    if plot is not None:
        from ..render.figures import fold_time_chart, save_figure

        save_figure(fold_time_chart(lib, [v for _, v in temps], thickness), plot)
        _note(f"wrote {plot}")
    if json_out:
        _echo_json({"materials": rows})
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"materials: fold time to 98 % (s), hinge {thickness:g} mm")
    table.add_column("material")
    table.add_column("role")
    table.add_column("Tg (°C)", justify="right")
    for key, _ in temps:
        table.add_column(f"{key} °C", justify="right")
    for r in rows:
        cells = ["-" if r["role"] != "hinge" else ("does not fold" if v is None else f"{v:.2f}")
                 for v in r["fold_time_s"].values()]
        table.add_row(r["name"], r["role"], f"{r['tg_c']:.1f}", *cells)
    Console(file=sys.stdout, width=120).print(table)


@app.command()
def templates(json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout.")):
    """List the shipped design templates.

    Example: foldprint templates --json
    """
    from ..io.templates import list_templates, templates_dir

    items = list_templates()
    if json_out:
        _echo_json({"templates": items})
        return
    if not items:
        echo(f"no templates found in {templates_dir()}", err=True)
        return
    width = max(len(t["name"]) for t in items)
    for t in items:
        echo(f"{t['name']:<{width}}  {t['description']}")


@app.command()
def simulate(
    design: str = typer.Argument(..., help="Design file (.toml, .fold) or template name."),
    temperature: Optional[float] = typer.Option(None, "--temperature", help="Bath temperature (deg C); default: the design's."),
    duration: Optional[float] = typer.Option(None, "--duration", help="Simulated time (s); default: the design's."),
    dt: float = typer.Option(DEFAULT_DT_S, "--dt", help="Time step of the trajectory (s)."),
    method: str = typer.Option(DEFAULT_METHOD.value, "--method", help="index2d | fcl | both"),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM, Eq. 2-4)"),
    after_contact: str = typer.Option(DEFAULT_AFTER_CONTACT.value, "--after-contact", help="stop | arrest"),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    plot: Optional[str] = typer.Option(None, "--plot", help="Directory for hinge-angle and collision-index plots."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    max_memory: Optional[str] = typer.Option(None, "--max-memory", help="Memory limit, e.g. 4G (default 2G)."),
    scale: Optional[float] = typer.Option(None, "--scale", help=_SCALE),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=_CREASE),
):
    """Fold the design in the bath: hinge angles, collisions, goals. Exit 0 when it
    completes, 1 when it collides, stalls or misses a goal. The printed geometry (arc
    hinges) is the default; the paper's point-hinge ROM is run beside it and reported
    when its verdict differs.

    Example: foldprint simulate helix_graded --json
    """
    from ..core.modes import AfterContact, HingeModel, Method
    from ..apps.pipeline import EvalOptions, Evaluation

    m, model, after = (_mode(Method, method, "--method"), _mode(HingeModel, hinge_model, "--hinge-model"),
                       _mode(AfterContact, after_contact, "--after-contact"))
    if temperature is not None:
        _temperature(temperature)
    _time_options(duration, dt)
    plot = _out_dir(plot, "--plot")
    guards.set_max_memory(max_memory)  # issue 14 resource guard
    d, lib = _load(design, materials_file, scale, crease_materials)
    if plot is not None:
        from ..exchange.files import ensure_dir
        ensure_dir(plot)
    ev = Evaluation(d, EvalOptions(hinge_model=model, method=m, after_contact=after, dt=dt, bath_c=temperature,
                                   duration=duration), library=lib)
    report = ev.simulation_json()  # with the printed crossings (issue 18) and the other hinge model's verdict
    res, crossing = ev.simulation, ev.printed_crossings
    if plot is not None:
        from ..render.figures import collision_index_figure, hinge_angle_figure, save_figure

        written = [save_figure(hinge_angle_figure(res), plot / f"{d.name}_hinge_angles.png")]
        if res.index2d is not None:
            written.append(save_figure(collision_index_figure(res), plot / f"{d.name}_collision_index.png"))
        for w in written:
            _note(f"wrote {w}")
    if json_out:
        _echo_json(report)
    else:
        _print_simulation(report)
    raise ExitCode(0 if res.completed and not crossing else 1)


@app.command()
def check(
    design: str = typer.Argument(..., help="Design file (.toml, .fold) or template name."),
    printer: Optional[str] = typer.Option(None, "--printer", help="Printer profile key (default: connex260)."),
    printers_file: Optional[Path] = typer.Option(None, "--printers", help="Extra printer profiles (TOML)."),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM)"),
    samples: int = typer.Option(CHECK_SAMPLES, "--samples", help="Monte-Carlo samples for the jam probability "
                                f"(0 skips it; {CHECK_SAMPLES}: the 95 % intervals at 5 % and 20 % do not overlap; run once per sigma scale of the sweep; the gallery runs the same)."),
    seed: int = typer.Option(CHECK_SEED, "--seed", help="Seed of the samples."),
    scatter_file: Optional[Path] = typer.Option(None, "--scatter", help="Scatter model TOML (default: shipped)."),
    error_above: float = typer.Option(JAM_ERROR_ABOVE, "--error-above", help="Fail when the 95 % interval's lower end "
                                      "of the jam probability is above this."),
    warn_above: float = typer.Option(JAM_WARN_ABOVE, "--warn-above", help="Warn when the jam probability is above this."),
    sensitivity: bool = typer.Option(True, "--sensitivity/--no-sensitivity",
                                     help="Also estimate it with the scatter spreads scaled by --scales and say "
                                     "(FP183) when the verdict flips in that range."),
    scales: str = typer.Option(",".join(f"{k:g}" for k in CHECK_SCALES), "--scales", help="Sigma scales of the sensitivity (comma-separated)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    max_memory: Optional[str] = typer.Option(None, "--max-memory", help="Memory limit, e.g. 4G (default 2G)."),
    scale: Optional[float] = typer.Option(None, "--scale", help=_SCALE),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=_CREASE),
):
    """Design-rule checks before printing, on the printed geometry: build volume, walls
    and gaps, hinge strain and size, temperatures, fold time, collisions and goals, and
    the jam probability under manufacturing scatter, also with the spreads at 0.5x and 2x
    (FP183 says when the verdict flips in that range). Exit 0 without errors, 1 with.

    Example: foldprint check helix_uniform --json
    """
    from ..checks.rules import Thresholds
    from ..core.modes import HingeModel
    from ..apps.pipeline import EvalOptions, Evaluation, check_scales
    from ..simulation.robust import load_scatter
    from ..simulation.sensitivity import parse_scales

    model = _mode(HingeModel, hinge_model, "--hinge-model")
    guards.set_max_memory(max_memory)  # resource guard (issue 14)
    _count(samples, "--samples", 0, MAX_SAMPLES)  # 0 skips the jam probability
    if seed < 0:
        raise FoldprintError(f"--seed must be >= 0, got {seed}")
    th = Thresholds(_fraction(error_above, "--error-above"), _fraction(warn_above, "--warn-above"))
    ks = parse_scales(scales) if sensitivity else ()
    key, pr = _printer(printer, printers_file)
    sc = load_scatter(scatter_file)
    d, lib = _load(design, materials_file, scale, crease_materials)
    opts = EvalOptions(hinge_model=model, samples=samples, seed=seed, scales=check_scales(ks), thresholds=th)
    with _samples_progress(f"{d.name}: scatter samples") as cb:
        ev = Evaluation(d, opts, library=lib, printer=pr, scatter=sc,
                        progress=(lambda _s, done, total: cb(done, total)) if cb else None)
        findings = ev.findings
    n_err = ev.errors
    if json_out:
        _echo_json(ev.to_json(key))
    else:
        for f in findings:
            where = ", ".join(f"{k} {v}" for k, v in f.where.items())
            echo(f"{f.severity.upper():<7} {f.code} {f.message}" + (f" [{where}]" if where else ""))
            if f.hint:
                echo(f"        hint: {f.hint}")
        _note(f"{d.name}: {n_err} error(s) on {pr.name} ({model.value} hinges)")
    raise ExitCode(1 if n_err else 0)


@app.command()
def robust(
    design: str = typer.Argument(..., help="Design file (.toml, .fold) or template name."),
    samples: int = typer.Option(ROBUST_SAMPLES, "--samples", help="Monte-Carlo samples (>= 1)."),
    seed: int = typer.Option(DEFAULT_SEED, "--seed", help="Seed: the same seed gives the same answer."),
    scatter_file: Optional[Path] = typer.Option(None, "--scatter", help="Scatter model TOML (default: shipped)."),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM)"),
    contributions: bool = typer.Option(False, "--contributions/--no-contributions",
                                       help="Also each scatter component alone and all but each (two more "
                                       "runs of the samples per component: about 11x the cost, so opt-in)."),
    sensitivity: bool = typer.Option(False, "--sensitivity", help="Also sweep every spread by --scales."),
    scales: str = typer.Option(",".join(f"{k:g}" for k in SWEEP_SCALES), "--scales", help="Sigma scales of --sensitivity (comma-separated)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", metavar="tcp://HOST:PORT",
                                            help="Run the samples on this Dask scheduler (default: local cores)."),
):
    """Jam probability under manufacturing and process scatter (foldprint/data/scatter.toml):
    shared by the part and run (bath temperature, the heat-transfer correlation's error)
    and per hinge (Tg, thickness, local heat transfer); N Monte-Carlo folds of the printed
    geometry on all cores, with each component's contribution and (--sensitivity) the
    curve over sigma scales. Exit 0; 2 on bad input.

    Example: foldprint robust helix_uniform --samples 60 --seed 1 --sensitivity --json
    """
    from ..core.modes import HingeModel
    from ..apps.pipeline import EvalOptions, Evaluation
    from ..simulation.robust import load_scatter
    from ..simulation.sensitivity import parse_scales

    model = _mode(HingeModel, hinge_model, "--hinge-model")
    _count(samples, "--samples", 1, MAX_SAMPLES)
    if seed < 0:
        raise FoldprintError(f"--seed must be >= 0, got {seed}")
    ks = parse_scales(scales)
    sc = load_scatter(scatter_file)
    d, lib = _load(design, materials_file)
    opts = EvalOptions(hinge_model=model, samples=samples, seed=seed, scales=ks if sensitivity else ())
    with _mapper(scheduler) as mapper:
        ev = Evaluation(d, opts, library=lib, scatter=sc, mapper=mapper)
        with _samples_progress(f"{d.name}: scatter samples") as cb:
            ev.run_robust(cb)
        if contributions:
            with _samples_progress(f"{d.name}: one component at a time") as cb:
                ev.run_contributions(cb)
        if sensitivity:
            with _samples_progress(f"{d.name}: sigma scales") as cb:
                ev.run_sweep(cb)
    out = ev.robust_json()
    if json_out:
        _echo_json(out)
        return
    lo, hi = out["ci95"]
    echo(f"{d.name}: jam probability {out['jam_probability']:.1%} (95 % interval {lo:.1%}-{hi:.1%}) "
         f"in {samples} samples, seed {seed} ({model.value} hinges)")
    for c in out["collisions"][:5]:
        echo(f"  {c['pair'][0]}-{c['pair'][1]} collide in {c['count']} samples")
    ft = out["fold_time_s"]
    if ft:
        echo(f"  fold time of the samples that completed: {ft['p5']:.2f} / {ft['p50']:.2f} / "
             f"{ft['p95']:.2f} s (5th / 50th / 95th percentile)")
    echo(f"  nominal: {_verdict(out['nominal'])}")

    def est(e):
        a, b = e["ci95"]
        return f"{e['jams']:>3}/{e['samples']} {e['jam_probability']:6.1%} ({a:.1%}-{b:.1%})"

    if out["contributions"] is not None:
        echo("  contribution of each scatter component (same draws; alone = the others at zero):")
        echo(f"    {'component':<42} {'spread':>9}  {'alone':<24} all but it")
        for c in out["contributions"]:
            name = f"{c['label']} [{c['scope']}]"
            echo(f"    {name:<42} {c['spread']:>6g} {c['unit']:<2}  {est(c['alone']):<24} {est(c['all_but'])}")
    if out["sensitivity"] is not None:
        echo("  sensitivity: every spread scaled by k (same draws):")
        for p in out["sensitivity"]:
            echo(f"    k = {p['scale']:<5g} jam {est(p)}")


@app.command()
def assign(
    design: str = typer.Argument(..., help="Design file (.toml, .fold) or template name."),
    materials: Optional[str] = typer.Option(None, "--materials", metavar="H-1,...,H-7",
                                            help="Hinge materials to choose from (default: every one)."),
    temperature: Optional[float] = typer.Option(None, "--temperature", help="Bath temperature (deg C); "
                                                "default: the design's."),
    temperature_range: Optional[Tuple[float, float]] = typer.Option(None, "--temperature-range", metavar="LO HI",
                                                                    help="Also choose the bath temperature "
                                                                    "(every 5 deg C from LO to HI)."),
    fixed: Optional[List[str]] = typer.Option(None, "--fixed", metavar="HINGE=MAT", help="Keep this hinge's material."),
    objective: str = typer.Option("time", "--objective", help="time (fastest fold) | margin (widest smallest "
                                  "clearance) | robust (lowest jam probability of the finalists)"),
    top: int = typer.Option(ASSIGN_TOP, "--top", help="How many assignments to report."),
    budget: int = typer.Option(ASSIGN_BUDGET, "--budget", help="Most simulations the search may run."),
    samples: int = typer.Option(ASSIGN_SAMPLES, "--samples", help="Monte-Carlo samples per finalist (--objective robust)."),
    seed: int = typer.Option(DEFAULT_SEED, "--seed", help="Seed of the samples."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", metavar="tcp://HOST:PORT",
                                            help="Run the evaluations on this Dask scheduler (default: local cores)."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local processes (default: all cores)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    write: Optional[Path] = typer.Option(None, "--write", help="Save the best assignment as a design file (TOML)."),
    continuous: bool = typer.Option(False, "--continuous", help="Choose every hinge's VeroWhite fraction (Tg) "
                                    "and the bath within --temperature-range for the lowest jam probability."),
):
    """Choose the hinge materials (and bath temperature) under which the printed part
    folds: every hinge to 98 %, no collision, every goal in order. A search over fold
    orders, not all m^n assignments (docs/assign.md). Exit 0 when something is feasible,
    1 when nothing is (naming what blocks), 2 on bad input or an unreachable scheduler.

    Example: foldprint assign helix_uniform --objective margin --top 3 --json
    """
    from ..apps.assign import assign as search, with_materials

    mats, temps, fixed_map = _assign_request(materials, temperature, temperature_range, fixed, objective, top,
                                             budget, samples, workers, seed)
    d, lib = _load(design)
    if continuous:  # per-hinge VeroWhite fractions and the bath (docs/assign.md, "Continuous fractions")
        from ..apps.assign_continuous import continuous_objective, search_options as search  # noqa: F811
        objective = continuous_objective(objective, mats, fixed_map)
    with _mapper(scheduler) as mapper, _samples_progress(f"{d.name}: evaluations") as cb:
        r = search(d, library=lib, materials=mats, temperatures=temps, fixed=fixed_map, objective=objective,
                   top=top, budget=budget, samples=samples, seed=seed, mapper=mapper, workers=workers,
                   progress=cb)
    out = r.to_json()
    if write is not None and r.best:
        from ..io.design_io import design_to_toml
        from ..exchange.files import write_atomic

        b = r.best[0]
        write_atomic(write, design_to_toml(with_materials(d, b.materials, b.bath_c, lib)))
        _note(f"wrote {write}")
    if json_out:
        _echo_json(out)
    else:
        _print_assign(d.name, r, out, objective)
    _assign_verdict(d.name, r, out, temperature_range is None)


def _assign_request(materials, temperature, temperature_range, fixed, objective, top, budget, samples, workers,
                    seed) -> tuple[list[str] | None, list[float] | None, dict[str, str]]:
    """``assign``'s options checked: the materials to choose from, the bath temperatures
    and the fixed hinges (FoldprintError naming the option)."""
    from ..apps.assign import OBJECTIVES, temperature_grid

    if objective not in OBJECTIVES:
        raise FoldprintError(f"--objective must be one of {', '.join(OBJECTIVES)}, got {objective!r}")
    if temperature is not None and temperature_range is not None:
        raise FoldprintError("give --temperature or --temperature-range, not both")
    if temperature is not None:
        _temperature(temperature)
    if temperature_range is not None:
        lo, hi = (_temperature(v, "--temperature-range") for v in temperature_range)
        if lo > hi:
            raise FoldprintError(f"--temperature-range needs LO <= HI, got {lo:g} {hi:g}")
    for name, v, hi in (("--top", top, MAX_TOP), ("--budget", budget, MAX_BUDGET), ("--samples", samples, MAX_SAMPLES),
                        ("--workers", workers or 1, MAX_WORKERS)):
        _count(v, name, 1, hi)
    if seed < 0:
        raise FoldprintError(f"--seed must be >= 0, got {seed}")
    fixed_map = {}
    for item in fixed or []:
        hid, sep, mat = item.partition("=")
        if not sep or not hid.strip() or not mat.strip():
            raise FoldprintError(f"--fixed {item!r}: expected HINGE=MATERIAL, e.g. h1=H-2")
        fixed_map[hid.strip()] = mat.strip()
    mats = [m.strip() for m in materials.split(",") if m.strip()] if materials is not None else None
    if mats is not None and not mats:
        raise FoldprintError("--materials: give at least one material, e.g. H-1,H-4,H-7")
    temps = None
    if temperature is not None:
        temps = [temperature]
    elif temperature_range is not None:
        temps = list(temperature_grid(*temperature_range))
    return mats, temps, fixed_map


def _print_assign(name: str, r, out: dict, objective: str) -> None:
    """``assign``'s human output: the best assignments and what blocks the others."""
    space = (f"{r.evaluated / r.search_space:.2e} of {r.search_space}" if math.isfinite(r.search_space)
             else "of a continuous space")
    echo(f"{name}: {r.feasible} feasible assignment(s) in {r.evaluated} evaluations ({space}), "
         f"objective {objective}")
    for k, c in enumerate(out["best"], 1):
        mats_s = ", ".join(f"{h}={m}" for h, m in c["assignment"].items())
        extra = "" if c["jam_probability"] is None else f", jam probability {c['jam_probability']:.1%}"
        clear = "-" if c["min_clearance_mm"] is None else f"{c['min_clearance_mm']:.2f} mm"
        echo(f"  {k}. {mats_s} at {c['temperature_c']:g} C: folds in {c['fold_time_s']:.2f} s, "
             f"smallest clearance {clear}{extra}")
    for b in out["blocking"][:5]:
        if r.permanent_blocked:  # found before any evaluation: no count to give
            echo(f"  blocking: {b['pair'][0]}-{b['pair'][1]} cross in the printed (permanent) state")
            continue
        what = f"{b['pair'][0]}-{b['pair'][1]} collide" if "pair" in b else f"goal {b['goal']} unmet"
        echo(f"  blocking: {what} in {b['count']} of {r.evaluated} evaluation(s)")


def _assign_verdict(name: str, r, out: dict, single_bath: bool) -> None:
    """The hint for a cooler bath, and exit 1 naming what blocks when nothing is feasible."""
    from ..checks.rules import Thresholds

    best_jam, warn = (r.best[0].jam_probability if r.best else None), Thresholds().warning
    if best_jam is not None and best_jam > warn and single_bath:
        _note(f"the best jam probability {best_jam:.0%} is above {warn:.0%}: a cooler bath "
              "spreads the materials' fold times, try --temperature-range 75 90 (docs/assign.md)")
    if r.best:
        return
    top_block = out["blocking"][0] if out["blocking"] else None
    if top_block is None:
        why = "no candidate completed within the budget (raise --budget)"
    elif "pair" in top_block:
        why = (f"panels {top_block['pair'][0]} and {top_block['pair'][1]} "
               + ("cross in the printed (permanent) state" if r.permanent_blocked else
                  f"collide first in {top_block['count']} of {r.evaluated} evaluations"))
    else:
        why = f"goal {top_block['goal']} is not met in order in {top_block['count']} evaluations"
    _err(f"{name}: no feasible assignment: {why}")
    raise ExitCode(1)


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
    scale: Optional[float] = typer.Option(None, "--scale", help=_SCALE),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=_CREASE),
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

    if state not in ("permanent", "programmed"):
        raise FoldprintError(f"--state must be permanent or programmed, got {state!r}")
    fmts = [f.strip() for f in formats.split(",") if f.strip()]
    bad = [f for f in fmts if f not in FORMATS]
    if bad or not fmts:
        raise FoldprintError(f"--format: unknown format(s) {bad or formats!r}; choose from {', '.join(FORMATS)}")
    out = _out_dir(out)
    d, lib = _load(design, materials_file, scale, crease_materials)
    out_dir = out if out is not None else Path("output") / d.name
    if printer is not None and "voxels" not in fmts:
        raise FoldprintError("--printer sets the voxel pitch of --format voxels; add voxels to --format")
    records = _with_progress(f"building {d.name} ({state})",
                             lambda: Evaluation(d, EvalOptions(state=state, formats=tuple(fmts)),
                                                library=lib).export(out_dir, printer=printer))
    if json_out:
        _echo_json({"design": d.name, "state": state, "out": str(out_dir), "files": records})
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
    from ..apps.gallery import build_gallery
    from ..model.materials import load_library
    from ..io.templates import list_templates, resolve_design_path

    out = _out_dir(out)
    if jobs is not None:
        _count(jobs, "--jobs", 1, MAX_WORKERS)
    lib = load_library(materials_file or None)
    names = list(designs) if designs else [t["path"] for t in list_templates()]
    if not names:
        raise FoldprintError("no designs given and no templates found")
    loaded = [load_design(resolve_design_path(n), lib) for n in names]
    ensure_dir(out)
    if _STATE["quiet"]:
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
    _note(f"wrote {index}")


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (also used by the tests, in-process)."""
    args = _expand_multi(list(sys.argv[1:] if argv is None else argv))
    try:
        rv = app(args=args, prog_name="foldprint", standalone_mode=False)
        return int(rv or 0)
    except ExitCode as e:
        return e.code
    except typer.Exit as e:
        return int(getattr(e, "exit_code", 0))
    except typer.Abort:
        _err("aborted")
        return 130
    except _CLICK_ERRORS as e:
        _err(e.format_message())
        return 2
    except FoldprintError as e:
        _err(str(e))
        return 2
    except KeyboardInterrupt:
        _err("interrupted")
        return 130
    except Exception as e:  # noqa: BLE001 -- a bug: exit 3 with a short report, never 1
        return _internal(e, args)


def run() -> None:  # console script
    sys.exit(main())
