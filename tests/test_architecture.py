"""The one-way data flow (docs/architecture.md): a module imports only from layers above
it, and the package's import graph has no cycle."""

import ast
from pathlib import Path

PKG = Path(__file__).resolve().parent.parent / "foldprint"

#: Layers from the top of the data flow down. A module may import from its own layer or
#: any earlier one, never a later one. Unlisted modules fail the test: place new ones.
LAYERS = [
    {"constants", "errors", "modes", "parallel", "schema", "guards"},
    {"materials"},
    {"recovery", "design", "crease_patterns"},
    {"design_io", "fold_format", "svg_format", "templates", "load", "recovery_table", "recovery_batch", "relief"},
    {"kinematics", "loops"},
    {"rigid", "goals", "motion"},
    {"collision2d", "collision3d"},
    {"simulate", "clearance"},
    {"scatter", "robust", "timing", "sensitivity", "paper_timings"},
    {"geometry"},
    {"checks", "report"},
    {"exchange", "render", "render3d", "render_scene", "render_anim", "viewer", "animation"},
    {"pipeline"},
    {"gallery", "assign", "distributed"},
    {"cli", "cli_support", "__main__"},
]
TOP = {"__init__"}  # the package facade re-exports; it may import anything below cli


def _layer(mod: str) -> int:
    head = mod.split(".")[0]
    for k, names in enumerate(LAYERS):
        if head in names:
            return k
    raise AssertionError(f"foldprint.{mod} is in no layer of tests/test_architecture.py: place it")


def _imports():
    """(module, imported module) for every relative import inside foldprint."""
    edges = []
    for path in PKG.rglob("*.py"):
        rel = path.relative_to(PKG).with_suffix("")
        parts = list(rel.parts)
        mod = ".".join(parts[:-1] if parts[-1] == "__init__" and len(parts) > 1 else parts)
        pkg_parts = parts[:-1]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = pkg_parts[: len(pkg_parts) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
                if target:
                    edges.append((mod, target))
                else:  # "from . import x": a module, or the package's own attribute (__version__)
                    edges += [(mod, a.name) for a in node.names if not a.name.startswith("__")]
    return edges


def test_no_upward_imports():
    bad = []
    for mod, target in _imports():
        if mod in TOP or target.split(".")[0] == "__init__" or target == "":
            continue
        if target.split(".")[0] == mod.split(".")[0]:
            continue  # inside one subpackage
        if _layer(target) > _layer(mod):
            bad.append(f"{mod} -> {target}")
    assert not bad, "upward imports: " + ", ".join(sorted(bad))


def test_no_import_cycles():
    graph: dict[str, set[str]] = {}
    for mod, target in _imports():
        a, b = mod.split(".")[0], target.split(".")[0]
        if a != b and a not in TOP and b not in TOP:
            graph.setdefault(a, set()).add(b)
    state: dict[str, int] = {}
    cycle: list[str] = []

    def visit(n, stack):
        state[n] = 1
        for m in graph.get(n, ()):
            if state.get(m) == 1:
                cycle.extend(stack[stack.index(m):] + [m] if m in stack else [n, m])
                return True
            if state.get(m) is None and visit(m, stack + [m]):
                return True
        state[n] = 2
        return False

    for n in list(graph):
        if state.get(n) is None and visit(n, [n]):
            break
    assert not cycle, "import cycle: " + " -> ".join(cycle)


def test_only_the_pipeline_chains_simulation_and_checks():
    """checks import no simulation or collision code; exchange imports no geometry builder."""
    for mod, target in _imports():
        if mod == "checks":
            assert target.split(".")[0] not in {"simulate", "collision3d", "collision2d", "robust", "kinematics"}, target
        if mod.startswith("exchange"):
            assert target not in {"geometry.assembly", "simulate", "pipeline"}, (mod, target)
