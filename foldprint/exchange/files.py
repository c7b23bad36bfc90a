"""File writes that land as a whole.

* :func:`write_atomic`: one file, via a temp file in the target directory and ``os.replace``.
* :func:`write_set`: a set of files (an export) via a staging directory inside the target
  directory and a commit journal:

  1. every file is written and fsynced into ``<out>/.foldprint-staging-XXXX/``;
  2. the list of names is written, last, as ``COMMIT`` in that directory (atomically);
  3. each file is renamed into ``<out>`` (same file system: atomic per file), then the
     staging directory is removed.

  Killed before step 2, the previous set is untouched and the staging directory is
  garbage; killed during step 3 (a window of a few renames), the journal says the new set
  is complete. The next :func:`write_set` into the same directory first calls
  :func:`recover`: it deletes uncommitted staging directories (and stale ``.NAME.XXXX.tmp``
  files of :func:`write_atomic`) and finishes committed ones, so the directory always ends
  with one complete set. A lock (``flock`` on the directory) keeps two writers apart.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import tempfile
from pathlib import Path

from ..errors import ExportError

STAGING_PREFIX = ".foldprint-staging-"
COMMIT = "COMMIT"
_STALE_TMP = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp$")
NAME_MAX = 255  # bytes, POSIX file systems


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
        fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", suffix=".tmp", dir=p.parent)
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
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    return p


def check_names(out: Path, names: list[str]) -> None:
    """ExportError (before anything is created) for names the file system cannot hold."""
    for n in names:
        if not n or "/" in n or "\0" in n or n in (".", ".."):
            raise ExportError(f"{out}: {n!r} is not a valid file name")
        if len(n.encode("utf-8")) > NAME_MAX:
            raise ExportError(f"{out}: file name {n[:40]}... is {len(n.encode('utf-8'))} bytes long, over the "
                              f"{NAME_MAX}-byte limit of the file system; shorten the design name")


def _roll_forward(stage: Path, out: Path) -> None:
    names = (stage / COMMIT).read_text(encoding="utf-8").splitlines()
    for n in names:
        src = stage / n
        if src.exists():
            os.replace(src, out / n)
    _fsync_dir(out)
    shutil.rmtree(stage, ignore_errors=True)


def recover(out: str | Path) -> list[str]:
    """Finish or discard what an interrupted writer left in ``out``: committed staging
    directories are rolled forward, uncommitted ones and stale temp files removed.
    Returns what it did (for logs and tests). Call with the directory lock held."""
    out = Path(out)
    done = []
    try:
        entries = list(os.scandir(out))
    except OSError:
        return done
    stages = sorted((e for e in entries if e.name.startswith(STAGING_PREFIX) and e.is_dir(follow_symlinks=False)),
                    key=lambda e: e.stat(follow_symlinks=False).st_mtime)
    for e in stages:
        stage = Path(e.path)
        if (stage / COMMIT).is_file():
            _roll_forward(stage, out)
            done.append(f"finished {e.name}")
        else:
            shutil.rmtree(stage, ignore_errors=True)
            done.append(f"removed {e.name}")
    for e in entries:
        if _STALE_TMP.match(e.name) and e.is_file(follow_symlinks=False):
            try:
                os.unlink(e.path)
                done.append(f"removed {e.name}")
            except OSError:
                pass
    return done


class _Lock:
    """An exclusive ``flock`` on a directory (released on close or process death)."""

    def __init__(self, path: Path):
        self.fd = os.open(path, os.O_RDONLY)
        fcntl.flock(self.fd, fcntl.LOCK_EX)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        os.close(self.fd)


def write_set(out_dir: str | Path, files: list[tuple[str, bytes]]) -> list[Path]:
    """Write ``files`` (name, bytes) into ``out_dir`` as a whole (see the module doc).

    On an error nothing of the new set is left, and a directory this call created is
    removed again."""
    out = Path(out_dir)
    names = [n for n, _ in files]
    check_names(out, names)
    if len(set(names)) != len(names):
        raise ExportError(f"{out}: two files of one export share a name")
    missing = [p for p in [out, *out.parents] if not p.exists()]
    ensure_dir(out)
    stage = None
    committed = False
    try:
        with _Lock(out):
            recover(out)
            stage = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX, dir=out))
            for name, data in files:
                with open(stage / name, "wb") as fh:
                    fh.write(data)
                    fh.flush()
                    os.fsync(fh.fileno())
                os.chmod(stage / name, 0o644)
            journal = stage / (COMMIT + ".tmp")
            with open(journal, "w", encoding="utf-8") as fh:
                fh.write("\n".join(names) + "\n")
                fh.flush()
                os.fsync(fh.fileno())
            _fsync_dir(stage)
            os.replace(journal, stage / COMMIT)
            committed = True
            _fsync_dir(stage)
            _roll_forward(stage, out)
    except BaseException as exc:
        if stage is not None and not committed:
            shutil.rmtree(stage, ignore_errors=True)
        if not committed:
            for p in missing:  # deepest first: only directories this call created, if empty
                try:
                    p.rmdir()
                except OSError:
                    break
        if isinstance(exc, OSError) and not isinstance(exc, ExportError):
            raise ExportError(f"{out}: cannot write: {exc.strerror or exc}") from None
        raise
    return [out / n for n in names]
