"""Exporters: 3MF (spec form + slicer metadata), PrusaSlicer 3MF, STL + manifest.

Real clients: lib3mf (the reference reader) and PrusaSlicer (``--info``, ``--export-gcode``)."""

from __future__ import annotations

import io
import json
import math
import os
import re
import shutil
import stat
import subprocess
import tomllib
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import lib3mf
import numpy as np
import pytest

import foldprint
from foldprint.physics.recovery.curve import hinge_fold_times
from foldprint.model.design import strip
from foldprint.io.design_io import design_from_dict
from foldprint.io.load import load_design
from foldprint.core.errors import ExportError
from foldprint.core.constants import EXPORT_FORMATS
from foldprint.exchange.export import (DEFAULT_FORMATS, FORMATS, NEEDS, REGISTRY, Rendered, export_assembly,
                                       render)
from foldprint.exchange.outfolder import MANIFEST, digest_file, read_manifest
from foldprint.apps.pipeline import export as export_design
from foldprint.exchange.stl import read_stl_volume
from foldprint.exchange.threemf import REL_DESIGN
from foldprint.geometry import build_assembly
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import fold_time

TEMPLATES = sorted((Path(__file__).resolve().parent.parent / "templates").glob("*.toml"))
#: see tests/test_geometry.py: templates whose permanent state does not build
KNOWN_UNPRINTABLE: set[str] = {"cross_lock_uniform"}  # targets off its folding path (docs/loops.md)
PRINTABLE = [p for p in TEMPLATES if p.stem not in KNOWN_UNPRINTABLE]
IDS = [p.stem for p in PRINTABLE]
PRUSA = shutil.which("prusa-slicer")
needs_prusa = pytest.mark.skipif(PRUSA is None, reason="prusa-slicer is not on PATH (install PrusaSlicer "
                                 "to run the real-client checks)")
NS = {"m": "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"}


@lru_cache(maxsize=None)
def _build(path: str, state: str = "permanent"):
    design = load_design(path)
    return design, build_assembly(design, state)


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """Every printable template exported once (all formats), keyed by stem."""
    out = {}
    for path in PRINTABLE:
        design, asm = _build(str(path))
        d = tmp_path_factory.mktemp(path.stem)
        out[path.stem] = (design, asm, d, export_assembly(design, asm, d, fold_times=hinge_fold_times(design)))
    return out


def _files(records, fmt):
    return [Path(r["path"]) for r in records if r["format"] == fmt]


def _read3mf(path: Path):
    wrapper = lib3mf.get_wrapper()
    model = wrapper.CreateModel()
    reader = model.QueryReader("3mf")
    reader.AddRelationToRead(REL_DESIGN)
    reader.SetStrictModeActive(True)
    reader.ReadFromFile(str(path))
    warnings = [reader.GetWarning(i) for i in range(reader.GetWarningCount())]
    return model, warnings


def _mesh_objects(model):
    it = model.GetMeshObjects()
    out = []
    while it.MoveNext():
        out.append(it.GetCurrentMeshObject())
    return out


def _volume(obj) -> float:
    v = np.array([list(p.Coordinates) for p in obj.GetVertices()], dtype=np.float64)
    t = np.array([list(x.Indices) for x in obj.GetTriangleIndices()], dtype=np.int64)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


# -- records and files -------------------------------------------------------------------

@pytest.mark.parametrize("stem", IDS)
def test_records_and_file_names(exported, stem):
    design, asm, d, records = exported[stem]
    names = sorted(Path(r["path"]).name for r in records)
    mats = [b.material for b in asm.bodies]
    assert names == sorted([f"{design.name}.3mf", f"{design.name}_prusa.3mf", "manifest.json",
                            f"{design.name}_recipe.md"] + [f"{design.name}_{m}.stl" for m in mats])
    for r in records:
        assert Path(r["path"]).is_file() and Path(r["path"]).stat().st_size == r["bytes"]
        assert r["format"] in FORMATS + ("manifest", "recipe")
        assert all(set(b) == {"material", "extruder", "files", "volume_mm3", "z_range_mm", "needs_support"}
                   for b in r["bodies"])
    # plain files: the set and its manifest, nothing else (no links, no hidden folders)
    assert sorted(e.name for e in os.scandir(d)) == sorted(names + [MANIFEST])
    assert all(e.is_file(follow_symlinks=False) for e in os.scandir(d))
    assert read_manifest(d) == {n: frozenset([digest_file(d / n)]) for n in names}
    (tm,) = [r for r in records if r["format"] == "3mf"]
    assert [b["material"] for b in tm["bodies"]] == mats
    assert sum(b["volume_mm3"] for b in tm["bodies"]) == pytest.approx(asm.volume, rel=1e-9)


