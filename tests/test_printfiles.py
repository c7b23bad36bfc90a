"""Print files that print as designed: the slicer 3MFs carry a printer configuration with one
tool per material, printer profiles state their tools (check FP103/FP104, export --printer
refuses), and every export writes its recipe.

Real client: PrusaSlicer (``--export-gcode`` with NO options: the tools come from the
3MF). OrcaSlicer cannot be installed here (no Debian package, no PyPI package, AppImage
and Flatpak downloads are outside the package registries): its reader is replayed from its
source (``bbs_3mf.cpp``: the part extruders it keeps, the filament count it reads).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.checks.rules import CheckContext, rule_tools
from foldprint.core.display import seconds
from foldprint.cli.commands import main
from foldprint.core.errors import DesignError, ExportError
from foldprint.exchange.slicer_config import bed_layout
from foldprint.geometry import build_assembly
from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.model.printers import DIGITAL_SMP_RESINS, fdm_setup, load_printers, tool_fit
from foldprint.physics.recovery.curve import hinge_fold_times

PRUSA = shutil.which("prusa-slicer")
needs_prusa = pytest.mark.skipif(PRUSA is None, reason="prusa-slicer is not on PATH (install PrusaSlicer "
                                 "to run the real-client checks)")
NS = {"m": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"}
TEMPLATES = sorted((Path(__file__).resolve().parent.parent / "templates").glob("*.toml"))
#: G-code extrusion that is not a body: the wipe tower, the skirt, the start G-code's purge line
NOT_A_BODY = ("Wipe tower", "Skirt/Brim", "Custom")


def _design(stem):
    return load_design(resolve_design_path(stem))


def _export(design, out, formats=("3mf", "prusa3mf", "stl"), printer=None, ev=None):
    ev = ev or Evaluation(design)
    return {r["format"]: r for r in ev.export(out, formats=formats, printer=printer)}


def _zip(path, name) -> str:
    with zipfile.ZipFile(path) as zf:
        return zf.read(name).decode()


def _prusa_config(text: str) -> dict[str, str]:
    """What PrusaSlicer's legacy reader takes from Slic3r_PE.config: '; key = value' lines
    read from the end upwards, never the first line, stopping at a line that is not one."""
    lines = text.splitlines()
    out = {}
    for line in reversed(lines[1:]):
        m = re.match(r"^; ([a-z0-9_]+) = (.*)$", line)
        if len(line) < 10 or m is None:
            break
        out[m.group(1)] = m.group(2)
    assert len(out) == len(lines) - 1, "a line the reader would stop at"
    return out


def _strings(value: str) -> list[str]:
    """A PrusaSlicer list of strings ('"a";"b"' or 'a;b') as Python strings."""
    return [v[1:-1] if v.startswith('"') else v for v in value.split(";")]


def tool_regions(gcode: str) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per tool (0-based), the xy bounding box of its extrusion into the part (not the wipe
    tower, skirt or purge line): relative E, as the 3MF asks."""
    tool, kind, x, y, pts = 0, "", None, None, {}
    for line in gcode.splitlines():
        if re.match(r"^T\d+\s*$", line):
            tool = int(line[1:])
        elif line.startswith(";TYPE:"):
            kind = line[6:].strip()
        elif line.startswith("G1 "):
            mx, my = re.search(r"\bX(-?[\d.]+)", line), re.search(r"\bY(-?[\d.]+)", line)
            me = re.search(r"\bE(-?[\d.]+)", line)
            nx = float(mx.group(1)) if mx else x
            ny = float(my.group(1)) if my else y
            if me and float(me.group(1)) > 0 and (mx or my) and x is not None and kind not in NOT_A_BODY:
                pts.setdefault(tool, []).extend([(x, y), (nx, ny)])
            x, y = nx, ny
    return {t: (np.min(p, axis=0), np.max(p, axis=0)) for t, p in pts.items()}


