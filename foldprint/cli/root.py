"""The ``foldprint`` Typer application, its root options (``--version``, ``--quiet``,
``--verbose``) and its group class: a command registers on :data:`app` when its module is
imported, which :class:`LazyGroup` does when the command runs.
"""

from __future__ import annotations

import importlib

import typer
from typer import echo
from typer.core import TyperGroup

from ..core.version import __version__
from .lazy import COMMANDS, LazyCommands, module_name, summary
from .printing import OUTPUT_STATE


class LazyGroup(TyperGroup):
    """typer's group whose commands are a :class:`~foldprint.cli.lazy.LazyCommands`:
    ``--help`` lists the table's summaries, a command is imported and built when invoked."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.commands = LazyCommands(self.commands, build_command)

    def list_commands(self, ctx) -> list[str]:
        return list(self.commands)

    def format_commands(self, ctx, formatter) -> None:
        """The commands section of ``foldprint --help`` from the table alone: what typer
        prints for commands whose ``short_help`` is their summary."""
        rows = [(name, summary(name)) for name in self.commands if name in COMMANDS]
        if rows:
            with formatter.section("Commands"):
                formatter.write_dl(rows)


def build_command(name: str):
    """The click command of ``name``: its module imported (its decorators register it on
    :data:`app`), then typer builds the group of the commands registered so far."""
    import typer.main

    load_command(name)
    built = typer.main.get_command(app).commands
    built = built.built if isinstance(built, LazyCommands) else built
    if name not in built:
        raise LookupError(f"{__package__}.{COMMANDS[name][0]} registers no command {name!r}")
    return built[name]


def load_command(name: str):
    """Import the module of command ``name``; a front end's function (a dotted entry of
    :data:`COMMANDS`) is registered on :data:`app` here, once. Returns the module."""
    entry = COMMANDS[name][0]
    mod = importlib.import_module(module_name(entry))
    if "." in entry:
        fn = getattr(mod, name)
        if not any(c.callback is fn for c in app.registered_commands):
            app.command(name, short_help=summary(name))(fn)
    return mod


app = typer.Typer(cls=LazyGroup, add_completion=False, no_args_is_help=True, rich_markup_mode=None,
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
