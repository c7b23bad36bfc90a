"""Lines the outputs print are true: a hinge that never folds is not given its material's
fold time, a jam hint names the cause the samples show, the recipe says which 3MF is for
which slicer (checked against PrusaSlicer where it is installed), the gallery names the
paper's structures in English and a part that cannot be built as a verdict, the help names
every design format that loads, check says which materials it used; and a list that grows
with the design is summarised (its count and its first few), not printed line by line."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

from foldprint.apps.gallery.entry import Entry, Image
from foldprint.apps.gallery.page import entry_done, page_html, paper_label
from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.checks.report import finding_lines, simulation_json
from foldprint.checks.jam_rules import jam_hint
from foldprint.checks.rules import Finding
from foldprint.cli.commands import main
from foldprint.core.display import LIST_FIRST, clipped, first_few, hinge_lines, hinge_text
from foldprint.core.modes import JamReason, Method
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.model.printers import default_printer_key
from foldprint.simulation.robust import Outcome

TDATA = Path(__file__).parent / "data"


def _template(name):
    return load_design(templates_dir() / f"{name}.toml")


@pytest.fixture(scope="module")
def cross_lock():
    """cross_lock_uniform: its loop's targets cannot close; bd and ca never fold."""
    ev = Evaluation(_template("cross_lock_uniform"), EvalOptions(samples=8, workers=1))
    ev.findings  # noqa: B018 - check's stages
    return ev


def _entry(ev) -> Entry:
    result = ev.simulation_for(Method.BOTH)
    sim = simulation_json(result)
    return Entry(ev.design, ev.design.name, sim, ev.to_json(default_printer_key()), fold_time=sim["fold_time_s"],
                 contacts=[(c.panels[0], c.panels[1], c.time, c.method) for c in result.contacts],
                 hinge_done=list(result.hinge_done))


def test_the_gallery_hinge_table_does_not_give_a_stuck_hinge_a_fold_time(cross_lock):
    entry = _entry(cross_lock)
    page = page_html([entry], Image("materials.png", 1, 1, "chart", "chart"), default_library(), 0.01)
    cells = re.findall(r"<tr><td>(\w+)</td><td>\w+\u2013\w+</td>.*?<td class=\"num\">[^<]*</td>"
                       r"<td class=\"(num|fail)\">([^<]*)</td></tr>", page)
    rows = {hid: text for hid, _, text in cells}
    assert {hid for hid, cls, _ in cells if cls == "fail"} == {"bd", "ca"}  # said in red, not as a time
    assert set(rows) == {"ab", "bd", "dc", "ca"}
    stuck = {h["id"] for h in entry.sim["hinges"] if abs(h["final_angle_deg"]) < 1.0}
    assert stuck == {"bd", "ca"}  # what simulate says: they stay flat
    for hid in stuck:
        assert rows[hid].startswith("does not fold: 0.0 of 90 deg at the end"), rows[hid]
    for hid in {"ab", "dc"}:
        assert re.fullmatch(r"\d+\.\d\d s", rows[hid]), rows[hid]


def test_simulate_and_the_gallery_print_the_same_hinge_text(cross_lock):
    sim = simulation_json(cross_lock.simulation_for(Method.BOTH))
    lines = hinge_lines(sim["hinges"])
    assert [ln.split(None, 2)[2] for ln in lines] == [hinge_text(h) for h in sim["hinges"]]


def test_the_jam_hint_names_the_cause_the_samples_show(cross_lock):
    """cross_lock_uniform's samples jam with no collision (its loop cannot close): the hint
    is not the Tg spacing, which fixes a swapped order only."""
    (fp,) = [f for f in cross_lock.findings if f.code in ("FP180", "FP181")]
    assert not any(o.pair for o in cross_lock.robust.outcomes)
    assert "further apart in Tg" not in fp.hint and "no sample collides" in fp.hint
    collide = Outcome(True, JamReason.COLLISION, ("a", "b"), 1.0, None)
    stop = Outcome(True, JamReason.UNFOLDED, None, None, None)
    goal = Outcome(True, JamReason.GOAL, None, None, None)
    assert "further apart in Tg" in jam_hint([stop, collide])
    assert "further apart in Tg" in jam_hint([stop, goal])  # a pass-through out of order: an order
    assert "the 2 jammed sample(s) stop short" in jam_hint([stop, stop, Outcome(False, None, None, None, 2.0)])


def test_the_paper_s_structures_read_as_english():
    labels = {n: paper_label(Entry(_template(n), n, {}, {})) for n in ("self_lock", "mailbox", "helix_uniform")}
    assert labels["self_lock"] == "the paper's self-locking structure (Fig. 5)"
    assert labels["mailbox"].startswith("the paper's 3D folding box")
    assert labels["helix_uniform"] == "the paper's Sample 1 (Fig. 2b)"
    assert not any("the paper's the" in v for v in labels.values())


def test_a_part_that_cannot_be_built_is_a_verdict_in_the_progress_line():
    e = Entry(strip("x", [10.0, 10.0], [90.0], ["H-1"]), "x", {}, {}, export_note="No print files: loops do not close")
    line = entry_done(e)
    assert "no print files: the part cannot be built (loops do not close)" in line and "FAILED" not in line


