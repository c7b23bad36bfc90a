"""Hand-offs downstream: PrusaSlicer prints every body at its height, the export JSON's
per-body records, FOLD from the command line, Abaqus input, XDMF series, animated glTF.

Real clients: PrusaSlicer (``--export-gcode``), meshio's readers, trimesh, the FOLD
reader and ``foldprint simulate``."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from foldprint.geometry import bed_report, build_assembly
from foldprint.load import load_design
from foldprint.pipeline import export as export_design

ROOT = Path(__file__).resolve().parent.parent
TEMPLATES = sorted((ROOT / "templates").glob("*.toml"))
IDS = [p.stem for p in TEMPLATES]
PRUSA = shutil.which("prusa-slicer")
needs_prusa = pytest.mark.skipif(PRUSA is None, reason="prusa-slicer is not on PATH")
#: lean slicing: thick layers, one perimeter, no infill, no solid layers, no skirt
LAYER_MM = 0.3


@lru_cache(maxsize=None)
def _design(stem: str):
    return load_design(str(ROOT / "templates" / f"{stem}.toml"))


def _cli(*args, cwd=None):
    env = {"PYTHONPATH": str(ROOT)}
    import os

    env = {**os.environ, **env}
    return subprocess.run([sys.executable, "-m", "foldprint", *args], capture_output=True, text=True,
                          env=env, cwd=cwd, timeout=300)


# -- PrusaSlicer: each tool's first extrusion at its body's height --------------------------

def first_extrusion_z(gcode: str) -> dict[int, float]:
    """Per tool (0-based), the Z of the first layer in which it extrudes (relative E)."""
    tool, z, first = 0, None, {}
    for line in gcode.splitlines():
        if re.match(r"^T\d+\s*$", line):
            tool = int(line[1:])
        elif line.startswith(";Z:"):
            z = float(line[3:])
        elif line.startswith("G1 ") and ("X" in line or "Y" in line) and z is not None:
            m = re.search(r"\bE(-?[\d.]+)", line)
            if m and float(m.group(1)) > 0 and tool not in first:
                first[tool] = z
    return first


@needs_prusa
@pytest.mark.parametrize("state", ["permanent", "programmed"])
@pytest.mark.parametrize("stem", IDS)
def test_prusaslicer_prints_every_body_at_its_height(tmp_path, stem, state):
    design = _design(stem)
    (rec,) = export_design(design, tmp_path, state, ["prusa3mf"])
    n = len(rec["bodies"])
    gcode = tmp_path / "part.gcode"
    lo = -400
    cmd = [PRUSA, "--export-gcode", "--nozzle-diameter", ",".join(["0.4"] * n),
           "--layer-height", str(LAYER_MM), "--first-layer-height", str(LAYER_MM),
           "--perimeters", "1", "--fill-density", "0%", "--top-solid-layers", "0",
           "--bottom-solid-layers", "0", "--skirts", "0", "--use-relative-e-distances",
           "--bed-shape", f"{lo}x{lo},{-lo}x{lo},{-lo}x{-lo},{lo}x{-lo}", "--max-print-height", "400",
           "--dont-arrange", "--output", str(gcode), rec["path"]]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    first = first_extrusion_z(gcode.read_text())
    assert sorted(first) == list(range(n)), first
    for b in rec["bodies"]:
        z_low = b["z_range_mm"][0]
        z = first[b["extruder"] - 1]
        # the first layer that prints the body is sliced at its mid-height: that plane is
        # at or above the body's lowest point, and less than one layer above it
        plane = z - LAYER_MM / 2
        assert z_low - 1e-6 <= plane <= z_low + LAYER_MM + 1e-6, (b["material"], z_low, z)


def test_first_extrusion_parser():
    g = "T1\n;Z:0.3\nG1 X1 Y1 E0.5\nT0\nG1 E-0.8\n;Z:0.6\nG1 X2 Y2 F300\nG1 X3 Y3 E0.2\n"
    assert first_extrusion_z(g) == {1: 0.3, 0: 0.6}


# -- the export's per-body records ---------------------------------------------------------

def test_export_json_lists_every_body(tmp_path):
    res = _cli("export", "mailbox", "--state", "programmed", "--format", "3mf,prusa3mf,stl,fold",
               "--out", str(tmp_path), "--json")
    assert res.returncode == 0, res.stderr
    doc = json.loads(res.stdout)
    design = _design("mailbox")
    asm = build_assembly(design, "programmed")
    names = {Path(r["path"]).name for r in doc["files"]}
    (prusa,) = [r for r in doc["files"] if r["format"] == "prusa3mf"]
    assert [b["material"] for b in prusa["bodies"]] == asm.materials
    assert [b["extruder"] for b in prusa["bodies"]] == list(range(1, len(asm.bodies) + 1))
    for b, body in zip(prusa["bodies"], asm.bodies):
        assert set(b) == {"material", "extruder", "files", "volume_mm3", "z_range_mm", "needs_support"}
        assert set(b["files"]) <= names
        assert {"mailbox_programmed.3mf", "mailbox_programmed_prusa.3mf", "mailbox.fold",
                f"mailbox_programmed_{body.material}.stl"} == set(b["files"])
        assert b["volume_mm3"] == pytest.approx(body.volume, rel=1e-6)
        lo, hi = body.bounds[:, 2] - asm.bounds[0][2]
        assert b["z_range_mm"] == pytest.approx([lo, hi], abs=1e-6)
    # the whole part on the bed
    assert min(b["z_range_mm"][0] for b in prusa["bodies"]) == 0.0
    for r in doc["files"]:
        if r["format"] == "stl":
            assert len(r["bodies"]) == 1 and Path(r["path"]).name in r["bodies"][0]["files"]


# -- on the bed --------------------------------------------------------------------------------

def test_bed_report_flat_mailbox_panels_float_by_half_the_thickness_difference():
    design = _design("mailbox")
    asm = build_assembly(design, "programmed")
    rep = {(r["kind"], r["id"]): r for r in bed_report(asm)}
    t_hinge = max(h.thickness for h in design.hinges)
    for p in design.panels:
        r = rep[("panel", p.id)]
        gap = (t_hinge - p.thickness) / 2
        assert r["z_min_mm"] == pytest.approx(gap, abs=1e-9)
        assert not r["on_bed"] and r["needs_support"]
        # the whole underside floats: its area is the panel's rigid part (outline less strips)
        assert 0 < r["unsupported_area_mm2"] <= p.area + 1e-6
    for h in design.hinges:  # the thick steps stand on the bed, the thin ones float
        r = rep[("hinge", h.id)]
        assert r["on_bed"] and r["needs_support"]


def test_bed_report_equal_thickness_flat_strip_needs_no_support():
    design = _design("helix_graded")  # panels and hinges 0.8 mm (paper)
    rep = bed_report(build_assembly(design, "programmed"))
    assert all(r["on_bed"] and not r["needs_support"] for r in rep)


# -- FOLD from the command line ------------------------------------------------------------

@pytest.mark.parametrize("stem", ["helix_graded", "self_lock"])
def test_fold_from_cli_round_trips_through_simulate(tmp_path, stem):
    res = _cli("export", stem, "--format", "fold", "--out", str(tmp_path), "--json")
    assert res.returncode == 0, res.stderr
    (rec,) = json.loads(res.stdout)["files"]
    assert rec["format"] == "fold" and Path(rec["path"]).name == f"{stem}.fold"
    fold = json.loads(Path(rec["path"]).read_text())
    for key in ("file_spec", "vertices_coords", "faces_vertices", "edges_vertices", "edges_assignment"):
        assert key in fold
    nv = len(fold["vertices_coords"])
    assert all(0 <= v < nv for f in fold["faces_vertices"] for v in f)
    assert len(fold["edges_assignment"]) == len(fold["edges_vertices"])
    design = _design(stem)
    if any(p.holes for p in design.panels):  # holes are FOLD geometry: no face keeps one
        assert not any(fold["faces_foldprint:holes"])
        assert "F" in fold["edges_assignment"]
    a = _cli("simulate", stem, "--json")
    b = _cli("simulate", rec["path"], "--json")
    assert a.returncode == b.returncode == 0, a.stderr + b.stderr
    assert json.loads(a.stdout) == json.loads(b.stdout)
