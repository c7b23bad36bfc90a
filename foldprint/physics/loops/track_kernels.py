"""The compiled loop tracker's whole track in one call: the compiled bookkeeping
(:func:`~foldprint.physics.loops.tracker_kernels.between`) and the compiled round
(:func:`~foldprint.physics.loops.closure_kernels.round_pool`) in turn until no point is
left (``docs/loops.md``, "Little work per round").

:func:`foldprint.physics.loops.tracker.track`'s compiled loop called the two from Python,
once each a round: numba checks the type of every array a call passes (48 for the
bookkeeping, 23 for the round), and that with the Python around the calls cost about half
of what the bookkeeping itself does (0.5 of 1 CPU-ms a ``miura_3x3`` sample). Here the
loop is compiled and calls them directly, so a track is one dispatch; the calls, their
order and their arrays are the same, so the answers are the same bits. Imported lazily,
only where :func:`foldprint.core.jit.use_kernels` says yes.

numba stamps a cached function with its own source file's time and size, but the code it
caches holds the functions it calls compiled in: an edit of the bookkeeping or the round
alone would leave the track running their old code from the cache. So the track's stamp
is also that of every module it compiles in (:data:`COMPILED_IN`, :func:`foldprint.core.jit.stale_with`).
"""

from __future__ import annotations

from ...core.jit import njit, stale_with
from . import closure_kernels, corrector, decomp_kernels, drive_state, normal_kernels, pairwise_kernels, tracker_kernels
from .closure_kernels import round_pool
from .tracker_kernels import between

#: the modules whose functions and constants :func:`track_pool`'s compiled code holds
COMPILED_IN = (tracker_kernels, pairwise_kernels, closure_kernels, decomp_kernels, normal_kernels, corrector,
               drive_state)


@njit
def track_pool(first, st, rq, pl, tb):  # pragma: no cover - compiled
    """tracker.track's loop, compiled: ``between(first, st, rq, pl)`` (the three tuples of
    :mod:`~foldprint.physics.loops.tracker_kernels`), then while it leaves live points a round
    of the pool ``pl`` with the closure tables ``tb``
    (:attr:`~foldprint.physics.loops.closure_kernels.CompiledClosure.tables`) and
    ``between`` again. Returns the rounds taken and the points they evaluated."""
    rounds, evaluations = 0, 0
    # one call of between, its flag a bool (a constant False would compile it again, for the literal)
    while between(first and rounds == 0, st, rq, pl):
        evaluations += round_pool(pl[0], pl[1], pl[2], pl[3], pl[4], pl[5], pl[6], pl[7], pl[8], pl[9], pl[10],
                                  pl[11], pl[12], pl[13], tb[0], tb[1], tb[2], tb[3], tb[4], tb[5], tb[6], tb[7], tb[8])
        rounds += 1
    return rounds, evaluations


stale_with(__name__, COMPILED_IN)
