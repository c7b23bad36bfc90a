"""The door every front end's inputs come in through (foldprint.apps.resolve): a refusal
names the input as the caller names it (a notebook: the input's own name; the command
line: its option, so its messages read as before), and a resolved input is the one the
command line evaluates."""

from __future__ import annotations

import pytest

from foldprint.apps import resolve
from foldprint.core.errors import FoldprintError
from foldprint.cli.commands import main


@pytest.mark.parametrize("call, message", [
    (lambda: resolve.check_temperature(600.0), r"^temperature must be in \[-100, 500\] deg C, got 600\.0$"),
    (lambda: resolve.time_options(None, 0.0), r"^dt must be in \[1e-06, 100\] s, got 0\.0$"),
    (lambda: resolve.time_options(-1.0, 0.01), r"^duration must be in \(0, 1e\+12\] s, got -1\.0$"),
    (lambda: resolve.check_seed(-1), r"^seed must be >= 0, got -1$"),
    (lambda: resolve.thresholds(1.5, 0.05), r"^error_above must be a probability between 0 and 1, got 1\.5$"),
    (lambda: resolve.thresholds(0.2, -0.1), r"^warn_above must be a probability between 0 and 1, got -0\.1$"),
    (lambda: resolve.check_thickness(0.0), r"^thickness must be in \[0\.001, 10000\] mm, got 0\.0$"),
    (lambda: resolve.load_input("helix_graded", scale=-2.0), r"^scale must be in \(0, 1e\+06\] mm per file unit"),
    (lambda: resolve.check_count(0, "samples", 1, resolve.MAX_SAMPLES), r"^samples must be a whole number in"),
])
def test_a_refusal_names_the_input(call, message):
    with pytest.raises(FoldprintError, match=message):
        call()


@pytest.mark.parametrize("argv, line", [
    (["simulate", "helix_graded", "--temperature", "600"], "--temperature must be in [-100, 500] deg C, got 600.0"),
    (["simulate", "helix_graded", "--dt", "0"], "--dt must be in [1e-06, 100] s, got 0.0"),
    (["check", "helix_graded", "--error-above", "1.5"], "--error-above must be a probability between 0 and 1"),
    (["robust", "helix_graded", "--seed", "-1"], "--seed must be >= 0, got -1"),
])
def test_the_command_line_passes_its_option_names(argv, line, capsys):
    """The same functions at the command line: exit 2, one line naming the option."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and line in err, err


def test_a_resolved_design_is_the_loaders():
    """``load_input`` reads a template by name as the loader reads its path, with the
    library it returns (the shipped one plus the files given)."""
    from foldprint.io.design_io import design_to_dict
    from foldprint.io.load import load_design
    from foldprint.io.templates import resolve_design_path
    from foldprint.model.materials import default_library

    d, lib = resolve.load_input("helix_graded")
    assert design_to_dict(d) == design_to_dict(load_design(resolve_design_path("helix_graded"), default_library()))
    assert [m.name for m in lib] == [m.name for m in default_library()]
    assert [design_to_dict(x) for x in resolve.load_designs(["helix_graded"], lib)] == [design_to_dict(d)]
    key, printer = resolve.load_printer()
    assert printer.name and key == resolve.load_printer(key)[0]
    with pytest.raises(FoldprintError, match="unknown"):
        resolve.load_printer("no_such_printer")
    assert resolve.sigma_scales("2,0.5,2") == (0.5, 2.0)
