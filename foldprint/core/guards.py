"""Resource guards: the limits, the arithmetic and the refusal. Each layer estimates its
own runs' memory and time from what it knows (the simulation's in
:mod:`foldprint.simulation.costs`, the build's in :mod:`foldprint.geometry.build_cost`, the
bar-and-hinge solver's in :mod:`foldprint.physics.barhinge.solve_cost`, a fit's in
:mod:`foldprint.physics.calibration.fit_cost`, the voxel stack's in
:mod:`foldprint.exchange.voxel_cost`); here an estimate (a dict with ``bytes`` and/or
``seconds``) is compared with the limits and, over one, refused with a
:class:`ResourceError` (exit 2) that names the estimate, the limit and how to lift it:
never a MemoryError and never a run that would fit (``docs/input-safety.md`` has the
table of estimate vs measured).

The memory limit defaults to :data:`DEFAULT_MAX_MEMORY` (2 GiB, or the environment
variable ``FOLDPRINT_MAX_MEMORY``); the CLI's ``--max-memory`` sets it for one run. The time
budget is :data:`DEFAULT_TIME_BUDGET_S` (or ``FOLDPRINT_TIME_BUDGET`` in seconds), in CPU
seconds, so that whether a run is refused does not depend on the load of a shared machine.
Estimates are computed in floats, so absurd sizes (1e300 steps) are refused, not overflowed.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from collections.abc import Callable

from .errors import FoldprintError

GiB = 2 ** 30
DEFAULT_MAX_MEMORY = 2 * GiB
#: Time budget of one stage of a run (s), in CPU seconds of the work (estimated before it
#: starts, or measured on its first part, divided among the workers): our choice, one
#: minute, so that any input at the defaults is answered within about a minute, a verdict
#: or a refusal that names the estimate; a longer run is asked for with the environment
#: variable ``FOLDPRINT_TIME_BUDGET`` (seconds). The slowest default stage of a shipped
#: template is 12.5 CPU-s (check's 400 samples of miura_3x3 on 2 workers), the 20 x 20
#: Miura sheet's bar-and-hinge run 27 s estimated (docs/input-safety.md).
DEFAULT_TIME_BUDGET_S = 60.0
#: resident memory of the imported package (numpy, fcl, shapely, manifold3d), bytes:
#: measured on the 2-core sandbox with benchmarks/bench_scale.py (peak RSS of fresh
#: processes, docs/input-safety.md); every estimate starts from it
BASE_BYTES = 110 * 2 ** 20
#: how to lift the time budget, said by every time refusal
LIFT_TIME = "lift the budget with the environment variable FOLDPRINT_TIME_BUDGET (seconds)"

_LIMIT = {"bytes": None, "seconds": None}


class ResourceError(FoldprintError, MemoryError):
    """A run would need more memory or work than the limit allows (exit 2)."""


def parse_size(text: str | int | float) -> int:
    """``"4G"``, ``"512M"``, ``"1.5GiB"``, ``"2000000000"`` -> bytes."""
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        value, unit = float(text), ""
    else:
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?)(?:i?[bB])?\s*", str(text))
        if not m:
            raise FoldprintError(f"--max-memory must be a size like 4G, 512M or 2000000000 (bytes), got {text!r}")
        value, unit = float(m.group(1)), m.group(2).upper()
    size = value * {"": 1, "K": 2 ** 10, "M": 2 ** 20, "G": GiB, "T": 2 ** 40}[unit]
    if not (math.isfinite(size) and 1 <= size <= 2 ** 60):  # 1 byte .. 1 EiB
        raise FoldprintError(f"--max-memory must be a size from 1 byte to 1048576T (1 EiB), got {text!r}")
    return int(size)


def set_max_memory(text: str | int | float | None) -> None:
    """Set the memory limit for this process (None: back to the default)."""
    _LIMIT["bytes"] = None if text is None else parse_size(text)


def set_time_budget(seconds: float | None) -> None:
    """Set the time budget (s) for this process (None: back to the default)."""
    if seconds is not None and not (math.isfinite(float(seconds)) and float(seconds) > 0):
        raise FoldprintError(f"the time budget must be a number of seconds > 0, got {seconds!r}")
    _LIMIT["seconds"] = None if seconds is None else float(seconds)


def time_budget() -> float:
    if _LIMIT["seconds"] is not None:
        return _LIMIT["seconds"]
    env = os.environ.get("FOLDPRINT_TIME_BUDGET")
    if env:
        try:
            value = float(env)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and value > 0):
            raise FoldprintError(f"FOLDPRINT_TIME_BUDGET must be a number of seconds > 0, got {env!r}")
        return value
    return DEFAULT_TIME_BUDGET_S


def max_memory() -> int:
    if _LIMIT["bytes"] is not None:
        return _LIMIT["bytes"]
    env = os.environ.get("FOLDPRINT_MAX_MEMORY")
    return parse_size(env) if env else DEFAULT_MAX_MEMORY


def fmt_bytes(n: float) -> str:
    """``1.5e9`` -> ``"1.4 GiB"`` (three digits; any float, inf included)."""
    if not math.isfinite(n):
        return "more than 1e308 bytes"
    for unit, size in (("TiB", 2 ** 40), ("GiB", GiB), ("MiB", 2 ** 20)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1024:.3g} KiB"


def fmt_seconds(sec: float) -> str:
    """``90`` -> ``"1.5 min"`` (s, min, h or years; any float, inf included)."""
    if not math.isfinite(sec):
        return "more than 1e308 s"
    if sec >= 3600 * 24 * 365:
        return f"{sec / (3600 * 24 * 365):.3g} years"
    if sec >= 3600:
        return f"{sec / 3600:.3g} h"
    if sec >= 60:
        return f"{sec / 60:.3g} min"
    return f"{sec:.3g} s"


def lift_hint(est: dict, option: str = "--max-memory") -> str:
    """``--max-memory 2.4GiB``: the option that lifts the memory limit to fit ``est``
    (20 % over its bytes), or that no machine holds it."""
    if not est["bytes"] * 1.2 < 2.0 ** 60:  # beyond any machine (or not finite): no size to suggest
        return f"{option} (no machine holds this run)"
    return f"{option} {fmt_bytes(est['bytes'] * 1.2).replace(' ', '')}"


def lift_memory_env(est: dict) -> str:
    """How to lift the memory limit where no command option sets it."""
    return f"lift the limit with the environment variable FOLDPRINT_MAX_MEMORY (e.g. {lift_hint(est, '').strip()})"


def refuse(what: str, need: str, fix: str, *, seconds: bool = False):
    """Raise ``ResourceError("{what} refused: {need}, over the {limit}; {fix}")`` where
    the limit is the memory limit (or, ``seconds``, the time budget) in force."""
    limit = f"{fmt_seconds(time_budget())} time budget" if seconds else f"{fmt_bytes(max_memory())} memory limit"
    raise ResourceError(f"{what} refused: {need}, over the {limit}; {fix}")


def enforce(est: dict, what: str, memory: tuple[str, str] | Callable[[], tuple[str, str]] | None = None,
            time: tuple[str, str] | Callable[[], tuple[str, str]] | None = None) -> dict:
    """The refusal: ``est["bytes"]`` over :func:`max_memory` is refused with
    ``memory = (need, fix)``, then ``est["seconds"]`` over :func:`time_budget` with
    ``time = (need, fix)`` (:func:`refuse`); else ``est`` is returned. ``what`` names the
    input and the work ("s.toml: simulation"). ``memory`` and ``time`` may be functions
    giving the pair, called only for a refusal (a caller on a hot path, every Monte-Carlo
    sample's fold, does not write sentences nobody reads)."""
    if memory is not None and est.get("bytes", 0.0) > max_memory():
        refuse(what, *(memory() if callable(memory) else memory))
    if time is not None and est.get("seconds", 0.0) > time_budget():
        refuse(what, *(time() if callable(time) else time), seconds=True)
    return est


def source_of(design) -> str:
    """``"path: "`` (or ``"name: "``): how a refusal names the design it refuses."""
    return f"{design.source}: " if design.source else f"{design.name}: "


#: The bytes of results each evaluation holds while it computes another stage (its earlier
#: simulations' trajectories and indexes), set by :func:`holding` and added to every
#: simulation's estimate: what is held stays allocated while the next run allocates.
_HOLDERS: dict = {}


def held_elsewhere() -> float:
    """Bytes the callers of this process say they hold (:func:`holding`)."""
    return float(sum(_HOLDERS.values()))


@contextlib.contextmanager
def holding(nbytes: float, owner=None):
    """Within the block, the guards count ``nbytes`` already held by ``owner`` (an
    evaluation: nested stages of one owner replace its count, owners add)."""
    key = owner if owner is not None else object()
    before = _HOLDERS.get(key)
    _HOLDERS[key] = float(nbytes)
    try:
        yield
    finally:
        if before is None:
            _HOLDERS.pop(key, None)
        else:
            _HOLDERS[key] = before


def narrow_deadline(what: str = "the 3D swept check", fix: str = "raise --dt, shorten --duration"):
    """A callable ``tick(progress)`` for a long loop: refuses (ResourceError) once the
    loop has spent more CPU than the time budget, naming how far it got and ``fix``. The
    narrow phase's work depends on how close the panels come, and a bar-and-hinge path's
    on how many steps split, known only while they run: they are bounded here, at the
    budget, not estimated ahead."""
    from .jit import work_cpu_s

    budget = time_budget()
    t0 = work_cpu_s()  # the kernels' compilation (a cold cache) is not the loop's work

    def tick(progress: str = "") -> None:
        spent = work_cpu_s() - t0
        if spent > budget:
            raise ResourceError(f"{what} refused after {fmt_seconds(spent)} of CPU, over the {fmt_seconds(budget)} time "
                                f"budget{' (' + progress + ')' if progress else ''}; {fix}, or {LIFT_TIME}")

    return tick
