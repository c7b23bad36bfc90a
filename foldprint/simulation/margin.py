"""Is the nominal fold's smallest clearance larger than what scatter moves the panels?

A nominal fold that completes may pass two panels within a hair of each other; a printed
part, whose hinges differ from nominal, then touches. :func:`scatter_margin` folds the
first :data:`~foldprint.core.constants.MARGIN_SAMPLES` samples that ``foldprint check``
draws (the same scatter model and seed: :func:`~foldprint.simulation.scatter.draw_samples`
gives the first k of n samples whatever n is) along the same time grid as the nominal
fold, kinematically (through contacts: a sample is not stopped where it touches), and
measures each one's closest approach between non-adjacent panels (exact FCL distances at
the sampled poses, :func:`foldprint.collision.clearance.min_clearance`; 0 where panels
overlap). What scatter moves the panels is how much it shrinks the closest approach:
``motion`` = nominal clearance - the smallest closest approach of the samples. The fold is
*marginal* when that closes the gap: some sample's panels come within the contact
tolerance.

Why samples and not a derivative: the per-pair clearance's linear sensitivity to the
per-hinge spreads, taken at a fixed time, counts a hinge that runs early as motion and
called every template marginal (``helix_graded``, whose 80 check samples never collide,
at 2 sd: 35 mm of motion against a 24 mm gap at 4.3 s); taken at each pair's closest
approach (where the time derivative vanishes, so the clock drops out) it is blind to a
swapped order (``octagon_stack``'s closest approach is in the final state, which scatter
does not move, yet check jams 71 % of its samples when two flaps swap). The closest
approach of scattered folds sees both, and is the check's own model. It is a screen, not
an estimate: ``foldprint check`` gives the jam probability (its samples include these).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..collision.clearance import Gap, min_clearance, sampled_poses
from ..collision.swept3d import SweptChecker
from ..collision.broadphase import count_non_adjacent_pairs
from ..core.constants import CHECK_SEED, CLEARANCE_SAMPLES, MARGIN_MAX_PAIRS, MARGIN_SAMPLES, tol
from ..model.hinge_graph import has_loops
from ..model.materials import MaterialLibrary
from ..physics.hinge_drive import simulate_kinematics, solve_loops_many
from ..physics.recovery.batch import MAX_BATCH_ELEMENTS, N_LAYERS, grid_until
from .robust import curves_at_once, sample_drives
from .scatter import Scatter, draw_samples
from .simulate import SimulationResult


@dataclass(frozen=True)
class ScatterMargin:
    """The nominal fold's smallest ``clearance`` (mm) against the closest approach of
    ``samples`` scattered folds (``seed``): ``closest`` (mm, per sample), the smallest of
    them (``worst``: its panels, time and distance). ``motion``: how much scatter shrinks
    the closest approach (mm); ``marginal``: some sample's panels touch."""

    clearance: float
    samples: int
    seed: int
    closest: tuple[float, ...]
    worst: Gap

    @property
    def motion(self) -> float:
        return max(0.0, self.clearance - self.worst.distance)

    @property
    def touching(self) -> int:
        """How many of the samples bring two panels within the contact tolerance."""
        return sum(c <= tol.contact for c in self.closest)

    @property
    def marginal(self) -> bool:
        return self.touching > 0

    def to_json(self) -> dict:
        w = self.worst
        return {"samples": self.samples, "seed": self.seed, "touching": self.touching,
                "marginal": self.marginal, "motion_mm": round(self.motion, 4),
                "closest_mm": [round(float(c), 4) for c in self.closest],
                "worst": {"panels": list(w.panels), "time_s": None if w.time is None else round(float(w.time), 4),
                          "distance_mm": round(float(w.distance), 4)}}


#: bytes per element (hinge x time x layer) of a recovery batch's working arrays (the
#: temperatures, rates, reduced times, relaxation terms and their temporaries): measured
#: 69 B at MAX_BATCH_ELEMENTS (tracemalloc, the margin screen of a 150-panel strip), 72
#: counted
BATCH_BYTES_PER_ELEMENT = 72


