"""Sets of files that land as a whole: an export, a gallery (docs/output-files.md).

Every output is a plain file in a plain folder; the set is staged beside its folder and
published by renaming the staged folder into place:

1. :func:`~foldprint.exchange.outfolder.plan` decides, before anything is written,
   whether the folder may take the set (a new or empty folder, or one holding only an
   earlier foldprint export; a folder of other files only with ``force``; never the
   root, a system folder or a file);
2. the files are written and flushed into a staging folder beside ``<out>``
   (``<parent>/.<out-name>.foldprint-tmp-XXXXXXXX``, the same file system), which holds
   ``foldprint-set.json`` from its first instant and an exclusive ``flock`` while its
   writer lives; at the end the manifest names every file with its sha256;
3. with a lock on ``<parent>``, the staged folder takes the place of ``<out>``: one
   ``rename`` when ``<out>`` is new, one ``renameat2(RENAME_EXCHANGE)`` swap when it holds
   an earlier export (where the system cannot swap: two renames, the earlier folder moved
   aside as ``.<out-name>.foldprint-old-XXXXXXXX`` and moved back by the next run if a
   kill falls between them); the earlier set, now in the staging name, is removed.

A reader of ``<out>`` therefore sees the earlier complete set or the new one. Into a
folder of other files (``force``), the set is staged inside it (``.foldprint-tmp-XXXXXXXX``)
and each file is renamed into place on its own (:data:`~foldprint.core.modes.Publish`
``FILE_BY_FILE``): files of other names are never touched, a kill can leave a mix of the
two sets. Every run first removes what killed runs left (:func:`recover`): only folders of
its own names that carry a foldprint manifest (or are empty) and whose writer is gone.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import logging
import os
import re
import shutil
import stat
import time
from pathlib import Path
from typing import Callable

from ..core.errors import ExportError
from ..core.files import (TMP_NAME, ensure_dir, fsync_dir, rename_exchange,  # noqa: F401
                          rename_noreplace, token, write_atomic, write_new)
from ..core.modes import OutFolder, Publish
from .outfolder import (LEGACY_CURRENT, LEGACY_SETS, MANIFEST, NAME_MAX, STAGE_INSIDE, FileEntry, Holding,
                        digest_file, is_ours, manifest_bytes, Plan, plan, valid_name)

log = logging.getLogger(__name__)

STALE_TMP_S = 60.0  # a write_atomic temp file older than this is left over from a killed run
_SIBLING_TAIL = re.compile(r"^(tmp|old)-[a-z0-9_]{8}$")
_RESERVED = (MANIFEST, LEGACY_SETS, LEGACY_CURRENT)


def sibling_prefix(real: Path) -> str:
    """``.<out-name>.foldprint-``: the start of the names of ``out``'s staging folders
    beside it (the name cut so that a whole staging name fits the file system)."""
    raw = real.name.encode("utf-8", "surrogateescape")[:NAME_MAX - 32]
    return f".{raw.decode('utf-8', 'ignore')}.foldprint-"


def check_names(out: Path, names: list[str]) -> None:
    """ExportError (before anything is created) for names the file system cannot hold."""
    for n in names:
        if n and len(n.encode("utf-8", "surrogateescape")) > NAME_MAX:
            raise ExportError(f"{out}: file name {n[:40]}... is {len(n.encode('utf-8', 'surrogateescape'))} bytes "
                              f"long, over the {NAME_MAX}-byte limit of the file system; shorten the design name")
        if not valid_name(n) or "/" in n or n in _RESERVED or TMP_NAME.match(n) or STAGE_INSIDE.match(n):
            raise ExportError(f"{out}: {n!r} is not a valid file name")


@contextlib.contextmanager
def _dir_lock(real: Path):
    """An exclusive ``flock`` on the parent of ``real`` (on ``real`` when the parent cannot
    be opened): two writers of one folder publish one after the other."""
    fd = None
    for p in (real.parent, real):
        try:
            fd = os.open(p, os.O_RDONLY | os.O_DIRECTORY)
            break
        except OSError:
            continue
    try:
        if fd is not None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        if fd is not None:
            os.close(fd)


def plan_out(out_dir: str | Path, force: bool = False) -> Plan:
    """:func:`~foldprint.exchange.outfolder.plan` with the folder's publication lock held,
    so a concurrent writer's swap is never seen half-way."""
    with _dir_lock(Path(os.path.realpath(out_dir))):
        return plan(out_dir, force)


