"""What the voxel writer (:mod:`foldprint.exchange.voxels`) receives and the grid it
slices: the voxel :class:`Pitch`, one :class:`VoxelRegion` per panel and hinge (its
solid, its VeroWhite fraction profile, for a graded hinge the axes that give u, or a
:class:`Uniform` fraction), the :class:`VoxelPart` of them all and its :class:`Grid`
(``docs/voxels.md``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import manifold3d as mf
import numpy as np

from ..core.errors import ExportError

#: the two base resins (names as in the material library)
VERO_WHITE, TANGO_BLACK = "VeroWhite", "TangoBlack"


@dataclass(frozen=True)
class Pitch:
    """Voxel size (mm) in x, y and z (layer), and where it comes from."""

    x: float
    y: float
    z: float
    printer: str = ""
    source: str = ""

    def __post_init__(self):
        for k in ("x", "y", "z"):
            v = getattr(self, k)
            if not (math.isfinite(v) and v > 0):
                raise ExportError(f"voxel pitch {k} must be a positive length in mm, got {v!r}")

    @property
    def dpi(self) -> tuple[float, float]:
        return 25.4 / self.x, 25.4 / self.y


@dataclass(frozen=True)
class Uniform:
    """A constant VeroWhite fraction (panels: 1 or 0); the FractionProfile interface."""

    value: float
    along: Any = None

    def at(self, u: np.ndarray) -> np.ndarray:
        return np.full(np.shape(u), float(self.value))

    @property
    def mean(self) -> float:
        return float(self.value)

    @property
    def knots(self) -> tuple[float, ...]:
        return (float(self.value),)


@dataclass(frozen=True)
class VoxelRegion:
    """One panel or hinge to rasterise: its solid (sheet frame, mm), its VeroWhite
    fraction profile (``.at(u)``, ``.knots``, ``.along``: None, WIDTH or LENGTH) and, for a
    profile that varies, the hinge axes that give u."""

    kind: str  # "panel" | "hinge"
    id: str
    material: str
    solid: mf.Manifold = field(repr=False)
    profile: Any
    axes: Any = field(default=None, repr=False)

    @property
    def constant(self) -> float | None:
        knots = tuple(self.profile.knots)
        if len(set(knots)) == 1:
            return float(knots[0])
        return None

    @property
    def along_length(self) -> bool:
        return getattr(self.profile.along, "name", str(self.profile.along)).upper().endswith("LENGTH")

    def fraction(self, p: np.ndarray, width_u: Callable | None = None) -> np.ndarray:
        """VeroWhite fraction at points (n, 3); ``width_u`` replaces ``axes.width_u``
        (the writer's tabulated u)."""
        c = self.constant
        if c is not None:
            return np.full(len(p), c)
        if self.axes is None:
            raise ExportError(f"{self.kind} {self.id!r}: a graded fraction needs the hinge's axes")
        u = self.axes.length_u(p) if self.along_length else (width_u or self.axes.width_u)(p)
        return np.clip(np.asarray(self.profile.at(u), dtype=float), 0.0, 1.0)


@dataclass(frozen=True)
class VoxelPart:
    """Everything the voxel writer writes: the regions, the pitch and the print offset
    (sheet frame -> print frame, ``Assembly.print_offset``)."""

    design: str
    state: str
    regions: tuple[VoxelRegion, ...]
    pitch: Pitch
    print_offset: np.ndarray

    def grid(self) -> "Grid":
        lo = np.min([r.solid.bounding_box()[:3] for r in self.regions], axis=0)
        hi = np.max([r.solid.bounding_box()[3:] for r in self.regions], axis=0)
        p = self.pitch
        n = [max(1, int(math.ceil((hi[i] - lo[i]) / s - 1e-9))) for i, s in enumerate((p.x, p.y, p.z))]
        return Grid(lo, tuple(n), p)


@dataclass(frozen=True)
class Grid:
    """The voxel grid: ``origin`` (sheet frame, the lower corner), ``shape`` (nx, ny, nz)."""

    origin: np.ndarray
    shape: tuple[int, int, int]
    pitch: Pitch

    def layer_z(self, k: int) -> float:
        return float(self.origin[2] + (k + 0.5) * self.pitch.z)


def part_size(regions, pitch: Pitch) -> tuple[int, int, int]:
    """(nx, ny, nz) of the grid the regions need (for the guard, before any slicing)."""
    return VoxelPart("", "", tuple(regions), pitch, np.zeros(3)).grid().shape
