"""The composition model: Tg(VeroWhite fraction), profiles, canonical names, the library's
synthesised materials, and the spec parser the design readers share."""

from __future__ import annotations

import tomllib
from importlib import resources

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from foldprint.core.errors import DesignError, MaterialError
from foldprint.model import composition as comp
from foldprint.model import composition_library
from foldprint.model.composition import Along, FractionProfile, composition_model
from foldprint.model.materials import default_library

M = composition_model()
LO, HI = M.fraction_range


def _toml() -> dict:
    return tomllib.loads((resources.files("foldprint") / "data" / "composition.toml").read_text("utf-8"))


def test_range_is_the_measured_grades():
    lib = default_library()
    assert M.tg_c(LO) == pytest.approx(lib["H-1"].tg_c, abs=1e-9)
    assert M.tg_c(HI) == pytest.approx(lib["H-7"].tg_c, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(hs.floats(0.0, 1.0), hs.floats(0.0, 1.0))
def test_monotone_and_inverse(a, b):
    wa, wb = LO + (HI - LO) * a, LO + (HI - LO) * b
    assert M.fraction(M.tg_c(wa)) == pytest.approx(wa, abs=1e-12)
    if wa < wb:
        assert M.tg_c(wa) < M.tg_c(wb)


@pytest.mark.parametrize("law", ["gordon-taylor", "fox"])
@pytest.mark.parametrize("k", [0.3, 1.0, 3.0])
def test_other_laws_monotone_and_inverse(law, k):
    from dataclasses import replace
    m = replace(M, law=law, k=k)
    w = np.linspace(*m.fraction_range, 101)
    t = m.tg_c(w)
    assert np.all(np.diff(t) > 0)
    assert np.allclose(m.fraction(t), w, atol=1e-12)


def test_end_members_are_the_law_ends():
    # independent of the implementation's inverse: Gordon-Taylor at w = 0 and 1
    assert float(M._tg(0.0)) == pytest.approx(M.tg_tango_c)
    assert float(M._tg(1.0)) == pytest.approx(M.tg_vero_c)


def test_fox_matches_its_kelvin_form():
    from dataclasses import replace
    fox = replace(M, law="fox")
    w = np.linspace(0, 1, 11)
    ref = 1.0 / (w / (M.tg_vero_c + 273.15) + (1 - w) / (M.tg_tango_c + 273.15)) - 273.15
    assert np.allclose(fox._tg(w), ref, atol=1e-9)


@pytest.mark.parametrize("bad", [LO - 0.01, HI + 0.01, float("nan"), -1.0])
def test_outside_range_refused_with_range_in_message(bad):
    with pytest.raises(MaterialError, match=r"outside the range the data support, 0\.5600\.\.1\.0000"):
        M.tg_c(bad)


def test_tg_outside_refused():
    with pytest.raises(MaterialError, match="outside the range"):
        M.fraction(20.0)


def test_assumed_grades_follow_the_law():
    lib = default_library()
    for name, w in M.assumed:
        assert w == pytest.approx(M.fraction(lib[name].tg_c), abs=1e-6), name
        assert composition_library.fraction_profile(lib, name) == FractionProfile((pytest.approx(w, abs=1e-6),), None)


def test_recorded_fit_matches_recomputation():
    fit, rec = composition_library.ladder_fit(), _toml()["fit"]
    assert fit["law"]["rms_c"] == pytest.approx(rec["linear_rms_c"], abs=0.005)
    assert fit["law"]["max_c"] == pytest.approx(rec["linear_max_c"], abs=0.005)
    assert fit["fox"]["rms_c"] == pytest.approx(rec["fox_rms_c"], abs=0.005)
    assert fit["fox"]["max_c"] == pytest.approx(rec["fox_max_c"], abs=0.005)


def test_profile_at_and_mean():
    p = FractionProfile((0.6, 0.9), Along.WIDTH)
    assert np.allclose(p.at(np.array([0.0, 0.5, 1.0])), [0.6, 0.75, 0.9])
    u = np.linspace(0, 1, 200001)
    q = FractionProfile((0.6, 0.95, 0.7, 0.8), Along.LENGTH)
    assert q.mean == pytest.approx(np.trapezoid(q.at(u), u), abs=1e-9)
    assert FractionProfile((0.7,)).mean == 0.7
    with pytest.raises(MaterialError):
        FractionProfile((0.6, 0.9), None)


@settings(max_examples=100, deadline=None)
@given(hs.lists(hs.floats(0.0, 1.0), min_size=1, max_size=comp.MAX_KNOTS), hs.sampled_from(["width", "length"]))
def test_name_round_trip(us, along):
    vals = [LO + (HI - LO) * u for u in us]
    name = comp.vero(vals if len(vals) > 1 else vals[0], along if len(vals) > 1 else None)
    prof = comp.parse_name(name)
    assert prof.name == name
    assert all(LO - 1e-9 <= k <= HI + 1e-9 for k in prof.knots)
    assert comp.parse_material_spec(comp.material_spec(name)) == name


def test_names():
    assert comp.vero(0.62) == "VW0.620"
    assert comp.vero([0.6, 0.9], "width") == "VW0.600-0.900@width"
    assert comp.vero([0.7, 0.7], "length") == "VW0.700"  # equal knots are uniform
    for bad in ("VW0.62", "VW0.600-0.900", "VW0.700@width", "VW0.100", "VW1.200"):
        with pytest.raises(MaterialError):
            comp.parse_name(bad)


def test_library_synthesises_on_demand():
    lib = default_library()
    m = lib["VW0.700"]
    assert m.role == "hinge" and m.tg_c == pytest.approx(M.tg_c(0.7))
    assert m.recovery == lib["H-1"].recovery
    g = lib["VW0.600-0.900@width"]
    assert g.profile == FractionProfile((0.6, 0.9), Along.WIDTH)
    assert g.tg_c == pytest.approx(M.tg_c(0.75))
    assert "VW0.700" in lib and "VW0.100" not in lib and "VW0.7" not in lib
    assert "VW0.700" not in lib.names()  # the continuum is not enumerated
    # a synthesised grade at H-3's fraction has H-3's Tg
    assert lib[comp.vero(M.assumed_fraction("H-3"))].tg_c == pytest.approx(lib["H-3"].tg_c, abs=0.05)


def test_ramp_colours():
    assert M.color(0.0) == M.ramp[0] and M.color(1.0) == M.ramp[1]
    a, b = int(M.color(0.6)[1:3], 16), int(M.color(0.9)[1:3], 16)
    assert a < b  # more VeroWhite is lighter


@pytest.mark.parametrize("value,expected", [
    ("H-3", "H-3"), (0.62, "VW0.620"), ({"vero_fraction": 0.62}, "VW0.620"),
    ({"vero_fraction": [0.6, 0.9], "along": "width"}, "VW0.600-0.900@width"),
    ({"vero_fraction": [0.6, 0.8, 0.9], "along": "length"}, "VW0.600-0.800-0.900@length"),
])
def test_parse_material_spec(value, expected):
    assert comp.parse_material_spec(value, "x: ") == expected


@pytest.mark.parametrize("value,msg", [
    ({"vero_fraction": 0.3}, "outside the range"),
    ({"vero_fraction": [0.6, 0.9]}, "along"),
    ({"vero_fraction": [0.6, 0.9], "along": "diagonal"}, "width' or 'length"),
    ({"vero_fraction": 0.7, "along": "width"}, "only to a graded"),
    ({"fraction": 0.7}, "vero_fraction"),
    ({"vero_fraction": "a lot"}, "number"),
    ({"vero_fraction": [0.7]}, "2.."),
    (True, "material name"),
    ("VW0.7", "canonical|not a composition name"),
])
def test_parse_material_spec_errors_name_the_place(value, msg):
    with pytest.raises(DesignError, match=r"^d\.toml: hinges\[2\] \(h3\): material: .*(" + msg + ")"):
        comp.parse_material_spec(value, "d.toml: hinges[2] (h3): material: ")
