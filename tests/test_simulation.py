"""ROM kinematics, the paper's collision index, the FCL swept check, goals and templates."""

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from shapely.geometry import LineString

from foldprint.collision.clearance import gaps_in_pose, min_clearance
from foldprint.collision.index2d import collision_index, index_arrays, paper_contact, world_side_segments
from foldprint.collision.broadphase import non_adjacent_pairs
from foldprint.collision.swept3d import SweptChecker
from foldprint.collision.swept_search import swept_first_contact
from foldprint.model.design import strip
from foldprint.io.load import load_design
from foldprint.physics.kinematics import forward, transform_points
from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics
from foldprint.apps.pipeline import build
from foldprint.simulation.simulate import simulate

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"


def template(name):
    return load_design(TEMPLATES / f"{name}.toml")


# -- kinematics ------------------------------------------------------------------------

@pytest.mark.parametrize("rho_deg", [30.0, 90.0, -120.0, 180.0])
def test_two_panel_fold_matches_closed_form_point(rho_deg):
    """Paper Eq. 2-4 for two panels: the child end is at x0 + l cos(phi), z = l sin(phi)."""
    d = strip("two", [10.0, 7.0], [rho_deg], ["H-1"])
    rho = math.radians(rho_deg)
    pose = forward(d, np.array([[rho]]), "point")[0, 1]
    tip = transform_points(pose, np.array([[17.0, 3.0]]))[0]
    assert tip == pytest.approx([10 + 7 * math.cos(rho), 3.0, 7 * math.sin(rho)], abs=1e-12)


@pytest.mark.parametrize("rho_deg", [45.0, 90.0, -90.0, 170.0])
def test_two_panel_fold_matches_closed_form_arc(rho_deg):
    """Arc hinge of width w = R|rho_t| bent uniformly: the child's rigid edge starts at the
    arc's end, (s + (w/rho) sin rho, (w/rho)(1 - cos rho)), turned by rho."""
    R = 5.0
    d = strip("two", [20.0, 15.0], [rho_deg], ["H-1"], radius=R)
    rho = math.radians(rho_deg)
    w = R * abs(rho)
    s = 20.0 - w / 2
    pose = forward(d, np.array([[rho]]), "arc")[0, 1]
    edge = transform_points(pose, np.array([[20.0 + w / 2, 0.0], [35.0, 0.0]]))
    start = np.array([s + w / rho * math.sin(rho), 0.0, w / rho * (1 - math.cos(rho))])
    assert edge[0] == pytest.approx(start, abs=1e-9)
    length = 15.0 - w / 2
    assert edge[1] == pytest.approx(start + length * np.array([math.cos(rho), 0, math.sin(rho)]), abs=1e-9)
    assert abs(w / rho) == pytest.approx(R)


def test_zero_angles_give_identity_poses():
    d = template("helix_graded")
    poses = forward(d, np.zeros((3, len(d.hinges))), "arc")
    assert np.allclose(poses, np.eye(4))


@settings(max_examples=30, deadline=None)
@given(lengths=st.lists(st.floats(3, 40), min_size=3, max_size=7), data=st.data(),
       model=st.sampled_from(["point", "arc"]))
def test_panels_stay_rigid_and_hinges_consistent(lengths, data, model):
    n = len(lengths)
    angles = data.draw(st.lists(st.floats(-180, 180), min_size=n - 1, max_size=n - 1))
    d = strip("r", lengths, angles, ["H-2"] * (n - 1), radius=1.0)
    frac = np.linspace(0, 1, 7)[:, None]
    poses = forward(d, frac * np.radians(angles)[None], model)
    R = poses[..., :3, :3]
    assert np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=1e-9)  # rigid: orthonormal
    assert np.allclose(np.linalg.det(R), 1.0)
    if model == "point":  # fold-line points map to the same place from both panels
        for k, h in enumerate(d.hinges):
            a, b = d.panel_index()[h.panels[0]], d.panel_index()[h.panels[1]]
            for t in range(len(frac)):
                pa = transform_points(poses[t, a], h.line)
                pb = transform_points(poses[t, b], h.line)
                assert np.allclose(pa, pb, atol=1e-9)
                axis = pa[1] - pa[0]  # the axis stays along the fold line, in the xz side view
                assert abs(axis[0]) < 1e-9 and abs(axis[2]) < 1e-9


