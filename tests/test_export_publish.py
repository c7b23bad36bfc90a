"""A set of files (an export, a gallery) lands as plain files and as a whole
(``foldprint/exchange/fileset.py``, docs/output-files.md).

Checked on the directory listing itself (``os.walk(followlinks=False)``, ``lstat``): every
entry a regular file or folder, exactly the names of ``foldprint-set.json`` with its
sha256, nothing beside the folder. A writer killed (``os._exit`` in a forked child) after
each of its file-system operations in turn, enumerated, never leaves a mixed set nor
touches a file it did not make; planted names beside and inside the folder are left
alone; refusals are one line and write nothing."""

from __future__ import annotations

import errno
import fcntl
import hashlib
import json
import os
import shutil
import stat
import time
from pathlib import Path

import pytest

from foldprint.core import files as core_files
from foldprint.core.errors import ExportError
from foldprint.exchange import fileset as files_mod
from foldprint.exchange.fileset import StagedSet, recover, sibling_prefix, write_set
from foldprint.exchange.outfolder import MANIFEST, plan

OLD = [("a.3mf", b"old a"), ("b.stl", b"old b"), ("only_old.stl", b"old c")]
NEW = [("a.3mf", b"new a"), ("b.stl", b"new b"), ("only_new.stl", b"new d")]
MINE = {"notes.txt": b"mine", ".hidden": b"mine too", "sub/deep.txt": b"deep"}


def tree(root: Path) -> dict:
    """Every entry under ``root`` without following links: kind and content or target."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(root, followlinks=False):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            rel = os.path.relpath(p, root)
            st = os.lstat(p)
            if stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir", None)
            elif stat.S_ISREG(st.st_mode):
                out[rel] = ("file", Path(p).read_bytes())
            else:
                out[rel] = ("other", None)
    return out


def files_of(out: Path) -> dict:
    """name -> bytes of every regular file under ``out`` (None when it is missing);
    AssertionError on a link or anything but files and folders."""
    if not os.path.lexists(out):
        return None
    t = tree(out)
    assert all(kind in ("file", "dir") for kind, _ in t.values()), t
    return {k: v for k, (kind, v) in t.items() if kind == "file"}


def assert_plain_set(out: Path, expected: dict | None = None) -> dict:
    """``out`` holds plain files only, exactly the manifest's names with its sha256, and
    nothing of foldprint's is left beside it; returns name -> bytes without the manifest."""
    got = files_of(out)
    man = json.loads(got.pop(MANIFEST))
    assert man["tool"] == "foldprint" and man["complete"] is True
    listed = {r["name"]: r for r in man["files"]}
    assert sorted(listed) == sorted(got), (sorted(listed), sorted(got))
    for name, data in got.items():
        assert hashlib.sha256(data).hexdigest() == listed[name]["sha256"] and len(data) == listed[name]["bytes"]
    assert [n for n in os.listdir(out.parent) if n.startswith(sibling_prefix(out))] == []
    assert not [n for n in os.listdir(out) if n.startswith(".foldprint-")]
    if expected is not None:
        assert got == expected
    return got


def test_a_set_is_plain_files_with_a_manifest_and_a_new_set_drops_stale_names(tmp_path):
    out = tmp_path / "out"
    paths = write_set(out, OLD)
    assert paths == [out / n for n, _ in OLD]
    assert os.listdir(tmp_path) == ["out"]
    assert_plain_set(out, dict(OLD))
    write_set(out, NEW)  # a re-export that drops a name: the stale file is gone
    assert_plain_set(out, dict(NEW))
    assert os.listdir(tmp_path) == ["out"]


