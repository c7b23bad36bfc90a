"""One design of the gallery, built in a worker process: its evaluation (the check's, with
the nominal fold as ``foldprint simulate`` runs it), the JSON, the viewer, the renders
and the printable files; returns the page's :class:`~foldprint.apps.gallery.entry.Entry`."""

from __future__ import annotations

import logging
from pathlib import Path
from urllib.parse import quote

from ...core.display import seconds
from ...core.version import __version__
from ...core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from ...core.errors import FoldprintError
from ...core.modes import State
from ...model.design import Design
from ...model.materials import MaterialLibrary
from .entry import Entry, Image, Link, json_bytes, url, write_image
from .page import NO_FILES, check_verdict, nominal_status
from .samples import mc_summary, worst_json

log = logging.getLogger("foldprint.apps.gallery.runner")


MATERIAL_TEMPERATURES = (80.0, 90.0, 100.0)
"""Bath temperatures (deg C) of the material chart."""


GIF_FRAMES = 30


GIF_DPI = 72


STATE_DPI = 100


PLOT_DPI = 90


def _png(fig, dpi: int) -> bytes:
    """A gallery figure's PNG, saved as it is: every one is laid out to fit its figure
    (``tight_layout``, or a still cut to its drawing), so a tight crop, which draws the
    figure a second time to measure it, would only trim a few pixels of margin."""
    from ...render import figures as render

    return render.figure_bytes(fig, "png", dpi, crop=False)


def _evaluate(design: Design, lib: MaterialLibrary, dt: float = CHECK_DT_S, samples: int = CHECK_SAMPLES,
              seed: int = CHECK_SEED, mapper=None):
    """The design's :class:`~foldprint.apps.pipeline.Evaluation` with check's options (its
    simulation is the 3D swept check; the page's nominal fold is its ``simulation_for
    (both)``, as ``foldprint simulate`` runs it, for the paper's collision index on a
    planar strip) and the replay of its worst Monte-Carlo sample (None without samples)."""
    from ..pipeline import CHECK_SCALES, EvalOptions, Evaluation, check_scales

    ev = Evaluation(design, EvalOptions(dt=dt, samples=samples, seed=seed, scales=check_scales(CHECK_SCALES),
                                        workers=1), library=lib, mapper=mapper)
    ev.findings  # noqa: B018 - check's stages, in check's order
    replay = ev.worst_replay
    if replay is not None and not replay.agrees:
        log.warning("gallery: %s: the replay of sample %d does not give the recorded outcome",
                    design.name, replay.index)
    return ev, replay


def chart_task(out: Path, lib: MaterialLibrary) -> Image:
    from ...render import figures as render

    chart = _png(render.fold_time_chart(lib, MATERIAL_TEMPERATURES), PLOT_DPI)
    temps = ", ".join(f"{t:g}" for t in MATERIAL_TEMPERATURES)
    return write_image(
        out, "materials.png", chart,
        f"Glass transition temperature of each hinge material and its fold time at {temps} \u00b0C",
        f"Hinge materials: Tg and 98 % fold time against bath temperature ({temps} \u00b0C marked).")


def build_design(design: Design, out: Path, dirname: str, lib: MaterialLibrary, dt: float,
                 gif_frames: int, samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED, mapper=None) -> Entry:
    """Every file of one design (runs in a worker process); the entry for the page.
    ``mapper``: the design's Monte-Carlo outcomes when folded in the gallery's shared pool
    (:class:`foldprint.simulation.jamtest.pool.Precomputed`)."""
    log.info("gallery: %s: simulating and checking (%d scatter samples, seed %d)", design.name, samples, seed)
    ev, replay = _evaluate(design, lib, dt, samples, seed, mapper)
    with ev.cache.active():  # the renders below derive from the same design
        entry = _data_files(ev, replay, out / dirname, dirname)
        _viewer_page(entry, ev, replay, out / dirname, dirname)
        _pictures(entry, ev, out, dirname, gif_frames)
        _printable_files(entry, ev, out / dirname, dirname)
    return entry


