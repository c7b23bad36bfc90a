"""Run many independent evaluations (Monte-Carlo samples, candidate designs) on all
local cores, in processes: python-fcl holds the GIL, so threads would not help.

Results come back in the order of the inputs, whatever the number of workers, so a run
with the same inputs (and seeds) gives the same answer on one core, on many, or on a
cluster. ``progress(done, total)`` is called as results arrive.

Items are consumed lazily and at most ``2 x workers`` are in flight, so a long stream
(Monte-Carlo chunks) never sits in memory at once. Each worker process limits its BLAS
(OpenBLAS / MKL / OpenMP) pools to one thread (:func:`limit_blas_threads`): the
processes are the parallelism, and a worker's BLAS threads would fight the others.
Each worker also ends when the process that started it ends, even by ``kill -9``
(:func:`die_with_parent`), so no worker lives on without a parent holding its pipes.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Callable, Iterable, Sequence, TypeVar

T = TypeVar("T")
R = TypeVar("R")


def default_workers() -> int:
    """All usable cores (the affinity mask where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
                "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def limit_blas_threads(n: int = 1) -> bool:
    """Limit this process's BLAS and OpenMP thread pools to ``n`` threads: the pools
    already loaded through threadpoolctl (a worker forked after numpy was imported), the
    environment variables for libraries loaded later and for child processes. True when
    the loaded pools could be limited (threadpoolctl installed)."""
    for var in _THREAD_VARS:
        os.environ[var] = str(n)
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is a dependency
        return False
    threadpool_limits(limits=n)
    return True


#: How often a worker's watchdog looks whether its parent is still there (s; our choice:
#: an orphan is gone within a second, the check costs one system call)
WATCH_S = 0.5


def _deathsig() -> bool:
    """Ask Linux to SIGKILL this process when its parent (the thread that forked it) ends
    (``prctl(PR_SET_PDEATHSIG)``); False where that is not available."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        return libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) == 0  # 1 = PR_SET_PDEATHSIG
    except (OSError, AttributeError):  # pragma: no cover - no libc prctl
        return False


def _watch(parent: int) -> None:
    while True:
        time.sleep(WATCH_S)
        if os.getppid() != parent:  # re-parented: the parent is gone
            os._exit(1)


def die_with_parent() -> None:
    """Make this worker process end when its parent ends, however it ends (``kill -9``
    included): the kernel's parent-death signal on Linux, and everywhere a daemon thread
    that exits the worker once its parent id changes (the fallback, and the guard against
    the parent dying before the signal was armed). SIGKILL, not SIGTERM: a forked worker
    inherits the parent's handlers, and must not run the parent's clean-up."""
    parent = os.getppid()
    _deathsig()
    if os.getppid() != parent or parent == 1:  # the parent died before the signal was armed
        os._exit(1)
    threading.Thread(target=_watch, args=(parent,), daemon=True, name="foldprint-parent-watch").start()


def _worker_init() -> None:
    limit_blas_threads(1)
    die_with_parent()


def map_ordered(fn: Callable[[T], R], items: Sequence[T] | Iterable[T], *, workers: int | None = None,
                progress: Callable[[int, int], None] | None = None,
                total: int | None = None) -> list[R]:
    """``[fn(x) for x in items]`` on ``workers`` processes (default: all cores; 1 runs in
    this process). ``fn`` and the items must pickle (module-level functions). ``items``
    may be a generator; ``total`` is then its length (for ``progress`` and the pool size)."""
    if total is None:
        try:
            total = len(items)  # type: ignore[arg-type]
        except TypeError:
            items = list(items)
            total = len(items)
    n = int(total)
    workers = default_workers() if workers is None else max(1, int(workers))
    if workers == 1 or n <= 1:
        out = []
        for k, x in enumerate(items):
            out.append(fn(x))
            if progress:
                progress(k + 1, n)
        return out
    results: dict[int, R] = {}
    with ProcessPoolExecutor(max_workers=min(workers, n), initializer=_worker_init) as pool:
        it = iter(items)
        pending: dict = {}
        k = 0
        done = 0
        while True:
            while len(pending) < 2 * workers:
                try:
                    x = next(it)
                except StopIteration:
                    break
                pending[pool.submit(fn, x)] = k
                k += 1
            if not pending:
                break
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in finished:
                results[pending.pop(fut)] = fut.result()
                done += 1
                if progress:
                    progress(done, n)
    return [results[j] for j in range(k)]