def test_files_and_folders_get_the_users_umask(tmp_path):
    old = os.umask(0o027)
    try:
        with StagedSet(tmp_path / "out") as st:
            st.write("a.txt", b"a")
            st.write("sub/b.txt", b"b")
        write_set(tmp_path / "flat", NEW)
    finally:
        os.umask(old)
    for p in (tmp_path / "out", tmp_path / "out" / "sub", tmp_path / "flat"):
        assert stat.S_IMODE(os.lstat(p).st_mode) == 0o750, p
    for p in [tmp_path / "out" / "a.txt", tmp_path / "out" / "sub" / "b.txt", tmp_path / "out" / MANIFEST,
              *(tmp_path / "flat").iterdir()]:
        assert stat.S_IMODE(os.lstat(p).st_mode) == 0o640, p


def test_a_re_export_keeps_the_folders_own_permissions(tmp_path):
    out = tmp_path / "out"
    write_set(out, OLD)
    os.chmod(out, 0o700)
    write_set(out, NEW)
    assert stat.S_IMODE(os.lstat(out).st_mode) == 0o700


# -- killed at every step ---------------------------------------------------------------

HOOKED_OS = ("replace", "rename", "unlink", "rmdir", "mkdir", "fsync", "chmod")


def _killed_at(step: int, run) -> bool:
    """Run ``run()`` in a child that dies (``os._exit``) at its ``step``-th file-system
    operation (a rename or ``renameat2``, a file created, an fsync, a folder made or
    removed, a file removed); True when it was killed, False when it finished first."""
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

        try:
            for name in HOOKED_OS:
                setattr(os, name, hook(getattr(os, name)))
            shutil.rmtree = hook(shutil.rmtree)
            core_files.renameat2 = hook(core_files.renameat2)
            core_files.open = hook(open)  # every file the writer creates
            run()
        except BaseException:
            os._exit(3)
        os._exit(0)
    _, status = os.waitpid(pid, 0)
    code = os.waitstatus_to_exitcode(status)
    assert code in (0, 9), f"step {step}: the writer failed (exit {code})"
    return code == 9


def _legacy(out: Path, files) -> None:
    """An export in the earlier layout: every name a link through a switch into a set."""
    s = out / ".foldprint-sets" / "set-abcd1234"
    s.mkdir(parents=True)
    for n, b in files:
        (s / n).write_bytes(b)
        os.symlink(f".foldprint-current/{n}", out / n)
    os.symlink(".foldprint-sets/set-abcd1234", out / ".foldprint-current")


def _no_renameat2():
    core_files._RENAMEAT2 = None  # a system without renameat2: two renames


SCENARIOS = {
    # name: (set up the folder, what a reader may see after a kill, run in the child)
    "swap": (lambda out: write_set(out, OLD), ("old", "new"), lambda out: write_set(out, NEW)),
    "two-renames": (lambda out: write_set(out, OLD), ("old", "new", None),
                    lambda out: (_no_renameat2(), write_set(out, NEW))),
    "first": (lambda out: None, ("new", None), lambda out: write_set(out, NEW)),
    "legacy": (lambda out: _legacy(out, OLD), ("old", "new"), lambda out: write_set(out, NEW)),
}


def _state(out: Path) -> str | None:
    """'old', 'new', None (no folder) or the names a reader sees (a mix), links followed."""
    if not os.path.lexists(out):
        return None
    seen = {p.name: p.read_bytes() for p in out.iterdir() if not p.name.startswith(".") and p.name != MANIFEST}
    for name, ref in (("old", dict(OLD)), ("new", dict(NEW))):
        if seen == ref:
            return name
    return repr(seen)


@pytest.mark.parametrize("scenario", list(SCENARIOS))
def test_a_kill_after_any_step_leaves_one_complete_set(tmp_path, scenario):
    setup, allowed, run = SCENARIOS[scenario]
    step, kills = 0, 0
    while True:
        base = tmp_path / f"k{step}"
        base.mkdir()
        (base / "keep.txt").write_bytes(b"mine")
        out = base / "out"
        setup(out)
        killed = _killed_at(step, lambda: run(out))
        st = _state(out)
        assert st in allowed, (step, st)
        if not killed:
            assert st == "new"
            assert_plain_set(out, dict(NEW))
            break
        kills += 1
        recover(out)  # the next run first cleans up: a folder that was there is there again
        assert _state(out) in allowed and (_state(out) is not None or scenario == "first"), (step, _state(out))
        write_set(out, NEW)
        assert_plain_set(out, dict(NEW))
        assert sorted(os.listdir(base)) == ["keep.txt", "out"] and (base / "keep.txt").read_bytes() == b"mine"
        step += 1
    assert kills >= {"first": 6, "two-renames": 12}.get(scenario, 10), kills


