"""What ``foldprint calibrate --out`` does to the library: a measured material the library
lacks is added with its own parameters, colour and no claim to be a VeroWhite/TangoBlack
blend; the library's other grades are written unchanged; the command says what it added
and moved; a fit with no degrees of freedom identifies nothing (docs/calibrate.md)."""

import json
from dataclasses import fields

import pytest

from foldprint.apps import calibrate as cal
from foldprint.apps.calibrate_library import MIN_COLOR_STEP, changes, own_color
from foldprint.cli.commands import main
from foldprint.core.errors import MaterialError
from foldprint.io.hinge_data import parse_hinge_data
from foldprint.model.composition_library import fraction_profile
from foldprint.model.materials import default_library, load_library
from foldprint.model.printers import find_printer, tool_fit

#: A newcomer's measurements: three points of one curve and a DMA Tg (docs/calibrate.md).
MYRESIN = """kind,material,bath_c,thickness_mm,time_s,value,sigma,source
ratio,MyResin,80,0.8,2.0,0.12,,video frame 60
ratio,MyResin,80,0.8,4.0,0.55,,video frame 120
ratio,MyResin,80,0.8,8.0,0.97,,video frame 240
tg,MyResin,,,,47.5,,DMA 1 Hz tan delta peak
"""
#: A lab that re-measures a library grade (H-3) and measures nothing else.
H3 = """kind,material,bath_c,thickness_mm,time_s,value,sigma,source
ratio,H-3,80,0.8,1.0,0.10,,a
ratio,H-3,80,0.8,2.0,0.45,,b
ratio,H-3,80,0.8,3.0,0.80,,c
ratio,H-3,80,0.8,5.0,0.97,,d
"""


def _rgb(c):
    return tuple(int(c[i:i + 2], 16) for i in (1, 3, 5))


def test_own_colour_is_deterministic_and_apart_from_the_library():
    lib = default_library()
    taken = [m.color for m in lib.materials]
    for name in ("MyResin", "H-8", "resin A", "x"):
        c = own_color(name, taken)
        assert c == own_color(name, taken)
        assert all(max(abs(a - b) for a, b in zip(_rgb(c), _rgb(t))) >= MIN_COLOR_STEP for t in taken), (name, c)
    assert own_color("MyResin", taken) != own_color("YourResin", taken)


@pytest.fixture(scope="module")
def myresin(tmp_path_factory):
    out = tmp_path_factory.mktemp("my") / "my.toml"
    csv = out.with_suffix(".csv")
    csv.write_text(MYRESIN)
    c = cal.run(csv, default_library())
    cal.write(c, out, csv, "test")
    return c, out


def test_a_new_material_is_added_and_the_library_kept(myresin):
    c, out = myresin
    lib, got = default_library(), load_library(out)
    my = got["MyResin"]
    assert my.tg_c == 47.5 and not my.blend
    assert my.color not in {m.color for m in lib.materials}
    for m in lib.materials:  # every library material loads exactly as without the file
        assert got[m.name] == m, m.name
    ch = changes(c)
    assert [x["material"] for x in ch] == ["MyResin"] and ch[0]["status"] == "added"
    moved = {x["name"]: x["after"] for x in ch[0]["moved"]}
    assert moved["h_w_m2k"] == pytest.approx(my.recovery.h_w_m2k) and moved["tg_c"] == 47.5


def test_a_new_material_is_not_called_a_blend(myresin):
    _, out = myresin
    lib = load_library(out)
    fit = tool_fit(find_printer("connex260"), ["VeroWhite", "H-1", "MyResin"], lib)
    assert "MyResin" not in fit.mixed and "H-1" in fit.mixed
    assert "MyResin" in fit.feeds and "MyResin" not in fit.summary().split("jetted from")[0].split("(")[-1]
    with pytest.raises(MaterialError, match="not a VeroWhite/TangoBlack"):
        fraction_profile(lib, "MyResin")
    assert fraction_profile(lib, "H-1").uniform


