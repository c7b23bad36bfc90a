"""3MF packages of an :class:`~foldprint.geometry.Assembly` (``docs/geometry-and-export.md``).

Two flavours, both written deterministically (fixed timestamps, fixed entry order,
ZIP_DEFLATED), so the same assembly gives byte-identical files:

``3mf`` (:func:`threemf_bytes`), the spec-correct form plus what slicers read:
    * ``3D/3dmodel.model``: ``<basematerials>`` (one ``<base>`` per material, name and
      ``displaycolor``), one mesh object per material with ``pid``/``pindex``, one
      assembly object made of ``<components>`` (no ``pid``), one ``<build><item>``
      whose transform puts the part on the plate (z min = 0); each mesh object carries
      ``<metadatagroup><metadata name="cura:extruder_nr">`` (0-based, Cura);
    * ``Metadata/model_settings.config``: Bambu Studio / OrcaSlicer turn the
      components into parts of one object, each with its ``extruder`` (1-based);
    * ``Metadata/project_settings.config``: OrcaSlicer's project, one filament per body
      (:mod:`.slicer_config`);
    * ``Metadata/foldprint_design.toml``: the design (``design_to_toml``), referenced
      from the model part's relationships; ``Application`` metadata names foldprint.

``prusa3mf`` (:func:`prusa3mf_bytes`), for PrusaSlicer, which ignores both components
and base materials for parts: ONE object whose mesh holds every body's triangles, and
``Metadata/Slic3r_PE_model.config`` with a ``<volume firstid lastid>`` triangle range,
name and ``extruder`` per body, and ``Metadata/Slic3r_PE.config``, the printer with one
extruder per body (:mod:`.slicer_config`).

Both put the part on the bed their configuration describes (:func:`.slicer_config.bed_layout`).
"""

from __future__ import annotations

import io
import zipfile
from xml.sax.saxutils import quoteattr

import numpy as np

from ..core.version import __version__
from ..model.design import Design
from ..io.design_io import design_to_toml
from ..geometry import Assembly, Body
from ..model.materials import MaterialLibrary, default_library
from ..model.printers import fdm_setup
from .slicer_config import (ORCA_PROJECT_CONFIG_PATH, PRUSA_PRINT_CONFIG_PATH, BedLayout, bed_layout,
                            orca_project_settings, prusa_print_config, require_bodies)

APPLICATION = f"foldprint {__version__}"
CORE_NS = "http://schemas.microsoft.com/3dmanufacturing/core/2015/02"
CURA_NS = "http://software.ultimaker.com/xml/cura/3mf/2015/10"
FOLDPRINT_NS = "urn:foldprint:3mf:2025"
SLIC3RPE_NS = "http://schemas.slic3r.org/3mf/2017/06"
#: PrusaSlicer's 3MF reader treats a file without ``slic3rpe:Version3mf`` as version 0
#: (a foreign file) and, for an object with one instance, bakes the build item's
#: transform into the mesh of its *first* volume only, then resets the instance: every
#: other volume loses the placement (bodies printed at the wrong height). Version 1 is
#: the format PrusaSlicer 2.x writes: vertices in object coordinates, the build
#: transform kept on the instance, each volume placed by its ``matrix``.
PRUSA_3MF_VERSION = 1
REL_MODEL = "http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"
REL_DESIGN = "urn:foldprint:3mf:2025:design"
MODEL_PATH = "3D/3dmodel.model"
DESIGN_PATH = "Metadata/foldprint_design.toml"
BAMBU_CONFIG_PATH = "Metadata/model_settings.config"
PRUSA_CONFIG_PATH = "Metadata/Slic3r_PE_model.config"
ZIP_DATE = (1980, 1, 1, 0, 0, 0)
IDENTITY = "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"

CONTENT_TYPES = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">\n'
    ' <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>\n'
    ' <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>\n'
    ' <Default Extension="config" ContentType="application/xml"/>\n'
    ' <Default Extension="toml" ContentType="application/toml"/>\n'
    '</Types>\n')

