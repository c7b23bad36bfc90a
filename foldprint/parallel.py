"""Run many independent evaluations (Monte-Carlo samples, candidate designs) on all
local cores, in processes: python-fcl holds the GIL, so threads would not help.

Results come back in the order of the inputs, whatever the number of workers, so a run
with the same inputs (and seeds) gives the same answer on one core, on many, or on a
cluster. ``progress(done, total)`` is called as results arrive.
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor
from typing import Callable, Iterable, Sequence, TypeVar

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    """All usable cores (the affinity mask where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def map_ordered(fn: Callable[[T], R], items: Sequence[T] | Iterable[T], *, workers: int | None = None,
                progress: Callable[[int, int], None] | None = None, chunksize: int = 1) -> list[R]:
    """``[fn(x) for x in items]`` on ``workers`` processes (default: all cores; 1 runs in
    this process). ``fn`` and the items must pickle (module-level functions)."""
    items = list(items)
    n = len(items)
    workers = default_workers() if workers is None else max(1, int(workers))
    if workers == 1 or n <= 1:
        out = []
        for k, x in enumerate(items):
            out.append(fn(x))
            if progress:
                progress(k + 1, n)
        return out
    out: list = [None] * n
    with ProcessPoolExecutor(max_workers=min(workers, n)) as pool:
        futures = {pool.submit(fn, x): k for k, x in enumerate(items)}
        done = 0
        from concurrent.futures import as_completed

        for fut in as_completed(futures):
            out[futures[fut]] = fut.result()
            done += 1
            if progress:
                progress(done, n)
    return out
