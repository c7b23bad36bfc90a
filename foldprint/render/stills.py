"""Still 3D renders of a design: one state, or mid-fold frames in one figure.

The scene (:mod:`foldprint.render.scene`) is projected orthographically by the design's
fixed camera and drawn as 2D paths, back to front (painter's order, per panel and per
ribbon quad), on a plain matplotlib Agg canvas: no mplot3d, no pyplot state, no display.
The view's size comes from the projected vertices, so nothing is drawn twice to measure
it; the scenes are drawn without axes, through a fixed affine map from screen mm to
figure pixels, and a scale bar replaces axes. The figure is the drawing with a fixed
white border (:data:`PAD_IN`), saved as it is, without a tight crop (which would draw it
once more to measure it). Functions return a :class:`matplotlib.figure.Figure`; output
is deterministic. The fold animation lives in :mod:`foldprint.render.anim`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..core.display import seconds
from ..core.modes import DEFAULT_HINGE_MODEL, HingeModel
from ..model.derived import scoped
from ..model.design import Design
from ..model.materials import MaterialLibrary, default_library
from .scene import (Camera, Scene, camera_for, contact_state, frame_times, motion_end,  # noqa: F401
                           poses_at, scene, state_poses)

_BACKGROUND = "white"
TITLE_IN = 0.32  # title band above a view (in)
_BAR_IN = 0.3  # scale-bar band below a view (in)
_HEAD_IN = 0.4  # figure title band above a frame grid (in)
_MARGIN = 0.04  # fraction of the projected extent left free around the drawing
#: White border (in) left, right and below a still's drawing; above it the title band
#: leaves as much. Our choice: matplotlib's pad of a tight crop (``pad_inches``), so a
#: still saved as it is looks as one cropped tight did.
PAD_IN = 0.1


def new_figure(figsize: tuple[float, float], dpi: float):
    """An Agg figure with a white background (no pyplot)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi, facecolor=_BACKGROUND)
    FigureCanvasAgg(fig)
    return fig


def project(points: np.ndarray, camera: Camera) -> np.ndarray:
    """Screen coordinates (n, 2), mm, of world points (n, 3)."""
    right, up, _ = camera.axes()
    return points @ np.stack([right, up]).T


def bounds(scenes: Sequence[Scene], camera: Camera) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) on screen (mm) of every vertex of ``scenes``, with a margin."""
    pts = project(np.concatenate([s.points() for s in scenes]), camera)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    pad = np.maximum(_MARGIN * float((hi - lo).max()), 0.5)
    return float(lo[0] - pad), float(hi[0] + pad), float(lo[1] - pad), float(hi[1] + pad)


@dataclass(frozen=True)
class View:
    """A view's screen bounds (mm) and its drawing size (in) at a fixed scale."""

    bounds: tuple[float, float, float, float]
    width: float
    height: float

    @staticmethod
    def fit(b: tuple[float, float, float, float], box_in: tuple[float, float]) -> "View":
        w, h = b[1] - b[0], b[3] - b[2]
        s = min(box_in[0] / w, (box_in[1] - _BAR_IN) / h)
        return View(b, w * s, h * s)

    @property
    def cell(self) -> tuple[float, float]:
        return self.width, self.height + _BAR_IN


def _nice(x: float) -> float:
    """The largest 1, 2 or 5 x 10^k not above ``x``."""
    k = 10.0 ** math.floor(math.log10(x))
    return max(m * k for m in (1.0, 2.0, 5.0) if m * k <= x)


