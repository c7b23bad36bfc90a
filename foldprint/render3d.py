"""Headless 3D renders of a design: still states, mid-fold frames and a fold GIF.

Every panel is drawn as its rigid polygon (holes included, from
:func:`foldprint.rigid.rigid_polygon`) at the panel's mid-surface, moved by its pose and
coloured by its material; hinges are drawn in their material's colour: a line on the
fold line under the ``point`` model, a curved ribbon under the ``arc`` model. The camera
is fixed per design (:func:`camera_for`): planar strips are seen from the side, looking
along +y, so the xz view shows the fold as in the paper's figures.

Only matplotlib's Agg canvas is used (no pyplot state, no display), nothing is written
here: functions return a :class:`matplotlib.figure.Figure` or bytes. Output is
deterministic: the same design and result give byte-identical PNG/GIF data.
"""

from __future__ import annotations

import functools
import io
import logging
import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np

from .design import Design
from .kinematics import forward, hinge_frames, hinge_map, target_angles
from .materials import MaterialLibrary, default_library

log = logging.getLogger(__name__)

FALLBACK_COLOR = "#9a9a9a"
"""Colour of a panel or hinge whose material is not in the library."""
CONTACT_COLOR = (0.84, 0.15, 0.16)
"""Edge and tint colour of panels in contact."""
_BACKGROUND = "white"
_LIGHT = np.array([0.35, -0.55, 0.76])
_LIGHT = _LIGHT / np.linalg.norm(_LIGHT)
_ARC_STEPS = 8  # ribbon segments per arc hinge
_TITLE_IN = 0.32  # title band above a view (in)
_HEAD_IN = 0.4  # figure title band above a frame grid (in)


@dataclass(frozen=True)
class Camera:
    """A fixed view: matplotlib elevation and azimuth (deg), orthographic projection."""

    elev: float
    azim: float


def camera_for(design: Design) -> Camera:
    """The camera used for ``design``.

    Parameters
    ----------
    design : Design
        The design to view.

    Returns
    -------
    Camera
        Planar strips (every fold line parallel to y): a side view looking along +y,
        raised by 20 deg so the panels' faces stay visible; other designs: an oblique
        view from the front left and above.
    """
    if design.is_planar_strip:
        return Camera(elev=20.0, azim=-90.0)
    return Camera(elev=32.0, azim=-58.0)


# -- geometry --------------------------------------------------------------------------

@dataclass(frozen=True)
class _PanelGeometry:
    pieces: tuple[np.ndarray, ...]  # convex pieces (k, 2), sheet frame
    rings: tuple[np.ndarray, ...]  # outline and hole rings (k, 2), closed


def _panel_geometry(design: Design, model: str) -> list[_PanelGeometry]:
    """Convex pieces and boundary rings of every panel's rigid part (cached on the design)."""
    from .rigid import convex_pieces, rigid_polygon

    cache = design.__dict__.setdefault("_render3d_cache", {})
    if model in cache:
        return cache[model]
    out = []
    for i in range(len(design.panels)):
        poly = rigid_polygon(design, i, model)
        if poly.is_empty:
            out.append(_PanelGeometry((), ()))
            continue
        rings = [np.asarray(poly.exterior.coords)] + [np.asarray(r.coords) for r in poly.interiors]
        out.append(_PanelGeometry(tuple(convex_pieces(poly)), tuple(rings)))
    cache[model] = out
    return out


def _to_world(pose: np.ndarray, pts2d: np.ndarray) -> np.ndarray:
    return pts2d @ pose[:3, :2].T + pose[:3, 3]


def _rgb(color: str) -> np.ndarray:
    from matplotlib.colors import to_rgb

    return np.array(to_rgb(color))


def _material_rgb(lib: MaterialLibrary, name: str) -> np.ndarray:
    return _rgb(lib[name].color if name in lib else FALLBACK_COLOR)


