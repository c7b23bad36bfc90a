"""The command line's shared plumbing: errors and exit codes, messages, loading a design,
progress, output of a simulation, option parsing (``foldprint.cli.commands`` holds the commands)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from typer import echo

from ..core.errors import FoldprintError
from ..core.display import seconds

#: Options that take several values after one flag (``--temperature 80 90 100``).
_MULTI = {"--temperature"}


def click_errors() -> tuple[type, ...]:
    """The ClickException classes of the click modules loaded (typer >= 0.26 vendors its
    own click, older typers use click's): only a loaded module can have raised one, so
    the handler imports nothing."""
    return tuple(sys.modules[mod].ClickException for mod in ("typer._click.exceptions", "click.exceptions")
                 if mod in sys.modules)


#: Exit codes: 0 ok, 1 the design fails, 2 bad input or a refused run, 3 an internal error
#: (a bug: never the design's verdict), 130 interrupted.
EXIT_OK, EXIT_FAILS, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3


class ExitCode(Exception):
    def __init__(self, code: int):
        self.code = code


def echo_err(msg: str) -> None:
    echo(f"foldprint: error: {msg}", err=True)


def internal_error(exc: BaseException, argv: list[str]) -> int:
    """An exception no check anticipated: a short report on stderr, exit 3 (never 1, the
    code of a failing design, nor 2, which promises a message naming the input). The
    traceback is printed only with FOLDPRINT_TRACEBACK=1."""
    import os
    import traceback

    if isinstance(exc, MemoryError):
        echo_err(f"out of memory ({type(exc).__name__}); the input is too large for this machine: "
             "reduce it, raise --dt or lower --max-memory so the guard refuses it early")
        return EXIT_INPUT
    frame = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    at = f" at {Path(frame[0].filename).name}:{frame[0].lineno}" if frame else ""
    text = str(exc).splitlines()[0][:200] if str(exc) else ""
    echo_err(f"internal error: {type(exc).__name__}{at}: {text}")
    echo(f"foldprint: this is a bug in foldprint, not a verdict on the design (exit {EXIT_INTERNAL}); "
         f"please report it with the command `foldprint {' '.join(argv)[:300]}` and the input file"
         + ("" if os.environ.get("FOLDPRINT_TRACEBACK") else "; FOLDPRINT_TRACEBACK=1 prints the traceback"),
         err=True)
    if os.environ.get("FOLDPRINT_TRACEBACK"):
        echo("".join(traceback.format_exception(exc)), err=True)
    return EXIT_INTERNAL


def echo_json(obj) -> None:
    echo(json.dumps(obj, indent=2, allow_nan=False))


def check_number(text: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise FoldprintError(f"{what} must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise FoldprintError(f"{what} must be a finite number, got {text!r}")
    return v


OUTPUT_STATE = {"quiet": False, "verbose": False}


def echo_note(msg: str) -> None:
    """A human message on stderr (silenced by --quiet)."""
    if not OUTPUT_STATE["quiet"]:
        echo(msg, err=True)


def load_input(design: str, materials_file=None, scale=None, crease_materials=None):
    from ..io.load import load_design
    from ..model.materials import load_library
    from ..io.templates import resolve_design_path

    lib = load_library(materials_file or None)
    if scale is not None:
        check_in_range(scale, "--scale", 0.0, 1e6, "mm per file unit", lo_open=True)
    d = load_design(resolve_design_path(design), lib, scale=scale, crease_materials=crease_materials)
    for note in d.notes:
        echo_note(f"note: {d.source or d.name}: {note}")
    return d, lib


SCALE_HELP = "FOLD/SVG crease patterns: mm per file unit (needed when frame_unit is 'unit' or missing)."
CREASE_HELP = "FOLD/SVG crease patterns: hinge materials by assignment, e.g. 'M=H-2,V=H-5'."


def parse_mode(enum, value: str, option: str):
    from ..core.modes import parse

    try:
        return parse(enum, value, option)
    except FoldprintError:
        raise FoldprintError(f"{option} must be one of {', '.join(m.value for m in enum)}, got {value!r}") from None


#: Admissible ranges of the command line's numeric options: outside
#: them a value is refused with exit 2 naming the option and the range.
#: --dt: 1 us is 1e4 below the default step and far below any recovery time constant;
#: --duration: schema.MAX_DURATION_S (the resource guard refuses long runs with an
#: estimate); temperatures: schema.TEMPERATURE_C.
DT_RANGE_S = (1e-6, 100.0)
MAX_SAMPLES = 1_000_000
MAX_BUDGET = 1_000_000
MAX_TOP = 1000
MAX_WORKERS = 1024


def check_in_range(value, option: str, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> float:
    """``value`` finite and in [lo, hi] (or (lo, hi]); FoldprintError naming the option."""
    u = f" {unit}" if unit else ""
    rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]{u}"
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise FoldprintError(f"{option} must be a number in {rng}, got {value!r}") from None
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v <= lo):
        raise FoldprintError(f"{option} must be in {rng}, got {value!r}")
    return v


def check_temperature(value, option: str = "--temperature") -> float:
    from ..core.schema import TEMPERATURE_C

    return check_in_range(value, option, *TEMPERATURE_C, "deg C")


def time_options(duration, dt) -> None:
    from ..core.schema import MAX_DURATION_S

    check_in_range(dt, "--dt", *DT_RANGE_S, "s")
    if duration is not None:
        check_in_range(duration, "--duration", 0.0, MAX_DURATION_S, "s", lo_open=True)


def check_count(value: int, option: str, lo: int, hi: int) -> int:
    if not lo <= value <= hi:
        raise FoldprintError(f"{option} must be a whole number in [{lo}, {hi}], got {value}")
    return value


#: An output path may be at most this long (bytes of its absolute form; the system's
#: PATH_MAX is 4096 and the files written inside need room) and this many levels deep
#: (the folders are created one level at a time).
MAX_OUT_PATH_BYTES = 3800
MAX_OUT_LEVELS = 128
#: Formats of a chart (``materials --plot``).
PLOT_FORMATS = ("png", "svg", "pdf")


def _check_out_path(value: str, option: str) -> None:
    """Refuse an output path the file system cannot hold, before anything is made."""
    import os

    from ..core.inputs import shown

    full = os.fsencode(os.path.abspath(value))
    parts = [c for c in full.split(b"/") if c]
    if len(full) > MAX_OUT_PATH_BYTES or any(len(c) > 255 for c in parts) or len(parts) > MAX_OUT_LEVELS:
        raise FoldprintError(f"{option} {shown(value)!r} is too long or too deep ({len(full)} bytes, {len(parts)} "
                             f"levels; at most {MAX_OUT_PATH_BYTES} bytes, {MAX_OUT_LEVELS} levels and 255 bytes a "
                             f"name); give a shorter path, e.g. {option} output/mine")


def check_out_file(value: Path | None, option: str = "--plot", formats=PLOT_FORMATS) -> Path | None:
    """An output file option: a path of a size the file system holds, ending in one of
    ``formats``."""
    if value is None:
        return None
    _check_out_path(str(value), option)
    fmt = value.suffix.lstrip(".").lower()
    if fmt not in formats:
        raise FoldprintError(f"{option} {str(value)[:80]!r}: the file name must end in "
                             f"{', '.join('.' + f for f in formats)} (the chart's format), got {fmt or 'no suffix'!r}")
    return value


def check_out_dir(value: str | None, option: str = "--out"):
    """An output directory option: refuses "" (it would mean the current folder without
    saying so), the file-system root and a path too long or deep to create."""
    import os

    if value is None:
        return None
    if not value.strip():
        raise FoldprintError(f"{option} is empty; give a directory, e.g. {option} output/mine "
                             f"(or {option} . for the current folder)")
    _check_out_path(value, option)
    p = Path(value)
    try:
        real = p.resolve()
    except (OSError, RuntimeError):  # a loop of symbolic links
        raise FoldprintError(f"{option} {value!r} cannot be resolved (a loop of symbolic links); give a directory, "
                             f"e.g. {option} output/mine") from None
    if os.path.abspath(p) == os.path.abspath(os.sep) or real == Path(real.anchor):
        raise FoldprintError(f"{option} {value!r} is the root of the file system; give a directory of its own, "
                             f"e.g. {option} output/mine")
    return p


def _progress_off(silent: bool) -> bool:
    """No progress display: --quiet, --json (``silent``), or stderr not a terminal."""
    return silent or OUTPUT_STATE["quiet"] or not sys.stderr.isatty()


def _bar(at_most: bool):
    """A rich progress display on stderr: what, a bar, done/total, the rate, the time left
    (``at_most``: an upper bound, the total being a maximum a sequential test may not
    need) or a note ("decided"), the time elapsed."""
    from rich.console import Console
    from rich.progress import BarColumn, Progress, ProgressColumn, SpinnerColumn, TextColumn, TimeElapsedColumn
    from rich.text import Text

    class Count(ProgressColumn):
        def render(self, task):
            return Text("" if task.total is None else f"{int(task.completed)}/{int(task.total)}",
                        style="progress.download")

    class Rate(ProgressColumn):
        def render(self, task):
            return Text(f"{task.speed:.1f}/s" if task.speed else "", style="progress.data.speed")

    class Left(ProgressColumn):
        def render(self, task):
            note = task.fields.get("note", "")
            if note or task.total is None or not task.speed:
                return Text(note, style="progress.remaining")
            secs = int(round((task.total - task.completed) / task.speed))
            left = f"{secs // 60}:{secs % 60:02d} left"
            return Text(f"at most {left}" if at_most else left, style="progress.remaining")

    return Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(bar_width=16), Count(), Rate(),
                    Left(), TimeElapsedColumn(), transient=True, console=Console(stderr=True))


def samples_progress(label: str, silent: bool = False):
    """A context manager giving a ``progress(done, total)`` callback: a bar on stderr with
    the rate and time left, when stderr is a terminal and not --quiet or ``silent``
    (--json); else None."""
    import contextlib

    if _progress_off(silent):
        return contextlib.nullcontext(None)

    @contextlib.contextmanager
    def bar():
        with _bar(False) as p:
            task = p.add_task(label, total=None)
            yield lambda done, total: p.update(task, completed=done, total=total)

    return bar()


def stage_progress(title: str, silent: bool = False):
    """A context manager giving ``progress(stage, done, total)`` for an evaluation whose
    stages are sequential tests: a line saying what runs from the first second, then one
    bar per stage with its samples so far of the maximum, the rate and the time left at
    most, and "decided" once the stage reports (n, n) below its maximum. None when
    stderr is not a terminal, with --quiet or ``silent`` (--json)."""
    import contextlib

    if _progress_off(silent):
        return contextlib.nullcontext(None)

    @contextlib.contextmanager
    def bars():
        with _bar(True) as p:
            p.add_task(title, total=None)
            tasks: dict = {}

            def update(stage: str, done: int, total: int) -> None:
                if stage not in tasks:
                    tasks[stage] = (p.add_task(f"  {stage}", total=total), total)
                task, most = tasks[stage]
                note = "" if done < total else ("decided" if total < most else "done")
                p.update(task, completed=done, total=most, note=note)

            yield update

    return bars()


def verdict_word(r: dict) -> str:
    if r["completed"]:
        return "completes"
    c = r["first_collision"]
    return "does NOT complete" + (f" ({c['panels'][0]}-{c['panels'][1]} at {seconds(c['time_s'])})" if c else "")


def print_simulation(r: dict) -> None:
    crossing = r.get("printed_crossings") or []
    if crossing:  # the printed part itself overlaps: no fold, no contact time to report
        pairs = ", ".join(f"{a!r} and {b!r}" for a, b in crossing[:5])
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
    for c in r["contacts"]:
        echo(f"  contact {c['panels'][0]}-{c['panels'][1]} at {seconds(c['time_s'])} ({c['method']})")
    for h in r["hinges"]:
        echo(f"  {h['id']:<6} {h['material']:<6} {hinge_text(h)}")
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
             f"{', '.join(stuck['hinges'])}: they stay where the closure holds them (docs/loops.md)")
    print_paper(r.get("paper") or [])


def hinge_text(h: dict) -> str:
    """A hinge's row: its fold time, or why it does not fold (arrested at a contact, or
    short of 98 % of its target at the end: e.g. held by a loop's closure)."""
    from ..core.constants import FOLD_LEVEL

    ft = "does not fold" if h["fold_time_s"] is None else seconds(h["fold_time_s"])
    if h["arrested_at_s"] is not None:
        return f"{ft}, arrested at {seconds(h['arrested_at_s'])}, {h['angle_error_deg']:.1f} deg short"
    if abs(h["angle_error_deg"]) > (1 - FOLD_LEVEL) * abs(h["target_angle_deg"]) + 1e-9:
        alone = "" if h["fold_time_s"] is None else f" (its material alone folds in {ft})"
        return (f"does not fold: {h['final_angle_deg'] + 0.0:.1f} of {h['target_angle_deg']:g} deg at the end, "
                f"short of 98 %{alone}")
    return ft


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


def load_printer(printer, printers_file):
    from ..model.printers import default_printer_key, find_printer

    key = printer or default_printer_key()
    return key, find_printer(key, printers_file)


def check_fraction(value: float, option: str) -> float:
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise FoldprintError(f"{option} must be a probability between 0 and 1, got {value}")
    return value


def open_mapper(scheduler: str | None):
    """A context giving the mapper of ``--scheduler`` (a Dask cluster), or None (local cores)."""
    import contextlib

    if scheduler is None:
        return contextlib.nullcontext(None)
    from ..apps.distributed import cluster_mapper

    return cluster_mapper(scheduler)


def with_progress(label: str, fn):
    """Run ``fn`` with a spinner on stderr when stderr is a terminal and not --quiet."""
    if OUTPUT_STATE["quiet"] or not sys.stderr.isatty():
        return fn()
    from rich.console import Console

    with Console(stderr=True).status(label):
        return fn()


def expand_multi(argv: list[str]) -> list[str]:
    """``--temperature 80 90`` -> ``--temperature 80 --temperature 90``."""
    out: list[str] = []
    i = 0
    while i < len(argv):
        tok = argv[i]
        out.append(tok)
        i += 1
        if tok in _MULTI:
            first = True
            while i < len(argv) and (first or not argv[i].startswith("-") or _is_number(argv[i])):
                if not first:
                    out.append(tok)
                out.append(argv[i])
                first = False
                i += 1
    return out


def _is_number(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return False
