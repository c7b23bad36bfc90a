"""The pixels of a voxel slice: the blue-noise threshold mask the hinges are dithered
against, polygons filled at pixel centres (as runs of pixels), and the 2-bit palette PNG a
slice is written as. What :mod:`foldprint.exchange.voxels` builds its stack from; nothing
here knows about hinges, fractions or the part (docs/voxels.md)."""

from __future__ import annotations

import functools
import math
import struct
import zlib

import numpy as np

from ..core.errors import ExportError

#: PNG palette: index -> (name, RGBA). Index 0 is empty space (transparent; its RGB,
#: magenta, is neither resin, so a tool that drops alpha does not read it as a resin).
EMPTY, VERO, TANGO = 0, 1, 2  # VERO = TANGO - 1: a hinge voxel is TANGO - (VeroWhite?)
PALETTE = ((None, (255, 0, 255, 0)), ("VeroWhite", (255, 255, 255, 255)), ("TangoBlack", (0, 0, 0, 255)))
#: side of the blue-noise tile (voxels); its thresholds repeat every 64 voxels in x and y
MASK_SIZE = 64
#: layer-to-layer shift of the thresholds: the golden ratio's fractional part
GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
ZLIB_LEVEL = 6


# -- the threshold mask --------------------------------------------------------------------

