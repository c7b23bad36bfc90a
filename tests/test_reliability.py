"""Hostile inputs (SVG coordinates, output folders, option values): each is exit 2 with one line naming the
item and what would be right, or the documented behaviour; an unexpected exception is
exit 3 with a short report, never 1 (the code of a failing design)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from foldprint.io import svg_creases
from foldprint.cli.commands import main
from foldprint.io.load import load_design

TOML = (__import__("pathlib").Path(__file__).resolve().parents[1] / "templates" / "helix_graded.toml").read_text()
FOLD = {"file_spec": 1.2, "frame_unit": "mm", "vertices_coords": [[0, 0], [10, 0], [10, 6], [0, 6], [20, 0], [20, 6]],
        "faces_vertices": [[0, 1, 2, 3], [1, 4, 5, 2]], "edges_vertices": [[1, 2]],
        "edges_assignment": ["V"], "edges_foldAngle": [90]}
BOX = ('<rect x="0" y="0" width="100" height="100" stroke="#000" fill="none"/>'
       '<line x1="50" y1="0" x2="50" y2="100" stroke="#00f"/>')


def _fold(**kw) -> str:
    d = json.loads(json.dumps(FOLD))
    d.update(kw)
    return json.dumps(d)


def _svg(body: str) -> str:
    return f'<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">{body}</svg>'


def _random_path(n: int, seed: int = 1) -> str:
    r = np.random.default_rng(seed).uniform(0, 100, (n + 1, 2))
    return "M " + " L ".join(f"{x:.3f} {y:.3f}" for x, y in r)


BAD = {  # name: (file name, text, words the message must hold)
    "toml_5000_digits": ("big.toml", TOML.replace("[process]", "[process]\nx = " + "9" * 5000, 1),
                         ["big.toml", f"line {TOML[:TOML.index('[process]')].count(chr(10)) + 2}", "5000+ digits"]),
    "fold_angle_5000_digits": ("big.fold", json.dumps(FOLD).replace('"edges_foldAngle": [90]',
                                                                   '"edges_foldAngle": [' + "9" * 5000 + "]"),
                               ["big.fold", "digits"]),
    "fold_index_401_digits": ("i.fold", json.dumps(FOLD).replace("[1, 2]]", "[1, " + "9" * 401 + "]]"),
                              ["edges_vertices[0]", "401 digits", "0 to 5"]),
    "fold_face_index_401_digits": ("f.fold", json.dumps(FOLD).replace("[1, 4, 5, 2]", "[1, 4, 5, " + "9" * 401 + "]"),
                                   ["faces_vertices[1]", "401 digits"]),
    "fold_file_spec_string": ("s.fold", _fold(file_spec="x"), ["file_spec", "number"]),
    "fold_index_float": ("v.fold", _fold(faces_vertices=[[0, 1, 2.0, 3], [1, 4, 5, 2]]),
                         ["faces_vertices[0]", "2.0", "whole numbers"]),
    "fold_title_number": ("t.fold", _fold(frame_title=5), ["frame_title", "string"]),
    "svg_coordinate_1e300": ("c.svg", _svg(BOX.replace('x2="50"', 'x2="1e300"')), ["<line> #2", "outside"]),
    "svg_x2_1e309": ("x.svg", _svg(BOX.replace('x2="50"', 'x2="1e309"')), ["<line> #2", "inf"]),
    "svg_scale_1e200": ("s.svg", _svg(f'<g transform="scale(1e200)">{BOX}</g>'), ["scale(1e200)", "out of range"]),
    "svg_scale_0": ("z.svg", _svg(BOX.replace('stroke="#00f"', 'stroke="#00f" transform="scale(0)"')),
                    ["scale(0)", "collapses"]),
    "svg_translate_1e308": ("t.svg", _svg(BOX.replace('stroke="#00f"', 'stroke="#00f" transform="translate(1e308 1e308)"')),
                            ["translate(1e308 1e308)", "out of range"]),
    "svg_skew_400_digits": ("k.svg", _svg(BOX.replace('stroke="#00f"', 'stroke="#00f" transform="skewX(' + "9" * 400 + ')"')),
                            ["skewX(", "out of range"]),  # found by benchmarks/fuzz_inputs.py: math domain error
    "svg_5000_nested_groups": ("n.svg", _svg("<g>" * 5000 + BOX + "</g>" * 5000), ["nested more than 64"]),
    "svg_2000_crossing_segments": ("p.svg", _svg(BOX + f'<path d="{_random_path(2000)}" stroke="#f00"/>'),
                                   ["cross each other about", "50000"]),
    "svg_50001_segments": ("l.svg", _svg(BOX + f'<path d="M0 0{" l0.001 0" * 50001}" stroke="#ff0"/>'),
                           ["more than 50000 line segments"]),
    "fix_temperature_absolute_zero": ("k.toml", TOML.replace("fix_temperature_c = 10.0", "fix_temperature_c = -273.15"),
                                      ["process.fix_temperature_c", "[-100, 500]"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_hostile_file_exits_2_with_one_line(tmp_path, capsys, case):
    name, text, needles = BAD[case]
    f = tmp_path / name
    f.write_text(text)
    code = main(["check", str(f), "--samples", "0", "--json"])
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == "" and "Traceback" not in err and err.count("\n") == 1, err
    for n in needles:
        assert n in err, (n, err)
    assert len(err) < 600


def test_svg_desc_with_brackets_is_read(tmp_path):
    f = tmp_path / "d.svg"
    f.write_text(_svg("<desc>" + "[" * 40 + "</desc>" + BOX))
    assert len(load_design(f).panels) == 2


def test_svg_path_drawn_back_and_forth_is_one_line(tmp_path):
    """2,000 segments over one line (1.3 GB and 21 s CPU before): one crease line, fast."""
    f = tmp_path / "b.svg"
    f.write_text(_svg(BOX + f'<path d="M20 20{" l1 0 l-1 0" * 1000}" stroke="#ff0"/>'))
    assert len(load_design(f).panels) == 2


def test_big_integer_in_a_materials_file_exits_2(tmp_path, capsys):
    m = tmp_path / "m.toml"
    m.write_text("[materials.X]\ntg_c = " + "9" * 5000 + "\n")
    code = main(["materials", "--materials", str(m)])
    err = capsys.readouterr().err
    assert code == 2 and "m.toml" in err and "digits" in err and "Traceback" not in err


OPTIONS = {  # argv: words the message must hold
    ("simulate", "helix_graded", "--duration", "1e300", "--dt", "1e-300"): ["--dt", "[1e-06, 100] s"],
    ("simulate", "helix_graded", "--duration", "1e300"): ["--duration", "(0, 1e+12] s"],
    ("simulate", "helix_graded", "--duration", "nan"): ["--duration"],
    ("simulate", "helix_graded", "--dt", "inf"): ["--dt"],
    ("simulate", "helix_graded", "--max-memory", "1e400TiB"): ["--max-memory", "1 EiB"],
    ("simulate", "helix_graded", "--temperature", "1e308"): ["--temperature", "[-100, 500] deg C"],
    ("simulate", "helix_graded", "--temperature", "-273.15"): ["--temperature", "[-100, 500] deg C"],
    ("materials", "--temperature", "inf"): ["--temperature"],
    ("materials", "--thickness", "1e300"): ["--thickness", "mm"],
    ("robust", "helix_graded", "--samples", "100000000000"): ["--samples", "[1, 1000000]"],
    ("assign", "helix_graded", "--temperature-range", "1e308", "1e309"): ["--temperature-range", "[-100, 500]"],
    ("assign", "helix_graded", "--temperature-range", "90", "80"): ["--temperature-range", "LO <= HI"],
    ("export", "helix_graded", "--out", ""): ["--out is empty"],
    ("export", "helix_graded", "--out", "/"): ["--out '/'", "root of the file system"],
    ("gallery", "helix_graded", "--out", "/"): ["root of the file system"],
    ("simulate", "helix_graded", "--plot", ""): ["--plot is empty"],
}


@pytest.mark.parametrize("argv", sorted(OPTIONS), ids=lambda a: " ".join(a[2:]) or a[0])
def test_absurd_option_exits_2_naming_it(capsys, argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert code == 2, err
    assert "Traceback" not in err and err.count("\n") == 1 and "Warning" not in err, err
    for n in OPTIONS[argv]:
        assert n in err, (n, err)


def test_internal_error_exits_3_with_a_short_report(capsys, monkeypatch):
    import foldprint.apps.evaluation_nominal

    def boom(*a, **kw):
        raise ZeroDivisionError("a bug")

    monkeypatch.delenv("FOLDPRINT_TRACEBACK", raising=False)
    monkeypatch.setattr(foldprint.apps.evaluation_nominal, "simulate", boom)  # the CLI simulates through Evaluation
    code = main(["simulate", "helix_graded"])
    out, err = capsys.readouterr()
    assert code == 3 and out == ""
    assert "internal error: ZeroDivisionError" in err and "a bug" in err and "Traceback" not in err
    assert "not a verdict on the design" in err and err.count("\n") == 2


def test_internal_error_traceback_on_request(capsys, monkeypatch):
    import foldprint.apps.evaluation_nominal

    monkeypatch.setenv("FOLDPRINT_TRACEBACK", "1")
    monkeypatch.setattr(foldprint.apps.evaluation_nominal, "simulate", lambda *a, **k: 1 / 0)
    assert main(["simulate", "helix_graded"]) == 3
    assert "Traceback" in capsys.readouterr().err


def _brute_clusters(pts: np.ndarray, tol: float) -> np.ndarray:
    n = len(pts)
    parent = list(range(n))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    d = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    for i, j in zip(*np.nonzero(np.triu(d < tol, 1))):
        parent[root(i)] = root(j)
    lab = np.array([root(i) for i in range(n)])
    out = pts.copy()
    for g in np.unique(lab):
        out[lab == g] = pts[lab == g].mean(axis=0)
    return out


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(n=hs.integers(1, 300), seed=hs.integers(0, 2 ** 32 - 1), tol=hs.floats(0.05, 5.0),
       shape=hs.sampled_from(["random", "grid", "line", "clump"]), kd=hs.booleans())
def test_vertex_clustering_matches_all_pairs(n, seed, tol, shape, kd):
    """The O(n log n) clustering (duplicates merged, Delaunay edges) gives the clusters of
    all pairs closer than tol, on random, gridded (duplicates), collinear and clumped points."""
    rng = np.random.default_rng(seed)
    pts = rng.uniform(0, 100, (n, 2))
    if shape == "grid":
        pts = np.round(pts / 5) * 5
    elif shape == "line":
        pts[:, 1] = 0.3 * pts[:, 0]
    elif shape == "clump":
        pts[: n // 2] = pts[0] + rng.normal(0, 1e-9, (n // 2, 2))
    old = svg_creases.KDTREE_POINTS
    svg_creases.KDTREE_POINTS = 10 ** 9 if kd else 0
    try:
        got = svg_creases.cluster_points(pts, tol)
    finally:
        svg_creases.KDTREE_POINTS = old
    np.testing.assert_allclose(got, _brute_clusters(pts, tol), atol=1e-9)


@pytest.mark.parametrize("kd", [True, False])
def test_points_exactly_tol_apart_stay_apart(kd):
    """'Closer than tol' is strict on both paths: grid points exactly tol apart are not
    merged (the k-d tree's query keeps pairs at tol: they are dropped)."""
    pts = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [5.0, 5.5]])
    old = svg_creases.KDTREE_POINTS
    svg_creases.KDTREE_POINTS = 10 ** 9 if kd else 0
    try:
        got = svg_creases.cluster_points(pts, 5.0)
    finally:
        svg_creases.KDTREE_POINTS = old
    np.testing.assert_allclose(got, [[0, 0], [5, 0], [5, 5.25], [5, 5.25]])


def test_svg_whose_noding_does_not_converge_exits_2(capsys):
    """Found by benchmarks/fuzz_inputs.py: GEOS 'Iterated noding failed to converge' was an
    internal error (exit 3); the noding is retried on a fine grid. Its lines cut the sheet
    into pieces joined by no crease: the reader keeps the largest piece and says so, naming
    the file (docs/input-safety.md), so the check answers for that one panel."""
    from pathlib import Path

    f = Path(__file__).resolve().parent / "data" / "fuzz" / "noding_fails.svg"
    code = main(["check", str(f), "--samples", "0", "--json"])
    err = capsys.readouterr().err
    assert "Traceback" not in err and "internal error" not in err
    assert code == 0 and "noding_fails.svg" in err and "kept the largest" in err, (code, err)
