"""Every bad input exits 2 with one clear line naming the item, and writes no file."""

import os

import pytest

from foldprint.cli import main

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
