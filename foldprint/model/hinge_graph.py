"""The hinge graph of a design: the edge two panels share, the breadth-first spanning tree
from the root and the hinges that close loops (rigid origami), the tree's order.

``Design``, ``Panel`` and ``Hinge`` in the annotations are
:mod:`foldprint.model.design`'s dataclasses; they are not imported here, because
``design`` imports this module (its names still import from ``design``).
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import LineString

from ..core.constants import tol
from ..core.errors import DesignError, where
from .derived import derived


def shared_edge(a: Panel, b: Panel) -> np.ndarray | None:
    """The longest common boundary segment of two panels, (2, 2), or None. Holes' rings
    count: a flap cut from a window of its neighbour meets it on the window's edge."""
    inter = a.polygon.boundary.intersection(b.polygon.boundary)
    best, best_len = None, tol.length * 100
    for g in getattr(inter, "geoms", [inter]):
        if isinstance(g, LineString) and g.length > best_len:
            coords = np.asarray(g.coords)
            best, best_len = np.array([coords[0], coords[-1]]), g.length
        elif g.geom_type == "MultiLineString":  # pragma: no cover - flattened above
            continue
    if best is None and inter.geom_type in ("MultiLineString", "GeometryCollection"):
        merged = shapely.line_merge(shapely.union_all([g for g in inter.geoms if g.geom_type == "LineString"]))
        for g in getattr(merged, "geoms", [merged]):
            if isinstance(g, LineString) and g.length > best_len:
                coords = np.asarray(g.coords)
                best, best_len = np.array([coords[0], coords[-1]]), g.length
    return best


def spanning_tree(design: Design) -> tuple[list[tuple[Hinge, str, str]], list[tuple[Hinge, str, str]]]:
    """The hinge graph split into a breadth-first spanning tree from the root and the
    hinges that close loops (rigid origami: creases meeting at interior vertices).

    Returns ``(tree, loops)``: tree entries are (hinge, parent id, child id) root outward;
    loop entries are (hinge, panel a, panel b) with a, b = ``hinge.panels``. Raises
    DesignError when some panel is not connected to the root. Computed once per active
    derived-data cache (:mod:`foldprint.model.derived`).
    """
    tree, loops = derived(design, ("spanning_tree",), lambda: _spanning_tree(design))
    return list(tree), list(loops)


def _spanning_tree(design: Design) -> tuple[tuple, tuple]:
    src = where(design.source)
    adj: dict[str, list[Hinge]] = {p.id: [] for p in design.panels}
    for h in design.hinges:
        for pid in h.panels:
            adj[pid].append(h)
    seen = {design.root}
    order: list[tuple[Hinge, str, str]] = []
    queue = [design.root]
    used: set[str] = set()
    while queue:
        cur = queue.pop(0)
        for h in adj[cur]:
            if h.id in used:
                continue
            other = h.panels[1] if h.panels[0] == cur else h.panels[0]
            if other in seen:
                continue  # closes a loop; collected below
            used.add(h.id)
            seen.add(other)
            order.append((h, cur, other))
            queue.append(other)
    missing = [p.id for p in design.panels if p.id not in seen]
    if missing:
        raise DesignError(
            f"{src}the hinge graph is not connected: panels {missing} are not joined to root "
            f"{design.root!r}; add a hinge joining them to the rest")
    loops = [(h, h.panels[0], h.panels[1]) for h in design.hinges if h.id not in used]
    return tuple(order), tuple(loops)


def tree_order(design: Design) -> list[tuple[Hinge, str, str]]:
    """Spanning-tree hinges in breadth-first order from the root: (hinge, parent id,
    child id). Hinges closing loops are left out (see :func:`spanning_tree`)."""
    return spanning_tree(design)[0]


def has_loops(design: Design) -> bool:
    """True when the hinge graph has cycles (more hinges than panels - 1)."""
    return len(design.hinges) > len(design.panels) - 1