ROOT_RELS = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n'
    f' <Relationship Target="/{MODEL_PATH}" Id="rel0" Type="{REL_MODEL}"/>\n'
    '</Relationships>\n')

MODEL_RELS = (
    '<?xml version="1.0" encoding="UTF-8"?>\n'
    '<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">\n'
    f' <Relationship Target="/{DESIGN_PATH}" Id="rel-design" Type="{REL_DESIGN}"/>\n'
    '</Relationships>\n')


def zip_bytes(entries: dict[str, bytes]) -> bytes:
    """A deterministic zip: ``[Content_Types].xml`` first, then the other entries
    sorted by name; fixed timestamps, permissions and compression level."""
    names = sorted(entries, key=lambda n: (n != "[Content_Types].xml", n))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for name in names:
            info = zipfile.ZipInfo(name, date_time=ZIP_DATE)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.create_system = 3
            info.external_attr = 0o644 << 16
            data = entries[name]
            zf.writestr(info, data if isinstance(data, bytes) else data.encode("utf-8"), compresslevel=6)
    return buf.getvalue()


def _numbers(a: np.ndarray) -> np.ndarray:
    """Coordinates as short exact-enough decimal strings (9 significant digits: 1 nm at
    1 m), no negative zero."""
    return np.char.mod("%.9g", np.asarray(a, dtype=np.float64) + 0.0)


