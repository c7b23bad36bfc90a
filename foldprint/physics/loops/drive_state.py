"""The per-drive state of the loop tracker (:mod:`foldprint.physics.loops.tracker`), one
row per drive: the last answer and its tangent space, the grid step to solve next, what
was met on the way (locks, the null-space dimension, the worst closure), the tables made
once per track (which steps restart from the drive, how many steps from each one move),
and the tolerances that decide when a drive is held, restarted or solved ahead, which answer
it takes and which of a window's it keeps (``docs/loops.md``; here so that the tracker and its
compiled bookkeeping, :mod:`foldprint.physics.loops.tracker_kernels`, read the same ones).
"""

from __future__ import annotations

import numpy as np

from .corrector import MAX_STEP, OPT_TOL, SVD_BELOW, Solves

#: a hinge whose closed angle stays this far from its driven angle "cannot follow" (rad)
FOLLOW_TOL = np.radians(2.0)
#: below this largest angle (rad) of the last answer and of the drive the tracker also restarts
#: from the drive (a drive farther from the flat sheet is not at its bifurcation: measured on
#: 64 check samples of miura_3x3 and cross_lock_uniform and 48 of miura_3x3 programmed flat,
#: the restarts taken had drives of at most 0.0048, 0.061 and 0.0015 rad; 0.05 sends one of 64
#: cross_lock_uniform check samples down the other branch)
NEAR_FLAT = 0.2
#: near the flat sheet, every this many grid steps (the grid's multiples) restart from the
#: drive (our choice: a restart depends on its drive alone and looks for a branch nearer it,
#: so a switch is taken at most two steps, 0.02 s, later; measured on the first 64 check
#: samples of miura_3x3 and cross_lock_uniform against restarting at every step: the same
#: outcomes, not-followed hinges and times, locks and degrees of freedom, closed angles
#: within 2e-10 rad once folded and 0.016 rad before, closures within 5e-10; 28 % and 44 %
#: fewer evaluations; the same outcomes in 640 more samples at 1x and 2x scatter. Every 2
#: or 4 steps: one cross_lock_uniform hinge's not-followed time 0.01 s later)
RESTART_EVERY = 3
#: ... and every step while the drive is within this of flat (rad; our choice: a part
#: programmed perfectly flat, fixity 1, chooses its branch there, its taken restarts had
#: drives of at most 0.0015 rad on 96 miura_3x3 samples; with it, 3 of 192 such samples at
#: 1x and 2x change outcome against restarting at every step, without it 7; the templates'
#: fixity starts their drives above it)
RESTART_ALL = 0.003
#: from a drive this far from flat (rad, its largest angle) a restart is not run where the last
#: answer converged with every hinge folded more than OPT_TOL on its drive's side (docs/loops.md,
#: "Restarts that cannot be taken": a restart is taken only with every hinge on its drive's side,
#: and near flat a branch is told by its mountain-valley assignment, so it could only land on
#: the continued branch). Nearer flat, restarts on the continued branch are taken at round-off
#: (answers 3e-7 rad apart on miura_3x3), so they run there: SVD_BELOW, where the SVD starts to
#: tell the branches apart. Measured on the first check chunk of miura_3x3: restarts 38.4 to
#: 23.1 a sample, evaluations 1773 to 1568, tracking 13.6 to 10.5 CPU-ms, the same answers bit
#: for bit; cross_lock_uniform's non-folding creases stay within OPT_TOL of flat: unchanged)
RESTART_SIDED = SVD_BELOW
#: a drive that moved less than this since the last solve (rad) is not re-solved
SKIP_TOL = 1e-8
#: away from the flat sheet (largest closed angle >= NEAR_FLAT), the same for a drive that moved
#: less than this (rad; our choice: OPT_TOL, the corrector's own step tolerance, so a held answer
#: is about as near the drive's closed configuration as a solve's answer is; measured on the
#: first check chunks of miura_3x3 and cross_lock_uniform: within 5.1e-6 rad of the answers
#: solved at every step, 6.5 % and 8.5 % fewer evaluations)
SKIP_FAR = OPT_TOL
#: most grid steps of one drive solved ahead in one window (our choice: on miura_3x3's check
#: chunk 8, 16, 32, 64 took 546, 444, 389, 364 rounds and 25.4k, 26.6k, 28.4k, 30.4k
#: evaluations, 51.5, 38.7, 35.9, 36.6 CPU-ms a sample of tracking)
WINDOW = 32

