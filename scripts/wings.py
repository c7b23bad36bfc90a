"""Move families of modules into wings: subpackages inside a layer (``apps/gallery/``,
``physics/loops/``, ...), and rewrite every reference to them.

    python scripts/wings.py --dry-run   # list the moves and the files that would change
    python scripts/wings.py             # move and rewrite

A wing groups one family of a layer's modules (docs/architecture.md: its modules count as
the layer's, the layer table names them ``wing/name``). The moves are a table (:data:`MOVES`,
old dotted name below ``foldprint`` -> new one), not a list of today's files: a listed
module that is missing is reported and skipped, one already at its new place is left as
it is, so the script runs on a tree other branches changed and a second run changes
nothing. It

1. rewrites every ``from ... import`` of foldprint in ``foldprint/``, ``tests/``,
   ``benchmarks/``, ``scripts/`` and ``examples/`` (relative imports stay relative,
   recomputed for the importing module's new place: a module one level deeper reads
   ``from ...core`` where it read ``from ..core``; ``from pkg import module`` of a moved
   module keeps its local name with ``as``),
2. rewrites dotted names (``foldprint.physics.recovery`` in code, strings and comments:
   ``import_module``, ``mock.patch`` and ``monkeypatch.setattr`` targets; without the
   ``foldprint.`` prefix, e.g. the facade's ``"physics.recovery"``, only in strings and
   comments) and file paths (``foldprint/physics/recovery.py``, ``physics/recovery.py``),
   also in ``docs/*.md``, ``README.md`` and the data files that name modules
   (``docs/data/*.json`` and ``*.toml``, ``foldprint/data/*.toml``); in a page, a
   backticked bare file name (``loop_solve.py``) and the layer table's row (its modules
   cell and the backticked names of its last cell) follow too,
3. ``git mv``s each module (through a temporary name, so ``apps/gallery.py`` can become
   the wing ``apps/gallery/``) and writes each new wing's ``__init__.py`` (its docstring),
4. rebuilds docs/testing.md's mutation table (``benchmarks/mutation.py --report-only``):
   a moved module whose text changed is marked as changed since its mutants were drawn.

Behaviour is unchanged: only names move. ``scripts/relayout.py`` (the flat layout into
layers) is left as it is: its table describes that older move.
"""

from __future__ import annotations

import argparse
import ast
import io
import re
import subprocess
import sys
import tokenize
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "foldprint"
CODE_ROOTS = ("foldprint", "tests", "benchmarks", "scripts", "examples")
#: files never rewritten: this script, and relayout's table of the older move
SKIP = {"scripts/wings.py", "scripts/relayout.py"}
ARCHITECTURE = "docs/architecture.md"

#: old module (dotted, below foldprint) -> its new place. A wing's modules drop the
#: family prefix their flat names needed (gallery_page -> gallery/page); no two modules
#: of the package share a file name where one name would be read for the other
#: (loops/corrector and barhinge/equilibrium, not two solve.py; exchange's files.py
#: is the set's publisher, core's the file-system primitives).
MOVES: dict[str, str] = {
    # apps: the gallery (runs the designs, one design's files, the page, the Monte-Carlo tables, an entry)
    "apps.gallery": "apps.gallery.runner",
    "apps.gallery_build": "apps.gallery.build",
    "apps.gallery_page": "apps.gallery.page",
    "apps.gallery_samples": "apps.gallery.samples",
    "apps.gallery_entry": "apps.gallery.entry",
    "apps.gallery_cache": "apps.gallery.cache",
    # apps: material assignment (the search, its waves, its ledger, its tasks, its result, continuous fractions)
    "apps.assign": "apps.assign.search",
    "apps.assign_waves": "apps.assign.waves",
    "apps.assign_ledger": "apps.assign.ledger",
    "apps.assign_tasks": "apps.assign.tasks",
    "apps.assign_result": "apps.assign.result",
    "apps.assign_continuous": "apps.assign.continuous",
    "apps.assign_surrogate": "apps.assign.surrogate",
    # physics: hinge recovery (one curve, many temperatures, many hinges at once, the relaxation table)
    "physics.recovery": "physics.recovery.curve",
    "physics.recovery_table": "physics.recovery.table",
    "physics.recovery_batch": "physics.recovery.batch",
    "physics.recovery_relaxation": "physics.recovery.relaxation",
    # physics: loop closure (the equations, the Gauss-Newton corrector, the tracker, its drives' state)
    "physics.loops": "physics.loops.closure",
    "physics.loop_solve": "physics.loops.corrector",
    "physics.loop_tracking": "physics.loops.tracker",
    "physics.loop_cost": "physics.loops.closure_cost",
    "physics.loop_state": "physics.loops.drive_state",
    # physics: the bar-and-hinge model (the model, its mesh, its energy, the equilibrium path, stiffnesses)
    "physics.barhinge": "physics.barhinge.model",
    "physics.barhinge_mesh": "physics.barhinge.mesh",
    "physics.barhinge_energy": "physics.barhinge.energy",
    "physics.barhinge_solve": "physics.barhinge.equilibrium",
    "physics.modulus": "physics.barhinge.stiffness",
    "physics.barhinge_cost": "physics.barhinge.solve_cost",
    # physics: the recovery model fitted to measurements, and what the fit can say
    "physics.calibration": "physics.calibration.fit",
    "physics.calibration_profile": "physics.calibration.profile",
    "physics.calibration_cost": "physics.calibration.fit_cost",
    # simulation: check's sequential jam test (the verdict, at every scale, its stages, the pool, a flip's drivers)
    "simulation.verdict": "simulation.jamtest.verdict",
    "simulation.sequential": "simulation.jamtest.scales",
    "simulation.check_stages": "simulation.jamtest.stages",
    "simulation.batch": "simulation.jamtest.pool",
    "simulation.flip_drivers": "simulation.jamtest.flip_drivers",
    # exchange: the staged, published set of files (core.files keeps the file-system primitives)
    "exchange.files": "exchange.fileset",
}

