"""What the still renders and the fold animation draw: the design in world coordinates
at given panel poses, a fixed camera per design, and the times worth drawing.

Every panel is its rigid polygon (holes included, :func:`foldprint.collision.rigid.rigid_polygon`)
at the mid-surface, moved by its pose and shaded by a fixed light; hinges are lines on the
fold line (``point`` model) or curved ribbons through :func:`foldprint.physics.kinematics.hinge_map`
(``arc``). A :class:`Scene` is plain numpy data: :mod:`foldprint.render.stills` projects and
draws it, :mod:`foldprint.render.anim` animates it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from ..core.display import seconds
from ..core.modes import DEFAULT_HINGE_MODEL, HingeModel, State
from ..model.derived import derived
from ..model.design import Design
from ..physics.kinematics import forward, hinge_frames, hinge_map, target_angles
from ..model.materials import MaterialLibrary

FALLBACK_COLOR = "#9a9a9a"
"""Colour of a panel or hinge whose material is not in the library."""
CONTACT_COLOR = np.array([0.84, 0.15, 0.16])
"""Edge and tint colour of panels in contact."""
_LIGHT = np.array([0.35, -0.55, 0.76])
_LIGHT = _LIGHT / np.linalg.norm(_LIGHT)
_ARC_STEPS = 8  # ribbon segments per arc hinge


@dataclass(frozen=True)
class Camera:
    """A fixed orthographic view: elevation and azimuth (deg), matplotlib's convention."""

    elev: float
    azim: float

    def axes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Unit screen-right, screen-up and toward-the-viewer vectors (world)."""
        e, a = math.radians(self.elev), math.radians(self.azim)
        right = np.array([-math.sin(a), math.cos(a), 0.0])
        up = np.array([-math.sin(e) * math.cos(a), -math.sin(e) * math.sin(a), math.cos(e)])
        eye = np.array([math.cos(e) * math.cos(a), math.cos(e) * math.sin(a), math.sin(e)])
        return right, up, eye


def camera_for(design: Design) -> Camera:
    """Planar strips (every fold line parallel to y): a side view looking along +y, raised
    20 deg so the faces stay visible; other designs: oblique, from the front left, above."""
    if design.is_planar_strip:
        return Camera(elev=20.0, azim=-90.0)
    return Camera(elev=32.0, azim=-58.0)


@dataclass
class Scene:
    """World-space drawables: filled polygons (each a list of rings, outline first) and
    polylines, each with colours and widths."""

    polys: list = field(default_factory=list)  # list of list[(k, 3)]
    face_colors: list = field(default_factory=list)
    edge_colors: list = field(default_factory=list)  # None: edge in the face colour (no outline)
    edge_widths: list = field(default_factory=list)
    lines: list = field(default_factory=list)  # (k, 3)
    line_colors: list = field(default_factory=list)
    line_widths: list = field(default_factory=list)

    def points(self) -> np.ndarray:
        parts = [r for p in self.polys for r in p] + list(self.lines)
        return np.concatenate(parts) if parts else np.zeros((1, 3))


def _rings(design: Design, model: HingeModel) -> list[tuple[np.ndarray, ...]]:
    """Outline and hole rings (sheet frame, outline counter-clockwise) of each rigid panel
    part, once per active derived-data cache (:mod:`foldprint.model.derived`)."""
    return derived(design, ("render_rings", str(model)), lambda: _compute_rings(design, model))


def _compute_rings(design: Design, model: str) -> list[tuple[np.ndarray, ...]]:
    import shapely

    from ..collision.rigid import rigid_polygons

    out = []
    for poly in rigid_polygons(design, model):
        if poly.is_empty:
            out.append(())
            continue
        polys = list(getattr(poly, "geoms", [poly]))
        rings = []
        for p in polys:
            p = shapely.orient_polygons(p)
            rings.append(np.asarray(p.exterior.coords)[:-1])
            rings.extend(np.asarray(r.coords)[:-1] for r in p.interiors)
        out.append(tuple(rings))
    return out


@functools.lru_cache(maxsize=256)
def _rgb(color: str) -> tuple[float, float, float]:
    from matplotlib.colors import to_rgb

    return to_rgb(color)


def rgb(color: str) -> np.ndarray:
    return np.array(_rgb(color))


def material_rgb(lib: MaterialLibrary, name: str) -> np.ndarray:
    return rgb(lib[name].color if name in lib else FALLBACK_COLOR)


def _shade(color: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Two-sided diffuse shading with a fixed light: faces keep 55-100 % of their colour."""
    k = 0.55 + 0.45 * abs(float(normal @ _LIGHT))
    return np.clip(color * k, 0.0, 1.0)


def _hinge_angle(frame, pose_parent: np.ndarray, pose_child: np.ndarray) -> float:
    """Signed hinge angle recovered from two poses (rotation of child about the hinge axis)."""
    rel = pose_parent[:3, :3].T @ pose_child[:3, :3]
    vee = 0.5 * np.array([rel[2, 1] - rel[1, 2], rel[0, 2] - rel[2, 0], rel[1, 0] - rel[0, 1]])
    return math.atan2(float(vee @ frame.axis), 0.5 * (np.trace(rel) - 1.0))