@functools.lru_cache(maxsize=1)
def blue_noise(size: int = MASK_SIZE, sigma: float = 1.5, seed: int = 20151001) -> np.ndarray:
    """(size, size) thresholds in (0, 1): ranks (k + 0.5) / size^2 of a void-and-cluster
    blue-noise pattern (Ulichney 1993): the initial pattern (10 % of random pixels, fixed
    seed) is relaxed by swapping its tightest cluster into its largest void until
    stable; ranks below its count are given by removing tightest clusters, the rest by
    filling largest voids. Energies on the torus with a Gaussian of ``sigma`` pixels."""
    n = size * size
    d = np.minimum(np.arange(size), size - np.arange(size)).astype(float)
    kernel = np.exp(-(d[:, None] ** 2 + d[None, :] ** 2) / (2 * sigma * sigma))

    def splat(energy, i, sign):
        r, c = divmod(int(i), size)
        energy += sign * np.roll(np.roll(kernel, r, axis=0), c, axis=1)

    rng = np.random.default_rng(seed)
    ones = np.zeros(n, bool)
    ones[rng.choice(n, n // 10, replace=False)] = True
    energy = np.zeros((size, size))
    for i in np.flatnonzero(ones):
        splat(energy, i, 1.0)
    for _ in range(n):  # relax: tightest cluster -> largest void
        e = energy.ravel()
        cluster = int(np.argmax(np.where(ones, e, -np.inf)))
        splat(energy, cluster, -1.0)
        ones[cluster] = False
        void = int(np.argmin(np.where(ones, np.inf, e)))
        if void == cluster:
            splat(energy, cluster, 1.0)
            ones[cluster] = True
            break
        splat(energy, void, 1.0)
        ones[void] = True
    rank = np.zeros(n, np.int64)
    start = ones.copy()
    start_energy = energy.copy()
    count = int(ones.sum())
    for k in range(count - 1, -1, -1):  # phase 1: remove tightest clusters
        e = energy.ravel()
        i = int(np.argmax(np.where(ones, e, -np.inf)))
        rank[i] = k
        ones[i] = False
        splat(energy, i, -1.0)
    ones, energy = start, start_energy
    for k in range(count, n):  # phases 2 and 3: fill largest voids
        e = energy.ravel()
        i = int(np.argmin(np.where(ones, np.inf, e)))
        rank[i] = k
        ones[i] = True
        splat(energy, i, 1.0)
    return ((rank + 0.5) / n).reshape(size, size)


def layer_mask(k: int) -> np.ndarray:
    """The (64, 64) dither thresholds of layer k, in [0, 1)."""
    t = blue_noise() + (k * GOLDEN) % 1.0
    return t - np.floor(t)


def tiled(tile: np.ndarray, j0: int, j1: int, i0: int, i1: int) -> np.ndarray:
    """``tile[(j0..j1-1) % m][:, (i0..i1-1) % m]`` of an (m, m) tile, by repeating the rolled
    tile (a copy at memory speed) instead of gathering element by element."""
    m = tile.shape[0]
    t = np.roll(tile, (-(j0 % m), -(i0 % m)), axis=(0, 1))
    return np.tile(t, (-(-(j1 - j0) // m), -(-(i1 - i0) // m)))[:j1 - j0, :i1 - i0]



# -- rasterising ---------------------------------------------------------------------------

def fill(polygons: list[np.ndarray], x0: float, y0: float, px: float, py: float,
         nx: int, ny: int) -> np.ndarray:
    """(ny, nx) bool: pixel centres (x0 + (i + 0.5) px, y0 + (j + 0.5) py) inside the
    polygons (even-odd rule, rings closed implicitly; a centre on a left edge is in, on a
    right edge out)."""
    return paint_runs(pixel_runs(polygons, x0, y0, px, py, nx, ny), nx, ny)


NO_RUNS = (np.zeros(0, np.int64),) * 3


def pixel_runs(polygons: list[np.ndarray], x0: float, y0: float, px: float, py: float,
          nx: int, ny: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The runs of pixels inside the polygons, (rows, first column, end column): what
    :func:`fill` paints, and all it depends on (the scan lines' crossings, rounded to
    pixel centres)."""
    rings = [np.asarray(p, float) for p in polygons if len(p) >= 3]
    if not rings:
        return NO_RUNS
    a = np.concatenate(rings)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    keep = a[:, 1] != b[:, 1]
    a, b = a[keep], b[keep]
    ylo, yhi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
    j0 = np.clip(np.ceil((ylo - y0) / py - 0.5), 0, ny).astype(np.int64)
    j1 = np.clip(np.ceil((yhi - y0) / py - 0.5), 0, ny).astype(np.int64)
    cnt = j1 - j0
    if cnt.sum() == 0:
        return NO_RUNS
    e = np.repeat(np.arange(len(a)), cnt)
    j = j0[e] + (np.arange(len(e)) - np.repeat(np.cumsum(cnt) - cnt, cnt))
    yc = y0 + (j + 0.5) * py
    ae, be = a[e], b[e]
    x = ae[:, 0] + (yc - ae[:, 1]) * (be[:, 0] - ae[:, 0]) / (be[:, 1] - ae[:, 1])
    order = np.lexsort((x, j))
    j, x = j[order], x[order]
    if len(j) % 2:  # cannot happen for closed rings; be safe
        raise ExportError("voxel slice: an open outline (odd number of edge crossings)")
    i0 = np.clip(np.ceil((x[0::2] - x0) / px - 0.5), 0, nx).astype(np.int64)
    i1 = np.clip(np.ceil((x[1::2] - x0) / px - 0.5), 0, nx).astype(np.int64)
    return j[0::2], i0, i1


def paint_runs(runs: tuple[np.ndarray, np.ndarray, np.ndarray], nx: int, ny: int) -> np.ndarray:
    """(ny, nx) bool mask of :func:`pixel_runs`' runs."""
    rows, i0, i1 = runs
    if len(rows) == 0:
        return np.zeros((ny, nx), bool)
    diff = np.bincount(rows * (nx + 1) + i0, minlength=ny * (nx + 1)).astype(np.int32)
    diff -= np.bincount(rows * (nx + 1) + i1, minlength=ny * (nx + 1)).astype(np.int32)
    return np.cumsum(diff.reshape(ny, nx + 1), axis=1)[:, :nx] > 0


#: cells of a :class:`_WidthTable` at most (float64: 16 MB), and their size relative to the
#: smallest pitch at most (a quarter voxel: u off by < 0.2 % of a 5 mm hinge's width)


# -- PNG -----------------------------------------------------------------------------------

PACK = (1 << 30) | (1 << 20) | (1 << 10) | 1


def png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(labels: np.ndarray, pitch) -> bytes:
    """A 2-bit palette PNG of ``labels`` (ny, nx) with values 0..3 (:data:`PALETTE`);
    row 0 of the image is y index 0 (the grid's front edge); pHYs gives the pitch
    (``pitch.x``, ``pitch.y`` in mm: a :class:`foldprint.exchange.voxel_regions.Pitch`)."""
    ny, nx = labels.shape
    lab = np.zeros((ny, padded_width(nx)), np.uint8)
    lab[:, :nx] = labels
    return png_padded(lab, nx, pitch)


def padded_width(nx: int) -> int:
    """Columns of a label row padded to whole bytes of four 2-bit pixels."""
    return nx + (-nx) % 4


def png_padded(lab: np.ndarray, nx: int, pitch) -> bytes:
    """:func:`png_bytes` of labels already padded with zeros to :func:`padded_width` columns
    (uint8, C-contiguous)."""
    ny = lab.shape[0]
    # four labels b0..b3 (0..3) -> one byte b0 << 6 | b1 << 4 | b2 << 2 | b3: read as a
    # little-endian word v = b0 + b1 2^8 + b2 2^16 + b3 2^24, v * PACK puts b0 << 30, b1 << 28,
    # b2 << 26, b3 << 24 in the top byte; every other product lies in bits 0-21 (no carry
    # reaches bit 24) or beyond bit 31 (dropped modulo 2^32)
    word = np.multiply(lab.view("<u4"), np.uint32(PACK))
    np.right_shift(word, np.uint32(24), out=word)
    raw = np.empty((ny, word.shape[1] + 1), np.uint8)
    raw[:, 0] = 0  # filter byte 0 (None) per row
    raw[:, 1:] = word
    ihdr = struct.pack(">IIBBBBB", nx, ny, 2, 3, 0, 0, 0)
    plte = b"".join(bytes(rgba[:3]) for _, rgba in PALETTE)
    trns = bytes(rgba[3] for _, rgba in PALETTE)
    phys = struct.pack(">IIB", round(1000.0 / pitch.x), round(1000.0 / pitch.y), 1)  # pixels per metre
    return (b"\x89PNG\r\n\x1a\n" + png_chunk(b"IHDR", ihdr) + png_chunk(b"PLTE", plte) + png_chunk(b"tRNS", trns)
            + png_chunk(b"pHYs", phys) + png_chunk(b"IDAT", zlib.compress(raw, ZLIB_LEVEL))
            + png_chunk(b"IEND", b""))


def read_png(data: bytes) -> np.ndarray:
    """Labels (ny, nx) of a PNG written by :func:`png_bytes` (for tests and checks)."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ExportError("not a PNG file")
    pos, idat, hdr = 8, [], None
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + n
    nx, ny, depth, ctype = hdr[0], hdr[1], hdr[2], hdr[3]
    if depth != 2 or ctype != 3:
        raise ExportError("read_png reads the 2-bit palette PNGs of the voxel writer only")
    raw = np.frombuffer(zlib.decompress(b"".join(idat)), np.uint8).reshape(ny, -1)
    packed = raw[:, 1:]
    lab = np.stack([(packed >> s) & 3 for s in (6, 4, 2, 0)], axis=-1).reshape(ny, -1)
    return lab[:, :nx]
