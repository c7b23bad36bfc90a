"""Hinge graphs with loops (rigid origami): closure at every interior vertex checked by an
independent formula (local frames: rotations about the creases with the sector angles
between), the degree-4 vertex against its closed form, the FOLD input rules and the CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from foldprint.model import crease_patterns as cp
from foldprint.cli.commands import main
from foldprint.model.design import strip
from foldprint.core.errors import DesignError
from foldprint.io.fold_format import design_from_fold
from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics
from foldprint.model.materials import default_library

DURATION = 4.0  # s: the default H-3 creases finish folding by ~3 s at 90 C (3.03 s)


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def interior_vertices(fold: dict) -> list[list[tuple[int, float]]]:
    """Per interior vertex: (edge index, direction angle) of its creases, counter-clockwise.
    A vertex is interior when no border (B) edge touches it."""
    xy = np.array(fold["vertices_coords"], float)[:, :2]
    inc: dict[int, list[int]] = {}
    for i, (a, b) in enumerate(fold["edges_vertices"]):
        inc.setdefault(a, []).append(i)
        inc.setdefault(b, []).append(i)
    out = []
    for v, es in inc.items():
        if any(fold["edges_assignment"][e] == "B" for e in es):
            continue
        ring = []
        for e in es:
            a, b = fold["edges_vertices"][e]
            o = b if a == v else a
            d = xy[o] - xy[v]
            ring.append((e, math.atan2(d[1], d[0]) % (2 * math.pi)))
        out.append(sorted(ring, key=lambda r: r[1]))
    return out


def vertex_closure(ring, rho: dict[int, float]) -> float:
    """max |prod_i Rx(rho_i) Rz(sector_i) - I| around one vertex (rho by edge index)."""
    m = np.eye(3)
    for i, (e, ang) in enumerate(ring):
        sector = (ring[(i + 1) % len(ring)][1] - ang) % (2 * math.pi)
        m = m @ _rx(rho[e]) @ _rz(sector)
    return float(np.abs(m - np.eye(3)).max())


PATTERNS = {"miura": cp.miura, "degree4": cp.degree4, "waterbomb": cp.waterbomb}


@pytest.fixture(scope="module")
def trajectories():
    out = {}
    for name, make in PATTERNS.items():
        fold = make()
        d = design_from_fold(fold)
        out[name] = (fold, d, simulate_kinematics(d, model="point", duration=DURATION, dt=0.01))
    return out


@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_every_interior_vertex_closes_at_every_time(trajectories, name):
    fold, d, traj = trajectories[name]
    col = {int(h.id[1:]): k for k, h in enumerate(d.hinges)}  # hinge "e<edge>"
    rings = interior_vertices(fold)
    assert rings, "the pattern has an interior vertex"
    worst = 0.0
    for row in traj.angles:
        for ring in rings:
            worst = max(worst, vertex_closure(ring, {e: row[col[e]] for e, _ in ring}))
    assert worst < 1e-6
    assert traj.loops is not None and traj.loops.closure < 1e-6
    assert np.abs(traj.angles[-1]).max() > math.radians(30)  # it really folded


def test_degree4_follows_its_closed_form(trajectories):
    """tan(rho2/2) = sin((a+b)/2)/sin((b-a)/2) tan(rho1/2), rho3 = -rho1, rho4 = rho2 at
    every time, and the final state reaches the (consistent) targets."""
    _, d, traj = trajectories["degree4"]
    k = traj.angles
    # below ~1e-3 rad every small configuration closes to within the solver tolerance
    # (the residual is second order), so the branch is only defined once folding starts
    moving = np.abs(k[:, 0]) > 1e-3
    assert moving.sum() > 50
    ratio = np.tan(k[moving, 1] / 2) / np.tan(k[moving, 0] / 2)
    expect = cp.degree4_ratio(60.0, 80.0)
    np.testing.assert_allclose(np.abs(ratio), expect, rtol=1e-6)
    np.testing.assert_allclose(k[moving, 2], -k[moving, 0], atol=1e-7)
    np.testing.assert_allclose(k[moving, 3], k[moving, 1], atol=1e-7)
    np.testing.assert_allclose(np.degrees(k[-1]), [h.angle_deg for h in d.hinges], atol=0.05)


def test_miura_is_one_dof_and_reaches_consistent_targets(trajectories):
    _, d, traj = trajectories["miura"]
    assert traj.loops.dof == 1 and traj.loops.n_loops == 4
    np.testing.assert_allclose(np.degrees(traj.angles[-1]), [h.angle_deg for h in d.hinges], atol=0.05)


def test_variation_bounds_every_angle_change(trajectories):
    """The swept check's bound: cumulative total variation is non-decreasing and covers
    |rho(t) - rho(s)| for any s < t, also between grid times."""
    _, d, _ = trajectories["waterbomb"]
    drive = HingeDrive(d)
    ts = np.sort(np.random.default_rng(1).uniform(0, DURATION, 400))
    ang, var = drive.angles(ts), drive.variation(ts)
    assert np.all(np.diff(var, axis=0) >= -1e-12)
    i, j = np.triu_indices(len(ts), 1)
    assert np.all(var[j] - var[i] >= np.abs(ang[j] - ang[i]) - 1e-12)



@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_a_hinge_held_back_by_its_loops_reports_what_it_reached(trajectories, name):
    """The ratio a crease reached, 1 - (1 - rho/rho_t)/f from its closed angle: never above
    what its material asks for, never below 0 (a crease the closure keeps below its
    programmed residual, or on the wrong side, has reached nothing), at most 1."""
    _, d, traj = trajectories[name]
    drive = HingeDrive(d)
    asked = drive.ratios(traj.times)
    reached = 1.0 - (1.0 - traj.angles / drive.target[None]) / drive.fixity[None]
    assert reached.min() < 0  # the closure holds some crease below its residual: the floor acts
    np.testing.assert_allclose(traj.ratios, np.clip(np.minimum(reached, asked), 0.0, 1.0), rtol=0, atol=1e-12)
    assert traj.ratios.min() >= 0.0 and traj.ratios.max() <= 1.0


def test_a_crease_without_fixity_has_reached_the_share_of_its_target_it_made():
    """A crease of fixity 0 (its programmed bend springs back whole: its drive is its
    target from the start) has reached rho/rho_t, the share of its fold it made, however far
    its material has recovered: a Miura-ori crease the others' slower recovery holds back is
    not done."""
    from dataclasses import replace

    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir

    d = load_design(templates_dir() / "miura_3x3.toml")
    d = replace(d, hinges=(replace(d.hinges[0], fixity=0.0),) + d.hinges[1:])
    traj = simulate_kinematics(d, dt=0.05, duration=8.0)
    drive = HingeDrive(d)
    share = traj.angles[:, 0] / drive.target[0]
    asked = drive.ratios(traj.times)[:, 0]
    assert (asked - share).max() > 0.5  # held back while its material recovers
    np.testing.assert_allclose(traj.ratios[:, 0], np.clip(np.minimum(share, asked), 0.0, 1.0), rtol=0, atol=1e-12)


@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_prefix_products_turn_loop_hinges_about_their_fold_lines(trajectories, name):
    """TreeTransforms (every hinge at once, the swept check's poses) = forward (one hinge
    at a time) on patterns with loops, where the arc hinges are centred (their child
    turns about the fold line): both hinge models, at folded times."""
    from foldprint.physics.kinematics import TreeTransforms, forward

    _, d, traj = trajectories[name]
    ang = traj.angles[::50]
    assert np.abs(ang).max() > math.radians(30)
    for model in ("point", "arc"):
        np.testing.assert_allclose(TreeTransforms(d, model).poses(ang), forward(d, ang, model), rtol=0, atol=1e-9)


def test_a_loop_solution_extended_past_the_duration_keeps_its_grid():
    """Asked for a time past the solved span, the drive solves again on a grid that holds
    the earlier grid's times and the new time, and agrees with a fresh drive there."""
    from dataclasses import replace

    d = design_from_fold(cp.degree4())
    d = replace(d, process=replace(d.process, duration_s=1.5))
    drive = HingeDrive(d)
    first = drive.solve_loops(np.array([0.5]), dt=0.05)
    assert first.times[-1] == pytest.approx(1.5)
    later = drive.solve_loops(np.array([3.03]), dt=0.05)
    assert later.times[-1] == pytest.approx(3.03, abs=1e-12)
    assert np.isin(first.times, later.times).all()
    fresh = HingeDrive(d).solve_loops(np.array([3.03]), dt=0.05)
    np.testing.assert_allclose(later.at([1.0, 2.0, 3.03]), fresh.at([1.0, 2.0, 3.03]), rtol=0, atol=1e-6)


