"""Fuzz: mutated templates through ``check --json`` and ``export`` (the exit-code contract).

Each case runs in a forked child (so a hang can be stopped) and must: exit 0, 1 or 2; never
print a traceback; print one JSON object on stdout for 0/1 (check); print exactly one line
on stderr for 2; write nothing into ``--out`` on 2; finish within the per-case budget.

``FOLDPRINT_FUZZ_CASES`` (default 200) sets the number of hypothesis examples.
``benchmarks/fuzz_inputs.py`` runs a fresh, larger campaign with the same mutator.
"""

from __future__ import annotations

import io
import json
import math
import os
import random
import signal
import sys
import time
import tomllib
import traceback
from pathlib import Path

import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

import foldprint.checks.rules  # noqa: E402,F401  (imported once: every forked case starts warm)
import foldprint.cli.fold_cmds, foldprint.cli.output_cmds  # noqa: E401,E402,F401  (the commands it runs)
import foldprint.apps.pipeline  # noqa: E402,F401

ROOT = Path(__file__).resolve().parents[1]
TEMPLATES = sorted((ROOT / "templates").glob("*.toml"))
BUDGET_S = 30.0  # CPU seconds of one run (wall time on a shared 2-core machine is not a measure)
WALL_FACTOR = 5  # a run is also stopped after 5x the budget in wall time (a hang that sleeps)
FOLD_BASE = {"file_spec": 1.2, "vertices_coords": [[0, 0], [10, 0], [10, 6], [0, 6], [20, 0], [20, 6]],
             "faces_vertices": [[0, 1, 2, 3], [1, 4, 5, 2]], "edges_vertices": [[1, 2]],
             "edges_assignment": ["V"], "edges_foldAngle": [90], "faces_foldprint:material": ["VeroWhite", None],
             "edges_foldprint:radius_mm": [4.0], "faces_foldprint:holes": [None, [[[12, 2], [16, 2], [16, 4]]]]}

BAD_VALUES = [float("nan"), float("inf"), -float("inf"), 1e308, 1e-300, 1e15, 1e6, 0, -1, 10 ** 40, "ab", "5",
              True, False, [], {}, [1, 2], {"a": 1}, 5, -1e-9, 0.5, "H-1", "VeroWhite", [[0, 0], [1, 0]]]


def _paths(obj, prefix=()):
    """Every (path, value) in a nested dict/list."""
    out = [(prefix, obj)]
    if isinstance(obj, dict):
        for k, v in obj.items():
            out += _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj[:12]):
            out += _paths(v, prefix + (i,))
    return out


def _set(obj, path, value, delete=False):
    for k in path[:-1]:
        obj = obj[k]
    if delete:
        del obj[path[-1]]
    else:
        obj[path[-1]] = value


def _deep(n, kind):
    return ("[" * n + "]" * n) if kind == 0 else ('{"a":' * n + "1" + "}" * n)


def mutate(rng: random.Random) -> tuple[str, bytes]:
    """One mutated design file: (file name, bytes)."""
    fold = rng.random() < 0.2
    if fold:
        data = json.loads(json.dumps(FOLD_BASE))
        name = "case.fold"
    else:
        data = tomllib.loads(rng.choice(TEMPLATES).read_text())
        name = "case.toml"
    kind = rng.random()
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        try:
            paths = [pv for pv in _paths(data) if pv[0]]
            path, value = rng.choice(paths)
            r = rng.random()
            if r < 0.15 and isinstance(value, (int, float)) and not isinstance(value, bool):
                _set(data, path, value * rng.uniform(0.7, 1.5))  # a plausible edit, often valid
            elif r < 0.2:
                _set(data, path, None, delete=True)
            elif r < 0.65:
                _set(data, path, rng.choice(BAD_VALUES))
            elif r < 0.8 and isinstance(value, (int, float)) and not isinstance(value, bool):
                _set(data, path, value * rng.choice([1e-7, 1e-3, -1, 3, 1e3, 1e6, 1e12]))
            elif r < 0.9 and isinstance(value, list) and value:
                _set(data, path, value + [rng.choice(value)] * rng.choice([1, 5, 50]))
            elif isinstance(data.get("strip"), dict) and r < 0.95:  # a huge strip
                n = rng.choice([1, 2, 50, 300, 3000])
                data["strip"] = {"lengths_mm": [rng.choice([4, 10, 30])] * n, "angles_deg": [rng.choice([20, 90])] * (n - 1),
                                 "materials": ["H-1"] * (n - 1)}
            else:
                _set(data, path, rng.choice(BAD_VALUES))
        except (KeyError, IndexError, TypeError):
            continue  # an earlier mutation removed this path
    if fold:
        text = json.dumps(data)
    else:
        def clean(o):
            if isinstance(o, dict):
                return {str(k): clean(v) for k, v in o.items() if v is not None}
            if isinstance(o, list):
                return [clean(v) for v in o if v is not None]
            return o
        try:
            text = tomli_w.dumps(clean(data))
        except (TypeError, ValueError):
            text = "schema = 1\nname = 'x'\n"
    raw = text.encode("utf-8")
    if kind < 0.05:
        raw = raw[:rng.randrange(len(raw) + 1)]
    elif kind < 0.08:
        raw = bytes(rng.randrange(256) for _ in range(rng.choice([10, 1000])))
    elif kind < 0.11:
        raw = (text + ("\nx = " if not fold else "") + _deep(rng.choice([40, 1000, 5000]), 0)).encode() \
            if not fold else ('{"a": ' + _deep(rng.choice([40, 1000, 5000]), rng.randrange(2)) + "}").encode()
    elif kind < 0.14 and not fold:
        raw = text.replace('name = "', 'name = "' + "n" * rng.choice([90, 300, 5000]), 1).encode()
    return name, raw