#: how much farther than the continued answer a restart from the drive may land (rad)
JUMP = 0.05
#: a solve that ends with a residual above this lost the manifold (the configuration is held)
LOST_TOL = 1e-7
#: near the flat sheet, restarts from the drive of this many next grid steps run ahead (our
#: choice: on miura_3x3's check chunk 784 rounds without, 389 with)
PREFETCH = 8
#: near the flat sheet too, a solve from a converged answer whose largest angle is at least this
#: (rad) and whose tangent space is a line takes the line solve (corrector._gn_line; our choice:
#: SVD_BELOW, below which the SVD resolves the small genuine singular values; docs/loops.md,
#: "The line solve near the flat sheet")
LINE_ABOVE = SVD_BELOW
#: a window's answer is kept when the step-by-step predictor lands within this of it (rad,
#: our choice: about 40 times the largest such distance on the first 64 check samples of the
#: loop templates, 2.3e-4 rad on miura_3x3)
ACCEPT = 0.01


class DriveState:
    """Per drive: the last answer and its tangent space, the grid step to solve next and
    what was met on the way (the step-by-step tracker's variables, one row per drive)."""

    def __init__(self, times, driven):
        self.times, self.driven = times, driven
        s, self.n_t, n = driven.shape
        self.x = np.zeros((s, n))
        self.basis = np.zeros((s, n, n))
        self.free = np.zeros((s, n), bool)
        self.tangent = np.zeros(s, bool)  # the last answer converged: predict along its tangent
        self.plain = np.zeros(s, bool)  # ... its tangent space by the rank rule alone (near flat)
        self.settled = np.ones(s, bool)
        self.xmax = np.zeros(s)  # the largest angle of x
        self.line = np.zeros(s, bool)  # the tangent space is a line
        self.prev = np.zeros((s, n))  # the drive at the last solved step
        self.k = np.zeros(s, int)  # the next grid step
        self.sub = np.zeros(s, int)  # the continuation sub-step within step k (0: none begun)
        self.nsub = np.ones(s, int)
        self.locked = np.full(s, np.nan)
        self.dof = np.full(s, -1)
        self.worst = np.zeros(s)
        self.res_x = np.zeros(s)
        self.width = np.full(s, 2)
        self.out = np.zeros_like(driven)
        # per drive and grid step, fixed for the track: whether the step restarts from its drive
        # (near the flat sheet: every RESTART_EVERY-th step, every step while the drive is
        # within RESTART_ALL of flat), and how many steps from there on in a row move the
        # drive by more than SKIP_TOL and at most MAX_STEP
        big = np.abs(driven).max(axis=2, initial=0.0)
        self.restarts = (big < NEAR_FLAT) & ((np.arange(self.n_t) % RESTART_EVERY == 0)[None] | (big < RESTART_ALL))
        move = np.abs(np.diff(driven, axis=1)).max(axis=2, initial=0.0)
        ok = np.concatenate([(move > SKIP_TOL) & (move <= MAX_STEP), np.zeros((s, 1), bool)], axis=1)
        at = np.arange(self.n_t)
        stop = np.minimum.accumulate(np.where(ok, self.n_t, at)[:, ::-1], axis=1)[:, ::-1]
        self.run = stop - at

    def skip(self, i):
        """Advance the settled drives ``i`` over steps whose drive moved at most SKIP_TOL
        since the last solve (their answer is the last one)."""
        k = self.k[i]
        ready = (k > 0) & (k < self.n_t) & self.settled[i] & (self.sub[i] == 0)
        if not ready.any():
            return
        i, k = i[ready], k[ready]
        tol = self.skip_tol(i)
        idle = np.abs(self.driven[i, k] - self.prev[i]).max(axis=1, initial=0.0) <= tol
        if not idle.any():
            return
        for i, t in zip(i[idle], tol[idle]):
            nxt = self._moving(i, t)
            self.out[i, self.k[i]:nxt] = self.x[i]
            self.k[i] = nxt

    def _moving(self, i, tol):
        """The first grid step from k whose drive ``i`` is more than ``tol`` from the drive
        of the last solve (n_t: none), looked for in blocks growing fourfold."""
        k, size = self.k[i], 16
        while k < self.n_t:
            moved = np.abs(self.driven[i, k:k + size] - self.prev[i]).max(axis=1) > tol
            if moved.any():
                return k + int(moved.argmax())
            k, size = k + size, 4 * size
        return self.n_t

    def skip_tol(self, i):
        """The drive motion (rad) below which drives ``i`` keep their answer: SKIP_FAR away
        from the flat sheet (a converged answer), SKIP_TOL near it, where the restarts from
        the drive choose the branch."""
        far = self.tangent[i] & (self.xmax[i] >= NEAR_FLAT)
        return np.where(far, SKIP_FAR, SKIP_TOL)

    def begin(self, live):
        """Targets of the live drives' next solve: their step's (sub-step's) drive."""
        y, prev, sub = self.driven[live, self.k[live]], self.prev[live], self.sub[live]
        fresh = sub == 0
        if fresh.any():
            delta = np.abs(y - prev).max(axis=1, initial=0.0)
            self.nsub[live] = np.where(fresh, np.maximum(1, np.ceil(delta / MAX_STEP)).astype(int), self.nsub[live])
            self.sub[live] = sub = np.where(fresh, 1, sub)
        return y, prev + (y - prev) * (sub / self.nsub[live])[:, None]

    def ahead(self, live, far):
        """Window widths (len(live),): how many grid steps from k each live drive solves now;
        1 unless ``far`` (away from the flat sheet, with a tangent, no sub-steps): then the
        next steps whose drive moves (by more than SKIP_TOL, at most MAX_STEP) up to the
        drive's current width."""
        w = np.ones(len(live), int)
        if far.any():
            i = live[far]
            w[far] = np.minimum(1 + np.minimum(self.run[i, self.k[i]], WINDOW), self.width[i])
        return w

    def finish(self, i, y, x, res, null):
        """End grid step k of drives ``i``: their answer ``x`` (len(i), n) for drive ``y``."""
        k = self.k[i]
        stop = null == 0  # no motion left: locked where the answer is more than FOLLOW_TOL from the drive
        if stop.any():
            stop &= np.isnan(self.locked[i]) & (np.abs(x - y).max(axis=1, initial=0.0) > FOLLOW_TOL)
            self.locked[i[stop]] = self.times[k[stop]]
        self.worst[i] = np.maximum(self.worst[i], res)
        self.prev[i] = y
        self.out[i, k] = x
        self.k[i] = k + 1
        self.sub[i] = 0

    def needless(self, i, y):
        """Whether restarts of drives ``i`` from drives ``y`` (len(i), n) cannot be taken: the
        drive at least RESTART_SIDED from flat, the last answer converged with every hinge
        folded more than OPT_TOL on its drive's side (a restart taken must keep every hinge on
        its drive's side: near flat, on the continued branch, whose nearest point the solve
        from the last answer finds)."""
        x = self.x[i]
        return (self.tangent[i] & (np.abs(y).max(axis=1, initial=0.0) >= RESTART_SIDED)
                & ((x * y > 0.0) & (np.abs(x) > OPT_TOL)).all(axis=1))

    def settle(self, i, sol: Solves, rows):
        """Take the converged answers ``sol`` rows ``rows`` as the drives' ``i`` configuration."""
        x, free = sol.x[rows], sol.free[rows]
        self.x[i], self.res_x[i] = x, sol.res[rows]
        self.settled[i] = self.tangent[i] = sol.done[rows]
        self.basis[i], self.free[i] = sol.basis[rows], free
        self.line[i] = free.sum(axis=1) == 1
        self.plain[i] = True if sol.plain is None else sol.plain[rows]
        self.xmax[i] = big = np.abs(x).max(axis=1, initial=0.0)
        first = self.dof[i] < 0
        if first.any():
            first &= big > 1e-3
            self.dof[i[first]] = sol.null[rows][first]