def test_solve_loops_many_solves_every_group_of_grids():
    """Drives whose grids differ (one solved before at an off-grid time keeps that time in
    its new grid) are tracked group by group: after one call every drive covers the
    request, each with the answers it gets alone."""
    from dataclasses import replace

    from foldprint.physics.hinge_drive import loop_dt, solve_loops_many

    d = design_from_fold(cp.degree4())
    d = replace(d, process=replace(d.process, duration_s=1.5))
    times = np.linspace(0.0, 2.0, 201)
    early, fresh = HingeDrive(d), HingeDrive(d)
    early.solve_loops(np.array([0.0037]))
    assert not np.array_equal(early._loop_grid(times, loop_dt(times))[0], fresh._loop_grid(times, loop_dt(times))[0])
    solve_loops_many([early, fresh], times)
    for drive in (early, fresh):
        assert drive._loop_grid(times, loop_dt(times))[0] is None  # solved: nothing left to track
    alone = HingeDrive(d)
    alone.solve_loops(times, dt=loop_dt(times))
    np.testing.assert_array_equal(fresh.angles(times), alone.angles(times))


def test_a_loop_solution_read_on_its_own_grid_is_its_interpolation():
    """At a simulation's times (the loop grid holds them exactly) the drive's angles and
    total variation are the grid's own rows: bit for bit what the piecewise-linear read
    gives; off the grid the read interpolates (and moves off the grid rows)."""
    from dataclasses import replace

    from foldprint.physics.hinge_drive import loop_dt, solve_loops_many
    from foldprint.physics.loops.closure import interp_rows

    d = design_from_fold(cp.miura())
    d = replace(d, process=replace(d.process, duration_s=1.5))
    times = np.linspace(0.0, 1.5, 151)
    drives = [HingeDrive(d, bath_c=c) for c in (85.0, 90.0)]
    solve_loops_many(drives, times)
    for drive in drives:
        sol = drive.solve_loops(times, loop_dt(times))
        assert sol.on_grid(times) and np.array_equal(sol.times, times)
        np.testing.assert_array_equal(drive.angles(times), sol.at(times))
        np.testing.assert_array_equal(drive.variation(times), sol.total_variation(times))
        read = interp_rows(times, sol.times, sol.angles)  # the interpolation the shortcut skips
        np.testing.assert_array_equal(sol.at(times), read)
        k = np.arange(len(times))
        np.testing.assert_array_equal(sol.total_variation(times), sol.variation[k] + np.abs(read - sol.angles[k]))
        off = times[:-1] + 0.004
        assert not sol.on_grid(off)
        np.testing.assert_array_equal(drive.angles(off), sol.at(off))
        assert not np.array_equal(drive.angles(off), sol.angles[:-1])
    assert not np.array_equal(drives[0].angles(times), drives[1].angles(times))