def test_a_kill_while_publishing_file_by_file_never_touches_the_users_files(tmp_path):
    """With --force into a folder of the user's files: each of our names is the old or
    the new file (a mix of the two sets is the documented risk), the user's files never
    change, and the next run finishes the set."""
    step, kills = 0, 0
    while True:
        out = tmp_path / f"k{step}"
        out.mkdir()
        for n, b in MINE.items():
            (out / n).parent.mkdir(parents=True, exist_ok=True)
            (out / n).write_bytes(b)
        write_set(out, OLD, force=True)
        killed = _killed_at(step, lambda: write_set(out, NEW, force=True))
        seen = files_of(out)
        assert {n: seen.get(n) for n in MINE} == MINE, step
        for n, b in dict(NEW).items():
            assert seen.get(n) in (dict(OLD).get(n), b), (step, n)
        if not killed:
            break
        kills += 1
        write_set(out, NEW, force=True)
        seen = files_of(out)
        assert {n: seen.get(n) for n in MINE} == MINE
        assert {n: seen.get(n) for n, _ in NEW} == dict(NEW) and "only_old.stl" not in seen
        step += 1
    assert kills >= 8
    assert sorted(r["name"] for r in json.loads((out / MANIFEST).read_text())["files"]) == sorted(dict(NEW))


def test_without_renameat2_a_failed_second_rename_puts_the_earlier_set_back(tmp_path, monkeypatch):
    out = tmp_path / "out"
    write_set(out, OLD)
    monkeypatch.setattr(core_files, "_RENAMEAT2", None)
    real_rename = os.rename

    def rename(src, dst, *a, **kw):
        if Path(dst) == out and ".foldprint-tmp-" in str(src):
            raise OSError(28, "No space left on device")
        return real_rename(src, dst, *a, **kw)

    monkeypatch.setattr(os, "rename", rename)
    with pytest.raises(ExportError, match="No space left"):
        write_set(out, NEW)
    assert_plain_set(out, dict(OLD))


# -- what is left alone, what is recovered ----------------------------------------------

def _plant_beside(base: Path) -> dict:
    """Entries beside ``out`` named like foldprint's staging folders that are not ours."""
    pre = sibling_prefix(base / "out")
    (base / "elsewhere").mkdir()
    (base / "elsewhere" / "x").write_bytes(b"x")
    (base / f"{pre}tmp-aaaaaaaa").write_bytes(b"a file, not a folder")
    (base / f"{pre}tmp-bbbbbbbb").mkdir()
    (base / f"{pre}tmp-bbbbbbbb" / "mine.txt").write_bytes(b"no manifest: not ours")
    (base / f"{pre}tmp-cccccccc").mkdir()
    (base / f"{pre}tmp-cccccccc" / MANIFEST).write_text(json.dumps({"tool": "another", "files": []}))
    os.symlink("elsewhere", base / f"{pre}tmp-dddddddd")
    (base / f"{pre}old-eeeeeeee").mkdir()
    (base / f"{pre}old-eeeeeeee" / "mine.txt").write_bytes(b"not a set of ours")
    (base / f"{pre}tmp-TOOLONGNAME").mkdir()
    return tree(base)


def test_names_like_ours_that_are_not_ours_are_left_alone(tmp_path):
    before = _plant_beside(tmp_path)
    out = tmp_path / "out"
    recover(out)  # "out" is missing: the foreign old-... folder must not be put in its place
    assert not out.exists() and tree(tmp_path) == before
    write_set(out, OLD)
    write_set(out, NEW)
    after = tree(tmp_path)
    assert {k: after.get(k) for k in before} == before


