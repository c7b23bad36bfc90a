"""What an output folder holds, and whether foldprint may publish a set of files into it.

Every published set carries :data:`MANIFEST` (``foldprint-set.json``): the tool and its
version, the set's id (a digest of its names and contents) and every file with its size
and sha256. A later export reads it to know that the folder holds a foldprint export,
which files are its own and whether one was changed since (:func:`inspect`); :func:`plan`
turns that into a decision (publish the folder whole, file by file with ``force``, or
refuse with a message saying what is wrong and how to go on).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

from ..core.version import __version__
from ..core.errors import ExportError
from ..core.files import TMP_NAME
from ..core.modes import OutFolder, Publish

MANIFEST = "foldprint-set.json"
MANIFEST_NOTE = ("foldprint wrote the files listed here into this folder as one set; a new export into "
                 "the folder replaces exactly these files (docs/output-files.md)")
#: the staging folder of a set published file by file, inside its folder
STAGE_INSIDE = re.compile(r"^\.foldprint-tmp-[a-z0-9_]{8}$")
#: the names of the earlier layout of links (``NAME -> .foldprint-current/NAME``)
LEGACY_SETS, LEGACY_CURRENT = ".foldprint-sets", ".foldprint-current"
_LEGACY_SET = re.compile(r"^set-[a-z0-9_]{8}$")
_SHA256 = re.compile(r"^[0-9a-f]{64}$")
NAME_MAX = 255  # bytes, POSIX file systems
#: folders an export never writes into, nor below: the system's own. Any other direct
#: child of the root (``/tmp``, ``/home``, ``/mnt``, ...) is refused itself, not below.
SYSTEM_TREES = ("/bin", "/boot", "/dev", "/etc", "/lib", "/lib32", "/lib64", "/libx32", "/proc", "/run",
                "/sbin", "/sys", "/usr", "/var/lib", "/System", "/Library")
LISTED = 4  # names a refusal lists


@dataclass(frozen=True)
class FileEntry:
    """One file of a set: its name relative to the set's folder, size and sha256."""

    name: str
    size: int
    sha256: str


@dataclass(frozen=True)
class Holding:
    """What :func:`inspect` found in a folder: its kind, the files of an earlier export
    (name -> sha256 now; link names of a legacy export -> ""), and the names that are
    not foldprint's (``foreign``) or were changed since foldprint wrote them."""

    kind: OutFolder
    ours: dict
    foreign: tuple = ()
    changed: tuple = ()


@dataclass(frozen=True)
class Plan:
    """Where and how a set goes (:func:`plan`): the folder with links resolved, what it
    holds, how the set is published and, when file by file, why."""

    real: Path
    holding: Holding
    publish: Publish
    why: str = ""


_SEEN: dict = {}  # (device, inode, size, mtime, ctime) -> sha256: a folder is inspected 2-3 times per run


