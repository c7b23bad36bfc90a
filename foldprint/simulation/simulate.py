"""Simulation: ROM kinematics + collision (paper index, FCL swept) + goals, with the
``stop`` or ``arrest`` behaviour after contact: one stage of the pipeline
(:mod:`foldprint.apps.pipeline` chains the stages)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..model.derived import scoped
from ..collision.index2d import Index2D, collision_index
from ..collision.swept3d import Contact
from ..collision.swept_search import checker_for, swept_first_contact
from . import costs
from ..core.constants import DEFAULT_DT_S, FOLD_LEVEL, tol
from ..model.design import Design, tree_order
from ..core.errors import DesignError
from ..core.jit import use_kernels
from ..collision.goals import GoalResult, evaluate_goals
from ..physics.kinematics import Trajectory
from ..physics.hinge_drive import HingeDrive, simulate_kinematics
from ..model.materials import MaterialLibrary
from ..core.modes import (DEFAULT_AFTER_CONTACT, DEFAULT_HINGE_MODEL, DEFAULT_MECHANICS, DEFAULT_METHOD, AfterContact,
                          HingeModel, Mechanics, Method, parse)
from ..physics.barhinge import solve_cost as barhinge_cost

if TYPE_CHECKING:  # the bar-and-hinge model (scipy.sparse, 0.3 CPU-s to import) loads when a run asks for it
    from ..physics.barhinge.equilibrium import CompliantSolution

METHODS = tuple(m.value for m in Method)
AFTER = tuple(m.value for m in AfterContact)


@dataclass(frozen=True, eq=False)
class SimulationResult:
    design: Design
    trajectory: Trajectory
    method: Method
    after_contact: AfterContact
    contacts: tuple[Contact, ...]  # in time order; the first is the first collision
    index2d: Index2D | None
    goals: tuple[GoalResult, ...]
    initial_contacts: tuple[Contact, ...] = ()
    arrested: dict = field(default_factory=dict)  # hinge id -> time frozen
    notes: tuple[str, ...] = ()  # what the run left out and why (e.g. the 2D index over the memory limit)
    compliant: CompliantSolution | None = None  # --mechanics bar-hinge: the equilibrium path
    #: the 3D broad phase's work on the first round (to the first contact): (group pair,
    #: interval)s its descent examined; a Monte-Carlo sample's cost is estimated from it
    broad_nodes: int = 0

    @property
    def first_collision(self) -> Contact | None:
        return self.contacts[0] if self.contacts else None

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays this result holds (trajectory, 2D index): what keeping it
        costs while another run allocates (:func:`foldprint.core.guards.holding`)."""
        parts = (self.trajectory, self.index2d)
        return sum(v.nbytes for p in parts if p is not None for v in vars(p).values() if isinstance(v, np.ndarray))

    @property
    def hinge_done(self) -> list[bool]:
        return [bool(r >= FOLD_LEVEL) for r in self.trajectory.ratios[-1]]

    @property
    def completed(self) -> bool:
        return (self.first_collision is None and all(self.hinge_done)
                and all(g.met for g in self.goals))

    @property
    def hinge_fold_times(self) -> tuple[float | None, ...]:
        """Per hinge, when its simulated recovery ratio reaches 98 % (s), None where it does
        not within the run. A hinge the fold leaves free follows its recovery curve (its
        simulated ratio is that curve at the steps), so its time is the curve's own 98 %
        time, exact and the same at any time step (the ``materials`` table's and the
        recipe's); a hinge held back (a loop's closure), which crosses in a later step than
        its curve, at the crossing of the ratio it reached, linear between the two steps."""
        traj = self.trajectory
        out: list[float | None] = []
        for i, (k, t) in enumerate(zip(*level_crossings(traj.times, traj.ratios, FOLD_LEVEL))):
            curve = traj.fold_times[i]
            if k < 0:
                out.append(None)
            elif curve is not None and (k == 0 or traj.times[k - 1] < curve) and curve <= traj.times[k]:
                out.append(float(curve))
            else:
                out.append(t)
        return tuple(out)

    @property
    def fold_time(self) -> float | None:
        """The fold time of record (s): when the last hinge reaches 98 %
        (:attr:`hinge_fold_times`), None if some hinge does not within the run. What
        ``simulate``, ``check``, the gallery, the viewer and ``robust``'s percentiles print
        (docs/simulation.md, "The fold time")."""
        ft = self.hinge_fold_times
        return None if None in ft else max(ft, default=0.0)

    def final_angle_error(self) -> np.ndarray:
        """|rho_target - rho_final| per hinge (rad)."""
        target = np.array([h.angle for h in self.design.hinges])
        return np.abs(target - self.trajectory.angles[-1])


