"""What a voxel print is made of: the voxel pitch of a printer profile
(:func:`voxel_pitch`) and every panel and hinge of a built part with its VeroWhite fraction
profile (:func:`voxel_part`), the :class:`~foldprint.exchange.voxel_regions.VoxelPart` the voxel
writer rasterises (``foldprint export --format voxels``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable

from ..checks.rules import Printer, default_voxel_printer_key, load_printers
from ..core.errors import ExportError
from ..exchange.voxel_regions import TANGO_BLACK, VERO_WHITE, Pitch, Uniform, VoxelPart, VoxelRegion
from ..geometry import Assembly, hinge_axes
from ..model.composition_library import fraction_profile
from ..model.design import Design
from ..model.materials import MaterialLibrary, default_library


def voxel_pitch(printer: str | Printer | None = None, printers_file: str | Path | None = None) -> Pitch:
    """The voxel pitch of a printer profile (``data/printers.toml``, or the profile itself;
    default: the one marked ``voxel_default``, the J750); ExportError names printers that have one."""
    printers = load_printers(printers_file)
    key = printer.key if isinstance(printer, Printer) else printer or default_voxel_printer_key()
    pr = printer if isinstance(printer, Printer) else printers.get(key)
    if pr is None or pr.voxel_mm is None:
        have = sorted(k for k, p in printers.items() if p.voxel_mm is not None)
        what = "unknown printer" if pr is None else "printer without a voxel pitch (voxel_mm)"
        raise ExportError(f"--printer {key!r}: {what}; voxel print knows {have}")
    return Pitch(*pr.voxel_mm, printer=f"{key} ({pr.name})", source=pr.voxel_source)


def voxel_part(design: Design, assembly: Assembly, library: MaterialLibrary | None = None,
               pitch: Pitch | None = None, profiles: Callable | None = None) -> VoxelPart:
    """What the voxel writer writes: every panel and hinge of ``assembly`` (its units)
    with its VeroWhite fraction profile (panels: VeroWhite 1, TangoBlack 0; hinges:
    ``profiles(library, material)``, by default :func:`foldprint.model.composition_library.fraction_profile`)
    and, for hinges, the axes that give u (:func:`foldprint.geometry.hinge_axes`)."""
    lib = library or default_library()
    profiles = profiles or fraction_profile
    axes = hinge_axes(design, assembly.state)
    regions = []
    for u in assembly.units:
        if u.kind == "panel":
            if u.material not in (VERO_WHITE, TANGO_BLACK):
                raise ExportError(f"panel {u.owner!r}: material {u.material!r} is not a base resin; voxel print "
                                  f"jets panels in {VERO_WHITE} or {TANGO_BLACK} (set the panel's material)")
            prof = Uniform(1.0 if u.material == VERO_WHITE else 0.0)
            regions.append(VoxelRegion("panel", u.owner, u.material, u.solid, prof))
        else:
            regions.append(VoxelRegion("hinge", u.owner, u.material, u.solid, profiles(lib, u.material),
                                       axes.get(u.owner)))
    return VoxelPart(design.name, assembly.state, tuple(regions), pitch or voxel_pitch(), assembly.print_offset)