def _mesh_xml(vertices: np.ndarray, faces: np.ndarray, indent: str = "   ") -> str:
    s = _numbers(vertices).ravel().tolist()
    f = np.asarray(faces, dtype=np.int64).ravel().tolist()
    parts = [f"{indent}<mesh>\n{indent} <vertices>\n"]
    parts.append((f'{indent}  <vertex x="%s" y="%s" z="%s"/>\n' * (len(s) // 3)) % tuple(s))
    parts.append(f"{indent} </vertices>\n{indent} <triangles>\n")
    parts.append((f'{indent}  <triangle v1="%d" v2="%d" v3="%d"/>\n' * (len(f) // 3)) % tuple(f))
    parts.append(f"{indent} </triangles>\n{indent}</mesh>\n")
    return "".join(parts)


def _color(library: MaterialLibrary, material: str) -> str:
    if material in library:
        c = library[material].color.lstrip("#").upper()
        return "#" + (c if len(c) == 8 else c + "FF")
    return "#808080FF"


def placement(assembly: Assembly) -> np.ndarray:
    """Translation (3,) that puts the part on the plate: z min -> 0, x and y kept."""
    lo = assembly.bounds[0]
    return np.array([0.0, 0.0, -lo[2]]) + 0.0


def _item_transform(assembly: Assembly, offset: np.ndarray | None = None) -> str:
    t = _numbers(placement(assembly) if offset is None else offset)
    return f"1 0 0 0 1 0 0 0 1 {t[0]} {t[1]} {t[2]}"


def _layout(assembly: Assembly, layout: BedLayout | None) -> BedLayout:
    return bed_layout(assembly, fdm_setup(None)) if layout is None else layout


def _model_header(design: Design, assembly: Assembly, extra_ns: str = "") -> str:
    meta = [("Application", APPLICATION), ("Title", design.name),
            ("Description", design.description or design.name),
            ("foldprint:design", design.name), ("foldprint:state", assembly.state)]
    lines = ['<?xml version="1.0" encoding="UTF-8"?>\n',
             f'<model unit="millimeter" xml:lang="en-US" xmlns="{CORE_NS}" '
             f'xmlns:foldprint="{FOLDPRINT_NS}"{extra_ns}>\n']
    lines += [f" <metadata name={quoteattr(k)}>{_text(v)}</metadata>\n" for k, v in meta]
    return "".join(lines)


def _text(value: str) -> str:
    return value.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


def model_xml(design: Design, assembly: Assembly, library: MaterialLibrary | None = None,
              layout: BedLayout | None = None) -> str:
    """The core ``3D/3dmodel.model`` (one mesh object per material + an assembly), placed on
    the bed of ``layout`` (default: the generic FDM printer's)."""
    lib = library or default_library()
    require_bodies(assembly)
    layout = _layout(assembly, layout)
    out = [_model_header(design, assembly, f' xmlns:cura="{CURA_NS}"'), " <resources>\n"]
    out.append('  <basematerials id="1">\n')
    out += [f'   <base name={quoteattr(b.material)} displaycolor="{_color(lib, b.material)}"/>\n'
            for b in assembly.bodies]
    out.append("  </basematerials>\n")
    for k, b in enumerate(assembly.bodies):
        out.append(f'  <object id="{k + 2}" type="model" pid="1" pindex="{k}" name={quoteattr(b.material)}>\n')
        out.append(f'   <metadatagroup>\n    <metadata name="cura:extruder_nr">{k}</metadata>\n'
                   "   </metadatagroup>\n")
        out.append(_mesh_xml(b.vertices, b.faces))
        out.append("  </object>\n")
    asm_id = len(assembly.bodies) + 2
    out.append(f'  <object id="{asm_id}" type="model" name={quoteattr(design.name)}>\n   <components>\n')
    out += [f'    <component objectid="{k + 2}"/>\n' for k in range(len(assembly.bodies))]
    out.append("   </components>\n  </object>\n </resources>\n")
    out.append(f' <build>\n  <item objectid="{asm_id}" transform="{_item_transform(assembly, layout.offset)}"/>\n'
               ' </build>\n')
    out.append("</model>\n")
    return "".join(out)


def bambu_config(design: Design, assembly: Assembly) -> str:
    """``Metadata/model_settings.config`` for Bambu Studio and OrcaSlicer."""
    asm_id = len(assembly.bodies) + 2
    out = ['<?xml version="1.0" encoding="UTF-8"?>\n<config>\n', f'  <object id="{asm_id}">\n',
           f'    <metadata key="name" value={quoteattr(design.name)}/>\n',
           '    <metadata key="extruder" value="1"/>\n',
           '    <metadata key="interface_shells" value="1"/>\n']
    for k, b in enumerate(assembly.bodies):
        out.append(f'    <part id="{k + 2}" subtype="normal_part">\n'
                   f'      <metadata key="name" value={quoteattr(b.material)}/>\n'
                   f'      <metadata key="matrix" value="{IDENTITY}"/>\n'
                   f'      <metadata key="extruder" value="{k + 1}"/>\n'
                   "    </part>\n")
    out.append("  </object>\n</config>\n")
    return "".join(out)


def _package(design: Design, model: str, configs: dict[str, str]) -> bytes:
    """The 3MF package: content types, relationships, the model, the slicer configs and
    the design itself (provenance)."""
    return zip_bytes({
        "[Content_Types].xml": CONTENT_TYPES.encode(),
        "_rels/.rels": ROOT_RELS.encode(),
        "3D/_rels/3dmodel.model.rels": MODEL_RELS.encode(),
        MODEL_PATH: model.encode(),
        **{path: text.encode() for path, text in configs.items()},
        DESIGN_PATH: design_to_toml(design).encode(),
    })


def threemf_bytes(design: Design, assembly: Assembly, library: MaterialLibrary | None = None,
                  layout: BedLayout | None = None) -> bytes:
    """The spec-correct 3MF with Bambu/Orca (parts and project settings: one filament per
    body) and Cura metadata and the design inside, on ``layout``'s bed."""
    lib = library or default_library()
    layout = _layout(assembly, layout)
    return _package(design, model_xml(design, assembly, lib, layout), {
        BAMBU_CONFIG_PATH: bambu_config(design, assembly),
        ORCA_PROJECT_CONFIG_PATH: orca_project_settings(design.name, assembly, layout, lib)})


def merged_mesh(bodies: tuple[Body, ...]) -> tuple[np.ndarray, np.ndarray, list[tuple[int, int]]]:
    """All bodies in one vertex/triangle list; inclusive triangle ranges per body."""
    verts, faces, ranges, nv, nf = [], [], [], 0, 0
    for b in bodies:
        verts.append(b.vertices)
        faces.append(b.faces + nv)
        ranges.append((nf, nf + len(b.faces) - 1))
        nv += len(b.vertices)
        nf += len(b.faces)
    return np.concatenate(verts), np.concatenate(faces), ranges


def prusa_model_xml(design: Design, assembly: Assembly, layout: BedLayout | None = None) -> str:
    require_bodies(assembly)
    layout = _layout(assembly, layout)
    v, f, _ = merged_mesh(assembly.bodies)
    out = [_model_header(design, assembly, f' xmlns:slic3rpe="{SLIC3RPE_NS}"'),
           f' <metadata name="slic3rpe:Version3mf">{PRUSA_3MF_VERSION}</metadata>\n', " <resources>\n",
           f'  <object id="1" type="model" name={quoteattr(design.name)}>\n',
           _mesh_xml(v, f), "  </object>\n </resources>\n",
           f' <build>\n  <item objectid="1" transform="{_item_transform(assembly, layout.offset)}"/>\n </build>\n',
           "</model>\n"]
    return "".join(out)


def prusa_config(design: Design, assembly: Assembly) -> str:
    """``Metadata/Slic3r_PE_model.config``: one volume (triangle range) per body."""
    _, _, ranges = merged_mesh(assembly.bodies)
    out = ['<?xml version="1.0" encoding="UTF-8"?>\n<config>\n',
           ' <object id="1" instances_count="1">\n',
           f'  <metadata type="object" key="name" value={quoteattr(design.name)}/>\n',
           '  <metadata type="object" key="interface_shells" value="1"/>\n']
    for k, (b, (first, last)) in enumerate(zip(assembly.bodies, ranges)):
        out.append(f'  <volume firstid="{first}" lastid="{last}">\n'
                   f'   <metadata type="volume" key="name" value={quoteattr(b.material)}/>\n'
                   '   <metadata type="volume" key="volume_type" value="ModelPart"/>\n'
                   f'   <metadata type="volume" key="matrix" value="{IDENTITY}"/>\n'
                   f'   <metadata type="volume" key="extruder" value="{k + 1}"/>\n'
                   '   <mesh edges_fixed="0" degenerate_facets="0" facets_removed="0" '
                   'facets_reversed="0" backwards_edges="0"/>\n'
                   "  </volume>\n")
    out.append(" </object>\n</config>\n")
    return "".join(out)


def prusa3mf_bytes(design: Design, assembly: Assembly, library: MaterialLibrary | None = None,
                   layout: BedLayout | None = None) -> bytes:
    """The PrusaSlicer flavour: one multi-volume object, extruder per volume, and the
    printer configuration with one extruder per body, on ``layout``'s bed."""
    lib = library or default_library()
    layout = _layout(assembly, layout)
    return _package(design, prusa_model_xml(design, assembly, layout), {
        PRUSA_CONFIG_PATH: prusa_config(design, assembly),
        PRUSA_PRINT_CONFIG_PATH: prusa_print_config(design.name, assembly, layout, lib)})


# -- the voxel variant: base resins and composites (3MF Materials extension) ---------------

MATERIAL_NS = "http://schemas.microsoft.com/3dmanufacturing/material/2015/02"
#: graded hinges: vertex fractions are rounded to this step before composites are shared
COMPOSITE_STEP = 1e-3


def composite_model_xml(design: Design, assembly: Assembly, part, library: MaterialLibrary | None = None) -> str:
    """``3D/3dmodel.model`` of the voxel variant: ``<basematerials>`` VeroWhite and
    TangoBlack, one ``<m:compositematerials>`` per hinge (a uniform hinge one composite,
    its object's ``pindex``; a graded hinge one composite per distinct vertex fraction,
    referenced per vertex by its triangles' p1/p2/p3), one mesh object per panel and hinge
    (``part.regions``, :class:`~foldprint.exchange.voxel_regions.VoxelPart`), each a build item
    lifted onto the plate."""
    lib = library or default_library()
    require_bodies(assembly)
    out = [_model_header(design, assembly, f' xmlns:m="{MATERIAL_NS}"'), " <resources>\n",
           '  <basematerials id="1">\n',
           f'   <base name="VeroWhite" displaycolor="{_color(lib, "VeroWhite")}"/>\n',
           f'   <base name="TangoBlack" displaycolor="{_color(lib, "TangoBlack")}"/>\n',
           "  </basematerials>\n"]
    objects, next_id = [], 2
    for r in part.regions:
        mesh = r.solid.to_mesh64()
        v = np.asarray(mesh.vert_properties)[:, :3]
        f = np.asarray(mesh.tri_verts, dtype=np.int64)
        name = quoteattr(f"{r.kind} {r.id} ({r.material})")
        c = r.constant
        if r.kind == "panel" and c in (0.0, 1.0):
            objects.append((next_id, f'pid="1" pindex="{0 if c == 1.0 else 1}"', name, _mesh_xml(v, f)))
            next_id += 1
            continue
        frac = np.full(len(v), c) if c is not None else r.fraction(v)
        q = np.round(np.clip(frac, 0.0, 1.0) / COMPOSITE_STEP).astype(np.int64)
        values, inv = np.unique(q, return_inverse=True)
        comp_id = next_id
        out.append(f'  <m:compositematerials id="{comp_id}" matid="1" matindices="0 1">\n')
        out += [f'   <m:composite values="{x * COMPOSITE_STEP:.9g} {1.0 - x * COMPOSITE_STEP:.9g}"/>\n'
                for x in values.tolist()]
        out.append("  </m:compositematerials>\n")
        if len(values) == 1:
            body = _mesh_xml(v, f)
        else:
            body = _mesh_xml_vertex_props(v, f, comp_id, inv)
        objects.append((comp_id + 1, f'pid="{comp_id}" pindex="0"', name, body))
        next_id = comp_id + 2
    for oid, props, name, body in objects:
        out.append(f'  <object id="{oid}" type="model" {props} name={name}>\n')
        out.append(body)
        out.append("  </object>\n")
    out.append(" </resources>\n <build>\n")
    out += [f'  <item objectid="{oid}" transform="{_item_transform(assembly)}"/>\n' for oid, *_ in objects]
    out.append(" </build>\n</model>\n")
    return "".join(out)


def _mesh_xml_vertex_props(vertices: np.ndarray, faces: np.ndarray, pid: int, index: np.ndarray,
                           indent: str = "   ") -> str:
    s = _numbers(vertices).ravel().tolist()
    f = np.asarray(faces, dtype=np.int64)
    p = np.asarray(index, dtype=np.int64)[f]
    rows = np.concatenate([f, p], axis=1).ravel().tolist()
    parts = [f"{indent}<mesh>\n{indent} <vertices>\n"]
    parts.append((f'{indent}  <vertex x="%s" y="%s" z="%s"/>\n' * (len(s) // 3)) % tuple(s))
    parts.append(f"{indent} </vertices>\n{indent} <triangles>\n")
    parts.append((f'{indent}  <triangle v1="%d" v2="%d" v3="%d" pid="{pid}" p1="%d" p2="%d" p3="%d"/>\n'
                  * len(f)) % tuple(rows))
    parts.append(f"{indent} </triangles>\n{indent}</mesh>\n")
    return "".join(parts)


def composite3mf_bytes(design: Design, assembly: Assembly, part, library: MaterialLibrary | None = None) -> bytes:
    """The voxel variant as a 3MF package (see :func:`composite_model_xml`)."""
    return zip_bytes({
        "[Content_Types].xml": CONTENT_TYPES.encode(),
        "_rels/.rels": ROOT_RELS.encode(),
        "3D/_rels/3dmodel.model.rels": MODEL_RELS.encode(),
        MODEL_PATH: composite_model_xml(design, assembly, part, library).encode(),
        DESIGN_PATH: design_to_toml(design).encode(),
    })
