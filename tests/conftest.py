import os

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def lib():
    from foldprint.model.materials import default_library

    return default_library()


@pytest.fixture
def guard_defaults(monkeypatch):
    """The resource guards at their defaults (no limit from the environment) before and
    after a test that sets them."""
    from foldprint.core import guards

    monkeypatch.delenv("FOLDPRINT_TIME_BUDGET", raising=False)
    monkeypatch.delenv("FOLDPRINT_MAX_MEMORY", raising=False)
    guards.set_max_memory(None)
    guards.set_time_budget(None)
    yield
    guards.set_max_memory(None)
    guards.set_time_budget(None)
