"""Voxel print (PolyJet parts with graded hinges): rasterising, dithering to the hinge fractions, PNG,
streaming through the staged set, the composite 3MF, hinge axes."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
from pathlib import Path

import manifold3d as mf
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from shapely import contains_xy
from shapely.geometry import Polygon

from foldprint.core import guards
from foldprint.exchange import voxel_cost
from foldprint.core.errors import ExportError
from foldprint.exchange import voxels as vx
from foldprint.exchange import voxel_regions as vr
from foldprint.exchange import voxel_stats as vs
from foldprint.exchange.export import export_assembly
from foldprint.exchange.fileset import write_set
from foldprint.geometry import HingeAxes, build_pieces, hinge_axes
from foldprint.model.composition import Along, FractionProfile

J750 = vr.Pitch(25.4 / 600, 25.4 / 300, 0.027, "j750", "test")


def Profile(knots, along=None):
    return FractionProfile(tuple(knots), along)


def _box(x0, y0, z0, x1, y1, z1) -> mf.Manifold:
    return mf.Manifold.cube([x1 - x0, y1 - y0, z1 - z0]).translate([x0, y0, z0])


def _straight_axes(hid, x0, x1, y0, y1, z) -> HingeAxes:
    """A flat hinge across x (width), along y (length)."""
    mid = np.stack([np.linspace(x0, x1, 65), np.full(65, y0), np.full(65, z)], axis=1)
    return HingeAxes(hid, mid[0].copy(), np.array([0.0, 1.0, 0.0]), y1 - y0, mid)


def _part(profile, size=(4.0, 3.0, 0.8), panel=True) -> vr.VoxelPart:
    w, length, t = size
    regions = []
    if panel:
        regions.append(vr.VoxelRegion("panel", "p", "VeroWhite", _box(-2.0, 0.0, -0.5, 0.0, length, 0.5), vr.Uniform(1.0)))
    regions.append(vr.VoxelRegion("hinge", "h", "X", _box(0.0, 0.0, -t / 2, w, length, t / 2), profile,
                                  _straight_axes("h", 0.0, w, 0.0, length, 0.0)))
    return vr.VoxelPart("test", "permanent", tuple(regions), J750, np.array([0.0, 0.0, 0.5]))


def _stack(part, tmp_path: Path, name="t") -> tuple[list[bytes], dict]:
    files = vx.slice_files(part, name)
    paths = write_set(tmp_path, files)
    data = [p.read_bytes() for p in paths]
    return data[:-1], json.loads(data[-1])


# -- rasterising ---------------------------------------------------------------------------

@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(0.2, 9.8), st.floats(0.2, 4.8)), min_size=3, max_size=8),
       st.floats(0.1, 0.4))
def test_fill_matches_shapely(pts, hole_scale):
    """Scan-line fill of a polygon with a hole = shapely's point-in-polygon at the pixel centres."""
    poly = Polygon(pts).convex_hull
    if poly.geom_type != "Polygon" or poly.area < 0.5:
        return
    c = np.array(poly.centroid.coords[0])
    ring = np.array(poly.exterior.coords[:-1])
    hole = c + hole_scale * (ring - c)
    shape = Polygon(ring, [hole])
    px, py = 0.0423, 0.0846
    nx, ny = 240, 60
    mask = vx.fill([ring, hole[::-1]], 0.0, 0.0, px, py, nx, ny)
    xc = (np.arange(nx) + 0.5) * px
    yc = (np.arange(ny) + 0.5) * py
    X, Y = np.meshgrid(xc, yc)
    ref = contains_xy(shape, X, Y)
    # pixel centres exactly on an edge may go either way
    assert (mask != ref).sum() <= 0.002 * mask.size + 2


def test_png_round_trip_and_pillow_reads_it():
    rng = np.random.default_rng(1)
    labels = rng.integers(0, 3, size=(37, 53)).astype(np.uint8)
    data = vx.png_bytes(labels, J750)
    assert np.array_equal(vx.read_png(data), labels)
    from PIL import Image

    im = Image.open(io.BytesIO(data))
    rgba = np.array(im.convert("RGBA"))
    palette = np.array([rgba for _, rgba in vx.PALETTE], np.uint8)
    assert np.array_equal(rgba, palette[labels])
    assert im.info["dpi"][0] == pytest.approx(600, rel=1e-3) and im.info["dpi"][1] == pytest.approx(300, rel=1e-3)


def test_read_png_refuses_a_png_the_voxel_writer_did_not_write():
    """An 8-bit RGB PNG (Pillow's) is not read as labels: the error says what read_png reads."""
    from PIL import Image

    buf = io.BytesIO()
    Image.new("RGB", (5, 3), (255, 255, 255)).save(buf, format="PNG")
    with pytest.raises(ExportError, match="2-bit palette PNGs"):
        vx.read_png(buf.getvalue())
    with pytest.raises(ExportError, match="not a PNG"):
        vx.read_png(b"GIF89a" + bytes(10))


