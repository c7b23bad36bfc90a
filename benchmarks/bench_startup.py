"""What the command line costs before it does anything: ``foldprint --help`` and
``foldprint templates`` (and ``--version``), each run as a fresh process, against two floors
measured in the same run, interleaved so that a loaded machine slows all alike:
``python -c pass`` (the interpreter) and ``python -c "import typer"`` (the CLI library
foldprint is built on). Per command: the min and median wall time and CPU time (user +
sys of the child) over ``--runs`` runs, and the ratios of the mins to the floors (of the
wall times, and of the CPU times to ``import typer``'s, the steadier on a loaded machine).
The target (docs/scale.md, "Start-up"): ``--help`` and ``templates`` under 0.15 s wall on
an idle 2-core machine; on a loaded one, read the CPU columns and the ratios.

``python benchmarks/bench_startup.py [--runs 30] [--json]`` (run it with the venv's
python: the console script beside it is what is measured)."""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: seconds of wall time ``--help`` and ``templates`` may take on an idle 2-core machine
TARGET_WALL_S = 0.15


def _foldprint() -> list[str]:
    """The console script beside this interpreter (what a user runs), else ``-m foldprint``."""
    script = Path(sys.executable).parent / "foldprint"
    if script.exists():
        return [sys.executable, str(script)]
    found = shutil.which("foldprint")
    return [sys.executable, found] if found else [sys.executable, "-m", "foldprint"]


def commands() -> dict[str, list[str]]:
    fp = _foldprint()
    return {"python -c pass": [sys.executable, "-c", "pass"],
            "python -c 'import typer'": [sys.executable, "-c", "import typer"],
            "foldprint --help": [*fp, "--help"],
            "foldprint templates": [*fp, "templates"],
            "foldprint --version": [*fp, "--version"]}


def _run_once(argv: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds (user + sys) of one fresh process."""
    env = dict(os.environ, COLUMNS="80")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env, check=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def measure(runs: int) -> dict:
    cmds = commands()
    for argv in cmds.values():  # warm the file cache and the byte code
        _run_once(argv)
    wall: dict[str, list[float]] = {k: [] for k in cmds}
    cpu: dict[str, list[float]] = {k: [] for k in cmds}
    for _ in range(runs):
        for key, argv in cmds.items():  # interleaved: load hits every command alike
            w, c = _run_once(argv)
            wall[key].append(w)
            cpu[key].append(c)
    out: dict = {"runs": runs, "python": sys.version.split()[0], "target_wall_s": TARGET_WALL_S, "commands": {}}
    try:
        from importlib.metadata import version

        out["typer"] = version("typer")
    except Exception:  # noqa: BLE001 -- a report field, not a requirement
        out["typer"] = None
    floor_pass, floor_typer = min(wall["python -c pass"]), min(wall["python -c 'import typer'"])
    cpu_typer = min(cpu["python -c 'import typer'"])
    for key in cmds:
        w, c = wall[key], cpu[key]
        out["commands"][key] = {
            "wall_s": {"min": round(min(w), 4), "median": round(statistics.median(w), 4)},
            "cpu_s": {"min": round(min(c), 4), "median": round(statistics.median(c), 4)},
            "wall_min_over_pass": round(min(w) / floor_pass, 2),
            "wall_min_over_import_typer": round(min(w) / floor_typer, 2),
            "cpu_min_over_import_typer": round(min(c) / cpu_typer, 2)}
    out["load_average"] = [round(x, 2) for x in os.getloadavg()]
    return out


def _text(res: dict) -> str:
    lines = [f"{res['runs']} runs each, python {res['python']}, typer {res['typer']}, "
             f"load average {res['load_average']}",
             f"{'command':<28} {'wall min':>9} {'median':>8} {'cpu min':>8} {'median':>8} "
             f"{'/pass':>6} {'/typer':>7} {'cpu/typer':>10}"]
    for key, r in res["commands"].items():
        lines.append(f"{key:<28} {r['wall_s']['min']:>9.3f} {r['wall_s']['median']:>8.3f} "
                     f"{r['cpu_s']['min']:>8.3f} {r['cpu_s']['median']:>8.3f} "
                     f"{r['wall_min_over_pass']:>6.1f} {r['wall_min_over_import_typer']:>7.2f} "
                     f"{r['cpu_min_over_import_typer']:>10.2f}")
    lines.append(f"target: --help and templates under {res['target_wall_s']} s wall on an idle 2-core machine")
    return "\n".join(lines)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=30)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    result = measure(a.runs)
    print(json.dumps(result, indent=2) if a.json else _text(result))
