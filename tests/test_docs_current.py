"""The figures in docs/ that come from model runs are current: every block
scripts/regen_docs.py writes equals a fresh run (words exactly, numbers within the script's
TOLERANCE: 0.011 s for the nominal runs, 0.05 s for the Monte-Carlo percentiles)."""

import importlib.util
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parent.parent / "scripts" / "regen_docs.py"


@pytest.fixture(scope="module")
def regen():
    spec = importlib.util.spec_from_file_location("regen_docs", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_nominal_doc_figures_are_current(regen):
    names = [n for n, (_, _, slow) in regen.BLOCKS.items() if not slow]
    assert len(names) >= 4
    assert regen.check(names) == {}


@pytest.mark.slow  # 60 Monte-Carlo folds of Sample 1 with arrest (~1-3 min): the only way to know the figures
def test_sample1_scatter_figures_are_current(regen):
    assert regen.check(["sample1-scatter"]) == {}


def test_the_check_sees_a_stale_number_and_changed_words(regen):
    fresh = regen.recovery_fold_times()
    assert regen.differences(fresh, fresh, 0.011) == []
    first = fresh.index("| 80 °C | ") + len("| 80 °C | ")
    num = fresh[first:first + 4]
    stale = fresh[:first] + f"{float(num) + 0.02:.2f}" + fresh[first + 4:]
    assert regen.differences(stale, fresh, 0.011) == [f"{float(num) + 0.02:.2f} is now {num}"]
    assert regen.differences(fresh.replace("do not fold", "fold"), fresh, 0.011) == \
        ["the text differs (not only its numbers)"]