def _shade(rgb: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Two-sided diffuse shading with a fixed light: faces keep 55-100 % of their colour."""
    k = 0.55 + 0.45 * abs(float(normal @ _LIGHT))
    return np.clip(rgb * k, 0.0, 1.0)


def _edge_of(rgb: np.ndarray) -> np.ndarray:
    return rgb * 0.4




def _hinge_angle(frame, pose_parent: np.ndarray, pose_child: np.ndarray) -> float:
    """Signed hinge angle recovered from two poses (rotation of child about the hinge axis)."""
    rel = pose_parent[:3, :3].T @ pose_child[:3, :3]
    vee = 0.5 * np.array([rel[2, 1] - rel[1, 2], rel[0, 2] - rel[2, 0], rel[1, 0] - rel[0, 1]])
    return math.atan2(float(vee @ frame.axis), 0.5 * (np.trace(rel) - 1.0))


@dataclass
class _Scene:
    faces: list  # (k, 3) world polygons
    face_colors: list
    edges: list  # (2, 3) world segments
    edge_colors: list
    edge_widths: list
    hinge_lines: list
    hinge_colors: list

    def points(self) -> np.ndarray:
        parts = [f for f in self.faces] + [s for s in self.edges] + [s for s in self.hinge_lines]
        return np.concatenate(parts) if parts else np.zeros((1, 3))


def _scene(design: Design, poses: np.ndarray, model: str, lib: MaterialLibrary,
           highlight: Iterable[int] = ()) -> _Scene:
    """World-space polygons and lines of ``design`` at ``poses`` (n_panels, 4, 4)."""
    geom = _panel_geometry(design, model)
    hl = set(highlight)
    sc = _Scene([], [], [], [], [], [], [])
    for i, (panel, g) in enumerate(zip(design.panels, geom)):
        pose = poses[i]
        normal = pose[:3, 2]
        base = _material_rgb(lib, panel.material)
        if i in hl:
            base = 0.55 * base + 0.45 * np.array(CONTACT_COLOR)
        face = _shade(base, normal)
        for piece in g.pieces:
            sc.faces.append(_to_world(pose, piece))
            sc.face_colors.append(face)
        edge = np.array(CONTACT_COLOR) if i in hl else _edge_of(base)
        for ring in g.rings:
            w = _to_world(pose, ring)
            for a, b in zip(w[:-1], w[1:]):
                sc.edges.append(np.array([a, b]))
                sc.edge_colors.append(edge)
                sc.edge_widths.append(1.6 if i in hl else 0.7)
    for f in hinge_frames(design):
        h = f.hinge
        color = _material_rgb(lib, h.material)
        pp, pc = poses[f.parent], poses[f.child]
        if model == "point" or f.width <= 0:
            sc.hinge_lines.append(_to_world(pp, np.asarray(h.line)))
            sc.hinge_colors.append(color)
            continue
        # arc: a ribbon of uniform curvature from the parent's rigid edge to the child's,
        # through the same hinge map the simulation and the printed geometry use
        a = _hinge_angle(f, pp, pc)
        s = np.linspace(0.0, 1.0, _ARC_STEPS + 1)
        maps = pp[None] @ hinge_map(f, a, "arc", s)
        curves = []
        for e in np.asarray(h.line):
            line = (np.array([e[0], e[1], 0.0]) - 0.5 * f.width * f.normal)[None] \
                + (f.width * s)[:, None] * f.normal[None]
            curves.append(np.einsum("nij,nj->ni", maps[:, :3, :3], line) + maps[:, :3, 3])
        c0, c1 = curves
        for k in range(_ARC_STEPS):
            quad = np.array([c0[k], c0[k + 1], c1[k + 1], c1[k]])
            nrm = np.cross(quad[1] - quad[0], quad[3] - quad[0])
            nn = np.linalg.norm(nrm)
            sc.faces.append(quad)
            sc.face_colors.append(_shade(color, nrm / nn if nn > 0 else np.array([0.0, 0.0, 1.0])))
        for c in curves:
            for k in range(_ARC_STEPS):
                sc.hinge_lines.append(np.array([c[k], c[k + 1]]))
                sc.hinge_colors.append(_edge_of(color))
    return sc


def _limits(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre and half-extent per axis (mm), with a floor so flat states keep a box."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    centre = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    floor = max(0.04 * float(half.max()), 1.0)
    half = np.maximum(half, floor) * 1.04
    return centre, half


def _screen_axes(camera: Camera) -> tuple[np.ndarray, np.ndarray]:
    """Unit screen-right and screen-up vectors (world) of matplotlib's view."""
    e, a = math.radians(camera.elev), math.radians(camera.azim)
    right = np.array([-math.sin(a), math.cos(a), 0.0])
    up = np.array([-math.sin(e) * math.cos(a), -math.sin(e) * math.sin(a), math.cos(e)])
    return right, up


def _projected_size(limits, camera: Camera) -> tuple[float, float, np.ndarray]:
    """Width and height (mm) of the limits box on screen, and each axis' screen length."""
    _, half = limits
    right, up = _screen_axes(camera)
    w = float(np.sum(np.abs(right) * 2 * half))
    h = float(np.sum(np.abs(up) * 2 * half))
    lengths = 2 * half * np.hypot(right, up)
    return w, h, lengths


# -- layout ----------------------------------------------------------------------------
#
# mplot3d keeps room for its box at any rotation, so a long flat box (a strip seen from the
# side) uses a small part of its axes. Each view is therefore fitted once in a probe
# figure: the drawn extent (non-white pixels) is measured and the axes rectangle scaled
# about it until the drawing fills the probe; the view's cell is then cut to the drawing.
# The same limits and camera give the same box in every frame, so one probe serves a
# whole animation or frame grid.

@dataclass(frozen=True)
class _View:
    """A fitted view: cell size (in) and the axes rectangle (in) relative to the cell."""

    width: float
    height: float
    rect: tuple[float, float, float, float]


def _new_figure(figsize: tuple[float, float], dpi: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi, facecolor=_BACKGROUND)
    FigureCanvasAgg(fig)
    return fig


@functools.cache
def _axes_class():
    """Axes3D whose tight bbox is clipped to the figure: a fitted axes reaches past its
    cell, and ``savefig(bbox_inches="tight")`` must not grow the canvas for it."""
    from matplotlib.transforms import Bbox
    from mpl_toolkits.mplot3d import Axes3D

    class FittedAxes3D(Axes3D):
        def get_tightbbox(self, renderer=None, *args, **kwargs):
            bb = super().get_tightbbox(renderer, *args, **kwargs)
            if bb is None:
                return None
            clipped = Bbox.intersection(bb, self.get_figure(root=True).bbox)
            return clipped if clipped is not None else bb

    return FittedAxes3D


def _figure_rgb(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


def _ink(fig) -> tuple[float, float, float, float] | None:
    """Bounding box (x0, y0, x1, y1), figure fractions, of everything not white."""
    rgb = _figure_rgb(fig)
    h, w = rgb.shape[:2]
    ink = (rgb < 250).any(axis=-1)
    if not ink.any():
        return None
    rows, cols = np.nonzero(ink.any(axis=1))[0], np.nonzero(ink.any(axis=0))[0]
    return cols[0] / w, 1 - (rows[-1] + 1) / h, (cols[-1] + 1) / w, 1 - rows[0] / h


def _fit_view(scene: _Scene, limits, camera: Camera, box_in: tuple[float, float], dpi: float,
              fontsize: float, margin_in: float = 0.05) -> _View:
    """Fit one view into at most ``box_in`` (in): the cell it needs and its axes rectangle."""
    bw, bh = box_in
    fig = _new_figure(box_in, dpi)
    ax = fig.add_axes((0.1, 0.1, 0.8, 0.8), axes_class=_axes_class())
    _draw(ax, scene, limits, camera, fontsize)
    mx, my = margin_in / bw, margin_in / bh
    for _ in range(3):  # tick labels do not scale with the axes: iterate
        ink = _ink(fig)
        if ink is None:
            break
        x0, y0, x1, y1 = ink
        s = min((1 - 2 * mx) / (x1 - x0), (1 - 2 * my) / (y1 - y0))
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        pos = ax.get_position(original=True)
        ax.set_position((0.5 + s * (pos.x0 - cx), 0.5 + s * (pos.y0 - cy), s * pos.width, s * pos.height))
    ink = _ink(fig) or (0.0, 0.0, 1.0, 1.0)
    pos = ax.get_position(original=True)
    cw = min(bw, (ink[2] - ink[0]) * bw + 2 * margin_in)
    ch = min(bh, (ink[3] - ink[1]) * bh + 2 * margin_in)
    cx, cy = 0.5 * (ink[0] + ink[2]) * bw, 0.5 * (ink[1] + ink[3]) * bh
    rect = (pos.x0 * bw - (cx - cw / 2), pos.y0 * bh - (cy - ch / 2), pos.width * bw, pos.height * bh)
    return _View(float(cw), float(ch), tuple(float(v) for v in rect))


def _add_view(fig, view: _View, origin_in: tuple[float, float]):
    """A fitted 3D axes with its cell's lower-left corner at ``origin_in`` (in)."""
    fw, fh = fig.get_size_inches()
    x, y, w, h = view.rect
    return fig.add_axes(((origin_in[0] + x) / fw, (origin_in[1] + y) / fh, w / fw, h / fh),
                        axes_class=_axes_class())


def _title(fig, x_in: float, y_in: float, text: str, fontsize: float, **kw):
    fw, fh = fig.get_size_inches()
    return fig.text(x_in / fw, y_in / fh, text, ha="center", va="bottom", fontsize=fontsize, **kw)


def _draw(ax, sc: _Scene, limits, camera: Camera, fontsize: float = 9.0) -> None:
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    centre, half = limits
    ax.patch.set_visible(False)  # the axes is enlarged past its cell (_fit_view)
    ax.set_proj_type("ortho")
    ax.view_init(elev=camera.elev, azim=camera.azim)
    ax.computed_zorder = False
    if sc.faces:
        polys = Poly3DCollection(sc.faces, facecolors=sc.face_colors, edgecolors=sc.face_colors,
                                 linewidths=0.25, zsort="average")
        polys.set_zorder(1)
        ax.add_collection3d(polys)
    if sc.edges:
        lines = Line3DCollection(sc.edges, colors=sc.edge_colors, linewidths=sc.edge_widths)
        lines.set_zorder(2)
        ax.add_collection3d(lines)
    if sc.hinge_lines:
        hinges = Line3DCollection(sc.hinge_lines, colors=sc.hinge_colors, linewidths=2.6,
                                  capstyle="round")
        hinges.set_zorder(3)
        ax.add_collection3d(hinges)
    ax.set_xlim(centre[0] - half[0], centre[0] + half[0])
    ax.set_ylim(centre[1] - half[1], centre[1] + half[1])
    ax.set_zlim(centre[2] - half[2], centre[2] + half[2])
    ax.set_box_aspect(tuple(2 * half))
    ax.tick_params(labelsize=fontsize * 0.7, pad=0)
    _, _, lengths = _projected_size(limits, camera)
    for k, (axis, name) in enumerate(((ax.xaxis, "x"), (ax.yaxis, "y"), (ax.zaxis, "z"))):
        axis.set_pane_color((0.96, 0.96, 0.96, 1.0))
        if lengths[k] < 0.12 * lengths.max():  # seen end-on (the strip's depth): no ticks
            axis.set_ticks([])
            axis.set_label_text("")
            continue
        axis.set_label_text(f"{name} (mm)", fontsize=fontsize * 0.75)
        axis.labelpad = 6


def _as_poses(poses) -> np.ndarray:
    p = np.asarray(poses, float)
    if p.ndim == 4 and p.shape[0] == 1:
        p = p[0]
    if p.ndim != 3 or p.shape[1:] != (4, 4):
        raise ValueError(f"poses must have shape (n_panels, 4, 4), got {p.shape}")
    return p


def state_poses(design: Design, state: str, model: str = "point") -> np.ndarray:
    """Panel poses (n_panels, 4, 4) of a named state.

    Parameters
    ----------
    design : Design
        The design.
    state : {"programmed", "permanent"}
        ``programmed``: the flat sheet (every hinge angle 0); ``permanent``: the printed
        shape (every hinge at its target angle).
    model : {"point", "arc"}
        Hinge model for the forward kinematics.

    Returns
    -------
    numpy.ndarray
        (n_panels, 4, 4) poses mapping sheet to world coordinates.
    """
    if state == "programmed":
        angles = np.zeros(len(design.hinges))
    elif state == "permanent":
        angles = target_angles(design)
    else:
        raise ValueError(f"state must be 'programmed' or 'permanent', got {state!r}")
    return forward(design, angles[None], model)[0]


def render_state(design: Design, poses, title: str, *, model: str = "point",
                 highlight: Sequence[int] = (), library: MaterialLibrary | None = None,
                 max_size_in: tuple[float, float] = (7.0, 6.0), dpi: float = 100.0):
    """Render the design's panels and hinges at one set of poses.

    Parameters
    ----------
    design : Design
        The design to draw.
    poses : array_like
        (n_panels, 4, 4) poses (sheet to world), e.g. ``trajectory.poses[k]`` or
        :func:`state_poses`.
    title : str
        Figure title.
    model : {"point", "arc"}
        Hinge model the poses were computed with: selects each panel's rigid part and
        whether hinges are drawn as lines (point) or curved ribbons (arc).
    highlight : sequence of int
        Panel indices drawn in the contact colour.
    library : MaterialLibrary, optional
        Material colours; the default library if omitted.
    max_size_in : tuple of float
        Largest drawing size (in); the figure is cut to the drawing.
    dpi : float
        Figure resolution (also used to measure the drawing).

    Returns
    -------
    matplotlib.figure.Figure
        An Agg figure with one 3D axes (save it with :func:`foldprint.render.save_figure`).
    """
    lib = library or default_library()
    sc = _scene(design, _as_poses(poses), model, lib, highlight)
    limits = _limits(sc.points())
    cam = camera_for(design)
    view = _fit_view(sc, limits, cam, max_size_in, dpi, 9.0)
    fig = _new_figure((view.width, view.height + _TITLE_IN), dpi)
    ax = _add_view(fig, view, (0.0, 0.0))
    _draw(ax, sc, limits, cam, 9.0)
    _title(fig, view.width / 2, view.height + 0.06, title, 10.0)
    return fig


# -- trajectories ----------------------------------------------------------------------

def motion_end(result) -> float:
    """Time (s) after which nothing visibly moves any more in a simulation.

    Parameters
    ----------
    result : SimulationResult
        The simulation.

    Returns
    -------
    float
        The latest 98 % fold time of a hinge that folds (arrested hinges stop earlier),
        with a 5 % margin, clipped to the simulated duration; the duration when no hinge
        folds.
    """
    traj = result.trajectory
    t_max = float(traj.times[-1])
    ft = [t for t in traj.fold_times if t is not None]
    if not ft:
        return t_max
    return float(min(t_max, 1.05 * max(ft)))


def poses_at(result, times) -> np.ndarray:
    """Panel poses at arbitrary times of a simulation.

    Parameters
    ----------
    result : SimulationResult
        The simulation.
    times : array_like
        Times (s), within the simulated duration (clamped otherwise).

    Returns
    -------
    numpy.ndarray
        (n, n_panels, 4, 4) poses. Hinge angles are interpolated linearly between the
        trajectory's samples (they are monotone in time), then the forward kinematics is
        run with the trajectory's hinge model, so a frame can sit exactly on a contact.
    """
    traj = result.trajectory
    t = np.atleast_1d(np.asarray(times, float))
    angles = np.zeros((len(t), traj.angles.shape[1]))
    for k in range(traj.angles.shape[1]):
        angles[:, k] = np.interp(t, traj.times, traj.angles[:, k])
    return forward(result.design, angles, traj.model)


def frame_times(result, n: int = 4) -> np.ndarray:
    """``n`` mid-fold times (s), evenly spread inside the motion, one on the first contact.

    Parameters
    ----------
    result : SimulationResult
        The simulation.
    n : int
        Number of frames.

    Returns
    -------
    numpy.ndarray
        Sorted times in (0, :func:`motion_end`]. When the first collision happens during
        the motion, the frame nearest to it is moved onto it.
    """
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    end = motion_end(result)
    times = end * np.arange(1, n + 1) / (n + 1)
    c = result.first_collision
    if c is not None and 0.0 < c.time <= end:
        times[int(np.argmin(np.abs(times - c.time)))] = c.time
    return np.sort(times)


def _contact_state(result, t: float) -> tuple[set[int], str]:
    """Panels in contact at or before ``t`` and a title suffix naming the first contact."""
    hl: set[int] = set()
    note = ""
    for c in result.contacts:
        if c.time <= t + 1e-9:
            hl.update(int(i) for i in c.pair)
    first = result.first_collision
    if first is not None and first.time <= t + 1e-9:
        note = f" | contact {first.panels[0]}\u2013{first.panels[1]} at {first.time:.2f} s"
    return hl, note


def render_frames(result, n: int = 4, *, library: MaterialLibrary | None = None,
                  dpi: float = 100.0):
    """Mid-fold frames of a simulation in one figure, fixed camera and axes.

    Parameters
    ----------
    result : SimulationResult
        A simulation (:func:`foldprint.simulate.simulate`).
    n : int
        Number of frames (default 4). Wide views are stacked in one column, tall ones
        side by side in one row, others in a square-ish grid.
    library : MaterialLibrary, optional
        Material colours.
    dpi : float
        Figure resolution (also used to measure the drawing).

    Returns
    -------
    matplotlib.figure.Figure
        ``n`` 3D axes at :func:`frame_times`, all with the same limits; panels in contact
        (from the first contact on) are drawn in red.
    """
    lib = library or default_library()
    design = result.design
    model = result.trajectory.model
    times = frame_times(result, n)
    poses = poses_at(result, times)
    scenes, titles = [], []
    for t, p in zip(times, poses):
        hl, note = _contact_state(result, float(t))
        scenes.append(_scene(design, p, model, lib, hl))
        titles.append(f"t = {t:.2f} s{note}")
    limits = _limits(np.concatenate([s.points() for s in scenes]))
    cam = camera_for(design)
    w, h, _ = _projected_size(limits, cam)
    if w >= 2.5 * h:
        ncols, box = 1, (8.0, 3.5)
    elif h >= 1.25 * w:
        ncols, box = n, (3.6, 5.0)
    else:
        ncols, box = int(math.ceil(math.sqrt(n))), (5.0, 4.0)
    nrows = int(math.ceil(n / ncols))
    view = _fit_view(scenes[0], limits, cam, box, dpi, 8.0)
    row_h = view.height + _TITLE_IN
    fig = _new_figure((view.width * ncols, row_h * nrows + _HEAD_IN), dpi)
    for k, (sc, title) in enumerate(zip(scenes, titles)):
        r, c = divmod(k, ncols)
        y0 = (nrows - 1 - r) * row_h
        ax = _add_view(fig, view, (c * view.width, y0))
        _draw(ax, sc, limits, cam, 8.0)
        _title(fig, (c + 0.5) * view.width, y0 + view.height + 0.04, title, 9.0)
    _title(fig, view.width * ncols / 2, row_h * nrows + 0.08,
           f"{design.name}: folding at {result.trajectory.bath_c:g} \u00b0C ({model} hinges)", 11.0)
    return fig


def fold_animation_gif(result, n_frames: int = 40, *, dpi: float = 72.0,
                       max_size_in: tuple[float, float] = (7.0, 5.0), frame_ms: int = 90,
                       library: MaterialLibrary | None = None) -> bytes:
    """An animated GIF of the fold, from the flat sheet to the end of the motion.

    Parameters
    ----------
    result : SimulationResult
        A simulation.
    n_frames : int
        Number of frames, evenly spaced in time over [0, :func:`motion_end`].
    dpi : float
        Resolution; a frame is at most ``max_size_in * dpi`` pixels.
    max_size_in : tuple of float
        Largest drawing size (in); frames are cut to the drawing.
    frame_ms : int
        Display time per frame; the first frame is held 4x, the last 15x.
    library : MaterialLibrary, optional
        Material colours.

    Returns
    -------
    bytes
        GIF data (looping forever, ``loop=0``). The camera and the axes limits are fixed
        over the whole animation (limits from every frame); panels in contact are red from
        the first contact on. Frames share one palette and are not dithered, so the bytes
        are deterministic.
    """
    from PIL import Image

    if n_frames < 2:
        raise ValueError(f"n_frames must be >= 2, got {n_frames}")
    lib = library or default_library()
    design = result.design
    model = result.trajectory.model
    times = np.linspace(0.0, motion_end(result), n_frames)
    scenes = []
    for t, p in zip(times, poses_at(result, times)):
        hl, note = _contact_state(result, float(t))
        scenes.append((_scene(design, p, model, lib, hl), f"{design.name}   t = {t:5.2f} s{note}"))
    limits = _limits(np.concatenate([s.points() for s, _ in scenes]))
    cam = camera_for(design)
    view = _fit_view(scenes[0][0], limits, cam, max_size_in, dpi, 9.0)
    fig = _new_figure((view.width, view.height + _TITLE_IN), dpi)
    ax = _add_view(fig, view, (0.0, 0.0))
    pos = ax.get_position(original=True)
    label = None
    rgb = []
    for sc, title in scenes:
        ax.cla()
        ax.set_position(pos)
        _draw(ax, sc, limits, cam, 9.0)
        if label is not None:
            label.remove()
        label = _title(fig, view.width / 2, view.height + 0.06, title, 10.0, family="monospace")
        rgb.append(_figure_rgb(fig))
    log.debug("%s: rendered %d GIF frames of %dx%d px", design.name, len(rgb), rgb[0].shape[1],
              rgb[0].shape[0])
    # one palette for every frame: median cut over a subsampled montage of all frames
    montage = Image.fromarray(np.concatenate([f[::2, ::2] for f in rgb], axis=0))
    palette = montage.quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    frames = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in rgb]
    durations = [frame_ms] * len(frames)
    durations[0] = frame_ms * 4
    durations[-1] = frame_ms * 15
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=durations,
                   loop=0, optimize=False, disposal=1)
    return buf.getvalue()
