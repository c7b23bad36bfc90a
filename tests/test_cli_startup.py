"""The command line's start-up: ``foldprint --help`` and ``foldprint templates`` import no
numerical or geometry library and build no command they do not run
(:mod:`foldprint.cli.lazy`, :class:`foldprint.cli.root.LazyGroup`), and the help they print
is typer's own (an eagerly built app prints the same) and the checked-in snapshot
(``tests/data/cli_help``, ``scripts/cli_help_snapshot.py``). The time it takes is a
benchmark (``benchmarks/bench_startup.py``), not a test."""

from __future__ import annotations

import json
import subprocess
import sys
from importlib.metadata import version
from pathlib import Path

import pytest

from foldprint.cli.commands import main
from foldprint.cli.lazy import COMMANDS

ROOT = Path(__file__).resolve().parents[1]
HELP_DIR = ROOT / "tests" / "data" / "cli_help"
sys.path.insert(0, str(ROOT / "scripts"))
from cli_help_snapshot import COLUMNS, render  # noqa: E402

#: what a listing or a help page must not import: the numerical, geometry, plotting and
#: file-format libraries, the kernels' compiler (numba, llvmlite), and pydantic (typer >=
#: 0.29 coerces every option through it; pyproject.toml bounds typer below 0.29)
HEAVY = ("numpy", "numba", "llvmlite", "scipy", "shapely", "trimesh", "manifold3d", "fcl", "matplotlib", "meshio",
         "h5py", "PIL", "pygltflib", "pydantic", "starlette", "uvicorn", "anyio")

_PROBE = """
import contextlib, io, json, sys
from foldprint.cli.commands import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(sys.argv[1:])
print(json.dumps({"code": code, "modules": sorted(sys.modules)}))
"""


def _modules_after(*argv: str) -> tuple[int, set[str]]:
    """The exit code and every module loaded after ``foldprint ARGV`` in a fresh process."""
    out = subprocess.run([sys.executable, "-c", _PROBE, *argv], capture_output=True, text=True, timeout=120,
                         check=True)
    got = json.loads(out.stdout.strip().splitlines()[-1])
    return got["code"], set(got["modules"])


def _heavy(modules: set[str]) -> list[str]:
    return sorted({m.split(".")[0] for m in modules} & set(HEAVY))


@pytest.mark.parametrize("argv, runs", [(("--help",), None), (("templates",), "info_cmds"),
                                         (("templates", "--json"), "info_cmds"), (("--version",), None),
                                         (("simulate", "--help"), "fold_cmds")])
def test_startup_imports_no_heavy_library_and_only_the_command_that_runs(argv, runs):
    code, mods = _modules_after(*argv)
    assert code == 0
    assert not _heavy(mods), (f"foldprint {' '.join(argv)} imports {_heavy(mods)} (typer >= 0.29 brings "
                              "pydantic: pip install -e . installs the bounded typer)")
    cmd_modules = {m.rpartition(".")[2] for m in mods if m.startswith("foldprint.cli.")} & \
        {mod for mod, _ in COMMANDS.values()}
    assert cmd_modules == ({runs} if runs else set())
    assert "foldprint.model.design" not in mods and "foldprint.apps.pipeline" not in mods


def test_a_command_imports_what_it_needs():
    """The probe sees the imports of a command that does need numpy (a test of the test)."""
    code, mods = _modules_after("materials", "--json")
    assert code == 0 and "numpy" in _heavy(mods) and "foldprint.physics.recovery.curve" in mods


