"""What writing a voxel stack costs (``export --format voxels``: one slice held at a time,
every voxel visited), estimated from the grid's shape before any slice is made, and
refused through the guard (:func:`foldprint.core.guards.enforce`).

Measured with benchmarks/bench_voxels.py on the 150 x 150 x 20 mm plate (docs/voxels.md:
the writer of e4bbc23, 180 MB peak, 39.8 CPU-s for 4.65e9 voxels = 0.86e-8 s, rounded up;
the pre-change writer's 309 MB / 105 CPU-s set the memory figures below, kept as an upper
bound): bytes per pixel of one slice (the label image, a region's mask, its thresholds and
fraction, the scan-line counts and their cumulative sum, the packed rows); per graded
hinge its u table (<= 2e6 cells, 16 MB) and, while it is made, the cell centres and their
search (48 MB, one at a time); CPU seconds per voxel. Slices are streamed, so memory does
not grow with the layer count."""

from __future__ import annotations

from ..core.guards import BASE_BYTES, LIFT_TIME, enforce, fmt_bytes, fmt_seconds, lift_memory_env

VOXEL_BYTES_PER_PIXEL = 20
VOXEL_TABLE_BYTES = 16 * 2 ** 20
VOXEL_TABLE_BUILD_BYTES = 48 * 2 ** 20
VOXEL_S_PER_VOXEL = 0.9e-8


def check_voxels(shape: tuple[int, int, int], src: str = "", graded: int = 0) -> dict:
    """Refuse a voxel stack whose memory (one slice, plus the u tables of ``graded``
    hinges graded across their width) or whole-stack time would exceed the limits, before
    any slice is made. ``shape``: (nx, ny, layers)."""
    nx, ny, nz = (float(v) for v in shape)
    tables = graded * VOXEL_TABLE_BYTES + (VOXEL_TABLE_BUILD_BYTES if graded else 0)
    est = {"bytes": BASE_BYTES + nx * ny * VOXEL_BYTES_PER_PIXEL + tables,
           "seconds": nx * ny * nz * VOXEL_S_PER_VOXEL}
    what = f"a {nx:.0f} x {ny:.0f} pixel x {nz:.0f} layer voxel stack"
    return enforce(est, f"{src}voxel export",
                   (f"{what} needs about {fmt_bytes(est['bytes'])} per slice",
                    f"print the part in pieces, or {lift_memory_env(est)}"),
                   (f"{what} takes about {fmt_seconds(est['seconds'])}", f"print the part in pieces, or {LIFT_TIME}"))


def check_part(part, src: str = "") -> dict:
    """:func:`check_voxels` of a :class:`~foldprint.exchange.voxels.VoxelPart`: its grid's
    shape and its hinges graded across their width."""
    graded = sum(1 for r in part.regions if r.constant is None and not r.along_length)
    return check_voxels(part.grid().shape, src, graded)