def _data_files(ev, replay, base: Path, dirname: str) -> Entry:
    """``simulation.json``, ``check.json`` and ``samples.json``; the entry they describe."""
    from ...checks.report import simulation_json
    from ...checks.rules import default_printer_key
    from ...core.modes import Method
    from ...exchange.fileset import write_atomic

    design = ev.design
    result = ev.simulation_for(Method.BOTH)  # the nominal fold as ``foldprint simulate`` runs it
    sim = simulation_json(result)
    write_atomic(base / "simulation.json", json_bytes(sim))
    checks = ev.to_json(default_printer_key())
    write_atomic(base / "check.json", json_bytes(checks))
    # the page's fold time is the simulation's, the one `foldprint simulate` prints
    entry = Entry(design, dirname, sim, checks, fold_time=sim["fold_time_s"],
                  contacts=[(c.panels[0], c.panels[1], c.time, c.method) for c in result.contacts],
                  hinge_done=list(result.hinge_done))
    entry.data_links = [Link(url(f"{dirname}/simulation.json"), "simulation (JSON)"),
                        Link(url(f"{dirname}/check.json"), "design-rule checks and jam probability (JSON)")]
    if ev.robust is not None:
        entry.mc = mc_summary(ev.robust)
        entry.worst = None if replay is None else worst_json(replay, design)
        write_atomic(base / "samples.json", json_bytes({"design": design.name, **entry.mc, "worst": entry.worst}))
        entry.data_links.append(Link(url(f"{dirname}/samples.json"),
                                     "Monte-Carlo samples: each one's outcome, the worst one's parameters (JSON)"))
    return entry


def _viewer_page(entry: Entry, ev, replay, base: Path, dirname: str) -> None:
    """``viewer.html``, or the reason there is none (a part that cannot be built)."""
    from ...core.modes import Method
    from ...exchange.fileset import write_atomic
    from ...render import viewer

    name = ev.design.name
    log.info("gallery: %s: viewer", name)
    ok, status = nominal_status(entry)
    passes, verdict = check_verdict(entry)
    try:
        data = viewer.viewer_data(ev.simulation_for(Method.BOTH), ev.library, ev.robust, worst=replay)
    except FoldprintError as exc:  # the printed part cannot be built: said on the page
        log.warning("gallery: %s: no 3D viewer: %s", name, exc)
        entry.viewer_note = f"No 3D viewer: {exc}"
        return
    page = viewer.viewer_page(data, f"Nominal fold: {status} {verdict}", ok and passes,
                              f"../index.html#{quote('d-' + dirname)}", __version__)
    size = len(write_atomic(base / "viewer.html", page).read_bytes())
    entry.viewer = Link(url(f"{dirname}/viewer.html"), "interactive 3D viewer", size)


def _pictures(entry: Entry, ev, out: Path, dirname: str, gif_frames: int) -> None:
    """The renders (both states, mid-fold frames, the GIF) and the plots (hinge angles,
    the collision index of a planar strip, the Monte-Carlo samples)."""
    from ...core.modes import Method
    from ...render import anim as render_anim, figures as render, stills as render3d

    design, lib, result, robust = ev.design, ev.library, ev.simulation_for(Method.BOTH), ev.robust
    name, model, bath = design.name, result.trajectory.model, result.trajectory.bath_c
    log.info("gallery: %s: rendering", name)
    for state, what in (("programmed", "programmed (flat) state, as it goes into the bath"),
                        ("permanent", "permanent state: the printed shape every hinge recovers to")):
        fig = render3d.render_state(design, render3d.state_poses(design, state, model),
                                    f"{name}: {state} state", model=model, library=lib)
        entry.images.append(write_image(
            out, f"{dirname}/{state}.png", _png(fig, STATE_DPI),
            f"3D view of {name} in the {state} state", f"The {what}."))
    times = render3d.frame_times(result, 4)
    fig = render3d.render_frames(result, 4, library=lib)
    t_list = ", ".join(seconds(t) for t in times)
    entry.images.append(write_image(
        out, f"{dirname}/frames.png", _png(fig, PLOT_DPI),
        f"Four 3D views of {name} while folding, at {t_list}",
        f"Mid-fold frames at {t_list} (same camera and scale); panels in contact in red.",
        wide=True))
    gif = render_anim.fold_animation_gif(result, gif_frames, dpi=GIF_DPI, library=lib)
    end = render3d.motion_end(result)
    entry.images.append(write_image(
        out, f"{dirname}/fold.gif", gif,
        f"Animation of {name} folding in a {bath:g} \u00b0C bath, from flat to {seconds(end)}",
        f"The fold from 0 to {seconds(end)} ({gif_frames} frames, looping)."
        + (" After the first contact the model's motion is kinematic only: the real part jams."
           if result.contacts else "")))
    _plots(entry, result, robust, out, dirname)


