"""The note a command prints before it compiles the kernels on a cold numba cache (the first
command after an install): once, on stderr, only when the cache is cold, never with --quiet,
and not from a command that folds nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from foldprint.apps import pipeline
from foldprint.cli import printing
from foldprint.cli.commands import main
from foldprint.core import jit
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.simulation.jamtest import warmup

NOTE = "compiling the kernels, once after an install"


@pytest.fixture
def cache(monkeypatch):
    """The numba cache as the note reads it: ``cache["cold"]`` the groups it lacks. The
    folds themselves take the numpy path (what the note says is read, not compiled)."""
    state = {"cold": ["strips", "loops"], "asked": []}

    def cold_kernels(loops, *, sure=False):
        state["asked"].append((loops, sure))
        return [g for g in state["cold"] if g == "strips" or loops]

    monkeypatch.setenv("FOLDPRINT_KERNELS", "numpy")
    monkeypatch.setattr(warmup, "cold_kernels", cold_kernels)
    monkeypatch.setitem(printing._KERNELS, "compiling", False)
    monkeypatch.setitem(printing.OUTPUT_STATE, "quiet", False)
    return state


def _run(capsys, *args):
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


CHECK = ("check", "helix_uniform", "--samples", "0", "--no-sensitivity", "--json")


def test_a_cold_cache_is_said_once_on_stderr_before_the_fold(capsys, cache):
    code, out, err = _run(capsys, *CHECK)
    assert code == 0 and NOTE not in out
    assert err.count(NOTE) == 1 and "(about 45 s)" in err and "later runs load them from the cache" in err
    assert cache["asked"] == [(False, True)]  # a strip: no loops; only what every fold compiles
    _, _, again = _run(capsys, "robust", "helix_uniform", "--samples", "1", "--json")
    assert NOTE not in again  # once per process


def test_a_warm_cache_says_nothing(capsys, cache):
    cache["cold"] = []
    code, _, err = _run(capsys, *CHECK)
    assert code == 0 and NOTE not in err and cache["asked"]


def test_quiet_says_nothing_and_reads_no_cache(capsys, cache):
    code, _, err = _run(capsys, "--quiet", *CHECK)
    assert code == 0 and NOTE not in err and cache["asked"] == []


def test_a_command_that_folds_nothing_says_nothing(capsys, cache, tmp_path):
    code, _, err = _run(capsys, "export", "helix_uniform", "--format", "stl", "--out", str(tmp_path / "o"), "--json")
    assert code == 0 and NOTE not in err and cache["asked"] == []


def test_a_pattern_with_loops_is_said_to_take_longer(cache):
    miura = load_design(templates_dir() / "miura_3x3.toml")
    helix = load_design(templates_dir() / "helix_uniform.toml")
    assert "about a minute" in pipeline.compile_note(miura)
    assert "about 45 s" in pipeline.compile_note(helix)
    assert cache["asked"] == [(True, True), (False, True)]
    cache["cold"] = []
    assert pipeline.compile_note(miura) is None


def test_the_note_reads_only_what_every_fold_compiles(monkeypatch):
    """A cache written by runs that never reached the narrow phase, a clearance or
    scattered samples lacks their kernels: the note (``sure``) reads it warm, the pool's
    warm-up cold; a cache lacking a nominal fold's kernel is cold for both."""
    monkeypatch.setenv("FOLDPRINT_KERNELS", "numba")
    if not jit.use_kernels():
        pytest.skip("numba cannot load here")
    for some in ("walk_runs", "panel_bounds", "curves_table"):
        monkeypatch.setattr(warmup, "is_cached", lambda module, name, some=some: name != some)
        assert warmup.cold_kernels(True) == ["strips"]
        assert warmup.cold_kernels(True, sure=True) == []
    monkeypatch.setattr(warmup, "is_cached", lambda module, name: name != "screen_runs")
    assert warmup.cold_kernels(False, sure=True) == ["strips"]
    monkeypatch.setattr(warmup, "is_cached", lambda module, name: name != "track_pool")
    assert warmup.cold_kernels(True, sure=True) == ["loops"] and warmup.cold_kernels(False, sure=True) == []
    assert {g for g, probes in warmup.PROBES.items() for p in probes if p in warmup.EVERY_FOLD} == {"strips", "loops"}


def _cold(tmp_path, loops: bool, kernels: str) -> list[str]:
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), FOLDPRINT_KERNELS=kernels)
    code = f"from foldprint.simulation.jamtest.warmup import cold_kernels; print(','.join(cold_kernels({loops}, sure=True)))"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return [g for g in out.stdout.strip().split(",") if g]


def test_an_empty_cache_is_cold_for_the_note(tmp_path):
    if not jit.use_kernels():
        pytest.skip("numba cannot load here")
    assert _cold(tmp_path, False, "numba") == ["strips"]  # one group alone: still compiled, still said
    assert _cold(tmp_path, True, "numba") == ["strips", "loops"]
    assert _cold(tmp_path, True, "numpy") == []