def test_blue_noise_is_a_permutation_of_ranks():
    b = vx.blue_noise()
    assert b.shape == (64, 64)
    assert np.array_equal(np.sort(b.ravel()), (np.arange(4096) + 0.5) / 4096)
    # blue noise: the 10 % darkest thresholds are spread out (no two 4-neighbours)
    low = b < 0.1
    assert not (low & np.roll(low, 1, 0)).any() and not (low & np.roll(low, 1, 1)).any()


# -- dithering accuracy, counted on the written slices -------------------------------------

def _block_errors(slices, manifest, part, region_index):
    """|measured - target| per 1 mm block of the hinge, recounted from the PNGs."""
    p = part.pitch
    grid = part.grid()
    r = part.regions[region_index]
    i0, i1, j0, j1, k0, k1 = vx._window(r, grid)
    white, total, target = {}, {}, {}
    bb = r.solid.bounding_box()
    for k, data in enumerate(slices):
        lab = vx.read_png(data)
        z = grid.layer_z(k)
        if not (bb[2] < z < bb[5]):
            continue
        jj, ii = np.nonzero(lab > 0)
        x = grid.origin[0] + (ii + 0.5) * p.x
        y = grid.origin[1] + (jj + 0.5) * p.y
        inside = (x > bb[0]) & (x < bb[3]) & (y > bb[1]) & (y < bb[4])
        ii, jj, x, y = ii[inside], jj[inside], x[inside], y[inside]
        pts = np.stack([x, y, np.full(len(x), z)], axis=1)
        f = r.fraction(pts)
        key = np.floor((pts - grid.origin) / 1.0).astype(int)
        for kk, w, ff in zip(map(tuple, key), lab[jj, ii] == vx.VERO, f):
            white[kk] = white.get(kk, 0) + int(w)
            total[kk] = total.get(kk, 0) + 1
            target[kk] = target.get(kk, 0.0) + ff
    full = (1 / p.x) * (1 / p.y) * (1 / p.z)
    return {k: abs(white[k] - target[k]) / total[k] for k in total if total[k] >= vs.BLOCK_MIN_FILL * full}


@pytest.mark.parametrize("profile", [Profile((0.42,)), Profile((0.137,)), Profile((0.3, 0.7), Along.WIDTH),
                                     Profile((0.9, 0.2, 0.6), Along.LENGTH)])
def test_every_mm3_of_a_hinge_within_1_percent(tmp_path, profile):
    part = _part(profile)
    slices, manifest = _stack(part, tmp_path)
    errs = _block_errors(slices, manifest, part, 1)
    assert len(errs) >= 8
    assert max(errs.values()) <= vs.FRACTION_TOL
    rec = next(r for r in manifest["regions"] if r["id"] == "h")
    assert rec["within_tolerance"] and rec["blocks_checked"] == len(errs)
    # the writer looks u up in a table of quarter-voxel cells; the recount uses the exact u
    assert rec["worst_block_error"] == pytest.approx(max(errs.values()), abs=2e-4)
    # the whole hinge (a box: its voxels sample u evenly): target = the profile's mean
    assert rec["target_fraction"] == pytest.approx(profile.mean, abs=0.005)
    assert rec["measured_fraction"] == pytest.approx(rec["target_fraction"], abs=0.002)


def test_graded_hinge_follows_its_profile_across_the_width(tmp_path):
    part = _part(Profile((0.1, 0.9), Along.WIDTH), panel=False)
    slices, _ = _stack(part, tmp_path)
    labs = np.stack([vx.read_png(s) for s in slices[3:-3]])
    filled = (labs > 0).sum(axis=(0, 1))
    cols = np.flatnonzero(filled)
    white = (labs == vx.VERO).sum(axis=(0, 1))[cols] / filled[cols]
    u = (part.grid().origin[0] + (cols + 0.5) * part.pitch.x) / 4.0
    chunks = np.array_split(np.arange(len(cols)), 8)  # 0.5 mm wide bands
    for ch in chunks:
        assert white[ch].mean() == pytest.approx(0.1 + 0.8 * u[ch].mean(), abs=0.02)


def test_slices_are_byte_identical_between_runs(tmp_path):
    part = _part(Profile((0.3, 0.7), Along.WIDTH))
    a, ma = _stack(part, tmp_path / "a")
    b, mb = _stack(_part(Profile((0.3, 0.7), Along.WIDTH)), tmp_path / "b")
    assert a == b and ma == mb
    assert len(a) == part.grid().shape[2] == ma["layers"]


