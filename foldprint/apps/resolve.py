"""What a front end is given, resolved into what an evaluation takes: a design from a path
or a template's name (with its material library, a crease pattern's scale and crease
materials), the printer profile, the scatter model, the jam thresholds, the sigma scales,
the memory limit, a mode's name, and every number checked against its admissible range.

The command line, a notebook and any other front end come in through these functions
(docs/architecture.md, "One door"). A refusal is a :class:`~foldprint.core.errors.FoldprintError`
naming the input (``what``: "temperature", "samples", ...); a front end passes the name its
user knows the input by (the command line passes its option, ``--temperature``), so every
message names what the user typed. Nothing numerical is imported until a function runs
(``foldprint --help`` stays free of numpy).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from ..core.constants import JAM_ERROR_ABOVE, JAM_WARN_ABOVE
from ..core.errors import FoldprintError

if TYPE_CHECKING:
    from ..checks.rules import Printer, Thresholds
    from ..model.design import Design
    from ..model.materials import MaterialLibrary
    from ..simulation.scatter import Scatter

#: Admissible ranges of the numbers a front end passes on: outside them a value is
#: refused naming the input and the range. dt: 1 us is 1e4 below the default step and far
#: below any recovery time constant (our choice); duration: schema.MAX_DURATION_S (the
#: resource guard refuses long runs with an estimate); temperatures: schema.TEMPERATURE_C;
#: the counts' ceilings are our choice (far above any useful run, below what exhausts a
#: machine before the resource guard can say so).
DT_RANGE_S = (1e-6, 100.0)
MAX_SAMPLES = 1_000_000
MAX_BUDGET = 1_000_000
MAX_TOP = 1000
MAX_WORKERS = 1024

# -- numbers and names ----------------------------------------------------------------

def check_number(text: str, what: str) -> float:
    """``text`` as a finite number; FoldprintError naming ``what``."""
    try:
        v = float(text)
    except ValueError:
        raise FoldprintError(f"{what} must be a number, got {text!r}") from None
    if not math.isfinite(v):
        raise FoldprintError(f"{what} must be a finite number, got {text!r}")
    return v


def check_in_range(value, what: str, lo: float, hi: float, unit: str = "", lo_open: bool = False) -> float:
    """``value`` finite and in [lo, hi] (or (lo, hi]); FoldprintError naming ``what``."""
    u = f" {unit}" if unit else ""
    rng = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]{u}"
    try:
        v = float(value)
    except (TypeError, ValueError, OverflowError):
        raise FoldprintError(f"{what} must be a number in {rng}, got {value!r}") from None
    if not math.isfinite(v) or v > hi or v < lo or (lo_open and v <= lo):
        raise FoldprintError(f"{what} must be in {rng}, got {value!r}")
    return v


def check_count(value: int, what: str, lo: int, hi: int) -> int:
    """A whole number in [lo, hi]; FoldprintError naming ``what``."""
    if not lo <= value <= hi:
        raise FoldprintError(f"{what} must be a whole number in [{lo}, {hi}], got {value}")
    return value


def check_seed(value: int, what: str = "seed") -> int:
    """A seed of the Monte-Carlo samples: a whole number >= 0."""
    if value < 0:
        raise FoldprintError(f"{what} must be >= 0, got {value}")
    return value


def check_fraction(value: float, what: str) -> float:
    """A probability in [0, 1]."""
    if not (math.isfinite(value) and 0.0 <= value <= 1.0):
        raise FoldprintError(f"{what} must be a probability between 0 and 1, got {value}")
    return value


def check_temperature(value, what: str = "temperature") -> float:
    """A bath temperature (deg C) in the schema's range (schema.TEMPERATURE_C)."""
    from ..core.schema import TEMPERATURE_C

    return check_in_range(value, what, *TEMPERATURE_C, "deg C")


def check_thickness(value, what: str = "thickness") -> float:
    """A hinge thickness (mm) in the schema's range of lengths."""
    from ..core.schema import MAX_LENGTH_MM, MIN_LENGTH_MM

    return check_in_range(value, what, MIN_LENGTH_MM, MAX_LENGTH_MM, "mm")


