"""The examples in the package's docstrings run and give what they show."""

import doctest
import importlib
import pkgutil

import foldprint


def test_docstring_examples_run():
    attempted = 0
    for info in pkgutil.walk_packages(foldprint.__path__, "foldprint."):
        if info.name.endswith("__main__"):
            continue
        mod = importlib.import_module(info.name)
        res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
        assert res.failed == 0, f"{info.name}: {res.failed} docstring example(s) failed"
        attempted += res.attempted
    assert attempted >= 5, f"only {attempted} docstring examples found: did the walk miss modules?"