def _tilted_part(profile) -> vr.VoxelPart:
    """A panel and a hinge whose cross-sections change from layer to layer (rotated about
    x and z), next to a flat prism hinge whose cross-section repeats."""
    import math as _m
    tilt = _box(0.0, 0.0, -0.3, 3.0, 2.0, 0.3).rotate([17.0, 0.0, 23.0])
    lo = tilt.bounding_box()
    d = np.array([-_m.sin(_m.radians(23.0)), _m.cos(_m.radians(23.0)), 0.0])
    mid = np.stack([np.linspace(lo[0], lo[3], 65), np.linspace(lo[1], lo[1], 65), np.zeros(65)], axis=1)
    axes = HingeAxes("t", mid[0].copy(), d, 2.0, mid)
    regions = (vr.VoxelRegion("panel", "p", "TangoBlack", _box(-2.0, -1.0, -0.5, -0.5, 2.0, 0.5), vr.Uniform(0.0)),
               vr.VoxelRegion("hinge", "t", "X", tilt, profile, axes),
               vr.VoxelRegion("hinge", "h", "Y", _box(3.5, 0.0, -0.4, 5.0, 2.0, 0.4), Profile((0.2, 0.6), Along.WIDTH),
                              _straight_axes("h", 3.5, 5.0, 0.0, 2.0, 0.0)))
    return vr.VoxelPart("test", "permanent", regions, J750, np.array([0.0, 0.0, 0.6]))


@pytest.mark.parametrize("profile", [Profile((0.3, 0.8), Along.WIDTH), Profile((0.7, 0.1), Along.LENGTH),
                                     Profile((0.42,))])
def test_slices_and_manifest_do_not_depend_on_the_worker_threads(tmp_path, profile):
    """Slices made ahead by 1, 2 or 3 threads: the same bytes, the same manifest."""
    out = []
    for workers in (1, 2, 3):
        files = vx.slice_files(_tilted_part(profile), "t", workers=workers)
        out.append([make() for _, make in files])
    assert out[0] == out[1] == out[2]


def test_the_writer_matches_a_layer_by_layer_reference():
    """Every layer filled, dithered and encoded on its own (no reused mask, thresholds
    gathered per voxel, fractions along the length from the axes): the writer's slices."""
    part = _tilted_part(Profile((0.7, 0.1), Along.LENGTH))
    grid, p = part.grid(), part.pitch
    nx, ny, nz = grid.shape
    slices = [make() for _, make in vx.slice_files(part, "t", workers=2)][:-1]
    for k in range(nz):
        labels = np.zeros((ny, nx), np.uint8)
        z = grid.layer_z(k)
        for r in part.regions:
            i0, i1, j0, j1, k0, k1 = vx._window(r, grid)
            polys = r.solid.slice(z).to_polygons() if k0 <= k < k1 else []
            if not polys:
                continue
            mask = vx.fill(polys, grid.origin[0] + i0 * p.x, grid.origin[1] + j0 * p.y, p.x, p.y, i1 - i0, j1 - j0)
            if r.kind == "panel":
                labels[j0:j1, i0:i1][mask] = vx.TANGO
                continue
            rows, cols = np.arange(j0, j1), np.arange(i0, i1)
            t = vx.layer_mask(k)[np.ix_(rows % vx.MASK_SIZE, cols % vx.MASK_SIZE)]
            if r.along_length:
                X, Y = np.meshgrid(grid.origin[0] + (cols + 0.5) * p.x, grid.origin[1] + (rows + 0.5) * p.y)
                ax = r.axes
                u = ((X - ax.origin[0]) * ax.direction[0] + (Y - ax.origin[1]) * ax.direction[1]
                     + (z - ax.origin[2]) * ax.direction[2]) / ax.length
                f = np.clip(r.profile.at(np.clip(u, 0.0, 1.0)), 0.0, 1.0)
            else:  # the width-graded prism: the writer's own table (tested below against width_u)
                table = vx._WidthTable(r, p)
                f = vx._fraction_window(r, table, grid.origin[0] + (cols + 0.5) * p.x,
                                        grid.origin[1] + (rows + 0.5) * p.y, z)
            white = t < f
            view = labels[j0:j1, i0:i1]
            view[mask & white] = vx.VERO
            view[mask & ~white] = vx.TANGO
        assert slices[k] == vx.png_bytes(labels, p), k


def test_width_table_cells_are_width_u_of_their_centres():
    """The lazily filled table holds, cell by cell, what width_u gives for the whole grid."""
    r = _tilted_part(Profile((0.3, 0.8), Along.WIDTH)).regions[1]
    t = vx._WidthTable(r, vr.Pitch(0.2, 0.2, 0.2))
    rng = np.random.default_rng(3)
    ia = rng.integers(0, t.n[0], (40, 1))
    ib = rng.integers(0, t.n[1], (1, 30))
    got = t.at(ia, ib)
    A, B = np.meshgrid(t.ca, t.cb, indexing="ij")
    whole = r.axes.width_u(t.origin + A.reshape(-1, 1) * t.basis[0] + B.reshape(-1, 1) * t.basis[1])
    assert np.array_equal(got, whole.reshape(t.n[0], t.n[1])[ia, ib])
    assert t.known.sum() == len(np.unique(ia.ravel()[:, None] * t.n[1] + ib.ravel()[None, :]))


