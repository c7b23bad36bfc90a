"""The gallery's cache: a design whose inputs did not change keeps its folder and its page
entry from the gallery already in the output folder, instead of being folded, checked,
rendered and exported again.

A design's *key* is a digest of everything its folder is made from: the design's content
(:func:`foldprint.model.derived.content_key`), the materials it uses as the library defines
them (the whole library when a hinge names a VeroWhite fraction, which reads it), the
code and data of this foldprint (every file of the package: the printer profiles, the
scatter model and the paper's statements are package data) with the versions of Python
and the libraries that compute and draw (:data:`LIBRARIES`), its folder name and the
gallery's options (time step, animation frames, samples, seed, sigma scales). The key is
written beside the design's files (``<design>/gallery-cache.json``, with the page entry it
gave), so the cache is plain files inside the gallery: ``cp -r`` carries it, deleting a
folder forgets it. The material chart is kept the same way (``gallery-cache.json`` at the
top, keyed by the whole library and the code).

A design is kept only when its key matches *and* every file its folder held is there as
the gallery's manifest (``foldprint-set.json``) recorded it (size and sha256): a folder
edited by hand is built again. When every design and the chart are kept and the page
would be the same bytes, nothing is written at all (:meth:`Earlier.unchanged`).
``foldprint gallery --force`` builds everything.
"""

from __future__ import annotations

import functools
import hashlib
import json
import logging
import os
import shutil
import sys
from dataclasses import asdict, fields
from pathlib import Path

from ...core.constants import CHECK_SCALES
from ...core.version import __version__
from ...model import composition
from ...model.derived import content_key
from ...model.design import Design
from ...model.materials import MaterialLibrary
from .entry import Entry, Image, Link, json_bytes

log = logging.getLogger("foldprint.apps.gallery.runner")

CACHE_FILE = "gallery-cache.json"
"""The key and page entry of a design (in its folder) or of the material chart (at the top)."""

FORMAT = 1
"""The cache file's layout (a file of another layout is not read)."""


#: The libraries whose numbers and pictures a gallery holds (pyproject's dependencies that
#: compute or draw): their versions are part of :func:`code_digest`.
LIBRARIES = ("numpy", "scipy", "trimesh", "manifold3d", "shapely", "python-fcl", "matplotlib", "pillow")


def _versions() -> str:
    from importlib.metadata import PackageNotFoundError, version

    out = [sys.version]
    for name in LIBRARIES:
        try:
            out.append(f"{name}=={version(name)}")
        except PackageNotFoundError:
            out.append(f"{name} absent")
    return "\n".join(out)


@functools.lru_cache(maxsize=1)
def code_digest() -> str:
    """A digest of this foldprint: its version, Python's and its computing libraries'
    (:data:`LIBRARIES`) and every file of the package (sources and data), by path and
    content. Any change to the code, its data or those libraries changes it (a few ms)."""
    root = Path(__file__).resolve().parent.parent
    h = hashlib.sha256(__version__.encode() + b"\0" + _versions().encode())
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for f in sorted(filenames):
            if f.endswith((".pyc", ".pyo")):
                continue
            p = Path(dirpath) / f
            h.update(p.relative_to(root).as_posix().encode() + b"\0")
            h.update(p.read_bytes())
    return h.hexdigest()


def _library_part(design: Design, lib: MaterialLibrary) -> bytes:
    """The library as far as ``design`` reads it: its materials' entries, or the whole
    library when a material is a VeroWhite fraction (interpolated from the library)."""
    used = design.materials_used
    if any(composition.is_composition_name(m) for m in used):
        return content_key(lib)
    return content_key(tuple(lib.get(m) if m in lib else m for m in used))


def design_key(design: Design, lib: MaterialLibrary, dirname: str, options: dict) -> str:
    """The digest of a design's inputs (module docstring)."""
    h = hashlib.sha256()
    for part in (content_key(design), _library_part(design, lib), code_digest().encode(), dirname.encode(),
                 json.dumps({**options, "scales": list(CHECK_SCALES)}, sort_keys=True).encode()):
        h.update(len(part).to_bytes(8, "little") + part)
    return h.hexdigest()


def chart_key(lib: MaterialLibrary) -> str:
    """The digest of the material chart's inputs: the whole library and the code."""
    return hashlib.sha256(content_key(lib) + code_digest().encode()).hexdigest()


def entry_bytes(entry: Entry, key: str) -> bytes:
    """A design's cache file: its key and its page entry (the design itself is not kept:
    the key holds its digest, and the caller has it)."""
    data = {f.name: getattr(entry, f.name) for f in fields(entry) if f.name != "design"}
    data["images"] = [asdict(i) for i in entry.images]
    data["files"] = [asdict(link) for link in entry.files]
    data["data_links"] = [asdict(link) for link in entry.data_links]
    data["viewer"] = None if entry.viewer is None else asdict(entry.viewer)
    return json_bytes({"format": FORMAT, "key": key, "entry": data})