def test_tool_regions_parser():
    g = ("T1\n;TYPE:Perimeter\nG1 X1 Y1\nG1 X2 Y3 E0.5\n;TYPE:Wipe tower\nG1 X90 Y90 E1\nT0\n"
         ";TYPE:Perimeter\nG1 X5 Y5 E-0.8\nG1 X6 Y4 E0.2\n")
    r = tool_regions(g)
    assert sorted(r) == [0, 1]
    assert r[1][0].tolist() == [1, 1] and r[1][1].tolist() == [2, 3]  # not the tower
    assert r[0][0].tolist() == [5, 4] and r[0][1].tolist() == [6, 5]  # not the retraction


# -- PrusaSlicer, no options ------------------------------------------------------------------

def _slice(path: Path, out: Path, *args) -> str:
    res = subprocess.run([PRUSA, "--export-gcode", *args, "--output", str(out), str(path)],
                         capture_output=True, text=True, timeout=240)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    return out.read_text()


@needs_prusa
def test_prusaslicer_with_no_options_prints_each_body_with_its_tool(tmp_path):
    """helix_graded (eight materials) sliced with no options: tools T0..T7, each extruding
    inside its own body's footprint (the slicer arranges the part: one shift for all)."""
    design = _design("helix_graded")
    rec = _export(design, tmp_path / "out", ("prusa3mf",))["prusa3mf"]
    asm = build_assembly(design, "permanent")
    gcode = _slice(Path(rec["path"]), tmp_path / "p.gcode")
    n = len(asm.bodies)
    assert set(re.findall(r"^T(\d+)\s*$", gcode, flags=re.M)) == {str(k) for k in range(n)}
    regions = tool_regions(gcode)
    assert sorted(regions) == list(range(n))
    lo = np.array([b.vertices[:, :2].min(0) for b in asm.bodies])
    hi = np.array([b.vertices[:, :2].max(0) for b in asm.bodies])
    got_lo = np.array([regions[k][0] for k in range(n)])
    got_hi = np.array([regions[k][1] for k in range(n)])
    shift = got_lo.min(0) - lo.min(0)
    for b, rec_body in zip(asm.bodies, rec["bodies"]):
        k = rec_body["extruder"] - 1
        assert rec_body["material"] == b.material
        # each tool fills its body: its extrusion box is the body's box, less at most a line
        # width at the walls (the perimeters' centre lines)
        assert np.all(got_lo[k] >= lo[k] + shift - 0.05) and np.all(got_hi[k] <= hi[k] + shift + 0.05), b.material
        assert np.all(got_lo[k] <= lo[k] + shift + 0.5) and np.all(got_hi[k] >= hi[k] + shift - 0.5), b.material
    # PrusaSlicer echoes the configuration it sliced with: ours, read from the 3MF
    ours = _prusa_config(_zip(rec["path"], "Metadata/Slic3r_PE.config"))
    echoed = dict(re.findall(r"^; ([a-z0-9_]+) = (.*)$", gcode, flags=re.M))
    for key, value in ours.items():
        if key.endswith("_colour") or key == "filament_settings_id":
            assert _strings(echoed[key]) == _strings(value), key
        else:
            assert echoed[key] == value, key


@needs_prusa
def test_prusaslicer_reads_an_fdm_printer_profile(tmp_path):
    """Exported for the MK4 + MMU3 (one nozzle, five filaments): PrusaSlicer slices it with
    that bed and as a single-nozzle multi-material printer, one tool per material."""
    design = _design("self_lock")  # four materials
    pr = load_printers()["prusa_mk4_mmu3"]
    rec = _export(design, tmp_path / "out", ("prusa3mf",), printer="prusa_mk4_mmu3")["prusa3mf"]
    cfg = _prusa_config(_zip(rec["path"], "Metadata/Slic3r_PE.config"))
    gcode = _slice(Path(rec["path"]), tmp_path / "p.gcode")
    echoed = dict(re.findall(r"^; ([a-z0-9_]+) = (.*)$", gcode, flags=re.M))
    w, d, h = pr.build_mm
    assert echoed["bed_shape"] == cfg["bed_shape"] == f"0x0,{w:g}x0,{w:g}x{d:g},0x{d:g}"
    assert echoed["max_print_height"] == f"{h:g}"
    assert echoed["single_extruder_multi_material"] == "1"
    assert set(re.findall(r"^T(\d+)\s*$", gcode, flags=re.M)) == {"0", "1", "2", "3"}


