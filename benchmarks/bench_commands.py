"""The commands a user waits for, on the compiled kernels against the numpy path, in one run.

    python benchmarks/bench_commands.py [--only check_helix_graded,gallery] [--robust-samples 10000]
                                        [--repeat 1] [--json]

Each command runs as a user runs it (a fresh interpreter: ``python -m foldprint ...``), once
with ``FOLDPRINT_KERNELS=numpy`` (the reference path) and once with the default (numba),
alternating, on the same machine in the same run:

* ``check helix_graded --json`` and ``check miura_3x3 --json`` (their stages in one pool),
* ``--quiet gallery --jobs 2`` of every template into a fresh folder (no kept designs),
* ``assign helix_uniform --objective robust --json``,
* ``robust helix_graded --samples N --json`` (``--robust-samples``; the target is for 10 000).

For each: wall seconds; CPU seconds of the command's own process (the parent: imports, the
nominal fold, the findings, the output) and of its worker processes; the load average
before and after; whether the two paths printed the same (JSON, timing fields aside; the
gallery's ``check.json`` and ``samples.json`` of every design): identical, or the same within
1e-9 relative on every number (the paths' contact and fold times may differ in the last
bits), else where they differ. Wall seconds mean little on a
shared machine: the **idle estimate** is parent CPU + worker CPU / 2 (the parent's work is
serial, the workers' shared by two cores: a lower bound when the pool's work is balanced).
A robust run of fewer samples than the target's is also extrapolated to the target's count
at its measured worker CPU per sample. The issue's targets (2 idle cores) sit beside each.
``--json`` writes ``docs/data/bench_commands.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "data" / "bench_commands.json"

#: Robust's sample count the target is stated for.
ROBUST_TARGET_SAMPLES = 10_000

#: name -> (arguments, target, what the target bounds): the issue's targets on two idle cores.
COMMANDS = {
    "check_helix_graded": (["check", "helix_graded", "--json"], 2.0, "wall s"),
    "check_miura_3x3": (["check", "miura_3x3", "--json"], 3.0, "wall s"),
    "gallery": (["--quiet", "gallery", "--jobs", "2", "--out", "{out}"], 12.0, "wall s"),
    "assign_helix_uniform_robust": (["assign", "helix_uniform", "--objective", "robust", "--json"], 10.0, "CPU s"),
    "robust_helix_graded": (["robust", "helix_graded", "--samples", "{n}", "--json"], 30.0, "wall s"),
}

#: Runs the command in this interpreter (as ``foldprint`` does, ``cli.commands.main``),
#: then writes its own and its children's CPU seconds (the workers are joined by then) and
#: ends as ``foldprint`` ends (``cli.commands.leave``: no interpreter teardown).
_WRAP = """
import json, resource, sys
from foldprint.cli.commands import leave, main
out = sys.argv[1]
code = main(sys.argv[2:])
s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
with open(out, "w") as f:
    json.dump({"parent": s.ru_utime + s.ru_stime, "workers": c.ru_utime + c.ru_stime}, f)
