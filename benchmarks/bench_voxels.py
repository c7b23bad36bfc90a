"""Voxel print: wall time, CPU time and peak RSS of the streamed writer on the largest
plate we target, against the pre-change writer and the writer with one thread, measured in the same
run, plus small-plate baselines.

    python benchmarks/bench_voxels.py [--json] [--size X,Y,Z] [--small X,Y,Z] [--no-reference] [--no-serial]

The part is a plate of --size mm (default 150 x 150 x 20, our target for it: < 2 min and
< 1 GB) cut across x into 10 mm VeroWhite panels and 5 mm hinges (odd hinges graded
0.2 -> 0.8 across their width, even ones uniform 0.42), so every slice dithers 1/3 of its
area. It is written at the J750 pitch (600 x 300 dpi, 27 um) through the staged set
(:func:`foldprint.exchange.fileset.write_set`, one fsync per file), each run in a fresh
process whose peak RSS is read from the kernel (``ru_maxrss``); CPU time is the process's
(all threads).

Runs on the big plate:

* ``streamed_big``: the writer (``slice_files``, default threads);
* ``serial_big``: the same with one thread (``workers=1``);
* ``reference_big``: the writer as it was before it was made faster (foldprint 905e954,
  :class:`_Reference`: every region sliced and filled every layer, thresholds gathered per
  voxel, boolean-index labels, whole width tables, one layer at a time). Its slices must
  be the same bytes: the run reports whether the stacks' sha256 agree.

Baselines on a --small plate (default 15 x 5 x 2 mm: one panel and one hinge; trimesh
needs 1.9 GB for it, so neither fits the big one):

* ``whole_volume``: the same rasteriser and dither, but every slice's labels kept in one
  (nz, ny, nx) uint8 volume before encoding (what a non-streamed writer holds);
* ``trimesh``: ``trimesh.voxel.creation.voxelize`` + ``fill`` of the plate's mesh at the x
  pitch (isotropic: trimesh has one pitch), occupancy only (no materials, no PNG).

Ratios: reference and serial over streamed (wall, CPU, peak RSS) on the big plate; voxels
per second and peak RSS over the streamed writer's on the small plate; the big plate's
peak RSS over the small plate's (streaming: memory grows with a slice's area, not with
the layer count).
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import json
import math
import os
import resource
import subprocess
import struct
import sys
import tempfile
import time
import zlib

import numpy as np

TARGET_S = 120.0
TARGET_BYTES = 1e9


def plate(size):
    import manifold3d as mf

    from foldprint.exchange import voxel_regions as vr
    from foldprint.geometry import HingeAxes
    from foldprint.model.composition import Along, FractionProfile

    sx, sy, sz = size
    regions, x, k = [], 0.0, 0
    while x < sx - 1e-9:
        w = min(10.0, sx - x)
        box = mf.Manifold.cube([w, sy, sz]).translate([x, 0.0, -sz / 2])
        regions.append(vr.VoxelRegion("panel", f"p{k}", "VeroWhite", box, vr.Uniform(1.0)))
        x += w
        if x >= sx - 1e-9:
            break
        w = min(5.0, sx - x)
        box = mf.Manifold.cube([w, sy, sz]).translate([x, 0.0, -sz / 2])
        mid = np.stack([np.linspace(x, x + w, 65), np.zeros(65), np.zeros(65)], axis=1)
        axes = HingeAxes(f"h{k}", mid[0].copy(), np.array([0.0, 1.0, 0.0]), sy, mid)
        prof = FractionProfile((0.2, 0.8), Along.WIDTH) if k % 2 else FractionProfile((0.42,))
        regions.append(vr.VoxelRegion("hinge", f"h{k}", prof.name, box, prof, axes))
        x += w
        k += 1
    pitch = vr.Pitch(25.4 / 600, 25.4 / 300, 0.027, "j750", "bench")
    return vr.VoxelPart("plate", "permanent", tuple(regions), pitch, np.array([0.0, 0.0, sz / 2]))


def run_streamed(size, workers=None) -> dict:
    """The writer (``workers`` slice threads, default :func:`~foldprint.exchange.voxels.default_workers`)."""
    from foldprint.exchange import voxels as vx
    from foldprint.exchange.fileset import write_set

    part = plate(size)
    shape = part.grid().shape
    vx.blue_noise()
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        paths = write_set(os.path.join(tmp, "out"), vx.slice_files(part, "plate", workers=workers))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        written = sum(p.stat().st_size for p in paths)
        manifest = json.loads(paths[-1].read_text())
        digests = _digests(paths[:-1])
    worst = max((r["worst_block_error"] or 0.0 for r in manifest["regions"] if r["kind"] == "hinge"), default=None)
    return {"shape": list(shape), "wall_s": wall, "cpu_s": cpu, "written_bytes": written, "worst_block_error": worst,
            "workers": vx.default_workers() if workers is None else workers, "slice_sha256": digests}


def run_serial(size) -> dict:
    """The writer with one thread: every slice made by the caller."""
    return run_streamed(size, workers=1)


class _Reference:
    """The writer as it was before it was made faster (foldprint 905e954): per layer, every
    region sliced and filled, the dither thresholds gathered per voxel, labels set by
    boolean indexing, block sums rows first, the width tables built whole, one layer at a
    time in the caller. Kept here as the honest baseline; its slices must be the same
    bytes as the writer's."""

    def __init__(self, part):
        from foldprint.exchange import voxels as vx

        self.vx, self.part, self.grid, self.p = vx, part, part.grid(), part.pitch
        self.windows = [vx._window(r, self.grid) for r in part.regions]
        self.tables, self.blocks = {}, {}

    def table(self, r):
        """u on every cell of the hinge's table (what the old ``_WidthTable`` computed)."""
        t = self.vx._WidthTable(r, self.p)
        A, B = np.meshgrid(t.ca, t.cb, indexing="ij")
        pts = t.origin + A.reshape(-1, 1) * t.basis[0] + B.reshape(-1, 1) * t.basis[1]
        t.u = r.axes.width_u(pts).reshape(t.n[0], t.n[1])
        return t

    def fraction(self, r, table, xs, ys, z):
        if r.along_length:
            ax = r.axes
            d, o = ax.direction, ax.origin
            u = ((xs[None, :] - o[0]) * d[0] + (ys[:, None] - o[1]) * d[1] + (z - o[2]) * d[2]) / ax.length
        else:
            e, o = table.basis, table.origin
            a = (xs[None, :] - o[0]) * e[0, 0] + (ys[:, None] - o[1]) * e[0, 1] + (z - o[2]) * e[0, 2]
            b = (xs[None, :] - o[0]) * e[1, 0] + (ys[:, None] - o[1]) * e[1, 1] + (z - o[2]) * e[1, 2]
            ia = np.clip(((a - table.lo[0]) / table.h).astype(np.int64), 0, table.n[0] - 1)
            ib = np.clip(((b - table.lo[1]) / table.h).astype(np.int64), 0, table.n[1] - 1)
            u = table.u[ia, ib]
        return np.clip(np.asarray(r.profile.at(np.clip(u, 0.0, 1.0)), dtype=float), 0.0, 1.0)

    def block_sums(self, idx, r, mask, white, f, i0, j0, k):
        """The old per-layer block sums of a hinge (``_Stats.add_window``: rows first, int64)."""
        from foldprint.exchange.voxel_stats import BLOCK_MM

        vx, p, blk = self.vx, self.p, BLOCK_MM
        if idx not in self.blocks:
            bb = r.solid.bounding_box()
            lo = np.floor((np.array(bb[:3]) - self.grid.origin) / blk).astype(np.int64)
            n = np.floor((np.array(bb[3:]) - self.grid.origin) / blk).astype(np.int64) - lo + 1
            self.blocks[idx] = (lo, n, np.zeros((3, int(np.prod(n)))))
        lo, n, acc = self.blocks[idx]
        h, w = mask.shape
        cb = np.floor((i0 + np.arange(w) + 0.5) * p.x / blk).astype(np.int64) - lo[0]
        rb = np.floor((j0 + np.arange(h) + 0.5) * p.y / blk).astype(np.int64) - lo[1]
        zb = min(max(int(math.floor((k + 0.5) * p.z / blk)) - int(lo[2]), 0), int(n[2]) - 1)
        cs = np.flatnonzero(np.r_[True, cb[1:] != cb[:-1]])
        rs = np.flatnonzero(np.r_[True, rb[1:] != rb[:-1]])
        cb, rb = np.clip(cb[cs], 0, n[0] - 1), np.clip(rb[rs], 0, n[1] - 1)

        def sums(a, dtype):
            return np.add.reduceat(np.add.reduceat(a, rs, axis=0, dtype=dtype), cs, axis=1, dtype=dtype)

        count = sums(mask, np.int64)
        vw = sums(mask & white, np.int64)
        target = count * float(f) if np.isscalar(f) else sums(np.where(mask, f, 0.0), np.float64)
        key = ((zb * n[1] + rb[:, None]) * n[0] + cb[None, :]).ravel()
        for row, v in enumerate((count, vw, target)):
            np.add.at(acc[row], key, np.asarray(v, float).ravel())

    def layer(self, k):
        vx, grid, p = self.vx, self.grid, self.p
        nx, ny, _ = grid.shape
        z = grid.layer_z(k)
        labels = np.zeros((ny, nx), np.uint8)
        for idx, (r, (i0, i1, j0, j1, k0, k1)) in enumerate(zip(self.part.regions, self.windows)):
            if not (k0 <= k < k1) or i1 <= i0 or j1 <= j0:
                continue
            polys = r.solid.slice(z).to_polygons()
            if not polys:
                continue
            mask = vx.fill(polys, grid.origin[0] + i0 * p.x, grid.origin[1] + j0 * p.y, p.x, p.y, i1 - i0, j1 - j0)
            c = r.constant
            if c is not None and r.kind == "panel":
                labels[j0:j1, i0:i1][mask] = vx.VERO if c == 1.0 else vx.TANGO
                continue
            rows, cols = np.arange(j0, j1), np.arange(i0, i1)
            t = vx.layer_mask(k)[np.ix_(rows % vx.MASK_SIZE, cols % vx.MASK_SIZE)]
            if c is not None:
                f = c
            else:
                if not r.along_length and idx not in self.tables:
                    self.tables[idx] = self.table(r)
                xs = grid.origin[0] + (cols + 0.5) * p.x
                ys = grid.origin[1] + (rows + 0.5) * p.y
                f = self.fraction(r, self.tables.get(idx), xs, ys, z)
            white = t < f
            view = labels[j0:j1, i0:i1]
            view[mask & white] = vx.VERO
            view[mask & ~white] = vx.TANGO
            if r.kind == "hinge":
                self.block_sums(idx, r, mask, white, f, i0, j0, k)
        return self.png(labels)

    def png(self, labels):
        """The old encoder: four shifts and ors per byte, the same chunks and zlib level."""
        vx, p = self.vx, self.p
        ny, nx = labels.shape
        pad = (-nx) % 4
        lab = np.pad(labels.astype(np.uint8), ((0, 0), (0, pad))) if pad else labels.astype(np.uint8)
        q = lab.reshape(ny, -1, 4)
        packed = (q[:, :, 0] << 6) | (q[:, :, 1] << 4) | (q[:, :, 2] << 2) | q[:, :, 3]
        raw = np.zeros((ny, packed.shape[1] + 1), np.uint8)
        raw[:, 1:] = packed
        ihdr = struct.pack(">IIBBBBB", nx, ny, 2, 3, 0, 0, 0)
        plte = b"".join(bytes(rgba[:3]) for _, rgba in vx.PALETTE)
        trns = bytes(rgba[3] for _, rgba in vx.PALETTE)
        phys = struct.pack(">IIB", round(1000.0 / p.x), round(1000.0 / p.y), 1)
        return (b"\x89PNG\r\n\x1a\n" + vx.png_chunk(b"IHDR", ihdr) + vx.png_chunk(b"PLTE", plte)
                + vx.png_chunk(b"tRNS", trns) + vx.png_chunk(b"pHYs", phys)
                + vx.png_chunk(b"IDAT", zlib.compress(raw.tobytes(), vx.ZLIB_LEVEL)) + vx.png_chunk(b"IEND", b""))


