"""The README is the first thing a user runs: its two set-up commands come first and the
test command is the one CI runs; its command synopsis names every command and only options
the command line has (checked against the help snapshots, which tests/test_cli_startup.py
keeps equal to the real ``--help``), and every option a command has."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")
HELP = ROOT / "tests" / "data" / "cli_help"
#: options every command has or that the synopsis states once for all (README says so)
SHARED = {"--help", "--scale", "--crease-materials"}


def _blocks(kind: str) -> list[tuple[int, str]]:
    """(line number, body) of each fenced block whose info string is ``kind``, in order
    (fences paired from the top, so a closing fence is never read as an opening one)."""
    out, opened, body = [], None, []
    for n, line in enumerate(README.splitlines(), 1):
        if line.startswith("```"):
            if opened is None:
                opened, body = (n, line[3:].strip()), []
            else:
                if opened[1] == kind:
                    out.append((opened[0], "\n".join(body)))
                opened = None
        elif opened is not None:
            body.append(line)
    return out


def test_the_two_set_up_commands_come_first_and_ci_runs_the_second():
    (l1, install), (l2, tests) = _blocks("bash")[:2]
    assert install.strip() == "pip install -e . && foldprint gallery"
    assert tests.strip() == 'pip install -e ".[test]" && python -m pytest -n 2 --dist loadfile'
    assert l2 < 30, "the test command must be on the first screen"
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()
    assert ci[-1].strip() == tests.strip()


def _synopsis() -> dict[str, set[str]]:
    block = next(b for _, b in _blocks("") if b.lstrip().startswith("foldprint materials"))
    opts: dict[str, set[str]] = {}
    cmd = None
    for line in block.splitlines():
        m = re.match(r"foldprint (\w+)", line)
        if m:
            cmd = m.group(1)
            line = line[m.end():]
        opts.setdefault(cmd, set()).update(re.findall(r"--[a-z][a-z-]*", line))
    return opts


def _help_options(command: str) -> set[str]:
    text = (HELP / f"{command}.txt").read_text()
    return set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", text.split("Options:", 1)[1]))


def test_the_synopsis_names_every_command():
    commands = {p.stem for p in HELP.glob("*.txt")} - {"foldprint"}
    assert set(_synopsis()) == commands


@pytest.mark.parametrize("command", sorted(_synopsis()))
def test_the_synopsis_gives_exactly_the_options_of_the_command(command):
    """No option the command line lacks (a renamed option would mislead), and none left out
    (a new option belongs in the synopsis)."""
    said, has = _synopsis()[command], _help_options(command)
    toggle = {o: "--" + o[5:] for o in has if o.startswith("--no-") and "--" + o[5:] in has}
    said, has = {toggle.get(o, o) for o in said}, {toggle.get(o, o) for o in has}  # either side of a toggle
    assert said - has == set(), f"README names options {command} does not have"
    assert has - said - SHARED == set(), f"README leaves out options of {command}"


def test_the_python_api_example_runs(tmp_path):
    """The README's Python block runs as a user would run it (a fresh interpreter, an empty
    current folder): exit 0, the evaluation's answer printed, the files it names written."""
    import ast
    import os
    import subprocess
    import sys

    (line, code), = _blocks("python")
    script = tmp_path / "readme_example.py"
    script.write_text(code, encoding="utf-8")
    env = dict(os.environ, PYTHONPATH=str(ROOT), MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, str(script)], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, f"README.md:{line}: the Python example fails:\n{proc.stderr[-3000:]}"
    lines = proc.stdout.strip().splitlines()
    ok, codes = lines[-3].split(" ", 1)
    assert ok in {"True", "False"} and codes.startswith("[")
    jam, ci95 = lines[-2].split(" ", 1)
    lo, hi = ast.literal_eval(ci95)
    assert 0.0 <= lo <= float(jam) <= hi <= 1.0  # the estimate inside its interval
    written = ast.literal_eval(lines[-1])  # the paths the example printed
    assert any(w.endswith(".3mf") for w in written) and any(w.endswith(".stl") for w in written)
    assert all((tmp_path / w).is_file() for w in written), written