#: each wing's docstring (its __init__.py holds only this)
WINGS: dict[str, str] = {
    "apps.gallery": "The offline HTML gallery: the runs of every design in one pool (`runner`), one design's "
                    "files (`build`), the page (`page`), the Monte-Carlo tables (`samples`) and what the page "
                    "shows of a design (`entry`), which designs' folders a run keeps (`cache`).",
    "apps.assign": "Material assignment: the search over the seven grades (`search`), the waves of its "
                   "patterns (`waves`), the ledger of its evaluations (`ledger`), its tasks and mappers "
                   "(`tasks`), its result and JSON (`result`), continuous VeroWhite fractions and bath "
                   "(`continuous`) and their timing surrogate (`surrogate`).",
    "physics.recovery": "Hinge recovery R(t; material, bath, thickness): one curve and its fold times "
                        "(`curve`), over many bath temperatures (`table`), of many scattered hinges at once "
                        "(`batch`) with their working arrays and relaxation table (`relaxation`).",
    "physics.loops": "Loop closure on the constraint manifold: the closure equations and the drive "
                     "(`closure`), one Gauss-Newton step of many solves at once (`corrector`), the tracker "
                     "of many drives at once (`tracker`) and each drive's state between rounds (`drive_state`), what a closure costs (`closure_cost`).",
    "physics.barhinge": "The bar-and-hinge model (docs/mechanics.md): the model built from a design "
                        "(`model`), the panels' mesh (`mesh`), its energy with gradient and Hessian "
                        "(`energy`), the equilibrium path and CompliantDrive (`equilibrium`), moduli and "
                        "stiffnesses (`stiffness`), what a path costs (`solve_cost`).",
    "physics.calibration": "The recovery model fitted to measurements (`fit`) and what the fit can say: "
                           "profile-likelihood intervals, parameters the data do not fix (`profile`), what a fit costs (`fit_cost`).",
    "simulation.jamtest": "check's sequential jam test: the SPRTs, the verdict and its confidence sequence "
                          "(`verdict`), the test on a design at every sigma scale (`scales`), check's stages "
                          "as follow-up streams (`stages`), many designs' streams in one adaptive pool "
                          "(`pool`), what drives a flip of the verdict (`flip_drivers`).",
}


@dataclass(frozen=True)
class Move:
    old: str  # dotted below foldprint
    new: str

    @property
    def src(self) -> Path:
        return PKG / (self.old.replace(".", "/") + ".py")

    @property
    def dst(self) -> Path:
        return PKG / (self.new.replace(".", "/") + ".py")


