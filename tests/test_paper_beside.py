"""The paper's statements beside the model's values (foldprint.simulation.paper_beside), the
[paper] table of a design file, and what simulate and check print of them."""

from __future__ import annotations

import json
import tomllib

import pytest

from foldprint.core.errors import DesignError
from foldprint.core.display import percent, seconds
from foldprint.io.design_io import design_from_dict, design_to_dict
from foldprint.io.load import load_design
from foldprint.io.templates import list_templates, templates_dir
from foldprint.model.materials import default_library
from foldprint.model.paper_statements import PaperRef, load_statements
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.paper_beside import paper_lines
from foldprint.simulation.simulate import simulate


def _template(name: str) -> dict:
    return tomllib.loads((templates_dir() / f"{name}.toml").read_text(encoding="utf-8"))


def test_every_structure_of_the_paper_has_its_template_and_every_statement_a_structure():
    """Sample 1, Sample 2, Fig. 5 and Fig. 6 each have a template naming them; every
    statement about a structure (not Fig. 1b's free hinges) is linked by one template."""
    refs = {t["name"]: load_design(t["path"]).paper for t in list_templates()}
    names = {r.name for r in refs.values() if r is not None}
    assert {"Sample 1", "Sample 2"} <= names
    assert {r.figure for r in refs.values() if r is not None} >= {"Fig. 2b", "Fig. 2c", "Fig. 5", "Fig. 6"}
    linked = [sid for r in refs.values() if r is not None for sid in r.statements]
    assert len(linked) == len(set(linked))
    about_structures = {s.id for s in load_statements().items if s.measure != "free_hinges"}
    assert set(linked) == about_structures


def test_sample2_lines_are_the_materials_curves_and_the_paper_numbers():
    """helix_graded's lines: the model values are its hinge materials' own recovery curves
    (no kinematics), the paper's numbers the data file's, the ratio their quotient."""
    lib = default_library()
    d = load_design(templates_dir() / "helix_graded.toml", lib)
    lines = {ln.statement.id: ln for ln in paper_lines(d, simulate(d, library=lib))}
    curves = {m: recovery_curve(lib[m], 90.0) for m in ("H-1", "H-2", "H-7")}
    want = {"sample2_whole": curves["H-7"].fold_time, "sample2_inner_start": curves["H-2"].onset_time,
            "sample2_inner_finish": curves["H-2"].fold_time, "sample2_outer_start": curves["H-7"].onset_time,
            "sample2_outer_finish": curves["H-7"].fold_time}
    for sid, t in want.items():
        ln = lines[sid]
        assert ln.value.value_s == pytest.approx(t, abs=0.01), sid
        assert ln.ratio == pytest.approx(ln.value.value_s / ln.statement.value_s)
        j = ln.to_json()
        assert j["paper_s"] == ln.statement.value_s and j["structure"] == "Sample 2" and j["figure"] == "Fig. 2c"
        assert f"(model/paper {ln.ratio:.2f})" in j["summary"]
    whole = lines["sample2_whole"]
    assert whole.verdict == "misses" and "paper ~7 s; model: 6.39 s" in whole.summary
    assert lines["fig3b_order"].verdict == "meets" and lines["fig3b_order"].ratio is None


def test_sample1_says_there_is_no_nominal_contact_and_where_scatter_is():
    """helix_uniform: the paper's contact at ~7.5 s has no nominal counterpart; the line
    says so with the clearance, and with the jam probability once it is known."""
    from foldprint.apps.pipeline import EvalOptions, Evaluation

    ev = Evaluation(load_design(templates_dir() / "helix_uniform.toml"), EvalOptions(samples=0))
    contact = ev.paper_lines()[0]
    assert contact.statement.id == "sample1_contact" and contact.verdict == "never happens"
    assert contact.value.value_s is None and contact.ratio is None
    gap = ev.clearance
    assert f"closest {gap.distance:.2f} mm, p5-p9 at {seconds(gap.time)}" in contact.model
    assert "`foldprint check` gives the jam probability" in contact.model
    with_jam = paper_lines(ev.design, ev.simulation, gap, 0.975)[0]
    assert "under scatter the jam probability is 97.5 %" in with_jam.model  # percent(), as check prints it
    stop = ev.paper_lines()[1]
    assert stop.statement.id == "sample1_stop" and "never stops short" in stop.model


def test_a_design_not_from_the_paper_has_no_lines():
    lib = default_library()
    d = load_design(templates_dir() / "miura_3x3.toml", lib)
    assert d.paper is None and paper_lines(d, simulate(d, library=lib)) == ()


