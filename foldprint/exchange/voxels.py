"""Voxel print: the printed part as a stack of PNG slices at the printer's pitch, one
colour per base resin, hinges dithered to their VeroWhite fraction (``docs/voxels.md``).

The writer receives everything it writes (:class:`~foldprint.exchange.voxel_regions.VoxelPart`:
one :class:`~foldprint.exchange.voxel_regions.VoxelRegion` per panel and hinge, each with
its solid, its :class:`FractionProfile`-like profile and, for hinges, the
:class:`~foldprint.geometry.HingeAxes` that map a point to u); it runs no physics and builds
no geometry. What it measures of each hinge per 1 mm block is in
:mod:`foldprint.exchange.voxel_stats`.

Streamed: each slice is cut from the solids (``Manifold.slice``), rasterised with numpy
(even-odd scan lines at pixel centres) and encoded as a 2-bit palette PNG with zlib;
:func:`slice_files` returns callables that :func:`~foldprint.exchange.fileset.write_set`
calls in order. A few threads make the next slices ahead (at most ``workers * AHEAD + 1``
in memory), taken and measured in order, so the bytes are those of a one-at-a-time
writer. The manifest comes last and carries the fractions measured on the written voxels.

Dithering: a voxel (ix, iy, layer k) is VeroWhite when its threshold
t = frac(B[iy mod 64, ix mod 64] + k * (golden ratio - 1)) is below the VeroWhite fraction
f(u) of its hinge at its u. ``B`` is a 64 x 64 blue-noise rank mask (void and cluster,
Ulichney 1993, with a fixed seed); the golden-ratio shift from layer to layer makes each
column's thresholds a low-discrepancy sequence, so every 1 mm^3 holds the target fraction
to within a fraction of a percent. Deterministic: the same part gives the same bytes.
"""

from __future__ import annotations

import functools
import json
import math
import os
import threading
import weakref
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any, Callable

import numpy as np

from ..core.version import __version__
from ..core.errors import ExportError
from .voxel_pixels import (EMPTY, MASK_SIZE, PALETTE, TANGO, VERO, ZLIB_LEVEL, blue_noise,  # noqa: F401
                           fill, layer_mask, paint_runs, padded_width, pixel_runs, png_bytes, png_padded, read_png,
                           tiled)
from .voxel_regions import TANGO_BLACK, VERO_WHITE, Grid, Pitch, VoxelPart, VoxelRegion
from .voxel_stats import BLOCK_MIN_FILL, BLOCK_MM, FRACTION_TOL, BlockStats

#: threads that make slices ahead of the writer, at most (2 cores here; zlib, numpy and the
#: fill release the GIL, the Python between them does not)
MAX_WORKERS = 4
#: layers made ahead per worker thread (each holds a slice's labels and PNG until written)
AHEAD = 2


def _plane(xs: np.ndarray, ys: np.ndarray, z: float, o: np.ndarray, e: np.ndarray) -> np.ndarray:
    """(p - o) . e at the pixel centres (xs[i], ys[j], z) of a window, as the smallest array
    that broadcasts to (len(ys), len(xs)): the same sum ((x-term + y-term) + z-term) as over
    the whole window, where a term whose coefficient is 0 adds exactly nothing and is left
    out (a row when e has no y part, a column when it has no x part)."""
    zt = (z - o[2]) * e[2]
    if e[1] == 0.0:
        return ((xs - o[0]) * e[0] + zt)[None, :]
    if e[0] == 0.0:
        return ((ys - o[1]) * e[1] + zt)[:, None]
    return (xs[None, :] - o[0]) * e[0] + (ys[:, None] - o[1]) * e[1] + zt


def _fraction_window(r: VoxelRegion, table, xs: np.ndarray, ys: np.ndarray, z: float) -> np.ndarray:
    """VeroWhite fraction of a graded hinge at the pixel centres of a window of the layer at
    height z, as an array that broadcasts to (len(ys), len(xs)): u is linear in x and y
    (along the length) or looked up in the hinge's width table, both separable in x and y."""
    if r.along_length:
        ax = r.axes
        u = _plane(xs, ys, z, ax.origin, ax.direction) / ax.length
    else:
        e, o = table.basis, table.origin
        a, b = _plane(xs, ys, z, o, e[0]), _plane(xs, ys, z, o, e[1])
        ia = np.clip(((a - table.lo[0]) / table.h).astype(np.int64), 0, table.n[0] - 1)
        ib = np.clip(((b - table.lo[1]) / table.h).astype(np.int64), 0, table.n[1] - 1)
        u = table.at(ia, ib)
    return np.clip(np.asarray(r.profile.at(np.clip(u, 0.0, 1.0)), dtype=float), 0.0, 1.0)