def level_crossings(times: np.ndarray, ratios: np.ndarray, level: float) -> tuple[list[int], list[float]]:
    """Per column of ``ratios`` (n_t, n): the first step at which it reaches ``level`` (-1
    where it never does) and the crossing time, linear between that step and the one
    before (the first time where the first step already holds it; NaN where never). Every
    column in one array pass: the same steps and, element by element, the same sums."""
    times, ratios = np.asarray(times, float), np.asarray(ratios)
    n = ratios.shape[1]
    if len(times) == 0 or n == 0:
        return [-1] * n, [float("nan")] * n
    if ratios.dtype == np.float64 and len(times) == len(ratios) and use_kernels():
        from ..physics.kinematics_kernels import level_steps  # one compiled pass, row after row

        j, t = level_steps(times, np.ascontiguousarray(ratios), float(level))
        return j.tolist(), t.tolist()
    hit = ratios >= level
    j = hit.argmax(axis=0)
    reached = hit[j, np.arange(n)]
    i = np.maximum(j - 1, 0)
    r0, r1 = ratios[i, np.arange(n)], ratios[j, np.arange(n)]
    with np.errstate(divide="ignore", invalid="ignore"):  # the columns that never reach it, or reach it at 0
        f = (level - r0) / (r1 - r0)
        t = times[i] + f * (times[j] - times[i])
    t = np.where(j == 0, times[0], t)
    return (np.where(reached, j, -1).tolist(), np.where(reached, t, np.nan).tolist())


def crossing_times(result: SimulationResult, level: float) -> np.ndarray:
    """Per hinge, the first time (s) its simulated recovery ratio reaches ``level``
    (linear between samples); NaN where it never does. At 98 % the fold time of record is
    :attr:`SimulationResult.hinge_fold_times`."""
    return np.array(level_crossings(result.trajectory.times, result.trajectory.ratios, level)[1])


def _first_2d(traj: Trajectory, drive: HingeDrive, t_start: float,
              skip: set) -> tuple[Contact | None, Index2D]:
    idx = collision_index(traj)
    hit = idx.contact & ~idx.adjacent[None]
    for k, pair in enumerate(idx.pairs.tolist()):
        if tuple(pair) in skip:
            hit[:, k] = False
    hit[traj.times < t_start - tol.time_eps] = False
    rows = np.nonzero(hit.any(axis=1))[0]
    if len(rows) == 0:
        return None, idx
    k = int(rows[0])
    p = int(np.nonzero(hit[k])[0][0])
    i, j = idx.pairs[p]
    ids = (traj.design.panels[i].id, traj.design.panels[j].id)
    if k > 0 and traj.times[k - 1] >= t_start:  # bisect between the two samples
        t = _bisect_2d(traj, drive, (int(i), int(j)), traj.times[k - 1], traj.times[k])
    else:
        t = float(traj.times[k])
    return Contact(t, (int(i), int(j)), ids, (float("nan"),) * 3, 0.0, Method.INDEX2D), idx


def _bisect_2d(traj: Trajectory, drive: HingeDrive, pair, lo: float, hi: float) -> float:
    from ..collision.index2d import index_arrays, paper_contact, world_side_segments
    from ..physics.kinematics import forward

    i, j = pair
    for _ in range(30):
        if hi - lo < tol.time / 10:  # finer than the 3D check's refinement
            break
        mid = 0.5 * (lo + hi)
        poses = forward(traj.design, drive.angles([mid]), traj.model)
        segs = world_side_segments(traj.design, poses, traj.model)
        a, b = segs[i][0], segs[j][0]
        si, sj, _, coll = index_arrays(a[:, None, 0], a[:, None, 1], b[None, :, 0], b[None, :, 1])
        if (paper_contact(si, sj) | coll).any():
            hi = mid
        else:
            lo = mid
    return float(hi)


def _path_hinges(design: Design, a: int, b: int) -> list[int]:
    """Hinge indices on the tree path between panels a and b."""
    idx = {h.id: k for k, h in enumerate(design.hinges)}
    parent = {}
    pidx = design.panel_index()
    for h, p, c in tree_order(design):
        parent[pidx[c]] = (pidx[p], idx[h.id])

    def up(x):
        out = []
        while x in parent:
            p, hk = parent[x]
            out.append((x, hk))
            x = p
        return out

    ua, ub = up(a), up(b)
    anc_a = [a] + [parent[x][0] for x, _ in ua]
    anc_b = [b] + [parent[x][0] for x, _ in ub]
    lca = next(x for x in anc_a if x in anc_b)
    path = [hk for x, hk in ua if anc_a.index(x) < anc_a.index(lca)]
    path += [hk for x, hk in ub if anc_b.index(x) < anc_b.index(lca)]
    return path