def test_recovery_drives_angles_and_fixity():
    d = strip("f", [10, 10], [90], ["H-3"])
    tr = simulate_kinematics(d, duration=10, dt=0.05)
    from foldprint.model.materials import default_fixity
    # the material's shape fixity: the programmed hinge keeps 0.3 % of its 90 deg
    assert tr.angles[0, 0] == pytest.approx((1 - default_fixity()) * math.pi / 2, rel=1e-12)
    assert tr.angles[-1, 0] == pytest.approx(math.pi / 2, rel=1e-3)
    assert np.all(np.diff(tr.angles[:, 0]) >= 0)
    from dataclasses import replace
    d2 = replace(d, hinges=(replace(d.hinges[0], fixity=0.8),))
    tr2 = simulate_kinematics(d2, duration=10, dt=0.05)
    assert tr2.angles[0, 0] == pytest.approx(0.2 * math.pi / 2)  # rho = rho_t (1 - (1 - R) f)



def test_a_simulation_runs_for_the_duration_it_is_given():
    """The time grid: 0, dt, ... up to the first time at or past the given duration (the
    design's own duration when none is given), whatever the design's process says."""
    from dataclasses import replace

    d = strip("f", [10, 10], [90], ["H-3"])
    d = replace(d, process=replace(d.process, duration_s=1.0))
    tr = simulate_kinematics(d, dt=0.1, duration=2.35)
    np.testing.assert_allclose(tr.times, 0.1 * np.arange(25), rtol=0, atol=1e-12)
    assert tr.angles.shape == (25, 1) and tr.poses.shape == (25, 2, 4, 4)
    np.testing.assert_allclose(simulate_kinematics(d, dt=0.25).times, [0.0, 0.25, 0.5, 0.75, 1.0], atol=1e-12)


def test_curves_on_their_own_time_grids_are_each_read_on_theirs():
    """Recovery curves handed over on different time grids (no shared stack): each hinge's
    ratio is its own curve at that time (0 before t = 0, held past the horizon), an
    arrested hinge holds its value, and the angles follow rho_t (1 - (1 - R) f)."""
    from dataclasses import replace

    from foldprint.model.materials import default_library
    from foldprint.physics.recovery.curve import recovery_curve

    d = strip("g", [10, 10, 10], [90, -60], ["H-1", "H-3"])
    lib = default_library()
    c1, c2 = (recovery_curve(lib[h.material], d.process.bath_temperature_c, h.thickness,
                             d.process.fix_temperature_c) for h in d.hinges)
    c2 = replace(c2, t=c2.t[::3], ratio=c2.ratio[::3], mean_temperature_c=c2.mean_temperature_c[::3])
    drive = HingeDrive(d, curves=[c1, c2])
    ts = np.array([-1.0, 0.0, 0.7, 2.5, 9.0, 1e6])
    ref = np.column_stack([np.interp(ts, c.t, c.ratio, left=0.0) for c in (c1, c2)])
    np.testing.assert_allclose(drive.ratios(ts), ref, rtol=0, atol=1e-15)
    assert ref[2:5, 1].min() > 0 and not np.allclose(ref[:, 0], ref[:, 1])  # two different curves
    drive.frozen_at[1] = 0.7
    held = np.interp(np.minimum(ts, 0.7), c2.t, c2.ratio, left=0.0)
    np.testing.assert_allclose(drive.ratios(ts), np.column_stack([ref[:, 0], held]), rtol=0, atol=1e-15)
    target, fix = np.radians([90.0, -60.0]), drive.fixity
    np.testing.assert_allclose(drive.angles(ts), target * (1 - (1 - np.column_stack([ref[:, 0], held])) * fix),
                               rtol=0, atol=1e-15)


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(rows=st.lists(st.integers(0, 2), min_size=1, max_size=10))
@example(rows=[0, 1, 0])
@example(rows=[2, 2, 0, 1, 1, 2])
def test_held_configurations_get_the_poses_forward_gives(rows):
    """The poses of a pattern with loops are computed once per distinct configuration in
    a row of held ones: every row, also one that returns to an earlier configuration,
    gets exactly forward's poses (derandomised: the poses feed the collision check)."""
    from foldprint.physics.hinge_drive import _held_forward

    d = strip("h", [10, 12, 9], [90, -60], ["H-1", "H-3"])
    palette = np.radians([[0.0, 0.0], [30.0, -20.0], [90.0, -60.0]])
    angles = palette[rows]
    for model in ("point", "arc"):
        # forward on the path the simulation takes (compiled where numba loads)
        np.testing.assert_array_equal(_held_forward(d, angles, model), forward(d, angles, model, compiled=True))


