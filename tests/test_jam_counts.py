"""The jam test's running count (``simulation.jamtest.scales.JamCounts``): every path a
stream takes (the adaptive pool, precomputed outcomes, a plain mapper's rounds) reports
with its samples so far the jams among exactly those samples, in stream order, ending at
the decision's; a plain progress callback keeps its three arguments."""

from __future__ import annotations

import pytest

from foldprint.core.constants import CHECK_DT_S
from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.simulation.jamtest.pool import Precomputed
from foldprint.simulation.jamtest.scales import JamCounts, jam_tests
from foldprint.simulation.jamtest.verdict import jam_test


def plain_mapper(fn, items, progress=None):
    return [fn(x) for x in items]


@pytest.fixture(scope="module")
def reference():
    """helix_graded's test at twice the spreads (some samples jam, most do not), folded
    here: its outcomes are the stream every path consumes."""
    design = load_design(resolve_design_path("helix_graded"))
    test = jam_test(max_samples=60)
    r = jam_tests(design, test, scales=(2.0,), workers=1)[2.0]
    assert 0 < r.decision.jams < r.samples  # a count that neither the samples nor zero would fake
    return design, test, r


@pytest.mark.parametrize("path", ["here", "pool", "precomputed", "rounds"])
def test_each_report_counts_the_jams_of_its_samples(reference, path):
    design, test, r = reference
    seen = []
    kw = {"here": dict(workers=1), "pool": dict(workers=2), "rounds": dict(workers=2, mapper=plain_mapper),
          "precomputed": dict(mapper=Precomputed(design.name, test.max_samples, r.seed, r.hinge_model, CHECK_DT_S,
                                                 ((r.scatter, tuple(r.outcomes), test),), r.method))}[path]
    got = jam_tests(design, test, (2.0,), nominal=r.nominal, progress=JamCounts(lambda *a: seen.append(a)),
                    **kw)[2.0]
    assert got.decision == r.decision
    jammed = [o.jammed for o in r.outcomes]
    assert seen and seen[-1][1:] == (r.samples, r.samples, r.decision.jams)
    for stage, done, total, jams in seen:
        assert stage == "jam test at 2x" and jams == sum(jammed[:done])


def test_a_plain_callback_keeps_three_arguments(reference):
    design, test, r = reference
    seen = []
    jam_tests(design, test, (2.0,), nominal=r.nominal, workers=1, progress=lambda *a: seen.append(a))
    assert seen and all(len(a) == 3 for a in seen) and seen[-1] == ("jam test at 2x", r.samples, r.samples)
