"""``foldprint simulate``, ``check`` and ``robust``: one design folded, judged, and folded
again under scatter, each through :class:`~foldprint.apps.pipeline.Evaluation`.
"""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer
from typer import echo

from ..apps.resolve import (MAX_SAMPLES, check_count, check_seed, check_temperature, load_input, load_printer,
                            load_scatter, parse_mode, set_memory_limit, sigma_scales, thresholds, time_options)
from ..core.constants import (CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED, DEFAULT_DT_S, DEFAULT_SEED, JAM_ERROR_ABOVE,
                              JAM_WARN_ABOVE, ROBUST_SAMPLES, SWEEP_SCALES)
from ..core.modes import DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, DEFAULT_METHOD
from .exits import ExitCode
from .lazy import summary
from .options import CREASE_HELP, SCALE_HELP, check_out_dir, open_mapper
from .printing import echo_json, echo_note, noted, print_paper, print_simulation, verdict_word
from .progress import samples_progress, stage_progress
from .root import app


MECHANICS_HELP = ("rigid (default: rigid panels, exact and fast) | bar-hinge (panels stretch and bend, creases are "
                  "springs of their material's modulus at its temperature: docs/mechanics.md; slow: every "
                  "Monte-Carlo sample solves the equilibrium path)")


@app.command(short_help=summary('simulate'))
def simulate(
    design: str = typer.Argument(..., help="Design file (.toml, .fold, .svg) or template name."),
    temperature: Optional[float] = typer.Option(None, "--temperature", help="Bath temperature (deg C); default: the design's."),
    duration: Optional[float] = typer.Option(None, "--duration", help="Simulated time (s); default: the design's."),
    dt: float = typer.Option(DEFAULT_DT_S, "--dt", help="Time step of the trajectory (s)."),
    method: str = typer.Option(DEFAULT_METHOD.value, "--method", help="index2d | fcl | both"),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM, Eq. 2-4)"),
    after_contact: str = typer.Option(DEFAULT_AFTER_CONTACT.value, "--after-contact", help="stop | arrest"),
    mechanics: str = typer.Option(DEFAULT_MECHANICS.value, "--mechanics",
                                  help=MECHANICS_HELP),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    plot: Optional[str] = typer.Option(None, "--plot", help="Directory for hinge-angle and collision-index plots."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    max_memory: Optional[str] = typer.Option(None, "--max-memory", help="Memory limit, e.g. 4G (default 2G)."),
    scale: Optional[float] = typer.Option(None, "--scale", help=SCALE_HELP),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=CREASE_HELP),
):
    """Fold the design in the bath: hinge angles, collisions, goals, the smallest
    clearance along the fold and whether scatter closes it (a few scattered folds;
    `check` gives the jam probability), and for the paper's structures the paper's
    statements beside the model's values. Exit 0 when it completes, 1 when it collides,
    stalls, misses a goal or cannot be printed. The printed geometry (arc hinges) is the
    default; the paper's point-hinge ROM is run beside it and reported when its verdict
    differs.

    Example: foldprint simulate helix_graded --json
    """
    from ..core.modes import AfterContact, HingeModel, Mechanics, Method
    from ..apps.pipeline import EvalOptions, Evaluation

    m, model, after = (parse_mode(Method, method, "--method"), parse_mode(HingeModel, hinge_model, "--hinge-model"),
                       parse_mode(AfterContact, after_contact, "--after-contact"))
    mech = parse_mode(Mechanics, mechanics, "--mechanics")
    if temperature is not None:
        check_temperature(temperature, "--temperature")
    time_options(duration, dt, "--duration", "--dt")
    plot = check_out_dir(plot, "--plot")
    set_memory_limit(max_memory)  # the resource guard
    d, lib = noted(load_input(design, materials_file, scale, crease_materials, scale_what="--scale"))
    if plot is not None:
        from ..core.files import ensure_dir
        ensure_dir(plot)
    ev = Evaluation(d, EvalOptions(hinge_model=model, method=m, after_contact=after, dt=dt, bath_c=temperature,
                                   duration=duration, mechanics=mech), library=lib)
    if not json_out and plot is None and (early := ev.printed_crossings):
        # a part that cannot be printed: its verdict and line need no fold (the JSON and plots still fold it)
        print_simulation({"design": ev.design.name, "printed_crossings": early})
        raise ExitCode(1)
    report = ev.simulation_json()  # with the printed crossings and the other hinge model's verdict
    res, crossing = ev.simulation, ev.printed_crossings
    if plot is not None:
        from ..apps.outputs import simulation_plots

        for w in simulation_plots(res, plot, d.name):
            echo_note(f"wrote {w}")
    if json_out:
        echo_json(report)
    else:
        print_simulation(report)
    raise ExitCode(0 if res.completed and not crossing else 1)


