"""Rigid-origami kinematics for hinge graphs with loops (``docs/loops.md``).

When creases meet at interior vertices the hinge graph has cycles and the fold angles
are not independent: going around a loop the rigid transforms must compose to the
identity. Each hinge is driven toward its material's recovery angle rho_i(t)
(:class:`foldprint.physics.kinematics.HingeDrive`); at every time step this module finds the
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

from dataclasses import dataclass

import numpy as np

#: closure residual accepted as closed (rad for rotation, mm for translation)
CLOSURE_TOL = 1e-9
#: a hinge whose closed angle stays this far from its driven angle "cannot follow" (rad)
FOLLOW_TOL = np.radians(2.0)
#: tracking stops when a Gauss-Newton step moves no angle more than this (rad)
OPT_TOL = 1e-5
#: how much farther than the continued answer a restart from the drive may land (rad)
JUMP = 0.05
#: below this largest angle (rad) the tracker also restarts from the drive
NEAR_FLAT = 0.2
#: a drive that moved less than this since the last solve (rad) is not re-solved
SKIP_TOL = 1e-8
#: largest change of any driven angle per continuation sub-step (rad)
MAX_STEP = 0.1


def _hat(w: np.ndarray) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _rot(axis: np.ndarray, angle: float) -> np.ndarray:
    k = _hat(axis)
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross products of (..., 3) arrays (np.cross without its axis bookkeeping)."""
    out = np.empty(np.broadcast(a, b).shape)
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


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
    arc_gap_mm: float = 0.0

    def at(self, t) -> np.ndarray:
        """Angles (n, n_hinges) at times ``t``, piecewise linear between grid times."""
        t = np.atleast_1d(np.asarray(t, float))
        return np.stack([np.interp(t, self.times, self.angles[:, k])
                         for k in range(self.angles.shape[1])], axis=1)

    def total_variation(self, t) -> np.ndarray:
        """Cumulative total variation (n, n_hinges) of the piecewise linear angles from
        time 0 to ``t``: a bound on how far each angle has moved, valid when the angle
        is not monotone (the swept collision check's motion bound)."""
        t = np.atleast_1d(np.asarray(t, float))
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
        self.iterations = 0
        self.twist = np.hstack([self.axis, -np.cross(self.axis, self.point)])
        self._k = np.array([_hat(a) for a in self.axis]).reshape(self.n, 3, 3)
        self._k2 = self._k @ self._k
        # the cycles padded to one length L for the batched residual: a padded place is hinge
        # n (an identity factor) with sign 0, so it adds nothing to C or J
        m, L = len(self.cycles), max((len(c) for c in self.cycles), default=0)
        self._pk = np.full((m, L), self.n, dtype=np.intp)
        self._ps = np.zeros((m, L))
        for ci, cyc in enumerate(self.cycles):
            for l, (k, sg) in enumerate(cyc):
                self._pk[ci, l], self._ps[ci, l] = k, sg
        self._p_axis = np.vstack([self.axis, np.zeros((1, 3))])[self._pk]  # (m, L, 3)
        self._p_v = np.vstack([self.twist[:, 3:], np.zeros((1, 3))])[self._pk]
        self._p_point = np.vstack([self.point, np.zeros((1, 3))])[self._pk][..., None]  # (m, L, 3, 1)
        self._p_k = np.concatenate([self._k, np.zeros((1, 3, 3))])[self._pk]  # (m, L, 3, 3)
        self._p_k2 = np.concatenate([self._k2, np.zeros((1, 3, 3))])[self._pk]
        self._p_sign = np.where(self._ps < 0, -1.0, 1.0)
        self._p_rows = np.repeat(np.arange(m), L)
        self._p_cols = self._pk.ravel()

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
        pk, ps = self._pk, self._ps
        xa = np.concatenate([xs, np.zeros((S, 1))], axis=1)[:, pk] * self._p_sign  # (S, m, L) signed angles
        sn, c1 = np.sin(xa)[..., None, None], (1 - np.cos(xa))[..., None, None]
        r = sn * self._p_k + c1 * self._p_k2  # (S, m, L, 3, 3), minus the identity
        r[..., 0, 0] += 1.0
        r[..., 1, 1] += 1.0
        r[..., 2, 2] += 1.0
        q = self._p_point
        t = (q - r @ q)[..., 0]  # (S, m, L, 3): exp(xi x) = [r, q - r q]
        L = pk.shape[1]
        pre_r = np.empty((S, m, L, 3, 3))
        pre_t = np.empty((S, m, L, 3))
        gr = np.empty((S, m, 3, 3))
        gr[:] = np.eye(3)
        gt = np.zeros((S, m, 3))
        for l in range(L):
            pre_r[:, :, l], pre_t[:, :, l] = gr, gt
            gt = (gr @ t[:, :, l, :, None])[..., 0] + gt
            gr = gr @ r[:, :, l]
        p = gt
        out = np.empty((S, m, 6))
        out[..., 3:] = p
        # axis-angle of gr, as _rotvec (the half-turn case, never met near closure, by it)
        cosa = np.clip((gr[..., 0, 0] + gr[..., 1, 1] + gr[..., 2, 2] - 1) / 2, -1.0, 1.0)
        a = np.arccos(cosa)
        w = out[..., :3]
        w[..., 0] = gr[..., 2, 1] - gr[..., 1, 2]
        w[..., 1] = gr[..., 0, 2] - gr[..., 2, 0]
        w[..., 2] = gr[..., 1, 0] - gr[..., 0, 1]
        small = a < 1e-6
        sa = np.sin(a)
        w *= np.where(small, 0.5, a / (2 * np.where(small, 1.0, sa)))[..., None]
        if np.any(np.pi - a < 1e-6):  # pragma: no cover - see _rotvec
            for si, ci in zip(*np.nonzero(np.pi - a < 1e-6)):
                out[si, ci, :3] = _rotvec(gr[si, ci])
        c = out.reshape(S, 6 * m)
        if not jacobian:
            return c, None
        wj = (pre_r @ self._p_axis[..., None])[..., 0]
        vj = (pre_r @ self._p_v[..., None])[..., 0] + _cross3(pre_t, wj) + _cross3(wj, p[:, :, None, :])
        cols = np.concatenate([wj, vj], axis=3) * ps[..., None]  # (S, m, L, 6)
        jac = np.zeros((S, m, self.n + 1, 6))
        jac[:, self._p_rows, self._p_cols, :] = cols.reshape(S, m * L, 6)
        return c, jac.transpose(0, 1, 3, 2)[..., :self.n].reshape(S, 6 * m, self.n)

    def closure(self, x: np.ndarray) -> float:
        return float(np.abs(self.residual(x, False)[0]).max(initial=0.0))

    def project(self, x: np.ndarray, target: np.ndarray, iters: int = 8):
        """Gauss-Newton tracking from ``x`` toward ``target``: at most ``iters`` steps
        toward the nearest closed configuration, then Newton corrections until closed.
        Returns (x, |C|, null-space dimension, converged)."""
        return self._project(x, target, iters)[:4]

    def _evaluate(self, x: np.ndarray):
        """C at x and the SVD (u, s, vt) of J there: what one Gauss-Newton step needs."""
        c, jac = self.residual(x)
        return (c, *np.linalg.svd(jac, full_matrices=True))

    def _run(self, gen):
        """Drive a solve generator, evaluating each configuration it yields here."""
        try:
            x = next(gen)
            while True:
                x = gen.send(self._evaluate(x))
        except StopIteration as stop:
            return stop.value

    def _project(self, x: np.ndarray, target: np.ndarray, iters: int = 8, tangent: np.ndarray | None = None):
        return self._run(self._project_gen(x, target, iters, tangent))

    def _project_gen(self, x: np.ndarray, target: np.ndarray, iters: int = 8, tangent: np.ndarray | None = None):
        """:meth:`project` as a generator: it yields each configuration it needs C and the
        SVD of J at, and is sent them (:meth:`_run` one solve, :meth:`track_many` many
        in lockstep, one array evaluation for all); returns what :meth:`project` does,
        plus the tangent basis (rows) at the answer. ``tangent``: the
        basis at ``x`` from the previous solve; the predictor then moves along it toward
        ``target`` before the first evaluation (the step the first Gauss-Newton iteration
        would take from a closed ``x``, without evaluating C and J there), and the
        corrector iterates exactly as :meth:`project` until the same tests pass."""
        x = x.copy()
        if tangent is not None and tangent.shape[0]:
            step = tangent.T @ (tangent @ (target - x))
            big = np.abs(step).max(initial=0.0)
            if big > 0.1:
                step *= 0.1 / big
            x = x + step
        null, res, done, vn = 0, np.inf, False, np.zeros((0, self.n))
        for it in range(iters + 20):
            c, u, sv, vt = yield x
            res = float(np.abs(c).max(initial=0.0))
            rank = int((sv > 1e-7 * max(1.0, sv.max(initial=0.0))).sum())
            vr, vn = vt[:rank], vt[rank:]
            null = self.n - rank
            corr = -(vr.T @ ((u[:, :rank].T @ c) / sv[:rank])) if rank else np.zeros(self.n)
            if it < iters:
                d = target - x
                step = corr + d - vr.T @ (vr @ d)
            else:  # out of tracking steps: only restore closure
                step = corr
            big = np.abs(step).max(initial=0.0)
            if res < CLOSURE_TOL and (big < OPT_TOL or it >= iters):
                done = big < OPT_TOL
                break
            if big > 0.1:
                step *= 0.1 / big
            x = x + step
            self.iterations += 1
        else:
            c = (yield x)[0]
            res = float(np.abs(c).max(initial=0.0))
            vn = None
        return x, res, null, done, vn

    def track(self, times: np.ndarray, driven: np.ndarray) -> LoopSolution:
        """Follow the driven angles (n_t, n) on the closure manifold from the flat sheet."""
        return self._run(self._track_gen(times, driven))

    def track_many(self, times: np.ndarray, drivens) -> list[LoopSolution]:
        """:meth:`track` of several drives (each (n_t, n), on the same times) in lockstep:
        every round evaluates C, J and its SVD at all the drives' current configurations
        in one array pass. Each drive's solve is :meth:`track`'s, step by step, so the
        answers are its answers (``tests/test_loop_tracking.py``)."""
        gens = [self._track_gen(times, d) for d in drivens]
        out: list = [None] * len(gens)
        want: dict[int, np.ndarray] = {}
        for i, g in enumerate(gens):
            try:
                want[i] = next(g)
            except StopIteration as stop:  # pragma: no cover - a track always evaluates
                out[i] = stop.value
        while want:
            idx = list(want)
            c, jac = self.residuals(np.stack([want[i] for i in idx]))
            u, sv, vt = np.linalg.svd(jac, full_matrices=True)
            for j, i in enumerate(idx):
                try:
                    want[i] = gens[i].send((c[j], u[j], sv[j], vt[j]))
                except StopIteration as stop:
                    out[i] = stop.value
                    del want[i]
        return out

    def _track_gen(self, times: np.ndarray, driven: np.ndarray):
        times = np.asarray(times, float)
        x = np.zeros(self.n)
        out = np.zeros_like(driven)
        worst = 0.0
        locked_at = None
        dof = -1
        res_x = 0.0
        settled = True
        prev_drive = np.zeros(self.n)
        tangent = None  # tangent basis at x when x is a converged answer (the predictor's)
        for k in range(len(times)):
            y = driven[k]
            delta = np.abs(y - prev_drive).max(initial=0.0)
            if delta > SKIP_TOL or k == 0 or not settled:
                nsub = max(1, int(np.ceil(delta / MAX_STEP)))
                for s in range(1, nsub + 1):
                    ys = prev_drive + (y - prev_drive) * s / nsub
                    # the predictor only away from the flat state: at a bifurcation point the
                    # tangent space holds every branch, and which one is taken is decided below
                    near_flat = np.abs(x).max(initial=0.0) < NEAR_FLAT
                    xn, res, null, settled, basis = yield from self._project_gen(
                        x, ys, tangent=None if near_flat else tangent)
                    if near_flat and np.abs(xn - ys).max(initial=0.0) > OPT_TOL:
                        # near the flat state (a bifurcation point) the step from x can
                        # stall between branches: also start from the drive itself and
                        # keep whichever closed answer is nearer the drive, but never one
                        # that puts a hinge on the other side of flat from its drive (a
                        # drive keeps its target's sign at every instant; the other side
                        # is another branch, the one a scattered drive would flip to)
                        xb, rb, nb, sb, bb = yield from self._project_gen(ys, ys)
                        if (rb <= 1e-7 and np.linalg.norm(xb - ys) < np.linalg.norm(xn - ys) - 1e-9
                                and np.abs(xb - x).max(initial=0.0) <= np.abs(xn - x).max(initial=0.0) + JUMP
                                and not np.any(xb * ys < 0.0)):
                            xn, res, null, settled, basis = xb, rb, nb, sb, bb
                    if res > 1e-7:  # lost the manifold: hold the last closed configuration
                        settled = True
                        if locked_at is None:
                            locked_at = float(times[k])
                        break
                    x, res_x = xn, res
                    tangent = basis if settled else None
                    if dof < 0 and np.abs(x).max(initial=0) > 1e-3:
                        dof = null
                if locked_at is None and null == 0 and np.abs(x - y).max(initial=0) > FOLLOW_TOL:
                    locked_at = float(times[k])
                worst = max(worst, res_x)
                prev_drive = y
            out[k] = x
        # the first time each hinge's closed angle is more than FOLLOW_TOL from its drive
        # (one array test after the run instead of one per step: the same comparisons)
        dev = np.abs(out - driven) > FOLLOW_TOL
        first = dev.argmax(axis=0)
        stuck = {int(i): float(times[first[i]]) for i in np.nonzero(dev.any(axis=0))[0]}
        var = np.vstack([np.zeros((1, self.n)), np.cumsum(np.abs(np.diff(out, axis=0)), axis=0)])
        groups: dict[float, list[str]] = {}
        for i, t in sorted(stuck.items(), key=lambda it: (it[1], it[0])):
            groups.setdefault(t, []).append(self.ids[i])
        for a in (times, out, driven, var):
            a.setflags(write=False)
        return LoopSolution(times, out, driven, worst, tuple((t, tuple(h)) for t, h in groups.items()),
                            locked_at, max(dof, 0), len(self.cycles), var)
