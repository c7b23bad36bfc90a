"""The smallest clearance along a fold (what ``check``, ``simulate`` and the gallery report)
against a brute-force sweep: every non-adjacent pair's distance at every pose of the
trajectory, no pre-filter, no branch and bound (the exact distance of
:mod:`foldprint.collision.polytope_distance`, itself held to analytic and brute-force
references in ``tests/test_polytope_distance.py``).

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
from foldprint.collision.clearance import Gap, earliest_within, gaps_in_pose, min_clearance, permanent_crossings
from foldprint.core.constants import tol
from foldprint.collision.broadphase import non_adjacent_pairs
from foldprint.collision.polytope_distance import panel_distance
from foldprint.collision.swept3d import SweptChecker
from foldprint.collision.swept_search import min_clearance as swept_min_clearance
from foldprint.io.templates import resolve_design_path
from foldprint.io.load import load_design
from foldprint.model.design import strip

TEMPLATES = ("self_lock", "mailbox", "octagon_stack", "helix_uniform", "miura_3x3")


TIE_MM = tol.length  # gaps this close are one gap (folds rest on plateaus: a lid on its stop)


def _brute(checker, times, poses, pairs):
    """(distance, earliest time, all distances (n_t, n_pairs)) of the smallest gap over
    every pose and pair."""
    d = np.array([[panel_distance(checker, i, j, poses[k, i], poses[k, j])[0] for i, j in pairs]
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
    assert gap.point is not None and len(gap.point) == 3 and np.all(np.isfinite(gap.point)), name
    # up to a time: the minimum over the poses up to it alone
    m = len(times) // 2
    early = min_clearance(checker, times, poses, n_samples=len(times), t_end=float(times[m]))
    assert early.distance == pytest.approx(float(d[:m + 1].min()), abs=TIE_MM) and early.time <= times[m], name
    # the earliest pose within a distance, its bounds made a few poses at a time or all at once
    within = best + TIE_MM
    first = int(np.argwhere(d <= within)[0][0])
    for chunk in (1, 3 * len(pairs), 1 << 19):
        k, (i, j) = earliest_within(checker, poses, within, chunk=chunk)
        assert k == first and d[k, pairs.index((i, j))] <= within, (name, chunk)


def test_gaps_in_a_pose_are_every_pair_brute_force_finds_within_the_distance(folded):
    """In the pose of the smallest gap and in the last pose: the box prefilter drops no
    pair the exact distance puts within it, nearest first, each named by its indices and ids."""
    name, _, times, poses, checker, pairs = folded
    design = checker.design
    k_min = int(np.argmin([min(panel_distance(checker, i, j, poses[k, i], poses[k, j])[0] for i, j in pairs)
                           for k in range(0, len(times), max(1, len(times) // 40))])) * max(1, len(times) // 40)
    for k in (k_min, len(times) - 1):
        d = {(i, j): max(float(panel_distance(checker, i, j, poses[k, i], poses[k, j])[0]), 0.0) for i, j in pairs}
        for within in (min(d.values()) + 0.5, 3.0, 20.0):
            got = gaps_in_pose(checker, poses[k], within, time=float(times[k]))
            assert [g.pair for g in got] == sorted((p for p in d if d[p] < within), key=d.get), (name, k, within)
            assert [g.distance for g in got] == pytest.approx([d[g.pair] for g in got], abs=1e-9)
            for g in got:
                assert g.panels == (design.panels[g.pair[0]].id, design.panels[g.pair[1]].id)
                assert g.time == float(times[k]) and g.point is not None and np.all(np.isfinite(g.point))
            some = [p for p in pairs if d[p] < 20.0][:2]  # given pairs: those only
            assert {g.pair for g in gaps_in_pose(checker, poses[k], 20.0, some)} == set(some)


def test_gap_json_rounds_to_a_tenth_of_a_micron_and_gives_a_time_only_when_there_is_one():
    assert Gap(1.234567, (0, 2), ("a", "c"), 2.345678, (0.0, 0.0, 0.0)).to_json() == \
        {"distance_mm": 1.2346, "panels": ["a", "c"], "time_s": 2.3457}
    assert Gap(0.5, (0, 2), ("a", "c"), None, None).to_json() == {"distance_mm": 0.5, "panels": ["a", "c"]}


def test_permanent_crossings_name_panels_that_overlap_as_printed():
    """The strip whose two 120 deg folds put p3 through p1 as printed, and the templates,
    which all print: exactly the overlapping pair, nothing else."""
    from pathlib import Path

    crossing = load_design(Path(__file__).parent / "data" / "crossing.toml")
    assert permanent_crossings(crossing) == [("p1", "p3")]
    for name in TEMPLATES:
        assert permanent_crossings(load_design(resolve_design_path(name))) == [], name


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
    brute = min(panel_distance(checker, i, j, poses[t, i], poses[t, j])[0] for t in range(len(poses)) for i, j in pairs)
    assert dist == pytest.approx(brute, abs=1e-9)
    assert panel_distance(checker, *pair, poses[k, pair[0]], poses[k, pair[1]])[0] == pytest.approx(dist, abs=1e-9)