def _plots(entry: Entry, result, robust, out: Path, dirname: str) -> None:
    from ...render import figures as render

    name = result.design.name
    entry.images.append(write_image(
        out, f"{dirname}/hinge_angles.png",
        _png(render.hinge_angle_figure(result), PLOT_DPI),
        f"Fold angle of each hinge of {name} against time",
        "Hinge angles against time (paper Fig. 3b style); dashed red lines mark contacts."))
    if result.design.is_planar_strip and result.index2d is not None:
        entry.images.append(write_image(
            out, f"{dirname}/collision_index.png",
            _png(render.collision_index_figure(result), PLOT_DPI),
            f"Collision index of every non-adjacent panel pair of {name} against time",
            "The paper's collision index S_ij (Fig. 4 style): contact where it enters the shaded "
            "band (0, 1); red points are contacts."))
    fig = None if robust is None else render.sample_outcomes_figure(
        robust, None if entry.worst is None else entry.worst["sample"])
    if fig is not None:  # None: no sample completes or collides, nothing to draw (the text says so)
        entry.images.append(write_image(
            out, f"{dirname}/samples.png", _png(fig, PLOT_DPI),
            f"Histogram of the fold times and first-contact times of the {robust.samples} scatter samples of "
            f"{name}, and how often each panel pair collides first",
            f"The {robust.samples} Monte-Carlo samples (seed {robust.seed}) of the jam probability: when each "
            "completes (green) or first collides (red), the nominal fold dashed"
            + ("; right, the first-colliding pairs." if robust.collisions() else "; no sample collides."),
            wide=True))


def _printable_files(entry: Entry, ev, base: Path, dirname: str) -> None:
    """``files/``: the printed part the evaluation built (the check's), not a second build."""
    name = ev.design.name
    log.info("gallery: %s: exporting printable files", name)
    try:
        records = ev.export(base / "files", State.PERMANENT, ("3mf", "prusa3mf", "stl"))
    except FoldprintError as exc:  # a part that cannot be built is shown, not raised
        log.warning("gallery: %s: no print files: %s", name, exc)
        entry.export_note = f"{NO_FILES}{exc}"
        return
    for rec in records:
        fname = Path(rec["path"]).name
        entry.files.append(Link(url(f"{dirname}/files/{fname}"), _format_label(rec, fname), rec.get("bytes")))


def _format_label(rec: dict, fname: str) -> str:
    fmt = rec.get("format", "")
    mats = ", ".join(b.get("material", "?") for b in rec.get("bodies", []))
    if fmt == "3mf":
        return (f"3MF for OrcaSlicer / Bambu Studio, every material its own part and filament ({fname}; "
                "PrusaSlicer would print it with one tool: use the PrusaSlicer 3MF there)")
    if fmt == "prusa3mf":
        return f"3MF for PrusaSlicer, one extruder per material ({fname})"
    if fmt == "stl":
        return f"STL, {mats} ({fname})"
    if fmt == "manifest":
        return f"manifest: which STL is which material ({fname})"
    if fmt == "recipe":
        return f"print recipe: tools, programming temperatures, fold order, the check's verdict ({fname})"
    return f"{fmt} ({fname})"