@app.command(short_help=summary('check'))
def check(
    design: str = typer.Argument(..., help="Design file (.toml, .fold, .svg) or template name."),
    printer: Optional[str] = typer.Option(None, "--printer", help="Printer profile key (default: connex260)."),
    printers_file: Optional[Path] = typer.Option(None, "--printers", help="Extra printer profiles (TOML)."),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM)"),
    mechanics: str = typer.Option(DEFAULT_MECHANICS.value, "--mechanics",
                                  help=MECHANICS_HELP),
    samples: int = typer.Option(CHECK_SAMPLES, "--samples", help="The MOST Monte-Carlo samples of the jam test "
                                "(per sigma scale; 0 skips it). The test is sequential: it stops as soon as the "
                                "verdict is known at 5 % error rates (clear designs in 6-60 samples, marginal ones "
                                "up to this maximum); the gallery runs the same."),
    seed: int = typer.Option(CHECK_SEED, "--seed", help="Seed of the samples."),
    scatter_file: Optional[Path] = typer.Option(None, "--scatter", help="Scatter model TOML (default: shipped)."),
    error_above: float = typer.Option(JAM_ERROR_ABOVE, "--error-above", help="Fail when the jam test finds the jam "
                                      "probability above this (tested between it -/+ 0.05)."),
    warn_above: float = typer.Option(JAM_WARN_ABOVE, "--warn-above", help="Warn when the jam test finds the jam "
                                     "probability above this (tested between half and 1.5x it)."),
    sensitivity: bool = typer.Option(True, "--sensitivity/--no-sensitivity",
                                     help="Also run the jam test with the scatter spreads scaled by --scales (the "
                                     "same draws) and say (FP183) when the verdict flips in that range."),
    scales: str = typer.Option(",".join(f"{k:g}" for k in CHECK_SCALES), "--scales", help="Sigma scales of the sensitivity (comma-separated)."),
    json_out: bool = typer.Option(False, "--json", help="Print one JSON object to stdout."),
    materials_file: Optional[List[Path]] = typer.Option(None, "--materials", help="Extra material TOML file(s)."),
    max_memory: Optional[str] = typer.Option(None, "--max-memory", help="Memory limit, e.g. 4G (default 2G)."),
    scale: Optional[float] = typer.Option(None, "--scale", help=SCALE_HELP),
    crease_materials: Optional[str] = typer.Option(None, "--crease-materials", help=CREASE_HELP),
):
    """Design-rule checks before printing, on the printed geometry: build volume, the
    printer's materials, walls and gaps, hinge strain and size, temperatures, fold time,
    collisions and goals, and the jam verdict under manufacturing scatter: a sequential test that folds samples
    until it knows whether the jam probability is below 5 % (pass), above 20 % (fail) or
    between (warning), with 5 % error rates; the same test with the spreads at 0.5x and 2x
    (FP183 says when the verdict flips in that range). For the paper's structures, the
    paper's statements beside the model's values. Exit 0 without errors, 1 with.

    Example: foldprint check helix_uniform --json
    """
    from ..core.modes import HingeModel, Mechanics
    from ..apps.pipeline import EvalOptions, Evaluation, check_scales

    model = parse_mode(HingeModel, hinge_model, "--hinge-model")
    mech = parse_mode(Mechanics, mechanics, "--mechanics")
    set_memory_limit(max_memory)  # the resource guard
    check_count(samples, "--samples", 0, MAX_SAMPLES)  # 0 skips the jam probability
    check_seed(seed, "--seed")
    th = thresholds(error_above, warn_above, error_what="--error-above", warn_what="--warn-above")
    ks = sigma_scales(scales, "--scales") if sensitivity else ()
    key, pr = load_printer(printer, printers_file)
    sc = load_scatter(scatter_file)
    d, lib = noted(load_input(design, materials_file, scale, crease_materials, scale_what="--scale"))
    opts = EvalOptions(hinge_model=model, samples=samples, seed=seed, scales=check_scales(ks), thresholds=th,
                       mechanics=mech)
    with stage_progress(f"check {d.name}", json_out) as cb:
        ev = Evaluation(d, opts, library=lib, printer=pr, scatter=sc, progress=cb)
        findings = ev.findings
    n_err = ev.errors
    if json_out:
        echo_json(ev.to_json(key))
    else:
        for line in ev.finding_lines():
            echo(line)
        print_paper([line.to_json() for line in ev.paper_lines()])
        echo_note(f"{d.name}: {n_err} error(s) on {pr.name} ({model.value} hinges); materials: the shipped library"
                  + "".join(f" + {f}" for f in materials_file or ()))
    raise ExitCode(1 if n_err else 0)