# -- 3MF, spec form ------------------------------------------------------------------------

@pytest.mark.parametrize("stem", IDS)
def test_3mf_reads_in_lib3mf_without_warnings(exported, stem):
    design, asm, d, records = exported[stem]
    (path,) = _files(records, "3mf")
    model, warnings = _read3mf(path)
    assert warnings == []
    objs = _mesh_objects(model)
    assert [o.GetName() for o in objs] == [b.material for b in asm.bodies]  # one per material
    groups = model.GetBaseMaterialGroups()
    assert groups.MoveNext()
    bm = groups.GetCurrentBaseMaterialGroup()
    ids = bm.GetAllPropertyIDs()
    lib = default_library()
    assert [bm.GetName(i) for i in ids] == [b.material for b in asm.bodies]
    for i, b in zip(ids, asm.bodies):
        c = bm.GetDisplayColor(i)
        assert "#{:02x}{:02x}{:02x}".format(c.Red, c.Green, c.Blue) == lib[b.material].color.lower()[:7]
    for k, (o, b) in enumerate(zip(objs, asm.bodies)):
        has, res, prop = o.GetObjectLevelProperty()[2], o.GetObjectLevelProperty()[0], o.GetObjectLevelProperty()[1]
        assert has and res == bm.GetResourceID() and prop == ids[k]
        assert o.IsManifoldAndOriented()
        assert o.GetTriangleCount() == len(b.faces) and o.GetVertexCount() == len(b.vertices)
        assert _volume(o) == pytest.approx(b.volume, rel=1e-5)
        md = o.GetMetaDataGroup()
        entries = {md.GetMetaData(i).GetName(): md.GetMetaData(i).GetValue() for i in range(md.GetMetaDataCount())}
        assert entries == {"extruder_nr": str(k)}  # cura:extruder_nr, 0-based
    comps = model.GetComponentsObjects()
    assert comps.MoveNext()
    asm_obj = comps.GetCurrentComponentsObject()
    assert not comps.MoveNext()
    assert asm_obj.GetComponentCount() == len(asm.bodies)
    assert [asm_obj.GetComponent(i).GetObjectResourceID() for i in range(len(asm.bodies))] == \
        [o.GetResourceID() for o in objs]
    items = model.GetBuildItems()
    assert items.Count() == 1 and items.MoveNext()
    item = items.GetCurrent()
    assert item.GetObjectResourceID() == asm_obj.GetResourceID()
    tz = item.GetObjectTransform().Fields[3][2]
    assert tz == pytest.approx(-asm.bounds[0][2], abs=1e-6)  # sits on the plate
    mg = model.GetMetaDataGroup()
    meta = {mg.GetMetaData(i).GetName(): mg.GetMetaData(i).GetValue() for i in range(mg.GetMetaDataCount())}
    assert meta["Application"] == f"foldprint {foldprint.__version__}"
    assert meta["Title"] == design.name and meta["state"] == "permanent"
    assert model.GetAttachmentCount() == 1
    att = model.GetAttachment(0)
    assert att.GetPath() == "/Metadata/foldprint_design.toml"
    text = bytes(att.WriteToBuffer()).decode() if hasattr(att, "WriteToBuffer") else None
    with zipfile.ZipFile(path) as zf:
        raw = zf.read("Metadata/foldprint_design.toml").decode()
    if text is not None:
        assert text == raw
    back = design_from_dict(tomllib.loads(raw))
    assert back.name == design.name and len(back.panels) == len(design.panels)
    assert [h.material for h in back.hinges] == [h.material for h in design.hinges]
    assert build_assembly(back).volume == pytest.approx(asm.volume, rel=1e-9)