@pytest.mark.parametrize("tilt_deg", [30.0, 90.0])
def test_width_fractions_of_a_fold_line_out_of_the_bed(tilt_deg):
    """A folded state's hinge: its fold line tilted out of the bed's plane (90 deg: vertical,
    as between two walls of a folded box). Its mid-line runs along x from 0 to W, so the
    width coordinate of any point is x / W (analytic); the writer's fraction at a window of
    pixel centres is the profile there, within its table's cell (h / 2 in the width)."""
    import math as _m
    w, length, t = 3.0, 2.0, 0.4
    a = _m.radians(tilt_deg)
    d = np.array([0.0, _m.cos(a), _m.sin(a)])
    mid = np.stack([np.linspace(0.0, w, 65), np.zeros(65), np.zeros(65)], axis=1)
    solid = _box(0.0, 0.0, -t / 2, w, length, t / 2).rotate([tilt_deg, 0.0, 0.0])
    profile = Profile((0.3, 0.8), Along.WIDTH)
    r = vr.VoxelRegion("hinge", "h", "X", solid, profile, HingeAxes("h", mid[0].copy(), d, length, mid))
    table = vx._WidthTable(r, J750)
    xs = np.linspace(0.05, w - 0.05, 41)
    ys = length / 2 * _m.cos(a) + np.linspace(-0.1, 0.1, 7)
    got = np.broadcast_to(vx._fraction_window(r, table, xs, ys, length / 2 * _m.sin(a)), (len(ys), len(xs)))
    want = np.clip(np.asarray(profile.at(xs / w), float), 0.0, 1.0)
    slope = abs(profile.at(1.0) - profile.at(0.0))
    assert np.abs(got - want[None, :]).max() <= slope * table.h / (2 * w) + 1e-12


def test_manifest_colour_map_and_dpi_are_what_the_slices_hold(tmp_path):
    """Read by Pillow: each pixel's RGBA is the colour-map entry of its index, the panel's
    pixels are the entry naming the panel's resin, empty pixels the 'empty' one, and the
    PNG's pHYs is the manifest's dpi."""
    from PIL import Image

    part = _part(Profile((0.5,)))
    slices, manifest = _stack(part, tmp_path)
    entry = {c["index"]: c for c in manifest["colour_map"]}
    data = slices[len(slices) // 2]
    im = Image.open(io.BytesIO(data))
    lab, rgba = vx.read_png(data), np.array(im.convert("RGBA"))
    for idx in np.unique(lab):
        assert (rgba[lab == idx] == entry[int(idx)]["rgba"]).all()
    p = part.pitch
    panel = lab[1:int(3.0 / p.y) - 1, 1:int(2.0 / p.x) - 1]
    assert {entry[int(i)]["material"] for i in np.unique(panel)} == {part.regions[0].material}
    assert entry[int(lab[-1, -1])]["material"] == "empty"  # beyond the 3 mm part
    assert (manifest["dpi"]["x"], manifest["dpi"]["y"]) == pytest.approx(im.info["dpi"], rel=1e-3)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 300), st.integers(1, 200), st.integers(0, 300), st.integers(1, 200), st.integers(0, 99))
def test_tiled_thresholds_are_the_gathered_ones(j0, h, i0, w, k):
    m = vx.layer_mask(k)
    want = m[np.ix_(np.arange(j0, j0 + h) % vx.MASK_SIZE, np.arange(i0, i0 + w) % vx.MASK_SIZE)]
    assert np.array_equal(vx.tiled(m, j0, j0 + h, i0, i0 + w), want)


@settings(max_examples=60, deadline=None)
@given(st.sampled_from([0.0, 0.6, -1.0]), st.sampled_from([0.0, 0.8, 0.3]), st.floats(-2.0, 2.0),
       st.integers(1, 40), st.integers(1, 40))
def test_separable_plane_is_the_whole_window_sum(ex, ey, ez, w, h):
    """(p - o) . e over a window, as a row or column when e has no y or no x part: bit for bit."""
    xs, ys = np.linspace(-1.3, 2.9, w), np.linspace(0.7, -3.1, h)
    o, e, z = np.array([0.3, -0.2, 0.05]), np.array([ex, ey, ez]), 0.4
    whole = (xs[None, :] - o[0]) * e[0] + (ys[:, None] - o[1]) * e[1] + (z - o[2]) * e[2]
    got = np.broadcast_to(vx._plane(xs, ys, z, o, e), (h, w))
    assert np.array_equal(got, whole)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 40), st.integers(1, 9), st.integers(0, 2**32 - 1))
