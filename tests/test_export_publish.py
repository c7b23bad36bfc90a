"""The export set is published by one rename (issue 20 item 5): a process killed after any
step of :func:`write_set` leaves exactly the previous or the new set readable; planted
files in ``--out`` are refused or left alone, never followed or deleted."""

from __future__ import annotations

import os
import shutil

import pytest

from foldprint.core.errors import ExportError
from foldprint.exchange.files import CURRENT, SETS, recover, write_set

OLD = [("a.3mf", b"old a"), ("b.stl", b"old b"), ("only_old.stl", b"old c")]
NEW = [("a.3mf", b"new a"), ("b.stl", b"new b"), ("only_new.stl", b"new d")]


def readable(out):
    """name -> bytes of every visible name a reader can open."""
    return {p.name: p.read_bytes() for p in sorted(out.iterdir()) if not p.name.startswith(".") and p.is_file()}


def _killed_at(out, files, step) -> bool:
    """Run write_set in a child that dies (os._exit) at its ``step``-th file-system
    operation; True when it was killed, False when it finished first."""
    pid = os.fork()
    if pid == 0:  # child
        count = [0]

        def hook(fn):
            def wrapped(*a, **kw):
                count[0] += 1
                if count[0] > step:
                    os._exit(9)
                return fn(*a, **kw)
            return wrapped

        for name in ("replace", "symlink", "unlink", "link", "rmdir", "mkdir", "fsync", "chmod"):
            setattr(os, name, hook(getattr(os, name)))
        shutil.rmtree = hook(shutil.rmtree)
        try:
            write_set(out, files)
        finally:
            os._exit(0)
    _, status = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(status) == 9


@pytest.mark.parametrize("legacy", [False, True], ids=["layout", "legacy-files"])
def test_a_kill_after_any_step_leaves_one_complete_set(tmp_path, legacy):
    # legacy: the previous set as plain files of the names the new one shares (an export
    # made before this layout; a plain file of another name is not ours and stays)
    old = {n: b for n, b in OLD if n in dict(NEW)} if legacy else dict(OLD)
    new = dict(NEW)
    step, kills = 0, 0
    while True:
        out = tmp_path / f"out{step}"
        if legacy:
            out.mkdir()
            for n, b in old.items():
                (out / n).write_bytes(b)
        else:
            write_set(out, OLD)
        killed = _killed_at(out, NEW, step)
        seen = readable(out)
        assert seen in (old, new), (step, seen)
        if not killed:
            assert seen == new
            break
        kills += 1
        write_set(out, NEW)  # the next export cleans up whatever the kill left
        assert readable(out) == new
        assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == [CURRENT, SETS]
        assert len(os.listdir(out / SETS)) == 1
        step += 1
    assert kills >= 10  # every step of the publication was hit


def test_planted_switch_pointing_outside_is_refused(tmp_path):
    keep = tmp_path / "keep.txt"
    keep.write_text("mine")
    out = tmp_path / "out"
    out.mkdir()
    os.symlink("../keep.txt", out / CURRENT)
    with pytest.raises(ExportError, match=r"\.foldprint-current.*not a link foldprint made"):
        write_set(out, NEW)
    assert keep.read_text() == "mine" and os.readlink(out / CURRENT) == "../keep.txt"
    assert readable(out) == {}


@pytest.mark.parametrize("planted", ["file", "binary", "sets-link"])
def test_planted_switch_or_sets_folder_is_refused_with_a_message(tmp_path, planted):
    out = tmp_path / "out"
    out.mkdir()
    if planted == "file":
        (out / CURRENT).write_text("../keep.txt\n")
    elif planted == "binary":
        os.symlink(b"\xff\xfe/../x".decode("utf-8", "surrogateescape"), out / CURRENT)
    else:
        (tmp_path / "elsewhere").mkdir()
        os.symlink("../elsewhere", out / SETS)
    with pytest.raises(ExportError, match="foldprint made"):
        write_set(out, NEW)
    assert not (tmp_path / "elsewhere").exists() or list((tmp_path / "elsewhere").iterdir()) == []


def test_user_files_in_out_are_left_alone(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    mine = {".notes.abcdefgh.tmp": b"1", "notes.txt": b"2", ".foldprint-x.tmp": b"3"}
    for n, b in mine.items():
        (out / n).write_bytes(b)
    os.symlink("elsewhere/a.3mf", out / "mylink")
    write_set(out, OLD)
    write_set(out, NEW)
    recover(out)
    for n, b in mine.items():
        assert (out / n).read_bytes() == b
    assert os.readlink(out / "mylink") == "elsewhere/a.3mf"
    assert {k: v for k, v in readable(out).items() if k in dict(NEW)} == dict(NEW)
    assert "only_old.stl" not in os.listdir(out)


def test_stale_temp_files_of_ours_are_removed_only_when_old(tmp_path):
    out = tmp_path / "out"
    write_set(out, OLD)
    stale, fresh = out / ".foldprint-abcd1234.tmp", out / ".foldprint-efgh5678.tmp"
    stale.write_bytes(b"x")
    fresh.write_bytes(b"y")
    os.utime(stale, (1, 1))
    write_set(out, NEW)
    assert not stale.exists() and fresh.exists()  # a concurrent write_atomic's file survives


def test_a_set_name_that_collides_with_the_layout_is_refused(tmp_path):
    with pytest.raises(ExportError, match="not a valid file name"):
        write_set(tmp_path / "o", [(CURRENT, b"x")])
    assert not (tmp_path / "o").exists()


def test_a_directory_where_a_file_goes_is_refused_before_writing(tmp_path):
    out = tmp_path / "out"
    (out / "a.3mf").mkdir(parents=True)
    with pytest.raises(ExportError, match="is a directory"):
        write_set(out, NEW)
    assert sorted(os.listdir(out)) == ["a.3mf"]


def test_flatten_leaves_plain_files_and_the_next_export_adopts_them(tmp_path):
    from foldprint.exchange.files import flatten

    out = tmp_path / "out"
    write_set(out, OLD)
    flatten(out)
    assert sorted(os.listdir(out)) == sorted(n for n, _ in OLD)
    assert all(not (out / n).is_symlink() for n, _ in OLD) and readable(out) == dict(OLD)
    write_set(out, NEW)
    assert {k: v for k, v in readable(out).items() if k in dict(NEW)} == dict(NEW)
