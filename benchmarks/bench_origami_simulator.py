"""Origami Simulator's example crease patterns through `foldprint simulate`, each in its own
process under a time limit: which give a verdict (exit 0 completes, 1 does not), which are
refused (exit 2, the reason read from the one-line message), which run past the limit and
which end in a bug (exit 3 or a signal).

    PYTHONPATH=$PWD python benchmarks/bench_origami_simulator.py [ASSETS] [--timeout 30]
        [--jobs 2] [--out docs/data/bench_origami_simulator.json] [--only NAME ...]

ASSETS is the ``assets/`` folder of Origami Simulator (github.com/amandaghassaei/OrigamiSimulator,
MIT licence, Amanda Ghassaei), or the environment variable FOLDPRINT_OS_ASSETS; the files are
not part of this repository (five of them are, in tests/data/origami_simulator). Every ``*.svg``
below it is run except those under ``doc/`` (the documentation's figures). The JSON records
the machine's load before and after; docs/origami-simulator.md shows its table
(scripts/regen_docs.py, block ``origami-simulator``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import re
import resource
import signal
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "data" / "bench_origami_simulator.json"
#: s per pattern: the limit the examples are held to (our choice, as the task's "within 30 s")
TIMEOUT_S = 30.0
#: BLAS threads of each run (0: the library's default). One, because the limit is CPU time:
#: OpenBLAS's threads spin while they wait, and on a loaded 2-core machine they doubled the
#: CPU a loop pattern's small stacked SVDs took (miyamotoTower.svg: past 30 CPU-s with the
#: default, 16 CPU-s with one thread, measured at load 20)
BLAS_THREADS = {"n": 1}
#: wall seconds per CPU second of the limit before a run is stopped anyway (a loaded machine)
WALL_FACTOR = 10.0

#: refusal reasons, first match wins: (label, pattern of the message)
REASONS = [
    ("crease inside a panel", r"inside panel"),
    ("curved creases", r"curve|path command"),
    ("crease borders too few faces", r"borders \d+ face"),
    ("creases of one hinge not on one line", r"do not lie on one line"),
    ("different angles on one hinge", r"different fold angles"),
    ("memory or time guard", r"memory|--max-memory|estimate"),
    ("fold the printed hinge cannot make", r"hinge cannot|cannot make|beyond the .* hinge|bend radius"),
    ("no face / not a pattern", r"enclose no face|no coloured line|not a simple polygon"),
]


def assets_dir(arg: str | None) -> Path:
    where = arg or os.environ.get("FOLDPRINT_OS_ASSETS")
    if not where:
        raise SystemExit("bench_origami_simulator: give Origami Simulator's assets/ folder as an argument "
                         "or in FOLDPRINT_OS_ASSETS (the files are not in this repository)")
    path = Path(where)
    if not path.is_dir():
        raise SystemExit(f"bench_origami_simulator: {path} is not a folder")
    return path


def patterns(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.svg") if "doc" not in p.relative_to(folder).parts[:-1])


def reason(message: str) -> str:
    for label, pat in REASONS:
        if re.search(pat, message):
            return label
    return "other"


def _cpu_limit(seconds: float):
    def apply():
        lim = int(math.ceil(seconds))
        resource.setrlimit(resource.RLIMIT_CPU, (lim, lim + 5))  # SIGXCPU at the limit, SIGKILL 5 s on
    return apply


def run_one(path: Path, folder: Path, timeout: float, command: str) -> dict:
    """One pattern in a child process (its own session): stopped at ``timeout`` CPU seconds
    (RLIMIT_CPU: on a shared machine the CPU a run takes is its cost, its wall time is the
    load's) or at WALL_FACTOR times that of wall time, whichever comes first."""
    rel = path.relative_to(folder).as_posix()
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    if BLAS_THREADS["n"]:
        env.update({k: str(BLAS_THREADS["n"]) for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")})
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "foldprint", command, str(path)], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=_cpu_limit(timeout))
    out, err, rc, cpu = _wait(proc, timeout * WALL_FACTOR)
    wall = time.perf_counter() - t0
    if rc is None or rc in (-signal.SIGXCPU, -signal.SIGKILL) or cpu >= timeout:
        return {"file": rel, "outcome": "past the limit", "exit": None, "seconds": round(wall, 1),
                "cpu_s": round(cpu, 1), "message": ""}
    err, out = err.replace(str(path), rel), out.replace(str(path), rel)
    notes = [ln for ln in err.splitlines() if ln.startswith("note: ")]
    said = [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("note: ")]
    text = "\n".join(said) if rc not in (0, 1) else out.strip()
    first = next((ln for ln in text.splitlines() if ln.strip()), "")
    if rc in (0, 1):
        outcome = "completes" if rc == 0 else "does not complete"
    elif rc == 2:
        outcome = "refused"
    else:
        outcome = "bug"
        first = text.splitlines()[-1] if text else f"signal {-rc}"
    entry = {"file": rel, "outcome": outcome, "exit": rc, "seconds": round(wall, 1), "cpu_s": round(cpu, 1),
             "message": first[:300]}
    if outcome == "refused":
        entry["reason"] = reason(first)
    if notes:
        entry["notes"] = [n[:300] for n in notes]
    return entry


def _wait(proc, wall_limit: float):
    """Output, exit code (None when stopped at the wall limit) and CPU seconds (user +
    system, from wait4) of the child; its session is killed as a group at the wall limit."""
    bufs = {}

    def drain(name, pipe):
        bufs[name] = pipe.read()

    readers = [threading.Thread(target=drain, args=(n, p)) for n, p in (("out", proc.stdout), ("err", proc.stderr))]
    for t in readers:
        t.start()
    stopped = threading.Event()

    def stop():
        stopped.set()
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass

    timer = threading.Timer(wall_limit, stop)
    timer.start()
    _, status, ru = os.wait4(proc.pid, 0)
    timer.cancel()
    proc.returncode = os.waitstatus_to_exitcode(status)
    for t in readers:
        t.join()
    rc = None if stopped.is_set() else proc.returncode
    return bufs.get("out", ""), bufs.get("err", ""), rc, ru.ru_utime + ru.ru_stime


def counts(rows: list[dict]) -> dict:
    out: dict[str, int] = {}
    for r in rows:
        out[r["outcome"]] = out.get(r["outcome"], 0) + 1
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("assets", nargs="?")
    ap.add_argument("--timeout", type=float, default=TIMEOUT_S)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--command", default="simulate")
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--only", nargs="*", help="run only files whose path contains one of these")
    ap.add_argument("--merge", action="store_true", help="keep the other patterns' rows of --out")
    ap.add_argument("--blas-threads", type=int, default=BLAS_THREADS["n"],
                    help="BLAS threads per run (0: the library's default)")
    args = ap.parse_args(argv)
    folder = assets_dir(args.assets)
    BLAS_THREADS["n"] = args.blas_threads
    files = patterns(folder)
    if args.only:
        files = [f for f in files if any(s in f.as_posix() for s in args.only)]
    print(f"bench_origami_simulator: {len(files)} patterns from {folder}, {args.timeout:g} s each, "
          f"{args.jobs} at a time", flush=True)
    load0 = os.getloadavg()
    with ThreadPoolExecutor(args.jobs) as pool:
        rows = []
        for r in pool.map(lambda p: run_one(p, folder, args.timeout, args.command), files):
            print(f"  {r['outcome']:18s} {r['seconds']:5.1f} s  {r['file']}  {r.get('message', '')[:110]}", flush=True)
            rows.append(r)
    if args.merge and Path(args.out).exists():  # the other patterns' rows from the earlier run
        again = {r["file"] for r in rows}
        rows = sorted(rows + [r for r in json.loads(Path(args.out).read_text())["results"] if r["file"] not in again],
                      key=lambda r: r["file"])
    result = {"command": f"foldprint {args.command} FILE", "timeout_s": args.timeout, "jobs": args.jobs,
              "blas_threads": args.blas_threads,
              "patterns": len(rows), "counts": counts(rows),
              "load_before": [round(x, 2) for x in load0], "load_after": [round(x, 2) for x in os.getloadavg()],
              "cpu": platform.processor() or platform.machine(), "cores": os.cpu_count(), "results": rows}
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(f"counts: {result['counts']}; wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