def _run_drive(design: Design, bath_c, library, drive: HingeDrive | None, mechanics: Mechanics) -> HingeDrive:
    """This run's own drive: the nominal one, a copy of the given one (arrests go to the
    copy), or for ``bar-hinge`` a compliant drive (on the given drive's curves)."""
    if mechanics == Mechanics.BAR_HINGE and not (drive is not None and drive.compliant):
        from ..physics.barhinge.equilibrium import CompliantDrive

        barhinge_cost.check_mechanics(design)
        drive = CompliantDrive(design, bath_c if drive is None else drive.bath_c, library,
                               None if drive is None else drive.curves)
    if drive is None:
        return HingeDrive(design, bath_c, library)
    if drive.frozen_at:
        raise DesignError("simulate needs a fresh HingeDrive (this one has arrested hinges)")
    return drive.copy()  # arrests go to this run's copy: the caller's drive is left as given


@scoped
def simulate(design: Design, *, bath_c: float | None = None, duration: float | None = None,
             dt: float = DEFAULT_DT_S, method: Method | str = DEFAULT_METHOD,
             hinge_model: HingeModel | str = DEFAULT_HINGE_MODEL,
             after_contact: AfterContact | str = DEFAULT_AFTER_CONTACT,
             library: MaterialLibrary | None = None, drive: HingeDrive | None = None,
             progress=None, mechanics: Mechanics | str = DEFAULT_MECHANICS) -> SimulationResult:
    """Run the ROM and the collision check(s).

    ``hinge_model``: ``arc`` (default: the printed hinges, :class:`~foldprint.core.modes.HingeModel`)
    or ``point`` (the paper's Eq. 2-4). ``method``: "index2d" (the paper's index; planar
    strips only), "fcl" (3D swept) or "both" (index2d only where the design is a planar
    strip). ``after_contact``: "stop" keeps the kinematic trajectory and reports the first
    contact; "arrest" freezes the hinges on the tree path between two touching panels from
    the contact on and goes on. ``drive``: the hinges' recovery (default: the nominal
    curves of each hinge's material; :mod:`foldprint.simulation.robust` passes scattered ones).
    ``mechanics``: ``bar-hinge`` folds the bar-and-hinge model's equilibrium (a given rigid
    drive's curves are kept); a given compliant drive is used as it is.
    """
    method = parse(Method, method, "method")
    notes: list[str] = []
    skip2d = costs.index2d_skip_reason(design, dt, duration) if (
        method == Method.BOTH and design.is_planar_strip) else None
    if skip2d:
        notes.append(skip2d)
    # refuse before allocating
    costs.check_simulation(design, dt, duration, Method.FCL if skip2d else method)
    after_contact = parse(AfterContact, after_contact, "after_contact")
    hinge_model = parse(HingeModel, hinge_model, "hinge_model")
    use2d = method in (Method.INDEX2D, Method.BOTH) and design.is_planar_strip and not skip2d
    if method == Method.INDEX2D and not design.is_planar_strip:
        raise DesignError(f"{design.name}: the paper's 2D collision index needs a planar strip "
                          "(every fold line parallel to y); use --method fcl")
    use3d = method in (Method.FCL, Method.BOTH)
    drive = _run_drive(design, bath_c, library, drive, parse(Mechanics, mechanics, "mechanics"))
    contacts: list[Contact] = []
    skip: set = set()
    initial: list[Contact] = []
    checker = checker_for(design, hinge_model, drive) if use3d else None
    t_start = 0.0
    idx2d = None
    nodes = 0
    for _round in range(len(design.hinges) + 1):
        traj = simulate_kinematics(design, bath_c=drive.bath_c, model=hinge_model, dt=dt,
                                   duration=duration, drive=drive)
        found: list[Contact] = []
        if use2d:
            c2, idx2d = _first_2d(traj, drive, t_start, skip)
            if c2:
                found.append(c2)
        if use3d:
            c3, init = swept_first_contact(checker, traj.times, traj.angles, traj.poses, t_start, skip)
            if _round == 0:
                initial, nodes = init, checker.n_broad_nodes
                skip |= {c.pair for c in init}
            if c3:
                found.append(c3)
        if progress:
            progress(_round)
        if not found:
            break
        first = min(found, key=lambda c: c.time)
        contacts.append(first)
        if after_contact == AfterContact.STOP:
            break
        for k in _path_hinges(design, *first.pair):
            drive.frozen_at.setdefault(k, first.time)
        skip.add(first.pair)
        t_start = first.time
    goals = evaluate_goals(design, traj.times, traj.poses)
    arrested = {design.hinges[k].id: t for k, t in drive.frozen_at.items()}
    return SimulationResult(design, traj, method, after_contact, tuple(contacts), idx2d, tuple(goals),
                            tuple(initial), arrested, tuple(notes),
                            drive.solve(traj.times) if drive.compliant else None, nodes)
