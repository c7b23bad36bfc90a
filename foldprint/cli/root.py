"""The ``foldprint`` Typer application and its root options (``--version``, ``--quiet``,
``--verbose``). The command groups register on :data:`app` when :mod:`foldprint.cli.commands`
imports them.
"""

from __future__ import annotations

import typer
from typer import echo

from .. import __version__
from .support import OUTPUT_STATE


app = typer.Typer(add_completion=False, no_args_is_help=True, rich_markup_mode=None,
                  help="foldprint: design, simulate, check and export sequentially self-folding "
                       "structures printed with digital shape-memory polymers.")


def _version(value: bool):
    if value:
        echo(f"foldprint {__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(version: bool = typer.Option(False, "--version", is_eager=True, callback=_version,
                                       help="Print the version and exit."),
          quiet: bool = typer.Option(False, "--quiet", "-q", help="Only errors and machine output."),
          verbose: bool = typer.Option(False, "--verbose", "-v", help="Log what foldprint does (stderr).")):
    """foldprint: design, simulate, check and export self-folding structures."""
    import logging

    OUTPUT_STATE["quiet"], OUTPUT_STATE["verbose"] = quiet, verbose
    if verbose and not quiet:
        logging.basicConfig(level=logging.INFO, format="foldprint: %(name)s: %(message)s")
