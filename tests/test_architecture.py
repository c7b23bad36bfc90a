"""The one-way data flow (docs/architecture.md).

The layer table in docs/architecture.md is the single source: its rows name each layer's
subpackage and every module in it, top of the data flow first. These tests check that the
table and the tree agree (no module missing, none invented), that a module imports only
from its own subpackage or one above it (relative, absolute, ``__import__`` and
``importlib.import_module`` imports alike), and that the module graph has no cycle.
"""

from __future__ import annotations

import ast
import re
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "foldprint"
DOC = ROOT / "docs" / "architecture.md"
TOP = {"foldprint", "foldprint.__main__"}  # the facade and the entry point may import anything;
# no module imports the facade (test_no_module_imports_the_facade)

_ROW = re.compile(r"^\|\s*(\d+)\s*\|\s*`(\w+)/`\s*\|\s*([^|]*)\|")


def layer_table() -> list[tuple[str, set[str]]]:
    """(subpackage, its modules) per row of the doc's layer table, in layer order."""
    rows = []
    for line in DOC.read_text(encoding="utf-8").splitlines():
        m = _ROW.match(line)
        if m:
            assert int(m.group(1)) == len(rows), f"docs/architecture.md: layer {m.group(1)} out of order"
            mods = {s.strip().strip("`") for s in m.group(3).split(",") if s.strip()}
            rows.append((m.group(2), mods))
    assert rows, "docs/architecture.md has no layer table"
    return rows


