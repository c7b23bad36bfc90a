"""Quasi-static equilibrium of the bar-and-hinge model along a fold (``docs/mechanics.md``).

At each time of an adaptive grid every hinge spring takes its rest angle from the recovery
model (``HingeDrive.driven``: the angle the hinge's material has recovered to) and its
stiffness from the material's modulus at the hinge's mean temperature
(:mod:`foldprint.physics.barhinge.stiffness`); the structure settles where the energy is stationary.
Newton's method on the free degrees of freedom with a sparse direct solve
(``scipy.sparse.linalg.spsolve``), a Levenberg shift where the Hessian is not positive
definite (past a snap-through: the step then still descends) and an Armijo backtracking
line search on the energy; a step whose Newton solve does not converge is split into
halves (load stepping: rest angles and stiffnesses are interpolated).

:class:`CompliantDrive` is a :class:`~foldprint.physics.hinge_drive.HingeDrive` whose angles
are the equilibrium's fold angles (piecewise linear between grid times, like the loop
tracker's), so forward kinematics, the swept collision check (with the total variation of
each angle as its motion bound), goals and arrest run on it unchanged.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import MatrixRankWarning, spsolve

from ...core.errors import DesignError
from ...model.design import Design
from ...core.guards import narrow_deadline, source_of
from ...model.materials import MaterialLibrary
from .model import BarHinge, build
from .energy import stretch
from ..kinematics import forward
from ..hinge_drive import HingeDrive
from ...core.modes import HingeModel
from ..viscoelastic import viscoelastic
from .stiffness import MechanicsParams, default_params, hinge_modulus, hinge_stiffness

log = logging.getLogger(__name__)

#: Newton stops when the largest free force is below this (N) ...
FORCE_TOL_N = 1e-7
#: ... or a Newton step moves no node more than this (mm) or would lower the energy by
#: less than this share of it (round-off: the step is taken and the solve ends)
STEP_TOL_MM = 1e-8
ENERGY_TOL = 1e-13
#: Gauss-Newton iterations and relative length tolerance of :func:`retract`
RETRACT_ITER = 4
RETRACT_TOL = 1e-12

#: Newton iterations before a step is split in halves
MAX_NEWTON = 25
#: deepest halving of one time step
MAX_SPLIT = 8
#: largest change of any rest angle (rad) between two solved times (our choice: 1 deg;
#: halving it and GRID_LOG_K moved miura_3x3's angles by at most 0.33 deg, 0.55 % of its
#: 60 deg target, and helix_graded's by 2e-5 deg; tests/test_barhinge.py checks the bound)
GRID_ANGLE_RAD = np.radians(1.0)
#: largest change of any hinge's log stiffness between two solved times (a factor 1.5)
GRID_LOG_K = np.log(1.5)


@dataclass(frozen=True)
class Equilibrium:
    x: np.ndarray
    energy: float
    iterations: int
    converged: bool
    force: float  # largest free force at the end (N)


def equilibrium(model: BarHinge, x0: np.ndarray, hinge_k, hinge_rest, *,
                free: np.ndarray | None = None, max_iter: int = MAX_NEWTON) -> Equilibrium:
    """Newton with a Levenberg shift and an Armijo line search from ``x0`` (n, 3)."""
    free = model.free if free is None else free
    x = np.array(x0, float)
    U, g, H = model.energy(x, hinge_k, hinge_rest)
    for it in range(1, max_iter + 1):
        gf = g[free]
        if np.abs(gf).max(initial=0.0) <= FORCE_TOL_N:
            return Equilibrium(x, U, it - 1, True, float(np.abs(gf).max(initial=0.0)))
        d = _descent(H[free][:, free].tocsc(), gf)
        step = np.zeros(model.n_dof)
        step[free] = d
        slope = float(gf @ d)
        # the last step of a converged solve: the predicted decrease is round-off
        final = np.abs(d).max() <= STEP_TOL_MM or -slope <= ENERGY_TOL * max(abs(U), 1e-12)
        a = 1.0
        xt = x + step.reshape(-1, 3)
        if not final:
            J = bar_jacobian(model, x)
            dl = J @ step
            length = model.bar_length(x)
            for _ in range(40):
                xt = retract(model, x + a * step.reshape(-1, 3), length + a * dl, free)
                Ut = model.energy(xt, hinge_k, hinge_rest, hessian=False)[0]
                if Ut <= U + 1e-4 * a * slope:
                    break
                a *= 0.5
        x = xt
        U, g, H = model.energy(x, hinge_k, hinge_rest)
        if final:
            return Equilibrium(x, U, it, True, float(np.abs(g[free]).max(initial=0.0)))
    force = float(np.abs(g[free]).max(initial=0.0))
    return Equilibrium(x, U, max_iter, force <= FORCE_TOL_N, force)


def bar_jacobian(model: BarHinge, x: np.ndarray) -> sp.csr_matrix:
    """d l / d x (m, 3n) of the bar lengths."""
    u = x[model.bars[:, 1]] - x[model.bars[:, 0]]
    u /= np.linalg.norm(u, axis=1)[:, None]
    m = len(model.bars)
    rows = np.repeat(np.arange(m), 6)
    cols = (3 * model.bars[:, [0, 0, 0, 1, 1, 1]] + np.tile(np.arange(3), 2)).ravel()
    vals = np.concatenate([-u, u], axis=1).ravel()
    return sp.csr_matrix((vals, (rows, cols)), shape=(m, model.n_dof))


def retract(model: BarHinge, x: np.ndarray, length: np.ndarray, free: np.ndarray,
            iterations: int = RETRACT_ITER) -> np.ndarray:
    """``x`` moved (least squares, smallest move) until every bar has ``length``: the
    linear Newton step turns panels along tangents and stretches the bars by the square
    of the turn; this puts the step back on the curved path the panels move along."""
    x = np.array(x, float)
    for _ in range(iterations):
        r = model.bar_length(x) - length
        if np.abs(r).max(initial=0.0) <= RETRACT_TOL * float(model.bar_rest.min(initial=1.0)):
            break
        J = bar_jacobian(model, x)[:, free].tocsc()
        A = (J.T @ J).tocsc()
        A = A + (1e-10 * float(A.diagonal().mean() or 1.0)) * sp.identity(A.shape[0], format="csc")
        d = spsolve(A, -(J.T @ r))
        x.reshape(-1)[free] += d
    return x


def displacement_path(model: BarHinge, dofs, values, hinge_k, hinge_rest, x0: np.ndarray | None = None,
                      max_iter: int = 60) -> list[Equilibrium]:
    """Displacement control: the equilibrium with the coordinates ``dofs`` (flat indices
    into x) held at each row of ``values`` in turn, each solve starting from the last.
    Traces a path through a snap-through that force or drive control would jump (the
    Kresling tower's energy barrier, docs/mechanics.md)."""
    dofs = np.asarray(dofs, int)
    free = model.free.copy()
    free[dofs] = False
    x = np.array(model.nodes if x0 is None else x0, float)
    out = []
    for v in np.atleast_2d(np.asarray(values, float).T).T:
        x.reshape(-1)[dofs] = v
        eq = equilibrium(model, x, hinge_k, hinge_rest, free=free, max_iter=max_iter)
        x = np.array(eq.x)
        out.append(eq)
    return out


def _descent(Hf, gf: np.ndarray) -> np.ndarray:
    """-H^-1 g, shifted (H + mu I) until it is a descent direction."""
    scale = float(np.abs(Hf.diagonal()).mean()) or 1.0
    mu = 0.0
    eye = sp.identity(Hf.shape[0], format="csc")
    import warnings

    for _ in range(30):
        with warnings.catch_warnings():
            warnings.simplefilter("error", MatrixRankWarning)
            try:
                d = spsolve(Hf + mu * eye if mu else Hf, -gf)
                ok = np.isfinite(d).all() and float(gf @ d) < 0
            except (MatrixRankWarning, RuntimeError):
                ok = False
        if ok:
            return d
        mu = 1e-8 * scale if mu == 0 else 10.0 * mu
    return -gf / scale


@dataclass(frozen=True, eq=False)
class CompliantSolution:
    """The equilibrium path. Solved at the times ``grid`` (n_g,): each hinge's rest angle
    ``rest`` and stiffness ``stiffness`` (N mm/rad), node positions ``x`` (n_g, n, 3), each
    panel's largest bar strain ``panel_strain`` (n_g, n_panels) and largest diagonal fold
    ``panel_bending`` (rad), the energy (N mm), the Newton iterations and the steps that
    needed splitting. ``times``/``angles`` (n_t, n_hinges): the fold angles on the run's
    full time grid, each the drive's rest angle plus the equilibrium's departure from it
    interpolated linearly between solved times (exact at them), piecewise linear between
    ``times`` like the loop tracker's; ``variation`` their cumulative total variation."""

    model: BarHinge
    grid: np.ndarray
    rest: np.ndarray
    stiffness: np.ndarray
    x: np.ndarray
    panel_strain: np.ndarray
    panel_bending: np.ndarray
    energy: np.ndarray
    iterations: int
    splits: int
    unconverged: tuple[float, ...]
    times: np.ndarray
    angles: np.ndarray
    variation: np.ndarray
    strain_limit: float = 0.01  # the mechanics data's panel_strain_limit (check: FP190/191)

    @property
    def grid_angles(self) -> np.ndarray:
        """(n_g, n_hinges) the equilibrium's fold angles at the solved times."""
        return np.array([self.model.hinge_angles(x) for x in self.x])

    def at(self, t) -> np.ndarray:
        """Fold angles (n, n_hinges) at ``t``, piecewise linear between ``times``."""
        t = np.atleast_1d(np.asarray(t, float))
        g = self.times
        if len(g) == 1:
            return np.repeat(self.angles[:1], len(t), axis=0)
        k = np.clip(np.searchsorted(g, t, side="right") - 1, 0, len(g) - 2)
        f = np.clip((t - g[k]) / (g[k + 1] - g[k]), 0.0, 1.0)[:, None]
        return self.angles[k] + f * (self.angles[k + 1] - self.angles[k])

    def total_variation(self, t) -> np.ndarray:
        """Cumulative total variation (n, n_hinges) of the piecewise linear angles."""
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 1)
        return self.variation[k] + np.abs(self.at(t) - self.angles[k])

    @property
    def max_strain(self) -> float:
        return float(self.panel_strain.max(initial=0.0))

    @property
    def max_bending(self) -> float:
        return float(self.panel_bending.max(initial=0.0))


