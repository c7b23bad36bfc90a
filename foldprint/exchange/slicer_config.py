"""The printer configurations the slicer 3MFs carry, so that a slicer opening them (or
slicing them with no options) prints each body with its own tool.

Without them PrusaSlicer reads the per-volume extruders of a 3MF into its default
single-extruder profile and prints every body with T0, silently; OrcaSlicer resets a part
whose extruder is beyond the project's filament count to filament 1.

``Metadata/Slic3r_PE.config`` (:func:`prusa_print_config`, PrusaSlicer): ``; key = value``
lines after a first comment line, as PrusaSlicer writes into its own project 3MFs and reads
back (``ConfigBase::load_from_gcode_string_legacy``: from the end upwards, the first line
never). PrusaSlicer counts extruders by ``nozzle_diameter`` and resizes the per-extruder
and per-filament options to that count (``Preset::normalize``); the wipe tower's purge
matrix is NOT resized: ``wiping_volumes_matrix`` must be n x n and ``wiping_volumes_extruders``
2n, or the wipe tower of PrusaSlicer 2.5's command line reads past them (8 tools: > 9 GB
and no end, measured). The wipe tower needs relative extrusion distances.

``Metadata/project_settings.config`` (:func:`orca_project_settings`, OrcaSlicer / Bambu
Studio): JSON, every value a string or a list of strings. OrcaSlicer's 3MF reader
(``bbs_3mf.cpp``) loads it from a file of any producer and keeps each part's ``extruder``
(``Metadata/model_settings.config``) up to the number of ``filament_settings_id``;
``filament_colour``, ``filament_diameter`` and the flush matrix are per filament,
``nozzle_diameter`` per nozzle (one for a filament changer such as the AMS). Bambu Studio
loads a 3MF's settings only when its ``Application`` metadata names Bambu Studio, which a
foldprint file does not claim: there the parts keep their filament numbers, loaded into a
project that has that many filaments.

Both describe :func:`foldprint.model.printers.fdm_setup`: the FDM printer export was given,
else a generic one, with one tool per body (body k is extruder k + 1, the order of the
export records). :func:`bed_layout` puts the part and the wipe tower on that bed.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np

from ..core.errors import ExportError
from ..core.version import __version__
from ..geometry import Assembly
from ..model.materials import MaterialLibrary
from ..model.printers import FdmSetup

PRUSA_PRINT_CONFIG_PATH = "Metadata/Slic3r_PE.config"
ORCA_PROJECT_CONFIG_PATH = "Metadata/project_settings.config"


@dataclass(frozen=True)
class BedLayout:
    """Where the slicer 3MFs put the part: ``offset`` moves the sheet frame into the print
    frame on the bed (z min -> 0, the part centred in the bed left of the tower lane, or on
    the whole bed when it does not fit there); ``tower_xy``: the wipe tower's front-left
    corner (None for a one-body part: no tool change)."""

    offset: np.ndarray
    tower_xy: tuple[float, float] | None
    setup: FdmSetup


def require_bodies(assembly: Assembly) -> None:
    """ExportError naming the design when ``assembly`` has no body: a part with nothing to
    print has no bounds, no bed layout and no tools."""
    if not assembly.bodies:
        raise ExportError(f"design {assembly.design_name!r}: nothing to export (no bodies)")


def bed_layout(assembly: Assembly, setup: FdmSetup) -> BedLayout:
    """The part and its wipe tower on ``setup``'s bed (see :class:`BedLayout`); ExportError
    for an assembly without bodies."""
    require_bodies(assembly)
    lo, hi = assembly.bounds
    w, d = float(setup.build_mm[0]), float(setup.build_mm[1])
    m, tw = setup.margin_mm, setup.tower_width_mm
    tower = None
    right = w
    if len(assembly.bodies) > 1:
        tower = (round(w - m - tw, 3), round(m, 3))
        right = w - 2 * m - tw
    size = hi[:2] - lo[:2]
    if size[0] > right:  # no room beside the tower lane: centre on the whole bed
        right = w
    centre = np.array([right / 2.0, d / 2.0])
    xy = centre - (lo[:2] + hi[:2]) / 2.0
    return BedLayout(np.array([xy[0], xy[1], -lo[2]]) + 0.0, tower, setup)


def tool_colours(assembly: Assembly, library: MaterialLibrary) -> list[str]:
    """Each body's display colour, ``#RRGGBB`` (grey for a material the library lacks)."""
    out = []
    for b in assembly.bodies:
        c = library[b.material].color.lstrip("#")[:6].upper() if b.material in library else "808080"
        out.append("#" + c)
    return out