def test_the_recipe_says_which_3mf_is_for_which_slicer(tmp_path):
    recs = Evaluation(_template("self_lock")).export(tmp_path, "permanent", ("3mf", "prusa3mf", "stl"))
    text = next(Path(r["path"]) for r in recs if r["format"] == "recipe").read_text(encoding="utf-8")
    rows = [ln for ln in text.splitlines() if re.match(r"\| \d+ \| ", ln) and "extruder" in ln]
    assert len(rows) == 4 and not any(".3mf" in r for r in rows)  # each body's row: its own STL only
    assert all(re.search(r"`self_lock_[\w-]+\.stl` \|$", r) for r in rows)
    assert re.search(r"- `self_lock\.3mf`: OrcaSlicer / Bambu Studio project.*PrusaSlicer opens it with one "
                     r"extruder.*use `self_lock_prusa\.3mf` there", text)
    assert "- `self_lock_prusa.3mf`: PrusaSlicer project: one extruder per body" in text


@pytest.mark.skipif(shutil.which("prusa-slicer") is None, reason="PrusaSlicer is not installed")
def test_prusaslicer_prints_the_plain_3mf_with_one_tool_and_the_prusa_3mf_with_each(tmp_path):
    """What the recipe says of the two 3MFs, sliced: the plain one with T0 only, the
    PrusaSlicer one with a tool per body."""
    d = strip("two", [20.0, 20.0], [90.0], ["H-3"])  # two bodies: H-3 and VeroWhite
    Evaluation(d).export(tmp_path, "permanent", ("3mf", "prusa3mf"))
    tools = {}
    for name in ("two.3mf", "two_prusa.3mf"):
        gcode = tmp_path / f"{name}.gcode"
        subprocess.run(["prusa-slicer", "--export-gcode", str(tmp_path / name), "--output", str(gcode)],
                       check=True, capture_output=True, timeout=300)
        tools[name] = set(re.findall(r"^T(\d+)\s*$", gcode.read_text(errors="replace"), flags=re.M))
    assert tools["two.3mf"] <= {"0"}
    assert tools["two_prusa.3mf"] == {"0", "1"}


def test_help_names_svg_and_svg_loads(capsys):
    for cmd in ("check", "simulate", "robust", "export", "assign"):
        assert main([cmd, "--help"]) == 0
        out = capsys.readouterr().out
        assert ".svg" in out and ".fold" in out, cmd
    assert main(["check", str(TDATA / "origami_simulator" / "simpleVertex.svg"), "--samples", "0"]) in (0, 1)


def test_check_says_which_materials_it_used(tmp_path, capsys):
    design = tmp_path / "two.toml"
    from foldprint.io.design_io import design_to_toml

    design.write_text(design_to_toml(strip("two", [20.0, 20.0], [90.0], ["H-3"])), encoding="utf-8")
    mats = tmp_path / "mine.toml"
    mats.write_text('[materials.X-1]\nrole = "hinge"\ntg_c = 40.0\ncolor = "#112233"\n', encoding="utf-8")
    main(["check", str(design), "--samples", "0", "--materials", str(mats)])
    err = capsys.readouterr().err
    assert f"materials: the shipped library + {mats}" in err
    main(["check", str(design), "--samples", "0"])
    assert "materials: the shipped library\n" in capsys.readouterr().err


def test_long_lists_are_counted_not_printed():
    """A 100-hinge strip that never folds (a cold bath): simulate's rows and check's
    findings name the first few and count the rest."""
    hinges = [{"id": f"h{i}", "material": "H-3", "fold_time_s": None, "arrested_at_s": None,
               "target_angle_deg": 4.0, "final_angle_deg": 0.0, "angle_error_deg": 4.0} for i in range(1, 100)]
    lines = hinge_lines(hinges)
    assert len(lines) == LIST_FIRST + 1
    assert lines[-1].strip() == (f"... and {99 - LIST_FIRST} more hinges: {99 - LIST_FIRST} do not fold "
                                 f"({first_few([f'h{i}' for i in range(LIST_FIRST + 1, 100)])}) (--json lists every one)")
    assert len(hinge_lines(hinges[:LIST_FIRST + 1])) == LIST_FIRST + 1  # a summary would not save a line
    found = [Finding("FP151", "error", f"hinge h{i} never folds", "warm the bath", {"hinge": f"h{i}"})
             for i in range(1, 100)] + [Finding("FP104", "info", "2 materials", "")]
    text = finding_lines(found)
    assert sum(ln.startswith("ERROR   FP151 hinge") for ln in text) == LIST_FIRST
    assert f"FP151 ... and {99 - LIST_FIRST} more like these (hinge h{LIST_FIRST + 1}," in "\n".join(text)
    assert text[-1] == "INFO    FP104 2 materials"
    assert clipped(list("abcdefghij"), 3, "letters") == ["a", "b", "c", "... and 7 more letters"]


def test_the_gallery_counts_a_code_found_on_many_hinges():
    ev = Evaluation(strip("two", [20.0, 20.0], [90.0], ["H-3"]), EvalOptions(samples=0))
    entry = _entry(ev)
    entry.checks["findings"] = [{"code": "FP151", "severity": "error", "message": f"hinge h{i} never folds",
                                 "where": {"hinge": f"h{i}"}, "hint": "warm the bath"} for i in range(1, 100)]
    page = page_html([entry], Image("materials.png", 1, 1, "chart", "chart"), default_library(), 0.01)
    assert page.count("never folds</li>") + page.count("never folds <span") == LIST_FIRST
    assert f"FP151 ... and {99 - LIST_FIRST} more like these (hinge h{LIST_FIRST + 1}, " in page
    assert "(check.json lists every one)" in page