def hinge_stiffnesses(design: Design, drive: HingeDrive, times, params: MechanicsParams) -> np.ndarray:
    """(n_t, n_hinges) rotational stiffness (N mm/rad) of each hinge at ``times``: its
    material's relaxation modulus at the load time (:func:`.stiffness.hinge_modulus`) at the
    hinge's mean temperature (the recovery model's heat conduction) and Tg (its curve's: a
    Monte-Carlo sample's own), over its strip's width w = R |rho_target| (at least its thickness)."""
    t = np.atleast_1d(np.asarray(times, float))
    out = np.zeros((len(t), len(design.hinges)))
    lib = drive.library
    for i, (h, c) in enumerate(zip(design.hinges, drive.curves)):
        temp = np.interp(t, c.t, c.mean_temperature_c, left=c.initial_c)
        curve = params.curve(h.material)
        E = hinge_modulus(viscoelastic(lib[h.material]), temp, c.tg_c, curve)
        out[:, i] = hinge_stiffness(E, h.length, h.thickness, max(h.width, h.thickness), curve.poisson)
    return out


def adaptive_grid(times: np.ndarray, rest: np.ndarray, logk: np.ndarray) -> np.ndarray:
    """Indices of ``times`` to solve at: the first, the last, and each time some rest
    angle moved more than ``GRID_ANGLE_RAD`` or some log stiffness more than
    ``GRID_LOG_K`` since the last one kept."""
    keep = [0]
    for i in range(1, len(times)):
        j = keep[-1]
        if (np.abs(rest[i] - rest[j]).max(initial=0.0) > GRID_ANGLE_RAD
                or np.abs(logk[i] - logk[j]).max(initial=0.0) > GRID_LOG_K):
            if i - 1 > j:
                keep.append(i - 1)  # the step just before the threshold: steps stay under it
            if np.abs(rest[i] - rest[keep[-1]]).max(initial=0.0) > GRID_ANGLE_RAD or \
                    np.abs(logk[i] - logk[keep[-1]]).max(initial=0.0) > GRID_LOG_K:
                keep.append(i)
    if keep[-1] != len(times) - 1:
        keep.append(len(times) - 1)
    return np.array(sorted(set(keep)))


