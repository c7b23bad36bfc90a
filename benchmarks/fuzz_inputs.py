"""Fresh fuzz campaigns: hostile inputs through the command line (the exit-code contract).

    PYTHONPATH=$PWD python benchmarks/fuzz_inputs.py --kind all --cases 10000 --jobs 2 --json out.json

Kinds (``--kind``, comma-separated or ``all``; ``--cases`` is split evenly between them):

* ``design``: mutated templates and a FOLD sheet (``tests/test_fuzz.py:mutate``) through
  ``check --json`` and ``export``, seeds from ``--seed-base``;
* ``svg``, ``fold``: documents from the hypothesis strategies of ``tests/fuzz_gen.py``
  through ``check --samples 0 --json`` (the whole pipeline when the file is valid);
* ``cli``: command lines with hostile option values on a small strip design;
* ``planted``: an export (``write_set``) into an output folder with planted entries,
  in process (it only writes files);
* ``options``: option files (``--materials``, ``--printers``, ``--scatter``) with 1-3
  hostile values, through the command that reads each;
* ``paths``: FIFOs, devices, directories, dangling or looping links, names and paths too
  long or too deep, as a design, an option file, ``--out`` or ``--plot``;
* ``numeric``: numeric options of every command at their extremes (1e308, 5e-324, nan,
  400 digits, ...);
* ``calibrate``: calibrate's CSV with hostile cells (numbers that are not, digits of other
  scripts, quoted line breaks, names past the id rule, sigma extremes) through
  ``calibrate --no-profile --out``; ``calibrate-options``: ``--fix``, ``--fit``,
  ``--per-material``, ``--plot`` on a valid CSV; ``barhinge``: small strips, rows of panels
  (extra outline vertices, holes), single panels and four-panel loops at extreme angles
  through ``simulate`` / ``check --samples 0`` with ``--mechanics bar-hinge``
  (``tests/fuzz_gen_surfaces.py``; a case marked as past a limit must exit 2, a written
  materials file must load back).

``--kind new`` runs the last three. ``--max-wall S`` stops drawing new cases after S seconds
(the counts say how many ran).

Every command runs in a forked child with a budget of 30 s of its own CPU time (wall time
on the shared machine is reported, not used). Prints per kind: the exit codes,
tracebacks, exits other than 0/1/2, runs over 30 s (CPU), one-line-on-2 violations, the
largest CPU and wall time and the peak memory (max RSS of one child, MiB), and the first
failing inputs (saved under ``--keep`` for replay).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_fuzz import one, run_case  # noqa: E402

KINDS = ("design", "svg", "fold", "cli", "planted", "options", "paths", "numeric", "calibrate",
         "calibrate-options", "barhinge")
NEW_KINDS = ("calibrate", "calibrate-options", "barhinge")


def _warm():
    """Import the CLI and every stage once per worker, so each forked case starts warm."""
    import foldprint.checks.rules, foldprint.cli.fold_cmds, foldprint.cli.output_cmds, foldprint.io.load, foldprint.apps.pipeline, foldprint.simulation.simulate  # noqa: E401,F401
    import foldprint.geometry, foldprint.exchange.export, foldprint.io.svg_format  # noqa: E401,F401
    import foldprint.apps.calibrate, foldprint.cli.calibrate_cmd, foldprint.physics.barhinge.equilibrium  # noqa: E401,F401
    import foldprint.render.calibration_figure  # noqa: F401


def _summary(kind: str, code, bad: list, seconds: float, cpu: float, peak: float, err: str, case) -> dict:
    return {"kind": kind, "code": code, "bad": bad, "seconds": round(seconds, 2), "cpu_seconds": round(cpu, 2),
            "peak_mib": round(peak, 1), "err": err[-300:] if bad else "", "case": case if bad else None}


def _run_design(seed: int) -> list[dict]:
    with tempfile.TemporaryDirectory(prefix="fpfuzz") as tmp:
        r = one(seed, Path(tmp))
    return [_summary(f"design/{cmd}", v["code"], v["bad"], v["seconds"], v["cpu_seconds"], v.get("peak_mib", 0.0),
                     v["err"], seed) for cmd, v in r.items()]


def _contract(res: dict, before: list, after: list, args: list[str] = (), folder=".") -> list[str]:
    from foldprint.core.guards import DEFAULT_MAX_MEMORY
    from fuzz_gen import contract_violations, written_outside

    return contract_violations(res, wrote_on_exit_2=after != before, warnings_banned=True,
                               wrote_outside=written_outside(list(args), before, after, folder),
                               peak_limit_mib=DEFAULT_MAX_MEMORY / 2 ** 20)


def _run_file(kind: str, name: str, raw: bytes, args: list[str]) -> list[dict]:
    from fuzz_gen import SMALL_DESIGN

    with tempfile.TemporaryDirectory(prefix="fpfuzz") as tmp:
        case = Path(tmp)
        if name:
            (case / name).write_bytes(raw)
        (case / "d.toml").write_text(SMALL_DESIGN)
        before = sorted(p.name for p in case.iterdir())
        res = run_case(args, case)
        after = sorted(p.name for p in case.iterdir() if p.name not in (".stdout", ".stderr"))
    bad = _contract(res, before, after, args, case)
    return [_summary(kind, res["code"], bad, res["seconds"], res["cpu_seconds"], res["peak_mib"], res["err"],
                     {"args": args, "file": raw.decode("utf-8", "replace")[:20000] if name else None})]


OPTION_ARGS = {"--materials": ["materials", "--materials", "opt.toml"],
               "--printers": ["check", "d.toml", "--samples", "0", "--printers", "opt.toml"],
               "--scatter": ["robust", "d.toml", "--samples", "2", "--scatter", "opt.toml"]}


def _run_path(reader: str, kind: str, suffix: str) -> list[dict]:
    from fuzz_gen import READERS, SMALL_DESIGN, make_path

    with tempfile.TemporaryDirectory(prefix="fpfuzz") as tmp:
        case = Path(tmp)
        (case / "d.toml").write_text(SMALL_DESIGN)
        path = make_path(tmp, kind, suffix)
        args = [a.format(path) for a in READERS[reader]]
        before = sorted(p.name for p in case.iterdir())
        res = run_case(args, case)
        after = sorted(p.name for p in case.iterdir() if p.name not in (".stdout", ".stderr"))
    bad = _contract(res, before, after, args, case)
    if kind in ("fifo", "dev_zero", "dev_urandom", "directory") and reader[2:] not in ("out", "plot") \
            and res["code"] != 2:
        bad.append("not refused")
    return [_summary("paths", res["code"], bad, res["seconds"], res["cpu_seconds"], res["peak_mib"], res["err"],
                     {"reader": reader, "kind": kind, "suffix": suffix})]


def _run_planted(plants, names, twice, force) -> list[dict]:
    import resource

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    from test_fuzz_inputs import test_planted_output_folders

    t0, c0 = time.monotonic(), time.process_time()
    bad, err = [], ""
    try:
        test_planted_output_folders.hypothesis.inner_test(plants, names, twice, force)
    except AssertionError as exc:
        bad, err = ["contract"], str(exc)
    except Exception as exc:  # noqa: BLE001
        bad, err = ["traceback"], f"{type(exc).__name__}: {exc}"
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return [_summary("planted", 0 if not bad else None, bad, time.monotonic() - t0, time.process_time() - c0, peak,
                     err, {"plants": plants, "names": names, "twice": twice, "force": force})]


def _run_surface(kind: str, name: str, raw: bytes, args: list[str], must) -> list[dict]:
    from test_fuzz_surfaces import run_file_case

    res = run_file_case(name, raw, args, must, json_stdout="--json" in args)
    return [_summary(kind, res["code"], res["bad"], res["seconds"], res["cpu_seconds"], res["peak_mib"], res["err"],
                     {"args": args, "must": must, "file": raw.decode("utf-8", "replace")[:20000]})]


def _jobs(kind: str, n: int, seed_base: int):
    """(function, args) of ``n`` cases of ``kind``, drawn from the hypothesis strategies."""
    if kind == "design":
        return [(_run_design, (seed_base + i,)) for i in range(n)]
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as hs

    from fuzz_gen import (FILE_NAMES, PLANTS, command_lines, fold_documents, numeric_command_lines, option_files,
                          path_cases, svg_documents)
    from fuzz_gen_surfaces import barhinge_designs, calibrate_command_lines, calibrate_csvs

    out = []
    strat = {"svg": svg_documents(), "fold": fold_documents(), "cli": command_lines(),
             "planted": hs.tuples(hs.lists(hs.sampled_from(PLANTS), max_size=3, unique=True), FILE_NAMES,
                                  hs.booleans(), hs.booleans()),
             "options": option_files(), "paths": path_cases(), "numeric": numeric_command_lines(),
             "calibrate": calibrate_csvs(), "calibrate-options": calibrate_command_lines(),
             "barhinge": barhinge_designs()}[kind]

    @settings(max_examples=n, deadline=None, database=None, derandomize=True,
              suppress_health_check=list(HealthCheck))
    @given(strat)
    def draw(x):
        if len(out) >= n:
            return
        if kind == "svg":
            out.append((_run_file, ("svg", "case.svg", x, ["check", "case.svg", "--samples", "0", "--json"])))
        elif kind == "fold":
            out.append((_run_file, ("fold", "case.fold", x, ["check", "case.fold", "--samples", "0", "--json"])))
        elif kind in ("cli", "numeric"):
            out.append((_run_file, (kind, "", b"", x)))
        elif kind == "options":
            out.append((_run_file, ("options", "opt.toml", x[1], OPTION_ARGS[x[0]])))
        elif kind == "paths":
            out.append((_run_path, x))
        elif kind == "calibrate":
            out.append((_run_surface, (kind, "h.csv", x[0], ["calibrate", "h.csv", "--no-profile", "--out", "m.toml"],
                                       x[1])))
        elif kind == "calibrate-options":
            from test_fuzz_surfaces import valid_csv

            out.append((_run_surface, (kind, "h.csv", valid_csv(), x[0], x[1])))
        elif kind == "barhinge":
            out.append((_run_surface, (kind, "b.toml", x[0].encode(), x[1], None)))
        else:
            out.append((_run_planted, x))

    draw()
    return out


def _call(job):
    fn, args, deadline = job
    if deadline is not None and time.time() > deadline:
        return []  # past --max-wall: not run, not counted
    return fn(*args)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--kind", default="all")
    ap.add_argument("--cases", type=int, default=10_000)
    ap.add_argument("--seed-base", type=int, default=7_000_000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--keep", type=Path, help="directory for the failing inputs")
    ap.add_argument("--limit", type=int, help="run only the first N cases drawn (a partial campaign)")
    ap.add_argument("--max-wall", type=float, help="draw no new case after this many seconds")
    a = ap.parse_args()
    kinds = KINDS if a.kind == "all" else NEW_KINDS if a.kind == "new" else tuple(a.kind.split(","))
    per = max(1, a.cases // len(kinds))
    by_kind = [_jobs(k, per, a.seed_base) for k in kinds]
    if a.limit:  # evenly over the kinds: every kind's first cases
        by_kind = [js[:a.limit // len(kinds)] for js in by_kind]
    # interleaved over the kinds, so that a run stopped by --max-wall has run every kind
    deadline = time.time() + a.max_wall if a.max_wall else None
    jobs = [(*js[i], deadline) for i in range(max(map(len, by_kind))) for js in by_kind if i < len(js)]
    counts: dict[str, Counter] = {}
    peaks: dict[str, float] = {}
    failures = []
    t0 = time.monotonic()
    with ProcessPoolExecutor(a.jobs, initializer=_warm) as ex:
        for i, rows in enumerate(ex.map(_call, jobs, chunksize=4), 1):
            for v in rows:
                c = counts.setdefault(v["kind"], Counter())
                c["cases"] += 1
                c[f"exit {v['code']}"] += 1
                for b in v["bad"]:
                    if not b.startswith("exit ") and b != "timeout":  # counted by its exit code, below
                        c[b] += 1
                if "timeout" in v["bad"]:  # stopped at 30 s of CPU, or at 5x that in wall time
                    c["timeout: CPU budget" if v["cpu_seconds"] > 30 else "timeout: wall, CPU under 30 s"] += 1
                if v["cpu_seconds"] > 30:
                    c["over 30 s CPU"] += 1
                if v["seconds"] > 30:
                    c["over 30 s wall (busy machine)"] += 1
                c["max_cpu_seconds"] = max(c["max_cpu_seconds"], v["cpu_seconds"])
                c["max_wall_seconds"] = max(c["max_wall_seconds"], v["seconds"])
                peaks[v["kind"]] = max(peaks.get(v["kind"], 0.0), v["peak_mib"])
                if v["bad"]:
                    failures.append(v)
                    print(f"FAILURE {json.dumps(v)[:3000]}", file=sys.stderr, flush=True)
                    if a.keep:
                        a.keep.mkdir(parents=True, exist_ok=True)
                        (a.keep / f"failure_{len(failures) - 1}.json").write_text(json.dumps(v, indent=1))
            if i % 100 == 0:
                print(f"{i}/{len(jobs)} after {time.monotonic() - t0:.0f} s: "
                      f"{json.dumps({k: dict(v) for k, v in counts.items()})}", file=sys.stderr, flush=True)
    report = {"cases": len(jobs), "kinds": list(kinds), "wall_s": round(time.monotonic() - t0),
              "counts": {k: dict(v) for k, v in counts.items()}, "peak_mib": peaks, "failures": failures[:50]}
    print(json.dumps({k: v for k, v in report.items() if k != "failures"}, indent=1))
    print(json.dumps([{k: f[k] for k in ("kind", "bad", "err")} for f in failures[:10]], indent=1))
    if a.json:
        a.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
