"""Mutation score of the core modules: each module mutated (mutmut 3) against the test
files that cover it, the score and the surviving mutants written for docs/testing.md.

    python benchmarks/mutation.py [--modules recovery,kinematics ...] [--sample N --seed S]
                                  [--recheck] [--report-only] [--json] [--workdir DIR]

``MODULES`` below is the one map module -> tests. A run copies the package and the tests
to ``--workdir/<module>`` (the work tree is never touched), lets mutmut write the module's
mutants there and run, for each mutant, the mapped tests that called the mutated function
(its per-function selection, one forked process per mutant under a CPU limit of
``timeout_multiplier`` x the tests' clean time), then re-runs every mutant that survived
that selection against *all* the module's mapped tests in a fresh interpreter
(``MUTANT_UNDER_TEST`` set, a wall-clock timeout): mutmut's selection comes from one
traced run in which a cached result (``lru_cache``, a module-scoped fixture) is computed
by the first test only, so a survivor of the selection is not yet a survivor. Only what
survives the whole map is listed.

Which mutants run:

* every mutant of the module (the default): the score is a census, exact for the module;
* ``--sample N --seed S``: a uniform random sample of N of the module's mutants, drawn
  without replacement by ``random.Random(f"{S}:{module}")`` from the sorted mutant names
  (listed in the JSON with their statuses); the score is an estimate with a 95 %
  Clopper-Pearson interval (``mutation_report.py`` says why that one);
* ``--recheck``: only the recorded survivors of the modules' last runs, against the
  current tests (after a test was written to kill one); the source must be the one the
  mutants were made from (its sha256 is recorded). The first run's statuses are kept, so
  the report tells the estimate for mutants no test was written for ("as sampled") from
  the score after the new tests.

Two things mutmut 3.8 does not do are done here, in the scratch copy only:

* mutmut skips every decorated function (``@property``, ``@lru_cache``, ``@scoped``); the
  copy lifts those decorators below the module (``f = lru_cache(maxsize=8)(f)``, blank
  lines where they stood, so line numbers hold), unless module-level code uses the
  function at import;
* mutants are reported as ``file:line`` of the source with the changed line(s), read by
  diffing each mutant's function against mutmut's copy of the original.

Scores: ``killed`` counts mutants a test failed on (a timeout counts as killed: the
mutant hung the tests); ``score = killed / (mutants run - equivalent)``, where the
equivalent mutants are those listed with their reasons in
``docs/data/mutation_equivalent.toml`` (matched by module, function and the mutated line).
Results go to ``docs/data/mutation.json`` (merged: a run of some modules replaces only
their entries) and the table between the ``mutation-table`` markers of
``docs/testing.md``; ``--report-only`` rebuilds that table from the JSON and the
equivalent list without running anything.

Cost: CPU seconds (user + sys of every child process, ``RUSAGE_CHILDREN``) of mutmut's
run, of the confirmation pass and of rechecks, per module. Every child runs under
``nice -n 19``; run the script in the background, one module at a time.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import hashlib
import json
import os
import random
import re
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path

from mutation_report import (KILLED_STATUSES, SURVIVOR_STATUSES, load_data, load_equivalent, rescore,
                             save_data, table, write_docs)

ROOT = Path(__file__).resolve().parent.parent
MUTMUT_VERSION = "3.8.1"

# module -> (source, the test files that cover it)
MODULES: dict[str, tuple[str, tuple[str, ...]]] = {
    "recovery": ("foldprint/physics/recovery/curve.py",
                 ("tests/test_recovery.py", "tests/test_recovery_batch.py", "tests/test_materials.py",
                  "tests/test_grading.py")),
    "recovery_batch": ("foldprint/physics/recovery/batch.py",
                       ("tests/test_recovery_batch.py", "tests/test_grading.py")),
    "kinematics": ("foldprint/physics/kinematics.py",
                   ("tests/test_simulation.py", "tests/test_loops.py", "tests/test_collision_scale.py",
                    "tests/test_kinematics_tree.py")),
    "swept3d": ("foldprint/collision/swept3d.py",
                ("tests/test_collision_scale.py", "tests/test_clearance_reference.py", "tests/test_simulation.py")),
    "broadphase": ("foldprint/collision/broadphase.py",
                   ("tests/test_collision_scale.py", "tests/test_clearance_reference.py",
                    "tests/test_simulation.py")),
    "clearance": ("foldprint/collision/clearance.py",
                  ("tests/test_clearance_reference.py", "tests/test_simulation.py")),
    "robust": ("foldprint/simulation/robust.py",
               ("tests/test_jam_reference.py", "tests/test_robust.py", "tests/test_scatter.py",
                "tests/test_recovery_batch.py")),
    "verdict": ("foldprint/simulation/jamtest/verdict.py", ("tests/test_jam_reference.py", "tests/test_verdict.py")),
    "sequential": ("foldprint/simulation/jamtest/scales.py",
                   ("tests/test_batch.py", "tests/test_verdict.py", "tests/test_evaluation.py",
                    "tests/test_flip_drivers.py", "tests/test_progress.py")),
    "threemf": ("foldprint/exchange/threemf.py", ("tests/test_export.py", "tests/test_printfiles.py", "tests/test_voxels.py")),
    "voxels": ("foldprint/exchange/voxels.py", ("tests/test_voxels.py",)),
    "voxel_pixels": ("foldprint/exchange/voxel_pixels.py", ("tests/test_voxels.py",)),
    "files": ("foldprint/exchange/fileset.py",
              ("tests/test_export_publish.py", "tests/test_export_kill.py", "tests/test_export.py")),
    "core_files": ("foldprint/core/files.py", ("tests/test_export_publish.py", "tests/test_export_kill.py")),
}

NICE = 19  # our choice: the machine is shared; mutation runs yield to everything else
# mutmut's per-mutant CPU limit is (selected tests' clean time + constant) x multiplier x 2
TIMEOUT_MULTIPLIER = 10.0  # our choice: a mutant 10x slower than the clean tests has hung
TIMEOUT_CONSTANT_S = 5.0  # our choice: pytest start-up under load
CONFIRM_TIMEOUT_FACTOR = 5.0  # our choice: a confirmation run 5x the clean map's wall time has hung
# pytest's "tests failed" and "internal error", and a test process killed by SIGSEGV, SIGABRT or
# SIGBUS: the mutant crashed the interpreter (e.g. a wrong face count handed to FCL)
KILLED = {1: "killed", 3: "killed", -11: "killed", -6: "killed", -7: "killed"}
TIMEOUT_CODES = (24, -24, 36, 152, 255)  # mutmut's codes for a mutant stopped by its CPU limit
ALSO_COPY = ("templates", "examples", "docs")  # what the tests read beside the package
MUTANT_NAME = re.compile(r"^(x.*)__mutmut_(orig|\d+)$")
# mutmut 3.8's mutant generation alone, run in the scratch copy (the sample is drawn from
# its names before any test runs)
GENERATE = """
import os
from mutmut.__main__ import (copy_also_copy_files, copy_src_dir, create_mutants, set_mutant_under_test,
                             setup_source_paths, store_lines_covered_by_tests)