def test_tree_keeps_exact_forward_kinematics():
    d = strip("s", [10, 10, 10], [90, -60], ["H-1", "H-3"])
    traj = simulate_kinematics(d, model="point", duration=2.0)
    drive = HingeDrive(d)
    assert traj.loops is None and drive.loops is None
    np.testing.assert_array_equal(traj.angles, drive.driven(traj.times))


def test_square_of_four_panels_is_locked():
    """Four squares around a vertex, every crease driven to 90 deg: only one straight
    line can fold, so the drive cannot be followed; reported with hinge ids and time."""
    sq = [[0, 0], [10, 0], [20, 0], [0, 10], [10, 10], [20, 10], [0, 20], [10, 20], [20, 20]]
    faces = [[0, 1, 4, 3], [1, 2, 5, 4], [3, 4, 7, 6], [4, 5, 8, 7]]
    edges = [[1, 4], [3, 4], [4, 5], [4, 7], [0, 1], [1, 2], [2, 5], [5, 8], [8, 7], [7, 6], [6, 3], [3, 0]]
    fold = {"frame_unit": "mm", "vertices_coords": sq, "faces_vertices": faces, "edges_vertices": edges,
            "edges_assignment": ["V"] * 4 + ["B"] * 8, "edges_foldAngle": [90] * 4 + [0] * 8}
    d = design_from_fold(fold)
    traj = simulate_kinematics(d, model="point", duration=DURATION)
    assert traj.loops.stuck and traj.loops.stuck[0][0] < DURATION
    assert set(traj.loops.stuck[0][1]) <= {"e0", "e1", "e2", "e3"}
    assert traj.ratios[-1].min() < 0.98  # a held-back hinge is not "done"


# -- FOLD input rules ------------------------------------------------------------------