def plan(warn=print) -> list[Move]:
    """The moves still to make; ``warn`` hears of a listed module that is missing, one
    whose place is taken and a module that looks like a wing's but is not listed."""
    pending = []
    for old, new in MOVES.items():
        m = Move(old, new)
        src, dst = m.src.exists(), m.dst.exists()
        if src and not dst:
            pending.append(m)
        elif src and dst:
            warn(f"wings: {m.src.relative_to(ROOT)} and {m.dst.relative_to(ROOT)} both exist: left as they are")
        elif not dst:
            warn(f"wings: {m.src.relative_to(ROOT)} is listed but missing: skipped")
    moved_wings = {m.new.rpartition(".")[0] for m in pending if m.new.count(".") == 2}  # wings, not renames
    for wing in sorted(moved_wings):
        layer, _, name = wing.partition(".")
        for p in sorted((PKG / layer).glob(f"{name}_*.py")):
            if f"{layer}.{p.stem}" not in MOVES:
                warn(f"wings: {p.relative_to(ROOT)} looks like a module of the wing {layer}/{name}/ but is "
                     "not in MOVES: it stays where it is")
    return pending


def _renamer(moves: list[Move]):
    table = {tuple(m.old.split(".")): m.new.split(".") for m in moves}

    def new_name(dotted: str) -> str:
        """foldprint.<old>[.rest] -> foldprint.<new>[.rest]; anything else unchanged."""
        parts = dotted.split(".")
        if parts[0] != "foldprint":
            return dotted
        for k in range(len(parts), 1, -1):
            if tuple(parts[1:k]) in table:
                return ".".join(["foldprint", *table[tuple(parts[1:k])], *parts[k:]])
        return dotted

    return new_name


def module_of(path: Path) -> tuple[str, bool]:
    """(dotted module name, is a package) of a file under foldprint/."""
    parts = ["foldprint", *path.relative_to(PKG).with_suffix("").parts]
    return (".".join(parts[:-1]), True) if parts[-1] == "__init__" else (".".join(parts), False)


def _relative(from_pkg: list[str], target: list[str]) -> str:
    c = 0
    while c < min(len(from_pkg), len(target)) and from_pkg[c] == target[c]:
        c += 1
    return "." * (len(from_pkg) - c + 1) + ".".join(target[c:])


