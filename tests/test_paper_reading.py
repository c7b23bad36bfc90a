"""One reading of the paper's words: each phrase is one interval (docs/structure-timings.md),
and ``check``, ``materials`` (Fig. 1b) and ``calibrate`` give one verdict on every paper
statement they print, with the tolerance beside it."""

import json
import math
from pathlib import Path

import pytest
from hypothesis import given, strategies as st

from foldprint.cli.commands import main
from foldprint.model.paper_reading import PHRASES, read
from foldprint.simulation.paper_timings import fig1b_lines

CSV = Path(__file__).resolve().parent.parent / "foldprint" / "data" / "paper_hinge_data.csv"


@given(kind=st.sampled_from(sorted(PHRASES)), x=st.floats(0.5, 30.0), tol=st.floats(0.0, 2.0),
       v=st.floats(0.0, 40.0))
def test_each_phrase_is_one_interval(kind, x, tol, v):
    r = read(kind, x, tol)
    lo, hi = {"about": (x - tol, x + tol), "at_most": (0.0, x + tol), "at_least": (x - tol, math.inf)}[kind]
    assert (r.low, r.high) == (pytest.approx(lo), pytest.approx(hi) if hi < math.inf else math.inf)
    inside = lo - 1e-9 <= v <= hi + 1e-9
    assert r.verdict(v) == ("meets" if inside else "misses")
    assert (r.off_by(v) == 0.0) == inside or abs(r.off_by(v)) < 1e-9
    assert f"tolerance {tol:g} s" in r.text and r.phrase in r.text


def test_the_words_and_the_default_tolerance():
    assert read("at_most", 1.0).text.startswith("within ~1 s, read as <= 1.5 s; tolerance 0.5 s, our choice")
    assert read("at_least", 3.0).interval_text == ">= 2.5 s" and read("about", 7.0).interval_text == "6.5-7.5 s"
    assert read("about", 2.0).verdict(None) == "never happens"


#: calibrate's time rows of the paper's data (kind, material, level or bath) -> the
#: statements check / materials print about the same event.
ROWS = {("time_to", "H-2", 0.05): ("sample2_inner_start",), ("time_to", "H-2", 0.98): ("sample2_inner_finish",),
        ("time_to", "H-7", 0.05): ("sample2_outer_start",),
        ("time_to", "H-7", 0.98): ("sample2_outer_finish", "sample2_whole"),
        ("spread", "H-7", 80.0): ("fig1b_spread_80",), ("spread", "H-7", 100.0): ("fig1b_spread_100",)}


def test_check_and_calibrate_give_one_verdict_on_the_paper(capsys):
    assert main(["check", "helix_graded", "--samples", "16", "--json"]) == 0
    lines = {p["id"]: p for p in json.loads(capsys.readouterr().out)["paper"]}
    lines.update({ln.statement.id: ln.to_json() for ln in fig1b_lines()})  # what `foldprint materials` prints
    assert main(["calibrate", str(CSV), "--json", "--no-profile"]) == 0
    rows = [r for r in json.loads(capsys.readouterr().out)["rows"] if r["verdict"] is not None]
    assert len(rows) == 6
    compared = 0
    for r in rows:
        key = (r["kind"], r["material"], r["level"] if r["kind"] == "time_to" else r["bath_c"])
        for sid in ROWS[key]:
            p = lines[sid]
            assert r["verdict"] == p["verdict"], (sid, r, p)
            # the same words read as the same interval, printed beside the verdict
            assert p["reading"]["read_as"].split(";")[0] in r["reading"], (sid, r["reading"], p["reading"])
            assert p["reading"]["read_as"] in p["summary"]
            compared += 1
    assert compared == 7
    # the statement the two once disagreed on: "within ~1 s", the model 1.14 s
    inner = lines["sample2_inner_start"]
    assert inner["model_s"] == pytest.approx(1.14, abs=0.01) and inner["verdict"] == "meets"
