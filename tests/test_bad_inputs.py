"""Every bad input exits 2 with one clear line naming the item, and writes no file."""

import os

import pytest

from foldprint.cli.commands import main

GOOD_STRIP = """schema = 1
name = "{name}"
[strip]
lengths_mm = [10, 12, 14]
angles_deg = [90, 90]
materials = ["H-1", "H-2"]
"""

BOX = """schema = 1
name = "box"
[[panels]]
id = "base"
outline = [[0, 0], [20, 0], [20, 20], [0, 20]]
[[panels]]
id = "lid"
outline = [[0, 20], [20, 20], [20, 30], [0, 30]]
[[panels]]
id = "side"
outline = [[20, 0], [30, 0], [30, 20], [20, 20]]
[[hinges]]
id = "h1"
panels = ["base", "lid"]
angle_deg = 90
material = "H-1"
[[hinges]]
id = "h2"
panels = ["base", "side"]
angle_deg = 90
material = "H-1"
"""

def _sq(pid, x, y):
    return f'[[panels]]\nid = "{pid}"\noutline = [[{x}, {y}], [{x + 10}, {y}], [{x + 10}, {y + 10}], [{x}, {y + 10}]]\n'


def _hinge(hid, a, b):
    return f'[[hinges]]\nid = "{hid}"\npanels = ["{a}", "{b}"]\nangle_deg = 90\nmaterial = "H-1"\n'


DISCONNECTED = ('schema = 1\nname = "apart"\n' + _sq("a", 0, 0) + _sq("b", 10, 0) + _sq("c", 0, 10)
                + _sq("d", 30, 30) + _hinge("ab", "a", "b") + _hinge("ca", "c", "a"))

CASES = {
    "malformed_toml": ("bad.toml", 'name = "x"\n[strip\nlengths_mm = [1,', ["bad.toml", "not valid TOML"]),
    "malformed_fold": ("bad.fold", '{"vertices_coords": [[0,0],[1,0]], "faces_vertices": [[0,1,', ["bad.fold", "JSON"]),
    "fold_no_faces": ("nofaces.fold", '{"file_spec": 1.2, "vertices_coords": [[0,0],[1,0],[1,1]], '
                      '"edges_vertices": [[0,1],[1,2],[2,0]]}', ["nofaces.fold", "faces_vertices"]),
    "unknown_material": ("m.toml", GOOD_STRIP.format(name="m").replace('"H-2"', '"H-42"'), ["h2", "H-42"]),
    "dangling_hinge": ("d.toml", BOX.replace('panels = ["base", "side"]', 'panels = ["base", "ghost"]'),
                       ["h2", "ghost"]),
    "disconnected": ("t.toml", DISCONNECTED, ["not connected", "'d'"]),
    "self_intersecting": ("s.toml", BOX.replace("[[0, 0], [20, 0], [20, 20], [0, 20]]",
                                                "[[0, 0], [20, 20], [20, 0], [0, 20]]"), ["base", "self-intersecting"]),
    "nan": ("n.toml", GOOD_STRIP.format(name="n").replace("[10, 12, 14]", "[10, nan, 14]"), ["lengths_mm[1]", "finite"]),
    "zero_size": ("z.toml", GOOD_STRIP.format(name="z").replace("[10, 12, 14]", "[10, 0, 14]"), ["lengths_mm[1]", "> 0"]),
    "negative_size": ("neg.toml", BOX.replace('id = "lid"', 'id = "lid"\nthickness_mm = -1'), ["lid", "thickness_mm"]),
    "angle_out_of_range": ("a.toml", GOOD_STRIP.format(name="a").replace("[90, 90]", "[90, 270]"), ["h2", "[-180, 180]"]),
}


def listing(path):
    return sorted(os.listdir(path))


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("command", ["simulate", "check"])
def test_bad_design_exits_2(tmp_path, capsys, case, command):
    fname, text, needles = CASES[case]
    f = tmp_path / fname
    f.write_text(text)
    before = listing(tmp_path)
    code = main([command, str(f), "--json"])
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == "" and "Traceback" not in err and err.count("\n") == 1
    for n in needles:
        assert n in err, (n, err)
    assert listing(tmp_path) == before


def test_missing_file(tmp_path, capsys):
    code = main(["simulate", str(tmp_path / "nope.toml")])
    err = capsys.readouterr().err
    assert code == 2 and "nope.toml" in err and "not found" in err


