"""Derived per-design data (hinge frames, spanning tree, reliefs, rigid polygons, render
rings) kept in one explicit cache object, never in the frozen design.

A :class:`DerivedCache` belongs to its owner: :class:`foldprint.apps.pipeline.Evaluation`
owns one per evaluation and activates it around every stage it computes, so a stage that
needs the hinge frames finds them computed once for the whole evaluation. Library entry
points called on their own (``simulate``, ``build_assembly``, a chunk of Monte-Carlo
samples, the renderers) are decorated with :func:`scoped`: they use the active cache, or
open one of their own for the duration of the call.

The cache does not travel: it refuses to be pickled, and a process forked while it was
active ignores it (it is bound to the process that made it). A Monte-Carlo worker folds
one design in many chunks, each its own call: :func:`design_scope` keeps, per process, one
cache per design *content* (a digest of the pickled design, so a chunk's copy sent to a
worker finds the cache of an earlier copy; equal bytes, equal design: never stale) and
hands the chunk the first copy, whose identity the cache's entries are keyed by. Entries are keyed by the
identity of the (immutable) object they derive from plus a key; the cache holds a
reference to each such object, so an identity is never reused while it lives.
"""

from __future__ import annotations

import functools
import hashlib
import os
import pickle
from collections import Counter, OrderedDict
from contextlib import contextmanager
from contextvars import ContextVar
from typing import Callable, Hashable, Iterator, TypeVar

T = TypeVar("T")


class DerivedCache:
    """Values derived from immutable objects (designs), computed on first use.

    ``computed`` counts the computations per name (the first item of a tuple key), e.g.
    ``cache.computed["hinge_frames"]``."""

    def __init__(self) -> None:
        self._store: dict[tuple[int, Hashable], object] = {}
        self._keep: dict[int, object] = {}
        self._pid = os.getpid()
        self.computed: Counter = Counter()

    def get(self, obj: object, key: Hashable, compute: Callable[[], T]) -> T:
        """The value of ``key`` for ``obj``: computed by ``compute()`` on first use."""
        k = (id(obj), key)
        try:
            return self._store[k]  # type: ignore[return-value]
        except KeyError:
            pass
        value = compute()
        self._store[k] = value
        self._keep[id(obj)] = obj
        self.computed[key[0] if isinstance(key, tuple) else key] += 1
        return value

    def __len__(self) -> int:
        return len(self._store)

    @contextmanager
    def active(self) -> Iterator["DerivedCache"]:
        """Make this the cache :func:`derived` uses inside the ``with`` block."""
        token = _ACTIVE.set(self)
        try:
            yield self
        finally:
            _ACTIVE.reset(token)

    def __reduce__(self):
        raise TypeError("a DerivedCache belongs to the evaluation of one process and is not sent to "
                        "workers; each worker derives its own data")


_ACTIVE: ContextVar[DerivedCache | None] = ContextVar("foldprint_derived_cache", default=None)


def current() -> DerivedCache | None:
    """The active cache of this process, or None."""
    c = _ACTIVE.get()
    return c if c is not None and c._pid == os.getpid() else None


def derived(obj: object, key: Hashable, compute: Callable[[], T]) -> T:
    """``compute()`` kept in the active cache (computed each time when none is active)."""
    c = current()
    return compute() if c is None else c.get(obj, key, compute)


@contextmanager
def scope() -> Iterator[DerivedCache]:
    """The active cache, or a new one active for the ``with`` block."""
    c = current()
    if c is not None:
        yield c
        return
    c = DerivedCache()
    with c.active():
        yield c


def scoped(fn: Callable[..., T]) -> Callable[..., T]:
    """Run ``fn`` inside :func:`scope` (an entry point that may be called on its own)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with scope():
            return fn(*args, **kwargs)

    return wrapper


#: Designs whose derived data :func:`design_scope` keeps per process (a worker's designs).
KEEP_DESIGNS = 8
_kept: "OrderedDict[bytes, tuple[object, DerivedCache]]" = OrderedDict()


def content_key(obj: object) -> bytes:
    """A digest of ``obj``'s pickled bytes: equal for equal (immutable) designs, whichever
    copy (a worker receives a fresh copy with every task)."""
    return hashlib.blake2b(pickle.dumps(obj, protocol=5), digest_size=20).digest()


@contextmanager
def design_scope(design: T) -> Iterator[T]:
    """The active cache, with ``design`` itself; when none is active, this process's kept
    cache of a design with the same content (:func:`content_key`), active for the ``with``
    block, with that design's first copy (use it in place of ``design``: the cache's
    entries are keyed by its identity). Keeps :data:`KEEP_DESIGNS` designs, the least
    recently used dropped first; entries made by another process (before a fork) are not
    used."""
    if current() is not None:
        yield design
        return
    key = content_key(design)
    hit = _kept.get(key)
    if hit is None or hit[1]._pid != os.getpid():
        hit = (design, DerivedCache())
        _kept[key] = hit
        while len(_kept) > KEEP_DESIGNS:
            _kept.popitem(last=False)
    _kept.move_to_end(key)
    with hit[1].active():
        yield hit[0]
