"""The docs are a map a newcomer can follow: every relative link of README.md and docs/*.md
reaches a file (and, into a page, a heading), every repository path and every
``foldprint.module.name`` a page mentions exists, and no page reads like a development log
(issue and stop numbers, "final main")."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"
PAGES = [README, *sorted(DOCS.glob("*.md"))]

#: What marks a page as a development log (the repository hook's pattern, and "stop N").
HISTORY = re.compile(r"\b[Ii]ssues? [0-9]+|final main|\b[Ss]top [0-9]+")
_FENCE = re.compile(r"^(```|~~~).*?^\1[^\n]*$", re.S | re.M)
_LINK = re.compile(r"!?\[[^\]\n]*\]\(([^()\s]+)(?:\s+\"[^\"]*\")?\)")
_PATH = re.compile(r"(?<![\w./-])((?:foldprint|tests|scripts|benchmarks|docs|templates)/[\w./-]*\w)")
_DOTTED = re.compile(r"`[^`\n]*?\b(foldprint(?:\.[A-Za-z_]\w*)+)")


def _prose(text: str) -> str:
    """The page without its fenced code blocks (console output may show any text)."""
    return _FENCE.sub("", text)


def _slug(heading: str) -> str:
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    s = re.sub(r"[`*_]", "", heading.strip().lower())
    s = re.sub(r"[^\w\- ]", "", s)
    return s.replace(" ", "-")


def _anchors(page: Path) -> set[str]:
    return {_slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.*?)\s*#*\s*$", _prose(page.read_text()), re.M)}


def _links(page: Path) -> list[str]:
    return [m.group(1) for m in _LINK.finditer(_prose(page.read_text()))
            if not re.match(r"[a-z][a-z0-9+.-]*:", m.group(1))]


def _ids(pages):
    return [p.relative_to(ROOT).as_posix() for p in pages]


def _broken_links(page: Path) -> list[str]:
    bad = []
    for target in _links(page):
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
            bad.append(f"{target}: no heading with that anchor in {dest.name}")
    return bad


@pytest.mark.parametrize("page", PAGES, ids=_ids(PAGES))
def test_every_relative_link_reaches_a_file(page):
    assert _broken_links(page) == []


@pytest.mark.parametrize("page", PAGES, ids=_ids(PAGES))
def test_every_repository_path_a_page_names_exists(page):
    missing = sorted({m.group(1) for m in _PATH.finditer(page.read_text())
                      if not (ROOT / m.group(1).split("::")[0]).exists()})
    assert missing == []


def _resolves(dotted: str) -> bool:
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        for name in parts[i:]:
            if not hasattr(obj, name):
                return False
            obj = getattr(obj, name)
        return True
    return False


@pytest.mark.parametrize("page", PAGES, ids=_ids(PAGES))
def test_every_foldprint_name_a_page_quotes_exists(page):
    names = {m.group(1) for m in _DOTTED.finditer(page.read_text())}
    assert sorted(n for n in names if not _resolves(n)) == []


def _history(page: Path) -> list[str]:
    return [f"line {i}: {line.strip()[:100]}" for i, line in enumerate(page.read_text().splitlines(), 1)
            if HISTORY.search(line)]


@pytest.mark.parametrize("page", PAGES, ids=_ids(PAGES))
def test_no_page_reads_like_a_development_log(page):
    assert _history(page) == []


#: The code beside the package: its docstrings and comments give reasons, not the numbers of
#: the issues that asked for them (this file names some, to test the pattern on).
CODE = [p for d in ("tests", "benchmarks", "scripts", "examples") for p in sorted((ROOT / d).rglob("*.py"))
        if p != Path(__file__).resolve()]


def test_no_test_benchmark_or_script_reads_like_a_development_log():
    assert [f"{p.relative_to(ROOT)}: {h}" for p in CODE for h in _history(p)] == []


def test_the_docs_index_lists_every_page():
    index = DOCS / "README.md"
    listed = {Path(t.partition("#")[0]).name for t in _links(index)}
    pages = {p.name for p in DOCS.glob("*.md")} - {"README.md"}
    assert pages - listed == set()


def test_the_checks_see_what_they_guard(tmp_path):
    page = tmp_path / "page.md"
    (tmp_path / "there.md").write_text("# A heading (FP183)\n")
    page.write_text("[a](there.md#a-heading-fp183) [b](gone.md) [c](there.md#nope) ![d](x.png)\n"
                    "```\n[e](also-gone.md)\n```\n[f](https://example.org/x)\n"
                    "Since issue 18.\nOn the final main.\nAt stop 24.\nIt stops 6 samples on.\nSee issues 3 and 4.\n")
    assert _broken_links(page) == ["gone.md: no such file",
                                   "there.md#nope: no heading with that anchor in there.md",
                                   "x.png: no such file"]
    assert [h.split(":")[0] for h in _history(page)] == ["line 6", "line 7", "line 8", "line 10"]
    assert _resolves("foldprint.simulation.jamtest.verdict") and not _resolves("foldprint.simulation.no_such_name")