def time_options(duration: float | None, dt: float, duration_what: str = "duration", dt_what: str = "dt") -> None:
    """The time step (s) in :data:`DT_RANGE_S` and the simulated time (s, None: the
    design's) in (0, schema.MAX_DURATION_S]."""
    from ..core.schema import MAX_DURATION_S

    check_in_range(dt, dt_what, *DT_RANGE_S, "s")
    if duration is not None:
        check_in_range(duration, duration_what, 0.0, MAX_DURATION_S, "s", lo_open=True)


def parse_mode(enum, value: str, what: str):
    """``value`` as a member of the mode ``enum`` (:mod:`foldprint.core.modes`); the
    refusal lists the choices."""
    from ..core.modes import parse

    try:
        return parse(enum, value, what)
    except FoldprintError:
        raise FoldprintError(f"{what} must be one of {', '.join(m.value for m in enum)}, got {value!r}") from None


def set_memory_limit(size: str | int | float | None) -> None:
    """The memory limit every resource guard of this process refuses against ("4G",
    "512M", bytes; None: the default)."""
    from ..core import guards

    guards.set_max_memory(size)


# -- what an evaluation reads -----------------------------------------------------------

def load_library(materials_files=None) -> "MaterialLibrary":
    """The shipped material library plus user files (later files override earlier ones)."""
    from ..model.materials import load_library as load

    return load(materials_files or None)


def design_path(design: str | Path) -> Path:
    """The file a design argument names: a path as given, else the template of that name."""
    from ..io.templates import resolve_design_path

    return resolve_design_path(str(design))


def load_input(design: str | Path, materials_files=None, scale: float | None = None,
               crease_materials: str | dict | None = None, *, scale_what: str = "scale",
               library: "MaterialLibrary | None" = None) -> tuple["Design", "MaterialLibrary"]:
    """The design at a path (.toml, .fold, .svg) or the template of that name, and the
    library it was read with (``library``, else the shipped one plus ``materials_files``);
    ``scale`` (mm per file unit of a crease pattern) in (0, 1e6], ``crease_materials`` a
    rule such as ``"M=H-2,V=H-5"``."""
    from ..io.load import load_design

    lib = library if library is not None else load_library(materials_files)
    if scale is not None:
        check_in_range(scale, scale_what, 0.0, 1e6, "mm per file unit", lo_open=True)
    return load_design(design_path(design), lib, scale=scale, crease_materials=crease_materials), lib


def template_paths() -> list[str]:
    """The path of every shipped template, by name."""
    from ..io.templates import list_templates

    return [t["path"] for t in list_templates()]


def load_designs(names: Sequence[str], library: "MaterialLibrary") -> list["Design"]:
    """Each design (a path or a template's name) read with ``library``."""
    return [load_input(n, library=library)[0] for n in names]


def load_printer(printer: str | None = None, printers_file: str | Path | None = None) -> tuple[str, "Printer"]:
    """The printer profile ``printer`` (default: the shipped default), from the shipped
    profiles and ``printers_file``: its key and the profile."""
    from ..model.printers import default_printer_key, find_printer

    key = printer or default_printer_key()
    return key, find_printer(key, printers_file)


def load_scatter(path: str | Path | None = None) -> "Scatter":
    """The shipped scatter model with the fields a user TOML file names replaced."""
    from ..simulation.robust import load_scatter as load

    return load(path)


def thresholds(error_above: float = JAM_ERROR_ABOVE, warn_above: float = JAM_WARN_ABOVE, *,
               error_what: str = "error_above", warn_what: str = "warn_above") -> "Thresholds":
    """The jam probabilities above which check fails and warns, each a probability."""
    from ..checks.rules import Thresholds

    return Thresholds(check_fraction(error_above, error_what), check_fraction(warn_above, warn_what))


def sigma_scales(text: str, what: str = "scales") -> tuple[float, ...]:
    """``"0.5,1,2"`` -> the sigma scales of a sensitivity sweep (sorted, no repeats)."""
    from ..simulation.sensitivity import parse_scales

    return parse_scales(text, what)
