"""SVG reading at scale: the vertex clustering against the all-pairs
version it replaced, measured in the same run, and the whole reader on large patterns.

    PYTHONPATH=$PWD python benchmarks/bench_svg.py [--json]

Cases: the end points of a 20,200-segment grid (yellow facets, 100 x 100 cells) and of a
path drawn 1,000 times back and forth over one line (2,000 segments on 2 distinct points:
every pair is within the tolerance, 1.3 GB in the old reader). Each clustering runs in a
child process (peak RSS, CPU); the baseline is the previous all-pairs k-d tree union-find.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np


def old_cluster(pts: np.ndarray, tol: float) -> np.ndarray:
    """The straightforward clustering: every close pair from a k-d tree, a Python
    union-find, and one mask per cluster (O(pairs) memory, O(n x clusters) time)."""
    from scipy.spatial import cKDTree

    parent = np.arange(len(pts))

    def root(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in cKDTree(pts).query_pairs(tol):
        ri, rj = root(i), root(j)
        if ri != rj:
            parent[ri] = rj
    roots = np.array([root(i) for i in range(len(pts))])
    out = pts.astype(float).copy()
    for r in np.unique(roots):
        idx = roots == r
        out[idx] = pts[idx].mean(axis=0)
    return out


def grid_points(n: int = 100) -> np.ndarray:
    segs = [((i, j), (i, j + 1)) for i in range(n + 1) for j in range(n)]
    segs += [((j, i), (j + 1, i)) for i in range(n + 1) for j in range(n)]
    return np.array([a for a, _ in segs] + [b for _, b in segs], float)


def backforth_points(k: int = 2000) -> np.ndarray:
    a, b = (20.0, 20.0), (21.0, 20.0)
    return np.array([a, b] * k, float)


def _child(which: str, case: str, q):
    from foldprint.io.svg_format import cluster_points

    pts = grid_points() if case == "grid" else backforth_points()
    fn = old_cluster if which == "old" else cluster_points
    c0 = time.process_time()
    out = fn(pts, 0.5)
    q.put({"cpu_s": time.process_time() - c0, "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
           "digest": float(np.round(out, 9).sum())})


def _svg_grid(n: int = 100) -> str:
    lines = []
    for i in range(n + 1):
        for j in range(n):
            for (x1, y1, x2, y2) in ((i, j, i, j + 1), (j, i, j + 1, i)):
                edge = (x1 == x2 and x1 in (0, n)) or (y1 == y2 and y1 in (0, n))
                lines.append(f'<line x1="{x1}" y1="{y1}" x2="{x2}" y2="{y2}" stroke="{"#000" if edge else "#ff0"}"/>')
    return ('<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="100mm" viewBox="0 0 100 100">'
            + "".join(lines) + "</svg>")


def _load_child(text: str, q):
    from foldprint.io.load import load_design

    with tempfile.TemporaryDirectory() as tmp:
        f = Path(tmp) / "grid.svg"
        f.write_text(text)
        c0 = time.process_time()
        d = load_design(f)
        q.put({"cpu_s": time.process_time() - c0, "panels": len(d.panels),
               "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024})


def _run(target, *args) -> dict:
    ctx = mp.get_context("fork")
    q = ctx.Queue()
    p = ctx.Process(target=target, args=(*args, q))
    p.start()
    out = q.get()
    p.join()
    return out


def main():
    res = {}
    for case in ("grid", "backforth"):
        old, new = _run(_child, "old", case), _run(_child, "new", case)
        assert abs(old["digest"] - new["digest"]) < 1e-6 * max(1.0, abs(old["digest"]))  # same clusters
        res[case] = {"points": int(len(grid_points() if case == "grid" else backforth_points())),
                     "old": old, "new": new, "cpu_ratio_old_over_new": old["cpu_s"] / max(new["cpu_s"], 1e-9),
                     "peak_ratio_old_over_new": old["peak_mib"] / new["peak_mib"]}
    res["read_20200_segments"] = _run(_load_child, _svg_grid())
    if "--json" in sys.argv:
        print(json.dumps(res, indent=1))
        return
    for case in ("grid", "backforth"):
        r = res[case]
        print(f"{case:10s} {r['points']:6d} points: old {r['old']['cpu_s']:.2f} s CPU / {r['old']['peak_mib']:.0f} MiB, "
              f"new {r['new']['cpu_s']:.2f} s / {r['new']['peak_mib']:.0f} MiB: x{r['cpu_ratio_old_over_new']:.1f} "
              f"CPU, x{r['peak_ratio_old_over_new']:.1f} peak memory")
    r = res["read_20200_segments"]
    print(f"reading a 20,200-segment grid SVG: {r['cpu_s']:.2f} s CPU, {r['peak_mib']:.0f} MiB peak, {r['panels']} panel(s)")


if __name__ == "__main__":
    main()
