"""Rigid-origami kinematics for hinge graphs with loops (``docs/loops.md``).

When creases meet at interior vertices the hinge graph has cycles and the fold angles
are not independent: going around a loop the rigid transforms must compose to the
identity. Each hinge is driven toward its material's recovery angle rho_i(t)
(:class:`foldprint.physics.hinge_drive.HingeDrive`); at every time step this module finds the
closed configuration nearest to the driven angles, continuing from the previous step
(least-squares tracking on the constraint manifold, as in Tachi's Rigid Origami
Simulator):

    minimise |x - rho(t)|^2   subject to   C(x) = 0,

by Gauss-Newton steps ``dx = J^+ (-C) + (I - J^+ J)(rho - x)`` from the previous x.

Closure is written with the point hinge model (every hinge a rotation about its fold
line: a zero-pitch twist), one 6-vector constraint per hinge that closes a loop (the
fundamental cycles of the spanning tree). Arc hinges translate the child panel by an
amount that depends on the angle, so their axes are not concurrent at a vertex and a
loop of arc hinges generally has no exact closed configuration; foldprint uses the
point model's angles for both hinge models and reports the arc model's positional gap
at every loop hinge (:attr:`LoopSolution.arc_gap_mm`).

This module imports nothing from the pipeline: :mod:`foldprint.physics.kinematics` hands it the
hinge frames (duck-typed: ``index, parent, child, origin, axis, tree``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from .corrector import CLOSURE_TOL, MAX_STEP, OPT_TOL, solve  # noqa: F401
from .drive_state import FOLLOW_TOL, NEAR_FLAT, SKIP_TOL  # noqa: F401
from .tracker import JUMP, track as track_all, warm_compiled  # noqa: F401
from .closure_cost import check_loops
from ...core.jit import use_kernels


#: drives tracked at once from which :meth:`LoopSolver.track_many` takes the compiled round by
#: default (our choice: a Monte-Carlo chunk; one drive is the nominal fold, whose closure
#: residual and angles the reports print, kept the reference's to the bit)
COMPILED_FROM = 2


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


_NEXT, _PREV = np.array([1, 2, 0]), np.array([2, 0, 1])
_ROT_PLUS, _ROT_MINUS = np.array([7, 2, 3]), np.array([5, 6, 1])  # r21, r02, r10 and r12, r20, r01 of a flat 3 x 3


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of (..., 3) arrays (np.cross without its axis bookkeeping): component
    i is a[i+1] b[i+2] - a[i+2] b[i+1]."""
    return a[..., _NEXT] * b[..., _PREV] - a[..., _PREV] * b[..., _NEXT]


def _rotvec(r: np.ndarray) -> np.ndarray:
    """Axis-angle vector of a rotation matrix (stable near the identity)."""
    c = np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)
    a = np.arccos(c)
    w = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    s = np.sin(a)
    if a < 1e-6:
        return 0.5 * w
    if np.pi - a < 1e-6:  # pragma: no cover - half-turn residuals never occur near closure
        m = (r + np.eye(3)) / 2
        k = int(np.argmax(np.diag(m)))
        v = m[:, k] / np.sqrt(max(m[k, k], 1e-300))
        return a * v
    return a / (2 * s) * w


def _rotvecs(r: np.ndarray) -> np.ndarray:
    """:func:`_rotvec` of stacked rotations r (..., 3, 3)."""
    a = np.arccos(np.minimum(np.maximum((r[..., 0, 0] + r[..., 1, 1] + r[..., 2, 2] - 1) / 2, -1.0), 1.0))  # clip
    flat = r.reshape(r.shape[:-2] + (9,))
    w = flat[..., _ROT_PLUS] - flat[..., _ROT_MINUS]
    small = a < 1e-6
    w *= np.where(small, 0.5, a / (2 * np.sin(np.where(small, 1.0, a))))[..., None]
    if (np.pi - a < 1e-6).any():  # pragma: no cover - half-turn residuals never occur near closure
        for i in zip(*np.nonzero(np.pi - a < 1e-6)):
            w[i] = _rotvec(r[i])
    return w


