"""Solids and their checks: results (Body, Assembly, Piece), manifold3d helpers,
robust 2D cleaning and extrusion. Shared constants of the geometry package live here."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import manifold3d as mf
import numpy as np
import shapely
from shapely.geometry import MultiPolygon, Polygon
from shapely.geometry.polygon import orient

from ..core.errors import GeometryError
from ..core.modes import State

STATES = tuple(s.value for s in State)  # the build states, as text (messages)
#: Largest bend per slice of a curved hinge (rad). A chord slice keeps sin(a)/a of the
#: arc's volume: 5 deg loses at most 0.127 % (see :data:`BEND_VOLUME_RATIO_MIN`).
MAX_SLICE_RAD = math.radians(5.0)
BEND_VOLUME_RATIO_MIN = math.sin(MAX_SLICE_RAD) / MAX_SLICE_RAD
#: Triangular teeth stand on a land (a thin band along the strip edge) of this fraction
#: of the tooth depth, so neighbouring teeth never touch along a bare edge.
TOOTH_LAND_FRACTION = 0.1
#: Margin kept free of teeth at each end of a hinge segment, as a fraction of the pitch.
TOOTH_END_MARGIN = 0.25
#: 2D pieces smaller than this (mm^2) are dropped (never creates overlap: a dropped
#: tooth is not subtracted from its panel either).
MIN_AREA = 1e-6
#: 2D results whose minimum clearance is below 2 * CLEAN_EPS (spikes, slivers, parts
#: touching at a point, which would give non-manifold or self-overlapping solids) are
#: closed and opened by CLEAN_EPS (mm): features thinner than 0.2 um disappear.
CLEAN_EPS = 1e-4
#: Gap (mm) between the teeth of two hinges that compete for the same panel corner:
#: two pieces of one material touching along an edge would make a non-manifold body.
TEETH_GAP = 0.01
#: Teeth solids reach this far (mm) into their strip, so the two overlap and merge.
TEETH_OVERLAP = 0.01
#: Relative volume tolerance of the internal consistency checks.
VOLUME_RTOL = 1e-6
#: A piece whose lowest point is within this (mm) of the bed starts on the bed.
BED_TOL = 1e-3
#: Facets whose normal is within this angle of straight down count as bottom faces
#: that need something under them (the bed, or support) when printed.
BOTTOM_FACE_RAD = math.radians(5.0)


# -- results ---------------------------------------------------------------------------

@dataclass(frozen=True, eq=False)
class Body:
    """One material's solid: ``vertices`` (n, 3) mm, ``faces`` (m, 3) outward-wound
    triangles, ``volume`` mm^3. Arrays are read-only and canonically ordered."""

    material: str
    vertices: np.ndarray
    faces: np.ndarray
    volume: float
    solid: mf.Manifold | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        v = np.array(self.vertices, dtype=np.float64).reshape(-1, 3)
        f = np.array(self.faces, dtype=np.int64).reshape(-1, 3)
        v.setflags(write=False)
        f.setflags(write=False)
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "faces", f)
        object.__setattr__(self, "volume", float(self.volume))

    @property
    def bounds(self) -> np.ndarray:
        """(2, 3): min and max corner (mm)."""
        return np.array([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    def to_manifold(self) -> mf.Manifold:
        """The solid: the builder's own when the body came from it. (Rebuilding it from
        the arrays is not exact: manifold3d's mesh import swaps edges of needle and cap
        triangles even where the faces they join are not coplanar.)"""
        if self.solid is not None:
            return self.solid
        return solid_from_arrays(self.vertices, self.faces, f"body {self.material!r}")


@dataclass(frozen=True, eq=False)
class Assembly:
    """The printable part: ``bodies`` ordered by the material library."""

    design_name: str
    state: str
    bodies: tuple[Body, ...]
    #: the panels and hinges (each a :class:`Piece` of kind "panel" or "hinge") the
    #: bodies were united from, for per-piece reports (:func:`bed_report`)
    units: tuple["Piece", ...] = field(default=(), repr=False, compare=False)
    #: what the build accepted within a tolerance (loops closed at angles moved from the
    #: targets by less than the design's or the printer's resolution), one sentence each
    notes: tuple[str, ...] = field(default=(), compare=False)

    @property
    def materials(self) -> list[str]:
        return [b.material for b in self.bodies]

    def body(self, material: str) -> Body:
        for b in self.bodies:
            if b.material == material:
                return b
        raise KeyError(f"no body of material {material!r}; materials: {self.materials}")

    @property
    def volume(self) -> float:
        return float(sum(b.volume for b in self.bodies))

    @property
    def bounds(self) -> np.ndarray:
        allb = np.array([b.bounds for b in self.bodies])
        return np.array([allb[:, 0].min(axis=0), allb[:, 1].max(axis=0)])

    @property
    def print_offset(self) -> np.ndarray:
        """(3,) translation from the design's sheet frame (root mid-plane at z = 0) to
        the print frame: the part's lowest point on the bed (z = 0), x and y kept. The
        part prints as built (+z up): see ``docs/geometry-and-export.md``, "On the bed"."""
        return np.array([0.0, 0.0, -float(self.bounds[0][2])]) + 0.0

    def print_z_range(self, body: Body) -> tuple[float, float]:
        """A body's lowest and highest z in the print frame (mm)."""
        lo, hi = body.bounds[:, 2] + self.print_offset[2]
        return float(lo), float(hi)


