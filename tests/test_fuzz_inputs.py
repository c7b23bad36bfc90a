"""Property-based fuzz of the input boundary (hostile files and command lines): SVG, FOLD, command lines and
planted output folders from the strategies of ``tests/fuzz_gen.py``. A failure is shrunk by
hypothesis to its minimal input. The suite runs a small budget (``FOLDPRINT_FUZZ_CASES``
scales it); ``benchmarks/fuzz_inputs.py`` runs 10,000 cases with peak memory.

Contracts: a design file is read into a Design or refused with a FoldprintError (one line
naming the file) within the time budget; a command exits 0, 1 or 2, never with a
traceback, one line on stderr and nothing written on 2; an export into a planted folder
writes its set or refuses with an ExportError, and never changes, follows or deletes
what it did not make."""

from __future__ import annotations

import hashlib
import os
import signal
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from fuzz_gen import (FILE_NAMES, PLANTS, PLANTS_OURS, READERS, SMALL_DESIGN, command_lines, contract_violations,
                      fold_documents, make_path, numeric_command_lines, option_files, path_cases, plant, svg_documents,
                      written_outside)
from foldprint.core.errors import ExportError, FoldprintError
from foldprint.exchange.fileset import write_set
from foldprint.io.load import load_design

SCALE = float(os.environ.get("FOLDPRINT_FUZZ_CASES", "200")) / 200  # 1 at the suite's default
LOAD_BUDGET_S = 30.0


class _Slow(Exception):
    pass


def _alarm(signum, frame):
    raise _Slow()


def load_contract(name: str, raw: bytes, budget: float = LOAD_BUDGET_S) -> str:
    """'ok' or 'refused'; raises AssertionError on a contract violation."""
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / name
        f.write_bytes(raw)
        old = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, budget)
        try:
            with warnings.catch_warnings():  # a numpy overflow warning means an unchecked value
                warnings.simplefilter("error", RuntimeWarning)
                load_design(f)
            return "ok"
        except FoldprintError as exc:
            msg = str(exc)
            assert "\n" not in msg.strip() and name in msg and len(msg) < 2000, msg
            return "refused"
        except _Slow:
            raise AssertionError(f"reading took over {budget} s") from None
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)


FAST = settings(max_examples=max(10, int(60 * SCALE)), deadline=None, database=None, derandomize=True,
                suppress_health_check=list(HealthCheck))


@FAST
@given(raw=svg_documents())
def test_svg_inputs_are_read_or_refused_cleanly(raw):
    load_contract("case.svg", raw)


@FAST
@given(raw=fold_documents())
def test_fold_inputs_are_read_or_refused_cleanly(raw):
    load_contract("case.fold", raw)


def _tree(root: Path) -> dict:
    """Every entry under ``root`` without following links: type and content or target."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for n in dirnames + filenames:
            p = Path(dirpath) / n
            rel = str(p.relative_to(root))
            if p.is_symlink():
                out[rel] = ("link", os.readlink(p))
            elif p.is_dir():
                out[rel] = ("dir", None)
            else:
                out[rel] = ("file", hashlib.sha256(p.read_bytes()).hexdigest())
    return out


def _ours(plants: list[str], names: list[str], rel: str) -> bool:
    """Whether the entry ``rel`` (relative to the case folder) is foldprint's: a file of
    the set or its manifest in the folder (``out`` or, through a link, ``real_out``), or a
    planted entry of foldprint's own (:data:`fuzz_gen.PLANTS_OURS`) a run may remove."""
    for top in ("out/", "real_out/"):
        if rel in {f"{top}{n}" for n in [*names, "foldprint-set.json"]}:
            return True
    return any(rel.startswith(p) for k in plants for p in PLANTS_OURS.get(k, []))