def _absolute(pkg: str, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = pkg.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def import_edits(src: str, old_pkg: str | None, new_pkg: str | None, new_name, modules: set[str]):
    """{(first line, last line): new text} for every ``from ... import`` of foldprint that
    reads differently after the moves. ``old_pkg``/``new_pkg``: the package of the file
    before and after (None outside foldprint/, where imports are absolute); ``modules``:
    every module's old dotted name (to tell a module imported by name from a name)."""
    lines = src.splitlines(keepends=True)
    edits = {}
    for node in ast.walk(ast.parse(src)):
        if not isinstance(node, ast.ImportFrom) or (node.level and old_pkg is None):
            continue
        target = _absolute(old_pkg or "", node)
        if not (target == "foldprint" or target.startswith("foldprint.")):
            continue

        def head_of(mod: str) -> str:
            return _relative(new_pkg.split("."), mod.split(".")) if node.level else mod

        first = lines[node.lineno - 1]
        indent = first[: len(first) - len(first.lstrip())]
        as_modules = [a for a in node.names if f"{target}.{a.name}" in modules
                      and new_name(f"{target}.{a.name}") != f"{new_name(target)}.{a.name}"]
        if as_modules:  # from pkg import module: a moved module's new parent, its old local name
            groups: dict[str, list[str]] = {}
            for a in node.names:
                full = new_name(f"{target}.{a.name}")
                parent, _, leaf = full.rpartition(".")
                local = a.asname or a.name
                groups.setdefault(head_of(parent), []).append(leaf if local == leaf else f"{leaf} as {local}")
            tail = lines[node.end_lineno - 1]
            comment = "  " + tail[tail.index("#"):].rstrip("\n") if "#" in tail else ""
            text = "".join(f"{indent}from {h} import {', '.join(ns)}{comment}\n" for h, ns in groups.items())
            edits[(node.lineno, node.end_lineno)] = text
            continue
        new_head = head_of(new_name(target))
        old_head = re.match(r"(\s*from\s+)(\S+)(\s+import\b)", first)
        if old_head is None:
            raise SystemExit(f"wings: cannot read the import at line {node.lineno}: {first.strip()}")
        if new_head != old_head.group(2):
            edits[(node.lineno, node.lineno)] = first[: old_head.start(2)] + new_head + first[old_head.end(2):]
    return edits


def _text_regexes(moves: list[Move]):
    olds = sorted((m.old for m in moves), key=len, reverse=True)
    dotted = re.compile(r"(?<![\w./-])(foldprint\.)?(" + "|".join(re.escape(o) for o in olds) + r")(?![\w])")
    paths = re.compile(r"(?<![\w./-])((?:foldprint/)?)(" + "|".join(re.escape(o.replace(".", "/")) for o in olds)
                       + r")\.py\b")
    return dotted, paths


def _spans_of_text(src: str) -> list[tuple[int, int]]:
    """Character spans of the strings and comments of Python source."""
    starts = [0]
    for line in src.splitlines(keepends=True):
        starts.append(starts[-1] + len(line))
    spans = []
    for tok in tokenize.generate_tokens(io.StringIO(src).readline):
        if tok.type in (tokenize.STRING, tokenize.COMMENT):
            spans.append((starts[tok.start[0] - 1] + tok.start[1], starts[tok.end[0] - 1] + tok.end[1]))
    return spans


def rewrite_names(text: str, moves: list[Move], in_text=lambda pos: True) -> str:
    """Dotted names and paths of moved modules; ``in_text(pos)``: whether the character at
    ``pos`` is in prose (a string, a comment, a page), where names without the
    ``foldprint.`` prefix and paths are rewritten too."""
    table = {m.old: m.new for m in moves}
    dotted, paths = _text_regexes(moves)

    def sub_dotted(m: re.Match) -> str:
        if m.group(1) or in_text(m.start()):
            return (m.group(1) or "") + table[m.group(2)]
        return m.group(0)

    def sub_path(m: re.Match) -> str:
        if not in_text(m.start()):
            return m.group(0)
        return m.group(1) + table[m.group(2).replace("/", ".")].replace(".", "/") + ".py"

    return paths.sub(sub_path, dotted.sub(sub_dotted, text))


def rewrite_python(path: Path, src: str, moves: list[Move], new_name, modules: set[str]) -> str:
    if path.is_relative_to(PKG):
        mod, is_pkg = module_of(path)
        new_mod = new_name(mod)
        old_pkg = mod if is_pkg else mod.rpartition(".")[0]
        new_pkg = new_mod if is_pkg else new_mod.rpartition(".")[0]
    else:
        old_pkg = new_pkg = None
    edits = import_edits(src, old_pkg, new_pkg, new_name, modules)
    spans = _spans_of_text(src)
    lines = src.splitlines(keepends=True)
    skip = {k for first, last in edits for k in range(first, last + 1)}
    out, pos = [], 0
    for k, line in enumerate(lines, 1):
        if k not in skip:
            line = rewrite_names(line, moves, lambda p, at=pos: any(a <= at + p < b for a, b in spans))
        out.append(line)
        pos += len(lines[k - 1])
    for (first, last), text in sorted(edits.items(), reverse=True):
        out[first - 1: last] = [text]
    return "".join(out)


def rewrite_page(text: str, moves: list[Move], is_architecture: bool) -> str:
    text = rewrite_names(text, moves)
    leaves: dict[str, list[str]] = {}
    for p in PKG.rglob("*.py"):
        leaves.setdefault(p.name, []).append(str(p))
    for m in moves:  # a backticked bare file name, when no other module has that name
        layer, _, leaf = m.old.partition(".")
        if len(leaves.get(f"{leaf}.py", [])) == 1:
            new = m.new.partition(".")[2].replace(".", "/")
            text = re.sub(rf"`{re.escape(leaf)}\.py`", f"`{new}.py`", text)
    if is_architecture:
        text = "".join(_table_row(line, moves) for line in text.splitlines(keepends=True))
        if "wing" not in text and "\n| layer |" in text:
            at = text.index("\n| layer |") + 1
            text = text[:at] + WING_PARAGRAPH + "\n" + text[at:]
    return text


#: what docs/architecture.md says of wings, before its layer table, once there are wings
WING_PARAGRAPH = """A family of a layer's modules may sit in a wing, a subpackage inside the layer's package
(`apps/gallery/`, `physics/loops/`): its modules count as the layer's, the table names
them `wing/name`, its `__init__.py` holds only its docstring, and a wing holds no wing.
"""


_ROW = re.compile(r"^(\|\s*\d+\s*\|\s*`(\w+)/`\s*\|)([^|]*)(\|.*)$", re.S)


def _table_row(line: str, moves: list[Move]) -> str:
    """A row of the layer table: its moved modules as ``wing/name``, in the modules cell
    and backticked in the cells after it."""
    m = _ROW.match(line)
    if not m:
        return line
    layer = m.group(2)
    here = {mv.old.partition(".")[2]: mv.new.partition(".")[2].replace(".", "/")
            for mv in moves if mv.old.startswith(layer + ".")}
    if not here:
        return line
    cell = ", ".join(here.get(s.strip(), s.strip()) for s in m.group(3).split(",") if s.strip())
    rest = re.sub(r"`(\w+)`", lambda b: f"`{here[b.group(1)]}`" if b.group(1) in here else b.group(0), m.group(4))
    return f"{m.group(1)} {cell} {rest}"


def files_to_rewrite() -> tuple[list[Path], list[Path], list[Path]]:
    """The Python files, the pages and the data files (whose comments and records name
    modules: docs/data/mutation.json is what docs/testing.md's table is made from)."""
    py = [p for r in CODE_ROOTS for p in sorted((ROOT / r).rglob("*.py"))
          if str(p.relative_to(ROOT)) not in SKIP and "__pycache__" not in p.parts]
    pages = [p for p in (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))) if p.exists()]
    data = [p for pattern in ("docs/data/*.json", "docs/data/*.toml", "foldprint/data/*.toml")
            for p in sorted(ROOT.glob(pattern))]
    return py, pages, data


