"""The bar-and-hinge model of a design (``docs/mechanics.md``): nodes at the panels'
vertices, bars on every edge of the panels' triangulations (outline edges, fold lines
and the panel diagonals), rotational springs on the fold lines (one per triangulation
edge along a hinge, its share of the hinge's stiffness by length) and on the diagonals
inside a panel (panel bending, rest angle 0).

Panels joined by a hinge share the nodes on its fold line (hinge end points and any
vertex of either panel on it are inserted into both outlines); panels that only touch
elsewhere stay apart. Holes and non-convex panels are triangulated by
``manifold3d.triangulate`` (the mesh: :mod:`foldprint.physics.barhinge.mesh`). The energy, gradient and Hessian are in
:mod:`foldprint.physics.barhinge.energy`; the equilibrium path in
:mod:`foldprint.physics.barhinge.equilibrium`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ...core.errors import DesignError
from ...model.design import Design
from .energy import fold_angles, stretch, total
from .mesh import coarse_rings, on_segment, panel_rings, shared_nodes, triangulate
from .stiffness import MechanicsParams, bar_stiffness, bending_stiffness, default_params

#: relative tolerance (of the design's size) for a vertex lying on a fold line
_ON_LINE = 1e-7
#: a panel's outline and holes are simplified to this share of its size for the model (our
#: choice, docs/mechanics.md "Few nodes per panel"): the model needs the fold-line nodes
#: and the panel's rough shape, not every vertex of a curve; holes narrower collapse
SIMPLIFY = 0.02
#: ... and coarser (the tolerance doubled) while it keeps more points than this (our choice:
#: a bar-and-hinge panel is a few triangles; 200 holes of a sieve would be 800 nodes)
PANEL_POINTS = 100


@dataclass(frozen=True, eq=False)
class BarHinge:
    """A bar-and-hinge structure. ``nodes`` (n, 3) reference positions (mm);
    ``triangles`` (T, 3) with ``triangle_panel`` (T,); ``bars`` (m, 2) with rest lengths
    ``bar_rest`` and axial stiffnesses ``bar_k`` (N/mm); ``springs`` (s, 4) node lists
    i, j, k, l (axis j-k); ``spring_hinge`` (s,) the design hinge of a fold spring, -1 for
    a panel-bending spring; ``spring_share`` (s,) a fold spring's share of its hinge
    (edge length / hinge length); ``bend_k`` (s,) a bending spring's stiffness (N mm/rad,
    0 for fold springs); ``bar_panel``/``spring_panel`` the panel of a bar or bending
    spring (-1 on a fold line); ``fixed`` the dofs held (3 node + axis)."""

    nodes: np.ndarray
    triangles: np.ndarray
    triangle_panel: np.ndarray
    bars: np.ndarray
    bar_rest: np.ndarray
    bar_k: np.ndarray
    bar_panel: np.ndarray
    springs: np.ndarray
    spring_hinge: np.ndarray
    spring_share: np.ndarray
    bend_k: np.ndarray
    spring_panel: np.ndarray
    fixed: np.ndarray
    n_hinges: int = 0
    panel_nodes: tuple = ()  # per panel, its node indices

    @property
    def n_dof(self) -> int:
        return 3 * len(self.nodes)

    @property
    def free(self) -> np.ndarray:
        mask = np.ones(self.n_dof, bool)
        mask[self.fixed] = False
        return mask

    @property
    def fold(self) -> np.ndarray:
        return self.spring_hinge >= 0

    def spring_arrays(self, hinge_k: np.ndarray, hinge_rest: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(stiffness, rest angle) of every spring for per-hinge stiffness (N mm/rad) and
        rest angle (rad)."""
        h = np.maximum(self.spring_hinge, 0)
        # a design without hinges (one panel) has bending springs only: pad the lookup
        hk = np.append(np.asarray(hinge_k, float).ravel(), 0.0)
        hr = np.append(np.asarray(hinge_rest, float).ravel(), 0.0)
        k = np.where(self.fold, hk[h] * self.spring_share, self.bend_k)
        rest = np.where(self.fold, hr[h], 0.0)
        return k, rest

    def energy(self, x: np.ndarray, hinge_k, hinge_rest, hessian: bool = True):
        """U(x), gradient (3n,), Hessian (CSR, with ``hessian``) at positions x (n, 3)."""
        k, rest = self.spring_arrays(hinge_k, hinge_rest)
        return total(x, self.bars, self.bar_rest, self.bar_k, self.springs, rest, k, hessian)

    def hinge_angles(self, x: np.ndarray) -> np.ndarray:
        """(n_hinges,) each hinge's fold angle: its springs' angles weighted by length, each
        taken within pi of the springs' circular mean (a hinge folded flat may have springs
        on both sides of atan2's cut at +-pi; its angle is then near 180 deg, possibly a
        round-off past it)."""
        rho = fold_angles(x, self.springs[self.fold])
        h = self.spring_hinge[self.fold]
        w = self.spring_share[self.fold]
        mean = np.arctan2(np.bincount(h, weights=w * np.sin(rho), minlength=self.n_hinges),
                          np.bincount(h, weights=w * np.cos(rho), minlength=self.n_hinges))
        rho = mean[h] + stretch(rho, mean[h])
        num = np.bincount(h, weights=w * rho, minlength=self.n_hinges)
        den = np.bincount(h, weights=w, minlength=self.n_hinges)
        return num / np.where(den > 0, den, 1.0)

    def bar_length(self, x: np.ndarray) -> np.ndarray:
        """(m,) length of every bar."""
        return np.linalg.norm(x[self.bars[:, 1]] - x[self.bars[:, 0]], axis=1)

    def bar_strain(self, x: np.ndarray) -> np.ndarray:
        """(m,) engineering strain of every bar."""
        return self.bar_length(x) / self.bar_rest - 1.0

    def bending(self, x: np.ndarray) -> np.ndarray:
        """(s_bend,) fold angle across every panel diagonal (rad)."""
        return fold_angles(x, self.springs[~self.fold])