def _hold(path: Path, wait: bool = False) -> int | None:
    """An fd holding an exclusive ``flock`` on the folder ``path`` (None if another holds
    one, i.e. its writer is alive)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY | os.O_NOFOLLOW)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except OSError:
        os.close(fd)
        return None
    return fd


def _remove_set(d: Path) -> None:
    """Remove a folder of ours, its manifest (or the layout that names it ours) last, so
    a kill midway leaves a folder the next run still recognises."""
    last = (LEGACY_SETS, MANIFEST)
    for e in sorted(os.scandir(d), key=lambda e: (e.name in last, last.index(e.name) if e.name in last else 0)):
        if e.is_dir(follow_symlinks=False):
            shutil.rmtree(e.path)
        else:
            os.unlink(e.path)
    os.rmdir(d)


def _leftovers(real: Path, beside: bool):
    """(path, what) of the staging or set-aside folders of ``real`` beside it, or inside it."""
    prefix = sibling_prefix(real)
    if beside and real.parent.is_dir():
        for e in os.scandir(real.parent):
            if e.name.startswith(prefix) and _SIBLING_TAIL.match(e.name[len(prefix):]):
                yield Path(e.path), e.name[len(prefix):len(prefix) + 3]
    if not beside and real.is_dir() and not real.is_symlink():
        for e in os.scandir(real):
            if STAGE_INSIDE.match(e.name):
                yield Path(e.path), "tmp"


def recover(out: str | Path) -> list[str]:
    """Remove what killed runs left for ``out`` (links resolved): staging folders beside
    and inside it, a set moved aside (put back when ``out`` is missing), our temp files
    older than ``STALE_TMP_S``. Touches only folders of its own names that are real
    folders of this user, carry a foldprint manifest (or are empty) and whose writer is
    gone (no ``flock``). Returns what it did. Call with :func:`_dir_lock` held."""
    real = Path(os.path.realpath(out))
    done: list[str] = []
    for beside in (True, False):  # inside after beside: a set put back may hold one
        for path, what in list(_leftovers(real, beside)):
            _recover_one(real, path, what, done)
    if real.is_dir() and not real.is_symlink():
        now = time.time()
        for e in os.scandir(real):
            if TMP_NAME.match(e.name) and e.is_file(follow_symlinks=False) \
                    and now - e.stat(follow_symlinks=False).st_mtime > STALE_TMP_S:
                os.unlink(e.path)
                done.append(f"removed {e.name}")
    return done


def _recover_one(real: Path, path: Path, what: str, done: list[str]) -> None:
    try:
        st = os.lstat(path)
    except OSError:
        return
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != os.getuid():
        return
    fd = _hold(path)
    if fd is None:
        return  # a live writer's
    try:
        if not is_ours(path):
            return
        if what == "old" and not os.path.lexists(real):
            os.rename(path, real)
            done.append(f"restored {path.name}")
        else:
            _remove_set(path)
            done.append(f"removed {path.name}")
    finally:
        os.close(fd)


class StagedSet:
    """A set of files written into a staging folder and published into ``out_dir`` as a
    whole when the ``with`` block ends (discarded, leaving ``out_dir`` as it was, when the
    block raises). Write with :meth:`write` or into :attr:`path` directly (any depth);
    ``force``: a folder of other files takes the set file by file; ``names``, when known
    beforehand, are checked against what the folder holds before anything is written.

    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     with StagedSet(os.path.join(tmp, "out")) as st:
    ...         _ = st.write("a.txt", b"a")
    ...     sorted(os.listdir(os.path.join(tmp, "out"))), os.listdir(tmp)
    (['a.txt', 'foldprint-set.json'], ['out'])
    """

    def __init__(self, out_dir: str | Path, force: bool = False, names: list[str] | None = None):
        self.out, self.force, self.names = Path(out_dir), force, list(names or [])
        self.path: Path | None = None
        self.real: Path | None = None
        self.mode: Publish | None = None
        self.kind: OutFolder | None = None
        self.why = ""
        self._known: dict[str, FileEntry] = {}
        self._made: list[Path] = []
        self._fd: int | None = None

    def __enter__(self) -> "StagedSet":
        first = plan_out(self.out, self.force)
        self.real, self.mode, self.kind, self.why = first.real, first.publish, first.holding.kind, first.why
        if self.mode == Publish.FILE_BY_FILE:
            for name in self.names:
                _check_room(self.real, self.out, name)
        try:
            if self.kind == OutFolder.NEW:
                self._made = [p for p in self.real.parents if not os.path.lexists(p)]
                ensure_dir(self.real.parent)
            with _dir_lock(self.real):
                recover(self.real)
                if self.mode == Publish.WHOLE:
                    stage = self.real.parent / f"{sibling_prefix(self.real)}tmp-{token()}"
                else:
                    stage = self.real / f".foldprint-tmp-{token()}"
                os.mkdir(stage)
                self.path = stage
                self._fd = _hold(stage)
                write_new(stage / MANIFEST, manifest_bytes([], complete=False))  # ours from here on
        except BaseException as exc:
            self._discard()
            raise _export_error(self.out, exc) from None
        return self

    def write(self, name: str, data: bytes) -> Path:
        """Write one file of the set (``name`` relative, ``/`` between folders)."""
        if not valid_name(name) or name == MANIFEST:
            raise ExportError(f"{self.out}: {name!r} is not a valid file name")
        p = self.path / name
        if "/" in name:
            p.parent.mkdir(parents=True, exist_ok=True)
        write_new(p, data)
        self._known[name] = FileEntry(name, len(data), hashlib.sha256(data).hexdigest())
        return p

    def __exit__(self, typ, exc, tb) -> bool:
        try:
            if typ is None:
                self._publish()
        except BaseException as err:
            self._discard()
            raise _export_error(self.out, err) from None
        else:
            if typ is not None:
                self._discard()
                if isinstance(exc, OSError) and not isinstance(exc, ExportError):
                    raise _export_error(self.out, exc) from None  # a disk full while staging
        finally:
            if self._fd is not None:
                os.close(self._fd)
                self._fd = None
        return False

    def _entries(self) -> list[FileEntry]:
        """Every file of the staged set (empty folders pruned); ExportError for anything
        that is not a regular file (a writer's bug)."""
        out = []
        for dirpath, dirnames, filenames in os.walk(self.path, topdown=False):
            rel = os.path.relpath(dirpath, self.path)
            base = "" if rel == "." else rel + "/"
            for f in filenames:
                name, p = base + f, os.path.join(dirpath, f)
                if name == MANIFEST:
                    continue
                if os.path.islink(p) or not os.path.isfile(p) or TMP_NAME.match(f):
                    raise ExportError(f"{self.out}: {name} in the staged set is not a finished regular file")
                known = self._known.get(name)
                size = os.path.getsize(p)
                out.append(known if known is not None and known.size == size else
                           FileEntry(name, size, digest_file(p)))
            for d in dirnames:
                if os.path.islink(os.path.join(dirpath, d)):
                    raise ExportError(f"{self.out}: {base + d} in the staged set is a link")
                if not os.listdir(os.path.join(dirpath, d)):
                    os.rmdir(os.path.join(dirpath, d))
        return out

    def _publish(self) -> None:
        entries = self._entries()
        if self.mode == Publish.WHOLE:
            write_atomic(self.path / MANIFEST, manifest_bytes(entries))
        for dirpath, _, _ in os.walk(self.path, topdown=False):
            fsync_dir(dirpath)
        with _dir_lock(self.real):
            recover(self.real)
            now = plan(self.out, self.force)
            if (now.real, now.publish) != (self.real, self.mode):
                raise ExportError(f"{self.out}: changed while the set was written (it now holds: "
                                  f"{now.holding.kind}); run the command again")
            if now.publish == Publish.WHOLE:
                self._swap(now.holding)
            else:
                self._in_place(now.holding, entries)
            fsync_dir(self.real.parent)

    def _swap(self, holding: Holding) -> None:
        stage, real = self.path, self.real
        if holding.kind == OutFolder.NEW:
            try:
                rename_noreplace(stage, real)
            except FileExistsError:
                raise ExportError(f"{self.out}: appeared while the set was written; run the command again") from None
            self.path = None
            return
        try:
            os.chmod(stage, stat.S_IMODE(os.stat(real).st_mode))  # the folder keeps its permissions
        except OSError:
            pass
        if rename_exchange(stage, real):
            old = stage  # the staging name now holds the earlier set
        else:
            old = real.parent / f"{sibling_prefix(real)}old-{token()}"
            os.rename(real, old)
            try:
                os.rename(stage, real)
            except BaseException:
                os.rename(old, real)  # the earlier set back in its place
                raise
        self.path = None
        fsync_dir(real.parent)
        try:
            _remove_set(old)
        except OSError as exc:  # published; the next run removes what is left
            log.warning("%s: could not remove the earlier set %s: %s", self.out, old, exc)

    def _in_place(self, holding: Holding, entries: list[FileEntry]) -> None:
        """Into a folder of other files: each file of the set by its own rename; the
        earlier export's files the set drops (unchanged ones) are removed; nothing else
        is touched."""
        real, stage = self.real, self.path
        new = {e.name: e for e in entries}
        for name in new:
            _check_room(real, self.out, name)
        before = {n: s for n, s in holding.ours.items() if s}
        pending = entries + [FileEntry(n, os.path.getsize(real / n), s) for n, s in before.items() if n not in new]
        write_atomic(real / MANIFEST, manifest_bytes(pending, complete=False, before=before))
        for name in sorted(new):
            (real / name).parent.mkdir(parents=True, exist_ok=True)
            os.replace(stage / name, real / name)
        for name in holding.ours:
            if name not in new:
                _unlink(real / name)
                _prune(real, name)
        if holding.kind == OutFolder.LEGACY:
            _unlink(real / LEGACY_CURRENT)
            shutil.rmtree(real / LEGACY_SETS, ignore_errors=True)
        write_atomic(real / MANIFEST, manifest_bytes(entries))
        fsync_dir(real)
        _remove_set(stage)
        self.path = None

    def _discard(self) -> None:
        """Take back what this set made: its staging folder, the folders it created."""
        if self.path is not None and os.path.isdir(self.path):
            try:
                _remove_set(self.path)
            except OSError:
                shutil.rmtree(self.path, ignore_errors=True)
        self.path = None
        for p in self._made:  # deepest first: only folders this set created, if empty
            try:
                p.rmdir()
            except OSError:
                break


def _check_room(real: Path, given: Path, name: str) -> None:
    """ExportError when a folder stands where a file of the set goes, or a file or link
    where it needs a folder."""
    target = real / name
    if target.is_dir() and not target.is_symlink():
        raise ExportError(f"{given / name}: is a directory, where the export writes a file; move it or choose "
                          "another --out")
    parts = name.split("/")[:-1]
    for k in range(1, len(parts) + 1):
        p = real.joinpath(*parts[:k])
        if os.path.lexists(p) and (p.is_symlink() or not p.is_dir()):
            raise ExportError(f"{given.joinpath(*parts[:k])}: is a file or link, where the export needs a folder; "
                              "move it or choose another --out")


def _unlink(p: Path) -> None:
    try:
        os.unlink(p)
    except FileNotFoundError:
        pass


def _prune(real: Path, name: str) -> None:
    """Remove the folders of ``name`` left empty, deepest first."""
    for p in list((real / name).parents)[:name.count("/")]:
        try:
            p.rmdir()
        except OSError:
            return


def _export_error(out: Path, exc: BaseException) -> BaseException:
    if isinstance(exc, OSError) and not isinstance(exc, ExportError):
        return ExportError(f"{out}: cannot write: {exc.strerror or exc}")
    return exc


def write_set(out_dir: str | Path, files: list[tuple[str, bytes | Callable[[], bytes]]], *,
              force: bool = False) -> list[Path]:
    """Write ``files`` (name, bytes) into ``out_dir`` as a whole (:class:`StagedSet`; see
    the module doc). ``bytes`` may be a callable returning them: it is called when its
    file is staged, in the order of ``files``, so a large set (a voxel slice stack) is
    never all in memory. Returns the paths of the files in ``out_dir`` (which also gets
    ``foldprint-set.json``, the set's manifest).

    On an error nothing of the new set is left, ``out_dir`` keeps what it held, and
    folders this call created are removed again."""
    out = Path(out_dir)
    names = [n for n, _ in files]
    check_names(out, names)
    if len(set(names)) != len(names):
        raise ExportError(f"{out}: two files of one export share a name")
    with StagedSet(out, force, names) as st:
        for name, data in files:
            st.write(name, data() if callable(data) else data)
    return [out / n for n in names]