def module_name(path: Path) -> str:
    parts = ["foldprint", *path.relative_to(PKG).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {module_name(p): p for p in PKG.rglob("*.py")}


def _resolve(target: str, modules: dict[str, Path]) -> str | None:
    """The foldprint module a dotted name refers to (a name inside a module -> the module)."""
    while target and target not in modules:
        target = target.rpartition(".")[0]
    return target or None


def _from_module(pkg: str, node: ast.ImportFrom) -> str:
    """The absolute name of the module a ``from ... import`` reads, in package ``pkg``."""
    if node.level:
        base = pkg.split(".")[: len(pkg.split(".")) - (node.level - 1)]
        return ".".join(base + ([node.module] if node.module else []))
    return node.module or ""


def _is_package(name: str, modules) -> bool:
    return name in modules and Path(modules[name]).name == "__init__.py"


def reexports(pkg: str, modules, _seen: frozenset = frozenset()) -> dict[str, str]:
    """Each name package ``pkg``'s ``__init__`` imports from a foldprint module -> the module
    that defines it (followed through further packages' ``__init__``; a submodule imported
    by name maps to itself). The facade (``foldprint``) is not followed: no module may
    import it at all."""
    if pkg in TOP or not _is_package(pkg, modules) or pkg in _seen:
        return {}
    out = {}
    for node in ast.walk(ast.parse(Path(modules[pkg]).read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            head = _from_module(pkg, node)
            if not head.startswith("foldprint."):
                continue
            for a in node.names:
                full = f"{head}.{a.name}"
                out[a.asname or a.name] = full if full in modules else defining_module(
                    head, a.name, modules, _seen | {pkg})
    return out


def defining_module(head: str, name: str, modules, _seen: frozenset = frozenset()) -> str:
    """The module ``from head import name`` reaches: the submodule ``head.name``, else the
    module a package's ``__init__`` re-exports ``name`` from, else ``head`` itself."""
    if f"{head}.{name}" in modules:
        return f"{head}.{name}"
    return reexports(head, modules, _seen).get(name, head) if _is_package(head, modules) else head


def _whole_package(target: str, modules) -> list[str]:
    """A package imported as a whole (``import foldprint.geometry``, ``from .. import
    geometry``): the package and every module its ``__init__`` re-exports from."""
    r = _resolve(target, modules)
    if r is None or r != target or not _is_package(r, modules) or r in TOP:
        return [target]
    return [target, *sorted(set(reexports(r, modules).values()))]


def edges_of(mod: str, is_package: bool, src: str, modules) -> list[tuple[str, str]]:
    """(mod, imported foldprint module) for every import in one module's source, by
    resolved module: a name imported from a package's ``__init__`` counts as an import of
    the module that defines it, a package imported whole as one of each module its
    ``__init__`` re-exports."""
    pkg = mod if is_package else mod.rpartition(".")[0]
    edges = []
    for node in ast.walk(ast.parse(src)):
        targets: list[str] = []
        if isinstance(node, ast.ImportFrom):
            head = _from_module(pkg, node)
            targets = [defining_module(head, a.name, modules) for a in node.names] if head else []
            targets = [x for t in targets for x in _whole_package(t, modules)]
        elif isinstance(node, ast.Import):
            targets = [x for a in node.names for x in _whole_package(a.name, modules)]
        elif isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Constant) \
                and isinstance(node.args[0].value, str):
            fn = node.func
            name = fn.attr if isinstance(fn, ast.Attribute) else getattr(fn, "id", "")
            if name in {"__import__", "import_module"}:
                targets = [node.args[0].value]
        for t in targets:
            if t == "foldprint" or t.startswith("foldprint."):
                r = _resolve(t, modules)
                if r and r != mod:
                    edges.append((mod, r))
    return edges


def imports() -> list[tuple[str, str]]:
    """(importing module, imported foldprint module) for every import in the package.
    Walked once per test session (the tree does not change while the tests run; ten
    tests in three files read it, ~0.7 CPU-s a walk); each caller gets its own list."""
    return list(_import_edges())


@lru_cache(maxsize=1)
def _import_edges() -> tuple[tuple[str, str], ...]:
    modules = _modules()
    return tuple(e for mod, path in modules.items()
                 for e in edges_of(mod, path.name == "__init__.py", path.read_text(encoding="utf-8"), modules))


def _layer_of(mod: str, table) -> int:
    sub = mod.split(".")[1]
    for k, (name, _) in enumerate(table):
        if name == sub:
            return k
    raise AssertionError(f"{mod}: subpackage foldprint.{sub} is not in docs/architecture.md's layer table")


def layer_modules(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Layer subpackage -> its modules as the layer table names them: ``name`` for
    ``foldprint.<layer>.<name>``, ``wing/name`` for ``foldprint.<layer>.<wing>.<name>``. A
    wing is a subpackage inside a layer that groups one family of its modules; they count
    as the layer's, and the wing's ``__init__`` holds only its docstring (AssertionError
    for code there, for a module flat in ``foldprint/`` or one a wing deeper)."""
    tree: dict[str, set[str]] = {}
    for mod, path in modules.items():
        parts = mod.split(".")
        if len(parts) == 2 and mod not in TOP and path.name != "__init__.py":
            raise AssertionError(f"{mod} sits flat in foldprint/: put it in its layer's subpackage")
        if len(parts) > 4 or (len(parts) == 4 and path.name == "__init__.py"):
            raise AssertionError(f"{mod}: a wing inside a wing; a layer's wings are one level deep")
        if len(parts) == 3 and path.name == "__init__.py":
            body = [n for n in ast.parse(path.read_text(encoding="utf-8")).body
                    if not (isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant))
                    and not (isinstance(n, ast.ImportFrom) and n.module == "__future__")]
            assert not body, f"{mod}: a wing's __init__ holds its docstring only (its modules hold the code)"
        elif len(parts) >= 3:
            tree.setdefault(parts[1], set()).add("/".join(parts[2:]))
    return tree


def test_the_layer_table_is_the_tree():
    table = layer_table()
    tree = layer_modules(_modules())
    documented = {name: mods for name, mods in table}
    assert set(documented) == set(tree), (sorted(set(documented) ^ set(tree)), "subpackages differ")
    for name, mods in tree.items():
        assert documented[name] == mods, (
            f"docs/architecture.md layer {name}/ lists {sorted(documented[name])}, the tree has {sorted(mods)}")


def test_a_wings_modules_count_as_its_layers(tmp_path):
    """``foldprint.apps.wing.page`` is the apps layer's ``wing/page``; the wing's
    ``__init__`` with code, a wing inside a wing and a flat module are refused (a test of
    the test)."""
    doc, init, code = tmp_path / "doc.py", tmp_path / "__init__.py", tmp_path / "code" / "__init__.py"
    code.parent.mkdir()
    doc.write_text("X = 1\n")
    init.write_text('"""A wing."""\n\nfrom __future__ import annotations\n')
    code.write_text('"""A wing."""\nX = 1\n')
    mods = {"foldprint.apps": init, "foldprint.apps.chain": doc, "foldprint.apps.wing": init,
            "foldprint.apps.wing.page": doc, "foldprint.physics.fam.part": doc}
    assert layer_modules(mods) == {"apps": {"chain", "wing/page"}, "physics": {"fam/part"}}
    for bad in ({"foldprint.apps.wing": code}, {"foldprint.apps.wing.page.deep": doc},
                {"foldprint.apps.wing.page": init}, {"foldprint.flat": doc}):
        with pytest.raises(AssertionError):
            layer_modules({**mods, **bad})


def test_no_upward_imports():
    table = layer_table()
    bad = [f"{a} -> {b}" for a, b in imports()
           if a not in TOP and b not in TOP and _layer_of(b, table) > _layer_of(a, table)]
    assert not bad, "upward imports: " + ", ".join(sorted(bad))


def test_no_import_cycles():
    graph: dict[str, set[str]] = {}
    for a, b in imports():
        if a not in TOP and b not in TOP and not b.startswith(a + "."):
            graph.setdefault(a, set()).add(b)
    done: set[str] = set()

    def visit(n, stack):
        if n in stack:
            raise AssertionError("import cycle: " + " -> ".join(stack[stack.index(n):] + [n]))
        if n in done:
            return
        for m in graph.get(n, ()):
            visit(m, stack + [n])
        done.add(n)

    for n in list(graph):
        visit(n, [])


def test_only_the_pipeline_chains_simulation_and_checks():
    """checks compute nothing (no simulation, collision or kinematics); exchange builds nothing."""
    for a, b in imports():
        if a.startswith("foldprint.checks."):
            assert not b.startswith(("foldprint.simulation", "foldprint.collision",
                                     "foldprint.physics.kinematics")), (a, b)
        if a.startswith("foldprint.exchange."):
            assert b not in {"foldprint.geometry.assembly"} and not b.startswith(
                ("foldprint.simulation", "foldprint.apps")), (a, b)


#: What ``exchange/`` may import besides itself: the
#: writers format what they are given (writers that only write: no stage runs in them). ``io`` is
#: needed: the 3MF and FOLD files embed the design (``io.design_io.design_to_dict``), and
#: the FOLD writer shares the reader's tables and helpers (``io.fold_format``) and
#: re-exports the reader beside it. Never ``physics`` or ``simulation``, not even for a type.
EXCHANGE_MAY_IMPORT = ("core", "model", "io", "geometry")


def test_writers_import_no_physics_or_simulation():
    allowed = tuple(f"foldprint.{p}." for p in ("exchange", *EXCHANGE_MAY_IMPORT))
    bad = [f"{a} -> {b}" for a, b in imports()
           if a.startswith("foldprint.exchange.") and not (b + ".").startswith(allowed)]
    assert not bad, ("exchange/ imports outside core, model, io and geometry (hand the writer what it "
                     "writes instead): " + ", ".join(sorted(bad)))


def test_no_module_imports_the_facade():
    """``foldprint/__init__.py`` is the library's face for its users; it reaches every layer,
    so a module importing it (even for ``__version__``: that is ``core.version``) would
    import upward past the layer table. Only the entry point ``__main__`` may."""
    bad = [a for a, b in imports() if b == "foldprint" and a not in TOP]
    assert not bad, ("modules import the foldprint facade (import what they need from its layer; the "
                     "version from foldprint.core.version): " + ", ".join(sorted(set(bad))))


def test_the_walker_sees_a_facade_import_in_every_form():
    """``from .. import __version__``, ``import foldprint``, ``from foldprint import X`` and
    ``__import__('foldprint')`` reach the facade; ``from .. import geometry`` reaches the
    subpackage and every module its ``__init__`` re-exports (a test of the test)."""
    modules = _modules()
    for src in ("from .. import __version__\n", "import foldprint\n", "from foldprint import load_design\n",
                "__import__('foldprint')\n", "from ... import strip\n"):
        mod = "foldprint.exchange.sub.fake" if src.startswith("from ...") else "foldprint.exchange.fake"
        assert {b for _, b in edges_of(mod, False, src, modules)} == {"foldprint"}, src
    assert {b for _, b in edges_of("foldprint.apps.fake", False, "from .. import geometry\n", modules)} \
        == {"foldprint.geometry", *(f"foldprint.geometry.{m}" for m in ("assembly", "bed", "hinges", "layout",
                                                                         "solids"))}


#: Modules whose leading-underscore names other modules of their own subpackage may still
#: import, each with its reason (empty: cli.support's plumbing, apps.assign.search's ledger and
#: hinge graph and the split modules' helpers were given public names).
PRIVATE_IMPORT_ALLOWLIST: dict[str, str] = {}


def private_imports(mod: str, is_package: bool, src: str, modules) -> list[tuple[str, str, int]]:
    """(source module, name, line) for every leading-underscore name ``mod`` takes from
    another foldprint module: ``from X import _name`` and ``X._name`` on a module bound
    by an import (dunder names such as ``__version__`` are public)."""
    pkg = mod if is_package else mod.rpartition(".")[0]
    out, bound = [], {}
    tree = ast.parse(src)
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            head = _from_module(pkg, node)
            if not (head == "foldprint" or head.startswith("foldprint.")):
                continue
            for a in node.names:
                full = f"{head}.{a.name}"
                if full in modules:  # a module imported by name
                    bound[a.asname or a.name] = full
                if a.name.startswith("_") and not a.name.startswith("__"):
                    src_mod = _resolve(full if full in modules else head, modules)
                    if src_mod != mod:
                        out.append((src_mod, a.name, node.lineno))
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.asname and a.name in modules:
                    bound[a.asname] = a.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id in bound \
                and node.attr.startswith("_") and not node.attr.startswith("__") and bound[node.value.id] != mod:
            out.append((bound[node.value.id], node.attr, node.lineno))
    return out


def test_no_module_imports_another_modules_private_names():
    """A name with a leading underscore belongs to its module: another module that needs
    it gets a public name (or a shared module), not the private one."""
    modules = _modules()
    bad = []
    for mod, path in sorted(modules.items()):
        for src_mod, name, line in private_imports(mod, path.name == "__init__.py",
                                                  path.read_text(encoding="utf-8"), modules):
            same_package = src_mod.rpartition(".")[0] == mod.rpartition(".")[0]
            if not (src_mod in PRIVATE_IMPORT_ALLOWLIST and same_package):
                bad.append(f"{path.relative_to(ROOT)}:{line} {name} of {src_mod}")
    assert not bad, "private names imported across modules (give them a public name): " + ", ".join(bad)


def test_the_private_import_walker_sees_every_form():
    """Relative and absolute from-imports and attributes of an imported module count;
    dunder names, the module's own names and other packages do not (a test of the test)."""
    modules = _modules()
    src = ("from ..io.fold_format import _ring_edges, LINE_TOL\nfrom foldprint.geometry.solids import _clean\n"
           "from .. import __version__\nfrom . import fem as F\nimport foldprint.physics.recovery.curve as rec\n"
           "from numpy import _private\nx = F._levels(1) + rec._grid(2) + F.ELEMENT_SIZE_MM\n")
    got = {(m, n) for m, n, _ in private_imports("foldprint.exchange.fake", False, src, modules)}
    assert got == {("foldprint.io.fold_format", "_ring_edges"), ("foldprint.geometry.solids", "_clean"),
                   ("foldprint.exchange.fem", "_levels"), ("foldprint.physics.recovery.curve", "_grid")}
    assert private_imports("foldprint.exchange.fem", False, "from .fem import _levels\n", modules) == []


def test_the_import_walker_sees_every_form():
    """Relative, absolute and dynamic imports all count (a test of the test)."""
    modules = _modules()
    src = ("from ..core import errors\nfrom .rules import run_checks\nimport foldprint.model.design\n"
           "from foldprint.physics.recovery.curve import fold_time\n__import__('foldprint.apps.pipeline')\n"
           "importlib.import_module('foldprint.render.figures')\nfrom . import report\n")
    got = {b for _, b in edges_of("foldprint.checks.fake", False, src, modules)}
    assert got == {"foldprint.core.errors", "foldprint.checks.rules", "foldprint.model.design",
                   "foldprint.physics.recovery.curve", "foldprint.apps.pipeline", "foldprint.render.figures",
                   "foldprint.checks.report"}


#: The longest a function may be (lines from ``def`` to its last line, signature and
#: docstring included): a function that fits on a screen is read whole.
MAX_FUNCTION_LINES = 80
#: Functions over the limit, each as (module, qualified name) with the reason it is still
#: here in a comment. Empty: keep it so, a split is the way out.
LONG_FUNCTION_ALLOWLIST: set[tuple[str, str]] = set()


def long_functions(src: str, limit: int = MAX_FUNCTION_LINES) -> list[tuple[str, int, int]]:
    """(qualified name, first line, length) of every function or method in ``src`` longer
    than ``limit`` lines, nested ones included."""
    out = []

    def walk(node, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = child.end_lineno - child.lineno + 1
                if length > limit:
                    out.append((prefix + child.name, child.lineno, length))
                walk(child, prefix + child.name + ".")
            elif isinstance(child, ast.ClassDef):
                walk(child, prefix + child.name + ".")
            else:
                walk(child, prefix)

    walk(ast.parse(src), "")
    return out


def test_no_function_over_80_lines():
    """Every function of the package fits in 80 lines, but for the allowlisted ones
    (:data:`LONG_FUNCTION_ALLOWLIST`, empty)."""
    bad = []
    for mod, path in sorted(_modules().items()):
        for name, line, length in long_functions(path.read_text(encoding="utf-8")):
            if (mod, name) not in LONG_FUNCTION_ALLOWLIST:
                bad.append(f"{path.relative_to(ROOT)}:{line} {name} ({length} lines)")
    assert not bad, f"functions over {MAX_FUNCTION_LINES} lines (split them into named steps): " + ", ".join(bad)


def test_the_length_walker_sees_methods_and_nested_functions():
    """A long method or nested function counts as well as a top-level one (a test of the test)."""
    body = "".join(f"    x{k} = {k}\n" for k in range(80))
    src = (f"def short():\n    return 1\n\ndef long_one():\n{body}\n"
           f"class C:\n    def method(self):\n{body.replace('    ', '        ')}\n"
           f"def outer():\n    def inner():\n{body.replace('    ', '        ')}\n    return inner\n")
    got = {(name, length) for name, _, length in long_functions(src)}
    assert got == {("long_one", 81), ("C.method", 81), ("outer", 84), ("outer.inner", 81)}  # outer: def, inner, a blank line, return


#: The longest a module of foldprint/ may be (lines of the file): a module that fits is read whole.
MAX_MODULE_LINES = 600
#: Modules over the limit, each mapped to the reason it is still here (empty: none may be).
LONG_MODULE_ALLOWLIST: dict[str, str] = {}


def long_modules(limit: int = MAX_MODULE_LINES) -> list[tuple[str, int]]:
    """(module, lines) of every module of the package longer than ``limit`` lines."""
    out = []
    for mod, path in sorted(_modules().items()):
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > limit:
            out.append((mod, n))
    return out


def test_no_module_over_600_lines():
    """Every module of foldprint/ fits in 600 lines, but for the allowlisted ones: a longer
    one is split along a seam into modules named for what they hold (and put in the
    layer table)."""
    stale = sorted(set(LONG_MODULE_ALLOWLIST) - set(_modules()))
    assert not stale, f"LONG_MODULE_ALLOWLIST names modules that do not exist: {stale}"
    bad = [f"{mod} ({n} lines)" for mod, n in long_modules() if mod not in LONG_MODULE_ALLOWLIST]
    assert not bad, f"modules over {MAX_MODULE_LINES} lines (split them along a seam): " + ", ".join(bad)
    assert long_modules(limit=100), "the walker found no module over 100 lines: it reads nothing"
