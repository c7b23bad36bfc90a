"""Property-based fuzz of calibrate (its CSV and options) and of small designs through
``--mechanics bar-hinge``, from the strategies of ``tests/fuzz_gen_surfaces.py``. Each case
runs the command in a forked child (``tests/test_fuzz.py:run_case``) and must keep the
contract: exit 0, 1 or 2, no traceback, no warning printed, one line on stderr and nothing
written on 2; a case the generator marks as past a limit (a number that is not one, a
``sigma`` out of range, a name breaking the id rule, a cell over two lines, a ``--fix`` value
no materials file holds, a ``--plot`` format we do not write) is refused with exit 2; a
materials file calibrate writes loads back with every measured material in it.

The suite runs a small fixed sample (``FOLDPRINT_FUZZ_CASES`` scales it);
``benchmarks/fuzz_inputs.py --kind calibrate,calibrate-options,barhinge`` the big run."""

from __future__ import annotations

import csv
import io
import os
import tempfile
import warnings
from pathlib import Path

from hypothesis import HealthCheck, given, settings

import foldprint.apps.calibrate  # noqa: F401  (imported once: every forked case starts warm)
import foldprint.cli.calibrate_cmd, foldprint.cli.fold_cmds  # noqa: E401,F401
import foldprint.physics.barhinge.equilibrium, foldprint.render.calibration_figure  # noqa: E401,F401

from fuzz_gen import contract_violations, written_outside
from fuzz_gen_surfaces import CAL_COLUMNS, CAL_ROWS, barhinge_designs, calibrate_command_lines, calibrate_csvs

SCALE = float(os.environ.get("FOLDPRINT_FUZZ_CASES", "200")) / 200


def valid_csv() -> bytes:
    """The generators' valid data set as a file."""
    lines = [",".join(CAL_COLUMNS)] + [",".join(r.get(c, "") for c in CAL_COLUMNS) for r in CAL_ROWS]
    return ("\n".join(lines) + "\n").encode()


def _measured(raw: bytes) -> set[str]:
    """The material and reference names of a CSV's rows that are not comments (cells stripped)."""
    text = raw.decode("utf-8-sig")
    rows = list(csv.reader(io.StringIO("\n".join(ln for ln in text.split("\n") if not ln.lstrip().startswith("#")))))
    rows = [r for r in rows if any(c.strip() for c in r)]
    head = [c.strip() for c in rows[0]]
    names = set()
    for r in rows[1:]:
        cells = dict(zip(head, (c.strip() for c in r)))
        if cells.get("kind") not in ("tg", "fixity"):
            names |= {cells[k] for k in ("material", "reference") if cells.get(k)}
    return names


def run_file_case(name: str, raw: bytes, args: list[str], must: str | None, json_stdout: bool = False) -> dict:
    """Run ``foldprint args`` in a fresh folder holding ``name`` (``raw``); the run's dict
    (``tests/test_fuzz.py:run_case``) with ``bad``: the contract violations (empty: fine)."""
    from test_fuzz import run_case

    with tempfile.TemporaryDirectory(prefix="fpfuzz") as tmp:
        case = Path(tmp)
        (case / name).write_bytes(raw)
        before = sorted(p.name for p in case.iterdir())
        res = run_case(args, case)
        after = sorted(p.name for p in case.iterdir() if p.name not in (".stdout", ".stderr"))
        bad = contract_violations(res, wrote_on_exit_2=after != before, json_stdout=json_stdout,
                                  warnings_banned=True, wrote_outside=written_outside(args, before, after, case))
        if must and res["code"] != 2:
            bad.append(f"not refused ({must})")
        if res["code"] == 0 and "--out" in args:
            bad += _loads_back(case / args[args.index("--out") + 1], raw if name.endswith(".csv") else b"")
    res["bad"] = bad
    return res


def _loads_back(path: Path, raw: bytes) -> list[str]:
    """[] when the materials file at ``path`` loads (no warning) and holds every material the
    CSV ``raw`` measured."""
    from foldprint.core.errors import FoldprintError
    from foldprint.model.materials import load_library

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            lib = load_library(path)
    except (FoldprintError, Warning) as exc:
        return [f"written file does not load back: {str(exc)[:200]}"]
    missing = [m for m in _measured(raw) if m not in lib] if raw else []
    return [f"written file lacks {missing[:3]}"] if missing else []


FAST = settings(max_examples=max(3, int(6 * SCALE)), deadline=None, database=None, derandomize=True,
                suppress_health_check=list(HealthCheck))


@FAST
@given(case=calibrate_csvs())
def test_calibrate_csvs_keep_the_contract(case):
    raw, must = case
    res = run_file_case("h.csv", raw, ["calibrate", "h.csv", "--no-profile", "--out", "m.toml"], must)
    assert not res["bad"], (raw[:600], must, res["code"], res["bad"], res["err"][-800:])


@settings(max_examples=max(3, int(4 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(case=calibrate_command_lines(profile=False))
def test_calibrate_options_keep_the_contract(case):
    args, must = case
    res = run_file_case("h.csv", valid_csv(), args, must, json_stdout="--json" in args)
    assert not res["bad"], (args, must, res["code"], res["bad"], res["err"][-800:])


@settings(max_examples=max(2, int(2 * SCALE)), deadline=None, database=None, derandomize=True,
          suppress_health_check=list(HealthCheck))
@given(case=barhinge_designs())
def test_barhinge_designs_keep_the_contract(case):
    text, args = case
    res = run_file_case("b.toml", text.encode(), args, None, json_stdout=args[0] == "check")
    assert not res["bad"], (text, args, res["code"], res["bad"], res["err"][-800:])


def test_the_harness_sees_a_refusal_missed_and_a_file_that_does_not_load(tmp_path):
    """The properties can fail: a case marked as past a limit that exits 0 is reported, and
    a materials file that does not load is."""
    res = run_file_case("h.csv", valid_csv(), ["templates", "--json"], "marked")  # exit 0, cheaply
    assert res["code"] == 0 and res["bad"] == ["not refused (marked)"], (res["bad"], res["err"][-400:])
    broken = tmp_path / "m.toml"
    broken.write_text('[materials."a\\u0000b"]\nrole = "hinge"\ntg_c = 40.0\n')
    assert _loads_back(broken, b"")[0].startswith("written file does not load back")
    assert _measured(valid_csv()) == {"M1", "H-1", "H-7"}
