"""Compiled kernels: numba when it loads, the numpy reference path otherwise.

A kernel module (``*_kernels.py`` beside the numpy code it speeds up) decorates its
functions with :func:`njit` and is imported lazily, only by a caller that has asked
:func:`use_kernels` first, so ``foldprint --help`` never loads numba or LLVM. The numpy
code stays the reference: tests compare the two paths, and a platform where numba cannot
load (no wheel for the Python, a broken llvmlite) runs the numpy path with one note
(:func:`fallback_note`).

``FOLDPRINT_KERNELS=numpy`` selects the reference path (tests, benchmarks, a suspected
kernel bug); ``numba`` (the default) uses the kernels where numba loads.
Compiled code is cached on disk (``cache=True``: beside the module, or numba's user
cache where the package folder is read-only), so only the first command after an install
pays the compilation (docs/kernels.md measures it).
"""

from __future__ import annotations

import os
import sys
from functools import lru_cache
from typing import Callable, TypeVar

from .errors import DesignError
from .modes import Mode

F = TypeVar("F", bound=Callable)

ENV = "FOLDPRINT_KERNELS"


class Kernels(Mode):
    """Which implementation runs the Monte-Carlo sample's inner loops. ``NUMBA``: the
    compiled kernels (the default, where numba loads). ``NUMPY``: the reference path."""

    NUMBA = "numba"
    NUMPY = "numpy"


def requested() -> Kernels:
    """The path asked for by ``FOLDPRINT_KERNELS`` (default: numba), read at every call
    (tests switch it), parsed once per value (the narrow phase asks thousands of times)."""
    return _parse(os.environ.get(ENV))


@lru_cache(maxsize=8)
def _parse(raw: str | None) -> Kernels:
    text = (raw if raw is not None else Kernels.NUMBA.value).strip().lower() or Kernels.NUMBA.value
    try:
        return Kernels(text)
    except ValueError:
        raise DesignError(
            f"environment variable {ENV}={text!r} is not a kernel path; "
            f"use one of {', '.join(k.value for k in Kernels)}"
        ) from None


@lru_cache(maxsize=1)
def _numba_error() -> str | None:
    """None when numba imports, else why it does not (cached: tried once per process)."""
    try:
        import numba  # noqa: F401
    except Exception as exc:  # ImportError, or an llvmlite that cannot load its library
        return f"{type(exc).__name__}: {exc}"
    _clock_compilation()
    return None


#: CPU seconds this process spent compiling kernels (or loading them from the cache), the
#: outermost ``numba:compile`` events only (a kernel's callees compile inside its event)
_COMPILE = {"depth": 0, "start": 0.0, "total": 0.0}


def _clock_compilation() -> None:
    """Count the CPU of numba's compilations into :data:`_COMPILE` (once, when numba loads;
    a forked worker inherits the listener and the count)."""
    import time

    from numba.core import event

    class _Clock(event.Listener):
        def on_start(self, ev):
            if _COMPILE["depth"] == 0:
                _COMPILE["start"] = time.process_time()
            _COMPILE["depth"] += 1

        def on_end(self, ev):
            _COMPILE["depth"] -= 1
            if _COMPILE["depth"] == 0:
                _COMPILE["total"] += time.process_time() - _COMPILE["start"]

    event.register("numba:compile", _Clock())


def work_cpu_s() -> float:
    """This process's CPU seconds (``time.process_time``) less those spent compiling
    kernels: what a time guard extrapolates. On a cold numba cache the first chunk a worker
    folds compiles the kernels it meets (seconds, once per install); timed with it, a run
    that takes 20 s was estimated at 257 s and refused. A compilation still in progress
    counts as work until it ends."""
    import time

    return time.process_time() - _COMPILE["total"]


def use_kernels() -> bool:
    """True when the compiled kernels run: numba requested (the default) and loadable."""
    return requested() is Kernels.NUMBA and _numba_error() is None


def fallback_note() -> str | None:
    """One line for the user when numba was requested but cannot load, else None."""
    if requested() is not Kernels.NUMBA:
        return None
    err = _numba_error()
    if err is None:
        return None
    return f"compiled kernels unavailable ({err}); using the numpy path, which gives the same results more slowly"


def njit(fn: F | None = None, *, contract: bool = False, inline: bool = False):
    """Compile ``fn`` with numba (``nopython``, cached on disk, no GIL held). Call only
    from a kernel module imported after :func:`use_kernels` said yes. ``contract``
    (``@njit(contract=True)``): the compiler may fuse a multiply and an add into one
    fused multiply-add (one rounding instead of two, half the instructions of a
    polynomial), so results move by round-off: for kernels whose stated tolerance allows it.
    ``inline``: numba inlines the function into each kernel that calls it (a small helper
    called in an inner loop, where a call would cost more than its arithmetic)."""
    import numba

    options = {"cache": True, "nogil": True}
    if contract:
        options["fastmath"] = {"contract"}
    if inline:
        options["inline"] = "always"
    if fn is None:
        return numba.njit(**options)
    return numba.njit(**options)(fn)


#: each kernel module's compiled-in modules, as :func:`stale_with` stamped them (by name)
STAMPED: dict[str, tuple[str, ...]] = {}


def stale_with(module_name: str, modules) -> None:
    """Stamp numba's disk cache of every compiled function of the module ``module_name``
    with the time and size of each file of ``modules`` besides its own. numba stamps a
    cached function with its own file only, while the code it caches holds compiled in the
    kernels it calls and the constants it reads from other modules: an edit there alone
    (a ``git pull`` that changes only the SVD) would leave the cache running the old code.
    Call it at the end of a kernel module with every foldprint module it imports from
    (tests/test_tracker_kernels.py checks the lists against the imports). Where numba's
    private cache layout differs, or a function is not cached, nothing changes."""
    STAMPED[module_name] = tuple(m.__name__ for m in modules)
    stamps = tuple((os.stat(m.__file__).st_mtime, os.stat(m.__file__).st_size) for m in modules)
    for obj in list(vars(sys.modules[module_name]).values()):
        if getattr(getattr(obj, "py_func", None), "__module__", None) != module_name:
            continue
        cache = cache_file(obj)
        if cache is not None and hasattr(cache, "_source_stamp"):
            cache._source_stamp = (cache._source_stamp, *stamps)


def cache_file(kernel):
    """numba's disk-cache file object of the compiled function ``kernel`` (its index and
    source stamp), or None where it has none (not cached, the numpy path, a numba whose
    private cache layout differs): the one place that reads that layout."""
    return getattr(getattr(kernel, "_cache", None), "_cache_file", None)