def rewrite_all(moves: list[Move]) -> dict[Path, str]:
    """Every file's new text, for the files that change (read at the old places)."""
    new_name = _renamer(moves)
    modules = {module_of(p)[0] for p in PKG.rglob("*.py")}
    py, pages, data = files_to_rewrite()
    changed = {}
    for p in py:
        src = p.read_text(encoding="utf-8")
        new = rewrite_python(p, src, moves, new_name, modules)
        if new != src:
            changed[p] = new
    for p in pages:
        src = p.read_text(encoding="utf-8")
        new = rewrite_page(src, moves, str(p.relative_to(ROOT)) == ARCHITECTURE)
        if new != src:
            changed[p] = new
    for p in data:
        src = p.read_text(encoding="utf-8")
        new = rewrite_names(src, moves)
        if new != src:
            changed[p] = new
    return changed


def _git(*args: str) -> None:
    subprocess.run(["git", *args], check=True, cwd=ROOT)


def apply(moves: list[Move], changed: dict[Path, str]) -> None:
    for p, text in changed.items():
        p.write_text(text, encoding="utf-8")
    temps = []
    for k, m in enumerate(moves):  # through a temporary name: apps/gallery.py becomes apps/gallery/
        tmp = m.src.with_name(f"_wings_move_{k}.py")
        _git("mv", str(m.src), str(tmp))
        temps.append((tmp, m))
    for tmp, m in temps:
        wing_dir = m.dst.parent
        for d in reversed([wing_dir, *wing_dir.parents]):
            if d.is_relative_to(PKG) and d != PKG and not (d / "__init__.py").exists():
                d.mkdir(parents=True, exist_ok=True)
                wing = ".".join(d.relative_to(PKG).parts)
                doc = WINGS.get(wing, f"The {wing.replace('.', '/')}/ wing of foldprint.")
                (d / "__init__.py").write_text(f'"""{doc}"""\n', encoding="utf-8")
                _git("add", str(d / "__init__.py"))
        _git("mv", str(tmp), str(m.dst))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dry-run", action="store_true", help="list the moves and the files that would change")
    args = ap.parse_args(argv)
    moves = plan(warn=lambda s: print(s, file=sys.stderr))
    if not moves:
        print("wings: nothing to move (every listed module is at its new place or missing)")
        return 0
    changed = rewrite_all(moves)
    for m in moves:
        print(f"{m.src.relative_to(ROOT)} -> {m.dst.relative_to(ROOT)}")
    print(f"wings: {len(moves)} modules to move, {len(changed)} files to rewrite"
          + (":" if args.dry_run else ""))
    if args.dry_run:
        for p in sorted(changed):
            print(f"  {p.relative_to(ROOT)}")
        return 0
    apply(moves, changed)
    report_mutation_table()
    print("wings: done; run tests/test_architecture.py, tests/test_docs_links.py and tests/test_mutation_tool.py")
    return 0


def report_mutation_table() -> None:
    """Rebuild docs/testing.md's mutation table: a moved module whose imports changed is
    marked as changed since its mutants were drawn (its sha256 in docs/data/mutation.json
    is the older text's)."""
    tool = ROOT / "benchmarks" / "mutation.py"
    if not tool.exists():
        return
    r = subprocess.run([sys.executable, str(tool), "--report-only"], cwd=ROOT, capture_output=True, text=True)
    if r.returncode:
        print(f"wings: {tool.relative_to(ROOT)} --report-only failed; run it by hand:\n{r.stderr[-2000:]}",
              file=sys.stderr)


if __name__ == "__main__":
    raise SystemExit(main())
