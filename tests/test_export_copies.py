"""An export is plain files: the tools users copy folders with (``cp -r``, ``zip -r``,
``rsync -a``, ``find``, Python's ``glob("**")``) see each file once, as a file, and the copy
reads back with the bytes ``foldprint-set.json`` names (docs/output-files.md)."""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import stat
import subprocess
from pathlib import Path

import pytest

from foldprint.cli.commands import main
from foldprint.exchange.outfolder import MANIFEST

RSYNC = shutil.which("rsync")


def _run(capsys, *args) -> dict:
    code = main(list(args))
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def check_copy(folder: Path) -> dict:
    """Every entry under ``folder`` a regular file or folder (``lstat``), exactly the
    manifest's names plus the manifest, each with the manifest's size and sha256."""
    found = {}
    for dirpath, dirnames, filenames in os.walk(folder, followlinks=False):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            mode = os.lstat(p).st_mode
            assert stat.S_ISREG(mode) or stat.S_ISDIR(mode), f"{p} is neither a file nor a folder"
            if stat.S_ISREG(mode):
                found[os.path.relpath(p, folder)] = Path(p).read_bytes()
    manifest = json.loads(found.pop(MANIFEST))
    assert sorted(r["name"] for r in manifest["files"]) == sorted(found)
    for r in manifest["files"]:
        data = found[r["name"]]
        assert len(data) == r["bytes"] and hashlib.sha256(data).hexdigest() == r["sha256"], r["name"]
    return found


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    """self_lock exported with four formats, then again with three (fold dropped)."""
    root = tmp_path_factory.mktemp("copies")
    out = root / "self_lock"
    assert main(["export", "self_lock", "--out", str(out), "--format", "3mf,prusa3mf,stl,fold", "--json"]) == 0
    first = check_copy(out)
    assert main(["export", "self_lock", "--out", str(out), "--format", "3mf,prusa3mf,stl", "--json"]) == 0
    return root, out, first


def test_a_re_export_that_drops_a_format_leaves_no_stale_file(export):
    root, out, first = export
    second = check_copy(out)
    assert "self_lock.fold" in first and "self_lock.fold" not in second
    assert sorted(second) == sorted(n for n in first if n != "self_lock.fold")
    assert os.listdir(root) == ["self_lock"]  # nothing of foldprint's beside it


def test_the_json_lists_what_the_manifest_lists(capsys, tmp_path):
    out = tmp_path / "x"
    rec = _run(capsys, "export", "self_lock", "--out", str(out), "--format", "3mf,stl", "--json")
    files = check_copy(out)
    assert rec["manifest"] == str(out / MANIFEST) and rec["published"] == "whole"
    assert sorted(Path(r["path"]).name for r in rec["files"]) == sorted(files)
    assert all(r["bytes"] == len(files[Path(r["path"]).name]) for r in rec["files"])


def test_find_and_glob_see_each_file_once(export):
    _, out, _ = export
    names = sorted(check_copy(out)) + [MANIFEST]
    found = subprocess.run(["find", str(out), "-mindepth", "1"], capture_output=True, text=True, check=True)
    assert sorted(os.path.relpath(p, out) for p in found.stdout.split("\n") if p) == sorted(names)
    links = subprocess.run(["find", str(out), "-type", "l"], capture_output=True, text=True, check=True)
    assert links.stdout == ""
    assert sorted(p.name for p in out.glob("**/*") if p.is_file()) == sorted(names)


def test_cp_r_copies_files(export, tmp_path):
    _, out, _ = export
    subprocess.run(["cp", "-r", str(out), str(tmp_path / "copy")], check=True)
    assert check_copy(tmp_path / "copy") == check_copy(out)


def test_zip_r_and_unzip_give_the_files_back(export, tmp_path):
    _, out, _ = export
    if shutil.which("zip") is None or shutil.which("unzip") is None:
        pytest.skip("zip/unzip are not on PATH")
    archive = tmp_path / "export.zip"
    subprocess.run(["zip", "-q", "-r", str(archive), out.name], cwd=out.parent, check=True)
    subprocess.run(["unzip", "-q", str(archive), "-d", str(tmp_path / "unzipped")], check=True)
    assert check_copy(tmp_path / "unzipped" / out.name) == check_copy(out)


@pytest.mark.skipif(RSYNC is None, reason="rsync is not on PATH (install rsync to run this copy check)")
def test_rsync_a_copies_files(export, tmp_path):
    _, out, _ = export
    subprocess.run([RSYNC, "-a", f"{out}/", str(tmp_path / "synced")], check=True)
    assert check_copy(tmp_path / "synced") == check_copy(out)


def test_copytree_without_following_links_copies_files(export, tmp_path):
    _, out, _ = export
    shutil.copytree(out, tmp_path / "tree", symlinks=True)
    assert check_copy(tmp_path / "tree") == check_copy(out)


def test_the_cli_refuses_a_folder_of_other_files_and_force_adds_beside_them(capsys, tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    code = main(["export", "self_lock", "--out", str(out), "--format", "stl"])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and str(out) in err and "--force" in err
    assert os.listdir(out) == ["notes.txt"]
    code = main(["export", "self_lock", "--out", str(out), "--format", "stl", "--force"])
    _, err = capsys.readouterr()
    assert code == 0 and "one by one" in err
    assert (out / "notes.txt").read_text() == "mine" and (out / MANIFEST).is_file()
    assert "notes.txt" not in [r["name"] for r in json.loads((out / MANIFEST).read_text())["files"]]


def test_the_cli_refuses_a_system_folder(capsys):
    code = main(["export", "self_lock", "--out", "/etc", "--force"])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "/etc: is a system folder" in err