WIDTH_TABLE_CELLS = 2_000_000
WIDTH_TABLE_CELL = 0.25


class _WidthTable:
    """u across a hinge (``HingeAxes.width_u``) on a grid of cells in the plane
    perpendicular to its fold line (u does not change along the line), looked up per voxel
    by the nearest cell: the nearest-point search over the mid-line costs ~1 us a point,
    the lookup ~0.03 us. A cell's u is computed the first time a voxel looks it up (a
    layer of a flat hinge touches one row of cells in z), from the same cell centre as
    a table made whole; thread-safe."""

    def __init__(self, region: VoxelRegion, pitch: Pitch):
        ax = region.axes
        d = ax.direction
        e1 = np.cross(d, [0.0, 0.0, 1.0])
        if np.linalg.norm(e1) < 1e-9:
            e1 = np.cross(d, [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(d, e1)
        self.axes, self.origin, self.basis = ax, ax.origin, np.stack([e1, e2])
        bb = np.asarray(region.solid.bounding_box()).reshape(2, 3)
        corners = np.array([[bb[i, 0], bb[j, 1], bb[k, 2]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
        ab = (corners - self.origin) @ self.basis.T
        self.lo = ab.min(axis=0) - 1e-6
        span = ab.max(axis=0) + 1e-6 - self.lo
        h = WIDTH_TABLE_CELL * min(pitch.x, pitch.y, pitch.z)
        h = max(h, math.sqrt(span[0] * span[1] / WIDTH_TABLE_CELLS))
        self.h = h
        self.n = np.maximum(1, np.ceil(span / h).astype(np.int64))
        self.ca = self.lo[0] + (np.arange(self.n[0]) + 0.5) * h  # cell centres
        self.cb = self.lo[1] + (np.arange(self.n[1]) + 0.5) * h
        self.u = np.zeros((self.n[0], self.n[1]))
        self.known = np.zeros((self.n[0], self.n[1]), bool)
        self._lock = threading.Lock()

    def at(self, ia: np.ndarray, ib: np.ndarray) -> np.ndarray:
        """u of cells (ia, ib) (index arrays that broadcast together)."""
        with self._lock:
            need = ~self.known[ia, ib]
            if need.any():
                ia_, ib_ = np.broadcast_arrays(ia, ib)
                cells = np.unique(ia_[need] * self.n[1] + ib_[need])
                a, b = np.divmod(cells, self.n[1])
                e1, e2 = self.basis
                pts = self.origin + self.ca[a].reshape(-1, 1) * e1 + self.cb[b].reshape(-1, 1) * e2
                self.u.ravel()[cells] = self.axes.width_u(pts)
                self.known.ravel()[cells] = True
            return self.u[ia, ib]


def _window(region: VoxelRegion, grid: Grid) -> tuple[int, int, int, int, int, int]:
    """Index ranges [i0, i1) x [j0, j1) x [k0, k1) of the grid the region's box covers."""
    bb = region.solid.bounding_box()
    p = grid.pitch
    o = grid.origin
    out = []
    for lo, hi, s, org, n in ((bb[0], bb[3], p.x, o[0], grid.shape[0]), (bb[1], bb[4], p.y, o[1], grid.shape[1]),
                              (bb[2], bb[5], p.z, o[2], grid.shape[2])):
        out += [int(np.clip(math.floor((lo - org) / s - 0.5), 0, n)), int(np.clip(math.ceil((hi - org) / s + 0.5), 0, n))]
    return tuple(out)


# -- the stack -----------------------------------------------------------------------------

def default_workers() -> int:
    """Threads that make slices ahead of the writer: the CPUs this process may use, at most
    :data:`MAX_WORKERS` (1: every slice made by the caller, in order)."""
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return max(1, min(MAX_WORKERS, cpus))


def slice_files(part: VoxelPart, stem: str, workers: int | None = None) -> list[tuple[str, Callable[[], bytes]]]:
    """(name, callable) per file of the voxel stack: ``<stem>_slice_NNNNN.png`` per layer
    (bottom first), then ``<stem>_voxels.json`` (the manifest). The callables must be
    called in this order (:func:`~foldprint.exchange.fileset.write_set` does): each returns
    one layer's PNG, and the manifest reports what they measured. ``workers`` threads
    (default :func:`default_workers`) make the next layers while the caller writes one;
    the bytes do not depend on it."""
    if not part.regions:
        raise ExportError(f"design {part.design!r}: nothing to rasterise (no bodies)")
    w = _SliceWriter(part, default_workers() if workers is None else workers)
    nz = w.grid.shape[2]
    digits = max(5, len(str(nz - 1)))
    w.names = [f"{stem}_slice_{k:0{digits}d}.png" for k in range(nz)]
    files: list[tuple[str, Callable[[], bytes]]] = [(n, functools.partial(w.layer, k)) for k, n in enumerate(w.names)]
    files.append((f"{stem}_voxels.json", w.manifest))
    return files


class _SliceWriter:
    """Cuts, rasterises and dithers the layers of one voxel part, measuring each hinge's
    fraction; then writes the manifest.

    A layer is a pure function of k: its labels, its PNG and its hinges' block sums
    (:meth:`_make`). With ``workers`` > 1 a thread pool makes up to :data:`AHEAD` layers per
    worker ahead of the one asked for (numpy, zlib and the fill release the GIL); the
    caller takes them in order and adds their block sums in order, so the bytes and the
    manifest are those of the serial writer and at most ``workers * AHEAD + 1`` layers are
    in memory. A region's mask is kept with the runs of pixels it was painted from
    (:func:`pixel_runs`, all the mask depends on) and reused while the next layers' cross-sections
    give the same runs (a prism: panels and hinges printed flat)."""

    def __init__(self, part: VoxelPart, workers: int = 1):
        self.part, self.grid, self.p = part, part.grid(), part.pitch
        self.windows = [_window(r, self.grid) for r in part.regions]
        self.stats = {k: BlockStats(r, self.grid, self.windows[k]) for k, r in enumerate(part.regions)
                      if r.kind == "hinge"}
        self.tables: dict[int, _WidthTable] = {}
        self.masks: dict[int, tuple] = {}  # region -> (runs, mask, block counts), the last painted
        self.next = 0
        self.names: list[str] = []
        self.workers = max(1, int(workers))
        self._ready = False
        self._pool: ThreadPoolExecutor | None = None
        self._pending: dict[int, Future] = {}
        self._cut = threading.Lock()  # Manifold.slice from one thread at a time

    def layer(self, k: int) -> bytes:
        if self.next != k:
            raise ExportError("voxel slices must be written in order")
        self.next = k + 1
        self._prepare()
        if self.workers > 1:
            png, sums = self._ahead(k)
        else:
            png, sums = self._make(k)
        for idx, block in sums:
            self.stats[idx].add(*block)
        return png

    def _prepare(self) -> None:
        """Once, before any thread shares them: the blue-noise mask and the width tables of
        the hinges graded across their width."""
        if self._ready:
            return
        blue_noise()
        for idx, r in enumerate(self.part.regions):
            i0, i1, j0, j1, k0, k1 = self.windows[idx]
            if r.kind != "hinge" or r.constant is not None or k1 <= k0 or i1 <= i0 or j1 <= j0:
                continue
            if r.axes is None:
                raise ExportError(f"hinge {r.id!r}: a graded fraction needs the hinge's axes")
            if not r.along_length:
                self.tables[idx] = _WidthTable(r, self.p)
        self._ready = True

    def _ahead(self, k: int) -> tuple[bytes, list]:
        nz = self.grid.shape[2]
        if self._pool is None:
            self._pool = ThreadPoolExecutor(self.workers, thread_name_prefix="voxel-slices")
            self._stop = weakref.finalize(self, self._pool.shutdown, wait=False, cancel_futures=True)
        for kk in range(k, min(nz, k + 1 + self.workers * AHEAD)):
            if kk not in self._pending:
                self._pending[kk] = self._pool.submit(self._make, kk)
        try:
            out = self._pending.pop(k).result()
        except BaseException:
            self._stop()
            raise
        if k == nz - 1:
            self._stop()
        return out

    def _make(self, k: int) -> tuple[bytes, list]:
        """Layer k: its PNG and its hinges' block sums, [(region, block_sums)]."""
        grid, p = self.grid, self.p
        nx, ny, _ = grid.shape
        z = grid.layer_z(k)
        labels = np.zeros((ny, padded_width(nx)), np.uint8)  # the padding columns stay empty
        sums = []
        for idx, (r, (i0, i1, j0, j1, k0, k1)) in enumerate(zip(self.part.regions, self.windows)):
            if not (k0 <= k < k1) or i1 <= i0 or j1 <= j0:
                continue
            with self._cut:
                polys = r.solid.slice(z).to_polygons()
            if not polys:
                continue
            mask, count = self._mask(idx, polys)
            view = labels[j0:j1, i0:i1]
            c = r.constant
            if c is not None and r.kind == "panel":
                if c not in (0.0, 1.0):
                    raise ExportError(f"panel {r.id!r}: material {r.material!r} is not a base resin "
                                      f"({VERO_WHITE} or {TANGO_BLACK}); voxel print dithers hinges only")
                np.copyto(view, np.uint8(VERO if c == 1.0 else TANGO), where=mask)
                continue
            white, f = self._dither(idx, r, k, z)
            np.copyto(view, np.subtract(np.uint8(TANGO), white.view(np.uint8)), where=mask)  # VERO = TANGO - 1
            if idx in self.stats:
                sums.append((idx, self.stats[idx].block_sums(mask, white, f, k, count)))
        return png_padded(labels, nx, p), sums

    def _mask(self, idx: int, polys: list) -> tuple[np.ndarray, np.ndarray | None]:
        """The region's pixels inside ``polys`` (and their block counts for a hinge): the
        kept mask when the cross-section's runs of pixels are those it was painted from."""
        i0, i1, j0, j1 = self.windows[idx][:4]
        g, p = self.grid, self.p
        runs = pixel_runs(polys, g.origin[0] + i0 * p.x, g.origin[1] + j0 * p.y, p.x, p.y, i1 - i0, j1 - j0)
        key = b"".join(a.tobytes() for a in runs)
        kept = self.masks.get(idx)
        if kept is not None and kept[0] == key:
            return kept[1], kept[2]
        mask = paint_runs(runs, i1 - i0, j1 - j0)
        mask.flags.writeable = False
        count = self.stats[idx].int_sums(mask) if idx in self.stats else None
        self.masks[idx] = (key, mask, count)
        return mask, count

    def _dither(self, idx: int, r: VoxelRegion, k: int, z: float) -> tuple[np.ndarray, Any]:
        """(VeroWhite?, fraction) over the hinge's window in layer k: a voxel is VeroWhite
        when its threshold is below its fraction."""
        i0, i1, j0, j1 = self.windows[idx][:4]
        c = r.constant
        if c is not None:  # one comparison per threshold of the tile, then the tile repeated
            return tiled(layer_mask(k) < c, j0, j1, i0, i1), c
        g, p = self.grid, self.p
        xs = g.origin[0] + (np.arange(i0, i1) + 0.5) * p.x
        ys = g.origin[1] + (np.arange(j0, j1) + 0.5) * p.y
        f = _fraction_window(r, self.tables.get(idx), xs, ys, z)
        return tiled(layer_mask(k), j0, j1, i0, i1) < f, f

    def _regions(self) -> list[dict]:
        p = self.p
        full = (BLOCK_MM / p.x) * (BLOCK_MM / p.y) * (BLOCK_MM / p.z)
        regions = []
        for idx, r in enumerate(self.part.regions):
            rec = {"kind": r.kind, "id": r.id, "material": r.material,
                   "profile": {"knots": [round(float(v), 6) for v in r.profile.knots],
                               "along": None if r.profile.along is None
                               else getattr(r.profile.along, "name", str(r.profile.along)).lower()}}
            if idx in self.stats:
                rec.update(self.stats[idx].record(full))
            regions.append(rec)
        return regions

    def manifest(self) -> bytes:
        grid, p, part = self.grid, self.p, self.part
        nx, ny, nz = grid.shape
        if self.next != nz:
            raise ExportError("the voxel manifest is written after every slice")
        lo = grid.origin + np.asarray(part.print_offset, float)
        doc = {"foldprint_version": __version__, "design": part.design, "state": part.state,
               "format": "voxel slice stack (PNG, 2-bit palette, one file per layer, bottom layer first)",
               "printer": p.printer, "pitch_source": p.source,
               "pitch_mm": {"x": p.x, "y": p.y, "z": p.z},
               "dpi": {"x": round(p.dpi[0], 3), "y": round(p.dpi[1], 3)},
               "size_px": {"x": nx, "y": ny}, "layers": nz,
               "size_mm": [round(nx * p.x, 6), round(ny * p.y, 6), round(nz * p.z, 6)],
               "origin_print_mm": [round(float(v), 6) for v in lo],
               "frame": "print frame (part on the bed, z = 0); pixel (i, j) of slice k is the voxel centred at "
                        "origin + ((i + 0.5) px, (j + 0.5) py, (k + 0.5) pz); image row 0 is the lowest y",
               "colour_map": [{"index": i, "material": name or "empty", "rgba": list(rgba)}
                              for i, (name, rgba) in enumerate(PALETTE)],
               "support": "none in the slices: left to the printer software",
               "dither": {"method": "threshold mask: 64 x 64 void-and-cluster blue noise, shifted by the golden "
                                    "ratio from layer to layer", "block_mm": BLOCK_MM,
                          "block_min_fill": BLOCK_MIN_FILL, "tolerance": FRACTION_TOL},
               "files": self.names, "regions": self._regions()}
        return (json.dumps(doc, indent=1) + "\n").encode("utf-8")
