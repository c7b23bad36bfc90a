"""Fresh fuzz campaign (issue 14): N mutated designs through ``check --json`` and ``export``.

    PYTHONPATH=$PWD python benchmarks/fuzz_inputs.py --cases 1000 --seed-base 7000000 --jobs 2

Seeds start at ``--seed-base`` (the suite's hypothesis seeds are drawn from another
stream). Prints the counts per command: exit 0/1/2, tracebacks, other exit codes,
> 30 s, one-line-on-2 and nothing-written-on-2 violations, and the failing seeds.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_fuzz import one  # noqa: E402


def _warm():
    """Import the CLI and every stage once per worker, so each forked case starts warm."""
    import foldprint.checks, foldprint.cli, foldprint.load, foldprint.pipeline, foldprint.simulate  # noqa: E401,F401
    import foldprint.geometry, foldprint.exchange.export  # noqa: E401,F401


def _run(seed: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="fpfuzz") as tmp:
        r = one(seed, Path(tmp))
    return {cmd: {"code": v["code"], "bad": v["bad"], "seconds": round(v["seconds"], 2),
                  "cpu_seconds": round(v["cpu_seconds"], 2),
                  "err": v["err"][-300:] if v["bad"] else ""} for cmd, v in r.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cases", type=int, default=1000)
    ap.add_argument("--seed-base", type=int, default=7_000_000)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    seeds = range(a.seed_base, a.seed_base + a.cases)
    counts = {c: Counter() for c in ("check", "export")}
    failures = []
    with ProcessPoolExecutor(a.jobs, initializer=_warm) as ex:
        for seed, r in zip(seeds, ex.map(_run, seeds, chunksize=4)):
            for cmd, v in r.items():
                c = counts[cmd]
                c[f"exit {v['code']}"] += 1
                for b in v["bad"]:
                    c[b] += 1
                if v["cpu_seconds"] > 30 or v["code"] is None:
                    c["> 30 s"] += 1
                if v["seconds"] > 30:
                    c["> 30 s wall (busy machine)"] += 1
                c["max_cpu_seconds"] = max(c["max_cpu_seconds"], v["cpu_seconds"])
                c["max_wall_seconds"] = max(c["max_wall_seconds"], v["seconds"])
                if v["bad"]:
                    failures.append({"seed": seed, "cmd": cmd, **v})
            if (seed - a.seed_base + 1) % 25 == 0:
                print(f"after {seed - a.seed_base + 1}: {json.dumps({k: dict(v) for k, v in counts.items()})} "
                      f"failing seeds: {[(f['seed'], f['cmd'], f['bad']) for f in failures]}",
                      file=sys.stderr, flush=True)
    report = {"cases": a.cases, "seed_base": a.seed_base, "counts": {k: dict(v) for k, v in counts.items()},
              "failures": failures[:50]}
    print(json.dumps(report, indent=1))
    if a.json:
        a.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