# -- the paper's 2D index ----------------------------------------------------------------

def test_index_cases_from_the_paper():
    p1, p2 = np.array([0.0, 0.0]), np.array([1.0, 0.0])
    cases = [  # (q1, q2, contact)
        ((0.5, -1), (0.5, 1), True),      # crossing
        ((0.5, 1), (0.5, 2), False),      # 0 < S_i < 1, S_j < 0
        ((0.5, -2), (0.5, -1.5), False),  # 0 < S_i < 1, S_j > 1: exception (1)
        ((2, -1), (2, 1), False),         # S_i > 1, 0 < S_j < 1: exception (2)
        ((-1, -1), (-2, -2), False),      # both negative: exception (3)
        ((0.2, 0), (0.8, 0), True),       # collinear overlap
        ((2, 0), (3, 0), False),          # collinear, apart
        ((0, 1), (1, 1), False),          # parallel
    ]
    for q1, q2, expect in cases:
        si, sj, _, coll = index_arrays(p1, p2, np.array(q1, float), np.array(q2, float))
        assert bool(paper_contact(np.asarray(si), np.asarray(sj)) | coll) == expect, (q1, q2)


@settings(max_examples=40, deadline=None)
@given(lengths=st.lists(st.floats(2, 30), min_size=3, max_size=8), data=st.data())
def test_index_agrees_with_shapely_on_random_strips(lengths, data):
    n = len(lengths)
    angles = data.draw(st.lists(st.floats(-175, 175), min_size=n - 1, max_size=n - 1))
    d = strip("x", lengths, angles, ["H-1"] * (n - 1))
    poses = forward(d, np.linspace(0, 1, 5)[:, None] * np.radians(angles)[None], "point")
    from foldprint.physics.kinematics import Trajectory
    tr = Trajectory(d, np.arange(5.0), np.zeros((5, n - 1)), np.zeros((5, n - 1)), poses, "point", 90.0, (), ())
    idx = collision_index(tr)
    segs = world_side_segments(d, poses, "point")
    for t in range(5):
        for k, (i, j) in enumerate(idx.pairs):
            if idx.adjacent[k]:
                continue
            a, b = LineString(segs[i][t, 0]), LineString(segs[j][t, 0])
            # shapely's closed intersection; the paper's open rule differs only on a
            # measure-zero boundary, so skip pairs that merely touch within round-off
            if a.distance(b) < 1e-9 and not a.crosses(b) and not a.overlaps(b):
                continue
            assert bool(idx.contact[t, k]) == a.intersects(b), (t, i, j)


# -- the 3D swept check ------------------------------------------------------------------

