"""The closure tracker the array tracker replaced, kept as the reference of
``tests/test_loop_tracking.py`` and the baseline of ``benchmarks/bench_loops.py``: each
drive's solve a generator (one Gauss-Newton step per evaluation, the rank of J read off the
singular values of one SVD, RANK_TOL alone), several drives advanced in lockstep by
evaluating all their pending configurations in one array pass, a solve at every grid step
(no windows), the restart from the drive near the flat sheet only where the continued
answer missed the drive; and its evaluation of C and J (prefix products kept per place)."""

from __future__ import annotations

import numpy as np

from foldprint.core.constants import DEFAULT_DT_S
from foldprint.core.errors import DesignError
from foldprint.core.modes import DEFAULT_HINGE_MODEL, HingeModel
from foldprint.model.design import Design
from foldprint.model.materials import MaterialLibrary
from foldprint.physics.hinge_drive import HingeDrive, _with_arc_gap, loop_dt, run_times
from foldprint.physics.kinematics import HINGE_MODELS, Trajectory, forward
from foldprint.physics.loops.closure import (CLOSURE_TOL, FOLLOW_TOL, JUMP, MAX_STEP, NEAR_FLAT, OPT_TOL, SKIP_TOL,
                                     LoopSolution, LoopSolver, _cross3, _rotvec)


class OldSolver(LoopSolver):
    """:class:`LoopSolver` with the replaced evaluation of C and J and the replaced tracker."""

    def __init__(self, frames, hinge_ids):
        super().__init__(frames, hinge_ids)
        pad = lambda a: np.concatenate([a, np.zeros((1,) + a.shape[1:])])[self._pk]  # noqa: E731
        self._o_axis, self._o_v = pad(self.axis), pad(self.twist[:, 3:])
        self._o_point = pad(self.point)[..., None]
        self._o_rows = np.repeat(np.arange(len(self.cycles)), self._pk.shape[1])
        self._o_cols = self._pk.ravel()

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
        q = self._o_point
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
        wj = (pre_r @ self._o_axis[..., None])[..., 0]
        vj = (pre_r @ self._o_v[..., None])[..., 0] + _cross3(pre_t, wj) + _cross3(wj, p[:, :, None, :])
        cols = np.concatenate([wj, vj], axis=3) * ps[..., None]  # (S, m, L, 6)
        jac = np.zeros((S, m, self.n + 1, 6))
        jac[:, self._o_rows, self._o_cols, :] = cols.reshape(S, m * L, 6)
        return c, jac.transpose(0, 1, 3, 2)[..., :self.n].reshape(S, 6 * m, self.n)

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
                        # keep whichever closed answer is nearer the drive
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


def old_loop_grid(self, times, dt: float):
    """``HingeDrive._loop_grid`` before: the union of the LOOP_DT grid and the simulation's
    times, each of which it then held twice (arange against linspace rounding)."""
    times = np.atleast_1d(np.asarray(times if times is not None else [0.0], float))
    end = max(float(times.max(initial=0.0)), float(self.design.process.duration_s))
    key = tuple(sorted(self.frozen_at.items()))
    sol = self._solution
    if sol is not None and self._solved_for == key and sol.times[-1] >= end - 1e-12:
        return None, key
    grid = np.arange(0.0, end + dt, dt)
    if sol is not None and self._solved_for == key:
        grid = np.union1d(grid, sol.times)
    return np.union1d(grid[grid <= end + 1e-12], times[times >= 0]), key


def old_simulate_kinematics(design: Design, times: np.ndarray | None = None, *, bath_c: float | None = None,
                            model: HingeModel = DEFAULT_HINGE_MODEL, dt: float = DEFAULT_DT_S,
                            duration: float | None = None, library: MaterialLibrary | None = None,
                            drive: HingeDrive | None = None) -> Trajectory:
    """``simulate_kinematics`` before: the poses (and arc gap) of every time, held
    configurations included."""
    if model not in HINGE_MODELS:
        raise DesignError(f"hinge model must be one of {HINGE_MODELS}, got {model!r}")
    model = HingeModel(str(model))
    drive = drive or HingeDrive(design, bath_c, library)
    if times is None:
        times = run_times(design, dt, duration)
    times = np.asarray(times, float)
    ratios = drive.ratios(times)
    loop = None
    if drive.loops is not None:
        loop = drive.solve_loops(times, loop_dt(times))
        angles = loop.at(times)
        # the ratio a hinge actually reached: a hinge held back by its loops is not done
        with np.errstate(divide="ignore", invalid="ignore"):
            ach = 1.0 - (1.0 - angles / drive.target[None]) / np.where(drive.fixity > 0, drive.fixity, 1.0)[None]
        ratios = np.where(drive.target[None] != 0, np.clip(np.minimum(ach, ratios), 0.0, 1.0), ratios)
    else:
        angles = drive.angles(times)
    poses = forward(design, angles, model)
    if loop is not None and model == HingeModel.ARC:
        loop = _with_arc_gap(design, loop, angles, poses)
    for a in (times, ratios, angles, poses):
        a.setflags(write=False)
    return Trajectory(design, times, ratios, angles, poses, model, drive.bath_c,
                      tuple(c.fold_time for c in drive.curves), tuple(c.onset_time for c in drive.curves),
                      loop)
