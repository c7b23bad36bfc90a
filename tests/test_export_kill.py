"""SIGKILL ``export`` at random moments: the output folder holds exactly the previous
complete set or the new one, as plain files, never a mix, and nothing the killed run left
survives the next export (a set is staged beside the folder and published by one rename,
``foldprint/exchange/fileset.py``). ``tests/test_export_publish.py`` kills the writer after
each of its steps in turn; this test kills the real command at random moments.
``benchmarks/kill_export.py`` runs the same with 100 kills."""

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
    """name -> sha256 of every file in the folder (a link or a folder is recorded as
    such: an export holds neither)."""
    return {p.name: ("link" if p.is_symlink() else "folder" if p.is_dir() else
                     hashlib.sha256(p.read_bytes()).hexdigest()) for p in sorted(out.iterdir())}


def _staging(out: Path) -> list[str]:
    """The staging (or set-aside) folders of ``out`` beside it."""
    return sorted(n for n in os.listdir(out.parent) if n.startswith(f".{out.name}.foldprint-"))


def _state(out: Path, sets: dict) -> str:
    """'a', 'b', 'none' (nothing yet) or 'MIXED' (anything else a reader could see)."""
    if not out.exists():
        return "none"
    files = _digest(out)
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
            if seen is None and _staging(ref):
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
        # half the kills aim at the write phase (the set folder appears, then 0-1.5x its
        # length), half at a uniformly random moment of the whole run
        deadline = time.monotonic() + 20 * runtime[v] + 30
        if k % 4 < 2:
            before = set(_staging(out))
            while proc.poll() is None and time.monotonic() < deadline:
                if set(_staging(out)) - before:
                    time.sleep(rng.uniform(0.0, 1.5) * write_s)
                    break
                time.sleep(0.001)
        else:
            time.sleep(rng.uniform(0.0, 1.1) * runtime[v])
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
            killed += 1
        proc.wait()
        st = _state(out, sets)
        counts[st] = counts.get(st, 0) + 1
        assert st != "MIXED", f"kill {k}: mixed set {_digest(out)}"
    # the next export removes what the kills left, beside the folder and in it
    assert _export(designs["a"], out).wait() == 0
    leftovers = _staging(out) + sorted(p.name for p in out.iterdir() if p.name.startswith("."))
    assert _state(out, sets) == "a" and leftovers == [], leftovers
    return {"runs": kills, "killed": killed, "write_phase_s": round(write_s, 3), "states_after_kill": counts}


def test_killed_exports_never_leave_a_mixed_set(tmp_path):
    res = kill_campaign(tmp_path, kills=6)
    assert res["killed"] >= 1
