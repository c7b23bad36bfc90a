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
    assert {"design_strip", "fold_simulate_plot", "check_design", "compare_hinges", "notebook_check_export"} <= names


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
    elif script.stem == "notebook_check_export":
        _same_as_the_command_line(out, tmp_path, proc.stdout)


def _same_as_the_command_line(out: Path, tmp_path: Path, stdout: str) -> None:
    """The notebook's check, through the public API alone, is the command line's: the same
    JSON as ``foldprint check helix_uniform --json`` and the same STL bytes as ``foldprint
    export``; its refusal names the input, not an option."""
    import json

    assert "refused: temperature must be in [-100, 500] deg C, got 600.0" in stdout
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    cli = subprocess.run([sys.executable, "-m", "foldprint", "check", "helix_uniform", "--json"], cwd=tmp_path,
                         env=env, capture_output=True, text=True, timeout=300)
    assert cli.returncode == 1, cli.stderr[-2000:]  # helix_uniform jams: check fails it
    assert json.loads((out / "check.json").read_text()) == json.loads(cli.stdout)
    cli_out = tmp_path / "cli_export"
    done = subprocess.run([sys.executable, "-m", "foldprint", "export", "helix_uniform", "--format", "stl", "--out",
                           str(cli_out)], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    stls = sorted(p.name for p in (out / "print").glob("*.stl"))
    assert stls and stls == sorted(p.name for p in cli_out.glob("*.stl"))
    assert all((out / "print" / n).read_bytes() == (cli_out / n).read_bytes() for n in stls)
    with zipfile.ZipFile(out / "print" / "helix_uniform.3mf") as z:
        assert "3D/3dmodel.model" in z.namelist()