os.makedirs("mutants", exist_ok=True)
set_mutant_under_test("mutant_generation")
copy_src_dir(); copy_also_copy_files(); setup_source_paths(); store_lines_covered_by_tests(); create_mutants(1)
"""


def source_of(name: str) -> Path:
    return Path(MODULES[name][0])


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def draw_sample(name: str, keys, n: int, seed: int) -> list[str]:
    """A uniform random sample of ``n`` of ``keys`` without replacement, the same for the
    same seed, module and mutants (all of them when ``n`` is at least their number)."""
    keys = sorted(keys)
    return sorted(random.Random(f"{seed}:{name}").sample(keys, min(n, len(keys))))


# ---- the scratch copy ------------------------------------------------------------------

def _decorated(tree: ast.Module):
    """(owner class or None, function node) of each decorated function mutmut would skip."""
    for node in tree.body:
        owners = [(None, node)] if isinstance(node, ast.FunctionDef) else []
        if isinstance(node, ast.ClassDef):
            owners = [(node.name, sub) for sub in node.body if isinstance(sub, ast.FunctionDef)]
        for owner, fn in owners:
            names = [ast.unparse(d) for d in fn.decorator_list]
            if names and not (len(names) == 1 and names[0] in ("staticmethod", "classmethod")):
                yield owner, fn


def _used_at_import(tree: ast.Module, name: str, owner: str | None) -> bool:
    """Whether code that runs at import (outside function bodies) names ``name``."""
    def visit(node) -> bool:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            return any(visit(d) for d in getattr(node, "decorator_list", []))
        if isinstance(node, ast.Name) and node.id == name:
            return True
        if isinstance(node, ast.Attribute) and node.attr == name:
            return True
        return any(visit(child) for child in ast.iter_child_nodes(node))
    return any(visit(stmt) for stmt in tree.body)


def lift_decorators(path: Path) -> tuple[list[str], list[str]]:
    """Move the decorators of ``path``'s functions below the module so mutmut mutates the
    functions; returns (lifted, left alone) qualified names."""
    text = path.read_text()
    tree = ast.parse(text)
    lines = text.splitlines(keepends=True)
    tail, lifted, kept = [], [], []
    for owner, fn in _decorated(tree):
        qual = f"{owner}.{fn.name}" if owner else fn.name
        if _used_at_import(tree, fn.name, owner):
            kept.append(qual)
            continue
        target = f"{owner}.__dict__[{fn.name!r}]" if owner else fn.name
        expr = target
        for dec in reversed(fn.decorator_list):
            expr = f"({ast.get_source_segment(text, dec)})({expr})"
            for i in range(dec.lineno - 1, dec.end_lineno):
                lines[i] = "\n"
        tail.append(f"{owner}.{fn.name} = {expr}\n" if owner else f"{fn.name} = {expr}\n")
        lifted.append(qual)
    if tail:
        lines.append("\n\n# decorators lifted by benchmarks/mutation.py (mutmut skips decorated functions)\n")
        lines.extend(tail)
        path.write_text("".join(lines))
    return lifted, kept


def _pytest_table() -> str:
    """The project's [tool.pytest.ini_options] table, as it stands in pyproject.toml."""
    text = (ROOT / "pyproject.toml").read_text()
    m = re.search(r"^\[tool\.pytest\.ini_options\]\n(?:(?!^\[).*\n?)*", text, re.M)
    return m.group(0) if m else ""


