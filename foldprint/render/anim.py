"""The fold as an animated GIF: one figure, one :class:`foldprint.render.stills.Painter`,
redrawn frame after frame (only its paths, colours and the title text change)."""

from __future__ import annotations

import io
import logging

import numpy as np

from ..core.display import seconds
from ..model.derived import scoped
from ..model.materials import MaterialLibrary, default_library
from .stills import TITLE_IN, Painter, View, bounds, new_figure, title
from .scene import camera_for, contact_state, motion_end, poses_at, scene

log = logging.getLogger(__name__)


@scoped
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
        GIF data (looping forever). Camera and scale are fixed over the animation (bounds
        from every frame's projected vertices); panels in contact are red from the first
        contact on. Frames share one palette and are not dithered: the bytes are
        deterministic.
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
        hl, note = contact_state(result, float(t))
        scenes.append((scene(design, p, model, lib, hl), f"{design.name}   t = {seconds(t):>7}{note}"))
    cam = camera_for(design)
    view = View.fit(bounds([s for s, _ in scenes], cam), max_size_in)
    cw, ch = view.cell
    fig = new_figure((cw, ch + TITLE_IN), dpi)
    painter = Painter(fig, view, cam, (0.0, 0.0), 9.0)
    label = title(fig, cw / 2, ch + 0.06, "", 10.0, family="monospace")
    rgb = []
    for sc, text in scenes:
        painter.draw(sc)
        label.set_text(text)
        fig.canvas.draw()
        rgb.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
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
