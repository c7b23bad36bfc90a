"""Compare two output folders of foldprint (e.g. a gallery made before a change and one made
after): every file present in both, every JSON file equal once the fields that vary from run
to run of the same code are dropped, every zip package (3MF) equal member by member (their
entries' timestamps aside), every other file equal by sha256.

    python scripts/compare_outputs.py BEFORE AFTER          # two folders
    python scripts/compare_outputs.py BEFORE --run AFTER    # make AFTER first: foldprint gallery --out AFTER

Exit 0 when they are the same, 1 with a list of what differs (at most ``--show`` lines per
kind). The fields dropped (:data:`VARYING`) were found by comparing two galleries of the
same code: the output set's random id, and every timing.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import subprocess
import sys
import zipfile
from pathlib import Path

#: JSON keys whose values differ between two runs of the same code (found by comparing two
#: galleries made from one commit): the id an output set is published under (random per
#: run), and wall-clock timings.
VARYING = {"set", "elapsed_s", "wall_s", "cpu_s", "seconds", "time_taken_s", "timings"}
#: Keys holding a file's hash or size inside a set's manifest (foldprint-set.json): a zip
#: package's bytes carry its entries' timestamps, so its recorded hash varies with them;
#: the package itself is compared member by member.
HASH_KEYS = {"sha256", "bytes"}


def _drop(obj, path: str = ""):
    """``obj`` without the keys of :data:`VARYING` (recursively); in a list of file records
    naming a zip package, that record's hash and size too."""
    if isinstance(obj, dict):
        name = obj.get("name") or obj.get("path") or ""
        zipped = isinstance(name, str) and name.endswith(".3mf")
        return {k: _drop(v, f"{path}.{k}") for k, v in obj.items()
                if k not in VARYING and not (zipped and k in HASH_KEYS)}
    if isinstance(obj, list):
        return [_drop(v, f"{path}[{i}]") for i, v in enumerate(obj)]
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


def compare(before: Path, after: Path) -> dict[str, list[str]]:
    """What differs between the two folders, by kind."""
    fa = {p.relative_to(before).as_posix() for p in before.rglob("*") if p.is_file()}
    fb = {p.relative_to(after).as_posix() for p in after.rglob("*") if p.is_file()}
    out: dict[str, list[str]] = {"missing": sorted(fa - fb), "new": sorted(fb - fa), "json": [], "zip": [],
                                 "bytes": []}
    for rel in sorted(fa & fb):
        pa, pb = before / rel, after / rel
        if rel.endswith(".json"):
            d = json_diff(_drop(json.loads(pa.read_text(encoding="utf-8"))),
                          _drop(json.loads(pb.read_text(encoding="utf-8"))))
            out["json"] += [f"{rel}: {x}" for x in d]
        elif zipfile.is_zipfile(pa) and zipfile.is_zipfile(pb):
            out["zip"] += [f"{rel}: {x}" for x in zip_diff(pa, pb)]
        elif _sha(pa) != _sha(pb):
            out["bytes"].append(rel)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path, nargs="?")
    ap.add_argument("--run", type=Path, help="make this folder first with `foldprint gallery --out` and compare it")
    ap.add_argument("--show", type=int, default=20, help="lines shown per kind of difference")
    args = ap.parse_args(argv)
    after = args.run or args.after
    if after is None:
        ap.error("give AFTER or --run AFTER")
    if args.run is not None:
        subprocess.run([sys.executable, "-m", "foldprint", "--quiet", "gallery", "--out", str(after)], check=True)
    diff = compare(args.before, after)
    n_files = sum(1 for p in args.before.rglob("*") if p.is_file())
    if not any(diff.values()):
        print(f"identical: {n_files} files of {args.before} and {after} (JSON without {sorted(VARYING)}, "
              "3MF member by member, every other file by sha256)")
        return 0
    for kind, items in diff.items():
        if items:
            print(f"{kind}: {len(items)}")
            for line in items[:args.show]:
                print(f"  {line}")
    return 1


if __name__ == "__main__":
    raise SystemExit(main())