def initial_positions(design: Design, model: BarHinge, angles: np.ndarray) -> np.ndarray:
    """Node positions of the panels placed rigidly by ``angles`` (point hinges down the
    spanning tree); a node shared by panels takes their mean."""
    poses = forward(design, np.asarray(angles, float)[None], HingeModel.POINT)[0]
    acc = np.zeros_like(model.nodes)
    cnt = np.zeros(len(model.nodes))
    for p, nodes in enumerate(model.panel_nodes):
        acc[nodes] += model.nodes[nodes] @ poses[p, :3, :3].T + poses[p, :3, 3]
        cnt[nodes] += 1
    return acc / np.maximum(cnt, 1)[:, None]


def solve_path(design: Design, drive: HingeDrive, times, model: BarHinge | None = None,
               params: MechanicsParams | None = None) -> CompliantSolution:
    """The equilibrium at every time of an adaptive grid over ``times``."""
    params = params or default_params()
    model = model or build(design, params)
    times = np.asarray(times, float)
    rest_all = drive.driven(times)
    k_all = hinge_stiffnesses(design, drive, times, params)
    idx = adaptive_grid(times, rest_all, np.log(k_all))
    grid, rest, kk = times[idx], rest_all[idx], k_all[idx]
    x = initial_positions(design, model, rest[0])
    xs, iters, splits, bad = [], 0, 0, []
    prev = (rest[0], kk[0])
    # its cost is estimated ahead (solve_cost) for steps that converge; steps that split
    # are known only as they come (a 4-panel strip with a 0.01 mm panel folded to 179.99
    # deg: 3,112 Newton iterations, 47 splits, 38 CPU-s): bounded here, at the time budget
    tick = narrow_deadline(f"{source_of(design)}the bar-and-hinge equilibrium path", "use --mechanics rigid")
    for n in range(len(grid)):
        if bad:  # the path stopped: the structure holds where the last solve left it
            xs.append(x)
            continue
        where = (f"solved to {float(grid[n - 1]) if n else 0.0:.3g} s of {float(grid[-1]):.3g} s, {iters} Newton "
                 f"iterations, {splits} split steps before it")
        x, it, sp_, ok = _step(model, x, prev, (rest[n], kk[n]), tick=lambda where=where: tick(where))
        iters, splits = iters + it, splits + sp_
        if not ok:
            bad.append(float(grid[n]))
        xs.append(x)
        prev = (rest[n], kk[n])
    return _solution(model, grid, rest, kk, np.array(xs), iters, splits, bad, params.panel_strain_limit,
                     times, rest_all)