class Painter:
    """Draws scenes through a fixed camera and view into a figure, no axes (a fixed affine
    map from screen mm to figure pixels); reused frame after frame (only the paths and
    colours of its one collection change)."""

    def __init__(self, fig, view: View, camera: Camera, origin_in: tuple[float, float],
                 fontsize: float = 8.0):
        from matplotlib.collections import PathCollection
        from matplotlib.lines import Line2D
        from matplotlib.patches import Rectangle
        from matplotlib.text import Text
        from matplotlib.transforms import Affine2D

        x0, x1, y0, y1 = view.bounds
        mm_per_in = (x1 - x0) / view.width
        ybar = y0 - _BAR_IN * mm_per_in
        # screen mm -> figure inches (the view's one scale, the scale-bar band below) -> pixels
        to_fig = Affine2D().translate(-x0, -ybar).scale(1.0 / mm_per_in).translate(*origin_in) + fig.dpi_scale_trans
        self.camera = camera
        self.coll = PathCollection([], transform=to_fig, joinstyle="round", capstyle="round")
        self.coll.set_in_layout(False)  # a tight crop measures the view by its cell, below
        fig.add_artist(self.coll)
        cw, ch = view.cell
        fig.add_artist(Rectangle(origin_in, cw, ch, transform=fig.dpi_scale_trans, fill=False, linewidth=0.0))
        bar = _nice(0.25 * (x1 - x0))
        yb = ybar + 0.55 * _BAR_IN * mm_per_in
        fig.add_artist(Line2D([x0, x0 + bar], [yb, yb], color="0.25", lw=1.5, solid_capstyle="butt",
                              transform=to_fig))
        fig.add_artist(Text(x0 + bar + 0.08 * mm_per_in, yb, f"{bar:g} mm", va="center", ha="left",
                            fontsize=fontsize * 0.85, color="0.25", transform=to_fig))

    def draw(self, sc: Scene) -> None:
        """Replace the collection's paths by ``sc``'s, back to front (depth of a polygon's
        outline or a line's centre toward the eye; ties in scene order)."""
        from matplotlib.path import Path

        right, up, eye = self.camera.axes()
        proj = np.stack([right, up]).T
        n = len(sc.polys)
        depth = np.empty(n + len(sc.lines))
        paths = []
        for k, rings in enumerate(sc.polys):
            if len(rings) == 1:  # most polygons (ribbon quads): no concatenation
                verts = _closed(rings[0] @ proj)
                codes = _ring_codes(len(rings[0]))
            else:
                verts = np.concatenate([_closed(r @ proj) for r in rings])
                codes = np.concatenate([_ring_codes(len(r)) for r in rings])
            paths.append(Path(verts, codes))
            depth[k] = rings[0].sum(axis=0) / len(rings[0]) @ eye  # the mean, without np.mean's overhead
        for k, line in enumerate(sc.lines):
            depth[n + k] = line.sum(axis=0) / len(line) @ eye + 1e-6  # over the faces they bound
            paths.append(Path(line @ proj))
        faces = np.ones((len(depth), 4))
        faces[:n, :3] = sc.face_colors
        faces[n:, 3] = 0.0  # lines: no fill
        edges = faces.copy()
        for k, edge in enumerate(sc.edge_colors):
            if edge is not None:
                edges[k, :3] = edge
        edges[n:, :3] = sc.line_colors if sc.lines else np.zeros((0, 3))
        edges[n:, 3] = 1.0
        order = np.argsort(depth, kind="stable")
        self.coll.set_paths([paths[i] for i in order])
        self.coll.set_facecolors(faces[order])
        self.coll.set_edgecolors(edges[order])
        self.coll.set_linewidths(np.concatenate([sc.edge_widths, sc.line_widths])[order])


def _closed(p: np.ndarray) -> np.ndarray:
    """The ring ``p`` (k, 2) with its first point repeated at the end."""
    out = np.empty((len(p) + 1, 2))
    out[:-1] = p
    out[-1] = p[0]
    return out


@functools.lru_cache(maxsize=64)
def _ring_codes(k: int) -> np.ndarray:
    """Path codes of a closed ring of ``k`` points (read-only: shared by every path)."""
    from matplotlib.path import Path

    codes = np.array([Path.MOVETO] + [Path.LINETO] * (k - 1) + [Path.CLOSEPOLY], dtype=Path.code_type)
    codes.flags.writeable = False
    return codes


def title(fig, x_in: float, y_in: float, text: str, fontsize: float, **kw):
    fw, fh = fig.get_size_inches()
    return fig.text(x_in / fw, y_in / fh, text, ha="center", va="bottom", fontsize=fontsize, **kw)