def test_what_a_killed_run_left_is_removed_and_a_set_aside_is_put_back(tmp_path):
    out = tmp_path / "out"
    write_set(out, OLD)
    pre = sibling_prefix(out)
    stage = tmp_path / f"{pre}tmp-abcd1234"  # a staging folder killed mid-write
    stage.mkdir()
    (stage / MANIFEST).write_bytes(json.dumps({"tool": "foldprint", "complete": False, "files": []}).encode())
    (stage / "a.3mf").write_bytes(b"half")
    empty = tmp_path / f"{pre}tmp-efgh5678"  # killed between mkdir and its manifest
    empty.mkdir()
    inside = out / ".foldprint-tmp-ijkl9012"  # a file-by-file staging folder
    inside.mkdir()
    (inside / MANIFEST).write_bytes((out / MANIFEST).read_bytes())
    os.rename(out, tmp_path / f"{pre}old-mnop3456")  # killed between the two renames
    done = recover(out)
    assert sorted(os.listdir(tmp_path)) == ["out"], done
    assert_plain_set(out, dict(OLD))


def test_a_live_writers_staging_folder_is_not_recovered(tmp_path):
    out = tmp_path / "out"
    with StagedSet(out) as st:  # another writer, still writing
        st.write("a.3mf", b"theirs")
        write_set(out, NEW)  # publishes, recovers, and leaves the live folder alone
        assert st.path.is_dir() and (st.path / "a.3mf").read_bytes() == b"theirs"
    assert_plain_set(out, {"a.3mf": b"theirs"})  # the last to publish wins, whole