def margin_batch_bytes(design, until_s: float, k: int) -> float:
    """Bytes the recovery curves of ``k`` samples hold while they are made: the curves
    (:func:`~foldprint.simulation.robust.curves_at_once`) and the batch's working arrays
    (:data:`BATCH_BYTES_PER_ELEMENT` per hinge, time and layer, at most
    :data:`~foldprint.physics.recovery.batch.MAX_BATCH_ELEMENTS` elements at once)."""
    n_t = len(grid_until(until_s))
    elements = min(k * len(design.hinges) * n_t * N_LAYERS // 2, MAX_BATCH_ELEMENTS)
    return curves_at_once(design, until_s, k)[1] + BATCH_BYTES_PER_ELEMENT * elements


def screened_poses(design) -> int | None:
    """How many poses a scattered fold of the screen is made at: the clearance search's
    :data:`~foldprint.core.constants.CLEARANCE_SAMPLES` for a fold without loops (the same
    poses, a 10th of a 2001-step trajectory), None (every step) for one with loops, whose
    closure is tracked step by step."""
    return None if has_loops(design) else CLEARANCE_SAMPLES


def left_out(design, mechanics=None) -> str | None:
    """Why the screen is not run on ``design``: more non-adjacent panel pairs than
    :data:`~foldprint.core.constants.MARGIN_MAX_PAIRS` (its exact searches would take
    minutes), or a pattern with loops folded with ``mechanics`` bar-hinge (the screen's
    scattered folds are rigid: their loop closure is not the compliant fold's, and
    tracking it for a large sheet costs minutes), or None."""
    if str(mechanics) == "bar-hinge" and has_loops(design):
        return ("the scatter margin screen is left out under --mechanics bar-hinge for a pattern with loops (its "
                "scattered folds are rigid); `foldprint check --mechanics bar-hinge` gives the jam probability")
    pairs = count_non_adjacent_pairs(design)
    if pairs <= MARGIN_MAX_PAIRS:
        return None
    return (f"the scatter margin screen is left out: {pairs:,} non-adjacent panel pairs, over the "
            f"{MARGIN_MAX_PAIRS:,} it searches in {MARGIN_SAMPLES} scattered folds; `foldprint check` gives the "
            "jam probability")


def scatter_margin(result: SimulationResult, clearance: Gap, checker: SweptChecker, scatter: Scatter,
                   library: MaterialLibrary, samples: int = MARGIN_SAMPLES,
                   seed: int = CHECK_SEED, batch: int | None = None) -> ScatterMargin:
    """The closest approach of ``samples`` scattered folds of ``result``'s design (the
    first samples of ``seed``, as ``foldprint check`` draws them) beside the nominal
    ``clearance``, on the nominal fold's time grid and hinge model (``checker``); their
    curves made ``batch`` samples at a time (default: as many as CURVE_BATCH_BYTES holds;
    the result is the same)."""
    design = result.design
    traj = result.trajectory
    shift = float(traj.bath_c) - float(design.process.bath_temperature_c)  # a bath given for this run
    drawn = [replace(s, bath_c=s.bath_c + shift) for s in draw_samples(design, scatter, samples, seed)]
    per = batch or curves_at_once(design, float(traj.times[-1]), samples)[0]
    times = traj.times if screened_poses(design) is None else traj.times[sampled_poses(len(traj.times))]
    gaps = []
    for a in range(0, len(drawn), per):  # the curves of a few samples at a time, as check's chunks
        drives = sample_drives(design, library, drawn[a:a + per], until_s=float(traj.times[-1]))
        solve_loops_many(drives, traj.times)  # a pattern with loops: closure tracked in lockstep
        for d in drives:
            k = simulate_kinematics(design, times, model=traj.model, drive=d)
            gaps.append(min_clearance(checker, k.times, k.poses, n_samples=CLEARANCE_SAMPLES))
        del drives, k
    closest = tuple(float(g.distance) for g in gaps)
    worst = gaps[int(np.argmin(closest))]
    return ScatterMargin(float(clearance.distance), samples, seed, closest, worst)
