"""benchmarks/mutation.py's arithmetic: the sample it draws, the score and interval it
reports, the doc it writes. The interval is checked against its definition and an
independent implementation (exact enumeration of its coverage; scipy's binomtest), the
sample against uniformity over many seeds, the doc against the committed JSON."""

from __future__ import annotations

import importlib
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom, binomtest

BENCH = Path(__file__).resolve().parent.parent / "benchmarks"


@pytest.fixture(scope="module")
def tool():
    sys.path.insert(0, str(BENCH))
    try:
        report = importlib.import_module("mutation_report")
        mutation = importlib.import_module("mutation")
    finally:
        sys.path.remove(str(BENCH))
    return mutation, report


@pytest.mark.parametrize("n", [1, 7, 40, 60])
def test_clopper_pearson_is_scipys_exact_interval_and_meets_its_tails(tool, n):
    _, report = tool
    for k in range(n + 1):
        lo, hi = report.clopper_pearson(k, n)
        ci = binomtest(k, n).proportion_ci(0.95, method="exact")
        assert (lo, hi) == pytest.approx((ci.low, ci.high), abs=1e-9)
        # the definition: each end leaves the observed count in a 2.5 % tail
        if k > 0:
            assert binom.sf(k - 1, n, lo) == pytest.approx(0.025, rel=1e-6)
        else:
            assert lo == 0.0
        if k < n:
            assert binom.cdf(k, n, hi) == pytest.approx(0.025, rel=1e-6)
        else:
            assert hi == 1.0


@pytest.mark.parametrize("n", [10, 45])
def test_clopper_pearson_covers_every_share_at_least_95_percent(tool, n):
    """Exact coverage by enumeration of every outcome, on a grid of true shares (mutation
    scores live near 1, where Wilson's interval under-covers)."""
    _, report = tool
    ends = np.array([report.clopper_pearson(k, n) for k in range(n + 1)])
    for p in np.linspace(0.005, 0.995, 199):
        inside = (ends[:, 0] <= p) & (p <= ends[:, 1])
        assert binom.pmf(np.arange(n + 1), n, p)[inside].sum() >= 0.95 - 1e-12