def _step(model: BarHinge, x, start, end, depth: int = 0, tick=None):
    """Equilibrium at ``end`` (rest, k) from ``x`` (in equilibrium at ``start``), halving
    the increment when Newton fails. A first half that fails even at the deepest halving
    ends the step (failed): solving its second half from a state out of equilibrium would
    only repeat the failure, at 2^MAX_SPLIT solves per step. ``tick()`` before each solve
    (the time budget's deadline)."""
    if tick is not None:
        tick()
    eq = equilibrium(model, x, end[1], end[0])
    if eq.converged or depth >= MAX_SPLIT:
        return eq.x, eq.iterations, 0, eq.converged
    mid = tuple(0.5 * (a + b) for a, b in zip(start, end))
    xm, i1, s1, ok1 = _step(model, x, start, mid, depth + 1, tick)
    if not ok1:
        return xm, eq.iterations + i1, 1 + s1, False
    xe, i2, s2, ok2 = _step(model, xm, mid, end, depth + 1, tick)
    return xe, eq.iterations + i1 + i2, 1 + s1 + s2, ok2


def _solution(model, grid, rest, kk, X, iters, splits, bad, limit, times, rest_all) -> CompliantSolution:
    n_p = len(model.panel_nodes)
    strain = np.zeros((len(grid), n_p))
    bend = np.zeros((len(grid), n_p))
    angles = np.zeros((len(grid), model.n_hinges))
    energy = np.zeros(len(grid))
    inner = model.bar_panel >= 0
    bpanel = model.spring_panel[~model.fold]
    for n, x in enumerate(X):
        angles[n] = model.hinge_angles(x)
        e = np.abs(model.bar_strain(x))
        np.maximum.at(strain[n], model.bar_panel[inner], e[inner])
        if len(bpanel):
            np.maximum.at(bend[n], bpanel, np.abs(model.bending(x)))
        energy[n] = model.energy(x, kk[n], rest[n], hessian=False)[0]
    dev = stretch(angles, rest)  # within pi of the rest angle: a flat fold's springs may straddle +-pi
    full = rest_all + np.stack([np.interp(times, grid, dev[:, h]) for h in range(model.n_hinges)], axis=1) \
        if model.n_hinges else np.zeros((len(times), 0))
    var = np.vstack([np.zeros((1, model.n_hinges)), np.cumsum(np.abs(np.diff(full, axis=0)), axis=0)])
    out = CompliantSolution(model, grid, rest, kk, X, strain, bend, energy, iters, splits, tuple(bad),
                            np.array(times, float), full, var, float(limit))
    for a in (out.grid, rest, kk, X, strain, bend, energy, out.times, full, var):
        a.setflags(write=False)
    return out