def entry_from(data: dict, design: Design) -> Entry:
    """The :class:`Entry` a cache file holds, for ``design``."""
    e = dict(data)
    e["images"] = [Image(**i) for i in e["images"]]
    e["files"] = [Link(**link) for link in e["files"]]
    e["data_links"] = [Link(**link) for link in e["data_links"]]
    e["viewer"] = None if e["viewer"] is None else Link(**e["viewer"])
    e["contacts"] = [tuple(c) for c in e["contacts"]]
    return Entry(design=design, **e)


def chart_bytes(image: Image, key: str) -> bytes:
    return json_bytes({"format": FORMAT, "key": key, "chart": asdict(image)})


class Earlier:
    """The gallery already in ``out_dir`` (nothing when there is none or ``use`` is
    False): what of it may be kept."""

    def __init__(self, out_dir: str | Path, use: bool = True):
        self.root = Path(out_dir)
        self.files = _manifest_files(self.root) if use else {}

    def _cache(self, rel: str, key: str) -> dict | None:
        if not self.files:
            return None
        try:
            data = json.loads((self.root / rel).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        if not isinstance(data, dict) or data.get("format") != FORMAT or data.get("key") != key:
            return None
        return data

    def unchanged(self, designs, dirnames: list[str], lib: MaterialLibrary, options: dict, page) -> bool:
        """Whether the gallery here is the very one these inputs give, so nothing need be
        written: every design and the chart kept (:meth:`design`, :meth:`chart`), no other
        design's folder in it, and ``page(entries, chart)`` (the bytes of ``index.html``)
        and the viewer's files as the manifest recorded them."""
        from ...render.viewer import ASSETS, asset_bytes

        chart = self.chart(chart_key(lib))
        if chart is None:
            return False
        entries, expected = [], {"index.html", "materials.png", CACHE_FILE} | {f"viewer/{a}" for a in ASSETS}
        for d, n in zip(designs, dirnames):
            e = self.design(d, n, design_key(d, lib, n, options))
            if e is None:
                return False
            entries.append(e)
            expected |= {f for f in self.files if f.startswith(f"{n}/")}
        if set(self.files) != expected:
            return False
        fresh = {"index.html": page(entries, chart), **{f"viewer/{a}": asset_bytes(a) for a in ASSETS}}
        return all(hashlib.sha256(b).hexdigest() == self.files[n][1] for n, b in fresh.items()) \
            and self._intact(list(fresh))

    def chart(self, key: str, out: Path | None = None) -> Image | None:
        """The material chart, copied into ``out`` (when given), when its key matches."""
        data = self._cache(CACHE_FILE, key)
        if data is None or not self._intact(["materials.png", CACHE_FILE]):
            return None
        try:
            image = Image(**data["chart"])
        except (KeyError, TypeError):  # not what this code writes: built again
            return None
        if out is not None:
            _copy(self.root / "materials.png", out / "materials.png")
            (out / CACHE_FILE).write_bytes(chart_bytes(image, key))
        return image

    def design(self, design: Design, dirname: str, key: str, out: Path | None = None) -> Entry | None:
        """The design's entry, its folder copied into ``out`` (when given), when its key
        matches and its files are as the manifest recorded them; else None."""
        data = self._cache(f"{dirname}/{CACHE_FILE}", key)
        if data is None:
            return None
        prefix = f"{dirname}/"
        names = [n for n in self.files if n.startswith(prefix)]
        on_disk = {f"{prefix}{p.relative_to(self.root / dirname).as_posix()}"
                   for p in (self.root / dirname).rglob("*") if p.is_file() or p.is_symlink()}
        if set(names) != on_disk or not self._intact(names):
            log.info("gallery: %s: its folder changed since it was built; building it again", design.name)
            return None
        try:
            entry = entry_from(data["entry"], design)
        except (KeyError, TypeError, ValueError, AttributeError):  # not what this code writes: built again
            return None
        for n in names if out is not None else ():
            _copy(self.root / n, out / n)
        return entry

    def _intact(self, names: list[str]) -> bool:
        for n in names:
            p = self.root / n
            size, sha = self.files.get(n, (None, None))
            if size is None or p.is_symlink() or not p.is_file() or p.stat().st_size != size:
                return False
            if _sha256(p) != sha:
                return False
        return True


def _manifest_files(root: Path) -> dict[str, tuple[int, str]]:
    """name -> (bytes, sha256) of the gallery's manifest; {} without a complete one."""
    from ...exchange.outfolder import MANIFEST

    try:
        data = json.loads((root / MANIFEST).read_text(encoding="utf-8"))
        if data.get("tool") != "foldprint" or data.get("complete") is not True:
            return {}
        return {str(r["name"]): (int(r["bytes"]), str(r["sha256"])) for r in data["files"]}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return {}


def _sha256(p: Path) -> str:
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _copy(src: Path, dst: Path) -> None:
    """A file of the earlier gallery into the new one: a copy (plain files, no links: the
    new set shares nothing with the one it replaces)."""
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dst)
