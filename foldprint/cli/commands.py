"""Command line: a thin layer over the library.

Exit codes: 0 ok, 1 the design fails (collision, goal, rule), 2 bad input or usage,
3 an internal error (a bug, with a short report), 130 interrupted.
Machine output (``--json``) goes to stdout; human messages to stderr.

The commands live in one module per group (:mod:`~foldprint.cli.info_cmds`: materials,
templates; :mod:`~foldprint.cli.fold_cmds`: simulate, check, robust;
:mod:`~foldprint.cli.assign_cmd`: assign; :mod:`~foldprint.cli.output_cmds`: export,
gallery), registered on :mod:`~foldprint.cli.root`'s ``app`` in that order (the order
``--help`` lists them) when this module imports them; :func:`main` and :func:`run` are the
entry points. Every command function still imports from here.
"""

from __future__ import annotations

import sys

import typer

from ..core.errors import FoldprintError
from .root import app
from .support import ExitCode, CLICK_ERRORS, echo_err, expand_multi, internal_error

# the command groups, imported in the order --help lists their commands (they register on app)
from .info_cmds import materials, templates  # noqa: F401,I001
from .fold_cmds import check, robust, simulate  # noqa: F401
from .assign_cmd import assign  # noqa: F401
from .output_cmds import export, gallery  # noqa: F401


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
    except CLICK_ERRORS as e:
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
    sys.exit(main())
