"""The smallest clearance along a fold (what ``check``, ``simulate`` and the gallery report)
against a brute-force sweep: every non-adjacent pair's FCL distance at every pose of the
trajectory, no pre-filter, no branch and bound.

* ``min_clearance`` with every pose sampled must give the brute-force minimum exactly: its
  value, its pair and the earliest time it occurs;
* the evaluation's clearance (200 poses spread over the run) must lie within the sampling
  error of the dense minimum, at about its time, on the templates whose margins users act
  on (the self-locking strip's end passing the plate, the mailbox's lid, the octagon's
  flaps);
* the branch and bound itself equals brute force on arbitrary poses of small panels, whose
  bounding spheres are tight enough that stopping early on them misses the minimum.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.collision.clearance import earliest_within, min_clearance
from foldprint.core.constants import tol
from foldprint.collision.swept3d import SweptChecker, non_adjacent_pairs
from foldprint.collision.swept3d import min_clearance as swept_min_clearance
from foldprint.io.templates import resolve_design_path
from foldprint.io.load import load_design
from foldprint.model.design import strip

TEMPLATES = ("self_lock", "mailbox", "octagon_stack", "helix_uniform", "miura_3x3")


TIE_MM = tol.length  # gaps this close are one gap (folds rest on plateaus: a lid on its stop)


def _brute(checker, times, poses, pairs):
    """(distance, earliest time, all distances (n_t, n_pairs)) of the smallest gap over
    every pose and pair."""
    d = np.array([[checker.distance(i, j, poses[k, i], poses[k, j])[0] for i, j in pairs]
                  for k in range(len(times))])
    d = np.maximum(d, 0.0)
    best = d.min()
    k = int(np.argwhere(d <= best + TIE_MM)[0][0])  # argwhere is row-major: the earliest time first
    return float(best), float(times[k]), d


@pytest.fixture(scope="module", params=TEMPLATES)
def folded(request):
    design = load_design(resolve_design_path(request.param))
    ev = Evaluation(design, EvalOptions(samples=0, dt=0.05))
    sim = ev.simulation
    traj = sim.trajectory
    n = len(traj.times)
    if sim.first_collision is not None:
        n = int(np.searchsorted(traj.times, sim.first_collision.time, side="right"))
    checker = SweptChecker(design, "arc", None)
    pairs = non_adjacent_pairs(design)
    return request.param, ev, traj.times[:n], traj.poses[:n], checker, pairs


def test_every_pose_sampled_gives_the_brute_force_minimum(folded):
    name, _, times, poses, checker, pairs = folded
    gap = min_clearance(checker, times, poses, n_samples=len(times))
    best, t_best, d = _brute(checker, times, poses, pairs)
    assert gap.distance == pytest.approx(best, abs=TIE_MM), name
    assert gap.time == pytest.approx(t_best, abs=1e-12), name
    k = int(np.argmin(np.abs(times - gap.time)))
    assert d[k, pairs.index(gap.pair)] == pytest.approx(best, abs=TIE_MM), name  # the pair named is that gap
    # the earliest pose within a distance, its bounds made a few poses at a time or all at once
    within = best + TIE_MM
    first = int(np.argwhere(d <= within)[0][0])
    for chunk in (1, 3 * len(pairs), 1 << 19):
        k, (i, j) = earliest_within(checker, poses, within, chunk=chunk)
        assert k == first and d[k, pairs.index((i, j))] <= within, (name, chunk)


def test_the_reported_clearance_is_the_dense_minimum_within_sampling_error(folded):
    name, ev, times, poses, checker, pairs = folded
    gap = ev.clearance  # CLEARANCE_SAMPLES poses of the evaluation's own trajectory
    best, t_best, d = _brute(checker, times, poses, pairs)
    # the sampled minimum can only be larger, by what the gap changes between two samples
    stride = max(1, int(np.ceil((len(times) - 1) / (ev.options.clearance_samples - 1))))
    rate = np.abs(np.diff(d.min(axis=1))).max()  # mm per pose of the dense sweep
    assert best - 1e-9 <= gap.distance <= best + stride * rate + 1e-9, name
    # reported where the gap really is that small (not another sample's time)
    k = int(np.argmin(np.abs(times - gap.time)))
    assert d[k, pairs.index(gap.pair)] == pytest.approx(gap.distance, abs=1e-6), name
    # the earliest sample of the plateau: no earlier than the dense one, within a stride of it
    dt = float(times[1] - times[0])
    assert t_best - 1e-9 <= gap.time <= t_best + stride * dt + 1e-9 or gap.distance > best + TIE_MM, name


# -- the search against brute force on arbitrary poses --------------------------------------

#: small compact panels: their bounding spheres are tight, so a search that stops early on
#: its sphere bounds (by a fraction of a millimetre) misses the true minimum
_SMALL = strip("small", [2.0, 2.0, 2.0, 2.0, 2.0], [30.0, 30.0, 30.0, 30.0], ["H-1"] * 4, depth=1.5,
               thickness=0.3, radius=0.2, hinge_thickness=0.3)


def _pose(rx, ry, rz, tx, ty, tz):
    p = np.eye(4)
    p[:3, :3] = Rotation.from_rotvec([rx, ry, rz]).as_matrix()
    p[:3, 3] = (tx, ty, tz)
    return p


_POSE = st.tuples(*[st.floats(-3.2, 3.2)] * 3, *[st.floats(-6.0, 6.0)] * 3)


@settings(max_examples=60, derandomize=True, deadline=None, database=None)
@given(st.lists(st.lists(_POSE, min_size=5, max_size=5), min_size=1, max_size=3))
def test_branch_and_bound_finds_the_brute_force_minimum_on_any_poses(frames):
    checker = SweptChecker(_SMALL, "arc", None)
    poses = np.array([[_pose(*p) for p in frame] for frame in frames])
    pairs = non_adjacent_pairs(_SMALL)
    dist, pair, k = swept_min_clearance(checker, poses)
    brute = min(checker.distance(i, j, poses[t, i], poses[t, j])[0] for t in range(len(poses)) for i, j in pairs)
    assert dist == pytest.approx(brute, abs=1e-9)
    assert checker.distance(*pair, poses[k, pair[0]], poses[k, pair[1]])[0] == pytest.approx(dist, abs=1e-9)
