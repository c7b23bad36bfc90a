"""Command line: a thin layer over the library.

Exit codes: 0 ok, 1 the design fails (collision, goal, rule), 2 bad input or usage,
3 an internal error (a bug, with a short report), 130 interrupted.
Machine output (``--json``) goes to stdout; human messages to stderr.

The commands live in one module per group (:mod:`~foldprint.cli.info_cmds`: materials,
templates; :mod:`~foldprint.cli.fold_cmds`: simulate, check, robust;
:mod:`~foldprint.cli.assign_cmd`: assign; :mod:`~foldprint.cli.output_cmds`: export,
gallery; :mod:`~foldprint.cli.calibrate_cmd`: calibrate), listed in :data:`~foldprint.cli.lazy.COMMANDS` (the order ``--help`` lists them);
a command's module is imported and its command built only when it runs
(:class:`~foldprint.cli.lazy.LazyGroup`), so ``foldprint --help`` and ``foldprint
templates`` start without numpy or the geometry libraries. :func:`main` and :func:`run`
are the entry points (:func:`run` ends the process without the interpreter's teardown,
:func:`leave`). Every command function still imports from here
(``from foldprint.cli.commands import check``).
"""

from __future__ import annotations

import sys

import typer

from ..core.errors import FoldprintError
from .lazy import COMMANDS
from .root import app
from .exits import ExitCode, click_errors, echo_err, internal_error
from .options import expand_multi


def __getattr__(name: str):
    """A command function by its name (``commands.check``), its module imported on first use."""
    if name in COMMANDS:
        from .root import load_command

        return getattr(load_command(name), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def main(argv: list[str] | None = None) -> int:
    """Entry point; returns the exit code (also used by the tests, in-process)."""
    args = expand_multi(list(sys.argv[1:] if argv is None else argv))
    _tolerant_output()
    try:
        rv = app(args=args, prog_name="foldprint", standalone_mode=False)
        return int(rv or 0)
    except ExitCode as e:
        return e.code
    except typer.Exit as e:
        return int(getattr(e, "exit_code", 0))
    except typer.Abort:
        echo_err("aborted")
        return 130
    except click_errors() as e:
        echo_err(e.format_message())
        return 2
    except FoldprintError as e:
        echo_err(str(e))
        return 2
    except KeyboardInterrupt:
        echo_err("interrupted")
        return 130
    except Exception as e:  # noqa: BLE001 -- a bug: exit 3 with a short report, never 1
        return internal_error(e, args)


def _tolerant_output() -> None:
    """A name the system gave as bytes that are not UTF-8 (a file or folder name, held as
    lone surrogates) is printed as those bytes (stdout) or escaped (stderr), never an
    error, whatever the locale's strictness. Text inside files never holds one: the schema
    refuses it (:func:`foldprint.core.schema.string`)."""
    for stream, errors in ((sys.stdout, "surrogateescape"), (sys.stderr, "backslashreplace")):
        if getattr(stream, "errors", None) == "strict" and hasattr(stream, "reconfigure"):
            stream.reconfigure(errors=errors)


def run() -> None:  # console script
    leave(main())


def leave(code: int) -> None:
    """End the process with ``code`` once its output is out, without the interpreter's
    teardown: collecting every module of numba, llvmlite, scipy and FCL took 0.25 CPU-s
    after ``check`` had printed (0.5-0.8 s wall on a loaded machine). Nothing of foldprint
    waits for it: a command has closed its pools and files, and its workers end with it
    (:func:`foldprint.core.parallel.die_with_parent`). Under coverage, a profiler or a
    tracer (which write their data at exit) the interpreter exits as usual."""
    import os

    if "coverage" in sys.modules or sys.getprofile() is not None or sys.gettrace() is not None:
        sys.exit(code)
    import logging

    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more can be said there
            pass
    os._exit(code)
