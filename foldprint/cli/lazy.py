"""The command table and the mapping that builds a command on its first lookup.

``foldprint --help`` lists every command from :data:`COMMANDS` (its name and one-line
summary) without importing a command module; ``foldprint check ...`` imports
:mod:`~foldprint.cli.fold_cmds` alone and builds the ``check`` command alone (typer builds
a command's parameters when it builds the command; a module imports what its commands
need at module level). The summaries are also each command's ``short_help``, so typer's
own listing of the commands (an eagerly built app) prints the same lines. The group that
uses the mapping is :class:`foldprint.cli.root.LazyGroup`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, MutableMapping

#: every command, in the order ``foldprint --help`` lists them: the module that defines it
#: (in this package) and its one-line summary
COMMANDS: dict[str, tuple[str, str]] = {
    "materials": ("info_cmds", "Each material's Tg and its hinge fold time per bath temperature."),
    "templates": ("info_cmds", "List the shipped design templates."),
    "simulate": ("fold_cmds", "Fold a design once as designed: hinges, contacts, clearance."),
    "check": ("fold_cmds", "Design rules and the jam test under scatter, before printing."),
    "robust": ("fold_cmds", "Jam probability from a fixed number of scattered folds."),
    "assign": ("assign_cmd", "Choose the hinge materials (and bath) under which it folds."),
    "export": ("output_cmds", "Write the printable part: 3MF, STL and a print recipe."),
    "gallery": ("output_cmds", "Simulate, check and export designs into an offline HTML page."),
    "calibrate": ("calibrate_cmd", "Fit the hinge recovery model to measurements: a materials file."),
    "studio": ("foldprint.studio.command", "Edit a design in the browser: re-fold, clearance, jam verdict."),
}


def module_name(entry: str) -> str:
    """The module a :data:`COMMANDS` entry names: a module of this package by its short
    name, or a front end above the command line (``foldprint.studio.command``) by its full
    name; such a module defines the command's function under the command's name and the
    command line registers it (it imports nothing of the command line)."""
    return entry if "." in entry else f"{__package__}.{entry}"


def summary(name: str) -> str:
    """The one-line summary of command ``name`` (its ``short_help``)."""
    return COMMANDS[name][1]


class LazyCommands(MutableMapping):
    """The root group's commands by name: every name of :data:`COMMANDS` is a key, a
    command is built (``build(name)``) on its first lookup; ``keys()`` and ``in`` build
    nothing, so typer's "Did you mean ...?" sees every name."""

    def __init__(self, built, build: Callable[[str], object]):
        self.built = dict(built or {})
        self.build = build

    def __getitem__(self, name: str):
        if name not in self.built:
            if name not in COMMANDS:
                raise KeyError(name)
            self.built[name] = self.build(name)
        return self.built[name]

    def __setitem__(self, name: str, command) -> None:
        self.built[name] = command

    def __delitem__(self, name: str) -> None:
        del self.built[name]

    def __iter__(self) -> Iterator[str]:
        yield from COMMANDS
        yield from (n for n in self.built if n not in COMMANDS)

    def __len__(self) -> int:
        return len(COMMANDS) + sum(n not in COMMANDS for n in self.built)

    def __contains__(self, name) -> bool:
        return name in COMMANDS or name in self.built