@app.command(short_help=summary('robust'))
def robust(
    design: str = typer.Argument(..., help="Design file (.toml, .fold, .svg) or template name."),
    samples: int = typer.Option(ROBUST_SAMPLES, "--samples", help="Monte-Carlo samples (>= 1)."),
    seed: int = typer.Option(DEFAULT_SEED, "--seed", help="Seed: the same seed gives the same answer."),
    scatter_file: Optional[Path] = typer.Option(None, "--scatter", help="Scatter model TOML (default: shipped)."),
    hinge_model: str = typer.Option(DEFAULT_HINGE_MODEL.value, "--hinge-model",
                                    help="arc (default: the printed hinges) | point (the paper's ROM)"),
    mechanics: str = typer.Option(DEFAULT_MECHANICS.value, "--mechanics", help=MECHANICS_HELP),
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
    and per hinge (Tg, thickness, local heat transfer); exactly N Monte-Carlo folds of the
    printed geometry on all cores or --scheduler (an estimate with a Wilson interval);
    on request (both off by default) each scatter component's contribution
    (--contributions, about 11x the cost) and the curve over sigma scales
    (--sensitivity). `check` draws the same stream at its seed (0) but stops when its
    sequential test decides, so its figure is that of the first n samples: the output
    says what check's test makes of these samples. Exit 0; 2 on bad input.

    Example: foldprint robust helix_uniform --samples 60 --seed 1 --sensitivity --json
    """
    from ..core.modes import HingeModel, Mechanics, SampleRule
    from ..apps.pipeline import EvalOptions, Evaluation

    model = parse_mode(HingeModel, hinge_model, "--hinge-model")
    mech = parse_mode(Mechanics, mechanics, "--mechanics")
    check_count(samples, "--samples", 1, MAX_SAMPLES)
    check_seed(seed, "--seed")
    ks = sigma_scales(scales, "--scales")
    sc = load_scatter(scatter_file)
    d, lib = noted(load_input(design, materials_file))
    opts = EvalOptions(hinge_model=model, samples=samples, sample_rule=SampleRule.FIXED, seed=seed,
                       scales=ks if sensitivity else (), mechanics=mech)
    with open_mapper(scheduler) as mapper:
        ev = Evaluation(d, opts, library=lib, scatter=sc, mapper=mapper)
        with samples_progress(f"{d.name}: scatter samples", json_out) as cb:
            ev.run_robust(cb)
        if contributions:
            with samples_progress(f"{d.name}: one component at a time", json_out) as cb:
                ev.run_contributions(cb)
        if sensitivity:
            with samples_progress(f"{d.name}: sigma scales", json_out) as cb:
                ev.run_sweep(cb)
    out = ev.robust_json(CHECK_SEED)  # with how it relates to check's figure on check's seed
    if json_out:
        echo_json(out)
        return
    _print_robust(out, ev.robust, seed, model.value)


def _print_robust(out: dict, r, seed: int, model: str) -> None:
    """``robust``'s text output: the estimate, its pairs and fold times, check's relation,
    the contributions and the sweep."""
    from ..core.display import clipped, jam_estimate_text, percent, seconds

    echo(f"{r.design}: jam probability {jam_estimate_text(r)}, seed {seed} ({model} hinges)")
    for line in clipped([f"  {c['pair'][0]}-{c['pair'][1]} collide in {c['count']} samples" for c in out["collisions"]],
                        5, "pairs collide (--json lists every one)"):
        echo(line)
    ft = out["fold_time_s"]
    if ft:
        echo(f"  fold time of the samples that completed: {seconds(ft['p5'])} / {seconds(ft['p50'])} / "
             f"{seconds(ft['p95'])} (5th / 50th / 95th percentile)")
    echo(f"  nominal: {verdict_word(out['nominal'])}")
    echo(f"  check: {out['check']['text']}")

    def est(e):
        a, b = e["ci95"]
        return f"{e['jams']:>3}/{e['samples']} {percent(e['jam_probability']):>7} ({percent(a)}-{percent(b)})"

    if out["contributions"] is not None:
        echo("  contribution of each scatter component (same draws; alone = the others at zero):")
        echo(f"    {'component [scope, basis]':<54} {'spread':>9}  {'alone':<31} all but it")
        for c in out["contributions"]:
            name = f"{c['label']} [{c['scope']}, {c['basis'] or 'basis not stated'}]"
            echo(f"    {name:<54} {c['spread']:>6g} {c['unit']:<2}  {est(c['alone']):<31} {est(c['all_but'])}")
    if out["sensitivity"] is not None:
        echo("  sensitivity: every spread scaled by k (same draws):")
        for p in out["sensitivity"]:
            echo(f"    k = {p['scale']:<5g} jam {est(p)}")
