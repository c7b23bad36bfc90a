"""File writes that land as a whole.

* :func:`write_atomic`: one file, via a temp file in the target directory and ``os.replace``.
* :func:`write_set`: a set of files (an export), published by ONE atomic rename (issue 20).

  Layout of ``<out>`` (every name of the set is a fixed relative link through one switch)::

      <out>/.foldprint-sets/<id>/NAME      the files of one complete set
      <out>/.foldprint-current  ->  .foldprint-sets/<id>      the switch
      <out>/NAME  ->  .foldprint-current/NAME                  what the user opens

  1. every file is written and fsynced into a new ``.foldprint-sets/<id>/``;
  2. each name of the new set that is not yet a link gets one (it dangles, unreadable,
     until step 3 if the current set lacks it); an existing regular file of that name
     (an export written before this layout, or the user's) is first hard-linked into a
     copy of the current set, the switch turned to that copy, and only then replaced by
     the link, so its content does not change in this step;
  3. ``.foldprint-current`` is replaced by a link to the new set: one ``rename``;
  4. links of names the new set lacks (now dangling) and the other sets are removed.

  At every instant the names that can be opened are exactly one complete set, the
  previous one (before 3) or the new one (from 3 on); a kill anywhere leaves that state,
  and the next :func:`write_set` first calls :func:`recover`, which removes what the
  killed writer left (sets not switched to, dangling links of ours, our temp names).
  Only names foldprint makes are touched: ``.foldprint-sets/<id>``, ``.foldprint-current``,
  links whose target is exactly ``.foldprint-current/<their own name>`` and temp files
  ``.foldprint-XXXXXXXX.tmp``; a planted switch that points anywhere else is refused.
  A lock (``flock`` on the directory) keeps two writers apart.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import tempfile
import time
from pathlib import Path
from typing import Callable

from ..core.errors import ExportError

SETS = ".foldprint-sets"
CURRENT = ".foldprint-current"
TMP_PREFIX, TMP_SUFFIX = ".foldprint-", ".tmp"
_TMP = re.compile(r"^\.foldprint-[a-z0-9_]{8}\.tmp$")  # tempfile's 8 random characters
_SET_ID = re.compile(r"^set-[a-z0-9_]{8}$")
STALE_TMP_S = 60.0  # a write_atomic temp file older than this is left over from a killed run
NAME_MAX = 255  # bytes, POSIX file systems
_RESERVED = (SETS, CURRENT)


def ensure_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents); ExportError with the reason if impossible."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"{p}: cannot create output directory: {exc.strerror or exc}") from None
    if not os.access(p, os.W_OK):
        raise ExportError(f"{p}: output directory is not writable; choose another with --out")
    return p


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_atomic(path: str | Path, data: bytes | str) -> Path:
    """Write ``data`` to ``path`` so that no half-written file is ever left behind."""
    p = Path(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    ensure_dir(p.parent)
    fd, tmp = None, None
    try:
        fd, tmp = tempfile.mkstemp(prefix=TMP_PREFIX, suffix=TMP_SUFFIX, dir=p.parent)
        with os.fdopen(fd, "wb") as fh:
            fd = None
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, p)
        tmp = None
    except OSError as exc:
        raise ExportError(f"{p}: cannot write: {exc.strerror or exc}") from None
    finally:
        if fd is not None:
            os.close(fd)
        if tmp is not None and os.path.lexists(tmp):
            os.unlink(tmp)
    return p


def check_names(out: Path, names: list[str]) -> None:
    """ExportError (before anything is created) for names the file system cannot hold."""
    for n in names:
        if not n or "/" in n or "\0" in n or n in (".", "..") or n in _RESERVED or _TMP.match(n):
            raise ExportError(f"{out}: {n!r} is not a valid file name")
        if len(n.encode("utf-8")) > NAME_MAX:
            raise ExportError(f"{out}: file name {n[:40]}... is {len(n.encode('utf-8'))} bytes long, over the "
                              f"{NAME_MAX}-byte limit of the file system; shorten the design name")


def _link_target(name: str) -> str:
    return f"{CURRENT}/{name}"


def _is_our_link(path: Path) -> bool:
    try:
        return path.is_symlink() and os.readlink(path) == _link_target(path.name)
    except OSError:
        return False


def current_set(out: str | Path) -> Path | None:
    """The directory of the published set, None when there is none; ExportError when
    ``.foldprint-current`` or ``.foldprint-sets`` is not what foldprint makes (planted)."""
    out = Path(out)
    sets, cur = out / SETS, out / CURRENT
    if os.path.lexists(sets) and (sets.is_symlink() or not sets.is_dir()):
        raise ExportError(f"{sets}: not a directory foldprint made (a link or a file); remove it or "
                          "choose another --out")
    if not os.path.lexists(cur):
        return None
    target = os.readlink(cur) if cur.is_symlink() else None
    head, _, tail = (target or "").partition("/")
    if target is None or head != SETS or not _SET_ID.match(tail):
        raise ExportError(f"{cur}: not a link foldprint made (it must point to {SETS}/set-XXXXXXXX, "
                          f"found {'a file' if target is None else repr(target)}); remove it or choose another --out")
    d = sets / tail
    if d.is_symlink() or not d.is_dir():
        raise ExportError(f"{cur}: points to {target!r}, which is not a directory foldprint made; remove "
                          f"{cur} or choose another --out")
    return d


def recover(out: str | Path) -> list[str]:
    """Remove what an interrupted writer left in ``out``: sets that were never switched
    to, links of ours that no longer resolve, our temp files (those of :func:`write_atomic`
    only when older than ``STALE_TMP_S``). Never touches a name foldprint does not make.
    Returns what it did (for logs and tests). Call with the directory lock held."""
    out = Path(out)
    done: list[str] = []
    if not out.is_dir():
        return done
    cur = current_set(out)
    sets = out / SETS
    if sets.is_dir():
        for e in os.scandir(sets):
            if _SET_ID.match(e.name) and e.is_dir(follow_symlinks=False) and (cur is None or e.name != cur.name):
                shutil.rmtree(e.path, ignore_errors=True)
                done.append(f"removed {SETS}/{e.name}")
    now = time.time()
    for e in os.scandir(out):
        p = Path(e.path)
        if _TMP.match(e.name) and (e.is_symlink() or e.is_file(follow_symlinks=False)):
            if e.is_symlink() or now - e.stat(follow_symlinks=False).st_mtime > STALE_TMP_S:
                _unlink(p)
                done.append(f"removed {e.name}")
        elif _is_our_link(p) and not p.exists():
            _unlink(p)
            done.append(f"removed dangling {e.name}")
    return done


def _unlink(p: Path) -> None:
    try:
        os.unlink(p)
    except FileNotFoundError:
        pass


class _Lock:
    """An exclusive ``flock`` on a directory (released on close or process death)."""

    def __init__(self, path: Path):
        self.fd = os.open(path, os.O_RDONLY)
        fcntl.flock(self.fd, fcntl.LOCK_EX)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        os.close(self.fd)


def _symlink_replace(target: str, dest: Path) -> None:
    """Make ``dest`` a symlink to ``target`` by one rename (atomic)."""
    tmp = Path(tempfile.mktemp(prefix=TMP_PREFIX, suffix=TMP_SUFFIX, dir=dest.parent))
    os.symlink(target, tmp)
    try:
        os.replace(tmp, dest)
    except BaseException:
        _unlink(tmp)
        raise


def _new_set(out: Path) -> Path:
    (out / SETS).mkdir(exist_ok=True)
    return Path(tempfile.mkdtemp(prefix="set-", dir=out / SETS))


def _switch(out: Path, set_dir: Path) -> None:
    _fsync_dir(set_dir)
    _fsync_dir(out / SETS)
    _symlink_replace(f"{SETS}/{set_dir.name}", out / CURRENT)
    _fsync_dir(out)


def _adopt_regular_files(out: Path, names: list[str]) -> None:
    """Names of the new set held by regular files (a pre-switch export, the user's): copy
    the current set plus these files into a set of their own, switch to it, then turn each
    file into a link; the content behind every name stays the same throughout."""
    plain = [n for n in names if not (out / n).is_symlink() and (out / n).is_file()]
    if not plain:
        return
    cur = current_set(out)
    legacy = _new_set(out)
    sources = {e.name: Path(e.path) for e in (os.scandir(cur) if cur else []) if e.is_file(follow_symlinks=False)}
    sources.update({n: out / n for n in plain})  # a plain file wins over the set's file of its name
    for name, src in sources.items():
        try:
            os.link(src, legacy / name, follow_symlinks=False)
        except OSError:
            shutil.copy2(src, legacy / name)
    _switch(out, legacy)
    for n in plain:
        _symlink_replace(_link_target(n), out / n)
    _fsync_dir(out)
    if cur is not None:
        shutil.rmtree(cur, ignore_errors=True)


def write_set(out_dir: str | Path, files: list[tuple[str, bytes | Callable[[], bytes]]]) -> list[Path]:
    """Write ``files`` (name, bytes) into ``out_dir`` as a whole (see the module doc).
    ``bytes`` may be a callable returning them: it is called when its file is staged, in
    the order of ``files``, so a large set (a voxel slice stack) is never all in memory.

    On an error nothing of the new set is left, and a directory this call created is
    removed again."""
    out = Path(out_dir)
    names = [n for n, _ in files]
    check_names(out, names)
    if len(set(names)) != len(names):
        raise ExportError(f"{out}: two files of one export share a name")
    for n in names:
        if (out / n).is_dir() and not (out / n).is_symlink():
            raise ExportError(f"{out / n}: is a directory, where the export writes a file; move it or "
                              "choose another --out")
    missing = [p for p in [out, *out.parents] if not p.exists()]
    ensure_dir(out)
    stage, made_links, switched = None, [], False
    try:
        with _Lock(out):
            recover(out)
            stage = _new_set(out)
            for name, data in files:
                if callable(data):  # a streamed file (voxel slices): made now, one at a time
                    data = data()
                with open(stage / name, "wb") as fh:
                    fh.write(data)
                    fh.flush()
                    os.fsync(fh.fileno())
                os.chmod(stage / name, 0o644)
            _adopt_regular_files(out, names)
            for n in names:
                if not _is_our_link(out / n):
                    _symlink_replace(_link_target(n), out / n)
                    made_links.append(n)
            _switch(out, stage)
            switched = True
            keep = set(names)
            for e in os.scandir(out):
                if e.name not in keep and _is_our_link(Path(e.path)):
                    _unlink(Path(e.path))
            for e in os.scandir(out / SETS):
                if _SET_ID.match(e.name) and e.name != stage.name and e.is_dir(follow_symlinks=False):
                    shutil.rmtree(e.path, ignore_errors=True)
            _fsync_dir(out)
    except BaseException as exc:
        if not switched:
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)
            for n in made_links:
                if _is_our_link(out / n) and not (out / n).exists():
                    _unlink(out / n)
            if not os.path.lexists(out / CURRENT):
                try:  # the sets folder this call made in an existing directory
                    (out / SETS).rmdir()
                except OSError:
                    pass
            if missing:  # this call created out: take back what it made, then the directories
                for extra in (out / SETS, out / CURRENT):
                    if extra.is_symlink():
                        _unlink(extra)
                    elif extra.is_dir():
                        shutil.rmtree(extra, ignore_errors=True)
            for p in missing:  # deepest first: only directories this call created, if empty
                try:
                    p.rmdir()
                except OSError:
                    break
        if isinstance(exc, OSError) and not isinstance(exc, ExportError):
            raise ExportError(f"{out}: cannot write: {exc.strerror or exc}") from None
        raise
    return [out / n for n in names]


def flatten(out_dir: str | Path) -> None:
    """Turn a published export folder into plain files: each link of ours is replaced by
    the file it shows (a hard link, else a copy; one rename per name, its content never
    changes), then the switch and the sets folder are removed. For folders served as a web
    site (the gallery), whose hosts often skip or refuse dot-folders; the next
    :func:`write_set` into it adopts the plain files again."""
    out = Path(out_dir)
    with _Lock(out):
        cur = current_set(out)
        if cur is None:
            return
        for e in os.scandir(out):
            p = Path(e.path)
            if not (_is_our_link(p) and (cur / e.name).is_file()):
                continue
            tmp = Path(tempfile.mktemp(prefix=TMP_PREFIX, suffix=TMP_SUFFIX, dir=out))
            try:
                os.link(cur / e.name, tmp)
            except OSError:
                shutil.copy2(cur / e.name, tmp)
            os.replace(tmp, p)
        _fsync_dir(out)
        _unlink(out / CURRENT)
        shutil.rmtree(out / SETS, ignore_errors=True)