leave(code)
"""

#: JSON fields that are timings (not answers): left out of the comparison.
_TIMING_KEYS = ("seconds", "elapsed", "wall", "cpu_s")


def _strip(x):
    if isinstance(x, dict):
        return {k: _strip(v) for k, v in x.items() if not any(t in k for t in _TIMING_KEYS)}
    if isinstance(x, list):
        return [_strip(v) for v in x]
    return x


def _run(args: list[str], kernels: str) -> dict:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode compiled
    if kernels == "numpy":
        env["FOLDPRINT_KERNELS"] = "numpy"
    else:
        env.pop("FOLDPRINT_KERNELS", None)
    with tempfile.TemporaryDirectory(prefix="foldprint-bench-") as tmp:
        cpu_file = Path(tmp) / "cpu.json"
        out = Path(tmp) / "gallery"
        argv = [a.replace("{out}", str(out)) for a in args]
        load0 = os.getloadavg()[0]
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _WRAP, str(cpu_file), *argv], env=env, capture_output=True,
                           text=True, cwd=tmp)
        wall = time.perf_counter() - t0
        cpu = json.loads(cpu_file.read_text()) if cpu_file.exists() else {"parent": float("nan"), "workers": 0.0}
        if out.exists():  # the gallery: every design's answers
            answer = {str(f.relative_to(out)): _strip(json.loads(f.read_text()))
                      for f in sorted(out.glob("*/*.json")) if f.name in ("check.json", "samples.json")}
        else:
            try:
                answer = _strip(json.loads(p.stdout))
            except ValueError:
                answer = p.stdout
    return {"kernels": kernels, "exit": p.returncode, "wall_s": round(wall, 3), "parent_cpu_s": round(cpu["parent"], 3),
            "worker_cpu_s": round(cpu["workers"], 3), "cpu_s": round(cpu["parent"] + cpu["workers"], 3),
            "idle_wall_estimate_s": round(cpu["parent"] + cpu["workers"] / 2, 3),
            "load_before": round(load0, 2), "load_after": round(os.getloadavg()[0], 2),
            "stderr_tail": p.stderr.strip().splitlines()[-1:] if p.returncode not in (0, 1) else [],
            "_answer": answer}


#: Relative difference within which two numbers of the two paths' answers count as the same
#: (kernels.md: contact and fold times agree within one simulation step, poses to 1e-11).
REL = 1e-9


def _differ(a, b, where: str = "") -> list[str]:
    """Where two answers differ (numbers beyond :data:`REL`), as JSON paths."""
    if isinstance(a, dict) and isinstance(b, dict):
        return [w for k in sorted(set(a) | set(b)) for w in _differ(a.get(k), b.get(k), f"{where}/{k}")]
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return [w for k, (x, y) in enumerate(zip(a, b)) for w in _differ(x, y, f"{where}[{k}]")]
    if isinstance(a, float) and isinstance(b, float):
        return [] if abs(a - b) <= REL * max(abs(a), abs(b), 1e-300) else [where]
    return [] if a == b else [where]


def _row(name: str, runs: dict, target: float, unit: str, samples: int) -> dict:
    nb, npy = runs["numba"], runs["numpy"]
    figure = nb["cpu_s"] if unit == "CPU s" else nb["idle_wall_estimate_s"]
    diff = _differ(nb["_answer"], npy["_answer"])
    row = {"command": name, "target": target, "target_unit": unit, "identical_answers": nb["_answer"] == npy["_answer"],
           "same_answers": not diff, "differences": diff[:10],
           "numpy": {k: v for k, v in npy.items() if not k.startswith("_")},
           "numba": {k: v for k, v in nb.items() if not k.startswith("_")},
           "cpu_ratio_numpy_over_numba": round(npy["cpu_s"] / nb["cpu_s"], 2) if nb["cpu_s"] else None,
           "figure_for_target": figure, "meets_target": figure <= target}
    if name == "robust_helix_graded" and samples != ROBUST_TARGET_SAMPLES:
        per = nb["worker_cpu_s"] / samples  # the workers fold the samples; the parent's work is fixed
        est = nb["parent_cpu_s"] + per * ROBUST_TARGET_SAMPLES / 2
        row.update(samples=samples, extrapolated_to=ROBUST_TARGET_SAMPLES, figure_for_target=round(est, 2),
                   meets_target=est <= target)
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", default="", help="comma-separated command names (default: all five)")
    ap.add_argument("--robust-samples", type=int, default=ROBUST_TARGET_SAMPLES)
    ap.add_argument("--json", action="store_true", help=f"write {DATA.relative_to(ROOT)}")
    args = ap.parse_args()
    names = [n for n in (args.only.split(",") if args.only else COMMANDS) if n]
    rows = []
    for k, name in enumerate(names):
        argv, target, unit = COMMANDS[name]
        argv = [a.replace("{n}", str(args.robust_samples)) for a in argv]
        runs = {}
        for kernels in (("numpy", "numba") if k % 2 == 0 else ("numba", "numpy")):  # alternate the order
            runs[kernels] = _run(argv, kernels)
        row = _row(name, runs, target, unit, args.robust_samples)
        rows.append(row)
        nb, npy = row["numba"], row["numpy"]
        print(f"{name:30s} numpy {npy['wall_s']:7.2f} s wall {npy['cpu_s']:7.2f} CPU-s | numba {nb['wall_s']:7.2f} s wall "
              f"{nb['cpu_s']:7.2f} CPU-s (parent {nb['parent_cpu_s']:.2f}, workers {nb['worker_cpu_s']:.2f}) "
              f"idle ~{nb['idle_wall_estimate_s']:.2f} s | ratio {row['cpu_ratio_numpy_over_numba']} | "
              f"target {target:g} {unit}: {row['figure_for_target']} ({'met' if row['meets_target'] else 'not met'}) | "
              f"same answers: {row['same_answers']} (identical: {row['identical_answers']}) | load {nb['load_before']}-{nb['load_after']}", flush=True)
    if args.json:
        DATA.parent.mkdir(parents=True, exist_ok=True)
        DATA.write_text(json.dumps({"cpus": os.cpu_count(), "python": sys.version.split()[0], "rows": rows},
                                   indent=2) + "\n")


if __name__ == "__main__":
    main()