# -- the configurations as the slicers read them ----------------------------------------------

@pytest.mark.parametrize("stem", ["helix_graded", "mailbox", "helix_uniform"])
def test_prusa_config_has_one_extruder_per_body(tmp_path, stem):
    design = _design(stem)
    lib = default_library()
    rec = _export(design, tmp_path, ("prusa3mf",))["prusa3mf"]
    cfg = _prusa_config(_zip(rec["path"], "Metadata/Slic3r_PE.config"))
    n = len(rec["bodies"])
    for key in ("nozzle_diameter", "filament_diameter", "extruder_offset"):
        assert len(cfg[key].split(",")) == n, key
    colours = ["#" + lib[b["material"]].color.lstrip("#").upper() for b in rec["bodies"]]
    assert _strings(cfg["extruder_colour"]) == _strings(cfg["filament_colour"]) == colours
    assert _strings(cfg["filament_settings_id"]) == [b["material"] for b in rec["bodies"]]
    # the wipe tower's purge matrix is n x n with a zero diagonal (PrusaSlicer does not resize it)
    m = np.array([float(v) for v in cfg["wiping_volumes_matrix"].split(",")]).reshape(n, n)
    assert np.all(np.diag(m) == 0) and np.all(m + np.eye(n) > 0)
    assert len(cfg["wiping_volumes_extruders"].split(",")) == 2 * n
    assert cfg["wipe_tower"] == ("1" if n > 1 else "0") and cfg["use_relative_e_distances"] == "1"
    # each volume's extruder (Slic3r_PE_model.config) is one of the configured extruders, once
    model = ET.fromstring(_zip(rec["path"], "Metadata/Slic3r_PE_model.config"))
    ext = [int(v.find("metadata[@key='extruder']").get("value")) for v in model.iter("volume")]
    assert ext == list(range(1, n + 1))


def orca_reads(path) -> dict:
    """What OrcaSlicer's 3MF reader makes of the file (bbs_3mf.cpp, _load_model_from_file):
    it loads Metadata/project_settings.config from any producer (its version check is
    skipped), takes each part's extruder from Metadata/model_settings.config, and resets an
    extruder beyond the number of filament_settings_id (or 0) to 1."""
    settings = json.loads(_zip(path, "Metadata/project_settings.config"))
    for key, value in settings.items():  # ConfigBase::load_from_json: strings and lists of strings
        assert isinstance(value, str) or (isinstance(value, list) and all(isinstance(v, str) for v in value)), key
    n_fil = len(settings["filament_settings_id"])
    model = ET.fromstring(_zip(path, "3D/3dmodel.model"))
    (asm,) = [o for o in model.findall("m:resources/m:object", NS) if o.find("m:components", NS) is not None]
    components = [c.get("objectid") for c in asm.findall("m:components/m:component", NS)]
    parts = ET.fromstring(_zip(path, "Metadata/model_settings.config")).find("object").findall("part")
    assert [p.get("id") for p in parts] == components  # a part is found by its component's object id
    extruders = []
    for p in parts:
        e = int(p.find("metadata[@key='extruder']").get("value"))
        extruders.append(1 if e == 0 or e > n_fil else e)
    return {"settings": settings, "extruders": extruders,
            "names": [p.find("metadata[@key='name']").get("value") for p in parts]}


@pytest.mark.parametrize("stem,printer", [("helix_graded", None), ("self_lock", "bambu_x1c"),
                                          ("mailbox", "prusa_xl")])
