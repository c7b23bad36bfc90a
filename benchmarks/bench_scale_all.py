"""The scale figures in one run: dense folds and guards (``bench_scale.py``), then the
Monte-Carlo, check and assign (``bench_robust.py``), one after the other so neither loads
the other's timings.

    python benchmarks/bench_scale_all.py [--json] [--quick]

``--quick`` skips the 1000-panel runs and the assign search. Each part prints its own
figures beside the baseline measured in the same run; with ``--json`` the two JSON objects
come out as one: ``{"scale": {...}, "robust": {...}}``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def _run(script: str, args: list[str]) -> dict:
    p = subprocess.run([sys.executable, str(HERE / script), "--json", *args], capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{script} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    return json.loads(p.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    ap.add_argument("--quick", action="store_true", help="skip the 1000-panel runs and the assign search")
    a = ap.parse_args(argv)
    out = {"load_average": os.getloadavg(),
           "scale": _run("bench_scale.py", ["--quick"] if a.quick else []),
           "robust": _run("bench_robust.py", ["--no-assign"] if a.quick else [])}
    if a.json:
        print(json.dumps(out, indent=1))
    else:
        for part in ("scale", "robust"):
            print(f"== {part}")
            print(json.dumps(out[part], indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