def test_the_paper_table_round_trips_and_is_checked():
    data = _template("helix_uniform")
    d = design_from_dict(data, "helix_uniform.toml")
    assert d.paper == PaperRef("Sample 1", "Fig. 2b", ("sample1_contact", "sample1_stop"))
    again = design_from_dict(design_to_dict(d))
    assert again.paper == d.paper

    def refused(paper: dict, match: str, base: dict = data):
        bad = dict(base, paper=paper)
        with pytest.raises(DesignError, match=match):
            design_from_dict(bad, "x.toml")

    refused({"name": "Sample 1", "statements": ["sample_9"]}, r"x\.toml: paper\.statements\[0\]: 'sample_9' is not")
    refused({"figure": "Fig. 2"}, r"paper: needs name")
    refused({"name": "S", "colour": 1}, r"colour")
    # a statement about other hinges or about free hinges is not about this structure
    five = _template("self_lock")  # hinges h1..h5 on H-2, H-3, H-6
    refused({"name": "S", "statements": ["sample2_outer_start"]}, r"reads 'h8', 'h9', which this design", five)
    refused({"name": "S", "statements": ["fig3b_order"]}, r"reads 'H-1', 'H-4', 'H-7', which", five)
    refused({"name": "S", "statements": ["fig1b_spread_80"]}, r"about free hinges")


def test_simulate_and_check_print_the_quote_beside_the_model(capsys):
    from foldprint.cli.commands import main

    quote = load_statements()["sample2_whole"].quote
    assert main(["simulate", "helix_graded"]) == 0
    text = capsys.readouterr().out
    assert f'paper, Sample 2, Fig. 2c: "{quote}"' in text
    assert "the whole fold: paper ~7 s; model: 6.39 s, every hinge at 98 % (model/paper 0.91): misses the paper" in text
    assert main(["simulate", "helix_graded", "--json"]) == 0
    lines = json.loads(capsys.readouterr().out)["paper"]
    assert [ln["id"] for ln in lines] == list(load_design(templates_dir() / "helix_graded.toml").paper.statements)
    assert main(["check", "helix_uniform", "--samples", "8", "--no-sensitivity", "--json"]) == 1
    chk = json.loads(capsys.readouterr().out)
    p = chk["robust"]["jam_probability"]
    assert chk["paper"][0]["id"] == "sample1_contact"
    assert f"under scatter the jam probability is {percent(p)}" in chk["paper"][0]["model"]
    assert main(["check", "helix_uniform", "--samples", "8", "--no-sensitivity"]) == 1
    assert 'paper, Sample 1, Fig. 2b: "First, at ~7.5 s' in capsys.readouterr().out


def test_a_run_at_another_bath_says_so():
    from foldprint.apps.pipeline import EvalOptions, Evaluation

    ev = Evaluation(load_design(templates_dir() / "helix_graded.toml"), EvalOptions(samples=0, bath_c=80.0))
    whole = ev.paper_lines()[0]
    assert whole.model.endswith("(this run's bath 80 C, the design's 90 C)")
    assert whole.value.value_s > 6.39 + 0.5  # a cooler bath folds slower


def test_materials_prints_fig1b_beside_the_model_and_says_what_it_misses(capsys):
    """``foldprint materials`` puts Fig. 1b's two statements (free hinges) beside the model's
    spreads, computed here on another path (each hinge's own recovery curve), with the
    verdict under the data file's reading of "~"; the shipped library misses the 100 C one
    and the line says so. At another hinge thickness the paper's statements do not apply."""
    from foldprint.cli.commands import main

    lib = default_library()
    st = load_statements()
    assert main(["materials", "--json"]) == 0
    lines = {ln["id"]: ln for ln in json.loads(capsys.readouterr().out)["paper"]}
    assert set(lines) == {"fig1b_spread_80", "fig1b_spread_100"}
    for sid, bath in (("fig1b_spread_80", 80.0), ("fig1b_spread_100", 100.0)):
        spread = recovery_curve(lib["H-7"], bath).fold_time - recovery_curve(lib["H-1"], bath).fold_time
        ln = lines[sid]
        assert ln["model_s"] == pytest.approx(spread, abs=1e-3) and ln["paper_s"] == st[sid].value_s
        met = abs(spread - st[sid].value_s) <= st.approx_tol_s
        assert ln["verdict"] == ("meets" if met else "misses") and ln["figure"] == "Fig. 1b"
    assert lines["fig1b_spread_100"]["verdict"] == "misses"
    assert main(["materials"]) == 0
    assert 'paper, free hinges, Fig. 1b: "but at 100 °C, the difference becomes about 2 seconds"' in \
        capsys.readouterr().out
    assert main(["materials", "--json", "--thickness", "1.2"]) == 0
    assert json.loads(capsys.readouterr().out)["paper"] == []


def test_hinges_that_never_finish_are_named_not_a_sentence_cut_short():
    """In a 70 C bath Sample 2's H-7 hinges (h8, h9) never reach 98 % within the run: the
    line names them and says so; it never ends at "to reach 98 %" with no value."""
    from foldprint.apps.pipeline import EvalOptions, Evaluation

    ev = Evaluation(load_design(templates_dir() / "helix_graded.toml"), EvalOptions(samples=0, bath_c=70.0))
    lines = {ln.statement.id: ln for ln in ev.paper_lines()}
    finish = lines["sample2_outer_finish"]
    assert finish.value.value_s is None and finish.verdict == "never happens"
    assert finish.model.startswith("h8, h9 never reach 98 % within the run")
    start = lines["sample2_outer_start"]  # the first of them to start does: a number
    assert start.value.value_s is not None and start.model.startswith(seconds(start.value.value_s))
    for ln in lines.values():
        assert not ln.summary.rstrip().endswith("%"), ln.summary
        assert "to reach" not in ln.model or seconds(ln.value.value_s) in ln.model, ln.model