def test_unit_without_scale_is_refused_and_scale_fixes_it():
    f = cp.degree4()
    f["frame_unit"] = "unit"
    with pytest.raises(DesignError, match="--scale MM_PER_UNIT"):
        design_from_fold(f, source="x.fold")
    del f["frame_unit"]
    with pytest.raises(DesignError, match="frame_unit is missing"):
        design_from_fold(f, source="x.fold")
    d = design_from_fold(f, scale=2.0)
    assert d.hinges[0].length == pytest.approx(60.0)
    f["frame_unit"] = "in"
    assert design_from_fold(f).hinges[0].length == pytest.approx(30 * 25.4)


def test_folded_only_file_is_refused():
    f = cp.degree4()
    f["frame_classes"] = ["foldedForm"]
    with pytest.raises(DesignError, match="only a folded state"):
        design_from_fold(f, source="x.fold")


def test_crease_pattern_frame_is_picked_among_several():
    cpat = cp.degree4()
    folded = dict(cpat, frame_classes=["foldedForm"],
                  vertices_coords=[[x, y, 1.0] for x, y in cpat["vertices_coords"]])
    keys = [k for k in cpat if k.startswith(("vertices", "edges", "faces", "frame"))]
    data = {"file_spec": 1.2, "file_frames": [{k: folded[k] for k in keys}, {k: cpat[k] for k in keys}]}
    d = design_from_fold(data)
    assert len(d.hinges) == 4 and {h.id for h in d.hinges} == {"e0", "e1", "e2", "e3"}


def test_crease_materials_rule():
    d = design_from_fold(cp.miura(), crease_materials={"M": "H-1", "V": "H-5"})
    for h in d.hinges:
        assert h.material == ("H-1" if h.angle < 0 else "H-5")


