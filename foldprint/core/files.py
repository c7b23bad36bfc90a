"""File-system primitives every writer shares: make a folder, write one file so that it
lands whole, and the two atomic renames of Linux's ``renameat2`` (swap two paths; rename
without replacing).

Files and folders are made with the user's umask (``0o666`` / ``0o777`` before it), as
``cp`` or an editor would make them.
"""

from __future__ import annotations

import ctypes
import errno
import os
import re
import secrets
from pathlib import Path

from .errors import ExportError

TMP_PREFIX, TMP_SUFFIX = ".foldprint-", ".tmp"
#: the temp name of :func:`write_atomic`: ``.foldprint-`` + 8 random characters + ``.tmp``
TMP_NAME = re.compile(r"^\.foldprint-[a-z0-9_]{8}\.tmp$")

RENAME_NOREPLACE, RENAME_EXCHANGE = 1, 2  # <linux/fs.h>
_AT_FDCWD = -100
#: errno values by which a kernel, C library or file system says it cannot do a
#: ``renameat2`` flag (the caller then falls back to plain renames)
_UNSUPPORTED = {errno.ENOSYS, errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP}


def token() -> str:
    """8 random lowercase characters, for temporary names."""
    return secrets.token_hex(4)


#: The longest path the file system takes (Linux PATH_MAX, bytes with the final NUL).
PATH_MAX = 4096


def ensure_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents); ExportError with the reason if impossible. The
    missing levels are made one at a time from the top (``Path.mkdir(parents=True)``
    recurses once per level: 1,500 levels were a RecursionError), and removed again when a
    deeper one cannot be made."""
    p = Path(path)
    if len(os.fsencode(os.path.abspath(p))) >= PATH_MAX:
        raise ExportError(f"{p}: cannot create output directory: the path is longer than {PATH_MAX - 1} bytes; "
                          "give a shorter one")
    missing, q = [], p
    while not q.is_dir() and q != q.parent:
        missing.append(q)
        q = q.parent
    made = []
    try:
        for d in reversed(missing):
            try:
                os.mkdir(d)
                made.append(d)
            except FileExistsError:
                if not d.is_dir():
                    raise NotADirectoryError(0, f"{d} is a file, not a folder") from None
    except OSError as exc:
        for d in reversed(made):
            try:
                os.rmdir(d)
            except OSError:
                break
        raise ExportError(f"{p}: cannot create output directory: {exc.strerror or exc}") from None
    if not os.access(p, os.W_OK):
        raise ExportError(f"{p}: output directory is not writable; choose another with --out")
    return p


def fsync_dir(path: str | Path) -> None:
    """Flush a directory's entries to disk (best effort: some file systems refuse)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_new(path: str | Path, data: bytes) -> None:
    """Create ``path`` (it must not exist) with ``data``, flushed to disk; the mode is
    ``0o666`` less the umask."""
    with open(path, "xb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def write_atomic(path: str | Path, data: bytes | str, replace: bool = True) -> Path:
    """Write ``data`` to ``path`` so that no half-written file is ever left behind: a temp
    file beside it (``.foldprint-XXXXXXXX.tmp``), flushed, then renamed over ``path``;
    with ``replace=False`` renamed only if ``path`` does not exist (FileExistsError else)."""
    p = Path(path)
    if isinstance(data, str):
        data = data.encode("utf-8")
    ensure_dir(p.parent)
    tmp = None
    try:
        tmp = p.parent / f"{TMP_PREFIX}{token()}{TMP_SUFFIX}"
        write_new(tmp, data)
        (os.replace if replace else rename_noreplace)(tmp, p)
        tmp = None
    except FileExistsError:
        raise
    except OSError as exc:
        raise ExportError(f"{p}: cannot write: {exc.strerror or exc}") from None
    finally:
        if tmp is not None and os.path.lexists(tmp):
            os.unlink(tmp)
    return p


def _libc_renameat2():
    try:
        fn = ctypes.CDLL(None, use_errno=True).renameat2  # glibc >= 2.28, musl >= 1.2.3
    except (AttributeError, OSError):
        return None
    fn.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    fn.restype = ctypes.c_int
    return fn


_RENAMEAT2 = _libc_renameat2()


def renameat2(src: str | Path, dst: str | Path, flags: int) -> bool:
    """``renameat2(src, dst, flags)``: True when done, False when this system or file
    system cannot (no such call, or the flag is not supported); OSError otherwise."""
    if _RENAMEAT2 is None:
        return False
    if _RENAMEAT2(_AT_FDCWD, os.fsencode(src), _AT_FDCWD, os.fsencode(dst), flags) == 0:
        return True
    err = ctypes.get_errno()
    if err in _UNSUPPORTED:
        return False
    raise OSError(err, os.strerror(err), str(src), None, str(dst))


def rename_exchange(a: str | Path, b: str | Path) -> bool:
    """Swap the paths ``a`` and ``b`` (both exist) in one atomic step: True when done,
    False when the system cannot (the caller falls back to two renames)."""
    return renameat2(a, b, RENAME_EXCHANGE)


def rename_noreplace(src: str | Path, dst: str | Path) -> None:
    """Rename ``src`` to ``dst``, failing (FileExistsError) if ``dst`` exists; without
    ``RENAME_NOREPLACE`` a check, then a plain rename."""
    if not renameat2(src, dst, RENAME_NOREPLACE):
        if os.path.lexists(dst):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(dst))
        os.rename(src, dst)
