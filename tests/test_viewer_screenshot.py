"""The README's screenshot of the viewer (docs/img/viewer.png) shows what the tool says now:
scripts/viewer_screenshot.py records beside it (docs/img/viewer.json) the text it shows,
the viewer page's buttons and a digest of the viewer's scripts; these tests hold that record
to a fresh run of the code (the pixels are not compared). When one fails, run
``python scripts/viewer_screenshot.py`` and look at the picture."""

from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import pytest
from PIL import Image

from foldprint.apps.gallery.entry import Entry
from foldprint.apps.gallery.page import check_verdict, nominal_status
from foldprint.apps.pipeline import CHECK_SCALES, EvalOptions, Evaluation, check_scales
from foldprint.checks.report import simulation_json
from foldprint.core.modes import Method
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.printers import default_printer_key
from foldprint.render.viewer import viewer_data, viewer_page

ROOT = Path(__file__).resolve().parent.parent
RECORD = json.loads((ROOT / "docs" / "img" / "viewer.json").read_text(encoding="utf-8"))
STALE = "docs/img/viewer.png is stale: run python scripts/viewer_screenshot.py"


def _script():
    spec = importlib.util.spec_from_file_location("viewer_screenshot", ROOT / "scripts" / "viewer_screenshot.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _entry(ev) -> Entry:
    result = ev.simulation_for(Method.BOTH)  # the gallery's nominal fold
    sim = simulation_json(result)
    return Entry(ev.design, ev.design.name, sim, ev.to_json(default_printer_key()), fold_time=sim["fold_time_s"],
                 contacts=[(c.panels[0], c.panels[1], c.time, c.method) for c in result.contacts],
                 hinge_done=list(result.hinge_done))


def test_the_record_is_of_this_viewer_and_its_buttons():
    shot = _script()
    assert RECORD["design"] == shot.DESIGN and RECORD["fragment"] == shot.FRAGMENT, STALE
    assert RECORD["viewer_assets_sha256"] == shot.assets_digest(), STALE + " (the viewer's scripts changed)"
    page = viewer_page({"name": RECORD["design"]}, "status", True, "../index.html", "0")
    assert RECORD["controls"] == shot.controls(page), STALE + " (the viewer's buttons changed)"
    with Image.open(ROOT / "docs" / "img" / "viewer.png") as im:
        assert list(im.size) == RECORD["window"] == list(shot.WINDOW)
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert re.search(r"!\[[^\]]*self-locking strip[^\]]*\]\(docs/img/viewer\.png\)", readme)


def test_the_banner_and_facts_are_what_the_nominal_fold_says_now():
    ev = Evaluation(load_design(templates_dir() / f"{RECORD['design']}.toml"), EvalOptions(samples=0))
    _, status = nominal_status(_entry(ev))
    assert RECORD["banner"].startswith(f"Nominal fold: {status} "), STALE
    data = viewer_data(ev.simulation_for(Method.BOTH), ev.library)
    facts = RECORD["facts"].splitlines()
    assert facts[1] == f"bath {data['bath_c']:g} \u00b0C, {data['model']} hinges; the slider spans 0 to {data['end']:.2f} s"
    assert ("no contact" in facts) == (not data["contacts"]), STALE


@pytest.mark.slow
def test_the_banner_s_check_verdict_and_jam_probability_are_check_s_now():
    """The check the gallery runs (check's samples, seed and sigma scales): its verdict and
    jam probability are the screenshot's (about 30 CPU-s)."""
    ev = Evaluation(load_design(templates_dir() / f"{RECORD['design']}.toml"),
                    EvalOptions(scales=check_scales(CHECK_SCALES), workers=1))
    ev.findings  # noqa: B018 - check's stages, in check's order
    entry = _entry(ev)
    _, status = nominal_status(entry)
    _, verdict = check_verdict(entry)
    assert RECORD["banner"] == f"Nominal fold: {status} {verdict}", STALE
    r = ev.robust
    lo, hi = r.ci95
    assert (f"jam probability {100 * r.jam_probability:.1f} % (95 % CI {100 * lo:.1f}\u2013{100 * hi:.1f} %) in "
            f"{r.samples} samples, seed {r.seed}") in RECORD["facts"].splitlines(), STALE
    assert [f"run-worst: worst sample (#{ev.worst_replay.index})"] == RECORD["runs"][1:], STALE