def test_clopper_pearson_rejects_impossible_counts(tool):
    _, report = tool
    assert report.clopper_pearson(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        report.clopper_pearson(5, 4)


def test_the_sample_is_seeded_uniform_and_without_replacement(tool):
    mutation, _ = tool
    keys = [f"m.x_f__mutmut_{i}" for i in range(1, 31)]
    first = mutation.draw_sample("recovery", keys, 8, 3)
    assert first == mutation.draw_sample("recovery", list(reversed(keys)), 8, 3)  # order of listing is moot
    assert len(set(first)) == 8 and set(first) <= set(keys)
    assert first != mutation.draw_sample("kinematics", keys, 8, 3)  # each module its own draw
    assert mutation.draw_sample("recovery", keys, 99, 3) == sorted(keys)
    # every mutant has the same chance n/N: counts over 3000 seeds within 5 sigma of 800
    counts = Counter(k for s in range(3000) for k in mutation.draw_sample("recovery", keys, 8, s))
    expect, sd = 3000 * 8 / 30, (3000 * (8 / 30) * (22 / 30)) ** 0.5
    assert set(counts) == set(keys)
    assert all(abs(c - expect) < 5 * sd for c in counts.values())


def _entry(statuses: dict[str, str], survivors: list[str], first: dict | None = None) -> dict:
    e = {"mode": "sample", "status": dict(statuses),
         "survivors": [{"id": s, "function": "f", "to": f"line {s}", "where": "m.py:1", "from": "x"}
                       for s in survivors]}
    if first is not None:
        e["first_status"] = first
    return e


def test_rescore_counts_equivalents_out_of_the_denominator(tool):
    _, report = tool
    status = {**{f"k{i}": "killed" for i in range(40)}, "t": "timeout", "s1": "survived", "s2": "survived",
              "u": "unconfirmed", "e": "survived"}
    equivalent = [{"module": "mod", "function": "f", "to": "line e", "reason": "same numbers"}]
    e = report.rescore("mod", _entry(status, ["s1", "s2", "u", "e"]), equivalent)
    assert (e["mutants"], e["killed"], e["timeouts"], e["equivalent"], e["unconfirmed"]) == (45, 41, 1, 1, 1)
    assert e["score"] == pytest.approx(41 / 44, abs=1e-4)
    assert (e["interval"]["low"], e["interval"]["high"]) == pytest.approx(report.clopper_pearson(41, 44), abs=1e-4)
    assert [m["id"] for m in e["survivors"] if m["equivalent"]] == ["e"]
    assert {m["id"]: m["confirmed"] for m in e["survivors"]} == {"s1": True, "s2": True, "u": False, "e": True}
    # the same statuses under another module's name: nothing is equivalent
    assert report.rescore("other", _entry(status, ["s1", "s2", "u", "e"]), equivalent)["equivalent"] == 0


def test_rescore_keeps_the_as_sampled_estimate_apart_from_kills_by_new_tests(tool):
    _, report = tool
    first = {**{f"k{i}": "killed" for i in range(8)}, "s1": "survived", "s2": "survived"}
    now = {**first, "s1": "killed"}
    e = report.rescore("mod", _entry(now, ["s2"], first), [])
    assert e["killed_by_new_tests"] == ["s1"]
    assert (e["killed"], e["score"]) == (9, 0.9)
    assert (e["as_sampled"]["killed"], e["as_sampled"]["score"]) == (8, 0.8)
    assert (e["as_sampled"]["low"], e["as_sampled"]["high"]) == pytest.approx(report.clopper_pearson(8, 10), abs=1e-4)
    assert "as sampled: 80.0 %" in report.table({"mod": {**e, "source": "m.py", "tests": [], "cpu_s": {},
                                                           "population": 90, "sample": {"seed": 1}}})


def test_write_docs_replaces_only_the_block(tool, tmp_path):
    _, report = tool
    doc = tmp_path / "t.md"
    doc.write_text(f"intro\n{report.TABLE_BEGIN}\nold\n{report.TABLE_END}\noutro\n")
    e = report.rescore("mod", _entry({"a": "killed", "b": "survived"}, ["b"]), [])
    e.update(source="m.py", tests=["tests/test_m.py"], cpu_s={"mutmut": 3.0}, population=9, sample={"seed": 4})
    assert report.write_docs({"mod": e}, doc)
    text = doc.read_text()
    assert text.startswith("intro\n") and text.endswith("outro\n") and "old" not in text
    assert "| `m.py` | m | 9 | 2 (seed 4) | 1 | 0 | 50.0 % **below target** |" in text
    assert "**not yet killed**" in text
    report.write_docs({"mod": e}, doc)
    assert doc.read_text() == text


def test_the_committed_table_is_the_one_the_json_gives(tool, tmp_path):
    """docs/testing.md holds what ``mutation.py --report-only`` writes from the committed
    docs/data/mutation.json and equivalent list."""
    _, report = tool
    data = json.loads(report.DATA_JSON.read_text())
    equivalent = report.load_equivalent()
    modules = {k: report.rescore(k, v, equivalent) for k, v in data["modules"].items()}
    doc = tmp_path / "testing.md"
    doc.write_text(report.TESTING_MD.read_text())
    report.write_docs(modules, doc)
    assert doc.read_text() == report.TESTING_MD.read_text()
    assert {k: v["score"] for k, v in modules.items()} == {k: v["score"] for k, v in data["modules"].items()}


def test_every_mapped_module_and_test_file_exists(tool):
    mutation, _ = tool
    root = BENCH.parent
    for name, (src, tests) in mutation.MODULES.items():
        assert (root / src).is_file(), name
        assert tests and all((root / t).is_file() for t in tests), name


def test_the_docs_worked_interval_is_the_tools(tool):
    """docs/testing.md reads a 50-mutant sample with 2 survivors as 96 %, 86-99.5 %."""
    _, report = tool
    lo, hi = report.clopper_pearson(48, 50)
    assert (round(100 * lo), round(100 * hi, 1)) == (86, 99.5)
    assert "2 survivors the score is 96 % and the interval 86–99.5 %" in " ".join(report.TESTING_MD.read_text().split())
