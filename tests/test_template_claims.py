"""Every template's description is true to what the commands print.

Each template states its claims twice: in words in its description and machine-checkably
in its ``[claims]`` table (foldprint.io.templates.Claims). Here the description must say
each claim in the fixed words below, and the commands must print it: ``simulate --json``
for the nominal fold, ``check --json`` for whether the part can be built and (only for the
templates that claim anything about scatter: few, because it costs check's Monte-Carlo)
whether it jams under scatter.
"""

from __future__ import annotations

import json

import pytest

from foldprint.cli.commands import main
from foldprint.core.constants import FOLD_LEVEL
from foldprint.core.errors import DesignError
from foldprint.core.schema import Where
from foldprint.io.templates import Claims, list_templates, parse_claims, template_claims

NAMES = [t["name"] for t in list_templates()]
SCATTER = [n for n in NAMES if template_claims(n).jams_under_scatter is not None]


def phrases(c: Claims) -> list[str]:
    """The words a description must contain for each of its claims."""
    out = []
    out += {"completes": ["completes nominally"], "collides": ["it collides"],
            "stalls": ["does not complete"], None: []}[c.nominal]
    if c.contact is not None:
        out.append(f"{c.contact[0]}-{c.contact[1]}")
    if c.contact_s is not None:
        out.append(f"at {c.contact_s:.1f} s")
    if c.clearance_mm is not None:
        out.append(f"closest approach {c.clearance_mm:.1f} mm")
    if c.marginal is not None:
        out.append("marginal" if c.marginal else "not marginal")
    if c.point_model is not None:
        out.append(f"point-hinge ROM {c.point_model}")
    if c.goals_met is not None:
        out.append("every goal met" if c.goals_met else "goals not met")
    if c.buildable is False:
        out.append("cannot be built")
    out += list(c.unfolded or ())
    if c.jams_under_scatter is not None:
        out.append("jams under scatter" if c.jams_under_scatter else "does not jam under scatter")
    return out


def _json(capsys, argv: list[str]) -> tuple[int, dict]:
    code = main(argv)
    return code, json.loads(capsys.readouterr().out)


def _verdict(r: dict) -> str:
    return "completes" if r["completed"] else "collides" if r["first_collision"] else "stalls"


@pytest.mark.parametrize("name", NAMES)
def test_the_description_says_its_claims(name):
    c = template_claims(name)
    assert c.nominal is not None, f"{name}: [claims] needs at least nominal"
    desc = next(t["description"] for t in list_templates() if t["name"] == name)
    for words in phrases(c):
        assert words in desc, f"{name}: the description does not say {words!r}"
    if c.marginal is True:
        assert "not marginal" not in desc
    if "jams under scatter" in desc or "jam under scatter" in desc:
        assert c.jams_under_scatter is not None, f"{name}: a claim about scatter without [claims] jams_under_scatter"


@pytest.mark.parametrize("name", NAMES)
def test_simulate_prints_what_the_template_claims(name, capsys):
    c = template_claims(name)
    code, r = _json(capsys, ["simulate", name, "--json"])
    assert _verdict(r) == c.nominal and code == (0 if c.nominal == "completes" else 1)
    first = r["first_collision"]
    if c.contact is not None:
        assert sorted(first["panels"]) == sorted(c.contact)
    if c.contact_s is not None:
        assert first["time_s"] == pytest.approx(c.contact_s, abs=0.05)
    if c.clearance_mm is not None:
        assert r["clearance"]["distance_mm"] == pytest.approx(c.clearance_mm, abs=0.05)
    if c.marginal is not None:
        assert bool(r["scatter_margin"] and r["scatter_margin"]["marginal"]) is c.marginal
    if c.point_model is not None:
        other = r["comparison"] or r  # printed only where the point model's verdict differs
        assert (r["comparison"] is None or r["comparison"]["hinge_model"] == "point") and r["hinge_model"] == "arc"
        assert ("collides" if other["first_collision"] else "completes") == c.point_model
    if c.goals_met is not None:
        assert r["goals"] and all(g["met"] for g in r["goals"]) is c.goals_met
    if c.unfolded is not None:
        short = [h["id"] for h in r["hinges"] if h["fold_time_s"] is None
                 or abs(h["angle_error_deg"]) > (1 - FOLD_LEVEL) * abs(h["target_angle_deg"])]
        assert sorted(short) == sorted(c.unfolded)
    if c.buildable is not None:
        _, chk = _json(capsys, ["check", name, "--samples", "0", "--no-sensitivity", "--json"])
        assert (not any(f["code"] == "FP102" for f in chk["findings"])) is c.buildable


@pytest.mark.parametrize("name", SCATTER)
def test_check_prints_what_the_template_claims_about_scatter(name, capsys):
    """check's own verdict (its samples and seed): a jam probability above the warning
    threshold (FP180, FP181) or not."""
    c = template_claims(name)
    _, chk = _json(capsys, ["check", name, "--no-sensitivity", "--json"])
    jams = any(f["code"] in ("FP180", "FP181") for f in chk["findings"])
    assert jams is c.jams_under_scatter, (name, chk["robust"]["jam_probability"])


def test_claims_are_checked_on_load():
    at = Where("t.toml") / "claims"
    assert parse_claims(None, at) == Claims()
    assert parse_claims({"contact": ["a", "b"], "marginal": False}, at) == Claims(contact=("a", "b"), marginal=False)
    for bad, match in (({"nominal": "folds"}, r"t\.toml: claims\.nominal: must be one of completes"),
                       ({"point_model": "stalls"}, r"must be one of completes, collides"),
                       ({"jams": True}, r"jams"), ({"contact": ["a"]}, r"needs two panel ids"),
                       ({"marginal": "yes"}, r"claims\.marginal"), ({"clearance_mm": -1}, r"clearance_mm")):
        with pytest.raises(DesignError, match=match):
            parse_claims(bad, at)