def prepare(name: str, work: Path, resume: bool = False) -> dict:
    """A fresh scratch project for module ``name``: the package, the tests, a pyproject
    whose [tool.mutmut] mutates that module only (``resume``: the one left by an earlier
    run, if any)."""
    src = source_of(name)
    if resume and (work / "prepared.json").is_file():
        return json.loads((work / "prepared.json").read_text())
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc", ".hypothesis")
    shutil.copytree(ROOT / "foldprint", work / "foldprint", ignore=ignore)
    for tree in ("tests", *ALSO_COPY):
        shutil.copytree(ROOT / tree, work / tree, ignore=ignore)
    lifted, kept = lift_decorators(work / src)
    tests = MODULES[name][1]
    (work / "pyproject.toml").write_text(
        _pytest_table() + "\n[tool.mutmut]\n"
        f'source_paths = ["foldprint"]\nonly_mutate = ["{src}"]\n'
        f"pytest_add_cli_args_test_selection = {json.dumps(list(tests))}\n"
        f"timeout_multiplier = {TIMEOUT_MULTIPLIER}\ntimeout_constant = {TIMEOUT_CONSTANT_S}\n"
        f"also_copy = {json.dumps(list(ALSO_COPY))}\n"
        "use_git_change_detection = false\nuse_setproctitle = false\n")
    entry = {"source": str(src), "source_sha256": sha256(ROOT / src), "tests": list(tests),
             "decorators_lifted": lifted, "decorated_not_mutated": kept}
    (work / "prepared.json").write_text(json.dumps(entry))
    return entry


