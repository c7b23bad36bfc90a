"""FOLD export and import (foldprint.exchange.fold)."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import shapely
from shapely.geometry import Polygon
import pytest

from foldprint.model.design import Design, Goal, Hinge, HingeStyle, Panel, Process, strip
from foldprint.io.load import load_design
from foldprint.core.errors import DesignError
from foldprint.exchange.fold import (design_from_fold, design_from_fold_file, design_to_fold,
                                     fold_bytes, write_fold)


# -- fixtures -------------------------------------------------------------------------

def strip_design() -> Design:
    return strip("t", [12, 10, 14], [90, -45], ["H-1", "H-7"])


def box_design() -> Design:
    """A 20x20 base with four flaps: the right flap is narrower than the base side (a
    T-junction), the left hinge covers only part of the common side, the top flap has a
    hole, and the signs are mixed."""
    base = Panel("base", [[0, 0], [20, 0], [20, 20], [0, 20]], 1.0, "VeroWhite")
    bottom = Panel("bottom", [[0, -15], [20, -15], [20, 0], [0, 0]], 0.8, "VeroWhite")
    right = Panel("right", [[20, 5], [32, 5], [32, 15], [20, 15]], 0.6, "TangoBlack")
    top = Panel("top", [[0, 20], [20, 20], [20, 35], [0, 35]], 0.8, "VeroWhite",
                holes=([[8, 25], [12, 25], [12, 29], [8, 29]],))
    left = Panel("left", [[-15, 0], [0, 0], [0, 20], [-15, 20]], 0.8, "VeroWhite")
    hinges = (
        Hinge("hb", ("base", "bottom"), [[0, 0], [20, 0]], math.radians(90), "H-1", 4.0, 0.8),
        Hinge("hr", ("base", "right"), [[20, 5], [20, 15]], math.radians(-60), "H-3", 5.0, 0.7,
              fixity=0.9, style=HingeStyle(stepped=True, interface="triangular")),
        Hinge("ht", ("top", "base"), [[20, 20], [0, 20]], math.radians(-120), "H-5", 6.0, 0.8),
        Hinge("hl", ("base", "left"), [[0, 2], [0, 18]], math.radians(45), "H-7", 5.0, 0.8),
    )
    goal = Goal("g1", "pass_through", "right", "top", 0, [30.0, 10.0], order=1)
    process = Process(program_temperature_c=85.0, fix_temperature_c=5.0, bath_temperature_c=80.0,
                      duration_s=60.0)
    return Design("box", (base, bottom, right, top, left), hinges, process=process,
                  description="a box net", root="base", goals=(goal,))


def ring_set(ring) -> set:
    return {(round(float(x), 9), round(float(y), 9)) for x, y in np.asarray(ring)}


def line_set(line) -> frozenset:
    return frozenset((round(float(x), 9), round(float(y), 9)) for x, y in np.asarray(line))


def assert_same(a: Design, b: Design) -> None:
    assert [p.id for p in a.panels] == [p.id for p in b.panels]
    for p, q in zip(a.panels, b.panels):
        assert ring_set(p.outline) == ring_set(q.outline), p.id
        assert len(p.outline) == len(q.outline), p.id
        assert [ring_set(h) for h in p.holes] == [ring_set(h) for h in q.holes], p.id
        assert (p.material, p.thickness) == (q.material, q.thickness), p.id
    assert [h.id for h in a.hinges] == [h.id for h in b.hinges]
    for h, k in zip(a.hinges, b.hinges):
        assert h.panels == k.panels, h.id
        assert h.angle == pytest.approx(k.angle, abs=1e-9), h.id
        assert (h.material, h.radius, h.thickness, h.fixity, h.style) == \
               (k.material, k.radius, k.thickness, k.fixity, k.style), h.id
        assert line_set(h.line) == line_set(k.line), h.id
    assert a.process == b.process
    assert (a.name, a.root, a.description, a.depth) == (b.name, b.root, b.description, b.depth)
    assert [(g.id, g.type, g.panel, g.target, g.hole, g.tip.tolist(), g.order) for g in a.goals] == \
           [(g.id, g.type, g.panel, g.target, g.hole, g.tip.tolist(), g.order) for g in b.goals]


# -- round trip -------------------------------------------------------------------------

@pytest.mark.parametrize("make", [strip_design, box_design])
def test_round_trip(make):
    d = make()
    back = design_from_fold(design_to_fold(d))
    assert_same(d, back)


def test_box_export_splits_t_junctions_and_partial_hinges():
    f = design_to_fold(box_design())
    xy = [tuple(v) for v in f["vertices_coords"]]
    assert len(xy) == len(set(xy))  # deduplicated
    # the base face gained the right flap's corners and the left hinge's ends
    base = {xy[v] for v in f["faces_vertices"][0]}
    assert {(20.0, 5.0), (20.0, 15.0), (0.0, 2.0), (0.0, 18.0)} <= base
    # the left hinge is exactly one V edge from (0, 2) to (0, 18); the rest of the common side is B
    hl = [i for i, h in enumerate(f["edges_foldprint:hinge_id"]) if h == "hl"]
    assert [{xy[v] for v in f["edges_vertices"][i]} for i in hl] == [{(0.0, 2.0), (0.0, 18.0)}]
    assert f["edges_assignment"][hl[0]] == "V"
    side = [i for i, e in enumerate(f["edges_vertices"])
            if {xy[v] for v in e} in ({(0.0, 0.0), (0.0, 2.0)}, {(0.0, 18.0), (0.0, 20.0)})]
    assert len(side) == 2 and all(f["edges_assignment"][i] == "B" for i in side)
    # the top flap's hole is FOLD geometry: the flap is two counter-clockwise holeless faces
    # cut at the hole's centroid (x = 10), joined by flat edges; the hole's sides are B
    top = [k for k, pid in enumerate(f["faces_foldprint:id"]) if pid == "top"]
    assert len(top) == 2 and all(f["faces_foldprint:holes"][k] == [] for k in top)
    rings = [np.array([xy[v] for v in f["faces_vertices"][k]]) for k in top]
    for ring in rings:
        area2 = np.sum(ring[:, 0] * np.roll(ring[:, 1], -1) - np.roll(ring[:, 0], -1) * ring[:, 1])
        assert area2 > 0
    union = shapely.union_all([Polygon(r) for r in rings])
    assert union.area == pytest.approx(20 * 15 - 16)
    (hole,) = union.interiors  # with the cut's two points on its sides
    assert Polygon(hole).equals(Polygon([(8, 25), (12, 25), (12, 29), (8, 29)]))
    joins = [i for i, e in enumerate(f["edges_vertices"]) if all(xy[v][0] == 10.0 for v in e)]
    assert joins and all(f["edges_assignment"][i] == "F" and f["edges_foldAngle"][i] == 0 for i in joins)
    hole_sides = [i for i, e in enumerate(f["edges_vertices"])
                  if all(8 <= xy[v][0] <= 12 and 25 <= xy[v][1] <= 29 for v in e)]
    assert len(hole_sides) == 6 and all(f["edges_assignment"][i] == "B" for i in hole_sides)


def test_fold_bytes_deterministic_and_valid(tmp_path):
    d = box_design()
    a, b = fold_bytes(d), fold_bytes(box_design())
    assert a == b
    assert a.endswith(b"\n")
    data = json.loads(a)
    assert data["file_spec"] == 1.2
    assert data["file_creator"].startswith("foldprint ")
    assert data["frame_title"] == "box" and data["frame_unit"] == "mm"
    path = write_fold(d, tmp_path / "box.fold")
    assert path.read_bytes() == a
    assert_same(d, load_design(path))  # design_io dispatches .fold here


def test_assignments_and_angles():
    f = design_to_fold(strip_design())
    by_hinge = {h: i for i, h in enumerate(f["edges_foldprint:hinge_id"]) if h}
    assert f["edges_assignment"][by_hinge["h1"]] == "V"
    assert f["edges_foldAngle"][by_hinge["h1"]] == pytest.approx(90.0)
    assert f["edges_assignment"][by_hinge["h2"]] == "M"
    assert f["edges_foldAngle"][by_hinge["h2"]] == pytest.approx(-45.0)
    others = [i for i in range(len(f["edges_vertices"])) if i not in by_hinge.values()]
    assert len(f["edges_vertices"]) == 10 and len(others) == 8
    assert all(f["edges_assignment"][i] == "B" and f["edges_foldAngle"][i] == 0 for i in others)
    assert all(f["edges_foldprint:material"][i] is None for i in others)


def test_flat_hinge_is_F_and_survives():
    d = strip("flat", [10, 10], [0], ["H-2"])
    f = design_to_fold(d)
    i = f["edges_foldprint:hinge_id"].index("h1")
    assert (f["edges_assignment"][i], f["edges_foldAngle"][i]) == ("F", 0.0)
    back = design_from_fold(f)
    assert len(back.panels) == 2 and back.hinges[0].angle == 0.0


# -- foreign files ------------------------------------------------------------------------

def simulator_cp() -> dict:
    """Origami Simulator style: 3D coordinates with z = 0 (unit mm here: its own "unit" needs
    a scale, tested in test_loops.py), a square split
    into two triangles by a flat diagonal and a flap joined by a 90 deg valley."""
    return {
        "file_spec": 1.1, "file_creator": "Origami Simulator: http://git.amandaghassaei.com/OrigamiSimulator/",
        "file_classes": ["singleModel"], "frame_classes": ["creasePattern"], "frame_unit": "mm",
        "frame_title": "sim",
        "vertices_coords": [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]],
        "faces_vertices": [[0, 1, 2], [0, 2, 3], [1, 4, 5, 2]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2], [1, 4], [4, 5], [5, 2]],
        "edges_assignment": ["B", "V", "B", "B", "F", "B", "B", "B"],
        "edges_foldAngle": [0, 90, 0, 0, 0, 0, 0, 0],
    }


def check_simulator(d: Design, s: float = 1.0):
    assert len(d.panels) == 2 and len(d.hinges) == 1
    h = d.hinges[0]
    assert h.angle == pytest.approx(math.pi / 2, abs=1e-12)
    assert h.material == "H-3" and h.radius == 5.0 and h.thickness == 0.8
    assert {p.material for p in d.panels} == {"VeroWhite"}
    assert ring_set(d.panels[0].outline) == {(0, 0), (s, 0), (s, s), (0, s)}
    assert ring_set(d.panels[1].outline) == {(s, 0), (2 * s, 0), (2 * s, s), (s, s)}
    assert line_set(h.line) == {(s, 0.0), (s, s)}
    assert set(h.panels) == {p.id for p in d.panels}


def test_foreign_simulator_pattern():
    d = design_from_fold(simulator_cp())
    check_simulator(d)
    assert d.name == "sim"


def test_foreign_file_frames_wrapped():
    cp = simulator_cp()
    frame = {k: v for k, v in cp.items() if not k.startswith("file_")}
    wrapped = {"file_spec": 1.1, "file_creator": "Rabbit Ear", "file_frames": [frame]}
    check_simulator(design_from_fold(wrapped))


def test_foreign_simulator_xz_plane_and_series_layout():
    """Origami Simulator's own export puts the flat sheet in the xz plane (y = 0); its fold
    series keeps edges and faces at the top level and the coordinates in file_frames."""
    cp = simulator_cp()
    cp["vertices_coords"] = [[x, 0, y] for x, y, _ in cp["vertices_coords"]]
    check_simulator(design_from_fold(cp))
    frame = {"frame_title": "sim", "frame_inherit": True, "vertices_coords": cp.pop("vertices_coords")}
    cp["file_frames"] = [frame]
    check_simulator(design_from_fold(cp))


def test_foreign_units_and_scale():
    cp = simulator_cp()
    cp["frame_unit"] = "cm"
    check_simulator(design_from_fold(cp), 10.0)
    check_simulator(design_from_fold(simulator_cp(), scale=3.0), 3.0)


@pytest.mark.parametrize("letter", ["M", "V", "m"])
def test_foreign_crease_without_fold_angle_is_refused_naming_the_field(letter):
    """FOLD reads a bare M or V as folded flat (+-180 deg); foldprint asks for the angle."""
    cp = simulator_cp()
    cp["edges_assignment"][1] = letter
    del cp["edges_foldAngle"]
    with pytest.raises(DesignError, match=r"edges_foldAngle is missing.*edges_vertices 1\b"):
        design_from_fold(cp)
    cp["edges_foldAngle"] = [None, None, 0, 0, 0, 0, 0, 0]
    with pytest.raises(DesignError, match=r"edges_foldAngle has no value \(null\) for 1 crease"):
        design_from_fold(cp)
    cp["edges_foldAngle"][1] = -45 if letter.upper() == "M" else 45
    assert design_from_fold(cp).hinges[0].angle_deg == pytest.approx(cp["edges_foldAngle"][1])


def test_cli_fold_without_angles_exits_2_in_one_line(tmp_path, capsys):
    from foldprint.cli.commands import main

    cp = simulator_cp()
    del cp["edges_foldAngle"]
    path = tmp_path / "bare.fold"
    path.write_text(json.dumps(cp))
    assert main(["check", str(path), "--samples", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "edges_foldAngle" in err and "Traceback" not in err


def test_foreign_unassigned_edge_with_angle_is_a_hinge():
    cp = simulator_cp()
    cp["edges_assignment"] = ["U"] * 8
    cp["edges_foldAngle"][1] = -30
    d = design_from_fold(cp)
    assert len(d.panels) == 2 and d.hinges[0].angle_deg == pytest.approx(-30.0)


def test_subdivided_crease_merges_into_one_hinge():
    cp = {
        "frame_unit": "mm",
        "vertices_coords": [[0, 0], [1, 0], [1, 1], [0, 1], [2, 0], [2, 1], [1, 0.5]],
        "faces_vertices": [[0, 1, 6, 2, 3], [1, 4, 5, 2, 6]],
        "edges_vertices": [[0, 1], [1, 6], [6, 2], [2, 3], [3, 0], [1, 4], [4, 5], [5, 2]],
        "edges_assignment": ["B", "V", "V", "B", "B", "B", "B", "B"],
        "edges_foldAngle": [0, 120, 120, 0, 0, 0, 0, 0],
    }
    d = design_from_fold(cp, source="sub.fold")
    assert len(d.hinges) == 1
    assert line_set(d.hinges[0].line) == {(1.0, 0.0), (1.0, 1.0)}
    assert d.hinges[0].angle_deg == pytest.approx(120.0)
    assert ring_set(d.panels[0].outline) == {(0, 0), (1, 0), (1, 1), (0, 1)}  # (1, 0.5) dropped
    assert d.name == "sub"


def test_foreign_facets_around_a_hole_give_a_panel_with_a_hole():
    cp = {
        "frame_unit": "mm",
        "vertices_coords": [[0, 0], [3, 0], [3, 3], [0, 3], [1, 1], [2, 1], [2, 2], [1, 2], [4, 0], [4, 3]],
        "faces_vertices": [[0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7], [1, 8, 9, 2]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 6], [6, 7], [7, 4],
                           [0, 4], [1, 5], [2, 6], [3, 7], [1, 8], [8, 9], [9, 2]],
        "edges_assignment": ["B", "V", "B", "B", "B", "B", "B", "B", "F", "F", "F", "F", "B", "B", "B"],
        "edges_foldAngle": [0, 180] + [0] * 13,
    }
    d = design_from_fold(cp)
    assert [len(p.holes) for p in d.panels] == [1, 0]
    assert ring_set(d.panels[0].outline) == {(0, 0), (3, 0), (3, 3), (0, 3)}
    assert ring_set(d.panels[0].holes[0]) == {(1, 1), (2, 1), (2, 2), (1, 2)}
    assert line_set(d.hinges[0].line) == {(3.0, 0.0), (3.0, 3.0)}
    assert d.hinges[0].angle == pytest.approx(math.pi)


# -- errors ----------------------------------------------------------------------------

def test_error_missing_faces():
    cp = simulator_cp()
    del cp["faces_vertices"]
    with pytest.raises(DesignError, match="faces_vertices is missing") as e:
        design_from_fold(cp, source="x.fold")
    assert str(e.value).startswith("x.fold: ")


def test_error_edge_index_out_of_range():
    cp = simulator_cp()
    cp["edges_vertices"][3] = [3, 99]
    with pytest.raises(DesignError) as e:
        design_from_fold(cp, source="x.fold")
    assert str(e.value).startswith("x.fold: ")
    assert "edges_vertices[3] refers to vertex 99 but there are 6 vertices" in str(e.value)


def test_error_folded_3d_coordinates():
    cp = simulator_cp()
    cp["vertices_coords"][5] = [2, 1, 0.5]
    with pytest.raises(DesignError, match="not flat") as e:
        design_from_fold(cp, source="x.fold")
    assert "vertex 5" in str(e.value)


def test_error_unknown_foldprint_material():
    f = design_to_fold(strip_design())
    f = copy.deepcopy(f)
    f["faces_foldprint:material"][1] = "Unobtainium"
    with pytest.raises(DesignError, match="Unobtainium") as e:
        design_from_fold(f, source="m.fold")
    assert str(e.value).startswith("m.fold: ") and "panel 'p2'" in str(e.value)


def test_error_not_json(tmp_path):
    p = tmp_path / "bad.fold"
    p.write_text("{not json", encoding="utf-8")
    with pytest.raises(DesignError, match="not valid JSON") as e:
        design_from_fold_file(p)
    assert str(e.value).startswith(str(p))


def test_error_missing_file(tmp_path):
    p = tmp_path / "nope.fold"
    with pytest.raises(DesignError, match="file not found") as e:
        design_from_fold_file(p)
    assert str(p) in str(e.value)


def test_error_crease_inside_one_panel():
    """A crease that dies out inside the sheet does not separate two panels."""
    cp = {
        "frame_unit": "mm",
        "vertices_coords": [[0, 0], [1, 0], [1, 1], [0, 1], [0.5, 0.5]],
        "faces_vertices": [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]],
        "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 0], [0, 4], [1, 4], [2, 4], [3, 4]],
        "edges_assignment": ["B", "B", "B", "B", "V", "F", "F", "F"],
    }
    with pytest.raises(DesignError, match=r"edges_vertices\[4\] is a V crease inside panel"):
        design_from_fold(cp, source="x.fold")
    cp["edges_assignment"][4] = "F"  # all flat: one square panel from four triangles
    d = design_from_fold(cp)
    assert len(d.panels) == 1 and not d.hinges
    assert ring_set(d.panels[0].outline) == {(0, 0), (1, 0), (1, 1), (0, 1)}
