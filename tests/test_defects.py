"""Defects found in review, each with a test that failed before its fix."""

from __future__ import annotations

import json
from pathlib import Path
import random
from types import SimpleNamespace

import numpy as np
import pytest
import shapely

from foldprint.checks.jam_rules import rule_jam_probability
from foldprint.checks.rules import Thresholds
from foldprint.cli.commands import main
from foldprint.model.crease_patterns import waterbomb
from foldprint.io.fold_format import design_from_fold
from foldprint.geometry.assembly import build_pieces
from foldprint.geometry.hinges import tree_poses, state_angles
from foldprint.core.modes import HingeModel

from foldprint.geometry import layout



def _waterbomb_8():
    """The 8-crease waterbomb base of the report: diagonals +60 deg, midlines -131.59 deg."""
    d = waterbomb(40.0, 60.0, material="H-3")
    d["edges_foldAngle"] = [(-131.59 if k % 2 == 0 else 60.0) for k in range(8)] + [0.0] * 8
    d["edges_assignment"] = ["M" if a < 0 else "V" if a > 0 else "B" for a in d["edges_foldAngle"]]
    return design_from_fold(d)


def test_waterbomb_builds_every_triangle_as_a_solid():
    """The layout lists hinges in file order; a child placed before its parent kept an
    all-zero pose, so one of the eight congruent triangles was an empty solid (FP102)."""
    d = _waterbomb_8()
    pieces = [p for p in build_pieces(d) if p.kind == "panel"]
    assert len(pieces) == 8
    lays, rigid = layout(d)
    for k, piece in enumerate(pieces):  # volume = rigid area x thickness (an independent shapely area)
        area = shapely.union_all(list(getattr(rigid[k], "geoms", [rigid[k]]))).area
        assert piece.volume == pytest.approx(area * d.panels[k].thickness, rel=1e-6)


def test_poses_do_not_depend_on_the_order_of_the_frames():
    d = _waterbomb_8()
    lays, _ = layout(d)
    frames = [lay.frame for lay in lays]
    angles = state_angles(d, "permanent")
    ref = tree_poses(d, frames, angles)
    for seed in range(5):
        shuffled = frames[:]
        random.Random(seed).shuffle(shuffled)
        np.testing.assert_array_equal(tree_poses(d, shuffled, angles), ref)
    assert all(abs(np.linalg.det(p[:3, :3]) - 1.0) < 1e-9 for p in ref)


def test_waterbomb_exports(tmp_path, capsys):
    f = tmp_path / "wb.fold"
    d = waterbomb(40.0, 60.0, material="H-3")
    d["edges_foldAngle"] = [(-131.59 if k % 2 == 0 else 60.0) for k in range(8)] + [0.0] * 8
    d["edges_assignment"] = ["M" if a < 0 else "V" if a > 0 else "B" for a in d["edges_foldAngle"]]
    f.write_text(json.dumps(d))
    assert main(["export", str(f), "--out", str(tmp_path / "o"), "--format", "stl"]) == 0, capsys.readouterr().err


@pytest.fixture
def crossing():
    """Panels p1 and p3 cross in the printed state (shared with tests/test_assign.py)."""
    return Path(__file__).parent / "data" / "crossing.toml"


def test_simulate_says_a_crossing_part_can_never_be_printed(crossing, capsys):
    code = main(["simulate", str(crossing)])
    out = capsys.readouterr().out
    assert code == 1
    assert "can never be printed" in out and "'p1' and 'p3'" in out
    assert "contact" not in out and "collide" not in out  # not "a contact at 2.2 s"
    code = main(["simulate", str(crossing), "--json"])
    rep = json.loads(capsys.readouterr().out)
    assert code == 1 and rep["printed_crossings"] == [["p1", "p3"]] and rep["comparison"] is None


def test_simulate_answers_a_crossing_part_before_folding(crossing, capsys, monkeypatch):
    """The text verdict of a part that cannot be printed is the line the full report gives
    (the JSON path, which folds), reached without folding."""
    from foldprint.apps import evaluation_nominal
    from foldprint.cli.printing import print_simulation

    assert main(["simulate", str(crossing), "--json"]) == 1
    print_simulation(json.loads(capsys.readouterr().out))
    want = capsys.readouterr().out

    def no_fold(*args, **kwargs):
        raise AssertionError("folded a part that cannot be printed")

    monkeypatch.setattr(evaluation_nominal, "simulate", no_fold)
    assert main(["simulate", str(crossing)]) == 1
    assert capsys.readouterr().out == want and "can never be printed" in want


def test_fp170_offers_no_lower_tg_hint_for_a_crossing_part(crossing, capsys):
    main(["check", str(crossing), "--samples", "0", "--json"])
    findings = {f["code"]: f for f in json.loads(capsys.readouterr().out)["findings"]}
    assert "FP122" in findings and "FP170" in findings
    assert "Tg" not in findings["FP170"]["hint"] and "printed (permanent) state" in findings["FP170"]["hint"]


def test_fp170_keeps_its_hint_for_an_order_problem(capsys):
    main(["check", "helix_uniform", "--samples", "0", "--hinge-model", "point", "--json"])
    findings = {f["code"]: f for f in json.loads(capsys.readouterr().out)["findings"]}
    if "FP170" in findings:
        assert "lower-Tg" in findings["FP170"]["hint"]


def test_assign_on_a_crossing_part_counts_no_evaluation(crossing, capsys):
    code = main(["assign", str(crossing)])
    out = capsys.readouterr().out
    assert code == 1
    assert "in 0 evaluations" in out and "evaluation(s)" not in out  # was "... in 1 evaluation(s)"
    assert "p1-p3 cross in the printed (permanent) state" in out


def test_assign_json_on_a_crossing_part_counts_no_evaluation(crossing, capsys):
    code = main(["assign", str(crossing), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and out["evaluated"] == 0 and out["feasible"] == 0
    assert out["blocking"] == [{"pair": ["p1", "p3"], "count": 0, "kind": "pair", "printed_state": True}]


def test_fp171_names_the_hole_as_an_index(capsys):
    main(["check", "self_lock_uniform", "--samples", "0", "--json"])
    fp171 = [f for f in json.loads(capsys.readouterr().out)["findings"] if f["code"] == "FP171"]
    assert fp171
    msgs = {f["where"]["goal"]: f["message"] for f in fp171}
    assert "holes[1]" in msgs["hole2"] and "hole 1" not in msgs["hole2"]


@pytest.mark.parametrize("model", [HingeModel.POINT, HingeModel.ARC])
def test_fp180_names_the_hinge_model_it_sampled(model):
    r = SimpleNamespace(ci95=(0.5, 0.9), jam_probability=0.7, jams=14, samples=20, collisions=lambda: [], outcomes=(),
                        hinge_model=model)
    (f,) = rule_jam_probability(SimpleNamespace(robust=r, thresholds=Thresholds(), sweep=()))
    assert f.code == "FP180"
    assert ("printed geometry (arc hinges)" in f.message) == (model == HingeModel.ARC)
    if model == HingeModel.POINT:
        assert "point-hinge model (not the printed geometry)" in f.message
