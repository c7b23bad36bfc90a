"""Continuous and graded hinge materials through TOML, FOLD metadata, the API and the CLI."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import foldprint as fp
from foldprint.core.errors import DesignError
from foldprint.exchange.fold import design_from_fold, design_to_fold
from foldprint.io.design_io import design_from_dict, design_to_dict
from foldprint.io.load import load_design

TOML = """
name = "vw"
[strip]
lengths_mm = [20, 20, 20, 20]
angles_deg = [90, 90, 90]
materials = ["H-3", {vero_fraction = 0.62}, {vero_fraction = [0.6, 0.9], along = "length"}]
"""


def test_toml_strip_materials(tmp_path):
    p = tmp_path / "vw.toml"
    p.write_text(TOML)
    d = load_design(p)
    assert [h.material for h in d.hinges] == ["H-3", "VW0.620", "VW0.600-0.900@length"]


def test_general_form_round_trip_through_dict_and_fold():
    d = fp.strip("vw", [20, 20, 20, 20], [90, -90, 90],
                 ["H-5", 0.7, {"vero_fraction": [0.6, 0.75, 0.9], "along": "width"}])
    dd = design_to_dict(d)
    assert dd["hinges"][1]["material"] == {"vero_fraction": 0.7}
    assert [h.material for h in design_from_dict(dd).hinges] == [h.material for h in d.hinges]
    fold = json.loads(json.dumps(design_to_fold(d)))
    back = design_from_fold(fold)
    assert [h.material for h in back.hinges] == [h.material for h in d.hinges]


def test_fold_reads_a_fraction_object():
    d = fp.strip("vw", [20, 20], [90], ["H-3"])
    fold = json.loads(json.dumps(design_to_fold(d)))
    mats = fold["edges_foldprint:material"]
    k = next(i for i, m in enumerate(mats) if m is not None)
    mats[k] = {"vero_fraction": [0.65, 0.95], "along": "width"}
    assert design_from_fold(fold).hinges[0].material == "VW0.650-0.950@width"
    mats[k] = {"vero_fraction": 0.2}
    with pytest.raises(DesignError, match=r"edges_foldprint:material of hinge 'h1': .*outside the range"):
        design_from_fold(fold)


@pytest.mark.parametrize("spec,msg", [
    ("{vero_fraction = 0.3}", r"hinge 'h2'.*outside the range the data support, 0\.5600\.\.1\.0000"),
    ('{vero_fraction = [0.6, 0.9]}', r"hinge 'h2'.*along"),
    ('"VW0.7"', r"hinge 'h2'.*canonical spelling is 'VW0.700'"),
])
def test_bad_fraction_exits_2_naming_the_hinge(tmp_path, spec, msg):
    p = tmp_path / "bad.toml"
    p.write_text(TOML.replace("{vero_fraction = 0.62}", spec))
    with pytest.raises(DesignError, match=msg):
        load_design(p)
    r = subprocess.run([sys.executable, "-m", "foldprint", "simulate", str(p)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and "h2" in r.stderr


def test_api_names_and_general_hinge_validation():
    assert fp.vero(0.62) == "VW0.620"
    d = fp.strip("vw", [20, 20], [90], [fp.vero([0.6, 0.9], "width")])
    fp.validate(d)
    with pytest.raises(DesignError, match="materials\\[0\\] \\(hinge 'h1'\\)"):
        fp.strip("vw", [20, 20], [90], [1.5])


def test_viewer_and_gallery_show_the_ramp():
    from foldprint.apps.gallery.page import _ramp_note, _swatch
    from foldprint.model.composition import composition_model
    from foldprint.render.viewer import viewer_data
    from foldprint.simulation.simulate import simulate

    lib = fp.default_library()
    d = fp.strip("vw", [20, 20, 20], [90, 90], [0.62, {"vero_fraction": [0.6, 0.9], "along": "width"}])
    data = viewer_data(simulate(d, dt=0.05), lib)
    ramp = data["ramp"]
    m = composition_model()
    assert ramp["swatches"]["VW0.620"] == m.color(0.62) == data["colors"]["VW0.620"]
    assert ramp["swatches"]["VW0.600-0.900@width"] == f"linear-gradient(to right, {m.color(0.6)}, {m.color(0.9)})"
    assert data["colors"]["VW0.600-0.900@width"] == m.color(0.75)  # graded: the mean colour
    assert (ramp["tangoblack"], ramp["verowhite"]) == (lib["TangoBlack"].color, lib["VeroWhite"].color)
    assert "linear-gradient" in _swatch(lib, "VW0.600-0.900@width")
    assert "VW0.620: VeroWhite 62.0 %" in _ramp_note(d)
    plain = fp.strip("h", [20, 20], [90], ["H-3"])
    assert _ramp_note(plain) == "" and "ramp" not in viewer_data(simulate(plain, dt=0.05), lib)
