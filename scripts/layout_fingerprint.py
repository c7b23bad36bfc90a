"""Fingerprint of what foldprint writes and says, to prove a refactor changed nothing.

For every template: the JSON of ``simulate``, ``check`` and ``robust`` (seeded), the exit
codes, and the SHA-256 of every file ``export`` writes (3MF, PrusaSlicer 3MF, STL, FOLD,
both states). Prints one JSON object; compare two runs with ``diff``:

    python scripts/layout_fingerprint.py > before.json   # on the old tree
    python scripts/layout_fingerprint.py > after.json    # on the new tree
    diff before.json after.json && echo identical

Timing fields (wall times) are dropped; everything else must match byte for byte.
"""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VOLATILE = {"elapsed_s", "wall_s", "cpu_s", "duration_wall_s", "time_s"}


def _scrub(obj):
    if isinstance(obj, dict):
        return {k: _scrub(v) for k, v in obj.items() if k not in VOLATILE}
    if isinstance(obj, list):
        return [_scrub(v) for v in obj]
    return obj


def _run(*args: str) -> dict:
    p = subprocess.run([sys.executable, "-m", "foldprint", *args], capture_output=True, text=True, cwd=ROOT)
    try:
        out = _scrub(json.loads(p.stdout)) if p.stdout.strip() else None
    except json.JSONDecodeError:
        out = p.stdout
    return {"exit": p.returncode, "stdout": out}


def main() -> int:
    names = [t["name"] for t in _run("templates", "--json")["stdout"]["templates"]]
    result: dict = {}
    for name in names:
        r = {"simulate": _run("simulate", name, "--json"),
             "check": _run("check", name, "--json", "--samples", "8", "--seed", "3"),
             "robust": _run("robust", name, "--json", "--samples", "8", "--seed", "3")}
        for state in ("permanent", "programmed"):
            with tempfile.TemporaryDirectory() as tmp:
                e = _run("export", name, "--out", tmp, "--state", state, "--format", "3mf,prusa3mf,stl,fold", "--json")
                files = {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
                         for p in sorted(Path(tmp).rglob("*")) if p.is_file()}
                r[f"export_{state}"] = {"exit": e["exit"], "files": files}
        result[name] = r
        print(name, file=sys.stderr)
    print(json.dumps(result, indent=1, sort_keys=True))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