def scene(design: Design, poses: np.ndarray, model: HingeModel, lib: MaterialLibrary,
          highlight: Iterable[int] = ()) -> Scene:
    """The drawables of ``design`` at ``poses`` (n_panels, 4, 4); ``highlight``: panel
    indices in contact (tinted and outlined red)."""
    hl = set(highlight)
    sc = Scene()
    for i, (panel, rings) in enumerate(zip(design.panels, _rings(design, model))):
        if not rings:
            continue
        pose = poses[i]
        base = material_rgb(lib, panel.material)
        if i in hl:
            base = 0.55 * base + 0.45 * CONTACT_COLOR
        sc.polys.append([r @ pose[:3, :2].T + pose[:3, 3] for r in rings])
        sc.face_colors.append(_shade(base, pose[:3, 2]))
        sc.edge_colors.append(CONTACT_COLOR if i in hl else base * 0.4)
        sc.edge_widths.append(1.6 if i in hl else 0.7)
    for f in hinge_frames(design):
        h = f.hinge
        color = material_rgb(lib, h.material)
        pp, pc = poses[f.parent], poses[f.child]
        if model == HingeModel.POINT or f.width <= 0:
            line = np.column_stack([np.asarray(h.line, float), np.zeros(2)])
            sc.lines.append(line @ pp[:3, :3].T + pp[:3, 3])
            sc.line_colors.append(color)
            sc.line_widths.append(2.6)
            continue
        # arc: a ribbon of uniform curvature from the parent's rigid edge to the child's,
        # through the same hinge map the simulation and the printed geometry use
        s = np.linspace(0.0, 1.0, _ARC_STEPS + 1)
        maps = pp[None] @ hinge_map(f, _hinge_angle(f, pp, pc), HingeModel.ARC, s)
        curves = []
        for e in np.asarray(h.line):
            line = (np.array([e[0], e[1], 0.0]) - 0.5 * f.width * f.normal)[None] \
                + (f.width * s)[:, None] * f.normal[None]
            curves.append(np.einsum("nij,nj->ni", maps[:, :3, :3], line) + maps[:, :3, 3])
        c0, c1 = curves
        quads = np.stack([c0[:-1], c0[1:], c1[1:], c1[:-1]], axis=1)  # (steps, 4, 3)
        nrm = np.cross(quads[:, 1] - quads[:, 0], quads[:, 3] - quads[:, 0])
        nn = np.linalg.norm(nrm, axis=1, keepdims=True)
        nrm = np.where(nn > 0, nrm / np.where(nn > 0, nn, 1.0), np.array([0.0, 0.0, 1.0]))
        k_shade = 0.55 + 0.45 * np.abs(nrm @ _LIGHT)
        sc.polys.extend([q] for q in quads)
        sc.face_colors.extend(np.clip(color[None] * k_shade[:, None], 0.0, 1.0))  # one clip, not one a quad
        sc.edge_colors.extend([None] * len(quads))
        sc.edge_widths.extend([0.3] * len(quads))
        for c in curves:
            sc.lines.append(c)
            sc.line_colors.append(color * 0.4)
            sc.line_widths.append(1.2)
    return sc


# -- poses and times ------------------------------------------------------------------------

def state_poses(design: Design, state: State, model: HingeModel = DEFAULT_HINGE_MODEL) -> np.ndarray:
    """Panel poses (n_panels, 4, 4) of ``state``: ``programmed`` (flat, every angle 0) or
    ``permanent`` (every hinge at its target angle), by the ``model`` kinematics."""
    if state == State.PROGRAMMED:
        angles = np.zeros(len(design.hinges))
    elif state == State.PERMANENT:
        angles = target_angles(design)
    else:
        raise ValueError(f"state must be 'programmed' or 'permanent', got {state!r}")
    return forward(design, angles[None], model)[0]


def motion_end(result) -> float:
    """Time (s) after which nothing visibly moves: the latest 98 % fold time of a hinge
    that folds, plus 5 %, clipped to the simulated duration (the duration if none folds)."""
    traj = result.trajectory
    t_max = float(traj.times[-1])
    ft = [t for t in traj.fold_times if t is not None]
    if not ft:
        return t_max
    return float(min(t_max, 1.05 * max(ft)))


def poses_at(result, times) -> np.ndarray:
    """(n, n_panels, 4, 4) poses at ``times`` (s): hinge angles interpolated linearly
    between the trajectory's samples, then its forward kinematics, so a frame can sit
    exactly on a contact."""
    traj = result.trajectory
    t = np.atleast_1d(np.asarray(times, float))
    angles = np.zeros((len(t), traj.angles.shape[1]))
    for k in range(traj.angles.shape[1]):
        angles[:, k] = np.interp(t, traj.times, traj.angles[:, k])
    return forward(result.design, angles, traj.model)


def frame_times(result, n: int = 4) -> np.ndarray:
    """``n`` sorted mid-fold times in (0, :func:`motion_end`], evenly spread; the one
    nearest the first collision (during the motion) is moved onto it."""
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    end = motion_end(result)
    times = end * np.arange(1, n + 1) / (n + 1)
    c = result.first_collision
    if c is not None and 0.0 < c.time <= end:
        times[int(np.argmin(np.abs(times - c.time)))] = c.time
    return np.sort(times)


def contact_state(result, t: float) -> tuple[set[int], str]:
    """Panels in contact at or before ``t`` and a title suffix naming the first contact."""
    hl: set[int] = set()
    note = ""
    for c in result.contacts:
        if c.time <= t + 1e-9:
            hl.update(int(i) for i in c.pair)
    first = result.first_collision
    if first is not None and first.time <= t + 1e-9:
        note = f" | contact {first.panels[0]}\u2013{first.panels[1]} at {seconds(first.time)}"
    return hl, note