def build(design: Design, params: MechanicsParams | None = None,
          panel_modulus_mpa: float | None = None) -> BarHinge:
    """The bar-and-hinge model of ``design`` in its flat (sheet) state. Panels take the
    modulus of ``params`` (default: ``data/mechanics.toml``) or ``panel_modulus_mpa``."""
    params = params or default_params()
    size = max(float(np.ptp(np.concatenate([p.outline for p in design.panels]), axis=0).max()), 1.0)
    eps = _ON_LINE * size
    rings = panel_rings(design, eps)
    pidx = design.panel_index()
    for k, p in enumerate(design.panels):  # few nodes per panel: its outline to SIMPLIFY of its size
        lines = [tuple(np.asarray(q, float) for q in h.line) for h in design.hinges if p.id in h.panels]
        span = float(np.ptp(np.asarray(p.outline, float), axis=0).max())
        tol, coarse = SIMPLIFY * span, None
        while coarse is None or (sum(map(len, coarse)) > PANEL_POINTS and tol < span):
            coarse, tol = coarse_rings(rings[k], lines, tol, eps), 2 * tol
        rings[k] = coarse
    gid, xy, owner = shared_nodes(design, rings, eps)
    E = params.panel_modulus_mpa if panel_modulus_mpa is None else float(panel_modulus_mpa)
    tri, tri_panel, start = [], [], 0
    panel_nodes = []
    for k, (p, pr) in enumerate(zip(design.panels, rings)):
        n_k = sum(len(r) for r in pr)
        t = triangulate(pr, p.id)
        tri.append(gid[start + t])
        tri_panel.append(np.full(len(t), k))
        panel_nodes.append(np.unique(gid[start:start + n_k]))
        start += n_k
    tri, tri_panel = np.concatenate(tri), np.concatenate(tri_panel)
    nodes = np.column_stack([xy, np.zeros(len(xy))])
    thick = np.array([p.thickness for p in design.panels])
    lines = [(pidx[h.panels[0]], pidx[h.panels[1]], *(np.asarray(q, float) for q in h.line), h.length)
             for h in design.hinges]

    def crease_of(j: int, k: int, pa: int, pb: int):
        mid = 0.5 * (xy[j] + xy[k])
        for m, (a, b, p, q, length) in enumerate(lines):
            if {a, b} == {pa, pb} and on_segment(mid, p, q, eps) is not None:
                return m, float(np.linalg.norm(xy[k] - xy[j])) / length
        return None  # panels meeting along an edge without a hinge: a cut

    root = pidx[design.root]
    t0 = tri[np.nonzero(tri_panel == root)[0][0]]
    return from_mesh(nodes, tri, tri_panel, thick, E, params, crease_of, len(design.hinges),
                     tuple(panel_nodes), (3 * t0[:, None] + np.arange(3)[None]).ravel(), eps, design.name)


