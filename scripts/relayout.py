"""Move foldprint's flat modules into subpackages that are its layers.

One-off, kept for the record and for branches that still use the flat layout: run it on a
checkout in the flat layout (``python scripts/relayout.py``) and it

1. ``git mv``s every flat module to its subpackage (``MOVES``),
2. rewrites every import inside the package (relative imports stay relative, recomputed
   for the new locations; ``from . import a, b`` is split per subpackage),
3. rewrites ``foldprint.<old>`` references and ``from foldprint import <old>`` lines in
   tests, benchmarks, scripts, examples, docs and the README,
4. fixes the few ``__file__``-relative paths.

It refuses to run twice (the flat modules must exist). Behaviour is unchanged: the export
hashes and the JSON of every template are compared before and after by
``scripts/layout_fingerprint.py``.
"""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "foldprint"

#: flat module -> new dotted path below foldprint (subpackages in data-flow order)
MOVES = {
    # core: leaf utilities every layer may use
    "constants": "core.constants", "errors": "core.errors", "modes": "core.modes",
    "parallel": "core.parallel", "schema": "core.schema", "guards": "core.guards",
    # model: materials and the design itself
    "materials": "model.materials", "design": "model.design",
    "crease_patterns": "model.crease_patterns", "relief": "model.relief",
    # io: files in (TOML, FOLD, SVG) -> Design
    "design_io": "io.design_io", "fold_format": "io.fold_format", "svg_format": "io.svg_format",
    "load": "io.load", "templates": "io.templates",
    # physics: hinge recovery and the kinematics it drives
    "recovery": "physics.recovery", "recovery_table": "physics.recovery_table",
    "recovery_batch": "physics.recovery_batch",
    "kinematics": "physics.kinematics", "loops": "physics.loops", "motion": "physics.motion",
    # collision: rigid panels, the paper's index, the swept FCL check, clearances, goals
    "rigid": "collision.rigid", "goals": "collision.goals", "collision2d": "collision.index2d",
    "collision3d": "collision.swept3d", "clearance": "collision.clearance",
    # simulation: the nominal fold and the fold under scatter
    "simulate": "simulation.simulate", "scatter": "simulation.scatter", "robust": "simulation.robust",
    "sensitivity": "simulation.sensitivity", "timing": "simulation.timing",
    "paper_timings": "simulation.paper_timings",
    # checks: design rules and their report
    "checks": "checks.rules", "report": "checks.report",
    # render: figures, stills, scenes, animations, the viewer
    "render": "render.figures", "render3d": "render.stills", "render_scene": "render.scene",
    "render_anim": "render.anim", "viewer": "render.viewer",
    # apps: the evaluation pipeline and what calls it
    "pipeline": "apps.pipeline", "gallery": "apps.gallery", "assign": "apps.assign",
    "distributed": "apps.distributed",
    # cli
    "cli": "cli.commands", "cli_support": "cli.support",
}
#: existing subpackages, unchanged
KEEP_PACKAGES = {"geometry", "exchange"}

PACKAGE_DOCS = {
    "core": "Leaf utilities every layer may use: tolerances and defaults, errors, mode enums, "
            "the boundary schema, resource guards, the process pool.",
    "model": "The design and what it is made of: materials, panels and hinges, crease patterns, "
             "vertex reliefs.",
    "io": "Files in: TOML, FOLD and SVG designs become a Design; the shipped templates.",
    "physics": "Hinge recovery R(t; material, bath, thickness) and the kinematics it drives.",
    "collision": "Rigid panels, the paper's collision index (2D), the swept FCL check (3D), "
                 "clearances and goals.",
    "simulation": "The fold of a design (nominal) and under scatter (jam probability).",
    "checks": "Design-rule findings (read results, compute none) and their JSON report.",
    "render": "Figures, stills, scenes, animations and the interactive viewer.",
    "apps": "The evaluation pipeline and its callers: gallery, material assignment, Dask.",
    "cli": "The command line: typer commands and their plumbing.",
}


def old_module(path: Path) -> list[str]:
    rel = path.relative_to(PKG).with_suffix("")
    parts = ["foldprint", *rel.parts]
    return parts[:-1] if parts[-1] == "__init__" else parts


