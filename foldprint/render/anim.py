"""The fold as an animated GIF: one figure, one :class:`foldprint.render.stills.Painter`.
What does not change (the background, the scale bar) is drawn once; each frame restores
it and draws only the panels' collection (the same pixels as redrawing the whole figure:
the collection lies above the scale bar's band), then its title line with Pillow."""

from __future__ import annotations

import io
import logging

import numpy as np

from ..core.display import seconds
from ..model.derived import scoped
from ..model.materials import MaterialLibrary, default_library
from .stills import TITLE_IN, Painter, View, bounds, new_figure
from .scene import camera_for, contact_state, motion_end, poses_at, scene

log = logging.getLogger(__name__)

#: The palette of a GIF is cut from every frame's every PALETTE_STEP-th pixel along x and y
#: (our choice: 4 costs a quarter of 2, 20-30 ms a GIF instead of 70-100, and the frames
#: look the same: the faces' flat colours dominate; pixels differ by 1-2 levels of 255).
PALETTE_STEP = 4

#: The frame title's size (pt), as the stills' titles.
TITLE_PT = 10.0


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
    rgb = _frames(scenes, view, cam, dpi)
    log.debug("%s: rendered %d GIF frames of %dx%d px", design.name, len(rgb), rgb[0].shape[1],
              rgb[0].shape[0])
    return _gif_bytes(rgb, frame_ms)


def _frames(scenes, view: View, cam, dpi: float) -> list[np.ndarray]:
    """Every frame's RGB pixels: the background and the scale bar drawn once, then per
    frame the panels (matplotlib) and the title (:func:`_title_font`)."""
    from PIL import Image, ImageDraw

    cw, ch = view.cell
    fig = new_figure((cw, ch + TITLE_IN), dpi)
    painter = Painter(fig, view, cam, (0.0, 0.0), 9.0)
    fig.canvas.draw()  # the background and the scale bar, once (no panels yet)
    background = fig.canvas.copy_from_bbox(fig.bbox)
    font = _title_font(TITLE_PT * dpi / 72.0)
    rgb = []
    for sc, text in scenes:
        painter.draw(sc)
        fig.canvas.restore_region(background)
        fig.draw_artist(painter.coll)
        buf = np.asarray(fig.canvas.buffer_rgba())
        im = Image.frombuffer("RGBA", (buf.shape[1], buf.shape[0]), buf, "raw", "RGBA", 0, 1).convert("RGB")
        # centred, its bottom (descent included) 0.06 in above the view, as stills.title places it
        ImageDraw.Draw(im).text((cw / 2 * dpi, im.height - (ch + 0.06) * dpi), text, font=font,
                                fill=(0, 0, 0), anchor="md")
        rgb.append(np.asarray(im))
    return rgb


def _title_font(px: float):
    """The frame title's font: matplotlib's monospace face (DejaVu Sans Mono), ``px``
    pixels to the em, drawn by Pillow. Our choice: matplotlib draws text glyph by glyph
    (3 ms a title, 30 titles a GIF); Pillow draws the same face in a tenth of that, the
    glyphs within a pixel of matplotlib's."""
    from matplotlib import font_manager
    from PIL import ImageFont

    return ImageFont.truetype(font_manager.findfont(font_manager.FontProperties(family="monospace")), px)


def _gif_bytes(rgb: list[np.ndarray], frame_ms: int) -> bytes:
    """The frames as one looping GIF: one palette, no dithering (deterministic bytes);
    the first frame held 4x, the last 15x."""
    from PIL import Image

    # one palette for every frame: median cut over a montage of every frame's every
    # PALETTE_STEP-th pixel (our choice: the palette's cost falls with the pixels it sees)
    montage = Image.fromarray(np.concatenate([f[::PALETTE_STEP, ::PALETTE_STEP] for f in rgb], axis=0))
    palette = montage.quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    frames = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in rgb]
    durations = [frame_ms] * len(frames)
    durations[0] = frame_ms * 4
    durations[-1] = frame_ms * 15
    buf = io.BytesIO()
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=durations,
                   loop=0, optimize=False, disposal=1)
    return buf.getvalue()
