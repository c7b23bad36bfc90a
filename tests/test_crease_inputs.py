"""Crease patterns a designer brings: rounded fold angles build within the stated tolerance
(the design's angle resolution or the printer's), the SVG reader's readings of what
Origami Simulator draws (T junctions off by round-off, strays, creases on the outline,
several hinges between two panels, pieces of a cut sheet), and the two crashes of a
pattern whose hinge strips leave no rigid panel and of a strip cut that leaves a line."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import shapely
from hypothesis import given, settings, strategies as st
from shapely.geometry import GeometryCollection, LineString, Polygon

from foldprint.cli.commands import main
from foldprint.collision.clearance import permanent_crossings
from foldprint.core.errors import GeometryError
from foldprint.core.modes import HingeModel
from foldprint.geometry import build_assembly
from foldprint.geometry.hinges import angle_resolution_deg, closed_targets
from foldprint.io.fold_format import design_from_fold
from foldprint.io.svg_format import design_from_svg
from foldprint.model import crease_patterns as cp
from foldprint.physics.kinematics import hinge_frames
from foldprint.physics.loops.closure import LoopSolver

DATA = Path(__file__).parent / "data" / "origami_simulator"


def degree4_rounded(decimals: int | None, rho1: float = -30.0) -> dict:
    """The flat-foldable degree-4 vertex (sector angles 60, 80, 120, 100 deg) on its folding
    path through rho1, its fold angles from the closed form (crease_patterns.degree4_ratio),
    written to ``decimals`` (None: exact)."""
    f = cp.degree4(rho1_deg=rho1)
    if decimals is not None:
        f["edges_foldAngle"] = [round(a, decimals) for a in f["edges_foldAngle"]]
    return f


def closure_residual(design, angles) -> float:
    solver = LoopSolver(hinge_frames(design), [h.id for h in design.hinges])
    return solver.closure(np.asarray(angles))


# -- rounded angles -----------------------------------------------------------------------

def test_the_closed_form_closes_and_its_rounding_does_not():
    """The reference: exact closed-form angles close the vertex to round-off; rounded to
    0.1 deg they leave a residual the build must deal with."""
    exact = design_from_fold(degree4_rounded(None))
    assert closure_residual(exact, [h.angle for h in exact.hinges]) < 1e-9
    rounded = design_from_fold(degree4_rounded(1))
    assert closure_residual(rounded, [h.angle for h in rounded.hinges]) > 1e-5


@pytest.mark.parametrize("decimals", [2, 1])
def test_rounded_degree4_vertex_builds_and_says_so(decimals):
    d = design_from_fold(degree4_rounded(decimals))
    assert angle_resolution_deg(d) == pytest.approx(10.0 ** -decimals)
    asm = build_assembly(d)
    assert len(asm.notes) == 1 and f"angle resolution {10.0 ** -decimals:g} deg" in asm.notes[0]
    angles, note = closed_targets(d, "permanent")
    assert note == asm.notes[0]
    # the build's angles close the loop and stay within the resolution of the written ones
    assert closure_residual(d, angles) < 1e-7
    written = np.array([h.angle_deg for h in d.hinges])
    assert np.abs(np.degrees(angles) - written).max() <= 10.0 ** -decimals
    # and they are the closed form's angles to within that resolution too
    exact = np.array(degree4_rounded(None)["edges_foldAngle"][:4])
    assert np.abs(np.degrees(angles) - exact).max() <= 10.0 ** -decimals


def test_exact_angles_build_without_a_note():
    asm = build_assembly(design_from_fold(degree4_rounded(None)))
    assert asm.notes == ()


def test_angles_off_the_path_beyond_the_resolution_are_refused_with_the_measured_change():
    f = degree4_rounded(1)
    f["edges_foldAngle"][1] += 1.0  # one crease 1 deg off: the closure needs far more than 0.1 deg
    d = design_from_fold(f)
    with pytest.raises(GeometryError) as e:
        build_assembly(d)
    msg = str(e.value)
    assert "mm misfit" in msg and "differ from the targets by" in msg and "0.1 deg" in msg
    change = float(msg.split("differ from the targets by ")[1].split(" deg")[0])
    assert 0.1 < change < 1.0


def test_the_printer_resolution_is_the_tolerance_of_exact_looking_angles():
    """Angles written with many decimals state no resolution: the printer's layer decides."""
    f = degree4_rounded(None)
    f["edges_foldAngle"][1] += 1e-3  # moves points by about 1.7e-5 rad x 30 mm = 5e-4 mm
    d = design_from_fold(f)
    assert angle_resolution_deg(d) is None
    assert "printer's 0.016 mm resolution" in build_assembly(d, resolution_mm=0.016).notes[0]
    with pytest.raises(GeometryError, match="printer's 1e-05 mm"):
        build_assembly(d, resolution_mm=1e-5)


