"""Every script in examples/ runs as a newcomer would run it: a fresh interpreter, the
current directory an empty tmp dir (so whatever it writes lands there), exit status 0."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


def test_there_are_examples():
    names = {p.stem for p in EXAMPLES}
    assert len(EXAMPLES) >= 4
    assert {"design_strip", "fold_simulate_plot", "check_design", "compare_hinges"} <= names


def _run(script: Path, cwd: Path) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    return subprocess.run([sys.executable, str(script)], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs(script, tmp_path):
    proc = _run(script, tmp_path)
    assert proc.returncode == 0, f"{script.name} exited {proc.returncode}:\n{proc.stderr[-3000:]}"
    assert proc.stdout.strip(), f"{script.name} printed nothing"
    written = sorted(p for p in tmp_path.rglob("*") if p.is_file())
    out = tmp_path / "output" / "examples" / script.stem
    if script.stem == "design_strip":
        mf = out / "my_channel.3mf"
        with zipfile.ZipFile(mf) as z:  # a real 3MF package with its model part
            assert "3D/3dmodel.model" in z.namelist()
        assert {p.suffix for p in written} >= {".3mf", ".stl", ".json"}
        assert all(str(p).startswith(str(out)) for p in written), written
    elif script.stem == "fold_simulate_plot":
        for name in ("hinge_angles.png", "frames.png"):
            with Image.open(out / name) as im:
                im.verify()
        assert (out / "open_box.fold").is_file()
        assert "open_box: 5 panels, 4 hinges" in proc.stdout
    elif script.stem == "check_design":
        assert "self_lock:" in proc.stdout and "error(s)" in proc.stdout
        assert not written
    elif script.stem == "compare_hinges":
        lines = proc.stdout.splitlines()
        assert sum(line.startswith("self_lock") for line in lines) == 2
        assert proc.stdout.count("completes:") == 2