def _purge(n: int, setup: FdmSetup) -> tuple[list[str], list[str]]:
    """The n x n purge matrix (0 on the diagonal) and the per-extruder unload/load volumes."""
    v = f"{setup.purge_mm3:g}"
    matrix = ["0" if i == j else v for i in range(n) for j in range(n)]
    return matrix, [f"{setup.purge_mm3 / 2:g}"] * (2 * n)


def _quoted(values) -> str:
    """PrusaSlicer's serialisation of a list of strings: each in double quotes, ';'-joined."""
    return ";".join('"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"' for v in values)


def _bed(setup: FdmSetup) -> list[str]:
    w, d = (f"{v:g}" for v in setup.build_mm[:2])
    return ["0x0", f"{w}x0", f"{w}x{d}", f"0x{d}"]


def prusa_print_config(design_name: str, assembly: Assembly, layout: BedLayout, library: MaterialLibrary) -> str:
    """``Metadata/Slic3r_PE.config``: an FFF printer with one extruder per body."""
    s = layout.setup
    n = len(assembly.bodies)
    colours = tool_colours(assembly, library)
    matrix, extruders = _purge(n, s)
    rows = [
        ("printer_technology", "FFF"),
        ("bed_shape", ",".join(_bed(s))),
        ("max_print_height", f"{s.build_mm[2]:g}"),
        ("nozzle_diameter", ",".join([f"{s.nozzle_mm:g}"] * n)),
        ("extruder_offset", ",".join(["0x0"] * n)),
        ("extruder_colour", _quoted(colours)),
        ("filament_colour", _quoted(colours)),
        ("filament_diameter", ",".join([f"{s.filament_mm:g}"] * n)),
        ("filament_settings_id", _quoted(b.material for b in assembly.bodies)),
        ("single_extruder_multi_material", "1" if s.single_nozzle else "0"),
        ("layer_height", f"{s.layer_mm:g}"),
        ("first_layer_height", f"{s.layer_mm:g}"),
        ("use_relative_e_distances", "1"),
        ("wipe_tower", "0" if layout.tower_xy is None else "1"),
        ("wipe_tower_width", f"{s.tower_width_mm:g}"),
        ("wiping_volumes_matrix", ",".join(matrix)),
        ("wiping_volumes_extruders", ",".join(extruders)),
    ]
    if layout.tower_xy is not None:
        rows += [("wipe_tower_x", f"{layout.tower_xy[0]:g}"), ("wipe_tower_y", f"{layout.tower_xy[1]:g}")]
    head = (f"; generated by foldprint {__version__} for {design_name}: one extruder per material "
            f"({n}), {s.source}\n")
    return head + "".join(f"; {k} = {v}\n" for k, v in rows)


def orca_project_settings(design_name: str, assembly: Assembly, layout: BedLayout, library: MaterialLibrary) -> str:
    """``Metadata/project_settings.config``: one filament per body (JSON)."""
    s = layout.setup
    n = len(assembly.bodies)
    nozzles = 1 if s.single_nozzle else n
    colours = tool_colours(assembly, library)
    matrix, vector = _purge(n, s)
    doc = {
        "name": "project_settings",
        "from": "project",
        "printer_technology": "FFF",
        "printer_settings_id": f"foldprint {design_name}: {s.source}",
        "print_settings_id": f"foldprint {design_name}",
        "printable_area": _bed(s),
        "printable_height": f"{s.build_mm[2]:g}",
        "nozzle_diameter": [f"{s.nozzle_mm:g}"] * nozzles,
        "extruder_colour": colours if nozzles == n else [colours[0]],
        "extruder_offset": ["0x0"] * nozzles,
        "single_extruder_multi_material": "1" if s.single_nozzle else "0",
        "filament_settings_id": [b.material for b in assembly.bodies],
        "filament_colour": colours,
        "filament_diameter": [f"{s.filament_mm:g}"] * n,
        "layer_height": f"{s.layer_mm:g}",
        "initial_layer_print_height": f"{s.layer_mm:g}",
        "enable_prime_tower": "0" if layout.tower_xy is None else "1",
        "prime_tower_width": f"{s.tower_width_mm:g}",
        "flush_volumes_matrix": matrix,
        "flush_volumes_vector": vector,
    }
    if layout.tower_xy is not None:
        doc["wipe_tower_x"] = [f"{layout.tower_xy[0]:g}"]
        doc["wipe_tower_y"] = [f"{layout.tower_xy[1]:g}"]
    return json.dumps(doc, indent=4, sort_keys=True) + "\n"