@dataclass(frozen=True, eq=False)
class Piece:
    """A solid before the per-material union. ``kind``: panel, strip or teeth;
    ``owner``: the panel or hinge id."""

    kind: str
    owner: str
    material: str
    solid: mf.Manifold

    @property
    def volume(self) -> float:
        return float(self.solid.volume())


# -- manifold helpers --------------------------------------------------------------------

def checked_solid(m: mf.Manifold, what: str, expected: float | None = None) -> mf.Manifold:
    """manifold3d never raises: check status, emptiness and volume after each step."""
    status = m.status()
    if status != mf.Error.NoError:
        raise GeometryError(f"{what}: manifold construction failed ({status.name})")
    vol = m.volume()
    if m.is_empty() or not vol > 0:
        raise GeometryError(f"{what}: the solid is empty (volume {vol:g} mm^3)")
    if expected is not None and abs(vol - expected) > VOLUME_RTOL * expected + 1e-12:
        raise GeometryError(f"{what}: volume {vol:.6g} mm^3, expected {expected:.6g} mm^3 "
                            "(self-intersecting or degenerate geometry)")
    return m


def solid_from_arrays(vertices: np.ndarray, faces: np.ndarray, what: str) -> mf.Manifold:
    mesh = mf.Mesh64(vert_properties=np.array(vertices, dtype=np.float64, order="C"),
                     tri_verts=np.array(faces, dtype=np.uint64, order="C"))
    return checked_solid(mf.Manifold(mesh), what)


def polygons_of(geom) -> list[Polygon]:
    """The polygons of any shapely result, dropping slivers, lines and points."""
    if geom is None or geom.is_empty:
        return []
    out = []
    for g in shapely.get_parts(geom):
        if isinstance(g, Polygon) and g.area > MIN_AREA:
            out.append(g)
        elif isinstance(g, (MultiPolygon, shapely.GeometryCollection)):
            out.extend(polygons_of(g))
    return out


def clean_region(geom):
    """The polygons of ``geom`` as one geometry, free of spikes, slivers and pinch
    points; untouched (bit for bit) when it has none."""
    polys = polygons_of(geom)
    if not polys:
        return None
    g = polys[0] if len(polys) == 1 else shapely.union_all(polys)
    if shapely.minimum_clearance(g) >= 2 * CLEAN_EPS:
        return g
    kw = {"join_style": "mitre", "mitre_limit": 50.0}
    cleaned = g.buffer(CLEAN_EPS, **kw).buffer(-2 * CLEAN_EPS, **kw).buffer(CLEAN_EPS, **kw)
    # the buffers recompute every vertex: put back the exact input coordinates wherever
    # the result kept a vertex, so boundaries shared with other pieces stay bit-identical
    ref = shapely.get_coordinates(g)

    def snap(ring):
        c = np.asarray(ring.coords)
        d2 = ((c[:, None, :] - ref[None, :, :]) ** 2).sum(axis=2)
        k = d2.argmin(axis=1)
        near = d2[np.arange(len(c)), k] < (10 * CLEAN_EPS * 1e-3) ** 2
        c[near] = ref[k[near]]
        return c

    polys = []
    for p in polygons_of(cleaned):
        q = Polygon(snap(p.exterior), [snap(r) for r in p.interiors])
        polys.extend(polygons_of(q if q.is_valid else p))
    if not polys:
        return None
    return polys[0] if len(polys) == 1 else shapely.union_all(polys)


def apply_pose(pose: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """``pose`` (4, 4) applied to points (n, 3), element by element (no BLAS), so a
    point shared by two pieces lands on bit-identical coordinates in both."""
    r, t = pose[:3, :3], pose[:3, 3]
    return pts[:, 0:1] * r[:, 0] + pts[:, 1:2] * r[:, 1] + pts[:, 2:3] * r[:, 2] + t


def extrude(geom, thickness: float, pose: np.ndarray, what: str) -> mf.Manifold | None:
    """Extrude a shapely (multi)polygon to ``thickness`` about z = 0, then ``pose``.

    The mesh is built here (caps from ``manifold3d.triangulate``, one quad per ring
    edge) rather than through ``CrossSection``, whose Clipper2 back end rounds
    coordinates to 1e-8 mm: pieces that share a boundary (teeth and notches, strip
    edges) must keep bit-identical vertices to merge or touch cleanly."""
    polys = polygons_of(geom)
    if not polys:
        return None
    verts, faces, n0 = [], [], 0
    half = 0.5 * float(thickness)
    for p in polys:
        p = orient(p, 1.0)  # exterior counter-clockwise, holes clockwise
        rings = [np.asarray(p.exterior.coords, dtype=np.float64)[:-1]]
        rings += [np.asarray(r.coords, dtype=np.float64)[:-1] for r in p.interiors]
        pts = np.concatenate(rings)
        n = len(pts)
        tris = np.asarray(mf.triangulate(rings), dtype=np.int64).reshape(-1, 3)
        faces.append(tris[:, ::-1] + n0)  # bottom cap, facing -z
        faces.append(tris + n0 + n)  # top cap
        start = 0
        for ring in rings:
            k = len(ring)
            a = np.arange(start, start + k) + n0
            b = np.roll(a, -1)
            faces.append(np.stack([a, b, b + n], axis=1))
            faces.append(np.stack([a, b + n, a + n], axis=1))
            start += k
        verts.append(np.column_stack([pts, np.full(n, -half)]))
        verts.append(np.column_stack([pts, np.full(n, half)]))
        n0 += 2 * n
    area = float(sum(p.area for p in polys))
    v = apply_pose(pose, np.concatenate(verts))
    return checked_solid(solid_from_arrays(v, np.concatenate(faces), what), what, area * thickness)
