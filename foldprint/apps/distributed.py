"""Run evaluations on a Dask distributed cluster (``pip install "foldprint[distributed]"``).

``cluster_mapper(address)`` connects to a running scheduler (``dask scheduler`` and
``dask worker`` processes, or a ``distributed.LocalCluster``) and yields a
``mapper(fn, items, progress)`` with the contract of :func:`foldprint.core.parallel.map_ordered`:
results in the order of the inputs, so a cluster run gives the same answer as a local
one. The workers need foldprint importable (the same version). dask is imported only
here, lazily: the core install works without it.
"""

from __future__ import annotations

import contextlib
from typing import Callable, Iterator

from ..core.errors import FoldprintError

#: Seconds to wait for the scheduler before giving up.
CONNECT_TIMEOUT_S = 5.0


class SchedulerError(FoldprintError):
    """The Dask scheduler cannot be reached or dask.distributed is not installed."""


def _client(address: str, timeout: float):
    try:
        from distributed import Client
    except ImportError:
        raise SchedulerError(f"--scheduler {address}: dask.distributed is not installed; "
                             'pip install "foldprint[distributed]"') from None
    if not isinstance(address, str) or "://" not in address:
        raise SchedulerError(f"--scheduler {address!r}: expected an address like tcp://HOST:PORT")
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except Exception as exc:  # OSError, TimeoutError, CommClosedError... all mean "not reachable"
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SchedulerError(f"--scheduler {address}: cannot reach the Dask scheduler within "
                             f"{timeout:g} s ({reason}); start one with `dask scheduler` or check the address") from None


def client_mapper(client) -> Callable:
    """A ``mapper(fn, items, progress)`` running on an existing ``distributed.Client``."""

    def mapper(fn, items, progress=None):
        items = list(items)
        if not items:
            return []
        futures = client.map(fn, items, pure=False)
        if progress:  # in input order: a future done early is counted when its turn comes
            for k, fut in enumerate(futures, 1):
                fut.result()
                progress(k, len(items))
        return client.gather(futures)

    return mapper


@contextlib.contextmanager
def cluster_mapper(address: str, timeout: float | None = None) -> Iterator[Callable]:
    """Connect to the scheduler at ``address`` (``tcp://HOST:PORT``) for the duration of
    the block (waiting ``timeout`` s, default :data:`CONNECT_TIMEOUT_S`, read at the call);
    raises :class:`SchedulerError` (exit 2 on the CLI) if it cannot."""
    client = _client(address, CONNECT_TIMEOUT_S if timeout is None else timeout)
    try:
        yield client_mapper(client)
    finally:
        client.close()