def from_mesh(nodes, tri, tri_panel, thick, E, params: MechanicsParams, crease_of, n_hinges: int,
              panel_nodes: tuple, fixed, eps: float = 1e-9, name: str = "mesh") -> BarHinge:
    """A bar-and-hinge model of a triangle mesh (``nodes`` (n, 3) in their rest state,
    ``tri`` (T, 3), ``tri_panel`` (T,), panel thicknesses ``thick`` and modulus ``E``):
    a bar on every edge, a bending spring on every edge inside a panel and a fold spring
    where ``crease_of(j, k, panel_a, panel_b)`` returns (hinge index, share of the hinge)
    for an edge between two panels (None: no spring). ``fixed``: the dofs held."""
    nodes = np.asarray(nodes, float)
    area = 0.5 * np.linalg.norm(np.cross(nodes[tri[:, 1]] - nodes[tri[:, 0]], nodes[tri[:, 2]] - nodes[tri[:, 0]]),
                                axis=1)
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    opp = np.concatenate([tri[:, 2], tri[:, 0], tri[:, 1]])
    etri = np.tile(np.arange(len(tri)), 3)
    bars, inv = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
    inv = inv.ravel()
    rest = np.linalg.norm(nodes[bars[:, 1]] - nodes[bars[:, 0]], axis=1)
    if (rest <= eps).any():
        raise DesignError(f"{name}: two vertices closer than {eps:.2g} mm; merge them")
    kb = np.bincount(inv, weights=bar_stiffness(E, thick[tri_panel[etri]], area[etri], rest[inv]),
                     minlength=len(bars))
    sides: dict[int, list] = {}
    for e_, t_, o_ in zip(inv.tolist(), etri.tolist(), opp.tolist()):
        sides.setdefault(e_, []).append((t_, o_))
        if len(sides[e_]) > 2:
            raise DesignError(f"{name}: a fold line is shared by more than two panels")
    first = np.array([sides[e_][0][0] for e_ in range(len(bars))])
    two = {e_: v for e_, v in sides.items() if len(v) == 2}
    bar_panel = tri_panel[first].copy()
    rows = []  # i, j, k, l, hinge, share, bending k, panel
    for e_, ((ta, i), (tb, l_)) in sorted(two.items()):
        j, k = bars[e_]
        pa, pb = tri_panel[ta], tri_panel[tb]
        if pa == pb:
            kb_ = float(bending_stiffness(E, thick[pa], rest[e_], params.panel_poisson, params.bending_coefficient))
            rows.append((i, j, k, l_, -1, 0.0, kb_, pa))
            continue
        bar_panel[e_] = -1
        hit = crease_of(int(j), int(k), int(pa), int(pb))
        if hit is not None:
            rows.append((i, j, k, l_, hit[0], hit[1], 0.0, -1))
    cols = list(zip(*rows)) if rows else [()] * 8
    springs = _oriented(nodes, np.array(np.column_stack(cols[:4]) if rows else np.zeros((0, 4)), dtype=np.int64))
    arr = lambda a, dt=float: np.asarray(a, dtype=dt)  # noqa: E731
    out = BarHinge(nodes, tri, np.asarray(tri_panel), bars, rest, kb, bar_panel, springs, arr(cols[4], np.int64),
                   arr(cols[5]), arr(cols[6]), arr(cols[7], np.int64), np.sort(np.asarray(fixed, np.int64)),
                   n_hinges, panel_nodes)
    for a in (out.nodes, out.triangles, out.bars, out.bar_rest, out.bar_k, out.springs, out.spring_hinge,
              out.spring_share, out.bend_k, out.fixed):
        a.setflags(write=False)
    return out


