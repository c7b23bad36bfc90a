"""The scalable swept check keeps its guarantee: motion bounds hold (measured motion of
real panels), the broad phase never drops a touching pair, the first contact is no later
than dense sampling finds it, huge coordinates cannot hang it; the chunked 2D index equals
itself unchunked and stays within its memory estimate."""

import math
import tracemalloc
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.collision.index2d import collision_index, index_memory_bytes
from foldprint.collision.broadphase import candidate_runs, non_adjacent_pairs, panel_centres
from foldprint.collision.swept3d import FCL_REL, SweptChecker
from foldprint.collision.swept_search import min_clearance, swept_first_contact
from foldprint.model.design import Design, Panel, strip
from foldprint.physics.kinematics import forward
from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics
from foldprint.io.load import load_design

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"
MATERIALS = ["H-1", "H-2", "H-3", "H-4", "H-5"]


def random_strip(data, n_min=3, n_max=6):
    n = data.draw(st.integers(n_min, n_max))
    lengths = data.draw(st.lists(st.floats(6, 30), min_size=n, max_size=n))
    angles = data.draw(st.lists(st.sampled_from([-170, -150, -120, -90, 90, 120, 150, 170]),
                                min_size=n - 1, max_size=n - 1))
    mats = data.draw(st.lists(st.sampled_from(MATERIALS), min_size=n - 1, max_size=n - 1))
    return strip("r", lengths, angles, mats, radius=2.0)


def random_tree(data):
    """The mailbox panel tree with random fold angles and hinge materials."""
    d = load_design(TEMPLATES / "mailbox.toml")
    hinges = tuple(replace(h, angle=math.radians(data.draw(st.sampled_from([-150, -90, 90, 120, 150]))),
                           material=data.draw(st.sampled_from(MATERIALS))) for h in d.hinges)
    return replace(d, hinges=hinges)


def _solid_points(d: Design, i: int) -> np.ndarray:
    p = d.panels[i]
    h = p.thickness / 2
    return np.vstack([np.column_stack([p.outline, np.full(len(p.outline), z)]) for z in (-h, h)])


# -- motion bounds measured on real panels -----------------------------------------------

