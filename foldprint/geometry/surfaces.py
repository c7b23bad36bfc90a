"""The fold over time as moving surfaces: what the time-series writers (XDMF, glTF) draw.

Each panel's rigid part (its outline less the hinge strips and teeth notches, holes
kept) and each hinge segment (the strip's mid-surface between slots) is a triangulated
surface in the flat sheet (z = 0). A panel moves rigidly with its pose; a hinge segment
bends with the arc map across its width (:func:`foldprint.geometry.arc_transform`),
column by column, exactly as the printed strip is built (``docs/geometry-and-export.md``).
:func:`fold_frames` places every surface at every time step of a simulated trajectory
and hands the writers a :class:`Frames` (``foldprint.apps.pipeline.Evaluation.frames``):
they format these points and compute none.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import manifold3d as mf
import numpy as np
from shapely.geometry.polygon import orient

from ..core.errors import ExportError
from ..core.modes import HingeModel
from ..model.design import Design
from ..physics.kinematics import HingeFrame, Trajectory, local_transforms
from .hinges import strip_profile
from .layout import layout
from .solids import polygons_of


@dataclass(frozen=True, eq=False)
class Surface:
    """One moving surface: ``kind`` "panel" or "hinge", ``owner`` its panel or hinge
    id, ``segment`` (hinges: which slot-separated segment), ``material``; ``flat`` (n, 3)
    sheet points, ``triangles`` (m, 3) counter-clockwise seen from +z; for a panel
    ``index`` is the panel index, for a hinge the hinge index with its ``frame`` and the
    across-strip coordinate ``u`` (n,) of each point."""

    kind: str
    owner: str
    segment: int
    material: str
    index: int
    flat: np.ndarray
    triangles: np.ndarray
    frame: HingeFrame | None = None
    u: np.ndarray | None = None

    def track(self, poses: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """World points (n_t, n, 3) for panel poses (n_t, n_panels, 4, 4) and hinge
        angles (n_t, n_hinges). A hinge column at width u moves like the arc model's
        child of a strip of width u bent by rho u / w (what
        :func:`~foldprint.geometry.arc_transform` computes one time at a time)."""
        if self.kind == "panel":
            pose = poses[:, self.index]
            return np.einsum("tij,nj->tni", pose[:, :3, :3], self.flat) + pose[:, None, :3, 3]
        f = self.frame
        out = np.empty((len(poses), len(self.flat), 3))
        start = f.origin - 0.5 * f.width * f.normal
        for u in np.unique(self.u):
            sel = self.u == u
            sub = replace(f, origin=start + 0.5 * u * f.normal, width=float(u))
            pose = poses[:, f.parent] @ local_transforms(sub, angles[:, f.index] * (u / f.width), HingeModel.ARC)
            out[:, sel] = np.einsum("tij,nj->tni", pose[:, :3, :3], self.flat[sel]) + pose[:, None, :3, 3]
        return out

    def at(self, poses: np.ndarray, angles: np.ndarray) -> np.ndarray:
        """World points (n, 3) at one time: panel poses (n_panels, 4, 4), hinge angles."""
        return self.track(poses[None], np.asarray(angles)[None])[0]


def fold_surfaces(design: Design) -> list[Surface]:
    """Panels (design order), then hinge segments (design order)."""
    lays, rigid = layout(design)
    out: list[Surface] = []
    for k, (p, geom) in enumerate(zip(design.panels, rigid)):
        verts, tris, n0 = [], [], 0
        for poly in polygons_of(geom):
            poly = orient(poly, 1.0)
            rings = [np.asarray(poly.exterior.coords)[:-1]] + [np.asarray(r.coords)[:-1] for r in poly.interiors]
            t = np.asarray(mf.triangulate(rings), dtype=np.int64).reshape(-1, 3)
            pts = np.concatenate(rings)
            verts.append(pts)
            tris.append(t + n0)
            n0 += len(pts)
        if not verts:
            raise ExportError(f"panel {p.id!r}: no rigid part to draw")
        xy = np.concatenate(verts)
        out.append(Surface("panel", p.id, 0, p.material, k, np.column_stack([xy, np.zeros(len(xy))]),
                           np.concatenate(tris)))
    for lay in sorted(lays, key=lambda lay_: lay_.frame.index):
        h, f = lay.hinge, lay.frame
        u, _ = strip_profile(h, h.angle)
        n3 = np.array([lay.n[0], lay.n[1], 0.0])
        d3 = np.array([lay.d[0], lay.d[1], 0.0])
        base = np.array([lay.p0[0], lay.p0[1], 0.0])
        for s, (v0, v1) in enumerate(lay.segments):
            uu = np.concatenate([u, u])
            vv = np.concatenate([np.full(len(u), v0), np.full(len(u), v1)])
            flat = base + vv[:, None] * d3 + (uu - 0.5 * h.width)[:, None] * n3
            m = len(u)
            a = np.arange(m - 1)
            tris = np.concatenate([np.stack([a, a + 1, a + 1 + m], 1), np.stack([a, a + 1 + m, a + m], 1)])
            # counter-clockwise seen from +z: flip when (n, d) is a left-handed pair
            if np.cross(n3, d3)[2] < 0:
                tris = tris[:, ::-1]
            out.append(Surface("hinge", h.id, s, h.material, f.index, flat, tris, f, uu))
    return out


@dataclass(frozen=True, eq=False)
class Frames:
    """The fold over time as the time-series writers draw it, computed before they run:
    ``times`` (n_t,) s; ``poses`` (n_t, n_panels, 4, 4) every panel's pose (mm);
    ``surfaces`` (:func:`fold_surfaces`: panels, then hinge segments) and ``points``, for
    each surface its world points (n_t, n, 3) mm at every time; ``model``, the hinge
    model of the trajectory (always arc: the printed hinges); ``panel_strain`` (n_t,
    n_panels), a bar-and-hinge run's largest bar strain in each panel at each time (None
    for rigid mechanics). The arrays are read-only."""

    times: np.ndarray
    poses: np.ndarray
    surfaces: tuple[Surface, ...]
    points: tuple[np.ndarray, ...]
    model: HingeModel
    panel_strain: np.ndarray | None = None


def fold_frames(design: Design, trajectory: Trajectory, compliant=None) -> Frames:
    """Every surface of ``design`` (:func:`fold_surfaces`) placed at every time of the
    simulated ``trajectory`` (arc hinges; ExportError otherwise); with a bar-and-hinge
    run's ``compliant`` solution, each panel's strain at those times (step-wise: the
    solved step at or before each time)."""
    surfaces = fold_surfaces(design)
    times, poses, angles = frames_of(trajectory)
    points = tuple(s.track(poses, angles) for s in surfaces)
    strain = None
    if compliant is not None:
        k = np.clip(np.searchsorted(compliant.grid, times, side="right") - 1, 0, len(compliant.grid) - 1)
        strain = _read_only(compliant.panel_strain[k])
    return Frames(_read_only(times), _read_only(poses), tuple(surfaces), tuple(_read_only(p) for p in points),
                  trajectory.model, strain)


def _read_only(a: np.ndarray) -> np.ndarray:
    """A read-only copy of ``a`` (the frames never alias the trajectory's arrays)."""
    out = np.array(a)
    out.setflags(write=False)
    return out


def frames_of(trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (n_t,), panel poses (n_t, n_panels, 4, 4) and hinge angles (n_t, n_hinges)."""
    if trajectory.model != HingeModel.ARC:
        raise ExportError(f"the fold's time series show the printed (arc) hinges; the trajectory was "
                          f"simulated with '{trajectory.model}' hinges")
    return np.asarray(trajectory.times), np.asarray(trajectory.poses), np.asarray(trajectory.angles)
