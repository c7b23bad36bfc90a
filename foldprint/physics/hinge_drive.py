"""The hinge drive: each hinge's angle over continuous time, from its recovery curve, its
shape fixity and the arrests of a fold (:class:`HingeDrive`), with loops the closed angles
nearest the drive; the simulation's times, the loops of many drives of one design tracked
in lockstep, and :func:`simulate_kinematics` (angles and poses over time, with the arc
model's loop gap). The hinge frames, maps and forward kinematics it folds are in
:mod:`foldprint.physics.kinematics`.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from ..core.constants import DEFAULT_DT_S, FOLD_LEVEL, ONSET_LEVEL
from ..core.errors import DesignError
from ..core.jit import use_kernels
from ..core.modes import DEFAULT_HINGE_MODEL, HingeModel
from ..model.design import Design, has_loops
from ..model.materials import MaterialLibrary, default_library
from .kinematics import (HINGE_MODELS, Trajectory, forward, hinge_frames, kernels, local_transforms,
                         target_angles)
from .loops.closure import LoopSolution, LoopSolver
from .recovery.curve import RecoveryCurve, recovery_curve

#: time step of the loop solver's continuation grid (s)
LOOP_DT = 0.01
#: grid times closer than this to a simulation time are that time (arange against linspace), s
GRID_TOL_S = 1e-9


def hinge_fixities(design: Design, library: MaterialLibrary | None = None) -> np.ndarray:
    """Each hinge's shape fixity (n_hinges,): its own ``fixity``, else its material's
    (:attr:`foldprint.model.materials.Material.shape_fixity`, measured or the default)."""
    lib = library or default_library()
    return np.array([float(h.fixity) if h.fixity is not None else lib[h.material].shape_fixity
                     for h in design.hinges])


class HingeDrive:
    """Continuous-time hinge angles: evaluates rho_i(t) at any times (used by the
    trajectory and by the collision refinement between samples)."""

    #: True for a drive whose angles come from a compliant (bar-and-hinge) equilibrium
    #: (:class:`foldprint.physics.barhinge.equilibrium.CompliantDrive`)
    compliant = False

    def __init__(self, design: Design, bath_c: float | None = None,
                 library: MaterialLibrary | None = None, curves=None, *, stack: np.ndarray | None = None,
                 statics: tuple[np.ndarray, np.ndarray] | None = None):
        """Nominal recovery curves of each hinge's material, thickness and the bath, or
        the given ``curves`` (one :class:`~foldprint.physics.recovery.curve.RecoveryCurve` per hinge, in
        ``design.hinges`` order: e.g. a scattered sample from :mod:`foldprint.simulation.robust`).
        ``stack``: the curves' ratios already stacked (n_grid, n_hinges) on their common
        grid, ``statics``: (target angles, fixities) of this design and library (a
        Monte-Carlo chunk's drives share them, :meth:`statics`)."""
        self.design = design
        self.bath_c = float(design.process.bath_temperature_c if bath_c is None else bath_c)
        lib = library or default_library()
        self.library = lib  # the materials of the hinges (their viscoelastic models: barhinge)
        if curves is None:
            curves = [recovery_curve(lib[h.material], self.bath_c, h.thickness,
                                     design.process.fix_temperature_c) for h in design.hinges]
        elif len(curves) != len(design.hinges):
            raise DesignError(f"{len(curves)} recovery curves for {len(design.hinges)} hinges")
        self.curves = list(curves)
        self.target, self.fixity = statics if statics is not None else (target_angles(design),
                                                                          hinge_fixities(design, lib))
        self.frozen_at: dict[int, float] = {}  # hinge index -> time it was arrested
        # loops (rigid origami): angles() gives the closed angles nearest the drive
        self.loops = LoopSolver(hinge_frames(design), [h.id for h in design.hinges]) \
            if has_loops(design) else None
        self._solution: LoopSolution | None = None
        self._solved_for: tuple | None = None

        # every curve lives on the same internal grid: stack them for one fused lookup
        self._grid = self.curves[0].t if self.curves else np.zeros(1)
        if stack is not None and not self.curves and stack.shape[-1] == 0:
            self._stack = None  # a design without hinges: a chunk's empty stack holds nothing
        elif stack is not None:
            if stack.shape != (len(self._grid), len(self.curves)):
                raise DesignError(f"a stack of ratios {stack.shape} for {len(self.curves)} curves "
                                  f"on {len(self._grid)} grid times")
            self._stack = stack
        elif all(c.t is self._grid or np.array_equal(c.t, self._grid) for c in self.curves):
            # hinge-major and read-only, as a Monte-Carlo chunk's stacks are: one compiled
            # signature of the drive's kernels for both (each costs compilation once)
            self._stack = np.stack([c.ratio for c in self.curves], axis=0).T if self.curves else None
            if self._stack is not None:
                self._stack.setflags(write=False)
        else:  # pragma: no cover - custom horizons
            self._stack = None

    def statics(self) -> tuple[np.ndarray, np.ndarray]:
        """(target angles, fixities): what another drive of this design and library shares."""
        return self.target, self.fixity

    def copy(self) -> "HingeDrive":
        """The same drive with no hinge arrested (shares the curves and the loop solver)."""
        import copy

        out = copy.copy(self)
        out.frozen_at = {}
        return out

    def ratios(self, t) -> np.ndarray:
        """Recovery ratios (n_t, n_hinges) at times ``t``; arrested hinges hold their value."""
        t = np.atleast_1d(np.asarray(t, float))
        n_h = len(self.curves)
        if n_h == 0:  # a single panel: a valid, trivial design
            return np.zeros((len(t), 0))
        if self._stack is not None and not self.frozen_at:
            return self._stacked(t)  # every hinge at the same times: one lookup for all columns
        tt = np.repeat(t[:, None], n_h, axis=1)
        for i, tf in self.frozen_at.items():
            tt[:, i] = np.minimum(t, tf)
        if self._stack is None:
            return np.stack([c(tt[:, i]) for i, c in enumerate(self.curves)], axis=1)
        return self._stacked(tt)

    def _stacked(self, tt: np.ndarray) -> np.ndarray:
        """The stacked curves interpolated at times ``tt``: (n_t,), the same for every hinge,
        or (n_t, n_hinges), a time per hinge (the same numbers either way); R = 0 before 0."""
        g = self._grid
        if tt.ndim == 1 and use_kernels():
            return kernels().stacked_at(g, self._stack, np.ascontiguousarray(tt, float))
        tc = np.clip(tt, g[0], g[-1])
        k = np.clip(np.searchsorted(g, tc, side="right") - 1, 0, len(g) - 2)
        f = (tc - g[k]) / (g[k + 1] - g[k])
        if tt.ndim == 1:
            lo, hi, f, tt = self._stack[k], self._stack[k + 1], f[:, None], tt[:, None]
        else:
            cols = np.arange(tt.shape[1])[None, :]
            lo, hi = self._stack[k, cols], self._stack[k + 1, cols]
        r = lo + (hi - lo) * f  # monotone in t (the bound needs it)
        return np.where(tt < 0, 0.0, r)

    def driven(self, t) -> np.ndarray:
        """rho(t) = rho_target (1 - (1 - R(t)) f), (n_t, n_hinges) rad: what each hinge's
        material asks for on its own; one compiled pass where :meth:`ratios` is this
        class's, with no arrest (the same numbers)."""
        t = np.atleast_1d(np.asarray(t, float))
        if type(self).ratios is HingeDrive.ratios and self._one_pass(t):
            return kernels().ratios_driven(self._grid, self._stack, np.ascontiguousarray(t), self.target,
                                           self.fixity)[1]
        r = self.ratios(t)
        return self.target[None] * (1.0 - (1.0 - r) * self.fixity[None])

    def _one_pass(self, t: np.ndarray) -> bool:
        """Whether the compiled ``ratios_driven`` reads this drive at times ``t`` (one time
        per row, stacked curves, no arrest, kernels on)."""
        return t.ndim == 1 and not self.frozen_at and self._stack is not None and len(self.curves) > 0 and \
            use_kernels()

    def ratios_and_driven(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`ratios`, :meth:`driven`) at times ``t``, the ratios read once: one
        compiled pass for a plain drive with no arrest (the same numbers)."""
        plain = type(self).ratios is HingeDrive.ratios and type(self).driven is HingeDrive.driven
        if plain and self._one_pass(np.asarray(t, float)):
            return kernels().ratios_driven(self._grid, self._stack, np.ascontiguousarray(t, float), self.target,
                                           self.fixity)
        r = self.ratios(t)
        return r, (self.target[None] * (1.0 - (1.0 - r) * self.fixity[None]) if plain else self.driven(t))

    def level_times(self) -> tuple[tuple[float | None, ...], tuple[float | None, ...]]:
        """Each curve's (fold times, onset times) (:attr:`RecoveryCurve.fold_time`,
        ``onset_time``): read from the stacked curves by one compiled call for each level
        where the curves are plain :class:`RecoveryCurve` s (the same index, test and sums)."""
        if self._stack is not None and self.curves and use_kernels() and \
                all(type(c) is RecoveryCurve for c in self.curves):
            k = kernels()
            return tuple(tuple(None if math.isnan(x) else x for x in k.crossings(self._grid, self._stack, lv).tolist())
                         for lv in (FOLD_LEVEL, ONSET_LEVEL))
        return tuple(c.fold_time for c in self.curves), tuple(c.onset_time for c in self.curves)

    def angles_at(self, t: float) -> np.ndarray:
        """:meth:`angles` at one time, (1, n_hinges): the same numbers, by one compiled call
        for a hinge tree's plain drive (no arrest), where the narrow phase asks for the
        poses of one split time after another."""
        tables = self.compiled_tables()
        if tables is not None:
            return kernels().driven_at(*tables[:2], float(t), *tables[2:])
        return self.angles([t])

    def compiled_tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """(grid, stacked ratios, target angles, fixities): what the compiled ``driven_at``
        reads to give :meth:`angles` at any time, for a hinge tree's plain drive with no
        arrest where the kernels run; else None (the angles need this object's methods)."""
        if (self.loops is None and not self.frozen_at and self._stack is not None and type(self).angles is
                HingeDrive.angles and type(self).driven is HingeDrive.driven and use_kernels()):
            return self._grid, self._stack, self.target, self.fixity
        return None

    def angles(self, t) -> np.ndarray:
        """Fold angles (n_t, n_hinges) rad: the driven angles for a hinge tree; with loops
        the closed angles nearest the drive (:mod:`foldprint.physics.loops.closure`), piecewise linear
        between the solve grid's times."""
        if self.loops is None:
            return self.driven(t)
        t = np.atleast_1d(np.asarray(t, float))
        sol = self.solve_loops(t)
        return sol.at(t)

    def variation(self, t) -> np.ndarray:
        """Cumulative total variation of each angle from 0 to t, (n_t, n_hinges) rad (the
        swept collision bound; equals |rho(t) - rho(0)| for monotone tree drives)."""
        if self.loops is None:
            return np.abs(self.driven(t) - self.driven([0.0]))
        t = np.atleast_1d(np.asarray(t, float))
        sol = self.solve_loops(t)
        return sol.total_variation(t)

    def solve_loops(self, times=None, dt: float = LOOP_DT) -> LoopSolution:
        """The loop solution on a grid of step ``dt`` covering ``times`` (and holding
        ``times`` exactly); re-solved when the grid no longer covers the request or an
        arrest changed the drive."""
        grid, key = self._loop_grid(times, dt)
        if grid is not None:
            self._solution = self.loops.track(grid, self.driven(grid))
            self._solved_for = key
        return self._solution

    def _loop_grid(self, times, dt: float):
        """The grid :meth:`solve_loops` solves on and its arrest key; grid None when the
        current solution already covers ``times``."""
        times = np.atleast_1d(np.asarray(times if times is not None else [0.0], float))
        end = max(float(times.max(initial=0.0)), float(self.design.process.duration_s))
        key = tuple(sorted(self.frozen_at.items()))
        sol = self._solution
        if sol is not None and self._solved_for == key and sol.times[-1] >= end - 1e-12:
            return None, key
        grid = np.arange(0.0, end + dt, dt)
        if sol is not None and self._solved_for == key:
            grid = np.union1d(grid, sol.times)
        grid, times = grid[grid <= end + 1e-12], np.unique(times[times >= 0])
        if len(times):  # a grid time this close to a requested one is that time in another rounding
            j = np.searchsorted(times, grid)
            gap = np.minimum(np.abs(grid - times[np.maximum(j - 1, 0)]), np.abs(grid - times[np.minimum(j, len(times) - 1)]))
            grid = grid[gap >= GRID_TOL_S]
        return np.union1d(grid, times), key


def run_times(design: Design, dt: float = DEFAULT_DT_S, duration: float | None = None) -> np.ndarray:
    """The times of a simulation of ``design`` at step ``dt`` (0, dt, ... to the first at
    or past the duration)."""
    dur = float(design.process.duration_s if duration is None else duration)
    if not (dur > 0 and dt > 0):
        raise DesignError(f"duration and dt must be > 0 s, got {dur} and {dt}")
    n = int(np.ceil(dur / dt - 1e-9)) + 1
    return np.linspace(0.0, (n - 1) * dt, n)


def loop_dt(times: np.ndarray) -> float:
    """The loop grid's step for a simulation at ``times``."""
    return min(LOOP_DT, float(np.diff(times).min(initial=LOOP_DT)))


def solve_loops_many(drives: Sequence[HingeDrive], times: np.ndarray) -> None:
    """:meth:`HingeDrive.solve_loops` of several drives of one design for a simulation at
    ``times``, their closures tracked in lockstep (:meth:`LoopSolver.track_many`: one
    array evaluation per round for all of them): what ``simulate_kinematics`` would then
    solve drive by drive, and the same answers. Drives without loops are left alone."""
    dt, fresh = loop_dt(times), {}
    todo = []
    for d in drives:
        if d.loops is None:
            continue
        if d._solution is None and not d.frozen_at:  # its grid: a function of the times and the duration
            dur = float(d.design.process.duration_s)
            todo.append((d, *(fresh[dur] if dur in fresh else fresh.setdefault(dur, d._loop_grid(times, dt)))))
        else:
            todo.append((d, *d._loop_grid(times, dt)))
    todo = [(d, g, k) for d, g, k in todo if g is not None]
    while todo:
        d0, g0, _ = todo[0]
        same = [(d, g, k) for d, g, k in todo if d.loops.n == d0.loops.n and (g is g0 or np.array_equal(g, g0))]
        drives_at = [d.driven(g0) for d, _, _ in same]
        for (d, _, k), sol in zip(same, d0.loops.track_many(g0, drives_at)):
            d._solution, d._solved_for = sol, k
        todo = [t for t in todo if not any(t[0] is d for d, _, _ in same)]


def simulate_kinematics(design: Design, times: np.ndarray | None = None, *, bath_c: float | None = None,
                        model: HingeModel = DEFAULT_HINGE_MODEL, dt: float = DEFAULT_DT_S, duration: float | None = None,
                        library: MaterialLibrary | None = None,
                        drive: HingeDrive | None = None) -> Trajectory:
    """Hinge angles and panel poses over time."""
    if model not in HINGE_MODELS:
        raise DesignError(f"hinge model must be one of {HINGE_MODELS}, got {model!r}")
    model = HingeModel(str(model))
    drive = drive or HingeDrive(design, bath_c, library)
    if times is None:
        times = run_times(design, dt, duration)
    times = np.asarray(times, float)
    tree = drive.loops is None and not drive.compliant
    ratios, driven = drive.ratios_and_driven(times) if tree else (drive.ratios(times), None)
    loop = None
    if drive.loops is not None or drive.compliant:
        if drive.loops is not None:
            loop = drive.solve_loops(times, loop_dt(times))
        if loop is not None:  # on its own grid (a simulation's times): the grid angles, read as they are
            angles = loop.at(times)
        else:
            angles = drive.angles(times)
        ratios = _reached(angles, ratios, drive.target, drive.fixity)
    else:  # a hinge tree's angles are what its hinges ask for: drive.driven(times)
        angles = driven
    poses = forward(design, angles, model, compiled=True) if loop is None else _held_forward(design, angles, model)
    if loop is not None and model == HingeModel.ARC:
        loop = _with_arc_gap(design, loop, angles, poses)
    for a in (times, ratios, angles, poses):
        a.setflags(write=False)
    return Trajectory(design, times, ratios, angles, poses, model, drive.bath_c, *drive.level_times(), loop)


def _reached(angles: np.ndarray, ratios: np.ndarray, target: np.ndarray, fixity: np.ndarray) -> np.ndarray:
    """The ratio each hinge actually reached (n_t, n_hinges): a hinge held back by its loops
    is not done. 1 - (1 - angle / target) / fixity, at most the drive's ratio, in [0, 1];
    the drive's ratio where the target is 0. One working array, the operations in place
    (the same numbers as the expression written out)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.divide(angles, target[None])
        np.subtract(1.0, a, out=a)
        np.divide(a, np.where(fixity > 0, fixity, 1.0)[None], out=a)
        np.subtract(1.0, a, out=a)
    np.minimum(a, ratios, out=a)
    np.clip(a, 0.0, 1.0, out=a)
    flat = target == 0
    if flat.any():
        a[:, flat] = ratios[:, flat]
    return a


def _held(angles: np.ndarray) -> np.ndarray:
    """Which rows of ``angles`` (n_t, n) differ from the row before (the first always)."""
    moved = np.ones(len(angles), bool)
    moved[1:] = np.any(angles[1:] != angles[:-1], axis=1)
    return moved


def _held_forward(design: Design, angles: np.ndarray, model: HingeModel) -> np.ndarray:
    """:func:`forward` of a pattern with loops, which holds its configuration wherever its
    drive stopped moving: the poses of each distinct configuration computed once (the
    same numbers)."""
    moved = _held(angles)
    return np.take(forward(design, angles[moved], model, compiled=True), np.cumsum(moved) - 1, axis=0)


def loop_gap_mm(design: Design, angles: np.ndarray, model: HingeModel = DEFAULT_HINGE_MODEL,
                poses: np.ndarray | None = None) -> float:
    """Largest distance (mm, over the times of ``angles`` (n_t, n_hinges)) between where a
    loop hinge's child-side edge lands through that hinge and where the spanning tree puts
    the child: 0 for a tree; for loops, the misfit of angles that do not close the loops
    (loop hinges turn about their fold lines, ``HingeFrame.centred``, so closed angles
    give round-off; docs/loops.md)."""
    angles = np.atleast_2d(np.asarray(angles, float))
    moved = _held(angles)  # a held configuration has the gap it had
    angles, poses = angles[moved], (forward(design, angles[moved], model, compiled=True) if poses is None
                                    else poses[moved])
    gap = 0.0
    for f in hinge_frames(design):
        if f.tree:
            continue
        loc = local_transforms(f, angles[:, f.index], model)
        via = poses[:, f.parent] @ loc
        for end in design.hinges[f.index].line:
            p = np.array([end[0], end[1], 0.0]) + (0.5 * f.width * f.normal if model == HingeModel.ARC else 0.0)
            a = via[:, :3, :3] @ p + via[:, :3, 3]
            b = poses[:, f.child, :3, :3] @ p + poses[:, f.child, :3, 3]
            gap = max(gap, float(np.linalg.norm(a - b, axis=1).max(initial=0.0)))
    return gap


def _with_arc_gap(design: Design, loop: LoopSolution, angles: np.ndarray, poses: np.ndarray) -> LoopSolution:
    """``loop`` with the arc model's gap of ``angles`` and ``poses``, computed when read."""
    from dataclasses import replace
    from functools import partial

    return replace(loop, gap=partial(loop_gap_mm, design, angles, HingeModel.ARC, poses))
