"""What the voxel writer (:mod:`foldprint.exchange.voxels`) measures of each hinge it
writes: VeroWhite voxels, voxels and the target's sum per 1 mm block, summed layer by
layer, and the manifest's record of them against the tolerance (``docs/voxels.md``).
"""

from __future__ import annotations

import math

import numpy as np

from .voxel_regions import Grid, VoxelRegion

#: the accuracy the issue asks for: |measured - target| <= 1 % in every checked 1 mm^3
FRACTION_TOL = 0.01
#: block size (mm) over which the measured fraction is checked
BLOCK_MM = 1.0
#: a block is checked when it holds at least this share of a full 1 mm^3 block's voxels
#: of the hinge (a 0.8 mm hinge fills 80 % of the blocks inside it; blocks cut by the
#: hinge's faces hold a few voxels, where no dithering can be within 1 %)
BLOCK_MIN_FILL = 0.5


class BlockStats:
    """Per hinge: VeroWhite voxels, voxels and the target's sum, per 1 mm block. The blocks
    of its window's columns and rows are fixed; each layer's sums are made by
    :meth:`block_sums` (in any thread) and added by :meth:`add` in layer order."""

    def __init__(self, region: VoxelRegion, grid: Grid, window: tuple):
        bb = region.solid.bounding_box()
        self.lo = np.floor((np.array(bb[:3]) - grid.origin) / BLOCK_MM).astype(np.int64)
        hi = np.floor((np.array(bb[3:]) - grid.origin) / BLOCK_MM).astype(np.int64)
        self.n = hi - self.lo + 1
        size = int(np.prod(self.n))
        self.vw = np.zeros(size)
        self.count = np.zeros(size)
        self.target = np.zeros(size)
        self.pitch = p = grid.pitch
        i0, i1, j0, j1 = window[:4]
        # the runs of columns and rows whose centres fall in one 1 mm block
        cb = np.floor((i0 + np.arange(i1 - i0) + 0.5) * p.x / BLOCK_MM).astype(np.int64) - self.lo[0]
        rb = np.floor((j0 + np.arange(j1 - j0) + 0.5) * p.y / BLOCK_MM).astype(np.int64) - self.lo[1]
        self.cs = np.flatnonzero(np.r_[True, cb[1:] != cb[:-1]])
        self.rs = np.flatnonzero(np.r_[True, rb[1:] != rb[:-1]])
        cb, rb = np.clip(cb[self.cs], 0, self.n[0] - 1), np.clip(rb[self.rs], 0, self.n[1] - 1)
        self.key_xy = rb[:, None] * self.n[0] + cb[None, :]

    def int_sums(self, a: np.ndarray) -> np.ndarray:
        """Per-block counts of a bool window (columns first: contiguous and exact)."""
        return np.add.reduceat(np.add.reduceat(a.view(np.uint8), self.cs, axis=1, dtype=np.int32),
                               self.rs, axis=0, dtype=np.int64)

    def block_sums(self, mask: np.ndarray, white: np.ndarray, f, k: int, count: np.ndarray | None = None) -> tuple:
        """Layer k's (block keys, voxels, VeroWhite voxels, target sum) of the hinge's window;
        ``count`` the mask's block counts when known."""
        if count is None:
            count = self.int_sums(mask)
        vw = self.int_sums(mask & white)
        if np.isscalar(f):
            target = count * float(f)
        else:  # float sums: rows first, then columns (the order the manifest's numbers were made in)
            target = np.add.reduceat(np.add.reduceat(np.where(mask, f, 0.0), self.rs, axis=0, dtype=np.float64),
                                     self.cs, axis=1, dtype=np.float64)
        zb = int(math.floor((k + 0.5) * self.pitch.z / BLOCK_MM)) - int(self.lo[2])
        zb = min(max(zb, 0), int(self.n[2]) - 1)
        key = (zb * self.n[1] * self.n[0] + self.key_xy).ravel()
        return key, count.ravel(), vw.ravel(), np.asarray(target, float).ravel()

    def add(self, key: np.ndarray, count: np.ndarray, vw: np.ndarray, target: np.ndarray) -> None:
        np.add.at(self.count, key, count)
        np.add.at(self.vw, key, vw)
        np.add.at(self.target, key, target)

    def record(self, full_block: float) -> dict:
        total = float(self.count.sum())
        sel = self.count >= BLOCK_MIN_FILL * full_block
        err = np.abs(self.vw[sel] - self.target[sel]) / self.count[sel] if sel.any() else np.zeros(0)
        return {"voxels": int(total),
                "target_fraction": round(float(self.target.sum()) / total, 6) if total else None,
                "measured_fraction": round(float(self.vw.sum()) / total, 6) if total else None,
                "blocks_checked": int(sel.sum()),
                "worst_block_error": round(float(err.max()), 6) if len(err) else None,
                "within_tolerance": bool(len(err) == 0 or err.max() <= FRACTION_TOL)}