def new_dotted(old: list[str]) -> list[str]:
    """foldprint.<old>[.rest] -> foldprint.<new>[.rest] (a list of parts)."""
    if len(old) >= 2 and old[0] == "foldprint" and old[1] in MOVES:
        return ["foldprint", *MOVES[old[1]].split("."), *old[2:]]
    return list(old)


def new_file_package(path: Path) -> list[str]:
    """The package a file will live in after the move."""
    old = old_module(path)
    is_init = path.name == "__init__.py"
    new = new_dotted(old)
    return new if is_init else new[:-1]


def _new_pkg_of_moved(path: Path) -> list[str]:
    """The package of a module file already at its new place."""
    parts = ["foldprint", *path.relative_to(PKG).with_suffix("").parts]
    return parts[:-1]


def _rel(from_pkg: list[str], target: list[str]) -> tuple[int, str]:
    c = 0
    while c < min(len(from_pkg), len(target)) and from_pkg[c] == target[c]:
        c += 1
    level = len(from_pkg) - c + 1
    return level, ".".join(target[c:])


def rewrite_package_file(path: Path) -> str:
    src = path.read_text(encoding="utf-8")
    lines = src.splitlines(keepends=True)
    old_pkg = old_module(path) if path.name == "__init__.py" else old_module(path)[:-1]
    new_pkg = new_file_package(path)
    edits: list[tuple[int, int, str]] = []  # (first line, last line, replacement text)
    for node in ast.walk(ast.parse(src)):
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = old_pkg[: len(old_pkg) - (node.level - 1)]
        elif node.module and node.module.split(".")[0] == "foldprint":
            base = []
        else:
            continue
        first = lines[node.lineno - 1]
        indent = first[: len(first) - len(first.lstrip())]
        target = base + (node.module.split(".") if node.module else [])
        if node.module is None or target == ["foldprint"]:
            # "from . import a, b": names may be modules that now live in several places
            groups: dict[tuple[int, str], list[str]] = {}
            for a in node.names:
                full = new_dotted(target + [a.name])
                moved = full != target + [a.name]
                alias = a.asname or (a.name if moved and full[-1] != a.name else None)
                name = full[-1] + (f" as {alias}" if alias and alias != full[-1] else "")
                key = _rel(new_pkg, full[:-1]) if node.level else (0, ".".join(full[:-1]))
                groups.setdefault(key, []).append(name)
            out = []
            for (level, mod), names in groups.items():
                head = "." * level + mod if level else mod
                out.append(f"{indent}from {head} import {', '.join(names)}")
            tail = lines[node.end_lineno - 1]
            comment = ""
            if "#" in tail:
                comment = "  " + tail[tail.index("#"):].rstrip("\n")
            text = "\n".join(o + comment for o in out) + "\n"
            edits.append((node.lineno, node.end_lineno, text))
        else:
            full = new_dotted(target)
            if node.level:
                level, mod = _rel(new_pkg, full)
                head = "." * level + mod
            else:
                head = ".".join(full)
            old_head = re.match(r"(\s*from\s+)(\S+)(\s+import)", first)
            assert old_head, (path, node.lineno, first)
            new_first = first[: old_head.start(2)] + head + first[old_head.end(2):]
            edits.append((node.lineno, node.lineno, new_first))
    for first, last, text in sorted(edits, reverse=True):
        lines[first - 1: last] = [text]
    return "".join(lines)


_OLD_NAMES = sorted(MOVES, key=len, reverse=True)
_DOTTED = re.compile(r"\bfoldprint\.(" + "|".join(_OLD_NAMES) + r")\b(?!\.py)")
_PATH = re.compile(r"\bfoldprint/(" + "|".join(_OLD_NAMES) + r")\.py\b")
_FROM_PKG = re.compile(r"^(\s*)from foldprint import (\(?)([^#\n]+?)(\)?)(\s*#.*)?$", re.M)


_NEW_CHILDREN = {m.split(".")[0]: {v.split(".")[1] for v in MOVES.values() if v.startswith(m.split(".")[0] + ".")}
                 for m in MOVES.values()}


def _dotted(m: re.Match) -> str:
    old = m.group(1)
    rest = m.string[m.end():]
    child = re.match(r"\.(\w+)", rest)
    if old in _NEW_CHILDREN and child and child.group(1) in _NEW_CHILDREN[old]:
        return m.group(0)  # already the new layout (foldprint.checks.rules)
    return "foldprint." + MOVES[old]