@settings(max_examples=6, deadline=None)
@given(rho1=st.floats(-60.0, -20.0), decimals=st.sampled_from([1, 2, 3]))
def test_rounded_angles_build_and_cross_as_the_exact_ones(rho1, decimals):
    exact = design_from_fold(degree4_rounded(None, rho1))
    rounded = design_from_fold(degree4_rounded(decimals, rho1))
    angles, _ = closed_targets(rounded, "permanent")
    assert np.abs(np.degrees(angles) - np.array([h.angle_deg for h in exact.hinges])).max() <= 10.0 ** -decimals
    assert permanent_crossings(rounded) == permanent_crossings(exact)
    build_assembly(rounded)  # no GeometryError


def test_check_prints_the_tolerance_it_used(tmp_path, capsys):
    path = tmp_path / "vertex.fold"
    path.write_text(json.dumps(degree4_rounded(2)))
    main(["check", str(path), "--samples", "0"])
    out = capsys.readouterr().out
    assert "FP105" in out and "within the design's angle resolution 0.01 deg" in out and "FP102" not in out


def test_export_prints_the_tolerance_it_used(tmp_path, capsys):
    path = tmp_path / "vertex.fold"
    path.write_text(json.dumps(degree4_rounded(1)))
    assert main(["export", str(path), "--out", str(tmp_path / "out"), "--format", "stl"]) == 0
    err = capsys.readouterr().err
    assert "note: the target angles close the loops" in err and "angle resolution 0.1 deg" in err


# -- the two crashes ------------------------------------------------------------------------

def sheet_2x2(angle: float, size: float) -> dict:
    """A 2 x 2 sheet of square panels ``size`` mm wide, both crease lines at ``angle``."""
    n = 2
    vid = lambda i, j: j * (n + 1) + i  # noqa: E731
    verts = [[i * size, j * size] for j in range(n + 1) for i in range(n + 1)]
    faces = [[vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)] for j in range(n) for i in range(n)]
    edges, assign, angles = [], [], []
    for j in range(n + 1):
        for i in range(n):
            edges.append([vid(i, j), vid(i + 1, j)])
            assign.append("B" if j in (0, n) else "V")
            angles.append(0 if j in (0, n) else angle)
    for i in range(n + 1):
        for j in range(n):
            edges.append([vid(i, j), vid(i, j + 1)])
            assign.append("B" if i in (0, n) else "V")
            angles.append(0 if i in (0, n) else angle)
    return {"frame_unit": "mm", "vertices_coords": verts, "faces_vertices": faces, "edges_vertices": edges,
            "edges_assignment": assign, "edges_foldAngle": angles}


@pytest.mark.parametrize("angle", [120.0, 180.0])
def test_loop_sheet_whose_strips_cover_its_panels_gives_a_verdict(tmp_path, capsys, angle):
    """3 mm panels, strips R |rho| wide: no panel keeps a rigid part, so the clearance has
    no solid to measure (it ended in 'need at least one array to concatenate', exit 3)."""
    path = tmp_path / "sheet.fold"
    path.write_text(json.dumps(sheet_2x2(angle, 3.0)))
    code = main(["simulate", str(path), "--json"])
    assert code in (0, 1)
    report = json.loads(capsys.readouterr().out)
    assert report["design"] == "sheet"


