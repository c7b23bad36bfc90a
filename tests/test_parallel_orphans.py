"""Worker processes end with the process that started them: a parent killed by SIGKILL
(no clean-up runs) leaves no worker behind holding its pipes, through the kernel's
parent-death signal and, without it, through the worker's watchdog thread. Both pools are
covered: ``core.parallel.map_ordered`` and the Monte-Carlo batch pool's initializer."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")

PARENT = textwrap.dedent("""
    import os, sys, time
    from pathlib import Path
    from foldprint.core import parallel

    OUT = Path(sys.argv[1])

    def work(k):
        (OUT / f"w{os.getpid()}").write_text(str(os.getppid()))
        time.sleep(120)
        return k

    if __name__ == "__main__":
        if sys.argv[2] == "watchdog":  # no kernel signal: only the watchdog thread is left
            parallel._deathsig = lambda: False
        if sys.argv[2] == "batch":  # the batch pool's own initializer
            from concurrent.futures import ProcessPoolExecutor
            from foldprint.simulation.jamtest import pool as batch
            with ProcessPoolExecutor(2, initializer=batch._init, initargs=((), None)) as pool:
                list(pool.map(work, range(2)))
        else:
            parallel.map_ordered(work, range(4), workers=2)
""")


def _alive(pid: int) -> bool:
    """A process that exists and is not a zombie (a dead orphan whose reaper is slow)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.parametrize("mode", ["pdeathsig", "watchdog", "batch"])
def test_workers_die_within_seconds_of_a_killed_parent(tmp_path, mode):
    script = tmp_path / "parent.py"
    script.write_text(PARENT)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1])}
    parent = subprocess.Popen([sys.executable, str(script), str(tmp_path), mode], env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 60
        while len(list(tmp_path.glob("w*"))) < 2:
            assert parent.poll() is None, parent.stderr.read().decode()[-2000:]
            assert time.monotonic() < deadline, "the workers did not start"
            time.sleep(0.05)
        workers = [int(p.name[1:]) for p in tmp_path.glob("w*")]
        assert all(int((tmp_path / f"w{w}").read_text()) == parent.pid for w in workers)
        assert all(_alive(w) for w in workers)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(10)
        end = time.monotonic() + 5
        while any(_alive(w) for w in workers) and time.monotonic() < end:
            time.sleep(0.05)
        left = [w for w in workers if _alive(w)]
        assert left == [], f"workers {left} outlived their parent"
    finally:
        if parent.poll() is None:
            parent.kill()
        for p in tmp_path.glob("w*"):  # never leave one behind, even when the test fails
            try:
                os.kill(int(p.name[1:]), signal.SIGKILL)
            except ProcessLookupError:
                pass