def test_orca_keeps_one_filament_per_part(tmp_path, stem, printer):
    design = _design(stem)
    lib = default_library()
    rec = _export(design, tmp_path, ("3mf",), printer=printer)["3mf"]
    got = orca_reads(rec["path"])
    s, n = got["settings"], len(rec["bodies"])
    assert got["extruders"] == list(range(1, n + 1))  # none reset to filament 1
    assert got["names"] == s["filament_settings_id"] == [b["material"] for b in rec["bodies"]]
    assert s["filament_colour"] == ["#" + lib[m].color.lstrip("#").upper() for m in got["names"]]
    assert len(s["filament_diameter"]) == n and len(s["flush_volumes_matrix"]) == n * n
    assert len(s["flush_volumes_vector"]) == 2 * n
    pr = load_printers().get(printer)
    setup = fdm_setup(pr)
    w, d, h = setup.build_mm
    assert s["printable_area"] == ["0x0", f"{w:g}x0", f"{w:g}x{d:g}", f"0x{d:g}"]
    assert s["printable_height"] == f"{h:g}"
    single = pr is not None and pr.single_nozzle
    assert len(s["nozzle_diameter"]) == (1 if single else n)
    assert s["single_extruder_multi_material"] == ("1" if single else "0")
    assert s["enable_prime_tower"] == "1"


@pytest.mark.parametrize("path", TEMPLATES, ids=[p.stem for p in TEMPLATES])
def test_the_part_sits_on_the_bed_beside_the_tower(path):
    """Every template (both states): the build transform puts the part on the generic bed,
    z min on the plate, clear of the wipe tower's lane when it fits beside it."""
    design = load_design(path)
    setup = fdm_setup(None)
    w, d, _ = setup.build_mm
    for state in ("programmed", "permanent"):
        try:
            asm = build_assembly(design, state)
        except Exception:  # noqa: BLE001 - a template known not to build folded (test_geometry)
            continue
        lay = bed_layout(asm, setup)
        lo, hi = asm.bounds[0] + lay.offset, asm.bounds[1] + lay.offset
        assert lo[2] == pytest.approx(0.0, abs=1e-9)
        assert (lo[1] + hi[1]) / 2 == pytest.approx(d / 2)
        lane = w - 2 * setup.margin_mm - setup.tower_width_mm
        if lay.tower_xy is not None and hi[0] - lo[0] <= lane:
            assert (lo[0] + hi[0]) / 2 == pytest.approx(lane / 2)
            assert lo[0] >= -1e-9 and hi[0] <= lay.tower_xy[0] - setup.margin_mm + 1e-9  # clear of the tower
        else:  # one body (no tower), or too wide for the lane: centred on the whole bed
            assert (lo[0] + hi[0]) / 2 == pytest.approx(w / 2)


# -- tools: profiles, check, export ------------------------------------------------------------

def test_tool_fit_counts_filaments_on_fdm_and_resins_on_polyjet():
    lib = default_library()
    pr = load_printers()
    graded = _design("helix_graded").materials_used  # VeroWhite + H-1..H-7
    xl = tool_fit(pr["prusa_xl"], graded, lib)
    assert xl.needed == 8 and not xl.ok and xl.feeds == tuple(graded)
    connex = tool_fit(pr["connex260"], graded, lib)
    assert connex.ok and connex.feeds == DIGITAL_SMP_RESINS and len(connex.mixed) == 7
    # a resin the hinges are not mixed from takes a channel of its own
    three = tool_fit(pr["connex260"], ["VeroClear"] + graded, lib)
    assert three.needed == 3 and not three.ok and tool_fit(pr["connex3_500"], ["VeroClear"] + graded, lib).ok
    why = three.refusal("x.toml")
    assert "needs 3 resin channels" in why and "merge grades" not in why and "--printer connex3_500" in why
    # exactly as many materials as tools fits
    four = _design("self_lock").materials_used
    assert len(four) == 4 and tool_fit(pr["bambu_x1c"], four, lib).ok
    assert not tool_fit(pr["bambu_x1c"], four + ["H-7"], lib).ok


