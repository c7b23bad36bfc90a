"""What never imports what (docs/architecture.md's second table), by resolved module: a
name imported through a package's ``__init__`` counts as an import of the module that
defines it. Each rule fails on a planted import (a test of the test), and the command line
imports nothing of foldprint but ``apps``, ``core`` and itself (the one door)."""

from __future__ import annotations

import re

import pytest

from test_architecture import DOC, EXCHANGE_MAY_IMPORT, _modules, edges_of, imports


_NEVER_ROW = re.compile(r"^\|\s*`([\w.]+)`\s*\|\s*(only\s+)?((?:`[\w.]+`(?:,\s*)?)+)\s*\|")


def never_rules() -> list[tuple[str, bool, tuple[str, ...]]]:
    """(importer, ``only``, packages or modules) per row of the doc's "What never imports
    what" table: with ``only`` False the importer never imports these (prefixes); with
    True it imports nothing of foldprint but these and itself."""
    text = DOC.read_text(encoding="utf-8")
    section = text.split("## What never imports what", 1)[1].split("\n## ", 1)[0]
    rules = []
    for line in section.splitlines():
        m = _NEVER_ROW.match(line)
        if m:
            rules.append((m.group(1), bool(m.group(2)), tuple(re.findall(r"`([\w.]+)`", m.group(3)))))
    assert rules, "docs/architecture.md has no 'What never imports what' table"
    return rules


def _within(mod: str, prefix: str) -> bool:
    full = f"foldprint.{prefix}"
    return mod == full or mod.startswith(full + ".")


def never_violations(edges, rules) -> list[str]:
    """Every edge a rule refuses, as "rule: importer -> imported"."""
    bad = []
    for a, b in edges:
        for src, only, names in rules:
            if not _within(a, src):
                continue
            if only:
                refused = not any(_within(b, n) for n in (src, *names))
            else:
                refused = any(_within(b, n) for n in names)
            if refused:
                kind = f"only {', '.join(names)}" if only else f"never {', '.join(names)}"
                bad.append(f"{src} {kind}: {a} -> {b}")
    return bad


def test_the_never_table_holds_the_rules():
    """The table names at least the rules the architecture promises (a row deleted by
    mistake would silently lift one): the checks compute nothing, the writers only write,
    the geometry folds nothing, the renderers neither write nor fold, the CLI enters
    through apps."""
    rules = never_rules()
    never = {(src, n) for src, only, names in rules if not only for n in names}
    only = {src: set(names) for src, o, names in rules if o}
    for pair in [("geometry", "simulation"), ("geometry", "collision"), ("render", "exchange"),
                 ("render", "simulation"), ("exchange", "geometry.assembly"), ("checks", "simulation")]:
        assert pair in never, pair
    assert only.get("cli") == {"apps", "core"} and only.get("exchange") == set(EXCHANGE_MAY_IMPORT)


def test_nothing_imports_what_the_never_table_refuses():
    bad = never_violations(imports(), never_rules())
    assert not bad, "imports docs/architecture.md's 'What never imports what' refuses: " + "; ".join(sorted(bad))


@pytest.mark.parametrize("mod, src", [
    ("foldprint.geometry.fake", "from ..simulation.robust import jam_probability\n"),
    ("foldprint.geometry.fake", "from ..simulation import robust\n"),
    ("foldprint.geometry.fake", "def f():\n    from ..collision import swept3d\n"),
    ("foldprint.geometry.fake", "import foldprint.collision.rigid\n"),
    ("foldprint.render.fake", "from ..exchange.stl import write_stl\n"),
    ("foldprint.render.fake", "import foldprint.exchange\n"),
    ("foldprint.render.fake", "def f():\n    from ..simulation.simulate import simulate\n"),
    ("foldprint.exchange.fake", "from ..geometry import build_assembly\n"),  # through geometry's __init__
    ("foldprint.exchange.fake", "from .. import geometry\n"),  # the package whole: its builder too
    ("foldprint.exchange.fake", "from ..physics.recovery import fold_time\n"),
    ("foldprint.checks.fake", "from ..simulation.simulate import simulate\n"),
    ("foldprint.cli.fake", "from ..io.load import load_design\n"),
    ("foldprint.cli.fake", "def f():\n    from ..checks.report import percent\n"),  # a lazy import
    ("foldprint.cli.fake", "importlib.import_module('foldprint.model.materials')\n"),
])
def test_a_planted_import_breaks_a_never_rule(mod, src):
    """Each rule of the table fails on an import planted in a module's source, directly,
    through a package's ``__init__`` or inside a function (a test of the test)."""
    edges = edges_of(mod, False, src, _modules())
    assert never_violations(edges, never_rules()), (mod, src, edges)


@pytest.mark.parametrize("mod, src", [
    ("foldprint.exchange.fake", "from ..geometry import Assembly, bed_report\n"),  # the built part, its report
    ("foldprint.cli.fake", "from ..apps.pipeline import Evaluation\nfrom ..core.errors import FoldprintError\n"
                           "from .printing import echo_json\n"),
    ("foldprint.render.fake", "from ..geometry.surfaces import Frames\nfrom ..physics.kinematics import forward\n"),
    ("foldprint.geometry.fake", "from ..physics.kinematics import forward\nfrom ..model.design import Design\n"),
])
def test_an_allowed_import_passes_the_never_rules(mod, src):
    """What the rules allow passes them (the planted failures above are not the walker
    refusing everything)."""
    assert never_violations(edges_of(mod, False, src, _modules()), never_rules()) == []


def test_names_through_a_package_init_resolve_to_their_module():
    """``from ..geometry import build_assembly`` is an import of ``geometry.assembly``,
    ``Assembly`` of ``geometry.solids``; a submodule imported by name is itself."""
    modules = _modules()
    got = {b for _, b in edges_of("foldprint.exchange.fake", False,
                                  "from ..geometry import build_assembly, Assembly, surfaces\n", modules)}
    assert got == {"foldprint.geometry.assembly", "foldprint.geometry.solids", "foldprint.geometry.surfaces"}


def test_the_cli_imports_only_apps_and_core():
    """The door (docs/architecture.md, "One door"): every module of foldprint/cli, lazy
    imports inside functions included, imports nothing of foldprint but ``apps``, ``core``
    and ``cli``; checked by resolved module."""
    bad = [f"{a} -> {b}" for a, b in imports() if a.startswith("foldprint.cli.")
           and not any(_within(b, p) for p in ("apps", "core", "cli"))]
    assert not bad, "the CLI reaches past apps and core: " + ", ".join(sorted(bad))
    assert any(a.startswith("foldprint.cli.") and _within(b, "apps") for a, b in imports())
