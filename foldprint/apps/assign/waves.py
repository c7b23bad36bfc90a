"""The waves of :func:`foldprint.apps.assign.search.assign`'s pattern search: the hinge graph
(hinges sharing a panel), the connected groups of the hinges still to place offered as
the next wave, and the ``robust`` search's small waves that grow the folded region
(``docs/assign.md``).
"""

from __future__ import annotations

from ...model.design import Design

#: Connected waves offered as children of one prefix (the smallest first).
MAX_CHILDREN = 48
#: ``robust`` pattern search: the largest wave it proposes (but the last, "all the rest").
ROBUST_WAVE_MAX = 2


def hinge_adjacency(design: Design) -> list[set[int]]:
    by_panel: dict[str, list[int]] = {}
    for k, h in enumerate(design.hinges):
        for p in h.panels:
            by_panel.setdefault(p, []).append(k)
    nb = [set() for _ in design.hinges]
    for ks in by_panel.values():
        for a in ks:
            nb[a] |= set(ks) - {a}
    return nb


def connected_waves(remaining: frozenset, graph: list[set[int]], limit: int = MAX_CHILDREN) -> list[frozenset]:
    """Nonempty connected groups of ``remaining`` hinges (in the hinge graph restricted to
    them), smallest first, at most ``limit``; then all of ``remaining`` (possibly
    disconnected), so every prefix can be completed in one wave."""
    found: set[frozenset] = set()
    frontier = [frozenset([k]) for k in sorted(remaining)]
    out: list[frozenset] = []
    while frontier and len(out) < limit:
        nxt = []
        for s in frontier:
            if s in found or s == remaining:
                continue
            found.add(s)
            out.append(s)
            for k in sorted(set().union(*(graph[x] for x in s)) & remaining - s):
                nxt.append(s | {k})
        frontier = sorted(set(nxt), key=lambda s: sorted(s))
    out = sorted(out[:limit], key=lambda s: (len(s), sorted(s)))
    return [remaining] + out


def growing_waves(remaining: frozenset, placed: frozenset, graph: list[set[int]]) -> list[frozenset]:
    """The ``robust`` search's children of a prefix: "all the rest", then connected groups
    of at most ROBUST_WAVE_MAX remaining hinges that touch the hinges already placed (any
    group for the first wave). Many small waves, growing the folded region one step at a
    time: what a sequence that scatter cannot reorder looks like, and a narrow enough
    tree to reach the deep patterns within the budget."""
    out = [remaining]
    for g in connected_waves(remaining, graph)[1:]:
        if len(g) <= ROBUST_WAVE_MAX and (not placed or any(graph[k] & placed for k in g)):
            out.append(g)
    return out
