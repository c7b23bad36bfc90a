"""Write every command's ``--help`` (80 columns) to ``tests/data/cli_help/<command>.txt``
(``foldprint.txt`` for ``foldprint --help``) and the typer version that rendered it to
``tests/data/cli_help/typer-version``. tests/test_cli_startup.py compares the command line's
help against these files, so a change of a help text shows in review as a diff of them.
Run it after changing a help text on purpose: ``python scripts/cli_help_snapshot.py``."""

from __future__ import annotations

import contextlib
import io
import os
from importlib.metadata import version
from pathlib import Path

HELP_DIR = Path(__file__).resolve().parents[1] / "tests" / "data" / "cli_help"
#: the terminal width the snapshots are rendered at (click wraps help text at most at 80)
COLUMNS = "80"


def render(command: list[str]) -> str:
    """``foldprint <command> --help`` as printed at :data:`COLUMNS` columns, in-process."""
    from foldprint.cli.commands import main

    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = COLUMNS
    buf = io.StringIO()
    try:
        with contextlib.redirect_stdout(buf):
            code = main([*command, "--help"])
    finally:
        if before is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = before
    assert code == 0, f"foldprint {' '.join(command)} --help exited {code}"
    return buf.getvalue()


def command_names() -> list[str]:
    from foldprint.cli.lazy import COMMANDS

    return list(COMMANDS)


def main() -> None:
    HELP_DIR.mkdir(parents=True, exist_ok=True)
    (HELP_DIR / "foldprint.txt").write_text(render([]), encoding="utf-8")
    for name in command_names():
        (HELP_DIR / f"{name}.txt").write_text(render([name]), encoding="utf-8")
    (HELP_DIR / "typer-version").write_text(version("typer") + "\n", encoding="utf-8")
    print(f"wrote {HELP_DIR} (typer {version('typer')})")


if __name__ == "__main__":
    main()
