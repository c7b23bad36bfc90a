"""Mutation score of the core modules: each module mutated (mutmut 3) against the test
files that cover it, the score and the surviving mutants written for docs/testing.md.

    python benchmarks/mutation.py [--modules recovery,kinematics ...] [--all] [--json]
                                  [--workdir DIR] [--max-children 1] [--no-write]

``MODULES`` below is the one map module -> tests. A run copies the package and the tests
to ``--workdir/<module>`` (the work tree is never touched), lets mutmut mutate that one
module and run, for each mutant, the mapped tests that called the mutated function (its
per-function selection, one forked process per mutant under a CPU limit of
``timeout_multiplier`` x the tests' clean time), then re-runs every mutant that survived
that selection against *all* the module's mapped tests in a fresh interpreter
(``MUTANT_UNDER_TEST`` set, a wall-clock timeout): mutmut's selection comes from one
traced run in which a cached result (``lru_cache``, a module-scoped fixture) is computed
by the first test only, so a survivor of the selection is not yet a survivor. Only what
survives the whole map is listed.

Two things mutmut 3.8 does not do are done here, in the scratch copy only:

* mutmut skips every decorated function (``@property``, ``@lru_cache``, ``@scoped``); the
  copy lifts those decorators below the module (``f = lru_cache(maxsize=8)(f)``, blank
  lines where they stood, so line numbers hold), unless module-level code uses the
  function at import;
* mutants are reported as ``file:line`` of the source with the changed line(s), read by
  diffing each mutant's function against mutmut's copy of the original.

Scores: ``killed`` counts mutants a test failed on (a timeout counts as killed: the
mutant hung the tests); ``score = killed / (mutants - equivalent)``, where the equivalent
mutants are those listed with their reasons in ``docs/data/mutation_equivalent.toml``
(matched by module, function and the mutated line). Results go to
``docs/data/mutation.json`` (merged: a run of some modules replaces only their entries)
and the table between the ``mutation-table`` markers of ``docs/testing.md``.

Cost: CPU seconds (user + sys of every child process, ``RUSAGE_CHILDREN``) of mutmut's
run and of the confirmation pass, per module. Run it in the background, one module at a
time (``nice -n 10``); the default modules take about an hour of CPU.
"""

from __future__ import annotations

import argparse
import ast
import difflib
import json
import os
import re
import resource
import shutil
import subprocess
import sys
import time
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA_JSON = ROOT / "docs" / "data" / "mutation.json"
EQUIVALENT_TOML = ROOT / "docs" / "data" / "mutation_equivalent.toml"
TESTING_MD = ROOT / "docs" / "testing.md"
TABLE_BEGIN, TABLE_END = "<!-- mutation-table:begin -->", "<!-- mutation-table:end -->"
MUTMUT_VERSION = "3.8.1"

# module -> (source candidates: the first that exists, the test files that cover it)
MODULES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "recovery": (("foldprint/physics/recovery.py",),
                 ("tests/test_recovery.py", "tests/test_recovery_batch.py", "tests/test_materials.py",
                  "tests/test_grading.py")),
    "recovery_batch": (("foldprint/physics/recovery_batch.py",),
                       ("tests/test_recovery_batch.py", "tests/test_grading.py")),
    "kinematics": (("foldprint/physics/kinematics.py",),
                   ("tests/test_simulation.py", "tests/test_loops.py", "tests/test_collision_scale.py")),
    "swept3d": (("foldprint/collision/swept3d.py",),
                ("tests/test_collision_scale.py", "tests/test_clearance_reference.py",
                 "tests/test_simulation.py")),
    "broadphase": (("foldprint/collision/broadphase.py",),
                   ("tests/test_collision_scale.py", "tests/test_clearance_reference.py",
                    "tests/test_simulation.py")),
    "clearance": (("foldprint/collision/clearance.py",),
                  ("tests/test_clearance_reference.py", "tests/test_simulation.py")),
    "threemf": (("foldprint/exchange/threemf.py",), ("tests/test_export.py", "tests/test_printfiles.py")),
    "voxels": (("foldprint/exchange/voxels.py",), ("tests/test_voxels.py",)),
    "voxel_pixels": (("foldprint/exchange/voxel_pixels.py",), ("tests/test_voxels.py",)),
    # rewritten on other branches: configured, run with --all or --modules
    "robust": (("foldprint/simulation/robust.py",),
               ("tests/test_jam_reference.py", "tests/test_robust.py", "tests/test_scatter.py")),
    "verdict": (("foldprint/simulation/verdict.py",),
                ("tests/test_jam_reference.py", "tests/test_robust.py")),
    "files": (("foldprint/core/files.py", "foldprint/exchange/files.py"),
              ("tests/test_export_publish.py", "tests/test_export_kill.py", "tests/test_export.py")),
}
DEFAULT_MODULES = ("recovery", "recovery_batch", "kinematics", "swept3d", "broadphase", "clearance",
                   "threemf", "voxels", "voxel_pixels")