def test_unwritable_plot_directory(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        if os.access(ro, os.W_OK):
            pytest.skip("running as a user who can write anywhere (root); chmod cannot make it read-only")
        code = main(["simulate", "helix_graded", "--plot", str(ro / "plots")])
        err = capsys.readouterr().err
        assert code == 2 and str(ro) in err
        assert listing(ro) == []
    finally:
        ro.chmod(0o700)


def test_output_path_that_is_a_file(tmp_path, capsys):
    blocker = tmp_path / "afile"
    blocker.write_text("x")
    code = main(["simulate", "helix_graded", "--plot", str(blocker / "plots")])
    err = capsys.readouterr().err
    assert code == 2 and "afile" in err and "Traceback" not in err
    assert blocker.read_text() == "x"


def test_output_directory_that_cannot_be_created(capsys):
    code = main(["simulate", "helix_graded", "--plot", "/proc/foldprint-cannot-exist/plots"])
    err = capsys.readouterr().err
    assert code == 2 and "/proc/foldprint-cannot-exist" in err and "Traceback" not in err


# -- hostile design files, each a case a user or fuzzer once hit ---------------------------

import json  # noqa: E402

GOAL_DESIGN = """schema = 1
name = "g"
[strip]
lengths_mm = [20, 20, 20]
angles_deg = [90, 90]
materials = ["H-1", "H-2"]
holes = [{panel = 1, polygon = [[5, 2], [15, 2], [15, 4], [5, 4]]}]
[[goals]]
id = "g1"
type = "pass_through"
panel = "p3"
target = "p1"
hole = 0
tip = [55, 3]
order = 0
"""


def _strip(**over):
    base = {"lengths_mm": "[10, 12, 14]", "angles_deg": "[90, 90]", "materials": '["H-1", "H-2"]'}
    base.update(over)
    return 'schema = 1\nname = "s"\n[strip]\n' + "".join(f"{k} = {v}\n" for k, v in base.items())


def _deep(n, open_="[", close="]"):
    return open_ * n + close * n


FOLD_OK = {"file_spec": 1.2, "vertices_coords": [[0, 0], [10, 0], [10, 6], [0, 6], [20, 0], [20, 6]],
           "faces_vertices": [[0, 1, 2, 3], [1, 4, 5, 2]], "edges_vertices": [[1, 2]],
           "edges_assignment": ["V"], "edges_foldAngle": [90]}

NAMED = {  # name: (file name, text, needles in the one-line message)
    "goal_order_nan": ("g.toml", GOAL_DESIGN.replace("order = 0", "order = nan"), ["goals[0].order", "whole number"]),
    "fixity_string": ("f.toml", _strip() + '[defaults]\nfixity = "x"\n', ["defaults.fixity", "number"]),
    "panels_number": ("p.toml", 'schema = 1\nname = "p"\npanels = 5\n', ["panels", "list"]),
    "goals_number": ("g5.toml", _strip().replace("[strip]", "goals = 5\n[strip]"), ["goals", "list"]),
    "strip_thickness_string": ("t.toml", _strip(thickness_mm='"ab"'), ["strip.thickness_mm", "number"]),
    "goal_hole_table": ("gh.toml", GOAL_DESIGN.replace("hole = 0", "hole = {}"), ["goals[0].hole", "whole number"]),
    "deep_toml": ("deep.toml", "schema = 1\nx = " + _deep(1200) + "\n", ["deep.toml", "nested"]),
    "deep_fold": ("deep.fold", '{"a": ' + _deep(1200) + "}", ["deep.fold", "nested"]),
    "deep_fold_objects": ("deepo.fold", '{"a":' * 1200 + "1" + "}" * 1200, ["deepo.fold", "nested"]),
    "huge_length": ("hl.toml", _strip(lengths_mm="[30, 30, 1e6]"), ["lengths_mm[2]", "10000"]),
    "huge_coordinates": ("hc.toml", BOX.replace("[[0, 0], [20, 0], [20, 20], [0, 20]]",
                                                "[[0, 0], [1e15, 0], [1e15, 20], [0, 20]]"), ["outline", "10000"]),
    "step_period_tiny": ("sp.toml", _strip() + "[defaults.hinge_style]\nstepped = true\nstep_period_mm = 1e-6\n",
                         ["step_period_mm", "0.01"]),
    "tooth_pitch_tiny": ("tp.toml", _strip() + '[defaults.hinge_style]\ninterface = "triangular"\n'
                         "tooth_pitch_mm = 1e-6\n", ["tooth_pitch_mm", "0.01"]),
    "radius_1e308": ("r.toml", _strip(hinge_radius_mm="1e308"), ["hinge_radius_mm", "10000"]),
    "radius_string": ("rs.toml", _strip() + '[defaults]\nhinge_radius_mm = "5"\n', ["hinge_radius_mm", "without quotes"]),
    "thickness_bool": ("tb.toml", _strip(thickness_mm="true"), ["strip.thickness_mm", "boolean"]),
    "hole_panel_99": ("h99.toml", _strip(holes='[{panel = 99, polygon = [[1, 1], [3, 1], [3, 3]]}]'),
                      ["strip.holes[0].panel", "99"]),
    "overlap": ("ov.toml", BOX.replace('[[20, 0], [30, 0], [30, 20], [20, 20]]',
                                       '[[15, 0], [30, 0], [30, 20], [15, 20]]').replace(
        'panels = ["base", "side"]', 'panels = ["base", "side"]\nline = [[20, 0], [20, 20]]'),
        ["'base'", "'side'", "overlap"]),
    "long_name": ("ln.toml", _strip().replace('name = "s"', f'name = "{"x" * 5000}"'), ["name", "5000 characters"]),
    "fold_holes_number": ("fh.fold", json.dumps(dict(FOLD_OK, **{"faces_foldprint:holes": [5, None]})),
                          ["faces_foldprint:holes[0]"]),
    "binary": ("b.toml", "\x00\x01\x02schema", ["b.toml"]),
    "duration_1e9": ("d.toml", _strip().replace("[strip]", "[process]\nduration_s = 1e9\n[strip]"),
                     ["--duration", "--max-memory", "--dt"]),
}


@pytest.mark.parametrize("case", sorted(NAMED))
@pytest.mark.parametrize("command", ["check", "export"])
def test_named_case_exits_2_and_writes_nothing(tmp_path, capsys, case, command):
    fname, text, needles = NAMED[case]
    if case == "duration_1e9" and command == "export":
        pytest.skip("export does not simulate; a long duration is valid for it")
    f = tmp_path / fname
    f.write_bytes(text.encode("utf-8"))
    out_dir = tmp_path / "out"
    args = [command, str(f), "--json"] + (["--out", str(out_dir)] if command == "export" else [])
    code = main(args)
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == "" and "Traceback" not in err and err.count("\n") == 1, err
    for n in needles:
        assert n in err, (n, err)
    assert not out_dir.exists()


def test_duration_1e9_simulate_refused(tmp_path, capsys):
    f = tmp_path / "d.toml"
    f.write_text(NAMED["duration_1e9"][1])
    code = main(["simulate", str(f)])
    err = capsys.readouterr().err
    assert code == 2 and "memory limit" in err and "--duration" in err
    # the same run with a coarser step is allowed: the guard counts steps, not seconds
    f.write_text(_strip().replace("[strip]", "[process]\nduration_s = 1e4\n[strip]"))
    assert main(["simulate", str(f), "--dt", "5", "--method", "index2d"]) in (0, 1)


def test_index2d_on_2000_panel_strip_refused_naming_the_limit(tmp_path, capsys):
    n = 2000
    f = tmp_path / "big.toml"
    f.write_text(_strip(lengths_mm=str([4] * n), angles_deg=str([20] * (n - 1)),
                        materials=json.dumps(["H-1"] * (n - 1))))
    code = main(["simulate", str(f), "--method", "index2d", "--json"])
    out, err = capsys.readouterr()
    assert code == 2 and out == "" and err.count("\n") == 1
    assert "2D collision index" in err and "--max-memory" in err and "GiB" in err


def test_max_memory_option_lifts_and_lowers_the_limit(tmp_path, capsys):
    f = tmp_path / "s.toml"
    f.write_text(_strip())
    assert main(["simulate", str(f), "--json", "--max-memory", "1K"]) == 2
    assert "1 KiB memory limit" in capsys.readouterr().err
    assert main(["simulate", str(f), "--json", "--max-memory", "4G"]) in (0, 1)
    assert main(["simulate", str(f), "--max-memory", "lots"]) == 2
    assert "--max-memory" in capsys.readouterr().err


def test_single_panel_is_a_valid_trivial_design(tmp_path, capsys):
    f = tmp_path / "one.toml"
    f.write_text(_strip(lengths_mm="[10]", angles_deg="[]", materials="[]"))
    assert main(["check", str(f), "--json", "--no-sensitivity"]) == 0
    rep = json.loads(capsys.readouterr().out)
    assert rep["ok"] and rep["errors"] == 0
    assert main(["simulate", str(f), "--json"]) == 0
    sim = json.loads(capsys.readouterr().out)
    assert sim["completed"] and sim["hinges"] == []
    out = tmp_path / "out"
    assert main(["export", str(f), "--out", str(out), "--format", "stl", "--json"]) == 0
    files = json.loads(capsys.readouterr().out)["files"]
    assert [r["format"] for r in files] == ["stl", "manifest", "recipe"]
    assert files[0]["bodies"][0]["volume_mm3"] == pytest.approx(10 * 6 * 0.8)


def test_hole_leaving_a_1um_frame_is_a_min_wall_finding(tmp_path, capsys):
    f = tmp_path / "frame.toml"
    f.write_text(_strip(lengths_mm="[20, 20]", angles_deg="[90]", materials='["H-1"]',
                        holes="[{panel = 2, polygon = [[0.001, 0.001], [19.999, 0.001], [19.999, 5.999], "
                              "[0.001, 5.999]]}]"))
    assert main(["check", str(f), "--json", "--no-sensitivity"]) == 1
    rep = json.loads(capsys.readouterr().out)
    fp = [x for x in rep["findings"] if x["code"] == "FP112"]
    assert len(fp) == 1 and fp[0]["severity"] == "error" and fp[0]["where"] == {"panel": "p2"}
    assert "0.001 mm" in fp[0]["message"]
    # a 1 mm frame is fine on the default printer (0.6 mm minimum wall)
    f.write_text(f.read_text().replace("0.001", "1").replace("19.999", "19").replace("5.999", "5"))
    main(["check", str(f), "--json", "--no-sensitivity"])
    assert not [x for x in json.loads(capsys.readouterr().out)["findings"] if x["code"] == "FP112"]


def test_python_api_raises_the_same_errors():
    import numpy as np

    from foldprint.model.design import Design, Panel, validate, strip
    from foldprint.io.design_io import design_from_dict
    from foldprint.core.errors import DesignError, FoldprintError
    from foldprint.core.guards import ResourceError
    from foldprint.simulation.simulate import simulate

    with pytest.raises(DesignError, match="radius_mm"):
        strip("s", [10, 10], [90], ["H-1"], radius="5")
    with pytest.raises(DesignError, match="thickness_mm"):
        strip("s", [10, 10], [90], ["H-1"], thickness=True)
    with pytest.raises(DesignError, match="outline"):
        Panel("a", [["x", 1], [2, 3], [4, 5]], 1.0, "VeroWhite")
    sq = lambda x: np.array([[x, 0], [x + 10, 0], [x + 10, 10], [x, 10]], float)  # noqa: E731
    with pytest.raises(DesignError, match="'a' and 'b' overlap"):
        validate(Design("o", (Panel("a", sq(0), 1.0, "VeroWhite"), Panel("b", sq(5), 1.0, "VeroWhite")), ()))
    with pytest.raises(DesignError, match=r"panels\[0\]"):
        design_from_dict({"name": "x", "panels": [5]})
    d = strip("s", [10, 10], [90], ["H-1"])
    with pytest.raises(ResourceError) as ei:
        simulate(d, duration=1e9)
    assert isinstance(ei.value, FoldprintError) and "--duration" in str(ei.value)


@pytest.mark.parametrize("args, needle", [
    (["--error-above", "1"], "--error-above: must be a jam probability in (0, 1)"),
    (["--error-above", "0"], "--error-above: must be a jam probability in (0, 1)"),
    (["--warn-above", "0"], "--warn-above: must be a jam probability in (0, 1)"),
    (["--error-above", "0.04"], "--warn-above (0.05) must be below --error-above (0.04)"),
])
def test_jam_thresholds_outside_0_1_or_out_of_order_are_refused(tmp_path, capsys, args, needle):
    d = tmp_path / "d.toml"
    d.write_text(GOOD_STRIP.format(name="d"))
    assert main(["check", str(d), "--samples", "0", *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and needle in err, err


def test_jam_thresholds_are_checked_for_the_python_api_too():
    from foldprint.checks.rules import Thresholds
    from foldprint.core.errors import DesignError

    assert Thresholds(0.999, 0.001).error == 0.999
    for error, warning in ((1.0, 0.05), (float("nan"), 0.05), (0.2, 0.0), (0.2, 0.2)):
        with pytest.raises(DesignError):
            Thresholds(error, warning)


def _deep_tree(top, levels: int) -> None:
    """``levels`` nested folders under ``top``, made one level at a time relative to an open
    folder (os.makedirs recurses once per level)."""
    os.mkdir(top)
    fd = os.open(top, os.O_RDONLY)
    try:
        for _ in range(levels):
            os.mkdir("a", dir_fd=fd)
            nxt = os.open("a", os.O_RDONLY, dir_fd=fd)
            os.close(fd)
            fd = nxt
        with open(os.open("leaf.txt", os.O_WRONLY | os.O_CREAT, 0o644, dir_fd=fd), "w") as f:
            f.write("mine")
    finally:
        os.close(fd)


def test_an_output_folder_holding_a_tree_1000_levels_deep_is_walked_not_recursed(tmp_path, capsys):
    """An export into a folder holding a tree 1,000 levels deep (RecursionError in os.walk
    before) is refused as a folder of other files, and with --force writes beside it."""
    from foldprint.exchange.outfolder import OutFolder, inspect

    out = tmp_path / "out"
    _deep_tree(out, 1000)
    held = inspect(out)
    assert held.kind == OutFolder.FOREIGN and held.foreign == ("a",)
    d = tmp_path / "d.toml"
    d.write_text(GOOD_STRIP.format(name="d"))
    assert main(["export", str(d), "--format", "stl", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds files foldprint did not write (a)" in err, err
    assert main(["export", str(d), "--format", "stl", "--out", str(out), "--force"]) == 0
    assert (out / "foldprint-set.json").exists() and (out / "a").is_dir()
    deepest = out.joinpath(*["a"] * 1000)
    (deepest / "leaf.txt").unlink()
    for k in range(1000, 0, -1):  # removed here: shutil.rmtree recurses once per level too
        os.rmdir(out.joinpath(*["a"] * k))


def test_the_output_folder_walk_stops_at_its_bound(tmp_path, monkeypatch):
    from foldprint.exchange import outfolder

    monkeypatch.setattr(outfolder, "MAX_WALK", 25)
    for i in range(40):
        (tmp_path / f"f{i:02d}").write_text("x")
    held = outfolder.inspect(tmp_path)
    assert held.kind == outfolder.OutFolder.FOREIGN and len(held.foreign) == 26
    assert "(more than 25 entries)" in held.foreign


@pytest.mark.parametrize("name, needle", [
    ("a\\u007fb", "holds the control character '\\x7f'"), (" H-9", "has a space at its start or end"),
    ("a\\u2028b", "holds the control character '\\u2028'"), ("M" * 101, "is 101 characters long"),
])
def test_material_names_follow_the_one_id_rule(tmp_path, name, needle):
    """The library refuses the names calibrate refuses, with the rule in the message."""
    from foldprint.core.errors import MaterialError
    from foldprint.model.materials import load_library

    f = tmp_path / "m.toml"
    f.write_text(f'[materials."{name}"]\nrole = "panel"\ntg_c = 40.0\n')
    with pytest.raises(MaterialError) as ei:
        load_library(f)
    assert needle in str(ei.value) and "a name is 1 to 100 characters, no control characters" in str(ei.value)


def test_an_output_file_1500_levels_deep_is_made_without_recursion(tmp_path, capsys):
    """calibrate --out a/a/.../m.toml (1,500 levels, under PATH_MAX) was a RecursionError in
    Path.mkdir(parents=True); a file in the way is named, and nothing is left made."""
    from foldprint.core.files import ensure_dir

    deep = tmp_path.joinpath(*["a"] * 1500)
    assert ensure_dir(deep) == deep and deep.is_dir()
    for k in range(1500, 0, -1):  # removed here: shutil.rmtree recurses once per level too
        os.rmdir(tmp_path.joinpath(*["a"] * k))
    (tmp_path / "f").write_text("mine")
    from foldprint.core.errors import ExportError

    with pytest.raises(ExportError, match="f is a file, not a folder"):
        ensure_dir(tmp_path / "f" / "x" / "y")
    with pytest.raises(ExportError, match="longer than 4095 bytes"):
        ensure_dir(tmp_path.joinpath(*["b"] * 2100))
    assert not (tmp_path / "b").exists()