def test_strip_cut_leaving_a_line_keeps_the_polygon():
    """GEOS can return a polygon with a zero-area line as a GeometryCollection when strip
    bands are cut from a panel (miura-ori.svg); the rigid part is its polygon."""
    from foldprint.collision.rigid import _largest_polygon  # noqa: PLC2701 - the operation itself

    square = Polygon([(0, 0), (4, 0), (4, 4), (0, 4)])
    small = Polygon([(5, 0), (6, 0), (6, 1)])
    got = _largest_polygon(GeometryCollection([square, LineString([(4, 0), (5, 0)]), small]))
    assert got.geom_type == "Polygon" and got.area == pytest.approx(16.0)
    assert _largest_polygon(GeometryCollection([LineString([(0, 0), (1, 0)])])).is_empty


def test_miura_ori_svg_rigid_parts_are_polygons():
    from foldprint.collision.rigid import convex_pieces, rigid_polygons

    d = design_from_svg((DATA / "miura-ori.svg").read_text(), "miura-ori.svg")
    polys = rigid_polygons(d, HingeModel.ARC)
    assert {p.geom_type for p in polys} == {"Polygon"}
    assert all(convex_pieces(p) for p in polys if not p.is_empty)


# -- the SVG reader ---------------------------------------------------------------------------

def svg(*lines: str) -> str:
    """A 10 x 10 user-unit document, 10 mm per unit, the given elements inside."""
    return ('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 10 10">\n'
            + "\n".join(lines) + "\n</svg>")


BORDER = '<rect x="0" y="0" width="10" height="10" fill="none" stroke="#000"/>'
VALLEY = '<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="#00F" stroke-opacity="0.5"/>'
MOUNTAIN = '<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="#F00" stroke-opacity="0.5"/>'
BLACK = '<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="#000"/>'


def test_crease_ending_on_a_slanted_border_by_round_off_splits_it():
    """boatBase.svg: the border's side runs from x = 515.824 to 515.823 and a crease ends
    at x = 515.823 on it; unsplit, the crease bordered 0 faces."""
    text = svg(BLACK.format(0, 0, 10, 0), BLACK.format(10, 0, 10, 10), BLACK.format(10, 10, 0, 10),
               BLACK.format(0.0001, 10, 0, 0), VALLEY.format(0, 5, 10, 5))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and len(d.hinges) == 1 and d.notes == ()
    assert d.hinges[0].angle_deg == pytest.approx(90.0)


def test_stray_crease_inside_a_panel_is_dropped_with_a_note():
    text = svg(BORDER, VALLEY.format(5, 0, 5, 10), MOUNTAIN.format(6, 5, 8, 5))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and len(d.hinges) == 1
    assert len(d.notes) == 1 and "separate no two faces" in d.notes[0] and "(6, 5)" in d.notes[0]


def test_crease_on_the_outline_is_read_as_border_with_a_note():
    text = svg(BLACK.format(0, 0, 10, 0), BLACK.format(10, 10, 0, 10), BLACK.format(0, 10, 0, 0),
               VALLEY.format(10, 0, 10, 10), VALLEY.format(5, 0, 5, 10))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and len(d.hinges) == 1
    assert len(d.notes) == 1 and "outline" in d.notes[0]