def test_rule_tools_error_info_and_silence():
    lib = default_library()
    pr = load_printers()
    d = _design("helix_graded")
    (f,) = rule_tools(CheckContext(d, lib, pr["prusa_xl"]))
    assert (f.code, f.severity) == ("FP103", "error")
    assert "8 tools" in f.message and "has 5" in f.message and "voxels" in f.hint and "connex260" in f.hint
    (f,) = rule_tools(CheckContext(d, lib, pr["connex260"]))
    assert (f.code, f.severity) == ("FP104", "info") and "VeroWhite, TangoBlack (2)" in f.message
    (f,) = rule_tools(CheckContext(_design("self_lock"), lib, pr["bambu_x1c"]))
    assert (f.code, f.severity) == ("FP104", "info") and "not for filaments" in f.message
    assert rule_tools(CheckContext(d, lib, replace(pr["prusa_xl"], tools=None))) == []


def test_check_cli_fails_a_design_with_more_materials_than_tools(capsys):
    code = main(["check", "helix_graded", "--printer", "prusa_xl", "--samples", "0", "--no-sensitivity", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 1
    (f,) = [x for x in out["findings"] if x["code"] == "FP103"]
    assert f["severity"] == "error"


def test_export_refuses_a_printer_with_too_few_tools(tmp_path, capsys):
    out = tmp_path / "x"
    code = main(["export", "helix_graded", "--printer", "prusa_xl", "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "\n" not in err and "Traceback" not in err
    assert "helix_graded.toml" in err and "needs 8 tools" in err and "has 5" in err
    assert "merge grades" in err and "--printer connex260" in err and "--format voxels" in err
    assert not out.exists()


def test_export_for_a_printer_that_fits(tmp_path, capsys):
    """self_lock (4 materials) on the Prusa XL (5 tools): its bed in both slicer 3MFs; on
    the J750 (PolyJet) the slicer 3MFs stay generic; --printer keeps naming the voxel pitch."""
    code = main(["export", "self_lock", "--printer", "prusa_xl", "--out", str(tmp_path / "xl"), "--json"])
    recs = {r["format"]: r for r in json.loads(capsys.readouterr().out)["files"]}
    assert code == 0
    cfg = _prusa_config(_zip(recs["prusa3mf"]["path"], "Metadata/Slic3r_PE.config"))
    assert cfg["bed_shape"] == "0x0,360x0,360x360,0x360" and len(cfg["nozzle_diameter"].split(",")) == 4
    assert "Prusa XL" in Path(recs["recipe"]["path"]).read_text()
    code = main(["export", "self_lock", "--printer", "j750", "--format", "prusa3mf", "--out", str(tmp_path / "j")])
    assert code == 0
    cfg = _prusa_config(_zip(tmp_path / "j" / "self_lock_prusa.3mf", "Metadata/Slic3r_PE.config"))
    assert cfg["bed_shape"] == "0x0,250x0,250x210,0x210"  # generic: the J750 is no FDM printer


def test_printer_profiles_state_their_tools():
    pr = load_printers()
    assert {k: p.tools for k, p in pr.items()} == {"connex260": 2, "connex3_500": 3, "j750": 6, "j850": 7,
                                                  "prusa_xl": 5, "prusa_mk4_mmu3": 5, "bambu_x1c": 4}
    assert all(p.tools_source for p in pr.values())
    assert all(p.base_resins == DIGITAL_SMP_RESINS for p in pr.values() if p.technology == "polyjet")
    assert all(not p.base_resins and p.nozzle_mm for p in pr.values() if p.fdm)


@pytest.mark.parametrize("line,what", [("tools = 0", "tools"), ("tools = 2.5", "tools"), ('tools = "x"', "tools"),
                                       ("nozzle_mm = -0.4", "nozzle_mm")])
def test_bad_tool_counts_are_refused(tmp_path, line, what):
    from foldprint.model.printers import find_printer

    f = tmp_path / "p.toml"
    f.write_text(f'[printers.bad]\ntechnology = "fdm"\nbuild_mm = [100, 100, 100]\nmin_wall_mm = 0.8\n'
                 f'min_gap_mm = 0.4\n{line}\n')
    with pytest.raises(DesignError, match=rf"printers\.bad\.{what}: must be"):
        find_printer("bad", f)


# -- the recipe --------------------------------------------------------------------------------

def test_recipe_states_tools_protocol_and_fold_order(tmp_path):
    """A design with its own process temperatures: the recipe gives those, each body's tool,
    the hinges in the order of their fold times, and says it was not checked."""
    base = _design("mailbox")
    d = replace(base, process=replace(base.process, program_temperature_c=85.0, fix_temperature_c=5.0,
                                      bath_temperature_c=80.0))
    recs = _export(d, tmp_path)
    text = Path(recs["recipe"]["path"]).read_text()
    assert Path(recs["recipe"]["path"]).name == "mailbox_recipe.md"
    assert "heat it to 85 °C" in text and "cool it to 5 °C" in text and "80 °C bath" in text
    for b in recs["prusa3mf"]["bodies"]:
        assert f"| {b['extruder']} | {b['material']} |" in text and f"extruder {b['extruder']} (T{b['extruder'] - 1})" in text
    times = hinge_fold_times(d, default_library())
    rows = re.findall(r"^\| (\d+) \| (\S+) \| (\S+) \| ([\d.]+) s \|$", text, flags=re.M)
    assert [r[1] for r in rows] == sorted(times, key=lambda h: (times[h], h))
    assert all(float(t) == pytest.approx(times[h], abs=0.005) for _, h, _, t in rows)
    assert f"folded in {seconds(max(times.values()))}" in text
    assert "Not checked in this export" in text


def test_recipe_carries_the_check_verdict_when_it_ran(tmp_path):
    d = strip("two", [20, 20], [90], ["H-3"])
    ev = Evaluation(d, EvalOptions(samples=0))
    n_err = ev.errors  # the check's stages, as `check` computes them
    text = Path(_export(d, tmp_path, ("stl",), ev=ev)["recipe"]["path"]).read_text()
    assert "`foldprint check`: **" in text and "Not checked" not in text
    assert ("FAILS" in text) == (n_err > 0) and ev.printer.name in text


def test_recipe_of_the_programmed_state_warns_it_does_not_fold(tmp_path):
    d = _design("self_lock")
    (rec,) = [r for r in Evaluation(d).export(tmp_path, "programmed", ("stl",)) if r["format"] == "recipe"]
    assert Path(rec["path"]).name == "self_lock_programmed_recipe.md"
    assert "does not fold" in Path(rec["path"]).read_text()


def test_export_refusal_is_an_export_error(tmp_path):
    with pytest.raises(ExportError, match="needs 8 tools"):
        Evaluation(_design("helix_graded")).export(tmp_path / "x", printer="bambu_x1c")
    assert not (tmp_path / "x").exists()


def test_core_model_is_placed_where_its_layout_says_with_no_stray_text():
    """model_xml read as XML: the build item's translation is the given layout's offset
    (a layout moved 10 mm in x moves the item 10 mm), and no element carries stray text."""
    from foldprint.exchange.threemf import model_xml

    design = strip("s", [20.0, 20.0], [90.0], ["H-3"])
    asm = build_assembly(design, "permanent")
    lay = bed_layout(asm, fdm_setup(None))
    moved = replace(lay, offset=np.asarray(lay.offset, float) + [10.0, 0.0, 0.0])

    def item_xyz(xml):
        root = ET.fromstring(xml.encode("utf-8"))
        for el in root.iter():
            if not el.tag.endswith("metadata"):
                assert not (el.text or "").strip() and not (el.tail or "").strip(), el.tag
        (item,) = [e for e in root.iter() if e.tag.endswith("}item")]
        return np.array([float(x) for x in item.get("transform").split()][-3:])

    a, b = item_xyz(model_xml(design, asm, layout=lay)), item_xyz(model_xml(design, asm, layout=moved))
    assert np.allclose(b - a, [10.0, 0.0, 0.0], atol=1e-6)
    assert np.allclose(item_xyz(model_xml(design, asm)), a, atol=1e-6)  # default: the generic FDM layout