@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(data=st.data(), model=st.sampled_from(["point", "arc"]), tree=st.booleans())
def test_motion_bounds_hold_for_real_motion(data, model, tree):
    """Over [ta, tb], the distance between any corner of panel i and any corner of panel j
    changes by no more than the narrow-phase bound (FCL's own distance is not used here:
    its GJK error exceeds the motion near flat states, see collision3d.FCL_REL); the
    centroids' distance by no more than the broad-phase bound; every panel stays inside
    its hierarchy sphere."""
    d = random_tree(data) if tree else random_strip(data)
    drive = HingeDrive(d)
    ch = SweptChecker(d, model, drive)
    ta = data.draw(st.floats(0.0, 6.0))
    tb = ta + data.draw(st.floats(0.01, 4.0))
    ts = np.linspace(ta, tb, 41)
    ang = drive.angles(ts)
    poses = forward(d, ang, model)
    tb_, H = ch.tree, ch.hier
    P = tb_.prefix(ang)
    C = panel_centres(ch, poses)
    xc = tb_.qp + tb_.cen
    pairs = non_adjacent_pairs(d)
    for i, j in pairs[:: max(1, len(pairs) // 12)]:
        pi, pj = _solid_points(d, i), _solid_points(d, j)

        def corner_dist(k, i=i, j=j, pi=pi, pj=pj):
            wi = pi @ poses[k, i, :3, :3].T + poses[k, i, :3, 3]
            wj = pj @ poses[k, j, :3, :3].T + poses[k, j, :3, 3]
            return np.linalg.norm(wi[:, None] - wj[None], axis=-1)

        d0 = corner_dist(0)
        moved = max(np.abs(corner_dist(k) - d0).max() for k in range(len(ts)))
        bound = ch._bound((i, j), ang[0], ang[-1:])[0]
        assert moved <= bound + 1e-9, (i, j, moved, bound)
        # broad phase: centroid distance change vs the split-panel prefix bound
        a, b = np.array([i]), np.array([j])
        l = tb_.lca(a, b)
        s, on_a = tb_.split_panel(a, b, l, xc[a], xc[b])
        F = tb_.pair_motion(P, np.array([len(ts) - 1]), a, b, l, xc[a], xc[b], s, on_a)[0]
        F0 = tb_.pair_motion(P, np.array([0]), a, b, l, xc[a], xc[b], s, on_a)[0]
        dist = np.linalg.norm(C[:, i] - C[:, j], axis=-1)
        assert np.abs(dist - dist[0]).max() <= F - F0 + 1e-9
    for k in (0, len(ts) // 2, len(ts) - 1):
        world = [(_solid_points(d, v) @ poses[k, v, :3, :3].T + poses[k, v, :3, 3]) for v in range(len(d.panels))]
        for node in range(len(H.ref)):
            members = _members(H, node)
            c = C[k, H.ref[node]]
            far = max(np.linalg.norm(world[v] - c, axis=1).max() for v in members)
            assert far <= H.rad[node] + 1e-9


def _members(H, node):
    if H.left[node] < 0:
        return [int(H.ref[node])]
    return _members(H, H.left[node]) + _members(H, H.right[node])


# -- broad phase and first contact against dense sampling ---------------------------------

def _dense_first_touch(ch, d, model, times):
    dense = simulate_kinematics(d, times=times, model=model)
    first = {}
    for i, j in non_adjacent_pairs(d):
        for k in range(len(times)):
            if ch.gap(i, j, dense.poses[k, i], dense.poses[k, j]) <= 0:
                first[(i, j)] = float(times[k])
                break
    return first


def _assert_no_contact_missed(d, model):
    """Samples 0.25 s apart; every pair that touches at a dense (4 ms) sample lies in a
    broad-phase run around that time, and the swept contact is no later than the dense
    one (to the 1 ms time tolerance) and real. Returns the dense first touch of each pair
    not touching at the start."""
    coarse = simulate_kinematics(d, dt=0.25, duration=4.0, model=model)
    ch = SweptChecker(d, model, HingeDrive(d))
    dense_t = np.arange(0.0, 4.0, 0.004)
    first = _dense_first_touch(ch, d, model, dense_t)
    # on the samples only, and refined between the samples (sub-intervals, prefix poses)
    for runs in (candidate_runs(ch, coarse.angles, coarse.poses),
                 candidate_runs(ch, coarse.angles, coarse.poses, times=coarse.times)):
        for (i, j), t in first.items():
            k = int(np.searchsorted(coarse.times, t, side="right")) - 1
            mine = runs[(runs[:, 0] == i) & (runs[:, 1] == j)]
            assert any(a <= k + 1 and k <= b for _, _, a, b in mine), ((i, j), t, mine)
    contact, initial = swept_first_contact(ch, coarse.times, coarse.angles, coarse.poses)
    touching_at_start = {c.pair for c in initial}
    later = {p: t for p, t in first.items() if p not in touching_at_start}
    if later:
        assert contact is not None
        assert contact.time <= min(later.values()) + 1e-3
    if contact is not None:
        pose = forward(d, HingeDrive(d).angles([contact.time]), model)[0]
        assert ch.gap(*contact.pair, pose[contact.pair[0]], pose[contact.pair[1]]) <= ch.tol + 1e-9
    return later


#: strips on which a narrow phase that steps three times too far (``target = cum[c] + 2.7 * d``
#: in ``SweptChecker.steps``) finds the contact late or not at all, under the shipped
#: materials: found by a seeded random search (numpy seeds 1 and 2, 60 strips per hinge model,
#: the property test's ranges; 9 and 15 strips caught it), the smallest kept. They depend on
#: the recovery curves: when materials.toml moves, check that they still catch that rule
#: (the dense touch below must exist) and search again if not.
ADVERSARIAL = [
    ([6.0, 6.0, 6.0], [-120, -150], ["H-1", "H-3"], "point"),
    ([16.09, 17.346, 25.2], [-120, -170], ["H-3", "H-4"], "point"),
    ([6.0, 6.0, 6.0], [150, 170], ["H-3", "H-3"], "arc"),
    ([25.276, 14.82, 27.361], [-150, -170], ["H-1", "H-4"], "arc"),
]


@pytest.mark.parametrize("lengths,angles,materials,model", ADVERSARIAL)
def test_no_contact_missed_on_fixed_adversarial_strips(lengths, angles, materials, model):
    first = _assert_no_contact_missed(strip("r", lengths, angles, materials, radius=2.0), model)
    assert first, "the case has no contact in the checked window any more: search again (comment above)"


# derandomised, with a fixed example count: the same 40 designs every run, enough to
# catch a step rule three times too long (measured); no example database between runs
@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(data=st.data(), model=st.sampled_from(["point", "arc"]), tree=st.booleans())
def test_no_contact_missed_between_coarse_samples(data, model, tree):
    _assert_no_contact_missed(random_tree(data) if tree else random_strip(data), model)


def test_transient_contact_of_fast_outer_hinge_is_found():
    """A strip whose outer hinge is fast (H-1) and inner ones slow: the tip sweeps through
    the second panel's space and is stopped; a contact lasting less than the 0.5 s sample
    spacing is still found, at the dense-sampling time."""
    d = strip("t", [20, 10, 20], [170, 170], ["H-5", "H-1"], radius=1.0)
    coarse = simulate_kinematics(d, dt=0.5, duration=6.0, model="point")
    ch = SweptChecker(d, "point", HingeDrive(d))
    c, _ = swept_first_contact(ch, coarse.times, coarse.angles, coarse.poses)
    first = _dense_first_touch(ch, d, "point", np.arange(0.0, 6.0, 0.001))
    assert first, "dense sampling must see the contact"
    assert c is not None and c.time <= min(first.values()) + 1e-3
    assert c.time >= min(first.values()) - 0.01


def test_long_strip_broad_phase_drops_far_pairs():
    """A 120-panel zig-zag: no contact; the broad phase leaves no pair for FCL."""
    n = 120
    d = strip("z", [10.0] * n, [30.0 if k % 2 == 0 else -30.0 for k in range(n - 1)], ["H-3"] * (n - 1))
    tr = simulate_kinematics(d, model="arc")
    ch = SweptChecker(d, "arc", HingeDrive(d))
    runs = candidate_runs(ch, tr.angles, tr.poses)
    assert runs.shape == (0, 4) and runs.dtype == np.int64  # sample indices, even when there are none
    c, init = swept_first_contact(ch, tr.times, tr.angles, tr.poses)
    assert c is None and init == [] and ch.n_distance_calls == 0


def test_refined_broad_phase_certifies_long_paths_between_samples():
    """A 60-panel +-90 deg staircase sampled every 0.5 s: far panels on long tree paths are
    not certified over one sample step (the motion bound grows with the path length
    squared), so the samples-only broad phase hands pairs to FCL; re-tested between the
    samples none is left, and the swept check, like dense sampling, finds no contact."""
    n = 60
    d = strip("w", [6.0] * n, [90.0 if k % 2 == 0 else -90.0 for k in range(n - 1)], ["H-3"] * (n - 1),
              radius=3.0)
    tr = simulate_kinematics(d, model="arc", dt=0.5)
    ch = SweptChecker(d, "arc", HingeDrive(d))
    assert len(candidate_runs(ch, tr.angles, tr.poses)) > 0
    assert len(candidate_runs(ch, tr.angles, tr.poses, times=tr.times)) == 0
    c, init = swept_first_contact(ch, tr.times, tr.angles, tr.poses)
    assert c is None and init == [] and ch.n_distance_calls == 0
    dense = simulate_kinematics(d, model="arc", dt=0.05)
    C = panel_centres(ch, dense.poses)
    gap = np.linalg.norm(C[:, :, None] - C[:, None], axis=-1) - ch.tree.rc[:, None] - ch.tree.rc[None]
    far = np.abs(np.arange(n)[:, None] - np.arange(n)[None]) > 1
    assert gap[:, far].min() > 0  # an independent look: no two non-adjacent panels' spheres meet



def _sphere_meetings(ch, d, model, times, sub=8):
    """Brute force: every non-adjacent pair (i, j) and sample interval k in which the panels'
    bounding spheres (radius ``tree.rc`` about the world centroid) meet at one of ``sub``
    + 1 dense times of the interval: {(i, j, k)}."""
    drive = HingeDrive(d)
    pairs = np.array(non_adjacent_pairs(d)).reshape(-1, 2)
    out = set()
    for k in range(len(times) - 1):
        tt = np.linspace(times[k], times[k + 1], sub + 1)
        C = panel_centres(ch, forward(d, drive.angles(tt), model))
        gap = np.linalg.norm(C[:, pairs[:, 0]] - C[:, pairs[:, 1]], axis=-1) - ch.tree.rc[pairs].sum(axis=1)
        out |= {(int(i), int(j), k) for i, j in pairs[(gap <= 0).any(axis=0)]}
    return out


def _covered(runs, need):
    return [(i, j, k) for i, j, k in need
            if not ((runs[:, 0] == i) & (runs[:, 1] == j) & (runs[:, 2] <= k) & (runs[:, 3] >= k + 1)).any()]


# derandomised: the broad phase decides which pairs the narrow phase ever looks at
@settings(max_examples=30, deadline=None, derandomize=True, database=None)
@given(data=st.data(), model=st.sampled_from(["point", "arc"]), tree=st.booleans())
def test_broad_phase_keeps_every_pair_whose_spheres_meet(data, model, tree):
    """Against a brute-force enumeration of every pair at dense times: a pair and sample
    interval in which the two panels' bounding spheres meet is in a run, on the samples
    only and refined between them (in one chunk or in many), and the runs hold only
    non-adjacent, ordered pairs, sorted by their first sample, not skipped ones."""
    from foldprint.collision import broadphase

    d = random_tree(data) if tree else random_strip(data, 4, 8)
    coarse = simulate_kinematics(d, dt=0.5, duration=4.0, model=model)
    ch = SweptChecker(d, model, HingeDrive(d))
    need = _sphere_meetings(ch, d, model, coarse.times)
    plain = candidate_runs(ch, coarse.angles, coarse.poses)
    refined = candidate_runs(ch, coarse.angles, coarse.poses, times=coarse.times)
    with pytest.MonkeyPatch.context() as mp:  # one sample interval per chunk
        mp.setattr(broadphase, "REFINE_CHUNK_BYTES", 1)
        chunked = candidate_runs(ch, coarse.angles, coarse.poses, times=coarse.times)
    np.testing.assert_array_equal(chunked, refined)
    with pytest.MonkeyPatch.context() as mp:  # group pairs' static data computed at every level, no tables
        mp.setattr(broadphase, "PAIR_TABLE_MAX", 0)
        fresh = SweptChecker(d, model, HingeDrive(d))
        np.testing.assert_array_equal(candidate_runs(fresh, coarse.angles, coarse.poses), plain)
        np.testing.assert_array_equal(candidate_runs(fresh, coarse.angles, coarse.poses, times=coarse.times), refined)
    allowed = set(non_adjacent_pairs(d))
    for runs in (plain, refined):
        assert _covered(runs, need) == []
        assert {(int(i), int(j)) for i, j in runs[:, :2]} <= allowed
        assert np.all(np.diff(runs[:, 2]) >= 0) and np.all(runs[:, 2] <= runs[:, 3])
    if need:
        skip = {need_pair[:2] for need_pair in sorted(need)[:1]}
        left = candidate_runs(ch, coarse.angles, coarse.poses, skip=skip, times=coarse.times)
        assert not any((int(i), int(j)) in skip for i, j in left[:, :2])
        assert _covered(left, {x for x in need if x[:2] not in skip}) == []
        # the tables kept per set of exclusions: asked again without skipping, the pair is back
        np.testing.assert_array_equal(candidate_runs(ch, coarse.angles, coarse.poses, times=coarse.times), refined)



class _PiecewiseDrive:
    """Hinge angles (deg) given at times, linear between them (monotone per piece)."""

    def __init__(self, times, angles_deg):
        self.t, self.a = np.asarray(times, float), np.radians(angles_deg)

    def angles(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        return np.column_stack([np.interp(t, self.t, self.a[:, h]) for h in range(self.a.shape[1])])


def test_broad_phase_refines_a_pass_between_samples():
    """The third panel swings through the first one's space between two samples (hinge 2:
    20 deg at t = 1, 340 deg at t = 2) while their spheres are apart at every sample: only
    the refinement between the samples sees it, and hands that interval, not the one
    before, to the narrow phase, in one chunk or in many."""
    from foldprint.collision import broadphase

    d = strip("s", [20.0, 2.0, 20.0], [90.0, 170.0], ["H-1", "H-1"])
    times = np.array([0.0, 1.0, 2.0])
    ch = SweptChecker(d, "point", _PiecewiseDrive(times, [[0, 0], [0, 20], [0, 340]]))
    ang = ch.drive.angles(times)
    poses = forward(d, ang, "point")
    C = panel_centres(ch, poses)
    assert (np.linalg.norm(C[:, 0] - C[:, 2], axis=-1) - ch.tree.rc[0] - ch.tree.rc[2]).min() > 0.5
    need = {(0, 2, 1)}
    mid = panel_centres(ch, forward(d, ch.drive.angles([1.5]), "point"))[0]
    assert np.linalg.norm(mid[0] - mid[2]) < ch.tree.rc[0] + ch.tree.rc[2]  # they meet at t = 1.5
    np.testing.assert_array_equal(candidate_runs(ch, ang, poses, times=times), [[0, 2, 1, 2]])
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(broadphase, "REFINE_CHUNK_BYTES", 1)
        assert _covered(candidate_runs(ch, ang, poses, times=times), need) == []


@settings(max_examples=15, deadline=None)
@given(data=st.data(), model=st.sampled_from(["point", "arc"]), tree=st.booleans())
def test_prefix_product_poses_equal_forward(data, model, tree):
    """TreeTransforms (every hinge at once, pointer doubling) = forward (one hinge at a
    time), and the swept check's cached poses between samples = forward at that time."""
    from foldprint.physics.kinematics import TreeTransforms

    d = random_tree(data) if tree else random_strip(data, 3, 40)
    drive = HingeDrive(d)
    ts = np.array(data.draw(st.lists(st.floats(0.0, 20.0), min_size=1, max_size=4)))
    ang = drive.angles(ts)
    ref = forward(d, ang, model)
    assert np.allclose(TreeTransforms(d, model).poses(ang), ref, rtol=0, atol=1e-9)
    ch = SweptChecker(d, model, drive)
    assert np.allclose(ch.poses_at(ts[0]), ref[0], rtol=0, atol=1e-9)


@pytest.mark.parametrize("offset, scale", [(0.0, 1e5), (1e15, 1.0)])
def test_huge_coordinates_cannot_hang(offset, scale):
    """A panel 1e6 mm long, or coordinates near 1e15: the check ends with a bounded number
    of FCL calls (relative tolerance, time-resolution floor). The boundary schema refuses
    such designs (a file may not ask for them); this builds them past it, to test the check's own bound."""
    d = strip("big", [10.0] * 4, [170, 170, 170], ["H-1", "H-2", "H-1"], radius=1.0)
    d = replace(d, panels=tuple(Panel(p.id, p.outline * scale + offset, p.thickness, p.material)
                                for p in d.panels),
                hinges=tuple(replace(h, line=h.line * scale + offset) for h in d.hinges))
    tr = simulate_kinematics(d, dt=0.05, duration=6.0, model="point")
    ch = SweptChecker(d, "point", HingeDrive(d))
    swept_first_contact(ch, tr.times, tr.angles, tr.poses)
    assert ch.n_distance_calls < 20000


def test_min_clearance_matches_brute_force():
    d = load_design(TEMPLATES / "helix_graded.toml")
    tr = simulate_kinematics(d, dt=0.25, model="arc")
    ch = SweptChecker(d, "arc", None)
    dist, pair, k = min_clearance(ch, tr.poses)
    brute = min((ch.gap(i, j, tr.poses[t, i], tr.poses[t, j]), (i, j), t)
                for t in range(len(tr.times)) for i, j in non_adjacent_pairs(d))
    assert dist == brute[0]  # exact: the search asks for the same values (SweptChecker.gap)
    assert ch.distance(*pair, tr.poses[k, pair[0]], tr.poses[k, pair[1]])[0] == pytest.approx(dist)



def _on_panel(d: Design, i: int, pose: np.ndarray, point, tol: float) -> bool:
    """Whether a world point lies within ``tol`` of panel i's solid (its outline extruded to
    its thickness, about the mid-plane) at ``pose``: shapely in the panel's own frame."""
    from shapely.geometry import Point, Polygon

    p = d.panels[i]
    local = np.linalg.solve(pose, np.append(np.asarray(point, float), 1.0))[:3]
    return Polygon(p.outline).distance(Point(local[:2])) <= tol and abs(local[2]) <= p.thickness / 2 + tol


def test_a_contact_names_where_the_panels_touch():
    """The reported contact point lies on both panels' solids at the contact time (checked
    with shapely in each panel's frame), and a pair's own search agrees with the whole
    check; asked from past the last sample, the pair's search finds nothing."""
    d = strip("t", [20, 10, 20], [170, 170], ["H-5", "H-1"], radius=1.0)
    coarse = simulate_kinematics(d, dt=0.5, duration=6.0, model="point")
    ch = SweptChecker(d, "point", HingeDrive(d))
    c, initial = swept_first_contact(ch, coarse.times, coarse.angles, coarse.poses)
    assert c is not None and initial == [] and c.method == "fcl" and c.panels == ("p1", "p3")
    assert np.isfinite(c.point).all()
    pose = forward(d, HingeDrive(d).angles([c.time]), "point")[0]
    assert all(_on_panel(d, i, pose[i], c.point, 0.05) for i in c.pair)
    assert not _on_panel(d, 1, pose[1], c.point, 0.5)  # the middle panel is elsewhere: the test can tell
    again = ch.first_contact(c.pair, coarse.times, coarse.angles, coarse.poses)
    assert again.time == pytest.approx(c.time, abs=1e-3) and again.pair == c.pair
    assert ch.first_contact(c.pair, coarse.times, coarse.angles, coarse.poses, t_start=6.5) is None
    assert swept_first_contact(ch, coarse.times, coarse.angles, coarse.poses, t_start=6.5) == (None, [])
    # a pair the caller already handled is skipped (the strip has no other pair)
    assert swept_first_contact(ch, coarse.times, coarse.angles, coarse.poses, skip={c.pair}) == (None, [])
    # a panel does not move relative to itself
    np.testing.assert_array_equal(ch.cumulative_motion((1, 1), coarse.angles), np.zeros(len(coarse.times)))


def _prisms_case(sides, gap, lift, shift):
    """(FCL's distance, the exact one, the analytic one): a strip's first panel and a
    regular polygon put in place of its third, the polygon moved by (gap, shift, lift).
    The analytic distance is taken between the rigid polygons, the solids both distances
    are of (the vertex reliefs clip a triangle's corners)."""
    from shapely.affinity import translate

    from foldprint.collision.polytope_distance import panel_distance
    from foldprint.collision.rigid import rigid_polygons

    ang = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    disc = np.column_stack([5.0 + 4.0 * np.cos(ang), 5.0 + 4.0 * np.sin(ang)])
    d = strip("a", [10.0, 10.0, 10.0], [90.0, 90.0], ["H-1", "H-1"])
    d = replace(d, panels=(d.panels[0], d.panels[1], replace(d.panels[2], outline=disc + [20.0, -2.0])))
    move = np.eye(4)
    move[:3, 3] = [gap, shift, lift]
    solid = rigid_polygons(d, "point")
    ref = math.hypot(solid[0].distance(translate(solid[2], gap, shift)), max(0.0, lift - d.panels[0].thickness))
    ch = SweptChecker(d, "point", None)
    return (_fcl_distance(ch, 0, 2, np.eye(4), move), panel_distance(ch, 0, 2, np.eye(4), move)[0], ref)


def _fcl_distance(ch, i, j, pose_i, pose_j) -> float:
    """FCL's distance between the checker's FCL pieces of panels i and j (0 when touching)."""
    import fcl

    for objs, pose in ((ch.pieces[i], pose_i), (ch.pieces[j], pose_j)):
        for o in objs:
            o.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
    return max(0.0, min(fcl.distance(a, b, fcl.DistanceRequest(), fcl.DistanceResult())
                        for a in ch.pieces[i] for b in ch.pieces[j]))


#: FCL's distance between two prisms, measured against the analytic one (python-fcl 0.7,
#: GJK through libccd or its own solver alike): exact within 1e-6 on most poses, never
#: below it, and up to 12 % above it (0.71 mm at 6 mm) where a face of one prism and an
#: edge of the other are the nearest features and their faces are coplanar. Reported
#: distances are the exact ones (``collision.polytope_distance``); the property holds FCL
#: to the bound it meets here (random coplanar prisms reached 15 %:
#: ``tests/test_polytope_distance.py``'s cases).
FCL_OVER = 0.12
#: poses where FCL reads high: 12.37 mm for 12, 6.71 for 6 (coplanar squares)
FCL_MISSES = [(4, 1.0, 0.0, 0.0), (4, -5.0, 0.0, 0.0)]


@pytest.mark.parametrize("case", FCL_MISSES)
def test_exact_distance_where_fcl_reads_high(case):
    fcl_d, exact, ref = _prisms_case(*case)
    assert exact == pytest.approx(ref, abs=1e-9)
    assert fcl_d > ref + 0.3, "FCL is exact here now: the case no longer tests the exact distance against it"


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(sides=st.integers(3, 40), gap=st.floats(0.5, 20.0), lift=st.floats(0.0, 15.0),
       shift=st.floats(-10.0, 10.0))
def test_panel_distances_match_an_analytic_reference(sides, gap, lift, shift):
    """The distance between two panels' prisms (convex pieces with up to 80 vertices), the
    second moved by a translation, against sqrt(d_xy^2 + max(0, |dz| - t)^2), with d_xy
    the rigid outlines' distance in the plane (shapely) after the in-plane shift: the
    exact distance equals it; FCL's is never below it and at most FCL_OVER above."""
    fcl_d, exact, ref = _prisms_case(sides, gap, lift, shift)
    assert exact == pytest.approx(ref, abs=1e-9)
    assert ref - 1e-6 <= fcl_d <= ref * (1.0 + FCL_OVER) + 1e-6


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(sides=st.integers(3, 40), gap=st.floats(-10.5, -9.0), lift=st.floats(0.0, 1.0),
       shift=st.floats(-1.0, 1.0))
def test_near_contact_distances_are_exact(sides, gap, lift, shift):
    """Under 2 mm, where contacts are decided: the exact distance and FCL's match the
    analytic one on these poses (FCL not on all: ``test_polytope_distance``)."""
    fcl_d, exact, ref = _prisms_case(sides, gap, lift, shift)
    assert exact == pytest.approx(ref, abs=1e-9)
    assert fcl_d == pytest.approx(ref, abs=1e-6)

CORNER = """
schema = 1
name = "corner"
root = "hub"
[process]
program_temperature_c = 90.0
fix_temperature_c = 10.0
bath_temperature_c = 90.0
duration_s = 4.0
[defaults]
thickness_mm = 1.0
[[panels]]
id = "hub"
outline = [[0, 0], [10, 0], [10, 10], [0, 10]]
[[panels]]
id = "east"
outline = [[10, 0], [20, 0], [20, 10], [10, 10]]
[[panels]]
id = "north"
outline = [[0, 10], [10, 10], [10, 20], [0, 20]]
[[hinges]]
id = "e"
panels = ["hub", "east"]
line = [[10, 0], [10, 10]]
angle_deg = 90.0
material = "H-1"
[[hinges]]
id = "n"
panels = ["hub", "north"]
line = [[0, 10], [10, 10]]
angle_deg = 90.0
material = "H-3"
"""


def test_panels_touching_at_the_start_are_reported_apart_from_the_first_contact():
    """Two panels hinged to neighbouring edges of a square touch at its corner in the flat
    sheet (point hinges: whole outlines): that pair is reported as touching initially, at
    t = 0 and distance 0, and is not the first contact (they fold apart: no contact)."""
    import tomllib

    from foldprint.io.design_io import design_from_dict

    d = design_from_dict(tomllib.loads(CORNER))
    tr = simulate_kinematics(d, dt=0.25, model="point")
    ch = SweptChecker(d, "point", HingeDrive(d))
    c, initial = swept_first_contact(ch, tr.times, tr.angles, tr.poses)
    assert c is None
    assert [(x.pair, x.panels, x.time, x.distance, x.method) for x in initial] == \
        [((1, 2), ("east", "north"), 0.0, 0.0, "initial")]
    # a point as every contact has one (FCL names none for touching solids: its nearest points)
    assert len(initial[0].point) == 3 and all(isinstance(x, float) for x in initial[0].point)


# -- the 2D index in chunks ------------------------------------------------------------------

def test_index_chunks_and_memory_estimate():
    d = load_design(TEMPLATES / "self_lock.toml")  # holes: several segments per panel
    tr = simulate_kinematics(d, dt=0.05, model="arc")
    whole = collision_index(tr)
    tracemalloc.start()
    small = collision_index(tr, chunk_bytes=200_000)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert np.array_equal(whole.s_ij, small.s_ij, equal_nan=True)
    assert np.array_equal(whole.contact, small.contact)
    kmax = 3
    est = index_memory_bytes(len(tr.times), len(whole.pairs), kmax, chunk_bytes=200_000)
    assert peak <= est * 1.5 + 2_000_000
    # a 2000-panel strip at 1 ms for 20 s: the estimate grows with the output only
    n = 2000
    big = index_memory_bytes(20001, n * (n - 1) // 2)
    assert big >= 20001 * n * (n - 1) // 2 * 9
    assert index_memory_bytes(20001, 10) < 100 * 2**20


@pytest.mark.parametrize("motion,split", [(2 * (1 - FCL_REL) - 0.05, False), (2 - FCL_REL, True),
                                          (2 * (1 + FCL_REL) + 0.05, True)])
def test_a_step_is_certified_only_with_fcl_distances_shrunk(monkeypatch, motion, split):
    """The narrow phase's step rule on a fixed case: distances of 1 mm at both ends of a
    step and a motion bound F over it. The step is safe without splitting only when the
    distances shrunk by FCL_REL (GJK may overestimate them) still exceed the motion:
    F between 2 (1 - FCL_REL) and 2 mm must be split (unshrunk, the 2 mm would pass it),
    F below needs no split, F above 2 (1 + FCL_REL) is split either way."""
    d = strip("s", [20.0, 20.0, 20.0], [90.0, 90.0], ["H-3", "H-3"])
    ch = SweptChecker(d, "arc", HingeDrive(d))
    split_at = []
    monkeypatch.setattr(ch, "gap", lambda i, j, a, b: 1.0)
    monkeypatch.setattr(ch, "_bound", lambda pair, ang0, ang: np.array([0.0, motion])[:len(ang)])
    monkeypatch.setattr(ch, "_split", lambda pair, ang0, ta, da, fa, tb, db, fb: split_at.append((ta, tb)) or "hit")
    times, angles = np.array([0.0, 1.0]), np.zeros((2, 2))
    gen = ch.steps((0, 2), times, angles, np.zeros((2, 3, 4, 4)), 0, 1, False)
    with pytest.raises(StopIteration) as stop:
        while True:
            next(gen)
    assert (stop.value.value == "hit") is split and split_at == ([(0.0, 1.0)] if split else [])


# -- the narrow phase's cheaper queries give the same numbers ---------------------------------

@settings(max_examples=30, deadline=None, derandomize=True, database=None)
@given(data=st.data(), model=st.sampled_from(["point", "arc"]))
def test_gap_is_the_distance_of_the_same_queries(data, model):
    """``SweptChecker.gap`` (no nearest points) returns exactly ``distance``'s value, at random
    poses of a panel with holes (several convex pieces) and of one-piece panels, apart,
    touching (0) and overlapping (0), and keeps counting queries."""
    d = load_design(TEMPLATES / "self_lock.toml")
    ch = SweptChecker(d, model, None)
    multi = max(range(len(d.panels)), key=lambda i: len(ch.pieces[i]))
    assert len(ch.pieces[multi]) > 1 and min(len(p) for p in ch.pieces) == 1
    i = data.draw(st.sampled_from([multi, 1]))
    j = data.draw(st.sampled_from([k for k in range(len(d.panels)) if k != i]))
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 16)))
    for scale in (0.0, 3.0, 30.0):
        poses = np.tile(np.eye(4), (2, 1, 1))
        for p in poses:
            q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            p[:3, :3] = q * np.sign(np.linalg.det(q))
            p[:3, 3] = rng.normal(size=3) * scale
        ref = ch.distance(i, j, poses[0], poses[1])[0]
        calls = ch.n_distance_calls
        assert ch.gap(i, j, poses[0], poses[1]) == ref
        assert ch.n_distance_calls > calls
        assert ch.gap(j, i, poses[1], poses[0]) == ch.distance(j, i, poses[1], poses[0])[0]
    onto = np.eye(4)  # p3 moved onto p2 in the flat sheet: overlapping
    onto[:2, 3] = d.panels[1].outline.mean(axis=0) - d.panels[2].outline.mean(axis=0)
    assert ch.gap(1, 2, np.eye(4), onto) == ch.distance(1, 2, np.eye(4), onto)[0] == 0.0


class _MarkedGap:
    """A stand-in for ``SweptChecker.gap``: the distance at the sample whose poses are
    filled with its index (``steps`` asks at sample poses only), from a table."""

    def __init__(self, table):
        self.table = table

    def __call__(self, i, j, pose_i, pose_j):
        return self.table[int(pose_i[0, 0])]


def test_a_step_reports_the_sample_where_the_pair_came_within_tolerance(monkeypatch):
    """A pair within the contact tolerance at a sample it stepped to is refined from that
    sample's time (not one before); a pair certified to the end of its run by its first
    distance costs exactly that one query."""
    d = strip("s", [20.0, 20.0, 20.0], [90.0, 90.0], ["H-3", "H-3"])
    ch = SweptChecker(d, "arc", HingeDrive(d))
    times, angles = np.array([0.0, 1.0, 2.0, 3.0]), np.zeros((4, 2))
    poses = np.arange(4.0)[:, None, None, None] * np.ones((4, 3, 4, 4))
    refined = []
    monkeypatch.setattr(ch, "_refine", lambda pair, t, dist: refined.append(t) or "contact")
    monkeypatch.setattr(ch, "_split", lambda *args: None)  # nothing touches inside the step
    monkeypatch.setattr(ch, "gap", _MarkedGap([6.0, 0.0, 6.0, 6.0]))
    for rate in (5.0, 10.0):  # a jump to sample 1 (0.9 d covers its motion), a single step to it
        refined.clear()
        monkeypatch.setattr(ch, "_bound", lambda pair, ang0, ang, rate=rate: rate * np.arange(len(ang), dtype=float))
        assert ch._run((0, 2), times, angles, poses, 0, 3, False) == "contact" and refined == [1.0]
    queries = []
    monkeypatch.setattr(ch, "_bound", lambda pair, ang0, ang: np.zeros(len(ang)))  # nothing moves
    monkeypatch.setattr(ch, "gap", lambda i, j, a, b: queries.append(a[0, 0]) or 6.0)
    assert ch._run((0, 2), times, angles, poses, 1, 3, False) is None and queries == [1.0]


def test_refinement_finds_the_touching_time_ahead():
    """Handed a time some way before the pair touches (distance within the tolerance but
    not 0, or uncertified), the refinement looks ahead in growing steps and bisects to the
    first touching time within time_tol_s, as dense sampling finds it."""
    d = strip("t", [20, 10, 20], [170, 170], ["H-5", "H-1"], radius=1.0)
    ch = SweptChecker(d, "point", HingeDrive(d))
    touch = _dense_first_touch(ch, d, "point", np.arange(0.0, 6.0, 0.001))[(0, 2)]
    for early in (0.004, 0.05, 0.3):
        c = ch._refine((0, 2), touch - early, 1e-3)
        assert c.time == pytest.approx(touch, abs=2e-3) and c.distance == 0.0


class _LoopLikeDrive:
    """A drive with loops' interface: angles and their total variation at times."""

    loops = True
    frozen_at: dict = {}

    def __init__(self, drive):
        self.drive = drive

    def angles(self, t):
        return self.drive.angles(t)

    def variation(self, t):
        return 2.0 * np.abs(self.drive.angles(t)) + np.asarray(t, float)[:, None]


def test_a_checker_keeps_no_poses_of_another_drive_or_arrest():
    """Poses between samples are cached per time and per set of arrested hinges: the same
    time after an arrest, and the same time under another drive (``with_drive``), gets
    that drive's poses and bound coordinates, not the cached ones."""
    d = strip("c", [20.0, 10.0, 20.0], [170.0, 170.0], ["H-1", "H-5"], radius=1.0)
    drive = HingeDrive(d)
    ch = SweptChecker(d, "point", drive)
    t = 3.0
    before = ch.poses_at(t).copy()
    np.testing.assert_array_equal(before, forward(d, drive.angles([t]), "point", compiled=True)[0])
    drive.frozen_at[0] = 0.5
    np.testing.assert_array_equal(ch.poses_at(t), forward(d, drive.angles([t]), "point", compiled=True)[0])
    np.testing.assert_array_equal(ch._at(t)[1], ch.bound_coords([t]))
    assert not np.allclose(ch.poses_at(t), before)
    other = ch.with_drive(HingeDrive(d))
    np.testing.assert_array_equal(other.poses_at(t), before)
    loop_like = ch.with_drive(_LoopLikeDrive(HingeDrive(d)))  # the bound's coordinate is the variation
    np.testing.assert_array_equal(loop_like._at(t)[1], loop_like.drive.variation([t]))
    np.testing.assert_array_equal(loop_like.poses_at(t), before)


def test_a_checker_built_on_its_own_relieves_the_design_once(monkeypatch):
    """The panels' rigid polygons come from one relief of the design, made once per
    checker (and once per side view or render), not once per panel: built outside an
    evaluation's cache, a 60-panel staircase's checker used to make its relief 60 times."""
    from foldprint.collision import rigid
    from foldprint.model import derived, relief
    from foldprint.render.scene import _rings as panel_rings

    d = strip("stairs", [6.0] * 60, [90.0 if i % 2 == 0 else -90.0 for i in range(59)], ["H-3"] * 59,
              depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)
    calls = []
    real = relief._relieve
    monkeypatch.setattr(relief, "_relieve", lambda *a: calls.append(1) or real(*a))
    assert derived.current() is None
    checker = SweptChecker(d, "arc", HingeDrive(d))
    assert len(checker.pieces) == 60 and calls == [1]
    assert len(rigid.side_segments(d, "arc")) == 60 and calls == [1, 1]
    assert len(panel_rings(d, "arc")) == 60 and calls == [1, 1, 1]