def test_contact_between_samples_is_found_and_matches_dense_sampling():
    """helix_uniform: p4 and p9 touch transiently (near 2.6 s) and part again. With samples
    0.5 s apart no sample is in contact; the swept check still finds the contact, at
    the time dense (1 ms) sampling with trimesh gives."""
    import trimesh

    d = template("helix_uniform")
    coarse = simulate_kinematics(d, dt=0.5, duration=5.0, model="point")
    drive = HingeDrive(d)
    checker = SweptChecker(d, "point", drive)
    from foldprint.collision.rigid import rigid_polygon

    meshes = []
    for i, p in enumerate(d.panels):
        m = trimesh.creation.extrude_polygon(rigid_polygon(d, i, "point"), p.thickness)
        m.apply_translation([0, 0, -p.thickness / 2])
        meshes.append(m)

    def touching(poses, i, j):
        cm = trimesh.collision.CollisionManager()
        cm.add_object("a", meshes[i], poses[i])
        cm.add_object("b", meshes[j], poses[j])
        return cm.in_collision_internal()

    i, j = d.panel_index()["p4"], d.panel_index()["p9"]
    assert not any(touching(coarse.poses[k], i, j) for k in range(len(coarse.times)))
    contact, _ = swept_first_contact(checker, coarse.times, coarse.angles, coarse.poses)
    assert contact is not None and contact.panels == ("p4", "p9")
    dense = simulate_kinematics(d, times=np.arange(contact.time - 0.2, contact.time + 0.2, 0.001), model="point")
    hits = [t for t, P in zip(dense.times, dense.poses) if touching(P, i, j)]
    assert hits and hits[0] > dense.times[0], "dense sampling must see the contact begin"
    assert abs(contact.time - hits[0]) <= 2e-3
    k = int(contact.time // 0.5)
    assert all(not touching(coarse.poses[s], i, j) for s in (k, k + 1))  # the samples around it


def test_no_false_contact_for_graded_helix_against_dense_sampling():
    d = template("helix_graded")
    res = simulate(d, method="fcl", dt=0.05)
    assert res.first_collision is None
    dense = simulate_kinematics(d, dt=0.002, duration=8.0, model="point")
    checker = SweptChecker(d, "point", HingeDrive(d))
    worst = min(checker.gap(i, j, dense.poses[k][i], dense.poses[k][j])
                for k in range(0, len(dense.times), 25) for i, j in non_adjacent_pairs(d))
    assert worst > 0.0


# -- templates: the paper's outcomes reproduced -------------------------------------------

def test_helix_uniform_collides_with_both_methods_in_the_paper_rom():
    """The paper's own ROM (point hinges) reproduces Fig. 3c/4b: a collision."""
    d = template("helix_uniform")
    for method in ("index2d", "fcl"):
        r = simulate(d, method=method, hinge_model="point")
        assert not r.completed
        assert r.first_collision is not None and r.first_collision.method == method
    r2 = simulate(d, method="index2d", hinge_model="point")
    assert set(r2.first_collision.panels) == {"p4", "p9"}


def test_helix_uniform_printed_geometry_clears_nominally():
    """With the printed arc hinges the nominal fold of nine identical hinges does not touch
    (docs/simulation.md: the paper's Sample 1 and the faithful model disagree)."""
    r = simulate(template("helix_uniform"), method="fcl")
    assert r.trajectory.model == "arc" and r.first_collision is None


def test_helix_uniform_stalls_with_arrest():
    r = simulate(template("helix_uniform"), after_contact="arrest", method="fcl", hinge_model="point")
    err = np.degrees(r.final_angle_error())
    assert len(r.contacts) >= 2 and err.max() > 5.0 and err[:3].max() < 1e-6


def test_helix_graded_completes_in_time():
    r = simulate(template("helix_graded"), method="both")
    assert r.completed and r.first_collision is None
    assert 5.0 <= r.fold_time <= 9.0
    ft = dict(zip([h.material for h in r.design.hinges], r.trajectory.fold_times))
    assert ft["H-1"] <= 3.5


#: the smallest clearance we ask of the self-locking strip's fold (scripts/derive_self_lock.py
#: cuts each hole 1 mm around the swept region; docs/simulation.md)
SELF_LOCK_MARGIN_MM = 0.5


def test_self_lock_passes_both_holes_in_order():
    """The printed strip (arc hinges, the default) threads p6 through hole 1 then hole 2,
    completes, and never comes closer than the margin to another panel."""
    d = template("self_lock")
    r = simulate(d, method="both")
    assert r.trajectory.model == "arc"
    assert r.completed and r.first_collision is None
    g = {x.goal.id: x for x in r.goals}
    assert g["hole1"].met and g["hole2"].met and g["hole1"].time < g["hole2"].time
    # hole 1 while hinge 3 (H-3) closes the loop, hole 2 only as the slow H-6 hinges fold
    assert g["hole1"].time < r.trajectory.fold_times[2] < r.trajectory.onset_times[3] < g["hole2"].time
    gap = min_clearance(SweptChecker(d, "arc", None), r.trajectory.times, r.trajectory.poses)
    assert gap.distance >= SELF_LOCK_MARGIN_MM


def test_self_lock_is_robust_to_scatter_and_the_paper_rom_differs():
    """The holes admit the printed part as it varies (nominal + 20 scatter samples, design
    seed 100): fresh draws (seed 1) do not jam. The paper's point ROM, which the holes were
    not cut for, moves differently and strikes the plate (reported as a disagreement)."""
    from foldprint.simulation.robust import jam_probability

    d = template("self_lock")
    r = jam_probability(d, 12, 1)
    assert r.jams == 0 and r.nominal.completed
    p = simulate(d, method="fcl", hinge_model="point")
    assert not p.completed and p.first_collision is not None


def test_self_lock_uniform_fails():
    """Same geometry, every hinge H-3: everything folds at once and the end strikes the plate."""
    r = simulate(template("self_lock_uniform"), method="both")
    assert r.trajectory.model == "arc"
    assert not r.completed
    assert r.first_collision is not None and set(r.first_collision.panels) == {"p1", "p6"}
    assert not any(x.met for x in r.goals)  # it strikes the plate before reaching hole 1


@pytest.mark.parametrize("name", ["self_lock", "self_lock_uniform"])
def test_self_lock_builds_in_both_states(name):
    """Both printed states build with every body disjoint (the build raises otherwise); a
    second method agrees: FCL's distance between the non-adjacent rigid panels in the
    printed (permanent) pose is at least the margin, and the flat programmed pose has no
    two non-adjacent panels closer than the gap between them along the strip."""
    d = template(name)
    for state in ("permanent", "programmed"):
        asm = build(d, state)
        assert len(asm.bodies) == len(d.materials_used)
    checker = SweptChecker(d, "arc", None)
    printed = forward(d, np.array([[h.angle for h in d.hinges]]), "arc")[0]
    flat = forward(d, np.zeros((1, len(d.hinges))), "arc")[0]
    assert gaps_in_pose(checker, printed, 1e300, non_adjacent_pairs(d), 0.0)[0].distance >= SELF_LOCK_MARGIN_MM
    assert gaps_in_pose(checker, flat, 1e300, non_adjacent_pairs(d), 0.0)[0].distance > 5.0


@pytest.mark.parametrize("model", ["point", "arc"])
def test_mailbox_folds_in_sequence_without_collision(model):
    r = simulate(template("mailbox"), method="fcl", hinge_model=model)
    assert r.completed and r.first_collision is None
    assert not r.design.is_planar_strip  # a 3D panel tree
    ft = {}
    for h, t in zip(r.design.hinges, r.trajectory.fold_times):
        ft.setdefault(h.material, []).append(t)
    assert max(ft["H-3"]) < min(ft["H-5"]) and max(ft["H-5"]) < min(ft["H-6"])
    assert 8.0 <= r.fold_time <= 14.0


def test_mailbox_reversed_jams():
    r = simulate(template("mailbox_reversed"), method="fcl")
    assert not r.completed and r.first_collision is not None


def _crossings_column_by_column(times, ratios, level):
    """The first step at or above ``level`` and the linear crossing time, one column at a
    time in plain Python floats: the reference the array pass must match bit for bit."""
    steps, out = [], []
    for col in np.asarray(ratios).T.tolist():
        j = next((k for k, r in enumerate(col) if r >= level), -1)
        steps.append(j)
        if j < 0:
            out.append(math.nan)
        elif j == 0:
            out.append(float(times[0]))
        else:
            f = (level - col[j - 1]) / (col[j] - col[j - 1])
            out.append(float(times[j - 1]) + f * (float(times[j]) - float(times[j - 1])))
    return steps, out


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2 ** 32 - 1), st.integers(1, 40), st.integers(0, 7))
def test_level_crossings_match_a_column_by_column_reference(seed, n_t, n):
    """Columns that reach the level at the first step, later, never, or hold NaN: the same
    steps and the same crossing times (NaN where never) as the scalar reference, on the
    numpy path and the compiled one (``kinematics_kernels.level_steps``)."""
    import os
    from unittest import mock

    from foldprint.simulation.simulate import level_crossings

    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.001, 0.1, n_t))
    ratios = np.sort(rng.uniform(0.0, 1.05, (n_t, n)), axis=0)
    if n and n_t > 2:
        ratios[:, 0] = np.where(rng.random(n_t) < 0.2, np.nan, ratios[:, 0])
    for path in ("numpy", "numba"):
        with mock.patch.dict(os.environ, {"FOLDPRINT_KERNELS": path}):
            for level in (0.98, 0.5, float(ratios[0, 0]) if n else 0.5):
                steps, got = level_crossings(times, ratios, level)
                ref_steps, ref = _crossings_column_by_column(times, ratios, level)
                assert steps == ref_steps
                assert [repr(x) for x in got] == [repr(x) for x in ref]