class CompliantDrive(HingeDrive):
    """A hinge drive whose angles are the bar-and-hinge equilibrium's (see module doc).
    The rigid loop solver is not used: loops close through the compliant panels."""

    compliant = True

    def __init__(self, design: Design, bath_c: float | None = None, library: MaterialLibrary | None = None,
                 curves=None, *, params: MechanicsParams | None = None, panel_modulus_mpa: float | None = None):
        super().__init__(design, bath_c, library, curves)
        self.loops = None
        self.params = params or default_params()
        try:
            self.model = build(design, self.params, panel_modulus_mpa)
        except ValueError as exc:  # pragma: no cover - triangulation failure of a valid panel
            raise DesignError(f"{design.name}: bar-and-hinge model: {exc}") from None
        self._paths: dict = {}  # arrest set -> solution; shared with copies (simulate arrests on a copy)

    def solve(self, times=None) -> CompliantSolution:
        """The equilibrium path covering ``times`` and the design's duration (on the
        drive's current arrests); solved once per grid and arrest set."""
        t = np.atleast_1d(np.asarray(times if times is not None else [0.0], float))
        end = max(float(t.max(initial=0.0)), float(self.design.process.duration_s))
        key = tuple(sorted(self.frozen_at.items()))
        sol = self._paths.get(key)
        if sol is not None and sol.times[-1] >= end - 1e-12:
            return sol
        step = min(0.01, float(np.diff(np.unique(t)).min(initial=0.01)))
        grid = np.union1d(np.arange(0.0, end + step / 2, step), t[t >= 0])
        self._paths[key] = sol = solve_path(self.design, self, grid, self.model, self.params)
        return sol

    def angles(self, t) -> np.ndarray:
        return self.solve(t).at(t)

    def variation(self, t) -> np.ndarray:
        return self.solve(t).total_variation(t)