def _digests(paths) -> list[str]:
    return [hashlib.sha256(p.read_bytes()).hexdigest() for p in paths]


def run_reference(size) -> dict:
    """The pre-change writer (:class:`_Reference`), written through the same staged set."""
    from foldprint.exchange import voxels as vx
    from foldprint.exchange.fileset import write_set

    part = plate(size)
    vx.blue_noise()  # made once per process by both writers, outside the timing
    ref = _Reference(part)
    nz = ref.grid.shape[2]
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        paths = write_set(os.path.join(tmp, "out"), [(f"s{k:05d}.png", functools.partial(ref.layer, k))
                                                      for k in range(nz)])
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        digests = _digests(paths)
    return {"shape": list(ref.grid.shape), "wall_s": wall, "cpu_s": cpu, "slice_sha256": digests}


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
    digests = r.pop("slice_sha256", None)
    if digests is not None:  # one digest of the stack: sha256 of the slices' sha256s, in order
        r["slices"] = len(digests)
        r["stack_sha256"] = hashlib.sha256("".join(digests).encode()).hexdigest()
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
    ap.add_argument("--no-reference", action="store_true", help="skip the pre-change writer on the big plate")
    ap.add_argument("--no-serial", action="store_true", help="skip the one-thread run on the big plate")
    a = ap.parse_args()
    big = [float(v) for v in a.size.split(",")]
    small = [float(v) for v in a.small.split(",")]
    res = {"machine_load_1min": os.getloadavg()[0], "cpus": os.cpu_count()}
    runs = ["streamed_small", "whole_volume_small", "trimesh_small"]
    res["streamed_small"] = child("streamed", small)
    res["whole_volume_small"] = child("whole_volume", small)
    res["trimesh_small"] = child("trimesh", small)
    if not a.no_reference:
        res["reference_big"] = child("reference", big)
        runs.append("reference_big")
    if not a.no_serial:
        res["serial_big"] = child("serial", big)
        runs.append("serial_big")
    res["streamed_big"] = child("streamed", big)
    runs.append("streamed_big")
    res["machine_load_1min_end"] = os.getloadavg()[0]
    s, w, t, b = res["streamed_small"], res["whole_volume_small"], res["trimesh_small"], res["streamed_big"]
    res["ratios"] = {
        "streamed_vs_trimesh_voxels_per_s": s["voxels_per_s"] / t["voxels_per_s"],
        "streamed_vs_trimesh_voxels_per_cpu_s": s["voxels_per_cpu_s"] / t["voxels_per_cpu_s"],
        "streamed_vs_whole_volume_voxels_per_s": s["voxels_per_s"] / w["voxels_per_s"],
        "whole_volume_vs_streamed_peak_rss": w["peak_rss_bytes"] / s["peak_rss_bytes"],
        "big_vs_small_peak_rss": b["peak_rss_bytes"] / s["peak_rss_bytes"],
        "big_vs_small_voxels": b["voxels"] / s["voxels"],
    }
    for base in ("reference_big", "serial_big"):
        if base in res:
            r = res[base]
            name = base.split("_")[0]
            res["ratios"][f"{name}_over_streamed_wall"] = r["wall_s"] / b["wall_s"]
            res["ratios"][f"{name}_over_streamed_cpu"] = r["cpu_s"] / b["cpu_s"]
            res["ratios"][f"{name}_over_streamed_peak_rss"] = r["peak_rss_bytes"] / b["peak_rss_bytes"]
            res[f"slices_identical_to_{name}"] = r["stack_sha256"] == b["stack_sha256"] and r["slices"] == b["slices"]
    res["targets"] = {"big_wall_s": [b["wall_s"], TARGET_S, b["wall_s"] < TARGET_S],
                      "big_peak_rss_bytes": [b["peak_rss_bytes"], TARGET_BYTES, b["peak_rss_bytes"] < TARGET_BYTES]}
    if a.json:
        print(json.dumps(res, indent=1))
        return
    print(f"load {res['machine_load_1min']:.2f} -> {res['machine_load_1min_end']:.2f} on {res['cpus']} CPUs")
    for name in runs:
        r = res[name]
        extra = f", {r['slices_per_s']:.1f} slices/s" if "slices_per_s" in r else ""
        extra += f", {r['workers']} thread(s)" if "workers" in r else ""
        print(f"{name:20s} {r['shape']} {r['wall_s']:8.2f} s ({r['cpu_s']:.2f} CPU-s)  "
              f"{r['peak_rss_bytes'] / 2**20:7.0f} MiB  "
              f"{r['voxels_per_s'] / 1e6:7.2f} Mvox/s{extra}")
    for k, v in res["ratios"].items():
        print(f"{k}: {v:.3g}")
    for k in ("slices_identical_to_reference", "slices_identical_to_serial"):
        if k in res:
            print(f"{k}: {res[k]}")
    for k, (v, lim, ok) in res["targets"].items():
        print(f"{k}: {v:.4g} (target < {lim:g}) {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