def _zip_xml(path: Path, name: str) -> ET.Element:
    with zipfile.ZipFile(path) as zf:
        return ET.fromstring(zf.read(name))


@pytest.mark.parametrize("stem", IDS)
def test_3mf_slicer_metadata(exported, stem):
    design, asm, d, records = exported[stem]
    (path,) = _files(records, "3mf")
    model = _zip_xml(path, "3D/3dmodel.model")
    objects = model.findall("m:resources/m:object", NS)
    meshes = [o for o in objects if o.find("m:mesh", NS) is not None]
    (assembly,) = [o for o in objects if o.find("m:components", NS) is not None]
    assert "pid" not in assembly.attrib and all("pid" in o.attrib and "pindex" in o.attrib for o in meshes)
    assert [int(o.get("pindex")) for o in meshes] == list(range(len(asm.bodies)))
    config = _zip_xml(path, "Metadata/model_settings.config")
    (obj,) = config.findall("object")
    assert obj.get("id") == assembly.get("id")
    # the object's own settings (OrcaSlicer reads lower-case keys): its name, extruder 1 by default
    own = {m.get("key"): m.get("value") for m in obj.findall("metadata")}
    assert own == {"name": design.name, "extruder": "1", "interface_shells": "1"}
    parts = obj.findall("part")
    assert [p.get("id") for p in parts] == [c.get("objectid") for c in
                                             assembly.findall("m:components/m:component", NS)]
    ext = [int(p.find("metadata[@key='extruder']").get("value")) for p in parts]
    assert ext == list(range(1, len(asm.bodies) + 1))  # 1-based
    assert [p.find("metadata[@key='name']").get("value") for p in parts] == [b.material for b in asm.bodies]


@pytest.mark.parametrize("stem", IDS)
def test_package_content_types_and_relationships(exported, stem):
    design, asm, d, records = exported[stem]
    for path in _files(records, "3mf") + _files(records, "prusa3mf"):
        with zipfile.ZipFile(path) as zf:
            names = zf.namelist()
            assert names[0] == "[Content_Types].xml" and names[1:] == sorted(names[1:])
            assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in zf.infolist())
            assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in zf.infolist())
            types = ET.fromstring(zf.read("[Content_Types].xml"))
            ct = "{http://schemas.openxmlformats.org/package/2006/content-types}"
            defaults = {e.get("Extension") for e in types.iter(ct + "Default")}
            overrides = {e.get("PartName") for e in types.iter(ct + "Override")}
            for n in names[1:]:
                assert n.rsplit(".", 1)[-1] in defaults or "/" + n in overrides, n
            rel_ns = "{http://schemas.openxmlformats.org/package/2006/relationships}"
            for rels in [n for n in names if n.endswith(".rels")]:
                for rel in ET.fromstring(zf.read(rels)).iter(rel_ns + "Relationship"):
                    assert rel.get("Target").lstrip("/") in names
                    assert rel.get("Id") and rel.get("Type")
            start = ET.fromstring(zf.read("_rels/.rels"))
            assert [r.get("Target") for r in start.iter(rel_ns + "Relationship")] == ["/3D/3dmodel.model"]


def test_unzip_extracts_every_entry_as_a_plain_rw_r_r_file(exported, tmp_path):
    """Info-ZIP's unzip (a real client) applies the Unix mode stored with each entry: every
    part of both packages comes out a regular file, rw-r--r--."""
    unzip = shutil.which("unzip")
    if unzip is None:
        pytest.skip("unzip is not on PATH")
    design, asm, d, records = exported["mailbox"]
    for path in _files(records, "3mf") + _files(records, "prusa3mf"):
        out = tmp_path / path.stem
        subprocess.run([unzip, "-q", str(path), "-d", str(out)], check=True, timeout=60)
        files = [p for p in out.rglob("*") if not p.is_dir()]
        assert len(files) == len(zipfile.ZipFile(path).namelist())
        assert all(stat.S_ISREG(p.lstat().st_mode) and stat.S_IMODE(p.lstat().st_mode) == 0o644 for p in files)


