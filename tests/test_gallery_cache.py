"""The gallery's cache (foldprint.apps.gallery.cache): a second gallery with nothing changed
builds nothing and gives the same files; a changed design, or a changed material, builds
that design only; ``cache=False`` (``--force``) builds everything; a folder edited by hand
is built again; the cache travels with a copy of the gallery."""

from __future__ import annotations

import dataclasses
import shutil

import pytest

from foldprint.apps.gallery.runner import build_gallery
from foldprint.core.errors import ExportError
from foldprint.apps.gallery.cache import CACHE_FILE, Earlier, code_digest, design_key
from foldprint.model.design import strip
from foldprint.model.materials import default_library

OPTS = dict(gif_frames=3, jobs=1, samples=4)


def _designs():
    return [strip("one", [10.0, 12.0], [90.0], ["H-1"]), strip("two", [10.0, 11.0, 9.0], [60.0, -45.0], ["H-4", "H-5"])]


def _build(designs, out, **kw):
    steps: list[str] = []
    build_gallery(designs, out, progress=lambda done, total, msg: steps.append(msg), **{**OPTS, **kw})
    built = sorted(m.split(":")[0] for m in steps if ": simulated" in m)
    kept = sorted(m.split(":")[0] for m in steps if m.endswith("unchanged, kept"))
    return built, kept


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*") if p.is_file()}


@pytest.fixture(scope="module")
def first(tmp_path_factory):
    out = tmp_path_factory.mktemp("cache") / "site"
    built, kept = _build(_designs(), out)
    assert built == ["one", "two"] and kept == []
    return out


def test_second_run_builds_nothing_and_gives_the_same_files(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)  # the cache is plain files: a copy carries it
    before, inode = _files(site), (site / "index.html").stat().st_ino
    built, kept = _build(_designs(), site)
    assert built == [] and kept == ["material chart", "one", "two"]
    assert _files(site) == before  # index.html, manifest and every design's files byte for byte
    assert (site / "index.html").stat().st_ino == inode  # nothing written: the same files


def test_a_design_dropped_from_the_list_republishes_the_rest(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)
    built, kept = _build(_designs()[:1], site)
    assert built == [] and kept == ["material chart", "one"]
    assert not (site / "two").exists() and 'id="d-two"' not in (site / "index.html").read_text(encoding="utf-8")
    assert (site / "one" / CACHE_FILE).is_file()  # the kept design's cache came along


def test_a_changed_design_builds_that_design_only(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)
    one, two = _designs()
    two = strip("two", [10.0, 11.0, 9.5], [60.0, -45.0], ["H-4", "H-5"])
    built, kept = _build([one, two], site)
    assert built == ["two"] and kept == ["material chart", "one"]


def test_a_changed_material_builds_the_designs_that_use_it(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)
    lib = default_library()
    h1 = lib.get("H-1")
    changed = dataclasses.replace(lib, materials=tuple(
        dataclasses.replace(m, tg_c=m.tg_c + 1.0) if m is h1 else m for m in lib.materials))
    built, kept = _build(_designs(), site, library=changed)
    assert built == ["one"] and kept == ["two"]  # the chart draws every material: built again


def test_force_builds_everything(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)
    built, kept = _build(_designs(), site, cache=False)
    assert built == ["one", "two"] and kept == []


def test_a_folder_edited_by_hand_is_built_again(first, tmp_path):
    site = tmp_path / "site"
    shutil.copytree(first, site)
    (site / "one" / "check.json").write_text("{}", encoding="utf-8")
    with pytest.raises(ExportError, match="changed after foldprint wrote it"):
        _build(_designs(), site)  # the folder guard refuses it first
    built, kept = _build(_designs(), site, force=True)  # replaced file by file, the cache still asked
    assert built == ["one"] and kept == ["material chart", "two"]


def test_the_key_follows_every_input():
    one, _ = _designs()
    lib = default_library()
    opts = {"dt": 0.01, "gif_frames": 3, "samples": 4, "seed": 1}
    k = design_key(one, lib, "one", opts)
    assert k == design_key(strip("one", [10.0, 12.0], [90.0], ["H-1"]), lib, "one", opts)  # a fresh equal copy
    assert k != design_key(strip("one", [10.0, 12.0], [91.0], ["H-1"]), lib, "one", opts)
    assert k != design_key(one, lib, "one-2", opts)
    assert k != design_key(one, lib, "one", {**opts, "seed": 2})
    assert len(code_digest()) == 64


def test_no_gallery_no_cache(tmp_path):
    assert Earlier(tmp_path / "nothing").files == {}
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / CACHE_FILE).write_text("not json", encoding="utf-8")
    assert Earlier(tmp_path / "x").files == {}  # no manifest: nothing is trusted


def test_the_code_digest_follows_the_libraries(monkeypatch):
    from foldprint.apps.gallery import cache as gallery_cache

    before = code_digest()
    monkeypatch.setattr(gallery_cache, "_versions", lambda: "numpy==0.0")
    gallery_cache.code_digest.cache_clear()
    try:
        assert gallery_cache.code_digest() != before
    finally:
        gallery_cache.code_digest.cache_clear()
    monkeypatch.undo()
    assert code_digest() == before


def test_the_command_line_says_when_nothing_was_written(tmp_path, capsys):
    from foldprint.cli.commands import main
    from foldprint.io.design_io import design_to_toml

    design = tmp_path / "tiny.toml"
    design.write_text(design_to_toml(strip("tiny", [20.0, 20.0], [90.0], ["H-3"])), encoding="utf-8")
    out = tmp_path / "site"
    assert main(["gallery", str(design), "--out", str(out), "--jobs", "1"]) == 0
    capsys.readouterr()
    assert main(["gallery", str(design), "--out", str(out), "--jobs", "1"]) == 0
    err = capsys.readouterr().err
    assert "tiny: unchanged, kept" in err and "index.html: unchanged, nothing written" in err
    assert "wrote" not in err
    assert main(["gallery", str(design), "--out", str(out), "--jobs", "1", "--force"]) == 0
    assert "tiny: simulated, checked, rendered, exported" in capsys.readouterr().err


def test_a_cache_file_not_of_this_code_is_not_trusted(first, tmp_path):
    """A cache entry of the right key but another layout (a hand-edited gallery whose
    manifest was edited to match) is built again, not an internal error."""
    import hashlib
    import json

    site = tmp_path / "site"
    shutil.copytree(first, site)
    f = site / "one" / CACHE_FILE
    data = json.loads(f.read_text(encoding="utf-8"))
    data["entry"] = {"sim": {}}
    raw = (json.dumps(data) + "\n").encode()
    f.write_bytes(raw)
    man = site / "foldprint-set.json"
    text = man.read_text(encoding="utf-8")
    row = next(r for r in json.loads(text)["files"] if r["name"] == f"one/{CACHE_FILE}")
    man.write_text(text.replace(row["sha256"], hashlib.sha256(raw).hexdigest()).replace(
        f'"bytes": {row["bytes"]}, "sha256": "{hashlib.sha256(raw).hexdigest()}"',
        f'"bytes": {len(raw)}, "sha256": "{hashlib.sha256(raw).hexdigest()}"'), encoding="utf-8")
    assert Earlier(site).files[f"one/{CACHE_FILE}"] == (len(raw), hashlib.sha256(raw).hexdigest())
    built, kept = _build(_designs(), site, force=True)
    assert built == ["one"] and kept == ["material chart", "two"]