def test_png_packing_is_the_shift_and_or_of_four_pixels(nx, ny, seed):
    import zlib
    lab = np.random.default_rng(seed).integers(0, 4, (ny, nx)).astype(np.uint8)
    q = np.pad(lab, ((0, 0), (0, (-nx) % 4))).reshape(ny, -1, 4)
    raw = np.zeros((ny, q.shape[1] + 1), np.uint8)
    raw[:, 1:] = (q[:, :, 0] << 6) | (q[:, :, 1] << 4) | (q[:, :, 2] << 2) | q[:, :, 3]
    data = vx.png_bytes(lab, J750)
    assert data[data.index(b"IDAT") + 4:-16] == zlib.compress(raw.tobytes(), vx.ZLIB_LEVEL)


def test_a_slice_failing_in_a_worker_thread_leaves_no_set(tmp_path):
    bad = vr.VoxelRegion("panel", "q", "VW0.5", _box(-4.0, 0.0, -0.5, -2.5, 3.0, 0.5), vr.Uniform(0.5))
    part = _part(Profile((0.5,)))
    part = vr.VoxelPart(part.design, part.state, part.regions + (bad,), part.pitch, part.print_offset)
    with pytest.raises(ExportError, match="panel 'q'.*not a base resin"):
        write_set(tmp_path / "out", vx.slice_files(part, "t", workers=2))
    assert not (tmp_path / "out").exists()