def test_blend_is_a_boolean():
    from foldprint.model.materials import parse_library

    raw = {"materials": {"R": {"role": "hinge", "tg_c": 50.0, "blend": "no"}}}
    with pytest.raises(MaterialError, match=r"blend.*must be true"):
        parse_library(raw, "r.toml", base=default_library())
    raw["materials"]["R"]["blend"] = False
    assert not parse_library(raw, "r.toml", base=default_library())["R"].blend
    assert default_library()["H-4"].blend


def test_zero_degrees_of_freedom_identify_nothing(myresin):
    c, _ = myresin
    assert c.fit.dof == 0 and c.intervals
    for iv in c.intervals:
        assert iv.identified == "no" and "degrees of freedom" in iv.why, iv
    js = cal.to_json(c)
    assert all(p["identified"] == "no" and "degrees of freedom" in p["identified_why"] for p in js["parameters"])
    head = "\n".join(cal.header(c, c.problem.data.source, "test"))
    assert "identified: yes" not in myresin[1].read_text()
    # the reason for holding the span is not the paper's chi2 when the data are not the paper's
    assert "7.71" not in head and "spectrum_span_decades" in head


def test_remeasured_grade_changes_only_itself(tmp_path):
    csv = tmp_path / "h3.csv"
    csv.write_text(H3)
    c = cal.calibrate(parse_hinge_data(H3, str(csv)), default_library(), with_profile=False)
    out = tmp_path / "h3.toml"
    cal.write(c, out, csv, "test")
    lib, got = default_library(), load_library(out)
    for m in lib.materials:
        if m.name != "H-3":
            assert got[m.name] == m, m.name
    ch = changes(c)
    assert [(x["material"], x["status"]) for x in ch] == [("H-3", "changed")]
    for mv in ch[0]["moved"]:
        assert mv["before"] == pytest.approx(getattr(lib["H-3"].recovery, mv["name"]))
        assert mv["after"] == pytest.approx(getattr(got["H-3"].recovery, mv["name"]))
    names = {mv["name"] for mv in ch[0]["moved"]}
    assert names == {p.name for p in c.problem.params}
    assert all(getattr(got["H-3"].recovery, f.name) == getattr(lib["H-3"].recovery, f.name)
               for f in fields(lib["H-3"].recovery) if f.name not in names)


def test_check_with_the_newcomers_file_is_check_without_it(myresin, capsys):
    _, out = myresin
    assert main(["check", "helix_graded", "--samples", "16", "--json"]) == 0
    bare = json.loads(capsys.readouterr().out)
    assert main(["check", "helix_graded", "--samples", "16", "--json", "--materials", str(out)]) == 0
    with_file = json.loads(capsys.readouterr().out)
    for d in (bare, with_file):
        d.pop("materials", None)
    assert with_file == bare


def test_the_command_prints_what_it_added(tmp_path, capsys):
    csv = tmp_path / "my.csv"
    csv.write_text(MYRESIN)
    out = tmp_path / "my.toml"
    assert main(["calibrate", str(csv), "--out", str(out), "--no-profile"]) == 0
    text = capsys.readouterr()
    said = text.out + text.err
    assert "added MyResin" in said and "not a VeroWhite/TangoBlack blend" in said
    assert load_library(out)["MyResin"].color in said


def test_change_lines_name_the_first_few_and_count_the_rest():
    """Thirty new materials print LIST_FIRST lines and one count, not thirty lines."""
    from foldprint.apps.calibrate_library import change_lines
    from foldprint.core.display import LIST_FIRST

    items = [{"material": f"M{i}", "status": "added", "color": "#123456",
              "moved": [{"name": "tg_c", "before": None, "after": 40.0 + i}]} for i in range(30)]
    lines = change_lines(items)
    assert len(lines) == LIST_FIRST + 1
    assert lines[0].startswith("added M0 ") and "tg_c 40" in lines[0]
    assert lines[-1].startswith(f"... and {30 - LIST_FIRST} more material(s)")
    assert change_lines(items[:LIST_FIRST]) == lines[:LIST_FIRST]  # a short list is whole