def digest_file(path: str | Path) -> str:
    """The sha256 of a file (kept for the run while the file's inode, size, mtime and
    ctime stay the same: ctime cannot be set back, so a changed file is hashed again)."""
    st = os.stat(path)
    key = (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
    if key not in _SEEN:
        h = hashlib.sha256()
        with open(path, "rb") as fh:
            for block in iter(lambda: fh.read(1 << 20), b""):
                h.update(block)
        if len(_SEEN) > 100_000:
            _SEEN.clear()
        _SEEN[key] = h.hexdigest()
    return _SEEN[key]


def manifest_bytes(entries: Iterable[FileEntry], complete: bool = True, before: dict | None = None) -> bytes:
    """The manifest of a set (sorted by name, so the same files give the same bytes).
    ``before``: name -> the sha256 a file had before a publication file by file
    (``complete`` False while it runs), so a run killed in it still finds its own files."""
    files = sorted(entries, key=lambda e: e.name)
    ident = hashlib.sha256("".join(f"{e.name}\0{e.sha256}\n" for e in files).encode("utf-8")).hexdigest()[:16]
    rows = []
    for e in files:
        row = {"name": e.name, "bytes": e.size, "sha256": e.sha256}
        if before and before.get(e.name) and before[e.name] != e.sha256:
            row["sha256_before"] = before[e.name]
        rows.append(row)
    head = {"tool": "foldprint", "version": __version__, "set": ident, "complete": complete, "note": MANIFEST_NOTE}
    lines = [f" {json.dumps(k)}: {json.dumps(v, ensure_ascii=False)}," for k, v in head.items()]
    body = ",\n".join(f"  {json.dumps(r, ensure_ascii=False)}" for r in rows)
    return ("{\n" + "\n".join(lines) + '\n "files": [' + (f"\n{body}\n ]" if rows else "]") + "\n}\n").encode("utf-8")


def valid_name(name: str) -> bool:
    """A relative path inside the set's folder: no empty, ``.`` or ``..`` part, no NUL,
    not absolute, no part longer than the file system holds."""
    parts = name.split("/")
    return bool(name) and "\0" not in name and all(
        p not in ("", ".", "..") and len(p.encode("utf-8", "surrogateescape")) <= NAME_MAX for p in parts)


def read_manifest(folder: Path) -> dict | None:
    """name -> the sha256 values a file of the set may have (the published one and, in a
    publication file by file that was cut short, the one before); None when the folder
    has no manifest of foldprint's (missing, unreadable, another tool's, malformed)."""
    try:
        doc = json.loads((folder / MANIFEST).read_bytes())
        if not isinstance(doc, dict) or doc.get("tool") != "foldprint" or not isinstance(doc.get("files"), list):
            return None
        out = {}
        for row in doc["files"]:
            name, sums = row["name"], [row["sha256"], row.get("sha256_before", row["sha256"])]
            if not (isinstance(name, str) and valid_name(name) and name != MANIFEST
                    and all(isinstance(s, str) and _SHA256.match(s) for s in sums)):
                return None
            out[name] = frozenset(sums)
        return out
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return None


def is_ours(d: str | Path) -> bool:
    """A staging or set-aside folder foldprint made: empty, or with a foldprint manifest,
    or an export of the earlier layout of links."""
    d = Path(d)
    try:
        return (not any(os.scandir(d))) or read_manifest(d) is not None or legacy_names(d) is not None
    except OSError:
        return False


#: The most entries :func:`_walk` lists (our choice: an export set holds tens of files; a
#: folder past this holds other files whatever the rest are, and its walk stays bounded).
MAX_WALK = 100_000


def _walk(out: Path):
    """(files, others, empty dirs) under ``out`` by relative name, links not followed;
    the staging folders (of foldprint's) and temp files of foldprint at the top are left out.
    Iterative (a tree 1,000 levels deep is walked, not a RecursionError) and bounded: it
    stops after :data:`MAX_WALK` entries (then ``others`` ends with a note saying so)."""
    files, others, empty = [], [], []
    stack, seen = [(str(out), "")], 0
    while stack:
        path, base = stack.pop()
        try:
            with os.scandir(path) as it:
                entries = sorted(it, key=lambda e: e.name)
        except OSError:
            others.append(base[:-1] or ".")
            continue
        if base and not entries:
            empty.append(base[:-1])
        for e in entries:
            seen += 1
            if seen > MAX_WALK:
                others.append(f"(more than {MAX_WALK} entries)")
                return files, others, empty
            if not base and ((TMP_NAME.match(e.name) and not e.is_dir())
                             or (STAGE_INSIDE.match(e.name) and e.is_dir(follow_symlinks=False)
                                 and is_ours(out / e.name))):
                continue
            if e.is_dir(follow_symlinks=False):
                stack.append((e.path, base + e.name + "/"))
            elif e.is_file(follow_symlinks=False):
                files.append(base + e.name)
            else:
                others.append(base + e.name)
    return files, others, empty


def legacy_names(out: Path) -> list[str] | None:
    """The link names of an export in the earlier layout (every name a link
    ``NAME -> .foldprint-current/NAME``, the switch, the sets folder, temp files, a set
    being staged inside it), None
    when ``out`` holds anything else."""
    links, layout = [], False
    for e in os.scandir(out):
        if e.name == LEGACY_CURRENT and e.is_symlink():
            head, _, tail = os.readlink(e.path).partition("/")
            if head != LEGACY_SETS or not _LEGACY_SET.match(tail):
                return None
            layout = True
        elif e.name == LEGACY_SETS and e.is_dir(follow_symlinks=False):
            if any(not (_LEGACY_SET.match(s.name) and s.is_dir(follow_symlinks=False)) for s in os.scandir(e.path)):
                return None
            layout = True
        elif e.is_symlink() and os.readlink(e.path) == f"{LEGACY_CURRENT}/{e.name}":
            links.append(e.name)
        elif STAGE_INSIDE.match(e.name) and e.is_dir(follow_symlinks=False):
            continue  # a set being staged inside it, file by file (its own writer's)
        elif not (TMP_NAME.match(e.name) and e.is_file(follow_symlinks=False)):
            return None
    return sorted(links) if layout else None


def inspect(out: Path) -> Holding:
    """What the folder ``out`` (links resolved) holds; see :class:`Holding`."""
    if not os.path.lexists(out):
        return Holding(OutFolder.NEW, {})
    files, others, empty = _walk(out)
    if not (files or others or empty):
        return Holding(OutFolder.EMPTY, {})
    listed = read_manifest(out)
    if listed is not None:
        ours, foreign, changed = {}, list(others), []
        under = {n.rsplit("/", 1)[0] for n in listed if "/" in n}
        dirs = {"/".join(d.split("/")[:k]) for d in under for k in range(1, d.count("/") + 2)}
        foreign += [d for d in empty if d not in dirs]
        for name in files:
            if name == MANIFEST:
                continue
            if name not in listed:
                foreign.append(name)
                continue
            sha = digest_file(out / name)
            if sha in listed[name]:
                ours[name] = sha
            else:
                changed.append(name)
        if not foreign and not changed:
            return Holding(OutFolder.EXPORT, ours)
        return Holding(OutFolder.FOREIGN, ours, tuple(sorted(foreign)), tuple(sorted(changed)))
    legacy = legacy_names(out)
    if legacy is not None:
        return Holding(OutFolder.LEGACY, {n: "" for n in legacy})
    return Holding(OutFolder.FOREIGN, {}, tuple(sorted({n.split("/")[0] for n in files + others + empty})))


def _listing(names: tuple) -> str:
    shown = ", ".join(names[:LISTED])
    return shown + (f" and {len(names) - LISTED} more" if len(names) > LISTED else "")


def check_location(real: Path, given: str) -> None:
    """Refuse a place no export goes: the root, a system folder, a file, a dangling link."""
    if real == Path(real.anchor):
        raise ExportError(f"{given}: is the root of the file system; give a folder of its own, e.g. --out output/mine")
    text = str(real)
    top = real.parent == Path(real.anchor) and os.path.lexists(real)
    if top or any(text == t or text.startswith(t + "/") for t in SYSTEM_TREES):
        raise ExportError(f"{given}: is a system folder ({text}); give a folder of your own, e.g. --out output/mine")
    if os.path.islink(given) and not os.path.exists(given):
        raise ExportError(f"{given}: is a link to {os.readlink(given)!r}, which does not exist; remove the link "
                          "or give another folder with --out")
    if os.path.lexists(real) and not real.is_dir():
        raise ExportError(f"{given}: is a file, not a folder; give a folder with --out, e.g. --out output/mine")
    for p in real.parents:
        if os.path.lexists(p) and not p.is_dir():
            raise ExportError(f"{given}: cannot create the output folder: {p} is a file; give another folder "
                              "with --out")


def _holds_cwd(real: Path) -> bool:
    try:
        cwd = os.path.realpath(os.getcwd())
    except OSError:
        return False
    return cwd == str(real) or cwd.startswith(str(real).rstrip("/") + "/")


def refusal(given: str, holding: Holding) -> str:
    """The one-line message that refuses a folder of other files without ``--force``."""
    if holding.foreign:
        return (f"{given}: holds files foldprint did not write ({_listing(holding.foreign)}); export into a new "
                "or empty folder with --out, or pass --force to add the export's files beside them (other "
                "files are left as they are; files of the same names are replaced)")
    return (f"{given}: {_listing(holding.changed)} changed after foldprint wrote "
            f"{'it' if len(holding.changed) == 1 else 'them'} (the sha256 differs from {MANIFEST}); move "
            "what you want to keep out of the folder, or pass --force to replace it")


def plan(out_dir: str | Path, force: bool = False) -> Plan:
    """Where and how a set goes into ``out_dir``: :class:`Plan`, publishing ``WHOLE`` (a
    new or empty folder, or one holding an earlier export: the staged folder takes its
    place in one step) or ``FILE_BY_FILE`` (with ``force``: a folder of other files, the
    current folder or one that holds it; also a mount point or a folder whose parent is
    not writable). Raises ExportError (nothing written) for the root, a system folder, a
    file, and a folder of other files or the current folder without ``force``."""
    given = str(out_dir)
    real = Path(os.path.realpath(out_dir))
    check_location(real, given)
    holding = inspect(real)
    if holding.kind == OutFolder.NEW:
        return Plan(real, holding, Publish.WHOLE)
    if not os.access(real, os.W_OK | os.X_OK):
        raise ExportError(f"{given}: folder is not writable; choose another with --out")
    if holding.kind == OutFolder.FOREIGN:
        if not force:
            raise ExportError(refusal(given, holding))
        return Plan(real, holding, Publish.FILE_BY_FILE, "beside the files it holds (--force)")
    if _holds_cwd(real):
        if not force:
            raise ExportError(f"{given}: is the current folder or holds it; an export replaces its folder as a "
                              "whole, so give another folder with --out (e.g. --out output/mine), or pass --force "
                              "to write the files into it one by one")
        return Plan(real, holding, Publish.FILE_BY_FILE, "it is the current folder or holds it (--force)")
    if os.path.ismount(real):
        return Plan(real, holding, Publish.FILE_BY_FILE, "it is a mount point, which cannot be replaced")
    if not os.access(real.parent, os.W_OK | os.X_OK):
        return Plan(real, holding, Publish.FILE_BY_FILE, f"its parent {real.parent} is not writable")
    return Plan(real, holding, Publish.WHOLE)