def generate(work: Path) -> None:
    """mutmut's mutants of the module in ``work/mutants`` (once), no test run."""
    if (work / "generated").is_file():
        return
    proc = subprocess.run(["nice", "-n", str(NICE), sys.executable, "-c", GENERATE], cwd=work, env=_env(work),
                          capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"mutmut could not make the mutants in {work}:\n{proc.stderr[-2000:]}")
    (work / "generated").write_text("")


# ---- running ---------------------------------------------------------------------------

def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def _env(work: Path, **extra: str) -> dict:
    """The environment of a run: the mutated copy first on the path (a test's ``foldprint``
    subprocess imports it too), this interpreter's scripts on PATH."""
    path = os.pathsep.join([str(Path(sys.executable).parent), os.environ.get("PATH", "")])
    return {**os.environ, "PYTHONPATH": str(work / "mutants"), "PATH": path, "PYTHONDONTWRITEBYTECODE": "1",
            **extra}


def run_mutmut(work: Path, max_children: int, names: list[str] | None) -> tuple[float, float]:
    """mutmut run in ``work`` on ``names`` (None: every mutant), once: a resumed run reads
    what it cost; returns (CPU s, wall s)."""
    done = work / "mutmut.done"
    if done.is_file():
        return tuple(json.loads(done.read_text()))
    cpu0, t0 = _children_cpu(), time.monotonic()
    exe = [sys.executable, "-m", "mutmut", "run", "--max-children", str(max_children), *(names or [])]
    with open(work / "mutmut.log", "w") as log:
        proc = subprocess.run(["nice", "-n", str(NICE), *exe], cwd=work, stdout=log, stderr=subprocess.STDOUT,
                              env=_env(work))
    if proc.returncode != 0:
        tail = (work / "mutmut.log").read_text(errors="replace")[-2000:]
        raise SystemExit(f"mutmut failed in {work} (exit {proc.returncode}):\n{tail}")
    cost = (_children_cpu() - cpu0, time.monotonic() - t0)
    done.write_text(json.dumps(cost))
    return cost