def _small_design(**kw):
    d = strip("s", [10.0, 10.0, 10.0], [90.0, 90.0], ["H-1", "H-3"], **kw)
    return d, build_assembly(d, "permanent")


def test_writers_default_to_the_generic_fdm_bed_and_the_default_library():
    """Without a layout or a library, every writer places the part as the generic FDM
    printer's bed layout does and colours it from the default library."""
    from foldprint.exchange.slicer_config import bed_layout
    from foldprint.exchange.threemf import model_xml, prusa3mf_bytes, prusa_model_xml, threemf_bytes
    from foldprint.model.printers import fdm_setup

    design, asm = _small_design()
    lay, lib = bed_layout(asm, fdm_setup(None)), default_library()
    assert threemf_bytes(design, asm) == threemf_bytes(design, asm, lib, lay)
    assert prusa3mf_bytes(design, asm) == prusa3mf_bytes(design, asm, lib, lay)
    assert model_xml(design, asm) == model_xml(design, asm, lib, lay)
    assert prusa_model_xml(design, asm) == prusa_model_xml(design, asm, lay)


def test_a_librarys_colours_reach_both_flavours():
    """A library whose hinge resin has another colour: the core 3MF's base material (read by
    lib3mf) and the PrusaSlicer flavour's extruder colours carry it."""
    from foldprint.exchange.threemf import prusa3mf_bytes, threemf_bytes
    from foldprint.model.materials import MaterialLibrary

    design, asm = _small_design()
    base = default_library()
    lib = MaterialLibrary(tuple(replace(m, color="#123456") if m.name == "H-3" else m for m in base.materials))
    mats = [b.material for b in asm.bodies]
    assert "H-3" in mats and base["H-3"].color.lower()[:7] != "#123456"
    want = [("#123456" if m == "H-3" else base[m].color.lower()[:7]) for m in mats]
    model = lib3mf.get_wrapper().CreateModel()
    model.QueryReader("3mf").ReadFromBuffer(list(threemf_bytes(design, asm, lib)))
    groups = model.GetBaseMaterialGroups()
    assert groups.MoveNext()
    bm = groups.GetCurrentBaseMaterialGroup()
    got = ["#{:02x}{:02x}{:02x}".format(c.Red, c.Green, c.Blue)
           for c in (bm.GetDisplayColor(i) for i in bm.GetAllPropertyIDs())]
    assert got == want
    with zipfile.ZipFile(io.BytesIO(prusa3mf_bytes(design, asm, lib))) as zf:
        config = zf.read("Metadata/Slic3r_PE.config").decode()
    (line,) = [x for x in config.splitlines() if x.startswith("; extruder_colour = ")]
    assert [c.strip('"').lower() for c in line.split(" = ", 1)[1].split(";")] == want


def test_xml_special_characters_in_names_survive_a_strict_reader():
    """A name and a description with ``&``, ``<``, ``>`` and the CDATA end ``]]>`` (which
    XML forbids raw in text): both flavours parse (expat, lib3mf strict) and give them back."""
    from foldprint.exchange.threemf import prusa3mf_bytes, threemf_bytes

    name, text = "s <&> ]]> x", "a ]]> b <c> & 'd' \"e\""
    design, asm = _small_design(description=text)
    design = replace(design, name=name)
    for data in (threemf_bytes(design, asm), prusa3mf_bytes(design, asm)):
        with zipfile.ZipFile(io.BytesIO(data)) as zf:
            root = ET.fromstring(zf.read("3D/3dmodel.model"))
        meta = {m.get("name"): m.text for m in root.iter(f"{{{NS['m']}}}metadata")}
        assert meta["Title"] == name and meta["Description"] == text
        model = lib3mf.get_wrapper().CreateModel()
        reader = model.QueryReader("3mf")
        reader.SetStrictModeActive(True)
        reader.ReadFromBuffer(list(data))
        mg = model.GetMetaDataGroup()
        got = {mg.GetMetaData(i).GetName(): mg.GetMetaData(i).GetValue() for i in range(mg.GetMetaDataCount())}
        assert got["Title"] == name and got["Description"] == text