def interp_rows(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``np.interp(t, grid, values[:, k])`` for every column k at once (n, k): the same
    arithmetic (slope (v1 - v0) / (g1 - g0) times t - g0, plus v0; the end values outside
    the grid, the grid value on a grid time), one search for all columns instead of one
    interp call per hinge (a pattern of hundreds of hinges read its angles that way)."""
    last = len(grid) - 1
    j = np.clip(np.searchsorted(grid, t, side="right") - 1, 0, last)
    j1 = np.minimum(j + 1, last)
    out = values[np.where(t >= grid[last], last, j)]  # the ends outside the grid, grid values on it
    i = ((t > grid[0]) & (t < grid[last]) & (grid[j] != t)).nonzero()[0]
    if i.size:
        g0, a0 = grid[j[i]], values[j[i]]
        out[i] = (values[j1[i]] - a0) / (grid[j1[i]] - g0)[:, None] * (t[i] - g0)[:, None] + a0
    return out


@dataclass(frozen=True, eq=False)
class LoopSolution:
    """Closed fold angles on a time grid and what the solver met on the way.

    ``angles`` (n_t, n_hinges) rad satisfy closure at every grid time to ``closure``
    (max residual over the run, rad/mm). ``stuck`` lists (time s, hinge ids) the first
    time each hinge's closed angle stayed more than ``FOLLOW_TOL`` from its drive;
    ``locked_at`` is the first time the configuration had no motion left (rigidly
    locked) while the drive still asked for some, or None."""

    times: np.ndarray
    angles: np.ndarray
    driven: np.ndarray
    closure: float
    stuck: tuple[tuple[float, tuple[str, ...]], ...]
    locked_at: float | None
    dof: int  # dimension of the tangent space at the first folded step
    n_loops: int
    variation: np.ndarray  # (n_t, n_hinges) cumulative total variation of each angle (rad)
    #: computes :attr:`arc_gap_mm` when it is first read (a report reads it; the Monte-Carlo's
    #: folds do not, and it costs about a quarter of a loop pattern's fold); None: 0
    gap: Callable[[], float] | None = field(default=None, repr=False)

    @cached_property
    def arc_gap_mm(self) -> float:
        """The arc hinge model's largest positional gap at a loop hinge (mm, over the
        run; ``foldprint.physics.hinge_drive.loop_gap_mm``), 0 for the point model."""
        return 0.0 if self.gap is None else float(self.gap())

    def on_grid(self, t: np.ndarray) -> bool:
        """Whether times ``t`` are this solution's grid times themselves (a simulation's
        times are: the drive's loop grid holds them exactly)."""
        g = self.times
        return t.ndim == 1 and len(t) == len(g) and (t is g or np.array_equal(t, g))

    def at(self, t) -> np.ndarray:
        """Angles (n, n_hinges) at times ``t``, piecewise linear between grid times; on
        the grid's own times a copy of the grid rows (what the interpolation gives there:
        the grid value on a grid time), without the search."""
        t = np.atleast_1d(np.asarray(t, float))
        if self.on_grid(t):
            return self.angles.copy()
        return interp_rows(t, self.times, self.angles)

    def total_variation(self, t) -> np.ndarray:
        """Cumulative total variation (n, n_hinges) of the piecewise linear angles from
        time 0 to ``t``: a bound on how far each angle has moved, valid when the angle
        is not monotone (the swept collision check's motion bound)."""
        t = np.atleast_1d(np.asarray(t, float))
        if self.on_grid(t):  # k is each grid index, the angles there the grid's: the same sums
            return self.variation + np.abs(self.angles - self.angles)
        g = self.times
        k = np.clip(np.searchsorted(g, t, side="right") - 1, 0, len(g) - 1)
        return self.variation[k] + np.abs(self.at(t) - self.angles[k])