@settings(max_examples=max(20, int(150 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(plants=hs.lists(hs.sampled_from(PLANTS), max_size=3, unique=True), names=FILE_NAMES,
       twice=hs.booleans(), force=hs.booleans())
def test_planted_output_folders(plants, names, twice, force):
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        keep = tmp / "keep.txt"
        keep.write_text("mine")
        out = tmp / "out"
        for k in plants:
            plant(out, k, names)
        files = [(n, f"{n} v1".encode()) for n in names]
        for attempt in range(2 if twice else 1):
            before = _tree(tmp)
            try:
                write_set(out, files, force=force)
            except ExportError as exc:
                assert "\n" not in str(exc) and str(out) in str(exc), exc
                assert _tree(tmp) == before, "a refused export changed the folder"
                break
            else:
                for n, data in files:
                    assert (out / n).read_bytes() == data
                after = _tree(tmp)
                assert not [k for k, (kind, _) in after.items() if kind == "link" and k not in before], \
                    "the export made a link"
                theirs = {k: v for k, v in before.items() if not _ours(plants, names, k)}
                assert {k: after.get(k) for k in theirs} == theirs, "an entry foldprint did not make changed"
            files = [(n, f"{n} v2".encode()) for n in names]
        assert keep.read_text() == "mine"


@pytest.fixture(scope="module")
def cli_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    (d / "d.toml").write_text(SMALL_DESIGN)
    return d


@settings(max_examples=max(6, int(25 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(args=command_lines())
def test_command_lines_keep_the_contract(cli_dir, args):
    from test_fuzz import run_case

    with tempfile.TemporaryDirectory(dir=cli_dir) as case:
        case = Path(case)
        (case / "d.toml").write_text(SMALL_DESIGN)
        before = sorted(p.name for p in case.iterdir())
        res = run_case(args, case)
        after = sorted(p.name for p in case.iterdir() if p.name not in (".stdout", ".stderr"))
        assert contract_violations(res, wrote_on_exit_2=after != before,
                                   wrote_outside=written_outside(args, before, after, case)) == [], (
            args, res["code"], res["err"][-1500:], after)


# -- option files, paths that are not regular files, numeric extremes (the one door for files) ---

def _use_options(option: str, path: Path) -> None:
    """Load an option file and use what it holds the way the commands do: every hinge
    material's fold time at the ends of the bath range, the scatter's samples' curves."""
    from foldprint.checks.rules import load_printers
    from foldprint.core.schema import TEMPERATURE_C
    from foldprint.model.design import strip
    from foldprint.model.materials import load_library
    from foldprint.physics.recovery.curve import fold_time
    from foldprint.simulation.robust import sample_drives
    from foldprint.simulation.scatter import draw_samples, load_scatter

    if option == "--materials":
        lib = load_library(path)
        for m in lib.hinges():
            for bath in (*TEMPERATURE_C, 90.0):
                fold_time(m, bath, 0.8)
    elif option == "--printers":
        load_printers(path)
    else:
        d = strip("s", [10.0, 10.0, 10.0], [90.0, -90.0], ["H-1", "H-2"])
        from foldprint.model.materials import default_library

        sample_drives(d, default_library(), draw_samples(d, load_scatter(path), 4, 0))


@FAST
@given(case=option_files())
def test_option_files_are_read_or_refused_cleanly(case):
    """Read and usable, or refused with one line naming the file, no warning, in time."""
    option, raw = case
    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "opt.toml"
        f.write_bytes(raw)
        old = signal.signal(signal.SIGALRM, _alarm)
        signal.setitimer(signal.ITIMER_REAL, LOAD_BUDGET_S)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                _use_options(option, f)
        except FoldprintError as exc:
            msg = str(exc)
            assert "\n" not in msg.strip() and str(f) in msg and len(msg) < 2000, msg
        except _Slow:
            raise AssertionError(f"{option}: over {LOAD_BUDGET_S} s") from None
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, old)


def _cli_case(cli_dir, args, make=None):
    from test_fuzz import run_case

    with tempfile.TemporaryDirectory(dir=cli_dir) as case:
        case = Path(case)
        (case / "d.toml").write_text(SMALL_DESIGN)
        if make is not None:
            args = make(case, args)
        before = sorted(p.name for p in case.iterdir())
        res = run_case(args, case)
        after = sorted(p.name for p in case.iterdir() if p.name not in (".stdout", ".stderr"))
        return res, after != before, written_outside(args, before, after, case)


@settings(max_examples=max(8, int(20 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(case=path_cases())
def test_input_paths_that_are_not_files_keep_the_contract(cli_dir, case):
    """FIFOs, devices, directories, links that lead nowhere or in a loop, names and paths
    too long or too deep, as a design, an option file, --out or --plot: exit 0/1/2, one
    line on 2, nothing written on 2, no hang (the harness's CPU and wall limits)."""
    reader, kind, suffix = case

    def make(folder, args):
        p = make_path(str(folder), kind, suffix)
        return [a.format(p) for a in args]

    res, wrote, outside = _cli_case(cli_dir, READERS[reader], make)
    assert contract_violations(res, wrote_on_exit_2=wrote, warnings_banned=True, wrote_outside=outside) == [], (
        case, res["err"][-800:])
    if kind in ("fifo", "dev_zero", "dev_urandom", "directory", "long_path", "deep_path") and reader[2:] not in ("out", "plot"):
        assert res["code"] == 2, (case, res["err"])


@settings(max_examples=max(6, int(15 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(args=numeric_command_lines())
def test_numeric_options_at_their_extremes_keep_the_contract(cli_dir, args):
    res, wrote, outside = _cli_case(cli_dir, args)
    assert contract_violations(res, wrote_on_exit_2=wrote, warnings_banned=True, wrote_outside=outside) == [], (
        args, res["err"][-800:])