def test_an_assembly_without_bodies_is_refused_by_name(tmp_path):
    """Every writer refuses a part without bodies with the one ExportError naming the
    design, before anything reads the bodies' bounds (the bed layout did, an IndexError):
    with or without a given layout, and the whole export, which writes nothing."""
    from foldprint.exchange.slicer_config import bed_layout
    from foldprint.exchange.threemf import model_xml, prusa3mf_bytes, prusa_model_xml, threemf_bytes
    from foldprint.model.printers import fdm_setup

    design, asm = _small_design()
    lay = bed_layout(asm, fdm_setup(None))
    empty = replace(asm, bodies=())
    writes = [lambda: model_xml(design, empty, layout=lay), lambda: prusa_model_xml(design, empty, lay),
              lambda: threemf_bytes(design, empty), lambda: prusa3mf_bytes(design, empty),
              lambda: threemf_bytes(design, empty, layout=lay), lambda: prusa3mf_bytes(design, empty, layout=lay),
              lambda: bed_layout(empty, fdm_setup(None)),
              lambda: export_assembly(design, empty, tmp_path / "out", ["3mf", "prusa3mf"])]
    for write in writes:
        with pytest.raises(ExportError, match=r"^design 's': nothing to export \(no bodies\)$"):
            write()
    assert not (tmp_path / "out").exists()