def rewrite_text(text: str) -> str:
    text = _DOTTED.sub(_dotted, text)
    text = _PATH.sub(lambda m: "foldprint/" + MOVES[m.group(1)].replace(".", "/") + ".py", text)

    def split_from(m: re.Match) -> str:
        indent, names = m.group(1), [n.strip() for n in m.group(3).split(",") if n.strip()]
        groups: dict[str, list[str]] = {}
        for n in names:
            name, _, alias = n.partition(" as ")
            name = name.strip()
            if name in MOVES:
                *pkg, leaf = MOVES[name].split(".")
                alias = alias.strip() or (name if leaf != name else "")
                groups.setdefault("foldprint." + ".".join(pkg), []).append(
                    leaf + (f" as {alias}" if alias and alias != leaf else ""))
            else:
                groups.setdefault("foldprint", []).append(n)
        comment = m.group(5) or ""
        return "\n".join(f"{indent}from {mod} import {', '.join(ns)}{comment}" for mod, ns in groups.items())

    return _FROM_PKG.sub(split_from, text)


def main() -> int:
    if not (PKG / "design.py").exists():
        print("relayout: foldprint/design.py is gone: the tree is already in the new layout", file=sys.stderr)
        return 2
    flat = sorted(p for p in PKG.glob("*.py") if p.stem not in {"__init__", "__main__"})
    unplaced = [p.stem for p in flat if p.stem not in MOVES]
    if unplaced:
        print(f"relayout: place these modules in MOVES first: {', '.join(unplaced)}", file=sys.stderr)
        return 2
    # 1. rewrite imports in place (old locations), then move
    for path in sorted(PKG.rglob("*.py")):
        path.write_text(rewrite_package_file(path), encoding="utf-8")
    for sub in sorted({m.split(".")[0] for m in MOVES.values()}):
        d = PKG / sub
        d.mkdir(exist_ok=True)
        init = d / "__init__.py"
        if not init.exists():
            init.write_text(f'"""{PACKAGE_DOCS[sub]}"""\n', encoding="utf-8")
    for old, new in MOVES.items():
        dst = PKG / (new.replace(".", "/") + ".py")
        subprocess.run(["git", "mv", str(PKG / f"{old}.py"), str(dst)], check=True, cwd=ROOT)
    # 2. dynamic imports of a moved module become plain ones
    dyn = re.compile(r'__import__\("foldprint\.(\w+)"\)\.(\w+)\.')
    for path in sorted(PKG.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        found = {m.group(1) for m in dyn.finditer(text) if m.group(1) in MOVES and m.group(1) == m.group(2)}
        if not found:
            continue
        text = dyn.sub(lambda m: m.group(2) + "." if m.group(1) in found else m.group(0), text)
        lines = text.splitlines(keepends=True)
        at = next(i for i, ln in enumerate(lines) if ln.startswith("from .") or ln.startswith("import "))
        for name in sorted(found):
            *pkg, leaf = MOVES[name].split(".")
            level, mod = _rel(_new_pkg_of_moved(path), ["foldprint", *pkg])
            alias = f" as {name}" if leaf != name else ""
            lines.insert(at, f"from {'.' * level}{mod} import {leaf}{alias}\n")
        path.write_text("".join(lines), encoding="utf-8")
    # 3. references outside the package (and dotted strings inside it)
    others = [p for p in ROOT.rglob("*") if p.is_file() and p.suffix in {".py", ".md", ".toml", ".cfg", ".txt"}
              and not any(part in {".git", ".venv", ".venv-ci", "output", "node_modules"} or part.endswith(".egg-info")
                          for part in p.relative_to(ROOT).parts)
              and p.name != "relayout.py"]
    for path in others:
        text = path.read_text(encoding="utf-8")
        new = rewrite_text(text)
        if new != text:
            path.write_text(new, encoding="utf-8")
    # 4. paths relative to a module file
    tpl = PKG / "io" / "templates.py"
    tpl.write_text(tpl.read_text(encoding="utf-8").replace(
        'Path(__file__).resolve().parent.parent / "templates"',
        'Path(__file__).resolve().parents[2] / "templates"'), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