def test_every_command_is_in_the_table():
    """A command a module of foldprint/cli defines (``@app.command``) is in
    :data:`~foldprint.cli.lazy.COMMANDS` under its module, or ``foldprint`` never imports it
    (nothing else imports the command modules) and it is missing from ``--help``."""
    import ast
    import importlib

    found = {}
    for path in sorted((ROOT / "foldprint" / "cli").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef) and any(
                    isinstance(d, ast.Call) and isinstance(d.func, ast.Attribute) and d.func.attr == "command"
                    for d in node.decorator_list):
                found[node.name.replace("_", "-")] = path.stem
    # a front end above the command line (a dotted entry: foldprint.studio.command) defines its
    # function under the command's name, undecorated: the command line registers it
    fronts = {name: mod for name, (mod, _) in COMMANDS.items() if "." in mod}
    for name, mod in fronts.items():
        assert callable(getattr(importlib.import_module(mod), name.replace("-", "_"))), (mod, name)
    assert found == {name: mod for name, (mod, _) in COMMANDS.items() if name not in fronts}, (
        "foldprint/cli/lazy.py COMMANDS must list every command with its module (and each its summary: "
        "@app.command(short_help=summary(NAME)))")


def _eager_app():
    """The same app built the way typer builds any app: every command module imported,
    a plain TyperGroup, nothing lazy."""
    import importlib

    import typer

    from foldprint.cli.root import app, load_command

    order = list(COMMANDS)
    for name in COMMANDS:
        load_command(name)
    eager = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None, help=app.info.help)
    # in the table's order (the modules may have registered in another, as tests import them)
    eager.registered_commands = sorted(app.registered_commands, key=lambda c: order.index(c.callback.__name__))
    eager.registered_callback = app.registered_callback
    return eager


@pytest.mark.parametrize("command", [None, *COMMANDS])
def test_the_lazy_help_is_typers_own(command, monkeypatch):
    """Every help page, the root's included (its command list comes from the table), reads
    as typer prints it for the eagerly built app: same bytes."""
    import typer.main

    monkeypatch.setenv("COLUMNS", COLUMNS)
    args = [*([command] if command else []), "--help"]
    group = typer.main.get_command(_eager_app())
    assert type(group).__name__ == "TyperGroup"
    eager = _capture(lambda: group.main(args=args, prog_name="foldprint", standalone_mode=False))
    assert render([command] if command else []) == eager


def _capture(fn) -> str:
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        fn()
    return buf.getvalue()


def _snapshot_typer() -> str:
    return (HELP_DIR / "typer-version").read_text(encoding="utf-8").strip()


@pytest.mark.parametrize("command", [None, *COMMANDS])
def test_help_matches_the_snapshot(command):
    """Each help page is the checked-in one (scripts/cli_help_snapshot.py rewrites them
    after a deliberate change; the diff shows it). typer words metavars its own way in
    each version, so the pages are compared under the typer that rendered them."""
    if version("typer") != _snapshot_typer():
        pytest.skip(f"help snapshot rendered by typer {_snapshot_typer()}, this is typer {version('typer')}")
    name = command or "foldprint"
    assert render([command] if command else []) == (HELP_DIR / f"{name}.txt").read_text(encoding="utf-8")


def test_the_snapshot_covers_every_command():
    assert {p.stem for p in HELP_DIR.glob("*.txt")} == {"foldprint", *COMMANDS}


def test_summaries_fit_one_line_at_80_columns():
    """``foldprint --help`` lists each command on one line (no wrap, no "...")."""
    width = max(map(len, COMMANDS))
    for name, (_, text) in COMMANDS.items():
        assert "\n" not in text and 2 + width + 2 + len(text) <= 78, name
    help_text = render([])
    listed = help_text[help_text.index("Commands:"):].splitlines()[1:]
    assert [line.split()[0] for line in listed] == list(COMMANDS) and not any("..." in x for x in listed)


def test_a_mistyped_command_is_suggested_and_commands_import_by_name(capsys):
    """Every name is a key of the lazy table before any command is built, so typer's
    suggestion still sees them; ``from foldprint.cli.commands import check`` still works."""
    assert main(["chek"]) == 2
    assert "Did you mean 'check'?" in capsys.readouterr().err
    from foldprint.cli import commands

    assert commands.check.__module__ == "foldprint.cli.fold_cmds"
    with pytest.raises(AttributeError):
        commands.no_such_command  # noqa: B018
