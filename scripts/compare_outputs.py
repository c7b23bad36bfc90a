"""Compare two output folders of foldprint (e.g. a gallery made before a change and one made
after): the same files in both, every file equal byte for byte (sha256); where bytes
differ, a JSON file is compared again once the fields of ``--ignore`` are dropped (a
difference is listed by its JSON path) and a zip package (3MF) member by member, its
entries' timestamps aside.

    python scripts/compare_outputs.py BEFORE AFTER            # compare two folders
    python scripts/compare_outputs.py BEFORE --make AFTER     # make AFTER with this code, then compare
    python scripts/compare_outputs.py --make DIR --exports helix_graded,mailbox   # make only

``--make DIR`` runs ``foldprint gallery --out DIR`` (unless ``--no-gallery``) and, for each
design of ``--exports``, ``foldprint export NAME --format <every format> --json`` into
``DIR/exports/NAME`` (its JSON records kept as ``DIR/exports/NAME.json``), with the
foldprint that ``python -m foldprint`` imports: run it with ``PYTHONPATH`` pointing at an
older checkout (e.g. ``git archive COMMIT foldprint templates | tar -x -C OLD``) to make the
baseline. Exit 0 when the folders are the same, 1 with what differs.

Nothing in a gallery or an export varies between two runs of the same code: two galleries
made from one commit are equal byte for byte, JSON, 3MF packages (fixed entry timestamps)
and the output set's id (a digest of its files) included, so :data:`VARYING` is empty.
``--ignore KEY`` drops a JSON key everywhere when two versions are compared on purpose
(e.g. ``foldprint_version``).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

#: JSON keys whose values differ between two runs of the same code: none (found by
#: comparing two galleries made from one commit; see the module's docstring).
VARYING: frozenset[str] = frozenset()
#: Every format ``foldprint export`` writes (exchange.export.FORMATS).
ALL_FORMATS = "3mf,prusa3mf,stl,fold,inp,xdmf,glb,voxels"


def _drop(obj, keys: frozenset[str]):
    """``obj`` without the JSON keys ``keys`` (recursively)."""
    if isinstance(obj, dict):
        return {k: _drop(v, keys) for k, v in obj.items() if k not in keys}
    if isinstance(obj, list):
        return [_drop(v, keys) for v in obj]
    return obj


def json_diff(a, b, path: str = "$") -> list[str]:
    """Where two JSON values differ (paths, at most a few per level)."""
    if type(a) is not type(b):
        return [f"{path}: {a!r:.80} != {b!r:.80}"]
    if isinstance(a, dict):
        out = [f"{path}.{k}: only in one" for k in sorted(set(a) ^ set(b))]
        for k in sorted(set(a) & set(b)):
            out += json_diff(a[k], b[k], f"{path}.{k}")
        return out
    if isinstance(a, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} != {len(b)} items"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in json_diff(x, y, f"{path}[{i}]")]
    return [] if a == b else [f"{path}: {a!r:.80} != {b!r:.80}"]


def _sha(p: Path) -> str:
    return hashlib.sha256(p.read_bytes()).hexdigest()


def zip_diff(a: Path, b: Path) -> list[str]:
    """Members of two zip packages that differ (names, or bytes of a member)."""
    with zipfile.ZipFile(a) as za, zipfile.ZipFile(b) as zb:
        na, nb = za.namelist(), zb.namelist()
        if na != nb:
            return [f"members differ: {sorted(set(na) ^ set(nb)) or 'order'}"]
        return [f"member {n} differs" for n in na if za.read(n) != zb.read(n)]


def compare(before: Path, after: Path, ignore: frozenset[str] = VARYING) -> dict[str, list[str]]:
    """What differs between the two folders, by kind: files missing or new, JSON files that
    differ once ``ignore`` is dropped, 3MF packages whose members differ, other files whose
    bytes differ (a JSON or zip file equal in content but not in bytes: "same content")."""
    fa = {p.relative_to(before).as_posix() for p in before.rglob("*") if p.is_file()}
    fb = {p.relative_to(after).as_posix() for p in after.rglob("*") if p.is_file()}
    out: dict[str, list[str]] = {"missing": sorted(fa - fb), "new": sorted(fb - fa), "json": [], "zip": [],
                                 "bytes": [], "same content": []}
    for rel in sorted(fa & fb):
        pa, pb = before / rel, after / rel
        if _sha(pa) == _sha(pb):
            continue
        if rel.endswith(".json"):
            d = json_diff(_drop(json.loads(pa.read_text(encoding="utf-8")), ignore),
                          _drop(json.loads(pb.read_text(encoding="utf-8")), ignore))
            out["json"] += [f"{rel}: {x}" for x in d]
        elif zipfile.is_zipfile(pa) and zipfile.is_zipfile(pb):
            d = zip_diff(pa, pb)
            out["zip"] += [f"{rel}: {x}" for x in d]
        else:
            out["bytes"].append(rel)
            continue
        if not d:
            out["same content"].append(rel)
    return out


def make(out: Path, gallery: bool, exports: list[str]) -> None:
    """The gallery and the exports of this foldprint (``python -m foldprint``) in ``out``."""
    env = dict(os.environ, MPLBACKEND="Agg")
    if gallery:
        subprocess.run([sys.executable, "-m", "foldprint", "--quiet", "gallery", "--out", str(out)], check=True,
                       env=env)
    for name in exports:
        for formats in (ALL_FORMATS, ALL_FORMATS.replace(",inp", "")):  # inp: planar strips only
            done = subprocess.run([sys.executable, "-m", "foldprint", "--quiet", "export", name, "--format", formats,
                                   "--json", "--out", str(out / "exports" / name)], env=env, capture_output=True,
                                  text=True)
            if done.returncode == 0:
                break
        else:
            raise SystemExit(f"foldprint export {name} failed: {done.stderr.strip()}")
        records = json.loads(done.stdout)
        for key in ("out", "manifest"):  # absolute or caller-relative paths: where, not what
            records.pop(key, None)
        for r in records["files"]:
            r["path"] = Path(r["path"]).name
        (out / "exports" / f"{name}.json").write_text(json.dumps(records, indent=2), encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", type=Path, nargs="?")
    ap.add_argument("after", type=Path, nargs="?")
    ap.add_argument("--make", type=Path, help="make this folder first (the gallery and --exports) and compare it")
    ap.add_argument("--no-gallery", action="store_true", help="with --make: the exports only")
    ap.add_argument("--exports", default="", help="with --make: designs exported in every format (comma-separated)")
    ap.add_argument("--ignore", action="append", default=[], help="a JSON key dropped everywhere (repeatable)")
    ap.add_argument("--show", type=int, default=20, help="lines shown per kind of difference")
    args = ap.parse_args(argv)
    if args.make is not None:
        make(args.make, not args.no_gallery, [n for n in args.exports.split(",") if n])
    after = args.make if args.make is not None and args.after is None else args.after
    if args.before is None or after is None:
        if args.make is not None and args.before is None:
            print(f"made {args.make}")
            return 0
        ap.error("give BEFORE and AFTER (or BEFORE --make AFTER)")
    ignore = VARYING | frozenset(args.ignore)
    diff = compare(args.before, after, ignore)
    n_files = sum(1 for p in args.before.rglob("*") if p.is_file())
    if not any(v for k, v in diff.items() if k != "same content"):
        same = diff["same content"]
        print(f"identical: {n_files} files of {args.before} and {after}: "
              + (f"{len(same)} equal in content but not in bytes ({', '.join(same[:5])})" if same else
                 "every file byte for byte")
              + (f" (JSON without {sorted(ignore)})" if ignore else ""))
        return 0
    for kind, items in diff.items():
        if items:
            print(f"{kind}: {len(items)}")
            for line in items[:args.show]:
                print(f"  {line}")
    return 1


if __name__ == "__main__":
    raise SystemExit(main())