class LoopSolver:
    """Closure constraints of the fundamental cycles and the tracking solve."""

    def __init__(self, frames, hinge_ids: list[str]):
        self.ids = hinge_ids
        self.n = len(hinge_ids)
        self.axis = np.zeros((self.n, 3))
        self.point = np.zeros((self.n, 3))
        parent_of = {}
        for f in frames:
            self.axis[f.index] = f.axis
            self.point[f.index] = f.origin
            if f.tree:
                parent_of[f.child] = (f.parent, f.index)

        def chain(p):  # hinge indices root -> panel p
            out = []
            while p in parent_of:
                p, k = parent_of[p][0], parent_of[p][1]
                out.append(k)
            return out[::-1]

        self.cycles: list[list[tuple[int, float]]] = []
        for f in frames:
            if f.tree:
                continue
            ca, cb = chain(f.parent), chain(f.child)
            c = 0
            while c < min(len(ca), len(cb)) and ca[c] == cb[c]:
                c += 1
            cyc = [(k, 1.0) for k in ca[c:]] + [(f.index, 1.0)] + [(k, -1.0) for k in cb[c:][::-1]]
            self.cycles.append(cyc)
        # twists [w; v] of the point hinges: rotation about the fold line through origin
        self.evaluations = 0  # configurations C and J were evaluated at, in ...
        self.rounds = 0  # ... this many array evaluations (:meth:`track_many`)
        self._kernel = None  # the compiled closure, made when first tracked (:meth:`_compiled`)
        self.twist = np.hstack([self.axis, -np.cross(self.axis, self.point)])
        self._k = np.array([_hat(a) for a in self.axis]).reshape(self.n, 3, 3)
        self._k2 = self._k @ self._k
        self._eye = np.eye(3)
        # the cycles padded to one length L for the batched residual: a padded place is hinge
        # n (an identity factor) with sign 0, so it adds nothing to C or J
        m, L = len(self.cycles), max((len(c) for c in self.cycles), default=0)
        check_loops(self.n, m, L)  # refuse before the tables are made
        self._pk = np.full((m, L), self.n, dtype=np.intp)
        self._ps = np.zeros((m, L))
        for ci, cyc in enumerate(self.cycles):
            for l, (k, sg) in enumerate(cyc):
                self._pk[ci, l], self._ps[ci, l] = k, sg
        pad = lambda a: np.concatenate([a, np.zeros((1,) + a.shape[1:])])[self._pk]  # noqa: E731
        self._p_k, self._p_k2 = pad(self._k), pad(self._k2)  # (m, L, 3, 3)
        self._p_sign = np.where(self._ps < 0, -1.0, 1.0)
        # what the prefix of a cycle moves at each place: the factor's translation (filled per
        # evaluation), its axis and a point of it, as the columns of a 3 x 3
        self._p_cols = np.zeros((m, L, 3, 3))
        self._p_cols[..., 1], self._p_cols[..., 2] = pad(self.axis), pad(self.point)
        self._p_kq = np.einsum("clij,clj->cli", self._p_k, pad(self.point))  # K q, K^2 q: q - R q = -(s K q + c K^2 q)
        self._p_k2q = np.einsum("clij,clj->cli", self._p_k2, pad(self.point))
        self._p_onto = np.zeros((m, L, self.n + 1))  # place -> signed hinge column of J
        self._p_onto[np.arange(m)[:, None], np.arange(L)[None], self._pk] = self._ps
        self._p_onto = self._p_onto[..., :self.n]
        # the same map as a scatter where no hinge is twice in a cycle: J's entries of place
        # (c, l) are its column of cols6 times its sign, at J's flat index of (c, row, hinge)
        c_v, l_v = np.nonzero(self._ps)
        k_v = self._pk[c_v, l_v]
        once = len(np.unique(c_v * (self.n + 1) + k_v)) == len(c_v)
        self._scatter = (c_v, l_v, self._ps[c_v, l_v, None],
                         ((6 * c_v[:, None] + np.arange(6)) * self.n + k_v[:, None]).ravel()) if once else None

    def residual(self, x: np.ndarray, jacobian: bool = True):
        """C (6 m,) and J (6 m, n) of the m cycles at angles x (:meth:`residuals` of one)."""
        c, jac = self.residuals(np.asarray(x, float)[None], jacobian)
        return c[0], (None if jac is None else jac[0])

    def residuals(self, xs: np.ndarray, jacobian: bool = True):
        """C (S, 6 m) and J (S, 6 m, n) at S configurations xs (S, n), for all cycles at
        once (cycles padded to one length, rotations and translations kept apart): equal
        to the cycle-by-cycle product of 4x4 transforms to round-off
        (``tests/test_loop_tracking.py`` keeps that as the reference)."""
        m, S = len(self.cycles), xs.shape[0]
        if m == 0:
            return np.zeros((S, 0)), (np.zeros((S, 0, self.n)) if jacobian else None)
        th = np.concatenate([xs, np.zeros((S, 1))], axis=1)[:, self._pk] * self._p_sign  # (S, m, L) signed angles
        sn, c1 = np.sin(th), 1.0 - np.cos(th)
        r = sn[..., None, None] * self._p_k + c1[..., None, None] * self._p_k2  # (S, m, L, 3, 3), minus I
        r += self._eye
        cols = np.empty(r.shape)
        cols[...] = self._p_cols
        cols[..., 0] = -(sn[..., None] * self._p_kq + c1[..., None] * self._p_k2q)
        L = th.shape[2]
        cols6 = np.empty((S, m, L, 6))  # d C / d x at each place, its rotation part w first
        w, q = cols6[..., :3], np.empty((S, m, L, 3))  # each place's axis and point, moved
        gr, gt = r[:, :, 0], cols[:, :, 0, :, 0]
        w[:, :, 0], q[:, :, 0] = cols[:, :, 0, :, 1], cols[:, :, 0, :, 2]
        for l in range(1, L):
            moved = gr @ cols[:, :, l]
            w[:, :, l], q[:, :, l] = moved[..., 1], moved[..., 2] + gt
            gt = gt + moved[..., 0]
            gr = gr @ r[:, :, l]
        out = np.empty((S, m, 6))
        out[..., 3:] = gt
        out[..., :3] = _rotvecs(gr)
        c = out.reshape(S, 6 * m)
        if not jacobian:
            return c, None
        # d C / d x_k: the twist of place k moved by its prefix, (w, (q - p) x w), signed
        cols6[..., 3:] = _cross3(q - gt[:, :, None], w)
        if self._scatter is None:
            return c, (cols6.transpose(0, 1, 3, 2) @ self._p_onto).reshape(S, 6 * m, self.n)
        c_v, l_v, sg, flat = self._scatter  # the product above without its zero terms (bit for
        jac = np.zeros((S, 6 * m * self.n))  # bit: + 0.0 makes a zero times -1 the product's +0)
        jac[:, flat] = (cols6[:, c_v, l_v] * sg + 0.0).reshape(S, -1)
        return c, jac.reshape(S, 6 * m, self.n)

    def closure(self, x: np.ndarray) -> float:
        return float(np.abs(self.residual(x, False)[0]).max(initial=0.0))

    def project(self, x: np.ndarray, target: np.ndarray):
        """Gauss-Newton tracking from ``x`` toward ``target``: at most GN_STEPS steps toward
        the nearest closed configuration, then Newton corrections until closed.
        Returns (x, |C|, null-space dimension, converged)."""
        sol = solve(self._evaluate, np.asarray(x, float)[None], np.asarray(target, float)[None])
        return sol.x[0], float(sol.res[0]), int(sol.null[0]), bool(sol.done[0])

    def _evaluate(self, xs: np.ndarray):
        self.evaluations += len(xs)
        return self.residuals(xs)

    def track(self, times: np.ndarray, driven: np.ndarray) -> LoopSolution:
        """Follow the driven angles (n_t, n) on the closure manifold from the flat sheet."""
        return self.track_many(times, [driven])[0]

    def track_many(self, times: np.ndarray, drivens, compiled: bool | None = None) -> list[LoopSolution]:
        """:meth:`track` of several drives (each (n_t, n), on the same times) at once
        (:func:`foldprint.physics.loops.tracker.track`: every round evaluates C and J at all
        the drives' unfinished solves in one array pass). ``compiled``: each round in one
        compiled call (:mod:`foldprint.physics.loops.closure_kernels`) where
        :func:`foldprint.core.jit.use_kernels`; None: for COMPILED_FROM drives or more (a
        Monte-Carlo chunk), so one drive, the nominal fold ``simulate`` and ``check``
        report, is the numpy reference's to the bit (it loads, or on a cold cache compiles,
        the kernel all the same: a run's chunks, in this process or a pool forked after it,
        are then timed at the kernel's speed, not the compiler's)."""
        times = np.asarray(times, float)
        drivens = [np.asarray(d, float) for d in drivens]
        if not drivens:
            return []
        check_loops(self.n, len(self.cycles), self._pk.shape[1], len(drivens))
        if compiled is None:
            compiled = len(drivens) >= COMPILED_FROM
            if not compiled and self._compiled() is not None:
                warm_compiled(self._kernel)  # the chunks to come (a pool forked after this) find it loaded
        got = track_all((compiled and self._compiled()) or self._evaluate, times, np.stack(drivens))
        self.rounds += got.rounds
        return [self._solution(times, got.angles[i], d, float(got.closure[i]), got.locked_at[i], int(got.dof[i]))
                for i, d in enumerate(drivens)]

    def _compiled(self):
        """The compiled closure and corrector round where :func:`foldprint.core.jit.use_kernels`
        (:mod:`foldprint.physics.loops.closure_kernels`), else None (the numpy path)."""
        if not use_kernels():
            return None
        if self._kernel is None:
            from .closure_kernels import CompiledClosure
            self._kernel = CompiledClosure(self)
        return self._kernel

    def _solution(self, times, out, driven, worst, locked_at, dof) -> LoopSolution:
        """The report of one tracked drive: the first time each hinge's closed angle is more
        than FOLLOW_TOL from its drive, and each angle's cumulative total variation."""
        dev = np.abs(out - driven) > FOLLOW_TOL
        first = dev.argmax(axis=0)
        stuck = {int(i): float(times[first[i]]) for i in np.nonzero(dev.any(axis=0))[0]}
        var = np.vstack([np.zeros((1, self.n)), np.cumsum(np.abs(np.diff(out, axis=0)), axis=0)])
        groups: dict[float, list[str]] = {}
        for i, t in sorted(stuck.items(), key=lambda it: (it[1], it[0])):
            groups.setdefault(t, []).append(self.ids[i])
        times = times.copy()
        for a in (times, out, driven, var):
            a.setflags(write=False)
        return LoopSolution(times, out, driven, worst, tuple((t, tuple(h)) for t, h in groups.items()),
                            None if np.isnan(locked_at) else float(locked_at), max(dof, 0), len(self.cycles), var)
