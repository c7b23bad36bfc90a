"""The one door every input file comes through: design files (TOML, FOLD, SVG), option
files (``--materials``, ``--printers``, ``--scatter``) and data files (CSV).

:func:`read_input` opens a path once, with ``O_NONBLOCK`` so a FIFO cannot block the
open, and asks the opened descriptor (``fstat``) what it is before reading a byte: a
directory, FIFO, character or block device (``/dev/zero``, ``/dev/urandom``, through a
symbolic link or not) or socket is refused, naming what it is. It then reads at most the
size limit plus one byte, so a file that grows while it is read, or a file system that
reports no size (``/proc``), is refused at the limit instead of read to the end.
:func:`read_input_text` decodes UTF-8 and, for TOML and JSON, refuses nesting the
recursive parsers would choke on (:func:`foldprint.core.schema.check_text`) before they
see it; :func:`read_toml` parses. Every refusal is one line naming the file and what to
do, raised as ``error`` (a :class:`~foldprint.core.errors.FoldprintError`: exit 2).
"""

from __future__ import annotations

import errno
import os
import stat
import tomllib
from pathlib import Path

from .errors import DesignError, FoldprintError
from .schema import MAX_FILE_BYTES, check_text, parse_error

#: what a path that is not a regular file is, by its file type bits
_FILE_TYPES = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
               (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
               (stat.S_ISSOCK, "a socket"))
#: the longest path shown whole in a message (a 5,000-character path is shortened)
SHOWN_PATH = 200
_READ_CHUNK = 1 << 20


def shown(path: str | os.PathLike) -> str:
    """``path`` for a message: whole up to :data:`SHOWN_PATH` characters, else its start
    and its end around "..."."""
    text = os.fspath(path)
    if isinstance(text, bytes):
        text = os.fsdecode(text)
    if len(text) <= SHOWN_PATH:
        return text
    return f"{text[:SHOWN_PATH // 2 - 10]}...{text[-(SHOWN_PATH // 2):]} ({len(text)} characters)"


def stem_text(path: str | os.PathLike) -> str:
    """The stem of a file name as text a file can hold: bytes of the name that are not
    UTF-8 (which Python keeps as lone surrogates) become U+FFFD. A design named after its
    file (an SVG, a FOLD without a title) gets this name."""
    return os.fsencode(Path(path).stem).decode("utf-8", "replace")


def _open_error(exc: OSError, at: str, what: str) -> str:
    if exc.errno == errno.ENOENT:
        return f"{at}: file not found"
    if exc.errno == errno.ENAMETOOLONG:
        return (f"{at}: the path is too long for the file system (a name of at most 255 bytes, a path of at "
                "most 4096); move the file or give a shorter relative path")
    if exc.errno == errno.ELOOP:
        return f"{at}: too many levels of symbolic links; give the path of {what}"
    if exc.errno == errno.ENOTDIR:
        return f"{at}: a part of the path is not a directory"
    if exc.errno == errno.EACCES:
        return f"{at}: permission denied; make the file readable or copy it"
    if exc.errno == errno.ENXIO:  # opening a socket, or a FIFO's other end
        return f"{at}: is not a regular file (a socket or device); expected {what}"
    return f"{at}: cannot read: {exc.strerror or exc}"


def read_input(path: str | os.PathLike, what: str, limit: int = MAX_FILE_BYTES,
               error: type[FoldprintError] = DesignError) -> bytes:
    """The bytes of the regular file at ``path``, at most ``limit`` of them.

    ``what`` names what the file should be, for messages ("a TOML design (.toml)");
    ``error`` is the exception class raised (with one line naming the file). Opened once,
    non-blocking; refused before any read when it is not a regular file."""
    at = shown(path)
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise error(_open_error(exc, at, what)) from None
    except (ValueError, TypeError) as exc:  # an embedded NUL, a path that is not text
        raise error(f"{at}: not a usable path ({exc})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = next((name for test, name in _FILE_TYPES if test(st.st_mode)), "not a regular file")
            raise error(f"{at}: is {kind}, not a regular file; expected {what}")
        if st.st_size > limit:
            raise error(_too_big(at, st.st_size, limit))
        chunks, size = [], 0
        while size <= limit:
            block = os.read(fd, min(_READ_CHUNK, limit + 1 - size))
            if not block:
                break
            chunks.append(block)
            size += len(block)
        if size > limit:
            raise error(_too_big(at, None, limit))
        return b"".join(chunks)
    except OSError as exc:
        raise error(_open_error(exc, at, what)) from None
    finally:
        os.close(fd)


def _size(n: float) -> str:
    return f"{n / 2 ** 20:.3g} MiB" if n >= 2 ** 20 else f"{n / 2 ** 10:.3g} KiB"


def _too_big(at: str, size: int | None, limit: int) -> str:
    have = f"is {_size(size)}" if size is not None else f"holds more than {_size(limit)}"
    return f"{at}: file {have}; input files of at most {_size(limit)} are accepted"


def read_input_text(path: str | os.PathLike, what: str, syntax: str | None = None, limit: int = MAX_FILE_BYTES,
                    error: type[FoldprintError] = DesignError) -> str:
    """:func:`read_input` decoded as UTF-8. ``syntax`` "toml" or "json": nesting deeper
    than the schema allows is refused here, before a recursive parser sees it."""
    raw = read_input(path, what, limit, error)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise error(f"{shown(path)}: not a UTF-8 text file; expected {what}") from None
    if syntax is not None:
        try:
            check_text(text, shown(path), syntax)
        except FoldprintError as exc:
            raise error(str(exc)) from None
    return text


def read_toml(path: str | os.PathLike, what: str, limit: int = MAX_FILE_BYTES,
              error: type[FoldprintError] = DesignError) -> dict:
    """A TOML file through :func:`read_input_text`, parsed; a parse error (also an
    integer of more than 4300 digits) is one line naming the file and the line."""
    text = read_input_text(path, what, "toml", limit, error)
    try:
        return tomllib.loads(text)
    except ValueError as exc:  # TOMLDecodeError, or an integer of more than 4300 digits
        raise error(parse_error(exc, text, shown(path), "toml")) from None

