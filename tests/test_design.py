"""Design model: TOML round trips, the strip shorthand, and every validation error."""

import math
import tomllib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.model.design import strip, tree_order
from foldprint.io.design_io import design_from_dict, design_to_dict, design_to_toml
from foldprint.io.load import load_design
from foldprint.core.errors import DesignError

BOX = {
    "schema": 1, "name": "box",
    "panels": [
        {"id": "base", "outline": [[0, 0], [20, 0], [20, 20], [0, 20]]},
        {"id": "n", "outline": [[0, 20], [20, 20], [20, 30], [0, 30]], "holes": [[[5, 23], [8, 23], [8, 26], [5, 26]]]},
        {"id": "e", "outline": [[20, 0], [30, 0], [30, 20], [20, 20]], "material": "VeroWhite"},
        {"id": "s", "outline": [[0, -10], [20, -10], [20, 0], [0, 0]]},
    ],
    "hinges": [
        {"id": "hn", "panels": ["base", "n"], "angle_deg": 90, "material": "H-1"},
        {"id": "he", "panels": ["base", "e"], "angle_deg": -45, "material": "H-5", "radius_mm": 3},
        {"id": "hs", "panels": ["base", "s"], "angle_deg": 120, "material": "H-7",
         "style": {"stepped": True, "interface": "triangular"}},
    ],
}


def same(a, b):
    return design_to_dict(a) == design_to_dict(b)


def test_box_loads_with_derived_fold_lines():
    d = design_from_dict(BOX, "box.toml")
    assert [h.id for h, _, _ in tree_order(d)] == ["hn", "he", "hs"]
    hn = d.hinge("hn")
    assert sorted(map(tuple, hn.line.tolist())) == [(0.0, 20.0), (20.0, 20.0)]
    assert d.hinge("he").angle == pytest.approx(-math.pi / 4)
    assert d.hinge("hs").style.stepped and d.hinge("hs").style.interface == "triangular"
    assert d.panel("n").holes[0].shape == (4, 2)


def test_toml_round_trip_general(tmp_path):
    d = design_from_dict(BOX, "box.toml")
    text = design_to_toml(d)
    p = tmp_path / "box.toml"
    p.write_text(text)
    d2 = load_design(p)
    assert same(d, d2)
    assert design_to_toml(d2) == text


def test_strip_shorthand_matches_general_form():
    data = {"schema": 1, "name": "s", "strip": {"lengths_mm": [10, 12, 14], "angles_deg": [90, -90],
                                                 "materials": ["H-1", "H-2"]},
            "defaults": {"depth_mm": 6, "thickness_mm": 0.8}}
    d = design_from_dict(data)
    assert d.is_planar_strip and d.depth == 6
    assert [p.area for p in d.panels] == pytest.approx([60, 72, 84])
    assert d.hinges[0].line[:, 0] == pytest.approx([10, 10])
    assert d.hinges[1].line[:, 0] == pytest.approx([22, 22])
    d2 = design_from_dict(tomllib.loads(design_to_toml(d)))
    assert same(d, d2)


@settings(max_examples=25, deadline=None)
@given(lengths=st.lists(st.floats(1, 50), min_size=2, max_size=8), data=st.data())
def test_strip_round_trip_property(lengths, data):
    n = len(lengths)
    angles = data.draw(st.lists(st.floats(-180, 180), min_size=n - 1, max_size=n - 1))
    mats = data.draw(st.lists(st.sampled_from([f"H-{i}" for i in range(1, 8)]), min_size=n - 1, max_size=n - 1))
    d = strip("p", lengths, angles, mats)
    d2 = design_from_dict(tomllib.loads(design_to_toml(d)))
    assert same(d, d2)
    assert [h.angle for h in d2.hinges] == pytest.approx([math.radians(a) for a in angles])


def test_design_is_immutable():
    d = design_from_dict(BOX)
    with pytest.raises(Exception):
        d.name = "x"
    with pytest.raises(ValueError):
        d.panels[0].outline[0, 0] = 5.0


def _with(path, value):
    import copy
    data = copy.deepcopy(BOX)
    target = data
    for k in path[:-1]:
        target = target[k]
    target[path[-1]] = value
    return data


