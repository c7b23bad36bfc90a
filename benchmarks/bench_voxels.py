"""Voxel print: wall time, peak RSS and slices/s of the streamed writer, against a
whole-volume baseline measured in the same run.

    python benchmarks/bench_voxels.py [--json] [--size X,Y,Z] [--small X,Y,Z]

The part is a plate of --size mm (default 150 x 150 x 20, the issue's target: < 2 min and
< 1 GB) cut across x into 10 mm VeroWhite panels and 5 mm hinges (odd hinges graded
0.2 -> 0.8 across their width, even ones uniform 0.42), so every slice dithers 1/3 of its
area. It is written at the J750 pitch (600 x 300 dpi, 27 um) through the staged set
(:func:`foldprint.exchange.files.write_set`, one fsync per file), in a fresh process whose
peak RSS is read from the kernel (``ru_maxrss``).

Baselines (same run, a --small plate, default 15 x 5 x 2 mm: one panel and one hinge; trimesh needs 1.9 GB for it, since neither fits the big one):

* ``whole_volume``: the same rasteriser and dither, but every slice's labels kept in one
  (nz, ny, nx) uint8 volume before encoding (what a non-streamed writer holds);
* ``trimesh``: ``trimesh.voxel.creation.voxelize`` + ``fill`` of the plate's mesh at the x
  pitch (isotropic: trimesh has one pitch), occupancy only (no materials, no PNG).

Ratios are voxels per second and peak RSS over the streamed writer's on the small plate,
and the big plate's peak RSS over the small plate's (streaming: memory grows with a
slice's area, not with the layer count).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

TARGET_S = 120.0
TARGET_BYTES = 1e9


def plate(size):
    import manifold3d as mf

    from foldprint.exchange import voxels as vx
    from foldprint.geometry import HingeAxes
    from foldprint.model.composition import Along, FractionProfile

    sx, sy, sz = size
    regions, x, k = [], 0.0, 0
    while x < sx - 1e-9:
        w = min(10.0, sx - x)
        box = mf.Manifold.cube([w, sy, sz]).translate([x, 0.0, -sz / 2])
        regions.append(vx.VoxelRegion("panel", f"p{k}", "VeroWhite", box, vx.Uniform(1.0)))
        x += w
        if x >= sx - 1e-9:
            break
        w = min(5.0, sx - x)
        box = mf.Manifold.cube([w, sy, sz]).translate([x, 0.0, -sz / 2])
        mid = np.stack([np.linspace(x, x + w, 65), np.zeros(65), np.zeros(65)], axis=1)
        axes = HingeAxes(f"h{k}", mid[0].copy(), np.array([0.0, 1.0, 0.0]), sy, mid)
        prof = FractionProfile((0.2, 0.8), Along.WIDTH) if k % 2 else FractionProfile((0.42,))
        regions.append(vx.VoxelRegion("hinge", f"h{k}", prof.name, box, prof, axes))
        x += w
        k += 1
    pitch = vx.Pitch(25.4 / 600, 25.4 / 300, 0.027, "j750", "bench")
    return vx.VoxelPart("plate", "permanent", tuple(regions), pitch, np.array([0.0, 0.0, sz / 2]))


def run_streamed(size) -> dict:
    from foldprint.exchange import voxels as vx
    from foldprint.exchange.files import write_set

    part = plate(size)
    shape = part.grid().shape
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        paths = write_set(os.path.join(tmp, "out"), vx.slice_files(part, "plate"))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        written = sum(p.stat().st_size for p in paths)
        manifest = json.loads(paths[-1].read_text())
    worst = max((r["worst_block_error"] or 0.0 for r in manifest["regions"] if r["kind"] == "hinge"), default=None)
    return {"shape": list(shape), "wall_s": wall, "cpu_s": cpu, "written_bytes": written, "worst_block_error": worst}


def run_whole_volume(size) -> dict:
    from foldprint.exchange import voxels as vx

    part = plate(size)
    files = vx.slice_files(part, "plate")
    nx, ny, nz = part.grid().shape
    t0, c0 = time.perf_counter(), time.process_time()
    volume = np.zeros((nz, ny, nx), np.uint8)
    for k, (_, make) in enumerate(files[:-1]):
        volume[k] = vx.read_png(make())  # the same labels, kept
    blobs = [vx.png_bytes(volume[k], part.pitch) for k in range(nz)]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"shape": [nx, ny, nz], "wall_s": wall, "cpu_s": cpu, "written_bytes": sum(map(len, blobs))}


def run_trimesh(size) -> dict:
    import trimesh

    sx, sy, sz = size
    mesh = trimesh.creation.box(extents=[sx, sy, sz])
    pitch = 25.4 / 600
    t0, c0 = time.perf_counter(), time.process_time()
    grid = trimesh.voxel.creation.voxelize(mesh, pitch).fill()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    return {"shape": list(grid.shape), "wall_s": wall, "cpu_s": cpu, "filled": int(grid.filled_count)}


def child(kind: str, size) -> dict:
    """Run one measurement in a fresh process; its peak RSS from the kernel."""
    code = (f"import json, resource, sys; sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r}); "
            f"import bench_voxels as b; r = b.run_{kind}({tuple(size)!r}); "
            "u = resource.getrusage(resource.RUSAGE_SELF); r['peak_rss_bytes'] = u.ru_maxrss * 1024; "
            "r['process_cpu_s'] = u.ru_utime + u.ru_stime; print(json.dumps(r))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r["voxels"] = float(np.prod(r["shape"]))
    r["voxels_per_s"] = r["voxels"] / r["wall_s"]
    r["voxels_per_cpu_s"] = r["voxels"] / r["cpu_s"]
    if kind != "trimesh":
        r["slices_per_s"] = r["shape"][2] / r["wall_s"]
    return r


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", default="150,150,20", help="big plate x,y,z mm")
    ap.add_argument("--small", default="15,5,2", help="small plate for the baselines, x,y,z mm")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    big = [float(v) for v in a.size.split(",")]
    small = [float(v) for v in a.small.split(",")]
    res = {"machine_load_1min": os.getloadavg()[0], "cpus": os.cpu_count()}
    res["streamed_small"] = child("streamed", small)
    res["whole_volume_small"] = child("whole_volume", small)
    res["trimesh_small"] = child("trimesh", small)
    res["streamed_big"] = child("streamed", big)
    s, w, t, b = res["streamed_small"], res["whole_volume_small"], res["trimesh_small"], res["streamed_big"]
    res["ratios"] = {
        "streamed_vs_trimesh_voxels_per_s": s["voxels_per_s"] / t["voxels_per_s"],
        "streamed_vs_trimesh_voxels_per_cpu_s": s["voxels_per_cpu_s"] / t["voxels_per_cpu_s"],
        "streamed_vs_whole_volume_voxels_per_s": s["voxels_per_s"] / w["voxels_per_s"],
        "whole_volume_vs_streamed_peak_rss": w["peak_rss_bytes"] / s["peak_rss_bytes"],
        "big_vs_small_peak_rss": b["peak_rss_bytes"] / s["peak_rss_bytes"],
        "big_vs_small_voxels": b["voxels"] / s["voxels"],
    }
    res["targets"] = {"big_wall_s": [b["wall_s"], TARGET_S, b["wall_s"] < TARGET_S],
                      "big_peak_rss_bytes": [b["peak_rss_bytes"], TARGET_BYTES, b["peak_rss_bytes"] < TARGET_BYTES]}
    if a.json:
        print(json.dumps(res, indent=1))
        return
    print(f"load {res['machine_load_1min']:.2f} on {res['cpus']} CPUs")
    for name in ("streamed_small", "whole_volume_small", "trimesh_small", "streamed_big"):
        r = res[name]
        extra = f", {r['slices_per_s']:.1f} slices/s" if "slices_per_s" in r else ""
        print(f"{name:20s} {r['shape']} {r['wall_s']:8.2f} s ({r['cpu_s']:.2f} CPU-s)  "
              f"{r['peak_rss_bytes'] / 2**20:7.0f} MiB  "
              f"{r['voxels_per_s'] / 1e6:7.2f} Mvox/s{extra}")
    for k, v in res["ratios"].items():
        print(f"{k}: {v:.3g}")
    for k, (v, lim, ok) in res["targets"].items():
        print(f"{k}: {v:.4g} (target < {lim:g}) {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