def test_opposite_angles_on_one_line_are_two_hinges_and_simulate_answers(tmp_path, capsys):
    """A valley and a mountain on one line between the same two panels: two hinges on one
    axis whose targets differ: the loop they close decides (they cannot both fold)."""
    text = svg(BORDER, VALLEY.format(5, 0, 5, 5), MOUNTAIN.format(5, 5, 5, 10))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and sorted(h.angle_deg for h in d.hinges) == pytest.approx([-90.0, 90.0])
    path = tmp_path / "opposite.svg"
    path.write_text(text)
    assert main(["simulate", str(path), "--json"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert not report["completed"]


def test_hinge_of_two_segments_at_an_angle_is_two_hinges_and_simulate_answers(tmp_path, capsys):
    """An L-shaped panel around a square one: the creases between them run on two lines."""
    text = svg(BORDER, VALLEY.format(5, 0, 5, 5), VALLEY.format(5, 5, 10, 5))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and len(d.hinges) == 2
    lines = sorted(tuple(np.round(np.ptp(h.line, axis=0), 6)) for h in d.hinges)
    assert lines == [(0.0, 50.0), (50.0, 0.0)]
    path = tmp_path / "bent.svg"
    path.write_text(text)
    assert main(["simulate", str(path), "--json"]) == 1
    assert not json.loads(capsys.readouterr().out)["completed"]


def test_curved_crease_drawn_as_a_polyline_is_refused_as_curved():
    """Three or more straight pieces end to end between the same two panels: the faceted
    curve of Origami Simulator's curved-crease examples (shell6.svg: 40 pieces)."""
    from foldprint.core.errors import DesignError

    text = svg(BORDER, '<polyline points="5,0 5.5,3 5.5,7 5,10" fill="none" stroke="#00F"/>')
    with pytest.raises(DesignError, match="bent line of 3 straight crease pieces.*curved crease"):
        design_from_svg(text, "t.svg")


def test_collinear_pieces_of_one_crease_stay_one_hinge():
    text = svg(BORDER, VALLEY.format(5, 0, 5, 4), VALLEY.format(5, 4, 5, 10))
    d = design_from_svg(text, "t.svg")
    assert len(d.hinges) == 1 and np.ptp(d.hinges[0].line, axis=0)[1] == pytest.approx(100.0)


def test_a_sheet_cut_in_pieces_keeps_the_largest_with_a_note():
    text = svg(BORDER, BLACK.format(3, 0, 3, 10), VALLEY.format(6, 0, 6, 10), VALLEY.format(1.5, 0, 1.5, 10))
    d = design_from_svg(text, "t.svg")
    assert len(d.panels) == 2 and len(d.hinges) == 1
    assert sum(p.area for p in d.panels) == pytest.approx(70.0 * 100.0)
    assert len(d.notes) == 1 and "2 pieces" in d.notes[0]


def test_cli_prints_the_reader_notes(tmp_path, capsys):
    path = tmp_path / "stray.svg"
    path.write_text(svg(BORDER, VALLEY.format(5, 0, 5, 10), MOUNTAIN.format(6, 5, 8, 5)))
    assert main(["simulate", str(path)]) in (0, 1)
    err = capsys.readouterr().err
    assert "note:" in err and "separate no two faces" in err


# -- the benchmark over Origami Simulator's examples ----------------------------------------

def test_benchmark_runs_each_pattern_and_names_the_outcome(tmp_path):
    """benchmarks/bench_origami_simulator.py on a folder of two tiny patterns: one folds,
    one draws a curve (refused for it); docs/doc/ figures are skipped."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "bench_os", Path(__file__).resolve().parent.parent / "benchmarks" / "bench_origami_simulator.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    (tmp_path / "Simple").mkdir()
    (tmp_path / "doc").mkdir()
    (tmp_path / "Simple" / "fold.svg").write_text(svg(BORDER, VALLEY.format(5, 0, 5, 10)))
    (tmp_path / "Simple" / "curve.svg").write_text(svg(BORDER, '<path d="M5 0 c1 3 1 6 0 10" stroke="#00F"/>'))
    (tmp_path / "doc" / "figure.svg").write_text(svg(BORDER))
    out = tmp_path / "bench.json"
    assert bench.main([str(tmp_path), "--out", str(out), "--jobs", "1"]) == 0
    data = json.loads(out.read_text())
    got = {r["file"]: r for r in data["results"]}
    assert set(got) == {"Simple/fold.svg", "Simple/curve.svg"}
    assert got["Simple/fold.svg"]["outcome"] == "completes" and got["Simple/fold.svg"]["exit"] == 0
    assert got["Simple/curve.svg"]["outcome"] == "refused" and got["Simple/curve.svg"]["reason"] == "curved creases"
    assert data["counts"] == {"completes": 1, "refused": 1}
    assert all(r["cpu_s"] > 0 for r in data["results"])