def test_an_export_without_bodies_exits_2_with_one_line(tmp_path, monkeypatch, capsys):
    """At the command line the refusal is exit 2 and one line on stderr, nothing written
    (a part without bodies, as a geometry bug would hand over, reaches the writers)."""
    from foldprint.apps import evaluation_exports
    from foldprint.cli.commands import main
    from foldprint.io.design_io import design_to_toml

    design, asm = _small_design()
    f = tmp_path / "s.toml"
    f.write_text(design_to_toml(design))
    monkeypatch.setattr(evaluation_exports, "build_assembly", lambda *a, **k: replace(asm, bodies=()))
    out = tmp_path / "out"
    assert main(["export", str(f), "--out", str(out), "--format", "3mf,prusa3mf", "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.splitlines() == ["foldprint: error: design 's': nothing to export (no bodies)"]
    assert not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("stem", IDS)
def test_slicer_configs_hold_their_data_in_attributes(exported, stem):
    """PrusaSlicer's and Bambu/Orca's per-object configs are elements with attributes only:
    no character data between them."""
    design, asm, d, records = exported[stem]
    for path, name in [(_files(records, "prusa3mf")[0], "Metadata/Slic3r_PE_model.config"),
                       (_files(records, "3mf")[0], "Metadata/model_settings.config")]:
        root = _zip_xml(path, name)
        assert all(not (e.text or "").strip() and not (e.tail or "").strip() for e in root.iter()), name


# -- PrusaSlicer flavour -------------------------------------------------------------------

@pytest.mark.parametrize("stem", IDS)
def test_prusa3mf_volumes_cover_the_one_mesh(exported, stem):
    design, asm, d, records = exported[stem]
    (path,) = _files(records, "prusa3mf")
    model, warnings = _read3mf(path)
    assert warnings == []
    (obj,) = _mesh_objects(model)
    assert obj.GetTriangleCount() == sum(len(b.faces) for b in asm.bodies)
    assert _volume(obj) == pytest.approx(asm.volume, rel=1e-5)
    config = _zip_xml(path, "Metadata/Slic3r_PE_model.config")
    (o,) = config.findall("object")
    vols = o.findall("volume")
    assert len(vols) == len(asm.bodies)
    first = 0
    for k, (v, b) in enumerate(zip(vols, asm.bodies)):
        assert int(v.get("firstid")) == first
        assert int(v.get("lastid")) == first + len(b.faces) - 1
        first += len(b.faces)
        meta = {m.get("key"): m.get("value") for m in v.findall("metadata")}
        assert meta["name"] == b.material and meta["extruder"] == str(k + 1)
        assert meta["volume_type"] == "ModelPart"
    assert first == obj.GetTriangleCount()
    # both flavours put the part at the same place on the same bed (the core one: on the plate)
    (core,) = _files(records, "3mf")
    items = [m.GetBuildItems() for m in (model, _read3mf(core)[0])]
    assert all(it.Count() == 1 and it.MoveNext() for it in items)
    prusa_t, core_t = (np.array(it.GetCurrent().GetObjectTransform().Fields) for it in items)
    assert np.array_equal(prusa_t, core_t)


def _prusa_info(path: Path) -> list[dict]:
    res = subprocess.run([PRUSA, "--info", str(path)], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr[-2000:]
    blocks = []
    for line in res.stdout.splitlines():  # (PrusaSlicer 2.5 also logs a [trace] line here)
        if line.strip() == f"[{path.name}]":
            blocks.append({})
        elif "=" in line and blocks:
            k, v = (s.strip() for s in line.split("=", 1))
            blocks[-1][k] = v
    return blocks


@needs_prusa
@pytest.mark.parametrize("stem", IDS)
def test_prusaslicer_info_every_object_manifold(exported, stem):
    design, asm, d, records = exported[stem]
    (core,) = _files(records, "3mf")
    info = _prusa_info(core)
    # PrusaSlicer turns a components assembly into one object per mesh object
    assert len(info) == len(asm.bodies)
    assert all(b["manifold"] == "yes" for b in info)
    assert sorted(float(b["volume"]) for b in info) == pytest.approx(sorted(b.volume for b in asm.bodies), rel=1e-4)
    (prusa,) = _files(records, "prusa3mf")
    (one,) = _prusa_info(prusa)
    assert one["manifold"] == "yes"
    assert float(one["volume"]) == pytest.approx(asm.volume, rel=1e-4)
    assert int(one["number_of_facets"]) == sum(len(b.faces) for b in asm.bodies)


@needs_prusa
def test_prusaslicer_slices_the_prusa_flavour(tmp_path):
    """One small template (the one with the smallest folded bounding box), sliced with one
    extruder per material: every volume is printed with its own tool."""
    def size(p):
        lo, hi = _build(str(p))[1].bounds
        return float(np.prod(hi - lo))
    path = min(PRINTABLE, key=size)
    design, asm = _build(str(path))
    (rec,) = [r for r in export_design(design, tmp_path / "out", formats=["prusa3mf"]) if r["format"] == "prusa3mf"]
    n = len(asm.bodies)
    gcode = tmp_path / "part.gcode"
    cmd = [PRUSA, "--export-gcode", "--nozzle-diameter", ",".join(["0.4"] * n),
           "--layer-height", "0.2", "--output", str(gcode), rec["path"]]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    text = gcode.read_text()
    tools = set(re.findall(r"^T(\d+)\s*$", text, flags=re.M))
    assert tools == {str(k) for k in range(n)}, tools
    assert ";LAYER_CHANGE" in text


# -- STL + manifest ----------------------------------------------------------------------------

@pytest.mark.parametrize("stem", IDS)
def test_stl_volumes_sum_to_3mf(exported, stem):
    design, asm, d, records = exported[stem]
    stls = _files(records, "stl")
    vols = {p.name: read_stl_volume(p.read_bytes()) for p in stls}
    for b in asm.bodies:
        assert vols[f"{design.name}_{b.material}.stl"] == pytest.approx(b.volume, rel=1e-5)
        data = (d / f"{design.name}_{b.material}.stl").read_bytes()
        assert not data.startswith(b"solid") and len(data) == 84 + 50 * len(b.faces)
    (core,) = _files(records, "3mf")
    model, _ = _read3mf(core)
    total3mf = sum(_volume(o) for o in _mesh_objects(model))
    assert sum(vols.values()) == pytest.approx(total3mf, rel=1e-5)


@pytest.mark.parametrize("stem", IDS)
def test_manifest(exported, stem):
    design, asm, d, records = exported[stem]
    man = json.loads((d / "manifest.json").read_text())
    assert man["design"] == design.name and man["units"] == "mm" and man["state"] == "permanent"
    assert [b["material"] for b in man["bodies"]] == [b.material for b in asm.bodies]
    assert [b["file"] for b in man["bodies"]] == [f"{design.name}_{b.material}.stl" for b in asm.bodies]
    for k, (m, b) in enumerate(zip(man["bodies"], asm.bodies)):
        assert m["volume_mm3"] == pytest.approx(b.volume, abs=1e-6)
        assert m["extruder"] == k + 1
        # the print frame: the STL's z plus the offset, the whole part from z = 0
        assert m["z_range_print_mm"] == pytest.approx(b.bounds[:, 2] + man["print_offset_mm"][2], abs=1e-6)
    assert min(m["z_range_print_mm"][0] for m in man["bodies"]) == pytest.approx(0.0, abs=1e-9)
    assert man["bounding_box"]["min"] == pytest.approx(asm.bounds[0], abs=1e-6)
    assert man["bounding_box"]["max"] == pytest.approx(asm.bounds[1], abs=1e-6)
    pr = man["programming"]
    assert pr["program_temperature_c"] == design.process.program_temperature_c
    assert pr["fix_temperature_c"] == design.process.fix_temperature_c
    assert pr["bath_temperature_c"] == design.process.bath_temperature_c
    lib = default_library()
    times = [fold_time(lib[h.material], design.process.bath_temperature_c, h.thickness,
                       design.process.fix_temperature_c) for h in design.hinges]
    assert pr["expected_fold_time_s"] == pytest.approx(max(times), abs=1e-3)
    assert set(pr["hinge_fold_times_s"]) == {h.id for h in design.hinges}


def test_manifest_fold_time_null_when_a_hinge_does_not_fold(tmp_path):
    d = strip("cold", [15.0, 15.0], [90.0], ["H-7"])
    d = replace(d, process=replace(d.process, bath_temperature_c=30.0))  # below every Tg
    export_design(d, tmp_path, formats=["stl"])
    man = json.loads((tmp_path / "manifest.json").read_text())
    assert man["programming"]["expected_fold_time_s"] is None
    assert man["programming"]["hinge_fold_times_s"] == {"h1": None}


def test_mailbox_fold_time_is_the_slowest_main_hinge(exported):
    design, asm, d, records = exported["mailbox"]
    man = json.loads((d / "manifest.json").read_text())
    t = man["programming"]["hinge_fold_times_s"]
    assert man["programming"]["expected_fold_time_s"] == max(t.values()) == t["front"]
    assert t["tab_left_front"] < t["left"] < t["front"]  # H-3 < H-5 < H-6


# -- determinism and failure behaviour ----------------------------------------------------------

def test_export_twice_gives_identical_bytes(tmp_path):
    path = str(PRINTABLE[IDS.index("mailbox")])
    design = load_design(path)
    a = export_design(design, tmp_path / "a")
    b = export_design(load_design(path), tmp_path / "b")
    assert [Path(r["path"]).name for r in a] == [Path(r["path"]).name for r in b]
    for ra, rb in zip(a, b):
        assert Path(ra["path"]).read_bytes() == Path(rb["path"]).read_bytes(), ra["path"]


def test_programmed_state_export(tmp_path):
    design, asm = _build(str(PRINTABLE[IDS.index("mailbox")]), "programmed")
    recs = export_design(design, tmp_path, state="programmed", formats=["3mf", "stl"])
    names = {Path(r["path"]).name for r in recs}
    assert "mailbox_programmed.3mf" in names and "manifest_programmed.json" in names
    man = json.loads((tmp_path / "manifest_programmed.json").read_text())
    assert man["state"] == "programmed"
    half = max([p.thickness for p in design.panels] + [h.thickness for h in design.hinges]) / 2
    assert man["bounding_box"]["max"][2] == pytest.approx(half)  # flat: half the thickest part
    total = sum(b["volume_mm3"] for b in man["bodies"])
    assert total == pytest.approx(asm.volume, rel=1e-9)


def test_unwritable_output_dir_raises_and_writes_nothing(tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("not a directory")
    design = _build(str(PRINTABLE[0]))[0]
    with pytest.raises(ExportError, match="blocker"):
        export_design(design, blocker / "out")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]
    assert blocker.read_text() == "not a directory"


def _failing_open(monkeypatch, fail_at: int, calls: list):
    """Make the export's n-th file write fail (disk full), through the writer's ``open``."""
    from foldprint.core import files as files_mod

    def flaky(path, mode="r", *a, **kw):
        if "w" in mode or "x" in mode:
            calls.append(path)
            if len(calls) >= fail_at:
                raise OSError(28, "No space left on device")
        return open(path, mode, *a, **kw)

    monkeypatch.setattr(files_mod, "open", flaky, raising=False)


def test_failed_write_leaves_no_partial_output(tmp_path, monkeypatch):
    design = _build(str(PRINTABLE[0]))[0]
    calls = []
    _failing_open(monkeypatch, 3, calls)
    out = tmp_path / "out"
    with pytest.raises(ExportError, match="No space left"):
        export_design(design, out)
    assert len(calls) == 3 and not out.exists()  # the directory this export created is gone too


def test_failed_write_keeps_files_from_an_earlier_export(tmp_path, monkeypatch):
    design = _build(str(PRINTABLE[0]))[0]
    first = export_design(design, tmp_path, formats=["3mf", "prusa3mf"])
    before = {r["path"]: Path(r["path"]).read_bytes() for r in first}
    _failing_open(monkeypatch, 2, [])
    with pytest.raises(ExportError):
        export_design(design, tmp_path, formats=["3mf", "prusa3mf"])
    assert {p: Path(p).read_bytes() for p in before} == before
    # the earlier set and its manifest, nothing of the failed one (nor its staging folder beside)
    assert sorted(os.listdir(tmp_path)) == sorted([Path(p).name for p in before] + [MANIFEST])
    assert [n for n in os.listdir(tmp_path.parent) if n.startswith(f".{tmp_path.name}.")] == []


def test_unknown_format_raises_before_building(tmp_path):
    design = _build(str(PRINTABLE[0]))[0]
    with pytest.raises(ExportError, match="obj"):
        export_design(design, tmp_path / "x", formats=["3mf", "obj"])
    assert not (tmp_path / "x").exists()


def test_format_subset(tmp_path):
    design = _build(str(PRINTABLE[0]))[0]
    recs = export_design(design, tmp_path, formats=("prusa3mf",))
    assert [r["format"] for r in recs] == ["prusa3mf", "recipe"]  # every export ends with its recipe
    assert math.isclose(sum(b["volume_mm3"] for b in recs[0]["bodies"]), _build(str(PRINTABLE[0]))[1].volume,
                        rel_tol=1e-9)


# -- the format registry -------------------------------------------------------------------

def test_the_default_formats_are_registered_formats():
    # one source of truth: the names come from the registry, the default from core.constants
    assert FORMATS == tuple(REGISTRY) and all(REGISTRY[f].name == f for f in FORMATS)
    assert DEFAULT_FORMATS == EXPORT_FORMATS and EXPORT_FORMATS
    assert set(EXPORT_FORMATS) <= set(FORMATS)
    assert {f.needs for f in REGISTRY.values()} - {None} == set(NEEDS)


def test_files_come_in_registry_order_whatever_the_request_order():
    design, asm = _build(str(PRINTABLE[0]))
    files = render(design, asm, ["fold", "prusa3mf", "3mf", "fold"])
    assert all(isinstance(f, Rendered) for f in files)
    assert [f.fmt for f in files] == ["3mf", "prusa3mf", "fold", "recipe"]
    assert [f.name for f in files] == [f"{design.name}.3mf", f"{design.name}_prusa.3mf", f"{design.name}.fold",
                                       f"{design.name}_recipe.md"]
    assert [b["material"] for b in files[0].bodies] == [b.material for b in asm.bodies]


@pytest.mark.parametrize("fmt", [f for f in FORMATS if REGISTRY[f].needs])
def test_a_format_refuses_without_the_input_it_needs(fmt):
    design, asm = _build(str(PRINTABLE[0]))
    with pytest.raises(ExportError, match=re.escape(fmt)) as err:
        render(design, asm, [fmt])
    assert "export through foldprint.apps.pipeline" in str(err.value)
    # the formats that need nothing beyond the assembly are written without any of them
    free = [f for f in FORMATS if REGISTRY[f].needs is None]
    assert [f.fmt for f in render(design, asm, free)] == free + ["recipe"]
