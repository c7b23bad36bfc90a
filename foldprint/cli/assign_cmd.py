"""``foldprint assign``: its options checked, the search run (seven grades or ``--continuous``),
the best assignments printed or written, exit 1 naming what blocks when nothing is feasible.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import List, Optional, Tuple

import typer
from typer import echo

from ..apps.resolve import (MAX_BUDGET, MAX_SAMPLES, MAX_TOP, MAX_WORKERS, check_count, check_seed, check_temperature,
                            load_input, parse_mode)
from ..core.constants import ASSIGN_BUDGET, ASSIGN_SAMPLES, ASSIGN_TOP, DEFAULT_SEED, JAM_WARN_ABOVE
from ..core.errors import FoldprintError
from ..core.modes import DEFAULT_OBJECTIVE, Objective
from .exits import ExitCode, echo_err
from .lazy import summary
from .options import open_mapper
from .printing import echo_json, echo_note, noted
from .progress import samples_progress
from .root import app


@app.command(short_help=summary('assign'))
def assign(
    design: str = typer.Argument(..., help="Design file (.toml, .fold, .svg) or template name."),
    materials: Optional[str] = typer.Option(None, "--materials", metavar="H-1,...,H-7",
                                            help="Hinge materials to choose from (default: every one)."),
    temperature: Optional[float] = typer.Option(None, "--temperature", help="Bath temperature (deg C); "
                                                "default: the design's."),
    temperature_range: Optional[Tuple[float, float]] = typer.Option(None, "--temperature-range", metavar="LO HI",
                                                                    help="Also choose the bath temperature "
                                                                    "(every 5 deg C from LO to HI)."),
    fixed: Optional[List[str]] = typer.Option(None, "--fixed", metavar="HINGE=MAT", help="Keep this hinge's material."),
    objective: str = typer.Option(DEFAULT_OBJECTIVE.value, "--objective", help="time (fastest fold) | margin (widest smallest "
                                  "clearance) | robust (lowest jam probability of the finalists)"),
    top: int = typer.Option(ASSIGN_TOP, "--top", help="How many assignments to report."),
    budget: int = typer.Option(ASSIGN_BUDGET, "--budget", help="Most simulations the search may run."),
    samples: int = typer.Option(ASSIGN_SAMPLES, "--samples", help="Monte-Carlo samples per finalist (--objective robust, --continuous)."),
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
    from ..apps.assign.search import assign as search, with_materials

    objective, mats, temps, fixed_map = _assign_request(materials, temperature, temperature_range, fixed, objective,
                                                        top, budget, samples, workers, seed)
    d, lib = noted(load_input(design))
    if continuous:  # per-hinge VeroWhite fractions and the bath (docs/assign.md, "Continuous fractions")
        from ..apps.assign.continuous import continuous_objective, search_options as search  # noqa: F811
        objective = continuous_objective(objective, mats, fixed_map)
    with open_mapper(scheduler) as mapper, samples_progress(f"{d.name}: evaluations") as cb:
        r = search(d, library=lib, materials=mats, temperatures=temps, fixed=fixed_map, objective=objective,
                   top=top, budget=budget, samples=samples, seed=seed, mapper=mapper, workers=workers,
                   progress=cb)
    out = r.to_json()
    if write is not None and r.best:
        from ..apps.outputs import save_design

        b = r.best[0]
        save_design(write, with_materials(d, b.materials, b.bath_c, lib))
        echo_note(f"wrote {write}")
    if json_out:
        echo_json(out)
    else:
        _print_assign(d.name, r, out, objective)
    _assign_verdict(d.name, r, out, temperature_range is None)


def _assign_request(materials, temperature, temperature_range, fixed, objective, top, budget, samples, workers,
                    seed) -> tuple[Objective, list[str] | None, list[float] | None, dict[str, str]]:
    """``assign``'s options checked: the objective (parsed to an
    :class:`~foldprint.core.modes.Objective`), the materials to choose from, the bath
    temperatures and the fixed hinges (FoldprintError naming the option)."""
    from ..apps.assign.search import temperature_grid

    objective = parse_mode(Objective, objective, "--objective")
    if temperature is not None and temperature_range is not None:
        raise FoldprintError("give --temperature or --temperature-range, not both")
    if temperature is not None:
        check_temperature(temperature, "--temperature")
    if temperature_range is not None:
        lo, hi = (check_temperature(v, "--temperature-range") for v in temperature_range)
        if lo > hi:
            raise FoldprintError(f"--temperature-range needs LO <= HI, got {lo:g} {hi:g}")
    for name, v, hi in (("--top", top, MAX_TOP), ("--budget", budget, MAX_BUDGET), ("--samples", samples, MAX_SAMPLES),
                        ("--workers", workers or 1, MAX_WORKERS)):
        check_count(v, name, 1, hi)
    check_seed(seed, "--seed")
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
    return objective, mats, temps, fixed_map


def _print_assign(name: str, r, out: dict, objective: Objective) -> None:
    """``assign``'s human output: the best assignments and what blocks the others."""
    from ..core.display import percent, seconds

    space = (f"{r.evaluated / r.search_space:.2e} of {r.search_space}" if math.isfinite(r.search_space)
             else "of a continuous space")
    echo(f"{name}: {r.feasible} feasible assignment(s) in {r.evaluated} evaluations ({space}), "
         f"objective {objective}")
    for k, c in enumerate(out["best"], 1):
        mats_s = ", ".join(f"{h}={m}" for h, m in c["assignment"].items())
        extra = "" if c["jam_probability"] is None else f", jam probability {percent(c['jam_probability'])}"
        clear = "-" if c["min_clearance_mm"] is None else f"{c['min_clearance_mm']:.2f} mm"
        echo(f"  {k}. {mats_s} at {c['temperature_c']:g} C: folds in {seconds(c['fold_time_s'])}, "
             f"smallest clearance {clear}{extra}")
    for b in out["blocking"][:5]:
        if r.permanent_blocked:  # found before any evaluation: no count to give
            echo(f"  blocking: {b['pair'][0]}-{b['pair'][1]} cross in the printed (permanent) state")
            continue
        what = f"{b['pair'][0]}-{b['pair'][1]} collide" if "pair" in b else f"goal {b['goal']} unmet"
        echo(f"  blocking: {what} in {b['count']} of {r.evaluated} evaluation(s)")


def _assign_verdict(name: str, r, out: dict, single_bath: bool) -> None:
    """The hint for a cooler bath, and exit 1 naming what blocks when nothing is feasible."""
    from ..core.display import percent, threshold

    best_jam, warn = (r.best[0].jam_probability if r.best else None), JAM_WARN_ABOVE  # check's default warning
    if best_jam is not None and best_jam > warn and single_bath:
        echo_note(f"the best jam probability {percent(best_jam)} is above {threshold(warn)}: a cooler bath "
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
    echo_err(f"{name}: no feasible assignment: {why}")
    raise ExitCode(1)