def _as_poses(poses) -> np.ndarray:
    p = np.asarray(poses, float)
    if p.ndim == 4 and p.shape[0] == 1:
        p = p[0]
    if p.ndim != 3 or p.shape[1:] != (4, 4):
        raise ValueError(f"poses must have shape (n_panels, 4, 4), got {p.shape}")
    return p


@scoped
def render_state(design: Design, poses, title_text: str, *, model: HingeModel = DEFAULT_HINGE_MODEL,
                 highlight: Sequence[int] = (), library: MaterialLibrary | None = None,
                 max_size_in: tuple[float, float] = (7.0, 6.0), dpi: float = 100.0):
    """The design's panels and hinges at one set of poses.

    Parameters
    ----------
    design : Design
        The design to draw.
    poses : array_like
        (n_panels, 4, 4) poses (sheet to world), e.g. :func:`state_poses`.
    title_text : str
        Figure title.
    model : {"point", "arc"}
        Hinge model of the poses: each panel's rigid part, hinge lines or ribbons.
    highlight : sequence of int
        Panel indices drawn in the contact colour.
    library : MaterialLibrary, optional
        Material colours; the default library if omitted.
    max_size_in : tuple of float
        Largest drawing size (in); the figure is cut to the drawing.
    dpi : float
        Figure resolution.

    Returns
    -------
    matplotlib.figure.Figure
        An Agg figure (save it with :func:`foldprint.render.figures.figure_bytes`).
    """
    lib = library or default_library()
    sc = scene(design, _as_poses(poses), model, lib, highlight)
    cam = camera_for(design)
    view = View.fit(bounds([sc], cam), max_size_in)
    cw, ch = view.cell
    fig = new_figure((cw + 2 * PAD_IN, ch + TITLE_IN + PAD_IN), dpi)
    Painter(fig, view, cam, (PAD_IN, PAD_IN), 9.0).draw(sc)
    title(fig, PAD_IN + cw / 2, PAD_IN + ch + 0.06, title_text, 10.0)
    return fig


@scoped
def render_frames(result, n: int = 4, *, library: MaterialLibrary | None = None,
                  dpi: float = 100.0):
    """``n`` mid-fold frames (:func:`frame_times`) in one figure, same camera and scale;
    wide views stacked in a column, tall ones in a row, others in a grid; panels in
    contact red from the first contact on."""
    lib = library or default_library()
    design = result.design
    model = result.trajectory.model
    times = frame_times(result, n)
    scenes, titles = [], []
    for t, p in zip(times, poses_at(result, times)):
        hl, note = contact_state(result, float(t))
        scenes.append(scene(design, p, model, lib, hl))
        titles.append(f"t = {seconds(t)}{note}")
    cam = camera_for(design)
    b = bounds(scenes, cam)
    w, h = b[1] - b[0], b[3] - b[2]
    if w >= 2.5 * h:
        ncols, box = 1, (8.0, 3.0)
    elif h >= 1.25 * w:
        ncols, box = n, (2.6, 4.5)
    else:
        ncols, box = int(math.ceil(math.sqrt(n))), (4.5, 3.6)
    nrows = int(math.ceil(n / ncols))
    view = View.fit(b, box)
    cw, ch = view.cell
    row_h = ch + TITLE_IN
    fig = new_figure((cw * ncols + 2 * PAD_IN, row_h * nrows + _HEAD_IN + PAD_IN), dpi)
    for k, (sc, text) in enumerate(zip(scenes, titles)):
        r, c = divmod(k, ncols)
        y0 = PAD_IN + (nrows - 1 - r) * row_h
        Painter(fig, view, cam, (PAD_IN + c * cw, y0)).draw(sc)
        title(fig, PAD_IN + (c + 0.5) * cw, y0 + ch + 0.04, text, 9.0)
    title(fig, PAD_IN + cw * ncols / 2, PAD_IN + row_h * nrows + 0.08,
          f"{design.name}: folding at {result.trajectory.bath_c:g} \u00b0C ({model} hinges)", 11.0)
    return fig
