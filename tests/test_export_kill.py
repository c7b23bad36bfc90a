"""SIGKILL ``export`` at random moments: the output directory holds the previous complete
set or the new one (or a committed journal the next export finishes), never a mix, and no
temporary file survives the next export (issue 14). ``benchmarks/kill_export.py`` runs
the same with more kills."""

from __future__ import annotations

import hashlib
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {"a": "30, 30, 35.8, 35.8, 41.6, 41.6, 47.4, 47.4, 53.2, 53.2",
            "b": "31, 30, 35.8, 35.8, 41.6, 41.6, 47.4, 47.4, 53.2, 53.2"}
ARGS = ["--format", "3mf,prusa3mf,stl"]


def _design(tmp: Path, v: str) -> Path:
    text = (ROOT / "templates" / "helix_graded.toml").read_text()
    f = tmp / f"design_{v}.toml"
    f.write_text(text.replace("30, 30, 35.8, 35.8, 41.6, 41.6, 47.4, 47.4, 53.2, 53.2", VARIANTS[v]))
    return f


def _export(design: Path, out: Path):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "foldprint", "export", str(design), "--out", str(out), *ARGS],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _digest(out: Path) -> dict:
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(out.iterdir()) if p.is_file()}


def _state(out: Path, sets: dict) -> str:
    """'a', 'b', 'none' (nothing yet), 'journal' (a committed set pending), or 'MIXED'."""
    if not out.exists():
        return "none"
    stages = [p for p in out.iterdir() if p.name.startswith(".foldprint-staging-")]
    if any((p / "COMMIT").is_file() for p in stages):
        return "journal"
    files = {k: v for k, v in _digest(out).items()}
    if not files:
        return "none"
    for name, ref in sets.items():
        if files == ref:
            return name
    return "MIXED"


def kill_campaign(tmp: Path, kills: int, seed: int = 1) -> dict:
    rng = random.Random(seed)
    designs = {v: _design(tmp, v) for v in VARIANTS}
    sets, runtime = {}, {}
    write_s = 0.05
    for v, d in designs.items():  # reference sets, how long an export and its write phase take
        ref = tmp / f"ref_{v}"
        t0 = time.monotonic()
        proc = _export(d, ref)
        seen = None
        while proc.poll() is None:
            if seen is None and ref.exists() and any(p.name.startswith(".foldprint-staging-") for p in ref.iterdir()):
                seen = time.monotonic()
            time.sleep(0.001)
        assert proc.wait() == 0
        runtime[v] = time.monotonic() - t0
        if seen is not None:
            write_s = max(write_s, time.monotonic() - seen)
        sets[v] = _digest(ref)
    out = tmp / "out"
    assert _export(designs["a"], out).wait() == 0  # a previous complete set
    counts: dict = {}
    killed = 0
    for k in range(kills):
        v = "ab"[k % 2]
        proc = _export(designs[v], out)
        # aim at the write phase: wait for the staging directory, then kill within 0-40 ms
        deadline = time.monotonic() + 20 * runtime[v] + 30
        while proc.poll() is None and time.monotonic() < deadline:
            if out.exists() and any(p.name.startswith(".foldprint-staging-") for p in out.iterdir()):
                time.sleep(rng.uniform(0.0, 1.5) * write_s)
                break
            time.sleep(0.001)
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
            killed += 1
        proc.wait()
        st = _state(out, sets)
        counts[st] = counts.get(st, 0) + 1
        assert st != "MIXED", f"kill {k}: mixed set {_digest(out)}"
    # the next export finishes or discards what the kills left, and leaves no temp file
    assert _export(designs["a"], out).wait() == 0
    leftovers = [p.name for p in out.iterdir() if p.name.startswith(".")]
    assert _state(out, sets) == "a" and leftovers == [], leftovers
    return {"runs": kills, "killed": killed, "write_phase_s": round(write_s, 3), "states_after_kill": counts}


def test_killed_exports_never_leave_a_mixed_set(tmp_path):
    res = kill_campaign(tmp_path, kills=4)
    assert res["killed"] >= 1
