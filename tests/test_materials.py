import pytest

from foldprint.core.errors import MaterialError
from foldprint.model.materials import default_library, load_library


def test_seven_hinge_materials_with_rising_tg(lib):
    hinges = lib.hinges()
    assert [m.name for m in hinges] == [f"H-{i}" for i in range(1, 8)]
    tgs = [m.tg_c for m in hinges]
    assert tgs[0] == pytest.approx(32.0) and tgs[-1] == pytest.approx(65.0)
    assert all(b > a for a, b in zip(tgs, tgs[1:]))
    for m in hinges:
        assert m.recovery is not None and m.recovery.n_branches == 16
        assert m.color.startswith("#") and len(m.rgba) == 4


def test_panel_and_base_materials(lib):
    assert lib["VeroWhite"].role == "panel"
    assert lib["TangoBlack"].role == "base"


def test_user_file_adds_and_overrides(tmp_path):
    f = tmp_path / "mine.toml"
    f.write_text('[materials.H-3]\ntg_c = 44.5\n\n[materials.H-8]\nrole = "hinge"\ntg_c = 70.0\n'
                 'color = "#112233"\n[materials.H-8.recovery]\nh_w_m2k = 500.0\n')
    lib = load_library(f)
    assert lib["H-3"].tg_c == 44.5
    assert lib["H-3"].recovery == default_library()["H-3"].recovery
    assert lib["H-8"].tg_c == 70.0 and lib["H-8"].recovery.h_w_m2k == 500.0
    assert lib["H-8"].recovery.c1 == default_library()["H-1"].recovery.c1
    assert lib.names()[:7] == [f"H-{i}" for i in range(1, 8)]


@pytest.mark.parametrize("text,match", [
    ('[materials.X]\nrole = "hinge"\n', "tg_c"),
    ('[materials.X]\nrole = "wood"\ntg_c = 3\n', "role"),
    ('[materials.X]\nrole = "panel"\ntg_c = 3\ncolor = "red"\n', "color"),
    ('[materials.H-1]\nbogus = 1\n', "bogus"),
    ('[materials.H-1.recovery]\nh_w_m2k = -1.0\n', "h_w_m2k"),
    ('not toml [', "not valid TOML"),
])
def test_bad_user_file_names_the_problem(tmp_path, text, match):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(MaterialError, match=match) as ei:
        load_library(f)
    assert str(f) in str(ei.value)


def test_unknown_material_lists_known(lib):
    with pytest.raises(MaterialError, match="H-1"):
        lib["H-99"]
