"""SVG crease patterns in Origami Simulator's convention: colours, opacity, document
scale, noding, errors; Origami Simulator's own examples (tests/data/origami_simulator)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from foldprint.cli.commands import main
from foldprint.core.errors import DesignError
from foldprint.io.load import load_design
from foldprint.io.svg_format import design_from_svg, fold_from_svg

DATA = Path(__file__).parent / "data" / "origami_simulator"

# a 100 x 100 mm square (width in mm, viewBox 0..10 -> 10 mm per user unit), one valley
# at half opacity down the middle and a mountain from the middle to the right edge
SQUARE = """<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 10 10">
  <rect x="0" y="0" width="10" height="10" fill="none" stroke="#000"/>
  <g stroke="blue"><line x1="5" y1="0" x2="5" y2="10" stroke-opacity="0.5"/></g>
  <path d="M5 5 h5" style="stroke: #FF0000; opacity: 1"/>
</svg>"""


def test_colours_opacity_and_document_scale():
    d = design_from_svg(SQUARE, "sq.svg")
    assert len(d.panels) == 3 and len(d.hinges) == 3  # a T-junction: one loop around (5, 5)
    ang = sorted(h.angle_deg for h in d.hinges)
    assert ang == pytest.approx([-180.0, 90.0, 90.0])
    xs = np.concatenate([p.outline for p in d.panels])
    assert np.ptp(xs[:, 0]) == pytest.approx(100.0) and np.ptp(xs[:, 1]) == pytest.approx(100.0)
    assert sum(p.area for p in d.panels) == pytest.approx(100.0 * 100.0)


def test_scale_overrides_the_document():
    d = design_from_svg(SQUARE, "sq.svg", scale=2.0)
    xs = np.concatenate([p.outline for p in d.panels])
    assert np.ptp(xs[:, 0]) == pytest.approx(20.0)


def test_near_miss_endpoints_are_joined():
    """An undershoot of 0.5 user units (Origami Simulator merges within 3) still ends on
    the border, so the crease splits the sheet."""
    svg = SQUARE.replace('viewBox="0 0 10 10"', 'viewBox="0 0 1000 1000"').replace(
        '<rect x="0" y="0" width="10" height="10"', '<rect x="0" y="0" width="1000" height="1000"').replace(
        'x1="5" y1="0" x2="5" y2="10"', 'x1="500" y1="0.5" x2="500" y2="999.5"').replace("M5 5 h5", "M500 500 h500")
    f = fold_from_svg(svg, "n.svg")
    assert len(f["faces_vertices"]) == 3


def test_crease_materials_by_assignment():
    d = design_from_svg(SQUARE, "sq.svg", crease_materials={"M": "H-1", "V": "H-6"})
    assert {h.material for h in d.hinges if h.angle < 0} == {"H-1"}
    assert {h.material for h in d.hinges if h.angle > 0} == {"H-6"}


@pytest.mark.parametrize("svg, needle", [
    (SQUARE.replace("#FF0000", "#123456"), "#123456"),
    (SQUARE.replace("M5 5 h5", "M5 5 c1 1 2 2 5 0"), "curve"),
    ("<svg xmlns='http://www.w3.org/2000/svg'></svg>", "no coloured line"),
    ("<svg", "not valid SVG"),
])
def test_errors_name_the_problem(svg, needle):
    with pytest.raises(DesignError, match=needle) as e:
        design_from_svg(svg, "bad.svg")
    assert str(e.value).startswith("bad.svg: ")


@pytest.mark.parametrize("name, panels, hinges", [
    ("simpleVertex", 4, 4), ("waterbombBase", 8, 8), ("squareBase", 6, 6), ("birdBase", 16, 20),
    ("miura-ori", 156, 287)])
def test_origami_simulator_examples_load(name, panels, hinges):
    d = load_design(DATA / f"{name}.svg")
    assert (len(d.panels), len(d.hinges)) == (panels, hinges)
    # Origami Simulator's examples are drawn in px: 96 px = 25.4 mm
    assert all(abs(h.angle_deg) <= 180 for h in d.hinges)


def test_waterbomb_base_svg_simulates(capsys):
    """Origami Simulator's waterbomb base: red diagonals (mountain 180), blue midlines at
    opacity 0.5 (valley 90). Every interior-vertex loop closes and the report says so."""
    code = main(["simulate", str(DATA / "waterbombBase.svg"), "--json", "--duration", "3", "--method", "fcl"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    r = json.loads(out)
    assert r["loops"]["loops"] == 1 and r["loops"]["closure_residual"] < 1e-6
    assert {h["target_angle_deg"] for h in r["hinges"]} == {-180.0, 90.0}
    assert max(abs(h["final_angle_deg"]) for h in r["hinges"]) > 90


def test_cli_svg_scale_and_rule(tmp_path, capsys):
    p = tmp_path / "sq.svg"
    p.write_text(SQUARE, encoding="utf-8")
    code = main(["simulate", str(p), "--json", "--duration", "1", "--scale", "5",
                 "--crease-materials", "M=H-1,V=H-2"])
    out, err = capsys.readouterr()
    assert code in (0, 1), err
    assert {h["material"] for h in json.loads(out)["hinges"]} == {"H-1", "H-2"}
    assert main(["simulate", str(p), "--crease-materials", "X=H-1"]) == 2
    assert "ASSIGNMENT=MATERIAL" in capsys.readouterr().err