def kresling(n: int = 6, radius: float = 20.0, height: float = 35.0, twist: float = math.radians(70),
             thickness: float = 0.8, params: MechanicsParams | None = None) -> BarHinge:
    """A Kresling tower as a bar-and-hinge truss (the validation case of docs/mechanics.md):
    a fixed bottom n-gon of circumradius ``radius`` (mm), the top n-gon (fanned into
    triangles: rigid) turned by ``twist`` (rad) at ``height``; bars on every edge, every
    triangle its own panel, so the edges between them are fold springs of one hinge (index
    0, its stiffness the caller's). A tube, not a flat sheet: no foldprint design holds it."""
    params = params or default_params()
    ang = 2 * math.pi * np.arange(n) / n
    bottom = np.column_stack([radius * np.cos(ang), radius * np.sin(ang), np.zeros(n)])
    top = np.column_stack([radius * np.cos(ang + twist), radius * np.sin(ang + twist), np.full(n, height)])
    tri = []
    for k in range(n):
        k1 = (k + 1) % n
        tri += [[k, k1, n + k], [k1, n + k1, n + k]]
    tri += [[n, n + k, n + k + 1] for k in range(1, n - 1)]
    tri = np.array(tri)
    return from_mesh(np.vstack([bottom, top]), tri, np.arange(len(tri)), np.full(len(tri), thickness),
                     params.panel_modulus_mpa, params, lambda j, k, a, b: (0, 0.0), 1, (), np.arange(3 * n))


def kresling_heights(n: int, radius: float, height: float, twist: float) -> tuple[float, float]:
    """The other (height, twist) at which every bar of :func:`kresling` has its rest length:
    the diagonals |b_k t_k|^2 = h^2 + 2R^2 (1 - cos phi) and |b_k+1 t_k|^2 = h^2 +
    2R^2 (1 - cos(phi - 2 pi/n)) keep their lengths while sin(phi - pi/n) does, so
    phi2 = pi + 2 pi/n - phi1 and h2^2 = h1^2 + 2R^2 (cos phi2 - cos phi1) (Cai et al. 2015;
    Liu and Paulino 2017's bistable Kresling).

    >>> [round(v, 3) for v in kresling_heights(6, 20.0, 35.0, math.radians(70))]
    [12.788, 2.967]
    """
    phi2 = math.pi + 2 * math.pi / n - twist
    h2sq = height**2 + 2 * radius**2 * (math.cos(phi2) - math.cos(twist))
    if h2sq <= 0:
        raise DesignError(f"Kresling n={n}, R={radius}, h={height}, twist={twist:.3f}: no second stable height")
    return math.sqrt(h2sq), phi2


def diagonal_curvatures(nodes0: np.ndarray, x: np.ndarray) -> tuple[float, float]:
    """(a, b) of the least-squares fit z = a u^2 + b v^2 + c u v + d u + e v + f of the
    heights ``x[:, 2]`` over the sheet's diagonal coordinates u = (x + y)/sqrt 2,
    v = (y - x)/sqrt 2 of the flat positions ``nodes0``: a < 0 < b is a saddle rising along
    v (the pleated hypar's sign test, docs/mechanics.md)."""
    u0 = (nodes0[:, 0] + nodes0[:, 1]) / math.sqrt(2)
    v0 = (nodes0[:, 1] - nodes0[:, 0]) / math.sqrt(2)
    A = np.column_stack([u0**2, v0**2, u0 * v0, u0, v0, np.ones_like(u0)])
    a, b = np.linalg.lstsq(A, x[:, 2], rcond=None)[0][:2]
    return float(a), float(b)


def _oriented(nodes: np.ndarray, springs: np.ndarray) -> np.ndarray:
    """Springs with j, k ordered so that lifting the l side toward +z is a positive (valley)
    fold angle, the FOLD convention of the design's hinges."""
    if len(springs) == 0:
        return springs
    x = np.repeat(nodes[None], 1, axis=0)[0]
    lifted = np.zeros((len(springs), 4, 3))
    lifted[:] = x[springs]
    lifted[:, 3, 2] += 1e-3 * np.linalg.norm(lifted[:, 2] - lifted[:, 1], axis=1)
    local = np.arange(4 * len(springs)).reshape(-1, 4)
    rho = fold_angles(lifted.reshape(-1, 3), local)
    out = springs.copy()
    swap = rho < 0
    out[swap, 1], out[swap, 2] = springs[swap, 2], springs[swap, 1]
    return out