# -- CLI --------------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(PATTERNS))
def test_cli_simulate_fold_with_loops(tmp_path, capsys, name):
    fold = PATTERNS[name]()
    path = tmp_path / f"{name}.fold"
    path.write_text(json.dumps(fold), encoding="utf-8")
    code = main(["simulate", str(path), "--json", "--duration", str(DURATION), "--method", "fcl"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    r = json.loads(out)
    angles = {h["id"]: math.radians(h["final_angle_deg"]) for h in r["hinges"]}
    assert all(k.startswith("e") for k in angles)
    for ring in interior_vertices(fold):
        # final_angle_deg is rounded to 1e-3 deg in the report
        assert vertex_closure(ring, {e: angles[f"e{e}"] for e, _ in ring}) < 1e-4
    assert r["loops"]["closure_residual"] < 1e-6


def test_cli_unit_needs_scale(tmp_path, capsys):
    f = cp.degree4()
    f["frame_unit"] = "unit"
    path = tmp_path / "u.fold"
    path.write_text(json.dumps(f), encoding="utf-8")
    assert main(["simulate", str(path), "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and "--scale" in err and "Traceback" not in err
    assert main(["simulate", str(path), "--json", "--scale", "0.5", "--duration", "1"]) in (0, 1)
    capsys.readouterr()
    f["frame_classes"] = ["foldedForm"]
    path.write_text(json.dumps(f), encoding="utf-8")
    assert main(["simulate", str(path), "--scale", "1"]) == 2
    assert "foldedForm" in capsys.readouterr().err


# -- printable vertices and the shipped templates ------------------------------------------

def test_relief_keeps_strips_and_panels_apart():
    """At every vertex of the Miura template the trimmed hinge strips and the relieved
    panels are pairwise disjoint in the sheet (no shared area, no touching point between
    different panels), and every hinge keeps most of its length."""
    import itertools

    import shapely
    from shapely.geometry import LineString

    from foldprint.io.load import load_design
    from foldprint.model.relief import relief_vertices, relieve
    from foldprint.io.templates import templates_dir

    d = load_design(templates_dir() / "miura_3x3.toml")
    assert len(relief_vertices(d)) >= 4
    r = relieve(d)
    strips = [LineString(h.line).buffer(h.width / 2, cap_style="flat") for h in r.hinges]
    for a, b in itertools.combinations(strips, 2):
        assert a.intersection(b).area < 1e-9
    rigid = [p.polygon.difference(shapely.union_all(strips)) for p in r.panels]
    for a, b in itertools.combinations(rigid, 2):
        assert a.distance(b) > 0.1  # a strip or the relief always lies between two panels
    for h0, h1 in zip(d.hinges, r.hinges):
        assert 0.4 * h0.length < h1.length < h0.length


def test_relief_too_thin_is_a_design_rule_error():
    from foldprint.core.errors import GeometryError
    from foldprint.model.relief import relieve

    d = design_from_fold(cp.miura(2, 2, width=6.0, height=5.0, shift=2.0), default_radius_mm=5.0)
    with pytest.raises(GeometryError, match="relief"):
        relieve(d)


def test_miura_template_folds_without_collision_and_lock_template_jams(capsys):
    code = main(["simulate", "miura_3x3", "--json", "--method", "fcl", "--duration", "4"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and r["completed"] and r["first_collision"] is None
    code = main(["simulate", "cross_lock_uniform", "--json", "--method", "fcl", "--duration", "4"])
    r = json.loads(capsys.readouterr().out)
    assert code == 1 and not r["completed"] and r["loops"]["not_followed"]


def test_targets_off_the_folding_path_are_refused_with_the_misfit(capsys):
    """cross_lock_uniform drives all four creases of a flat vertex to 90 deg: no rigid
    configuration has those angles, so its folded state cannot be built."""
    assert main(["export", "cross_lock_uniform", "--out", "/nonexistent/never"]) == 2
    err = capsys.readouterr().err
    assert "do not close the loops" in err and "misfit" in err and "Traceback" not in err


def test_loop_hinge_turns_about_its_fold_line_and_prints_the_tangent_arc():
    """A hinge of a pattern with loops (HingeFrame.centred): the child's pose equals the
    point-hinge rotation about the fold line, and the strip is the circular arc tangent to
    both panels (set back w/2 from the fold line): its line at u lies at the distance
    r = w f / |rho| from the arc's centre, f = (rho/2)/tan(rho/2), and turns by rho u / w."""
    from foldprint.physics.kinematics import hinge_frames, hinge_map
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir

    d = load_design(templates_dir() / "miura_3x3.toml")
    for f in hinge_frames(d):
        assert f.centred
        for rho in (0.2, -0.9, 1.7):
            child = hinge_map(f, rho, "arc", 1.0)[0]
            assert np.allclose(child, hinge_map(f, rho, "point", 1.0)[0], atol=1e-12)
            fr = 0.5 * abs(rho) / math.tan(0.5 * abs(rho))
            w = f.width
            r = w * fr / abs(rho)  # = R f at the target angle, where w = R |rho|
            start = f.origin - 0.5 * w * f.normal  # the parent's edge of the strip
            centre = start + np.sign(rho) * r * np.array([0.0, 0.0, 1.0])
            for s in (0.25, 0.5, 1.0):
                t = hinge_map(f, rho, "arc", s)[0]
                p = t[:3, :3] @ (start + s * w * f.normal) + t[:3, 3]
                assert abs(np.linalg.norm(p - centre) - r) < 1e-9
                # the tangent turns with the line: the strip's direction is rotated by rho s
                tangent = t[:3, :3] @ f.normal
                assert abs(np.dot(tangent, f.normal) - math.cos(rho * s)) < 1e-9
        break


def test_loop_hinge_strain_adds_the_stretch_of_the_tangent_arc():
    """FP130/131 for a loop hinge: bending t / (2 R f) plus stretching 1/f - 1. The
    Miura template (60 deg, R 5 mm, t 0.8 mm) sits at 19 %, under the 20 % warning; the
    same patch at 110 deg and R 2.5 mm (the first template) is an error at 73 %."""
    from foldprint.checks.rules import rule_hinge_strain
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir

    class Ctx:
        library = default_library()

    ctx = Ctx()
    ctx.design = load_design(templates_dir() / "miura_3x3.toml")
    assert rule_hinge_strain(ctx) == []
    f = 0.5 * math.radians(60) / math.tan(0.5 * math.radians(60))
    assert abs((1 / f - 1) + 0.8 / (2 * 5.0 * f) - 0.1913) < 5e-4  # the header's 19 %
    ctx.design = design_from_fold(cp.miura(3, 3, width=24, height=20, shift=8, zigzag_deg=110),
                                  default_radius_mm=2.5, crease_materials={"M": "H-2", "V": "H-2"})
    found = rule_hinge_strain(ctx)
    zig = [x for x in found if x.code == "FP130" and "73%" in x.message]
    assert len(zig) == 6 and "stretching 49%" in zig[0].message


def test_miura_template_exports_and_prusaslicer_slices(tmp_path, capsys):
    import shutil
    import subprocess

    code = main(["export", "miura_3x3", "--out", str(tmp_path), "--json",  # folded: the printed state
                 "--format", "3mf,prusa3mf,stl"])
    rec = json.loads(capsys.readouterr().out)
    assert code == 0
    from foldprint.geometry import build_assembly
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir

    asm = build_assembly(load_design(templates_dir() / "miura_3x3.toml"), "permanent")
    import manifold3d as mf

    bodies = [b.to_manifold() for b in asm.bodies]
    assert len(bodies) == 3  # VeroWhite panels, H-2 and H-4 hinges
    for m in bodies:
        assert m.status() == mf.Error.NoError and m.volume() > 0
    for i in range(len(bodies)):
        for j in range(i + 1, len(bodies)):
            assert (bodies[i] ^ bodies[j]).volume() < 1e-6
    prusa = shutil.which("prusa-slicer")
    if prusa is None:
        pytest.skip("prusa-slicer is not on PATH")
    stls = [f["path"] for f in rec["files"] if f["format"] == "stl"]
    assert len(stls) == 3
    for path in stls:
        res = subprocess.run([prusa, "--info", path], capture_output=True, text=True, timeout=120)
        assert res.returncode == 0 and "manifold = yes" in res.stdout, res.stdout + res.stderr
    (p3mf,) = [f["path"] for f in rec["files"] if f["format"] == "prusa3mf"]
    gcode = tmp_path / "m.gcode"
    res = subprocess.run([prusa, "--export-gcode", "--nozzle-diameter", "0.4,0.4,0.4", "--layer-height", "0.2",
                          "--output", str(gcode), p3mf], capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    assert ";LAYER_CHANGE" in gcode.read_text()


def test_a_small_programming_bias_selects_the_miura_branch():
    """The flat sheet is a bifurcation point: from a perfectly flat start (fixity 1) a
    scattered drive sends the tracker down a branch where creases fold against their
    targets; the materials' shape fixity (the template sets none: 0.9967, a 0.2 deg
    residual) keeps every crease on the side of its target for the same draws (docs/loops.md,
    branch selection)."""
    from dataclasses import replace

    from foldprint.io.load import load_design
    from foldprint.simulation.robust import default_scatter, draw_samples, sample_drive
    from foldprint.io.templates import templates_dir

    from foldprint.model.materials import default_fixity
    from foldprint.physics.hinge_drive import HingeDrive

    d = load_design(templates_dir() / "miura_3x3.toml")
    assert all(h.fixity is None for h in d.hinges)
    assert np.all(HingeDrive(d).fixity == default_fixity())
    sign = np.sign([h.angle for h in d.hinges])
    flat = replace(d, hinges=tuple(replace(h, fixity=1.0) for h in d.hinges))
    for design, wrong_expected in ((flat, True), (d, False)):
        drawn = draw_samples(design, default_scatter(), 4, 0)
        wrong = [bool((simulate_kinematics(design, drive=sample_drive(design, default_library(), s),
                                           duration=2.5, dt=0.05).angles * sign < -1e-6).any()) for s in drawn]
        assert any(wrong) == wrong_expected, wrong


def test_degree4_relation_is_signed(trajectories):
    """On degree4()'s branch (crease 1 mountain, 2 valley) the ratio is negative: the
    closed form holds with its sign, not only in magnitude (a magnitude test passes a sign error)."""
    _, _, traj = trajectories["degree4"]
    k = traj.angles
    moving = np.abs(k[:, 0]) > 1e-3
    ratio = np.tan(k[moving, 1] / 2) / np.tan(k[moving, 0] / 2)
    np.testing.assert_allclose(ratio, -cp.degree4_ratio(60.0, 80.0), rtol=1e-6)


def test_degree4_docs_formula_matches_its_targets():
    """docs/loops.md's worked example: its numeric relation applied to its listed rho1
    gives its listed rho2 (the sign was once the opposite of the targets)."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "loops.md").read_text()
    coef = float(re.search(r"= (-?\d+\.\d+) tan\(rho1 / 2\)\n", text).group(1))
    targets = [float(x) for x in re.search(r"targets\s+rho = \(([^)]*)\) deg", text).group(1).split(",")]
    rho1, rho2 = np.radians(targets[0]), np.radians(targets[1])
    assert np.tan(rho2 / 2) == pytest.approx(coef * np.tan(rho1 / 2), rel=1e-4)
    assert coef == pytest.approx(-cp.degree4_ratio(60.0, 80.0), rel=1e-4)