@pytest.mark.parametrize("data,needle", [
    (_with(["hinges", 0, "material"], "H-9"), ["hinge 'hn'", "unknown material 'H-9'", "H-1"]),
    (_with(["panels", 2, "material"], "Wood"), ["panel 'e'", "unknown material 'Wood'"]),
    (_with(["hinges", 1, "material"], "VeroWhite"), ["hinge 'he'", "not a shape-memory"]),
    (_with(["hinges", 0, "panels"], ["n", "e"]), ["hinge 'hn'", "share no edge"]),
    (_with(["hinges", 0, "panels"], ["base", "zz"]), ["hinge 'hn'", "'zz'", "does not exist"]),
    (_with(["panels", 0, "outline"], [[0, 0], [20, 20], [20, 0], [0, 20]]), ["panel 'base'", "self-intersecting"]),
    (_with(["panels", 0, "outline"], [[0, 0], [10, 0], [20, 0]]), ["panel 'base'", "degenerate"]),
    (_with(["panels", 0, "thickness_mm"], 0), ["panel 'base'", "thickness_mm", "> 0"]),
    (_with(["panels", 1, "thickness_mm"], -0.5), ["panel 'n'", "thickness_mm"]),
    (_with(["hinges", 1, "radius_mm"], 0), ["hinge 'he'", "radius_mm"]),
    (_with(["hinges", 0, "angle_deg"], float("nan")), ["hinge 'hn'", "angle_deg", "finite"]),
    (_with(["panels", 0, "outline"], [[0, 0], [20, float("nan")], [20, 20], [0, 20]]), ["panel 'base'", "NaN"]),
    (_with(["hinges", 0, "angle_deg"], 200), ["hinge 'hn'", "outside [-180, 180]"]),
    (_with(["hinges", 2, "style"], {"interface": "zigzag"}), ["hinge 'hs'", "interface"]),
    (_with(["hinges", 2, "style"], {"color": 1}), ["hinge 'hs'", "color"]),
    (_with(["schema"], 7), ["schema"]),
    (_with(["process"], {"bath_temperature_c": "hot"}), ["process.bath_temperature_c", "number"]),
    (_with(["process"], {"duration_s": -1}), ["duration_s"]),
    (_with(["panels", 1, "holes"], [[[50, 50], [60, 50], [60, 60]]]), ["panel 'n'", "holes"]),
])
def test_validation_errors_name_the_item(data, needle):
    with pytest.raises(DesignError) as ei:
        design_from_dict(data, "my.toml")
    msg = str(ei.value)
    assert msg.startswith("my.toml: ")
    for n in needle:
        assert n in msg, (n, msg)


def test_hinge_graph_with_a_loop_is_accepted():
    data = {"schema": 1, "name": "loop", "panels": [
        {"id": "a", "outline": [[0, 0], [10, 0], [10, 10], [0, 10]]},
        {"id": "b", "outline": [[10, 0], [20, 0], [20, 10], [10, 10]]},
        {"id": "c", "outline": [[0, 10], [20, 10], [20, 20], [0, 20]]}],
        "hinges": [{"id": "ab", "panels": ["a", "b"], "angle_deg": 90, "material": "H-1"},
                   {"id": "bc", "panels": ["b", "c"], "angle_deg": 90, "material": "H-1"},
                   {"id": "ca", "panels": ["c", "a"], "angle_deg": 90, "material": "H-1"}]}
    from foldprint.model.design import spanning_tree
    tree, loops = spanning_tree(design_from_dict(data, "loop.toml"))
    assert len(tree) == 2 and [h.id for h, _, _ in loops] == ["bc"]  # BFS from a: ab, ca


def test_disconnected_panel_is_rejected():
    data = _with(["hinges"], BOX["hinges"][:2])
    with pytest.raises(DesignError, match=r"not connected.*\['s'\]"):
        design_from_dict(data, "d.toml")


def test_strip_count_mismatch():
    with pytest.raises(DesignError, match="angles_deg needs 2"):
        design_from_dict({"name": "x", "strip": {"lengths_mm": [1, 2, 3], "angles_deg": [90],
                                                  "materials": ["H-1", "H-1"]}}, "x.toml")


def test_file_errors(tmp_path):
    with pytest.raises(DesignError, match="file not found"):
        load_design(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [")
    with pytest.raises(DesignError, match="bad.toml: not valid TOML"):
        load_design(bad)
    with pytest.raises(DesignError, match="no geometry"):
        design_from_dict({"name": "x"}, "x.toml")
    with pytest.raises(DesignError, match="unknown key"):
        design_from_dict({"name": "x", "panel": []}, "x.toml")
