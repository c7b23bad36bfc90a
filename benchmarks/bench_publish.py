"""What publishing a set costs (``foldprint/exchange/fileset.py``, docs/output-files.md):
``write_set`` of N files (a first export into a new folder, then a re-export over it, which
reads and hashes the earlier set to know it is foldprint's) against the floor any writer
that survives a crash pays: the same files written and fsynced one by one into a folder.
CPU-seconds (user + sys of this process) and the ratio to that floor, measured in the same
run. ``python benchmarks/bench_publish.py [--files 700] [--kib 40] [--repeat 3] [--json]``
(700 files of 40 KiB: a voxel slice stack of the helix)."""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

from foldprint.exchange.fileset import write_set


def _cpu() -> float:
    t = os.times()
    return t.user + t.system


def _floor(folder: str, files) -> None:
    os.mkdir(folder)
    for name, data in files:
        with open(os.path.join(folder, name), "xb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())


def measure(n: int, kib: int, repeat: int) -> dict:
    files = [(f"s{k:05d}.png", os.urandom(kib * 1024)) for k in range(n)]
    best = {"floor": float("inf"), "first": float("inf"), "again": float("inf")}
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            for key, fn in (("floor", lambda: _floor(os.path.join(tmp, "plain"), files)),
                            ("first", lambda: write_set(os.path.join(tmp, "out"), files)),
                            ("again", lambda: write_set(os.path.join(tmp, "out"), files))):
                c0 = _cpu()
                fn()
                best[key] = min(best[key], _cpu() - c0)
    return {"files": n, "kib": kib, "cpu_s": {k: round(v, 3) for k, v in best.items()},
            "ratio_first_to_floor": round(best["first"] / best["floor"], 2),
            "ratio_again_to_floor": round(best["again"] / best["floor"], 2)}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--files", type=int, default=700)
    ap.add_argument("--kib", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    t0 = time.monotonic()
    res = measure(a.files, a.kib, a.repeat)
    res["wall_s"] = round(time.monotonic() - t0, 1)
    if a.json:
        print(json.dumps(res))
    else:
        c = res["cpu_s"]
        print(f"{a.files} files of {a.kib} KiB, CPU-s (best of {a.repeat}): floor {c['floor']}, first export "
              f"{c['first']} ({res['ratio_first_to_floor']}x), re-export {c['again']} ({res['ratio_again_to_floor']}x)")