def test_a_users_folder_is_never_changed_by_force(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    for n, b in MINE.items():
        (out / n).parent.mkdir(parents=True, exist_ok=True)
        (out / n).write_bytes(b)
    os.symlink("notes.txt", out / "mylink")
    inodes = {n: os.lstat(out / n).st_ino for n in [*MINE, "mylink"]}
    with pytest.raises(ExportError, match="holds files foldprint did not write"):
        write_set(out, OLD)
    write_set(out, OLD, force=True)
    write_set(out, NEW, force=True)  # drops only_old.stl: ours, unchanged, so it goes
    seen = tree(out)
    assert {n: seen[n][1] for n in MINE} == MINE and seen["mylink"] == ("link", "notes.txt")
    assert inodes == {n: os.lstat(out / n).st_ino for n in inodes}
    assert {n: seen[n][1] for n, _ in NEW} == dict(NEW) and "only_old.stl" not in seen
    assert sorted(r["name"] for r in json.loads((out / MANIFEST).read_text())["files"]) == sorted(dict(NEW))


def test_a_nested_set_file_by_file_keeps_the_users_files_in_its_folders(tmp_path):
    """The gallery's shape (folders in the set) published with force beside the user's files."""
    out = tmp_path / "site"
    (out / "d").mkdir(parents=True)
    (out / "d" / "mine.txt").write_bytes(b"mine")
    (out / "notes.txt").write_bytes(b"notes")

    def publish(names):
        with StagedSet(out, force=True) as st:
            for n in names:
                st.write(n, n.encode())

    publish(["index.html", "d/x.png", "d/y.png", "e/z.png"])
    publish(["index.html", "d/x.png"])  # y and the folder e dropped
    seen = files_of(out)
    seen.pop(MANIFEST)
    assert seen == {"index.html": b"index.html", "d/x.png": b"d/x.png", "d/mine.txt": b"mine",
                    "notes.txt": b"notes"}
    assert not (out / "e").exists() and os.listdir(tmp_path) == ["site"]


def test_a_changed_file_of_an_export_is_the_users(tmp_path):
    out = tmp_path / "out"
    write_set(out, OLD)
    (out / "only_old.stl").write_bytes(b"edited by the user")
    before = tree(tmp_path)
    with pytest.raises(ExportError, match=r"only_old\.stl changed after foldprint wrote it.*--force"):
        write_set(out, NEW)
    assert tree(tmp_path) == before
    write_set(out, NEW, force=True)  # not ours any more: replaced only if the new set has it
    assert (out / "only_old.stl").read_bytes() == b"edited by the user"


def test_a_legacy_export_of_links_is_replaced_by_plain_files(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    _legacy(out, OLD)
    write_set(out, NEW)
    assert_plain_set(out, dict(NEW))


# -- refusals ---------------------------------------------------------------------------

def _refusal(tmp_path, monkeypatch, case):
    base = tmp_path / "w"
    base.mkdir()
    (base / "design.toml").write_text("x")
    if case == "file":
        return base / "design.toml", "is a file, not a folder"
    if case == "below-a-file":
        return base / "design.toml" / "out", "design.toml is a file"
    if case == "dangling-link":
        os.symlink("missing", base / "out")
        return base / "out", "is a link to 'missing', which does not exist"
    if case == "cwd":  # an earlier export, opened in a shell
        write_set(base / "exp", OLD)
        monkeypatch.chdir(base / "exp")
        return Path("."), "is the current folder"
    if case == "parent-of-cwd":
        (base / "sub" / "deeper").mkdir(parents=True)
        monkeypatch.chdir(base / "sub" / "deeper")
        return Path(".."), "holds files foldprint did not write"
    if case == "empty-cwd":
        (base / "empty").mkdir()
        monkeypatch.chdir(base / "empty")
        return Path("."), "is the current folder or holds it"
    return Path(case), {"/": "root of the file system"}.get(case, "is a system folder")


@pytest.mark.parametrize("case", ["file", "below-a-file", "dangling-link", "cwd", "parent-of-cwd", "empty-cwd",
                                  "/", "/etc", "/usr/share/foldprint", "/proc/self", "/tmp"])
def test_places_no_export_goes_are_refused_in_one_line_and_nothing_is_written(tmp_path, monkeypatch, case):
    out, message = _refusal(tmp_path, monkeypatch, case)
    before = tree(tmp_path)
    with pytest.raises(ExportError) as err:
        write_set(out, NEW)
    assert message in str(err.value) and "\n" not in str(err.value) and str(out) in str(err.value)
    assert tree(tmp_path) == before
    if case in ("/", "/etc", "/proc/self", "/tmp", "file", "below-a-file", "dangling-link"):
        with pytest.raises(ExportError):  # --force does not open these
            write_set(out, NEW, force=True)


def test_the_current_folder_takes_a_set_file_by_file_with_force(tmp_path, monkeypatch):
    (tmp_path / "design.toml").write_text("x")
    monkeypatch.chdir(tmp_path)
    write_set(".", NEW, force=True)
    assert os.getcwd() == str(tmp_path) and (tmp_path / "design.toml").read_text() == "x"
    assert {n: (tmp_path / n).read_bytes() for n, _ in NEW} == dict(NEW)


def test_a_refusal_comes_before_a_gallery_builds_anything(tmp_path):
    from foldprint.apps.gallery.runner import build_gallery
    from foldprint.model.design import strip

    out = tmp_path / "site"
    out.mkdir()
    (out / "index.html").write_text("the user's own page")
    calls = []
    with pytest.raises(ExportError, match="holds files foldprint did not write"):
        build_gallery([strip("tiny", [10.0, 10.0], [90.0], ["H-1"])], out, progress=lambda *a: calls.append(a))
    assert calls == [] and os.listdir(out) == ["index.html"] and os.listdir(tmp_path) == ["site"]


def test_a_set_name_that_collides_with_the_manifest_is_refused(tmp_path):
    for bad in (MANIFEST, ".foldprint-current", ".foldprint-abcd1234.tmp", "../x", "a/b", ""):
        with pytest.raises(ExportError, match="not a valid file name"):
            write_set(tmp_path / "o", [(bad, b"x")])
    assert not (tmp_path / "o").exists()


def test_a_directory_where_a_file_goes_is_refused_before_writing(tmp_path):
    out = tmp_path / "out"
    (out / "a.3mf").mkdir(parents=True)
    with pytest.raises(ExportError, match="holds files foldprint did not write"):
        write_set(out, NEW)
    with pytest.raises(ExportError, match="is a directory"):
        write_set(out, NEW, force=True)
    assert sorted(os.listdir(out)) == ["a.3mf"] and os.listdir(tmp_path) == ["out"]


def test_plan_says_how_a_set_lands(tmp_path):
    out = tmp_path / "out"
    assert str(plan(out).publish) == "whole"
    write_set(out, OLD)
    assert str(plan(out).holding.kind) == "export" and str(plan(out).publish) == "whole"
    (out / "x").write_bytes(b"")
    assert str(plan(out, force=True).publish) == "file by file"


# -- two writers, and readers, at once ----------------------------------------------------

def _snapshot(out: Path) -> dict | None:
    """What a careful reader sees: the files of the folder named ``out``, read through
    the folder's fd, again if ``out`` was replaced while it read (the folder it opened is
    then the earlier set, being removed); None when there is no folder."""
    while True:
        try:
            fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
        except FileNotFoundError:
            return None
        try:
            seen = {}
            for n in os.listdir(fd):
                with os.fdopen(os.open(n, os.O_RDONLY | os.O_NOFOLLOW, dir_fd=fd), "rb") as fh:
                    seen[n] = fh.read()
            if os.stat(out).st_ino == os.fstat(fd).st_ino:
                return seen
        except FileNotFoundError:
            pass
        finally:
            os.close(fd)


def test_racing_writers_and_readers_see_one_complete_set(tmp_path):
    out = tmp_path / "out"
    sets = {k: [(f"{k}{i}.stl", f"{k} {i}".encode() * 50) for i in range(6)] for k in "ab"}
    running = {}
    for k in "ab":
        pid = os.fork()
        if pid == 0:
            try:
                for _ in range(15):
                    write_set(out, sets[k])
            except BaseException:
                os._exit(1)
            os._exit(0)
        running[pid] = None
    seen_states, deadline = set(), time.monotonic() + 300
    while any(code is None for code in running.values()) and time.monotonic() < deadline:
        snap = _snapshot(out)
        if snap is not None:
            snap.pop(MANIFEST, None)
            state = next((k for k, files in sets.items() if snap == dict(files)), snap)
            assert state in ("a", "b"), f"a reader saw a mix: {sorted(snap)}"
            seen_states.add(state)
        for pid in running:
            if running[pid] is None:
                done, status = os.waitpid(pid, os.WNOHANG)
                if done:
                    running[pid] = os.waitstatus_to_exitcode(status)
    assert list(running.values()) == [0, 0], running
    final = assert_plain_set(out)
    assert final in (dict(sets["a"]), dict(sets["b"])) and os.listdir(tmp_path) == ["out"]


# -- core/files: the file-system steps a set is made of ------------------------------------

def test_write_atomic_writes_text_as_utf8_and_refuses_with_the_path(tmp_path):
    """Text is written as its UTF-8 bytes; a target it cannot replace (a folder) is one
    ExportError naming the path, with no temp file left beside it."""
    text = "Tg = 45 °C, Δt = 3.03 s\n"
    p = core_files.write_atomic(tmp_path / "note.txt", text)
    assert p.read_bytes() == text.encode("utf-8")
    (tmp_path / "taken").mkdir()
    with pytest.raises(ExportError, match=r"taken: cannot write: Is a directory"):
        core_files.write_atomic(tmp_path / "taken", b"x")
    assert sorted(os.listdir(tmp_path)) == ["note.txt", "taken"]


def test_rename_errors_name_both_paths(tmp_path):
    """A rename of a missing source is the OS's error with its number and both paths,
    whether renameat2 or the fallback rename raised it."""
    src, dst = tmp_path / "missing", tmp_path / "dst"
    with pytest.raises(FileNotFoundError) as err:
        core_files.rename_noreplace(src, dst)
    assert (err.value.errno, err.value.filename, err.value.filename2) == (errno.ENOENT, str(src), str(dst))


def test_rename_noreplace_without_renameat2(tmp_path, monkeypatch):
    """Where the system has no RENAME_NOREPLACE (renameat2 says it cannot): a check, then a
    plain rename; an existing target is FileExistsError (EEXIST, its path), both kept."""
    monkeypatch.setattr(core_files, "renameat2", lambda src, dst, flags: False)
    a, b = tmp_path / "a", tmp_path / "b"
    a.write_bytes(b"A")
    core_files.rename_noreplace(a, b)
    assert not a.exists() and b.read_bytes() == b"A"
    a.write_bytes(b"new")
    with pytest.raises(FileExistsError) as err:
        core_files.rename_noreplace(a, b)
    assert (err.value.errno, err.value.filename) == (errno.EEXIST, str(b))
    assert a.read_bytes() == b"new" and b.read_bytes() == b"A"


# -- exchange/files: the edges of a publication --------------------------------------------

def test_recover_removes_only_its_own_stale_temp_files(tmp_path):
    """recover removes write_atomic's temp files older than STALE_TMP_S, and nothing else:
    not a fresh one (a writer may be using it), not a user's old file, not a link that
    merely has a temp file's name."""
    old = time.time() - 2 * files_mod.STALE_TMP_S
    stale, fresh = tmp_path / ".foldprint-abcd1234.tmp", tmp_path / ".foldprint-efgh5678.tmp"
    mine, link = tmp_path / "notes.txt", tmp_path / ".foldprint-link0000.tmp"
    for p in (stale, fresh, mine):
        p.write_bytes(b"x")
    link.symlink_to(mine)
    for p in (stale, mine):
        os.utime(p, (old, old))
    os.utime(link, (old, old), follow_symlinks=False)
    done = recover(tmp_path)
    assert done == [f"removed {stale.name}"]
    assert sorted(os.listdir(tmp_path)) == sorted([fresh.name, mine.name, link.name])


def test_write_set_calls_a_callable_for_its_bytes(tmp_path):
    paths = write_set(tmp_path / "out", [("a.txt", lambda: b"made late"), ("b.txt", b"given")])
    assert [p.read_bytes() for p in paths] == [b"made late", b"given"]


def test_a_folder_name_with_undecodable_bytes_is_published(tmp_path):
    """A folder whose name is not UTF-8 (a surrogate-escaped byte): its staging folders'
    prefix is made, and the set lands."""
    out = tmp_path / os.fsdecode(b"set-\xff")
    assert sibling_prefix(out).startswith(".set-")
    write_set(out, [("a.txt", b"A")])
    assert (out / "a.txt").read_bytes() == b"A" and os.listdir(tmp_path) == [out.name]


def test_an_interrupt_while_publishing_stays_an_interrupt(tmp_path, monkeypatch):
    """Ctrl-C during publication propagates as KeyboardInterrupt (not relabelled as a write
    error), and nothing of the set is left."""
    def interrupt(*a, **k):
        raise KeyboardInterrupt

    def data():
        monkeypatch.setattr(files_mod, "plan", interrupt)  # the set is staged: publication fails
        return b"A"

    with pytest.raises(KeyboardInterrupt):
        write_set(tmp_path / "out", [("a.txt", data)])
    assert os.listdir(tmp_path) == []


def test_an_earlier_set_that_cannot_be_removed_is_a_warning_naming_why(tmp_path, monkeypatch, caplog):
    out = tmp_path / "out"
    write_set(out, [("a.txt", b"old")])

    def busy(path):
        raise OSError(16, "Device or resource busy")

    monkeypatch.setattr(files_mod, "_remove_set", busy)
    with caplog.at_level("WARNING", logger=files_mod.__name__):
        write_set(out, [("a.txt", b"new")])
    assert (out / "a.txt").read_bytes() == b"new"
    [msg] = [r.getMessage() for r in caplog.records if r.name == files_mod.__name__]
    assert str(out) in msg and "resource busy" in msg


def test_the_lock_falls_back_to_the_folder_when_its_parent_cannot_be_opened(tmp_path, monkeypatch):
    """Two writers of one folder publish one after the other even where the parent cannot
    be opened: the lock is then taken on the folder itself (another open of it cannot)."""
    real = tmp_path / "out"
    real.mkdir()
    opener = os.open

    def no_parent(path, flags, *a):
        if Path(path) == tmp_path:
            raise PermissionError(13, "Permission denied", str(path))
        return opener(path, flags, *a)

    monkeypatch.setattr(files_mod.os, "open", no_parent)
    with files_mod._dir_lock(real):
        fd = opener(real, os.O_RDONLY | os.O_DIRECTORY)
        try:
            with pytest.raises(BlockingIOError):
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        finally:
            os.close(fd)


def test_files_made_in_the_staging_folder_directly_are_in_the_manifest(tmp_path):
    """The gallery's workers write into ``st.path`` themselves: such files, and a file
    written by ``st.write`` then rewritten in place, are listed with their own size and
    sha256 (checked by assert_plain_set against the bytes on disk)."""
    out = tmp_path / "out"
    with StagedSet(out) as st:
        (st.path / "sub").mkdir()
        (st.path / "sub" / "direct.png").write_bytes(b"made by a worker")
        st.write("page.html", b"first")
        (st.path / "page.html").write_bytes(b"rewritten, longer")
    assert_plain_set(out, {"sub/direct.png": b"made by a worker", "page.html": b"rewritten, longer"})


def test_a_staging_folder_that_cannot_be_made_is_one_export_error(tmp_path, monkeypatch):
    """A full disk before anything is staged: ExportError naming the folder, nothing made."""
    def full(path, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(files_mod.os, "mkdir", full)
    with pytest.raises(ExportError, match=r"out: cannot write: No space left on device"):
        write_set(tmp_path / "out", NEW)
    assert os.listdir(tmp_path) == []


def test_a_publication_into_a_users_folder_is_marked_incomplete_until_it_ends(tmp_path, monkeypatch):
    """File by file into a folder of the user's files: the manifest says complete: false
    (with the files it is replacing) from before the first file moves, so a run stopped
    half-way is never read as a whole set."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_bytes(b"mine")
    write_set(out, OLD, force=True)
    replace = os.replace

    def stop_after_manifest(src, dst):
        if Path(dst).name != MANIFEST:
            raise OSError(errno.EIO, "Input/output error", str(dst))
        replace(src, dst)

    monkeypatch.setattr(files_mod.os, "replace", stop_after_manifest)
    with pytest.raises(ExportError, match="Input/output error"):
        write_set(out, NEW, force=True)
    man = json.loads((out / MANIFEST).read_bytes())
    assert man["complete"] is False
    assert {r["name"] for r in man["files"]} >= {n for n, _ in OLD + NEW}


def test_a_legacy_export_that_is_the_current_folder_becomes_plain_files(tmp_path, monkeypatch):
    """File by file (--force: the current folder cannot be replaced whole) over an export
    of the earlier layout: its links, its switch and its sets go; plain files remain."""
    out = tmp_path / "out"
    out.mkdir()
    _legacy(out, OLD)
    monkeypatch.chdir(out)
    write_set(out, NEW, force=True)
    assert sorted(os.listdir(out)) == sorted([MANIFEST, *(n for n, _ in NEW)])
    assert_plain_set(out, dict(NEW))


def test_write_atomic_without_replace_keeps_what_is_there(tmp_path):
    """``replace=False`` (the studio's save of a new file) writes a new file whole, but
    never over one that exists: FileExistsError, the old bytes kept, no temp file left."""
    from foldprint.core.files import write_atomic

    p = tmp_path / "d.toml"
    assert write_atomic(p, "first", replace=False) == p and p.read_text() == "first"
    with pytest.raises(FileExistsError):
        write_atomic(p, "second", replace=False)
    assert p.read_text() == "first" and sorted(x.name for x in tmp_path.iterdir()) == ["d.toml"]
    write_atomic(p, "third")  # the default replaces
    assert p.read_text() == "third"