def _pytest_map(work: Path, tests, mutant: str, timeout: float | None) -> tuple[int | None, float]:
    """All of ``tests`` against one mutant (``""``: none) in a fresh interpreter in
    mutants/; returns (exit code or None on timeout, wall s)."""
    env = _env(work, MUTANT_UNDER_TEST=mutant)
    cmd = ["nice", "-n", str(NICE), sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
           "-p", "no:randomly", *tests]
    t0 = time.monotonic()
    try:
        proc = subprocess.run(cmd, cwd=work / "mutants", env=env, timeout=timeout,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return None, time.monotonic() - t0
    return proc.returncode, time.monotonic() - t0


def exit_codes(work: Path, src: Path) -> dict[str, int | None]:
    meta = json.loads((work / "mutants" / f"{src}.meta").read_text())
    return meta["exit_code_by_key"]


def confirm(work: Path, tests, candidates: list[str], log_name: str = "confirm.json"
            ) -> tuple[dict[str, str], float, float]:
    """Re-run each of ``candidates`` (mutmut's full names) against the whole map; returns
    ({mutant: status}, CPU s, the clean map's wall s). Progress is kept in ``log_name``:
    a resumed run goes on where the last one stopped."""
    log = work / log_name
    state = json.loads(log.read_text()) if log.is_file() else {"status": {}, "cpu_s": 0.0}
    cpu0 = _children_cpu()
    if "clean_wall_s" not in state:
        rc, state["clean_wall_s"] = _pytest_map(work, tests, "", None)
        if rc != 0:
            raise SystemExit(f"the mapped tests fail without a mutant in {work}: {' '.join(tests)}")
    timeout = CONFIRM_TIMEOUT_FACTOR * state["clean_wall_s"] + 60.0
    status = state["status"]
    for name in candidates:
        if name not in status:
            rc, _ = _pytest_map(work, tests, name, timeout)
            status[name] = "timeout" if rc is None else ("killed" if rc in KILLED else "survived")
            log.write_text(json.dumps({**state, "cpu_s": state["cpu_s"] + _children_cpu() - cpu0}))
    cpu = state["cpu_s"] + _children_cpu() - cpu0
    log.write_text(json.dumps({**state, "cpu_s": cpu}))
    return {k: status[k] for k in candidates}, cpu, state["clean_wall_s"]


# ---- where a mutant is ------------------------------------------------------------------

def _function_texts(path: Path) -> dict[str, str]:
    """mutmut's copies in the mutants file: {'x_f__mutmut_3': source, ...}."""
    text = path.read_text()
    lines = text.splitlines(keepends=True)  # once: ast.get_source_segment splits the file per call
    out = {}
    for n in ast.walk(ast.parse(text)):
        if isinstance(n, ast.FunctionDef) and MUTANT_NAME.match(n.name):
            seg = lines[n.lineno - 1:n.end_lineno]
            seg[-1] = seg[-1].encode()[:n.end_col_offset].decode()  # offsets count UTF-8 bytes
            seg[0] = seg[0].encode()[n.col_offset:].decode()
            out[n.name] = "".join(seg)
    return out


def _def_lines(path: Path) -> dict[str, int]:
    """'x_f' / 'xǁClassǁmethod' -> line of its ``def`` in the source."""
    out = {}
    for node in ast.parse(path.read_text()).body:
        if isinstance(node, ast.FunctionDef):
            out[f"x_{node.name}"] = node.lineno
        elif isinstance(node, ast.ClassDef):
            for sub in node.body:
                if isinstance(sub, ast.FunctionDef):
                    out[f"xǁ{node.name}ǁ{sub.name}"] = sub.lineno
    return out


def locate(work: Path, src: str, key: str, texts: dict[str, str], defs: dict[str, int]) -> dict:
    """file:line, function and the changed line(s) of mutant ``key``."""
    short = key.rpartition(".")[2]
    base = MUTANT_NAME.match(short).group(1)
    orig = texts[f"{base}__mutmut_orig"].splitlines()
    new = texts[short].splitlines()
    new[0] = new[0].replace(short, f"{base}__mutmut_orig", 1)
    offset, minus, plus = None, [], []
    for tag, i1, i2, j1, j2 in difflib.SequenceMatcher(a=orig, b=new, autojunk=False).get_opcodes():
        if tag == "equal":
            continue
        offset = i1 if offset is None else offset
        minus += [s.strip() for s in orig[i1:i2]]
        plus += [s.strip() for s in new[j1:j2]]
    line = defs.get(base, 0) + (offset or 0)
    function = base[2:].replace("ǁ", ".").lstrip(".") if base.startswith("xǁ") else base[2:]
    return {"id": short, "where": f"{src}:{line}", "line": line, "function": function,
            "from": " / ".join(minus), "to": " / ".join(plus)}


# ---- one module ---------------------------------------------------------------------------

def _classify(codes: dict[str, int | None]) -> dict[str, str]:
    """mutmut's exit code of each mutant -> killed | timeout | unconfirmed | not run."""
    return {k: ("not run" if c is None else "killed" if c in KILLED else "timeout" if c in TIMEOUT_CODES
                else "unconfirmed") for k, c in codes.items()}


def _short(key: str) -> str:
    """'foldprint.physics.recovery.curve.x_f__mutmut_3' -> 'x_f__mutmut_3'."""
    return key.rpartition(".")[2]


def _full(src: Path, short: str) -> str:
    return f"{str(src.with_suffix('')).replace('/', '.')}.{short}"


def _survivors(work: Path, src: Path, status: dict[str, str]) -> list[dict]:
    texts = _function_texts(work / "mutants" / src)
    defs = _def_lines(ROOT / src)
    out = [locate(work, str(src), key, texts, defs) for key, s in status.items() if s in SURVIVOR_STATUSES]
    return sorted(out, key=lambda m: (m["line"], m["id"]))


def _run_key(work: Path, args) -> dict:
    """Which mutants the scratch copy runs ({"sample": N or None, "seed": S}); a resumed
    copy must be resumed with the same."""
    marker = work / "run.json"
    key = {"sample": args.sample, "seed": args.seed if args.sample else None}
    if marker.is_file():
        held = json.loads(marker.read_text())
        if args.collect:
            return held
        if held != key:
            raise SystemExit(f"{work} holds a run of {held}, not {key}: run without --resume to start afresh")
    marker.write_text(json.dumps(key))
    return key


def evaluate(name: str, work: Path, args) -> dict:
    """Run module ``name``'s mutants (all, or a sample) and confirm its survivors against
    the whole map; ``args.collect``: run nothing, read what the scratch copy holds."""
    src = source_of(name)
    if args.collect and not (work / "generated").is_file():
        return {"skipped": "not run"}
    entry = prepare(name, work, args.resume or args.collect)
    generate(work)
    run = _run_key(work, args)
    keys = list(exit_codes(work, src))
    sample = draw_sample(name, keys, run["sample"], run["seed"]) if run["sample"] else None
    done, log = work / "mutmut.done", work / "confirm.json"
    if args.collect:
        mutmut_cost = tuple(json.loads(done.read_text())) if done.is_file() else (None, None)
    else:
        mutmut_cost = run_mutmut(work, args.max_children, sample)
    codes = exit_codes(work, src)
    status = _classify({k: codes[k] for k in (sample or keys)})
    candidates = [k for k, s in status.items() if s == "unconfirmed"]
    if args.collect:
        state = json.loads(log.read_text()) if log.is_file() else {"status": {}, "cpu_s": None}
        confirmed = {k: v for k, v in state["status"].items() if k in status}
        cpu, clean = state["cpu_s"], state.get("clean_wall_s")
    else:
        confirmed, cpu, clean = confirm(work, entry["tests"], candidates)
    status.update(confirmed)
    short = {_short(k): s for k, s in status.items()}
    entry.update({
        "mode": "sample" if sample else "all", "population": len(keys),
        "sample": {"n": run["sample"], "seed": run["seed"], "draw": f"random.Random('{run['seed']}:{name}')"}
        if sample else None,
        "status": short,
        "cpu_s": {"mutmut": mutmut_cost[0], "confirmation": cpu},
        "wall_s": {"mutmut": mutmut_cost[1], "clean_map": clean},
        "killed_by_selection": sum(codes[k] in KILLED for k in status),
        "killed_on_confirmation": sum(s in KILLED_STATUSES for s in confirmed.values()),
        "survivors": _survivors(work, src, short),
    })
    return rescore(name, entry, load_equivalent())


def recheck(name: str, work: Path, entry: dict) -> dict:
    """``entry``'s survivors (not the equivalent ones) run again against the current map, in
    a fresh scratch copy of the current package and tests; the first statuses are kept."""
    src = source_of(name)
    if entry.get("source_sha256") != sha256(ROOT / src):
        raise SystemExit(f"{src} changed since its mutants were made: draw them again (--sample N --seed S)")
    entry = rescore(name, entry, load_equivalent())  # a mutant explained since is not run again
    fresh = prepare(name, work)
    generate(work)
    todo = {m["id"]: _full(src, m["id"]) for m in entry["survivors"] if m["equivalent"] is None}
    confirmed, cpu, clean = confirm(work, fresh["tests"], list(todo.values()), "recheck.json")
    entry.setdefault("first_status", dict(entry["status"]))
    for short, full in todo.items():
        entry["status"][short] = confirmed[full]
    entry["survivors"] = [m for m in entry["survivors"] if entry["status"][m["id"]] in SURVIVOR_STATUSES]
    entry["tests"] = fresh["tests"]
    entry["cpu_s"]["recheck"] = (entry["cpu_s"].get("recheck") or 0.0) + cpu
    entry["wall_s"]["clean_map"] = clean
    return rescore(name, entry, load_equivalent())


# ---- output -------------------------------------------------------------------------------

def _summary(e: dict) -> str:
    if "skipped" in e:
        return e["skipped"]
    cpu = sum(v or 0.0 for v in e["cpu_s"].values())
    ci = f" [{100 * e['interval']['low']:.1f}, {100 * e['interval']['high']:.1f}] %" if e.get("interval") else ""
    return (f"{e['killed']}/{e['mutants'] - e['equivalent']} killed, score {100 * e['score']:.1f} %{ci}, "
            f"{cpu:.0f} CPU-s")


def _arguments() -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modules", help=f"comma-separated, of {', '.join(MODULES)} (default: all)")
    ap.add_argument("--sample", type=int, metavar="N", help="run a uniform random sample of N mutants per module")
    ap.add_argument("--seed", type=int, default=1, metavar="S", help="the sample's seed (default 1)")
    ap.add_argument("--recheck", action="store_true",
                    help="run only the recorded survivors again, against the current tests")
    ap.add_argument("--report-only", action="store_true",
                    help="run nothing: rebuild docs/testing.md's table from the JSON and the equivalent list")
    ap.add_argument("--collect", action="store_true",
                    help="run nothing: record what the scratch copies in --workdir hold (a campaign under way)")
    ap.add_argument("--resume", action="store_true",
                    help="go on from the scratch copies an interrupted run left in --workdir")
    ap.add_argument("--json", action="store_true", help="print the results as one JSON object")
    ap.add_argument("--workdir", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "foldprint-mutation")
    ap.add_argument("--max-children", type=int, default=1, help="mutants run at once (default 1)")
    ap.add_argument("--no-write", action="store_true", help="leave docs/ as it is")
    args = ap.parse_args()
    if args.sample is not None and args.sample < 1:
        ap.error("--sample N needs N >= 1")
    names = args.modules.split(",") if args.modules else list(MODULES)
    unknown = [n for n in names if n not in MODULES]
    if unknown:
        ap.error(f"unknown module(s) {', '.join(unknown)}; choose from {', '.join(MODULES)}")
    args.names = [] if args.report_only else names
    return args


def _save(done: dict, equivalent: list[dict] | None = None) -> dict:
    """Merge ``done`` (this run's modules) into docs/data/mutation.json as it stands now, so
    that runs of other modules at the same time keep theirs; rewrite the doc's table.
    ``equivalent``: rescore every module with it first."""
    data = load_data()
    data.update({"tool": f"mutmut {MUTMUT_VERSION}", "script": "benchmarks/mutation.py"})
    # entries without mutant statuses are of an earlier format of this script: run again
    held = {**{k: v for k, v in data.get("modules", {}).items() if "status" in v}, **done}
    data["modules"] = {k: (rescore(k, held[k], equivalent) if equivalent is not None and "status" in held[k]
                           else held[k]) for k in MODULES if k in held}
    save_data(data)
    write_docs(data["modules"])
    return data


def main() -> None:
    args = _arguments()
    modules = {k: v for k, v in load_data().get("modules", {}).items() if "status" in v}
    done: dict = {}
    for name in args.names:
        print(f"{'rechecking' if args.recheck else 'mutating'} {name} ...", file=sys.stderr, flush=True)
        if args.recheck:
            if "status" not in modules.get(name, {}):
                print(f"  {name}: no recorded run to recheck", file=sys.stderr)
                continue
            done[name] = recheck(name, args.workdir / name, modules[name])
        else:
            done[name] = evaluate(name, args.workdir / name, args)
        print(f"  {name}: {_summary(done[name])}", file=sys.stderr, flush=True)
        if not args.no_write:  # after each module, that module only: a long campaign keeps what it has
            _save({name: done[name]})  # done, and never writes back a module another run changed since
    if args.no_write:
        data = {"modules": {k: rescore(k, v, load_equivalent()) for k, v in {**modules, **done}.items()}}
    else:
        data = _save({}, load_equivalent())
    print(json.dumps(data, ensure_ascii=False) if args.json else table(data["modules"]))


if __name__ == "__main__":
    main()