def run_case(args: list[str], cwd: Path, budget: float = BUDGET_S) -> dict:
    """Run ``foldprint <args>`` in a forked child; exit code, output, time, timeout flag."""
    out_f, err_f = cwd / ".stdout", cwd / ".stderr"
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:  # child
        code = 70
        try:
            # the run's own time budget (guards.py) below the harness's: a run the guards
            # cannot bound ahead (the 3D narrow phase) must refuse (exit 2) before the kill
            os.environ["FOLDPRINT_TIME_BUDGET"] = str(budget / 2)
            os.chdir(cwd)
            fo, fe = os.open(out_f, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), os.open(err_f, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
            os.dup2(fo, 1)
            os.dup2(fe, 2)
            sys.stdout = io.TextIOWrapper(os.fdopen(1, "wb", closefd=False), write_through=True)
            sys.stderr = io.TextIOWrapper(os.fdopen(2, "wb", closefd=False), write_through=True)
            from foldprint.cli.commands import main

            code = main(args)
        except BaseException:
            traceback.print_exc()
            code = 70
        finally:
            try:
                sys.stdout.flush()
                sys.stderr.flush()
            finally:
                os._exit(code)
    timed_out = False
    clk = os.sysconf("SC_CLK_TCK")
    cpu, rss = 0.0, 0.0
    while True:
        done, status, usage = os.wait4(pid, os.WNOHANG)
        if done:
            cpu, rss = usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024  # KiB on Linux -> MiB
            break
        try:  # the child's own CPU time (utime + stime): the budget, robust to a busy machine
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            cpu = (int(fields[11]) + int(fields[12])) / clk
        except (OSError, IndexError, ValueError):
            pass
        if cpu > budget or time.monotonic() - t0 > WALL_FACTOR * budget:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            timed_out, status = True, 9
            break
        time.sleep(0.02)
    code = os.waitstatus_to_exitcode(status) if not timed_out else None
    return {"code": code, "out": out_f.read_text(errors="replace") if out_f.exists() else "",
            "err": err_f.read_text(errors="replace") if err_f.exists() else "",
            "seconds": time.monotonic() - t0, "cpu_seconds": cpu, "timeout": timed_out, "peak_mib": rss}


def classify(res: dict, command: str, out_dir: Path) -> list[str]:
    """The contract violations of one run (empty: fine)."""
    from fuzz_gen import contract_violations

    return contract_violations(res, wrote_on_exit_2=out_dir.exists(), json_stdout=command == "check")


def one(seed: int, tmp: Path, commands=("check", "export")) -> dict:
    rng = random.Random(seed)
    name, raw = mutate(rng)
    case = tmp / f"c{seed}"
    case.mkdir()
    (case / name).write_bytes(raw)
    result = {}
    for cmd in commands:
        out_dir = case / f"out_{cmd}"
        # check without its Monte-Carlo: the samples re-run the same validated pipeline with
        # scattered recovery curves, so they add time, not input handling
        args = [cmd, name, "--json"] + (["--out", out_dir.name, "--format", "3mf,stl"] if cmd == "export"
                                        else ["--samples", "0"])
        res = run_case(args, case)
        result[cmd] = dict(res, bad=classify(res, cmd, out_dir))
    return result


N_CASES = int(os.environ.get("FOLDPRINT_FUZZ_CASES", "200"))


@settings(max_examples=N_CASES, deadline=None, derandomize=True, database=None,
          suppress_health_check=list(HealthCheck))
@given(seed=hs.integers(0, 2 ** 32 - 1))
def test_mutated_designs_keep_the_contract(tmp_path_factory, seed):
    tmp = tmp_path_factory.mktemp("fuzz")
    res = one(seed, tmp)
    for cmd, r in res.items():
        assert not r["bad"], (seed, cmd, r["bad"], r["err"][-2000:])


def test_runner_detects_violations(tmp_path):
    """The harness itself can fail: a traceback and a timeout are caught."""
    res = run_case(["check", "does-not-exist.toml", "--json"], tmp_path)
    assert res["code"] == 2 and classify(res, "check", tmp_path / "nope") == []
    fake = {"code": 1, "out": "not json", "err": "Traceback (most recent call last)\n", "seconds": 0.1,
            "timeout": False}
    assert set(classify(fake, "check", tmp_path / "nope")) == {"traceback", "no JSON on stdout"}
    assert math.isfinite(run_case(["templates", "--json"], tmp_path)["seconds"])