# mutmut's per-mutant CPU limit is (selected tests' clean time + constant) x multiplier x 2
TIMEOUT_MULTIPLIER = 10.0  # our choice: a mutant 10x slower than the clean tests has hung
TIMEOUT_CONSTANT_S = 5.0  # our choice: pytest start-up under load
CONFIRM_TIMEOUT_FACTOR = 5.0  # our choice: a confirmation run 5x the clean map's wall time has hung
KILLED = {1: "killed", 3: "killed"}
ALSO_COPY = ("templates", "examples", "docs")  # what the tests read beside the package
MUTANT_NAME = re.compile(r"^(x.*)__mutmut_(orig|\d+)$")


def source_of(name: str) -> Path | None:
    for rel in MODULES[name][0]:
        if (ROOT / rel).is_file():
            return Path(rel)
    return None


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
    entry = {"source": str(src), "tests": list(tests), "decorators_lifted": lifted,
             "decorated_not_mutated": kept}
    (work / "prepared.json").write_text(json.dumps(entry))
    return entry


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


def run_mutmut(work: Path, max_children: int) -> tuple[float, float]:
    """mutmut run in ``work`` (once: a resumed run reads what it cost); returns (CPU s, wall s)."""
    done = work / "mutmut.done"
    if done.is_file():
        return tuple(json.loads(done.read_text()))
    cpu0, t0 = _children_cpu(), time.monotonic()
    exe = [sys.executable, "-m", "mutmut", "run", "--max-children", str(max_children)]
    with open(work / "mutmut.log", "w") as log:
        proc = subprocess.run(["nice", "-n", "10", *exe], cwd=work, stdout=log, stderr=subprocess.STDOUT,
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
    cmd = ["nice", "-n", "10", sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider",
           "-p", "no:randomly", *tests]
    t0 = time.monotonic()
    try:
        proc = subprocess.run(cmd, cwd=work / "mutants", env=env, timeout=timeout,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    except subprocess.TimeoutExpired:
        return None, time.monotonic() - t0
    return proc.returncode, time.monotonic() - t0


def exit_codes(work: Path, src: str) -> dict[str, int | None]:
    meta = json.loads((work / "mutants" / f"{src}.meta").read_text())
    return meta["exit_code_by_key"]


def confirm(work: Path, tests, candidates: list[str]) -> tuple[dict[str, str], float, float]:
    """Re-run each of ``candidates`` against the whole map; returns ({mutant: status},
    CPU s, the clean map's wall s). Progress is kept in ``confirm.json``: a resumed run
    goes on where the last one stopped."""
    log = work / "confirm.json"
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
    return {n.name: ast.get_source_segment(text, n) for n in ast.walk(ast.parse(text))
            if isinstance(n, ast.FunctionDef) and MUTANT_NAME.match(n.name)}


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

def load_equivalent() -> list[dict]:
    """The mutants explained as equivalent: [[equivalent]] module, function, to (the
    mutated line as listed), reason."""
    if not EQUIVALENT_TOML.is_file():
        return []
    return tomllib.loads(EQUIVALENT_TOML.read_text()).get("equivalent", [])


def _equivalent_reason(name: str, m: dict, equivalent: list[dict]) -> str | None:
    for e in equivalent:
        if e["module"] == name and e["function"] == m["function"] and e["to"] == m["to"]:
            return e["reason"]
    return None


def _statuses(work: Path, src: Path, tests, max_children: int, report_only: bool) -> tuple[dict, dict]:
    """{mutant: killed | timeout | survived | unconfirmed | not run} and the run's costs;
    ``report_only`` runs nothing and reads what the scratch copy holds."""
    done = work / "mutmut.done"
    if report_only:
        mutmut_cost = tuple(json.loads(done.read_text())) if done.is_file() else (None, None)
    else:
        mutmut_cost = run_mutmut(work, max_children)
    codes = exit_codes(work, str(src))
    status = {k: ("not run" if c is None else "killed" if c in KILLED
                  else "timeout" if c in (24, -24, 36, 152, 255) else "unconfirmed")
              for k, c in codes.items()}
    candidates = [k for k, s in status.items() if s == "unconfirmed"]
    if report_only:
        log = work / "confirm.json"
        state = json.loads(log.read_text()) if log.is_file() else {"status": {}, "cpu_s": None}
        confirmed = {k: v for k, v in state["status"].items() if k in status}
        confirm_cost = (state["cpu_s"], state.get("clean_wall_s"))
    else:
        confirmed, *confirm_cost = confirm(work, tests, candidates)
    status.update(confirmed)
    costs = {"cpu_s": {"mutmut": mutmut_cost[0], "confirmation": confirm_cost[0]},
             "wall_s": {"mutmut": mutmut_cost[1], "clean_map": confirm_cost[1]},
             "killed_by_selection": sum(c in KILLED for c in codes.values()),
             "killed_on_confirmation": sum(s in ("killed", "timeout") for s in confirmed.values())}
    return status, costs


def evaluate(name: str, workdir: Path, max_children: int, resume: bool = False,
             report_only: bool = False) -> dict:
    src = source_of(name)
    work = workdir / name
    if src is None or (report_only and not (work / "prepared.json").is_file()):
        return {"skipped": f"none of {', '.join(MODULES[name][0])} exists" if src is None else "not run"}
    entry = prepare(name, work, resume or report_only)
    status, costs = _statuses(work, src, entry["tests"], max_children, report_only)
    texts = _function_texts(work / "mutants" / src)
    defs = _def_lines(ROOT / src)
    equivalent = load_equivalent()
    survivors = []
    for key in sorted(k for k, s in status.items() if s in ("survived", "unconfirmed")):
        m = locate(work, str(src), key, texts, defs)
        m["equivalent"] = _equivalent_reason(name, m, equivalent)
        m["confirmed"] = status[key] == "survived"
        survivors.append(m)
    survivors.sort(key=lambda m: (m["line"], m["id"]))
    n = sum(s != "not run" for s in status.values())
    killed = sum(s in ("killed", "timeout") for s in status.values())
    n_eq = sum(m["equivalent"] is not None for m in survivors)
    entry.update({
        "mutants": n, "not_run": len(status) - n, "killed": killed,
        "timeouts": sum(s == "timeout" for s in status.values()),
        "survived": n - killed, "unconfirmed": sum(s == "unconfirmed" for s in status.values()),
        "equivalent": n_eq,
        "score": round(killed / max(n - n_eq, 1), 4), "raw_score": round(killed / max(n, 1), 4),
        **costs, "survivors": survivors,
    })
    return entry


# ---- output -------------------------------------------------------------------------------

def table(modules: dict) -> str:
    rows = ["| module | tests | mutants | killed | survived | equivalent | score | CPU-s |",
            "|---|---|---:|---:|---:|---:|---:|---:|"]
    for name, e in modules.items():
        if "mutants" not in e:
            continue
        tests = ", ".join(Path(t).stem.removeprefix("test_") for t in e["tests"])
        cpu = sum(v or 0.0 for v in e["cpu_s"].values())
        partial = " (partial)" if e["not_run"] or e["unconfirmed"] else ""
        rows.append(f"| `{e['source']}` | {tests} | {e['mutants']} | {e['killed']} | {e['survived']} "
                    f"| {e['equivalent']} | {100 * e['score']:.1f} %{partial} | {cpu:.0f} |")
    return "\n".join(rows)


def survivors_md(modules: dict) -> str:
    out = []
    for name, e in modules.items():
        for m in e.get("survivors", []):
            why = (f"equivalent: {m['equivalent']}" if m["equivalent"]
                   else "**not yet killed**" if m["confirmed"] else "survived mutmut's selection, not yet confirmed")
            out.append(f"- `{m['where']}` `{m['function']}`: `{m['from']}` -> `{m['to']}` ({why})")
    return "\n".join(out) or "- none"


def write_docs(modules: dict) -> None:
    if not TESTING_MD.is_file():
        return
    text = TESTING_MD.read_text()
    if TABLE_BEGIN not in text or TABLE_END not in text:
        return
    head, rest = text.split(TABLE_BEGIN, 1)
    tail = rest.split(TABLE_END, 1)[1]
    block = f"{TABLE_BEGIN}\n{table(modules)}\n\nSurviving mutants:\n\n{survivors_md(modules)}\n{TABLE_END}"
    TESTING_MD.write_text(head + block + tail)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modules", help=f"comma-separated, of {', '.join(MODULES)}")
    ap.add_argument("--all", action="store_true", help="every configured module")
    ap.add_argument("--json", action="store_true", help="print the results as one JSON object")
    ap.add_argument("--workdir", type=Path, default=Path(os.environ.get("TMPDIR", "/tmp")) / "foldprint-mutation")
    ap.add_argument("--max-children", type=int, default=1, help="mutants run at once (default 1)")
    ap.add_argument("--no-write", action="store_true", help="leave docs/ as it is")
    ap.add_argument("--report-only", action="store_true",
                    help="run nothing: report what the scratch copies in --workdir hold (a campaign under way)")
    ap.add_argument("--resume", action="store_true",
                    help="go on from the scratch copies an interrupted run left in --workdir")
    args = ap.parse_args()
    names = list(MODULES) if args.all else (args.modules.split(",") if args.modules else list(DEFAULT_MODULES))
    unknown = [n for n in names if n not in MODULES]
    if unknown:
        ap.error(f"unknown module(s) {', '.join(unknown)}; choose from {', '.join(MODULES)}")
    data = json.loads(DATA_JSON.read_text()) if DATA_JSON.is_file() else {}
    data.update({"tool": f"mutmut {MUTMUT_VERSION}", "script": "benchmarks/mutation.py"})
    modules = data.setdefault("modules", {})
    for name in names:
        print(f"mutating {name} ...", file=sys.stderr, flush=True)
        modules[name] = evaluate(name, args.workdir, args.max_children, args.resume, args.report_only)
        e = modules[name]
        print(f"  {name}: " + (e.get("skipped") or f"{e['killed']}/{e['mutants']} killed, score "
                                f"{100 * e['score']:.1f} %, {sum(v or 0.0 for v in e['cpu_s'].values()):.0f} CPU-s"),
              file=sys.stderr, flush=True)
        if not args.no_write:  # after each module: a long campaign keeps what it has done
            data["modules"] = {k: modules[k] for k in MODULES if k in modules}
            DATA_JSON.write_text(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
            write_docs(data["modules"])
    if args.json:
        print(json.dumps(data, ensure_ascii=False))
    else:
        print(table(data["modules"]))


if __name__ == "__main__":
    main()