def test_panels_are_one_resin_and_empty_is_transparent(tmp_path):
    part = _part(Profile((0.5,)))
    slices, manifest = _stack(part, tmp_path)
    lab = vx.read_png(slices[len(slices) // 2])
    p = part.pitch
    panel_cols = int(2.0 / p.x)
    rows = int(3.0 / p.y)  # the last row's centres lie beyond the 3 mm part
    assert set(np.unique(lab[:rows, 1:panel_cols - 1])) == {vx.VERO}
    assert set(np.unique(lab[:rows, panel_cols + 1:])) == {vx.VERO, vx.TANGO}  # the dithered hinge
    assert (lab[rows:] == vx.EMPTY).all()
    top = vx.read_png(slices[-1])  # the 1.0 mm panel pokes out above the 0.8 mm hinge
    assert (top[:, panel_cols + 2:] == vx.EMPTY).all()
    assert manifest["colour_map"][0]["rgba"][3] == 0
    assert manifest["pitch_mm"] == {"x": p.x, "y": p.y, "z": p.z}
    assert manifest["size_px"]["x"] == part.grid().shape[0]


def test_streamed_callables_run_in_order_and_the_manifest_last():
    files = vx.slice_files(_part(Profile((0.5,))), "t")
    with pytest.raises(ExportError, match="in order"):
        files[1][1]()
    with pytest.raises(ExportError, match="after every slice"):
        files[-1][1]()


def test_a_failed_slice_leaves_no_set(tmp_path):
    files = vx.slice_files(_part(Profile((0.5,))), "t")

    def boom():
        raise ExportError("disk full")

    files.insert(3, ("t_boom.png", boom))
    with pytest.raises(ExportError):
        write_set(tmp_path / "out", files)
    assert not (tmp_path / "out").exists()


# -- guards -------------------------------------------------------------------------------

def test_guard_refuses_only_what_exceeds_the_limits():
    plate = vr.part_size([vr.VoxelRegion("panel", "p", "VeroWhite", _box(0, 0, 0, 150, 150, 20), vr.Uniform(1.0))],
                         J750)
    assert plate == (3544, 1772, 741)
    est = voxel_cost.check_voxels(plate)  # a 150 x 150 x 20 mm plate, the largest part we target, is accepted under the default limits
    try:  # refused just below its estimate, accepted just above
        guards.set_max_memory(int(est["bytes"] * 0.99))
        with pytest.raises(guards.ResourceError, match="voxel export refused.*memory limit"):
            voxel_cost.check_voxels(plate)
        guards.set_max_memory(int(est["bytes"] * 1.01))
        voxel_cost.check_voxels(plate)
    finally:
        guards.set_max_memory(None)
    with pytest.raises(guards.ResourceError, match="voxel export refused"):
        voxel_cost.check_voxels((400_000, 200_000, 10))


# -- geometry: hinge axes ------------------------------------------------------------------

@pytest.mark.parametrize("name", ["helix_graded", "mailbox"])
def test_hinge_axes_map_the_strip_to_its_flat_u(name):
    from foldprint import load_design
    from foldprint.io.templates import resolve_design_path

    d = load_design(resolve_design_path(name))
    for state in ("programmed", "permanent"):
        axes = hinge_axes(d, state)
        flat = hinge_axes(d, "programmed")
        pieces = {pc.owner: pc for pc in build_pieces(d, state) if pc.kind == "strip"}
        for hid, pc in pieces.items():
            v = np.asarray(pc.solid.to_mesh64().vert_properties)[:, :3]
            u = axes[hid].width_u(v)
            assert u.min() == pytest.approx(0.0, abs=1e-6) and u.max() == pytest.approx(1.0, abs=1e-6)
            assert ((axes[hid].length_u(v) >= 0) & (axes[hid].length_u(v) <= 1)).all()
        if state == "programmed":  # flat: u is the distance from the parent's edge / w
            for h in d.hinges:
                a = flat[h.id]
                p = a.mid[0] + 0.37 * (a.mid[-1] - a.mid[0])
                assert a.width_u(p[None])[0] == pytest.approx(0.37, abs=1e-9)


# -- the composite 3MF and the pipeline ------------------------------------------------------

def _helix_voxel_part(profiles):
    from foldprint import load_design
    from foldprint.apps import pipeline
    from foldprint.io.templates import resolve_design_path

    d = load_design(resolve_design_path("helix_graded"))
    asm = pipeline.build(d)
    return d, asm, pipeline.voxel_part(d, asm, profiles=profiles, pitch=vr.Pitch(0.2, 0.2, 0.2))


def _profiles(lib, material):
    if material == "H-3":
        return Profile((0.3, 0.7), Along.WIDTH)
    return Profile((0.1 * int(material[2:]),))


def test_composite_3mf_reads_in_lib3mf_strict_mode(tmp_path):
    lib3mf = pytest.importorskip("lib3mf")
    d, asm, part = _helix_voxel_part(_profiles)
    recs = export_assembly(d, asm, tmp_path, ["voxels"], voxels=part)
    path = next(r["path"] for r in recs if r["format"] == "3mf-composite")
    w = lib3mf.get_wrapper()
    model = w.CreateModel()
    reader = model.QueryReader("3mf")
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(path)
    assert reader.GetWarningCount() == 0
    it = model.GetCompositeMaterials()
    counts = []
    while it.MoveNext():
        cm = it.GetCurrentCompositeMaterials()
        ids = cm.GetAllPropertyIDs()
        fr = [cm.GetComposite(i)[0].MixingRatio for i in ids]
        counts.append((len(ids), min(fr), max(fr)))
    hinges = [r for r in part.regions if r.kind == "hinge"]
    assert len(counts) == len(hinges)
    graded = [c for c in counts if c[0] > 1]
    assert graded and all(0.3 - 1e-9 <= c[1] and c[2] <= 0.7 + 1e-9 for c in graded)
    meshes = model.GetMeshObjects()
    n = 0
    while meshes.MoveNext():
        assert meshes.GetCurrentMeshObject().IsManifoldAndOriented()
        n += 1
    assert n == len(part.regions)
    # the base resins are shown in the colours of the library the part is written with
    import dataclasses

    from foldprint.exchange.threemf import composite3mf_bytes
    from foldprint.model.materials import MaterialLibrary, default_library

    base = default_library()
    assert base["VeroWhite"].color.lower()[:7] != "#123456"
    lib = MaterialLibrary(tuple(dataclasses.replace(m, color="#123456") if m.name == "VeroWhite" else m
                                for m in base.materials))
    other = w.CreateModel()
    other.QueryReader("3mf").ReadFromBuffer(list(composite3mf_bytes(d, asm, part, lib)))
    groups = other.GetBaseMaterialGroups()
    assert groups.MoveNext()
    bm = groups.GetCurrentBaseMaterialGroup()
    shown = {}
    for i in bm.GetAllPropertyIDs():
        c = bm.GetDisplayColor(i)
        shown[bm.GetName(i)] = f"#{c.Red:02x}{c.Green:02x}{c.Blue:02x}"
    assert shown == {"VeroWhite": "#123456", "TangoBlack": base["TangoBlack"].color.lower()[:7]}


@pytest.mark.skipif(shutil.which("prusa-slicer") is None, reason="prusa-slicer not on PATH")
def test_prusa_slicer_opens_the_composite_3mf(tmp_path):
    d, asm, part = _helix_voxel_part(_profiles)
    recs = export_assembly(d, asm, tmp_path, ["voxels"], voxels=part)
    path = next(r["path"] for r in recs if r["format"] == "3mf-composite")
    out = subprocess.run(["prusa-slicer", "--info", path], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0
    assert out.stdout.count("manifold = yes") == len(part.regions)
    vols = [float(line.split("=")[1]) for line in out.stdout.splitlines() if line.startswith("volume =")]
    assert sum(vols) == pytest.approx(asm.volume, rel=1e-6)


def test_cli_export_voxels_of_the_flat_helix(tmp_path):
    """The whole path: CLI -> pipeline (fractions from the composition model) -> writer."""
    from foldprint import load_design
    from foldprint.io.templates import resolve_design_path
    from foldprint.model.composition_library import fraction_profile
    from foldprint.model.materials import default_library

    out = subprocess.run(["foldprint", "export", "helix_graded", "--state", "programmed", "--format", "voxels",
                          "--out", str(tmp_path), "--json"], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    rec = json.loads(out.stdout)
    fmts = [f["format"] for f in rec["files"]]
    assert fmts.count("voxels") == 1 and fmts.count("3mf-composite") == 1
    manifest = json.loads((tmp_path / "helix_graded_programmed_voxels.json").read_text())
    assert fmts.count("png") == manifest["layers"] == len(manifest["files"])
    lib = default_library()
    d = load_design(resolve_design_path("helix_graded"))
    material = {h.id: h.material for h in d.hinges}
    hinges = [r for r in manifest["regions"] if r["kind"] == "hinge"]
    assert len(hinges) == len(d.hinges)
    for r in hinges:
        prof = fraction_profile(lib, material[r["id"]])
        assert r["profile"]["knots"] == [round(k, 6) for k in prof.knots]
        assert r["target_fraction"] == pytest.approx(prof.mean, abs=1e-6)
        assert r["within_tolerance"] and r["blocks_checked"] > 0
        assert abs(r["measured_fraction"] - r["target_fraction"]) < 0.002


def test_cli_refuses_a_printer_without_a_pitch(tmp_path):
    out = subprocess.run(["foldprint", "export", "helix_graded", "--format", "voxels", "--printer", "connex260",
                          "--out", str(tmp_path / "x")], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "j750" in out.stderr and "Traceback" not in out.stderr
    assert not (tmp_path / "x").exists()


def test_width_u_is_the_nearest_point_of_the_mid_line():
    """Against a brute-force reference: every chord of the mid-line, every point."""
    from foldprint import load_design
    from foldprint.io.templates import resolve_design_path

    d = load_design(resolve_design_path("helix_graded"))
    a = hinge_axes(d, "permanent")[d.hinges[0].id]
    rng = np.random.default_rng(3)
    k = rng.integers(0, len(a.mid) - 1, 5000)
    t = rng.random(5000)
    p = a.mid[k] + t[:, None] * (a.mid[k + 1] - a.mid[k]) + rng.normal(0.0, 0.3, (5000, 3))
    d3 = a.direction
    q = p - a.origin - np.outer((p - a.origin) @ d3, d3)
    m = a.mid - a.origin - np.outer((a.mid - a.origin) @ d3, d3)
    seg_a, seg_ab = m[:-1], m[1:] - m[:-1]
    tt = np.clip(np.einsum("nkj,kj->nk", q[:, None] - seg_a[None], seg_ab) / (seg_ab ** 2).sum(1), 0, 1)
    dist = ((q[:, None] - seg_a[None] - tt[..., None] * seg_ab[None]) ** 2).sum(-1)
    best = np.argmin(dist, axis=1)
    ref = (best + tt[np.arange(5000), best]) / (len(m) - 1)
    assert np.allclose(a.width_u(p), ref, atol=1e-9)


def test_graded_vw_materials_through_the_pipeline(tmp_path):
    """Hinges named by graded composition materials (comp's canonical names): the stack
    follows each profile across the width or along the length, every checked mm^3 within 1 %."""
    import dataclasses

    from foldprint import load_design
    from foldprint.apps import pipeline
    from foldprint.io.templates import resolve_design_path

    d = load_design(resolve_design_path("helix_graded"))
    names = ["VW0.600-0.900@width", "VW0.900-0.600@length", "VW0.750"]
    hinges = tuple(dataclasses.replace(h, material=names[k % 3]) for k, h in enumerate(d.hinges[:3]))
    d = dataclasses.replace(d, hinges=hinges + tuple(d.hinges[3:]))
    recs = pipeline.export(d, tmp_path, "programmed", ["voxels"])
    manifest = json.loads(Path(next(r["path"] for r in recs if r["format"] == "voxels")).read_text())
    by_id = {r["id"]: r for r in manifest["regions"]}
    for k, h in enumerate(hinges):
        r = by_id[h.id]
        assert r["material"] == names[k % 3] and r["within_tolerance"] and r["blocks_checked"] > 0
        assert r["target_fraction"] == pytest.approx(0.75, abs=0.01)  # every profile's mean is 0.75
        assert r["measured_fraction"] == pytest.approx(r["target_fraction"], abs=0.002)
    assert by_id[hinges[0].id]["profile"] == {"knots": [0.6, 0.9], "along": "width"}
    assert by_id[hinges[1].id]["profile"] == {"knots": [0.9, 0.6], "along": "length"}


def test_composite_3mf_mixes_each_hinge_as_its_profile_says(tmp_path):
    """Read back through lib3mf, per hinge and per vertex: the share of the base material
    NAMED VeroWhite is the hinge's VeroWhite fraction (uniform grades 0.1 n, the graded
    hinge the profile at that vertex), TangoBlack the rest: swapping the two fails."""
    lib3mf = pytest.importorskip("lib3mf")
    d, asm, part = _helix_voxel_part(_profiles)
    recs = export_assembly(d, asm, tmp_path, ["voxels"], voxels=part)
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromFile(next(r["path"] for r in recs if r["format"] == "3mf-composite"))
    regions = {f"{r.kind} {r.id} ({r.material})": r for r in part.regions}
    meshes, seen = model.GetMeshObjects(), 0
    while meshes.MoveNext():
        obj = meshes.GetCurrentMeshObject()
        r = regions[obj.GetName()]
        if r.kind != "hinge":
            continue
        res_id, prop0, _ = obj.GetObjectLevelProperty()
        comp = model.GetCompositeMaterialsByID(res_id)
        base = comp.GetBaseMaterialGroup()
        vw_share = {}
        for prop in comp.GetAllPropertyIDs():
            parts = {base.GetName(c.PropertyID): c.MixingRatio for c in comp.GetComposite(prop)}
            assert set(parts) == {"VeroWhite", "TangoBlack"}
            assert parts["VeroWhite"] + parts["TangoBlack"] == pytest.approx(1.0, abs=1e-9)
            vw_share[prop] = parts["VeroWhite"]
        if r.constant is not None:  # one composite for the hinge, on the object
            assert r.constant == pytest.approx(0.1 * int(r.material[2:]))
            assert list(vw_share) == [prop0] and vw_share[prop0] == pytest.approx(r.constant, abs=1e-9)
        else:  # graded: every triangle corner names the composite of its vertex's fraction
            verts = np.array([[v.Coordinates[k] for k in range(3)] for v in obj.GetVertices()])
            expected = r.fraction(verts)
            assert np.ptp(expected) > 0.3  # the profile really varies over the hinge
            for tri, props in zip(obj.GetTriangleIndices(), obj.GetAllTriangleProperties()):
                assert props.ResourceID == res_id
                for corner in range(3):
                    got = vw_share[props.PropertyIDs[corner]]
                    assert got == pytest.approx(expected[tri.Indices[corner]], abs=1e-3)
        seen += 1
    assert seen == len(d.hinges)


class _TwoLevels:
    """A hinge profile with exactly two VeroWhite fractions: 0.4 on one half of the width, 0.6 on the other."""

    along = None
    knots = (0.4, 0.6)

    def at(self, u):
        return np.where(np.asarray(u) < 0.5, 0.4, 0.6)


def _model_tree(xml: str):
    import xml.etree.ElementTree as ET

    return ET.fromstring(xml.encode("utf-8"))


def test_composite_model_gives_each_region_its_materials():
    """The voxel variant's model, read as XML: the all-VeroWhite panel takes base material 0
    (VeroWhite), a hinge with exactly two fractions gets two composites and per-vertex
    properties (so its two halves differ), and no element carries stray text (the 3MF
    schema's mesh elements have no mixed content)."""
    from foldprint.exchange.threemf import composite_model_xml
    from foldprint.geometry import build_assembly
    from foldprint.model.design import strip

    d = strip("s", [20.0, 20.0], [90.0], ["H-3"])
    root = _model_tree(composite_model_xml(d, build_assembly(d, "permanent"), _part(_TwoLevels())))
    ns = {"c": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02",
          "m": "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"}
    objs = {o.get("name"): o for o in root.iter(f"{{{ns['c']}}}object")}
    panel = next(o for n, o in objs.items() if n.startswith("panel"))
    hinge = next(o for n, o in objs.items() if n.startswith("hinge"))
    assert (panel.get("pid"), panel.get("pindex")) == ("1", "0")  # base material 0: VeroWhite
    (group,) = [g for g in root.iter(f"{{{ns['m']}}}compositematerials") if g.get("id") == hinge.get("pid")]
    assert [c.get("values") for c in group] == ["0.4 0.6", "0.6 0.4"]
    tris = list(hinge.iter(f"{{{ns['c']}}}triangle"))
    assert tris and all(t.get("p1") is not None for t in tris)
    assert {t.get(k) for t in tris for k in ("p1", "p2", "p3")} == {"0", "1"}  # both halves
    for el in root.iter():
        if not el.tag.endswith("metadata"):
            assert not (el.text or "").strip() and not (el.tail or "").strip(), el.tag
