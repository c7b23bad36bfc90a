"""The command line's exit codes and errors: 0 ok, 1 the design fails, 2 bad input or a
refused run (one line naming the input), 3 a bug (a short report, never a verdict).
"""

from __future__ import annotations

import sys
from pathlib import Path

from typer import echo


def click_errors() -> tuple[type, ...]:
    """The ClickException classes of the click modules loaded (typer >= 0.26 vendors its
    own click, older typers use click's): only a loaded module can have raised one, so
    the handler imports nothing."""
    return tuple(sys.modules[mod].ClickException for mod in ("typer._click.exceptions", "click.exceptions")
                 if mod in sys.modules)


#: Exit codes: 0 ok, 1 the design fails, 2 bad input or a refused run, 3 an internal error
#: (a bug: never the design's verdict), 130 interrupted.
EXIT_OK, EXIT_FAILS, EXIT_INPUT, EXIT_INTERNAL = 0, 1, 2, 3


class ExitCode(Exception):
    def __init__(self, code: int):
        self.code = code


def echo_err(msg: str) -> None:
    echo(f"foldprint: error: {msg}", err=True)


def internal_error(exc: BaseException, argv: list[str]) -> int:
    """An exception no check anticipated: a short report on stderr, exit 3 (never 1, the
    code of a failing design, nor 2, which promises a message naming the input). The
    traceback is printed only with FOLDPRINT_TRACEBACK=1."""
    import os
    import traceback

    if isinstance(exc, MemoryError):
        echo_err(f"out of memory ({type(exc).__name__}): the run needed more than this machine gave it, beyond "
             "the resource guard's estimate; reduce the input or raise --dt (and please report the command)")
        return EXIT_INPUT
    frame = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
    at = f" at {Path(frame[0].filename).name}:{frame[0].lineno}" if frame else ""
    text = str(exc).splitlines()[0][:200] if str(exc) else ""
    echo_err(f"internal error: {type(exc).__name__}{at}: {text}")
    echo(f"foldprint: this is a bug in foldprint, not a verdict on the design (exit {EXIT_INTERNAL}); "
         f"please report it with the command `foldprint {' '.join(argv)[:300]}` and the input file"
         + ("" if os.environ.get("FOLDPRINT_TRACEBACK") else "; FOLDPRINT_TRACEBACK=1 prints the traceback"),
         err=True)
    if os.environ.get("FOLDPRINT_TRACEBACK"):
        echo("".join(traceback.format_exception(exc)), err=True)
    return EXIT_INTERNAL
