"""A static, offline HTML gallery of designs: an interactive 3D viewer, renders, plots,
checks, simulation and files.

:func:`build_gallery` writes, for every design, into ``out_dir/<name>/``:

* ``viewer.html``: the interactive fold viewer (:mod:`foldprint.render.viewer`; three.js and the
  viewer script are written once into ``out_dir/viewer/``), opens from ``file://``;
* ``programmed.png`` and ``permanent.png``: the flat sheet and the printed shape;
* ``frames.png``: four mid-fold frames; ``fold.gif``: the fold as an animation;
* ``hinge_angles.png`` (paper Fig. 3b style) and, for planar strips,
  ``collision_index.png`` (paper Fig. 4 style);
* ``check.json`` (design-rule findings and the jam probability, as ``foldprint check
  --json``: the same check, with check's samples, seed and time step from
  :mod:`foldprint.core.constants`), ``simulation.json`` (as ``foldprint simulate --json``) and
  ``samples.json`` (every Monte-Carlo sample's outcome and the worst sample's drawn
  parameters);
* ``samples.png``: the distribution of first-colliding pairs and fold times over the
  samples; the viewer replays the worst sample (:func:`foldprint.apps.pipeline.worst_sample`)
  beside the nominal fold;
* ``files/``: the printable files from :func:`foldprint.apps.pipeline.export`
  (3MF, PrusaSlicer 3MF, STL per material, manifest), when that module is available;

and, once, ``out_dir/materials.png`` (fold time against bath temperature) and
``out_dir/index.html``, one self-contained page (inline CSS, no scripts, relative links)
that ties everything together. Designs are built in parallel worker processes (the
collision checks hold the GIL); every file goes through
:func:`foldprint.exchange.files.write_atomic`; nothing is printed, progress is logged and
reported to an optional callback. The output is deterministic: building twice, with any
number of processes, gives the same bytes (export files aside, which belong to the exporter).
"""

from __future__ import annotations

import html
import io
import json
import logging
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence
from urllib.parse import quote

from .. import __version__
from ..core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from ..model.design import Design
from ..core.errors import FoldprintError
from ..model import composition
from ..model.materials import MaterialLibrary, default_library

log = logging.getLogger(__name__)

MATERIAL_TEMPERATURES = (80.0, 90.0, 100.0)
"""Bath temperatures (deg C) of the material chart."""

HINGE_MODEL_TEXT = {
    "arc": "the printed (arc) hinges: each hinge's radius, thickness and width as exported",
    "point": "the paper's point-hinge reduced-order model (a comparison mode, not the printed part)",
}
"""How the page names the hinge model a design was simulated with."""

GIF_FRAMES = 30
GIF_DPI = 72
STATE_DPI = 100
PLOT_DPI = 90


@dataclass
class _Image:
    src: str  # relative URL from index.html
    width: int
    height: int
    alt: str
    caption: str
    wide: bool = False  # spans the whole row of the picture grid


@dataclass
class _Link:
    href: str
    label: str
    size: int | None = None


@dataclass
class _Entry:
    design: Design
    dirname: str
    sim: dict
    checks: dict
    fold_time: float | None = None  # s, every hinge at 98 % (from the recovery curves)
    contacts: list = field(default_factory=list)  # (panel a, panel b, time, method)
    hinge_done: list = field(default_factory=list)
    images: list = field(default_factory=list)
    files: list = field(default_factory=list)
    data_links: list = field(default_factory=list)
    export_note: str = ""
    viewer: _Link | None = None  # the design's interactive 3D viewer page
    viewer_note: str = ""  # why there is none
    mc: dict | None = None  # the Monte-Carlo summary (:func:`_mc_summary`) when it was run
    worst: dict | None = None  # the worst sample (:func:`_worst_json`)


# -- helpers --------------------------------------------------------------------------

def _slug(name: str) -> str:
    """A directory-name-safe version of a design name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "design"


def _unique_dirnames(designs: Sequence[Design]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for d in designs:
        base = _slug(d.name)
        if base.lower() in ("materials.png", "index.html"):
            base = f"design_{base}"
        k = seen.get(base.lower(), 0) + 1
        seen[base.lower()] = k
        out.append(base if k == 1 else f"{base}-{k}")
    return out


def _png_size(data: bytes) -> tuple[int, int]:
    from PIL import Image

    with Image.open(io.BytesIO(data)) as im:
        return int(im.width), int(im.height)


def _write_image(out_dir: Path, rel: str, data: bytes, alt: str, caption: str,
                 wide: bool = False) -> _Image:
    from ..exchange.files import write_atomic

    write_atomic(out_dir / rel, data)
    w, h = _png_size(data)
    return _Image(_url(rel), w, h, alt, caption, wide)


def _url(rel: str) -> str:
    """A relative URL for a POSIX relative path (each segment percent-encoded)."""
    return "/".join(quote(part) for part in rel.split("/"))


def _json_bytes(obj) -> bytes:
    return (json.dumps(obj, indent=2, ensure_ascii=False, allow_nan=False) + "\n").encode("utf-8")


def _fmt_s(t: float | None, nd: int = 2) -> str:
    return "\u2014" if t is None else f"{t:.{nd}f} s"


# -- building -------------------------------------------------------------------------

Progress = Callable[[int, int, str], None]
"""``progress(done, total, message)``: called as each part of the gallery is finished."""


def _evaluate(design: Design, lib: MaterialLibrary, dt: float = CHECK_DT_S, samples: int = CHECK_SAMPLES,
              seed: int = CHECK_SEED):
    """The nominal simulation as ``foldprint simulate`` runs it (both collision checks on a
    planar strip, for the paper's collision index), what ``foldprint check`` computes
    (:func:`foldprint.apps.pipeline.evaluate` with check's defaults: its own simulation (the 3D
    swept check), the printed part, gaps, clearance, the jam probability, every rule) and
    the replay of the worst Monte-Carlo sample (None when no sample was run)."""
    from .pipeline import CHECK_SCALES, evaluate, replay_sample, run_simulation, worst_sample

    result, _ = run_simulation(design, dt=dt, library=lib)
    ev = evaluate(design, library=lib, dt=dt, samples=samples, seed=seed, workers=1, scales=CHECK_SCALES)
    replay = None
    if ev.robust is not None:
        k = worst_sample(ev.robust)
        if k is not None:
            replay = replay_sample(design, ev.robust, k, library=lib, dt=dt)
            if not replay.agrees:
                log.warning("gallery: %s: the replay of sample %d does not give the recorded outcome",
                            design.name, k)
    return result, ev, replay


def _check_json(ev, printer_key: str) -> dict:
    """The ``foldprint check --json`` object of an evaluation (one writer: report.check_json)."""
    from ..checks.report import check_json

    return check_json(ev, printer_key)


def _mc_summary(robust) -> dict:
    """What the page shows of the Monte-Carlo: the estimate, and per sample its outcome."""
    import numpy as np

    pairs = []
    for (a, b), count in robust.collisions():
        times = sorted(o.time for o in robust.outcomes if o.pair == (a, b))
        pairs.append({"pair": [a, b], "count": count, "first_s": times[0],
                      "median_s": float(np.median(times)), "last_s": times[-1]})
    reasons = {k: sum(o.reason == k for o in robust.outcomes) for k in ("collision", "goal", "unfolded")}
    return {"samples": robust.samples, "seed": robust.seed, "hinge_model": str(robust.hinge_model.value),
            "jams": robust.jams, "jam_probability": float(robust.jam_probability),
            "ci95": [float(x) for x in robust.ci95], "failures": reasons, "pairs": pairs,
            "fold_time_s": robust.fold_time_percentiles(),
            "outcomes": [{"sample": k, "jammed": o.jammed, "reason": o.reason,
                          "pair": None if o.pair is None else list(o.pair),
                          "contact_s": o.time, "fold_time_s": o.fold_time}
                         for k, o in enumerate(robust.outcomes)]}


def _worst_json(replay, design: Design) -> dict:
    """The worst sample: why it is the worst, its replayed verdict and its drawn parameters."""
    import dataclasses

    import numpy as np

    from ..render.viewer import worst_text

    o, res = replay.outcome, replay.result
    c = res.first_collision
    params = {}
    for f in dataclasses.fields(replay.sample):
        v = getattr(replay.sample, f.name)
        params[f.name] = [float(x) for x in np.ravel(v)] if np.ndim(v) else float(v)
    return {"sample": replay.index, "why": worst_text(replay), "jammed": o.jammed, "reason": o.reason,
            "pair": None if o.pair is None else list(o.pair), "contact_s": o.time, "fold_time_s": o.fold_time,
            "replay_agrees": bool(replay.agrees),
            "replay": {"completed": bool(res.completed), "fold_time_s": res.fold_time,
                       "first_collision": None if c is None else {"panels": list(c.panels), "time_s": float(c.time)}},
            "hinges": [h.id for h in design.hinges], "parameters": params}


def _pool(jobs: int, n_tasks: int):
    """A process pool (FCL holds the GIL, so threads would not help), or None for one job."""
    import multiprocessing as mp
    import sys
    from concurrent.futures import ProcessPoolExecutor

    workers = max(1, min(jobs, n_tasks))
    if workers == 1:
        return None
    ctx = mp.get_context("fork") if sys.platform.startswith("linux") else None
    return ProcessPoolExecutor(max_workers=workers, mp_context=ctx)


def build_gallery(designs: Sequence[Design], out_dir: str | Path,
                  progress: Progress | None = None, *,
                  library: MaterialLibrary | None = None, dt: float = CHECK_DT_S,
                  gif_frames: int = GIF_FRAMES, jobs: int | None = None, samples: int = CHECK_SAMPLES,
                  seed: int = CHECK_SEED) -> Path:
    """Simulate, check, render and export ``designs`` into a static HTML gallery.

    Parameters
    ----------
    designs : sequence of Design
        The designs, in page order (e.g. every template, via
        :func:`foldprint.io.templates.list_templates` and :func:`foldprint.io.load.load_design`).
    out_dir : str or Path
        Output directory (created if needed); each design gets ``out_dir/<name>/``.
    progress : callable, optional
        ``progress(done, total, message)``, called as the material chart, each design and
        the index are finished (for a progress bar).
    library : MaterialLibrary, optional
        Materials for simulation, colours and the material chart; the default library if
        omitted.
    dt : float
        Time step (s) of the simulation and of every Monte-Carlo sample (default: check's).
    gif_frames : int
        Frames of each fold animation.
    jobs : int, optional
        Worker processes (default: the number of CPUs); designs are built in parallel,
        the page is the same whatever the number.
    samples, seed : int
        Monte-Carlo samples of the jam probability per design and their seed (default:
        what ``foldprint check`` runs, :data:`foldprint.core.constants.CHECK_SAMPLES` and
        :data:`~foldprint.core.constants.CHECK_SEED`); 0 samples skips it.

    Returns
    -------
    Path
        ``out_dir/index.html``.

    Raises
    ------
    foldprint.core.errors.ExportError
        If ``out_dir`` or a file in it cannot be written. A design whose printable files
        cannot be built is reported on the page (and logged), not raised.
    """
    import os

    from ..exchange.files import ensure_dir, write_atomic
    from ..render.viewer import ASSETS, asset_bytes

    lib = library or default_library()
    out = ensure_dir(out_dir)
    t_start = time.perf_counter()
    dirnames = _unique_dirnames(designs)
    total = len(designs) + 2
    done = 0

    def step(msg: str) -> None:
        nonlocal done
        done += 1
        log.info("gallery: [%d/%d] %s", done, total, msg)
        if progress is not None:
            progress(done, total, msg)

    for name in ASSETS:
        write_atomic(out / "viewer" / name, asset_bytes(name))
    tasks = [(_chart_task, (out, lib))] + [
        (_build_design, (d, out, dn, lib, dt, gif_frames, samples, seed)) for d, dn in zip(designs, dirnames)]
    results: list = [None] * len(tasks)
    pool = _pool(jobs or os.cpu_count() or 1, len(tasks))
    labels = ["material chart"] + [f"{d.name}: simulated, checked, rendered, exported" for d in designs]
    if pool is None:
        for k, (fn, args) in enumerate(tasks):
            results[k] = fn(*args)
            step(labels[k])
    else:
        from concurrent.futures import as_completed

        # the workers fork from here: import what they all need once, before the fork
        from ..checks import rules as checks  # noqa: F401
        from .. import geometry  # noqa: F401
        from ..render import figures as render, anim as render_anim, viewer  # noqa: F401
        from ..simulation import simulate  # noqa: F401

        # the biggest designs first, so the last task to finish is a small one
        order = [0] + sorted(range(1, len(tasks)), key=lambda k: -len(designs[k - 1].hinges))
        with pool:
            futures = {pool.submit(tasks[k][0], *tasks[k][1]): k for k in order}
            for fut in as_completed(futures):
                k = futures[fut]
                results[k] = fut.result()
                step(labels[k])
    materials_img = results[0]
    entries = results[1:]
    for entry, design in zip(entries, designs):
        entry.design = design  # the worker's copy came back pickled; keep the caller's

    page = _page(entries, materials_img, lib, dt, samples, seed)
    index = write_atomic(out / "index.html", page)
    step("index.html")
    log.info("gallery: %d design(s) in %s (%.1f s)", len(entries), out, time.perf_counter() - t_start)
    return index


def _chart_task(out: Path, lib: MaterialLibrary) -> _Image:
    from ..render import figures as render

    chart = render.figure_bytes(render.fold_time_chart(lib, MATERIAL_TEMPERATURES), "png", PLOT_DPI)
    temps = ", ".join(f"{t:g}" for t in MATERIAL_TEMPERATURES)
    return _write_image(
        out, "materials.png", chart,
        f"Glass transition temperature of each hinge material and its fold time at {temps} \u00b0C",
        f"Hinge materials: Tg and 98 % fold time against bath temperature ({temps} \u00b0C marked).")


def _build_design(design: Design, out: Path, dirname: str, lib: MaterialLibrary, dt: float,
                  gif_frames: int, samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED) -> _Entry:
    """Every file of one design (runs in a worker process); the entry for the page."""
    from ..render import figures as render, stills as render3d, anim as render_anim, viewer
    from ..checks.rules import default_printer_key
    from ..exchange.files import write_atomic
    from ..checks.report import simulation_json

    name = design.name
    base = out / dirname
    log.info("gallery: %s: simulating and checking (%d scatter samples, seed %d)", name, samples, seed)
    result, ev, replay = _evaluate(design, lib, dt, samples, seed)
    robust = ev.robust
    sim = simulation_json(result)
    write_atomic(base / "simulation.json", _json_bytes(sim))
    checks = _check_json(ev, default_printer_key())
    write_atomic(base / "check.json", _json_bytes(checks))

    # the page's fold time: the latest hinge's 98 % time from its recovery curve, so it
    # does not depend on the time step (simulation.json's is the first sample past it)
    hinge_times = [h["fold_time_s"] for h in sim["hinges"]]
    fold_time = (max(hinge_times, default=0.0) if sim["completed"] and None not in hinge_times
                 else None)
    entry = _Entry(design, dirname, sim, checks, fold_time=fold_time,
                   contacts=[(c.panels[0], c.panels[1], c.time, c.method) for c in result.contacts],
                   hinge_done=list(result.hinge_done))
    entry.data_links = [_Link(_url(f"{dirname}/simulation.json"), "simulation (JSON)"),
                        _Link(_url(f"{dirname}/check.json"), "design-rule checks and jam probability (JSON)")]
    if robust is not None:
        entry.mc = _mc_summary(robust)
        entry.worst = None if replay is None else _worst_json(replay, design)
        write_atomic(base / "samples.json", _json_bytes({"design": name, **entry.mc, "worst": entry.worst}))
        entry.data_links.append(_Link(_url(f"{dirname}/samples.json"),
                                      "Monte-Carlo samples: each one's outcome, the worst one's parameters (JSON)"))
    model = result.trajectory.model
    bath = result.trajectory.bath_c

    log.info("gallery: %s: viewer", name)
    ok, status = _status(entry)
    passes, verdict = _verdict(entry)
    try:
        data = viewer.viewer_data(result, lib, robust, worst=replay)
    except FoldprintError as exc:  # the printed part cannot be built: said on the page
        log.warning("gallery: %s: no 3D viewer: %s", name, exc)
        entry.viewer_note = f"No 3D viewer: {exc}"
    else:
        page = viewer.viewer_page(data, f"Nominal fold: {status} {verdict}", ok and passes,
                                  f"../index.html#{quote('d-' + dirname)}", __version__)
        size = len(write_atomic(base / "viewer.html", page).read_bytes())
        entry.viewer = _Link(_url(f"{dirname}/viewer.html"), "interactive 3D viewer", size)

    log.info("gallery: %s: rendering", name)
    for state, what in (("programmed", "programmed (flat) state, as it goes into the bath"),
                        ("permanent", "permanent state: the printed shape every hinge recovers to")):
        fig = render3d.render_state(design, render3d.state_poses(design, state, model),
                                    f"{name}: {state} state", model=model, library=lib)
        entry.images.append(_write_image(
            out, f"{dirname}/{state}.png", render.figure_bytes(fig, "png", STATE_DPI),
            f"3D view of {name} in the {state} state", f"The {what}."))
    times = render3d.frame_times(result, 4)
    fig = render3d.render_frames(result, 4, library=lib)
    t_list = ", ".join(f"{t:.2f}" for t in times)
    entry.images.append(_write_image(
        out, f"{dirname}/frames.png", render.figure_bytes(fig, "png", PLOT_DPI),
        f"Four 3D views of {name} while folding, at {t_list} s",
        f"Mid-fold frames at {t_list} s (same camera and scale); panels in contact in red.",
        wide=True))
    gif = render_anim.fold_animation_gif(result, gif_frames, dpi=GIF_DPI, library=lib)
    end = render3d.motion_end(result)
    entry.images.append(_write_image(
        out, f"{dirname}/fold.gif", gif,
        f"Animation of {name} folding in a {bath:g} \u00b0C bath, from flat to {end:.1f} s",
        f"The fold from 0 to {end:.2f} s ({gif_frames} frames, looping)."
        + (" After the first contact the model's motion is kinematic only: the real part jams."
           if result.contacts else "")))
    entry.images.append(_write_image(
        out, f"{dirname}/hinge_angles.png",
        render.figure_bytes(render.hinge_angle_figure(result), "png", PLOT_DPI),
        f"Fold angle of each hinge of {name} against time",
        "Hinge angles against time (paper Fig. 3b style); dashed red lines mark contacts."))
    if design.is_planar_strip and result.index2d is not None:
        entry.images.append(_write_image(
            out, f"{dirname}/collision_index.png",
            render.figure_bytes(render.collision_index_figure(result), "png", PLOT_DPI),
            f"Collision index of every non-adjacent panel pair of {name} against time",
            "The paper's collision index S_ij (Fig. 4 style): contact where it enters the shaded "
            "band (0, 1); red points are contacts."))

    if robust is not None:
        fig = render.sample_outcomes_figure(robust, None if entry.worst is None else entry.worst["sample"])
        entry.images.append(_write_image(
            out, f"{dirname}/samples.png", render.figure_bytes(fig, "png", PLOT_DPI),
            f"Histogram of the fold times and first-contact times of the {robust.samples} scatter samples of "
            f"{name}, and how often each panel pair collides first",
            f"The {robust.samples} Monte-Carlo samples (seed {robust.seed}) of the jam probability: when each "
            "completes (green) or first collides (red), the nominal fold dashed; right, the first-colliding "
            "pairs.", wide=True))

    from .pipeline import export as export_design

    log.info("gallery: %s: exporting printable files", name)
    try:
        records = export_design(design, base / "files", state="permanent",
                                formats=("3mf", "prusa3mf", "stl"), library=lib)
    except FoldprintError as exc:  # a part that cannot be built is shown, not raised
        log.warning("gallery: %s: export failed: %s", name, exc)
        entry.export_note = f"Export failed: {exc}"
    else:
        from ..exchange.files import flatten

        flatten(base / "files")  # plain files: web hosts skip the export's dot-folder layout
        for rec in records:
            fname = Path(rec["path"]).name
            entry.files.append(_Link(_url(f"{dirname}/files/{fname}"),
                                     _format_label(rec, fname), rec.get("bytes")))
    return entry


def _format_label(rec: dict, fname: str) -> str:
    fmt = rec.get("format", "")
    mats = ", ".join(b.get("material", "?") for b in rec.get("bodies", []))
    if fmt == "3mf":
        return f"3MF, every material as its own body ({fname})"
    if fmt == "prusa3mf":
        return f"3MF for PrusaSlicer ({fname})"
    if fmt == "stl":
        return f"STL, {mats} ({fname})"
    if fmt == "manifest":
        return f"manifest: which STL is which material ({fname})"
    return f"{fmt} ({fname})"


# -- the page -------------------------------------------------------------------------

_CSS = """
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, Helvetica, Arial, sans-serif;
       margin: 0 auto; max-width: 1100px; padding: 0 1.2em 3em; color: #1d1d1f; background: #fff; }
h1 { margin: 0.8em 0 0.2em; } h2 { margin-top: 2.2em; border-bottom: 2px solid #ddd; }
h3 { margin: 1.4em 0 0.4em; font-size: 1.05em; }
table { border-collapse: collapse; margin: 0.4em 0; }
th, td { border: 1px solid #ddd; padding: 0.25em 0.6em; text-align: left; vertical-align: top; }
th { background: #f4f4f4; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
figure { margin: 0.8em 0; }
figcaption { color: #555; font-size: 0.9em; }
img { max-width: 100%; height: auto; border: 1px solid #eee; }
.status { padding: 0.5em 0.8em; border-radius: 4px; font-weight: 600; }
.ok { background: #e6f4ea; color: #1e6b34; } .fail { background: #fdecea; color: #9b1c1c; }
.sev-error { color: #9b1c1c; font-weight: 600; } .sev-warning { color: #8a5300; font-weight: 600; }
.sev-info { color: #555; }
.swatch { display: inline-block; width: 0.9em; height: 0.9em; border: 1px solid #888;
          vertical-align: -0.1em; margin-right: 0.3em; }
.pics { display: grid; grid-template-columns: repeat(auto-fit, minmax(420px, 1fr)); gap: 0.8em 1.2em;
        align-items: start; }
.pics figure.wide { grid-column: 1 / -1; }
.muted { color: #666; }
code { font-size: 0.92em; }
a.button { display: inline-block; padding: 0.3em 0.9em; border-radius: 4px; background: #2f5d9e; color: #fff;
           text-decoration: none; font-weight: 600; }
"""


def _e(text) -> str:
    return html.escape(str(text), quote=True)


def _status(entry: _Entry) -> tuple[bool, str]:
    """(completed, one-line status text) of a design."""
    sim = entry.sim
    if sim["completed"]:
        return True, (f"Completes in {_fmt_s(entry.fold_time)} at {sim['temperature_c']:g} \u00b0C; "
                      "no collision" + (", every goal met." if sim["goals"] else "."))
    reasons = []
    if entry.contacts:
        a, b, t, method = entry.contacts[0]
        reasons.append(f"collision: panels {a} and {b} touch at {t:.3f} s ({method})")
    stalled = [h["id"] for h, done in zip(sim["hinges"], entry.hinge_done) if not done]
    if stalled:
        reasons.append(f"hinges {', '.join(stalled)} do not reach 98 % within {sim['duration_s']:g} s")
    missed = [g["id"] for g in sim["goals"] if not g["met"]]
    if missed:
        reasons.append(f"goals not met: {', '.join(missed)}")
    return False, "Does not complete \u2014 " + "; ".join(reasons) + "."


def _verdict(entry: _Entry) -> tuple[bool, str]:
    """(passes, one line) of ``foldprint check``'s verdict: its exit status and error codes."""
    chk = entry.checks
    codes = list(dict.fromkeys(f["code"] for f in chk["findings"] if f["severity"] == "error"))
    if chk["ok"]:
        return True, f"foldprint check passes (exit 0; {chk['warnings']} warning(s))."
    return False, f"foldprint check fails (exit 1): {chk['errors']} error(s), {', '.join(codes)}."


def _pct(p: float) -> str:
    return f"{100 * p:.1f} %"


def _jam_text(mc: dict) -> str:
    lo, hi = mc["ci95"]
    return f"{_pct(mc['jam_probability'])} (95 % CI {_pct(lo)}\u2013{_pct(hi)})"


def _mc_html(entry: _Entry) -> str:
    """The design's Monte-Carlo: estimate, first-colliding pairs, fold times, worst sample."""
    mc = entry.mc
    if mc is None:
        return ('<h3>Under manufacturing scatter</h3><p class="muted">Not run (0 samples): no jam '
                "probability.</p>")
    n, f = mc["samples"], mc["failures"]
    ways = ", ".join(f"{k} {w}" for w, k in (("collide", f["collision"]), ("miss a goal", f["goal"]),
                                               ("do not finish folding", f["unfolded"])) if k)
    parts = [f"<h3>Under manufacturing scatter ({n} samples, seed {mc['seed']})</h3>",
             f"<p>Jam probability <strong>{_e(_jam_text(mc))}</strong>: {mc['jams']} of {n} samples jam"
             + (f" ({_e(ways)})" if ways else "") + ". The same samples, seed and time step as "
             f"<code>foldprint check</code>; each sample draws Tg, thickness and heat transfer per hinge and "
             f"the bath temperature, and folds the printed part ({_e(mc['hinge_model'])} hinges).</p>"]
    if mc["pairs"]:
        rows = "".join(
            f"<tr><td>{_e(p['pair'][0])}\u2013{_e(p['pair'][1])}</td><td class=\"num\">{p['count']}</td>"
            f"<td class=\"num\">{_pct(p['count'] / n)}</td><td class=\"num\">{p['first_s']:.3f} s</td>"
            f"<td class=\"num\">{p['median_s']:.3f} s</td><td class=\"num\">{p['last_s']:.3f} s</td></tr>"
            for p in mc["pairs"])
        parts.append("<table><caption>First-colliding panel pairs</caption><thead><tr><th>panels</th>"
                     "<th>samples</th><th>share</th><th>earliest contact</th><th>median</th><th>latest</th>"
                     f"</tr></thead><tbody>{rows}</tbody></table>")
    else:
        parts.append("<p>No sample collides.</p>")
    ft = [o["fold_time_s"] for o in mc["outcomes"] if o["fold_time_s"] is not None]
    if ft:
        p = mc["fold_time_s"]
        parts.append("<table><caption>Fold time of the samples that complete</caption><thead><tr><th>samples</th>"
                     "<th>fastest</th><th>5 %</th><th>median</th><th>95 %</th><th>slowest</th></tr></thead>"
                     f"<tbody><tr><td class=\"num\">{len(ft)}</td><td class=\"num\">{min(ft):.2f} s</td>"
                     f"<td class=\"num\">{p['p5']:.2f} s</td><td class=\"num\">{p['p50']:.2f} s</td>"
                     f"<td class=\"num\">{p['p95']:.2f} s</td><td class=\"num\">{max(ft):.2f} s</td></tr>"
                     "</tbody></table>")
    else:
        parts.append("<p>No sample completes its fold.</p>")
    w = entry.worst
    if w is not None:
        link = (f' <a href="{_e(entry.viewer.href)}#run=worst">Replay it in the 3D viewer</a>.'
                if entry.viewer is not None else "")
        rep = w["replay"]
        again = ("completes" if rep["completed"] else "does not complete") + (
            f", first contact {rep['first_collision']['panels'][0]}\u2013{rep['first_collision']['panels'][1]} "
            f"at {rep['first_collision']['time_s']:.3f} s" if rep["first_collision"] else "")
        note = "" if w["replay_agrees"] else " (the replay does not give the recorded outcome: a bug, please report)"
        prm = w["parameters"]
        rows = []
        for k, hid in enumerate(w["hinges"]):
            cells = "".join(f'<td class="num">{_e(_param(name, vals[k]))}</td>' for name, vals in prm.items()
                            if isinstance(vals, list))
            rows.append(f"<tr><td>{_e(hid)}</td>{cells}</tr>")
        heads = "".join(f"<th>{_e(_PARAM_NAMES.get(name, name))}</th>" for name, vals in prm.items()
                        if isinstance(vals, list))
        shared = ", ".join(f"{_PARAM_NAMES.get(name, name)} {_param(name, v)}" for name, v in prm.items()
                           if not isinstance(v, list))
        parts.append(f"<p><strong>Worst sample: #{w['sample']}</strong>, {_e(w['why'])}; replayed, it "
                     f"{_e(again)}{_e(note)}.{link}</p>"
                     f"<details><summary>its drawn parameters ({_e(shared)})</summary><table><thead><tr>"
                     f"<th>hinge</th>{heads}</tr></thead><tbody>{''.join(rows)}</tbody></table></details>")
    return "\n".join(parts)


_PARAM_NAMES = {"tg_shift_c": "Tg shift", "thickness_mm": "thickness", "h_scale": "heat-transfer factor",
                "bath_c": "bath", "h_part": "part heat-transfer factor"}


def _param(name: str, v: float) -> str:
    if name.endswith("_c"):
        return f"{v:+.2f} \u00b0C" if name == "tg_shift_c" else f"{v:.2f} \u00b0C"
    if name.endswith("_mm"):
        return f"{v:.3f} mm"
    return f"\u00d7{v:.3f}"


def _img_html(img: _Image) -> str:
    cls = ' class="wide"' if img.wide else ""
    return (f'<figure{cls}><img src="{_e(img.src)}" width="{img.width}" height="{img.height}" '
            f'alt="{_e(img.alt)}"><figcaption>{_e(img.caption)}</figcaption></figure>')


def _link_html(link: _Link) -> str:
    size = "" if link.size is None else f' <span class="muted">({_size(link.size)})</span>'
    return f'<li><a href="{_e(link.href)}">{_e(link.label)}</a>{size}</li>'


def _size(n: int) -> str:
    return f"{n} B" if n < 1024 else f"{n / 1024:.1f} kB" if n < 1024 * 1024 else f"{n / 1024 ** 2:.1f} MB"


def _ramp_note(d: Design) -> str:
    """The VeroWhite ramp's legend under the hinge table, when a hinge names a fraction."""
    ramp = composition.ramp_legend(h.material for h in d.hinges)
    if ramp is None:
        return ""
    bar = (f'<span class="swatch" style="width:6em;background:linear-gradient(to right, {_e(ramp["tangoblack"])}, '
           f'{_e(ramp["verowhite"])})"></span>')
    items = "; ".join(f"{_e(n)}: {_e(t)}" for n, t in ramp["labels"].items())
    return (f'<p class="muted">{bar} VeroWhite fraction, TangoBlack 0 to VeroWhite 1 (usable '
            f'{ramp["range"][0]:.3f}-{ramp["range"][1]:.3f}; docs/composition.md). {items}</p>')


def _swatch(lib: MaterialLibrary, material: str) -> str:
    color = lib[material].color[:7] if material in lib else "#9a9a9a"
    if composition.is_composition_name(material):  # the VeroWhite ramp; graded: a gradient
        color = composition.css_background(material)
    return f'<span class="swatch" style="background:{_e(color)}"></span>'


def _design_html(entry: _Entry, lib: MaterialLibrary) -> str:
    d, sim, chk = entry.design, entry.sim, entry.checks
    ok, status = _status(entry)
    anchor = _e(f"d-{entry.dirname}")
    parts = [f'<section class="design" id="{anchor}">', f"<h2>{_e(d.name)}</h2>"]
    if d.description:
        parts.append(f'<p class="desc">{_e(d.description)}</p>')
    parts.append(f'<p class="status {"ok" if ok else "fail"}">Nominal fold: {_e(status)}</p>')
    passes, verdict = _verdict(entry)
    parts.append(f'<p class="status {"ok" if passes else "fail"}">{_e(verdict)}</p>')
    if entry.viewer is not None:
        parts.append(f'<p class="viewer"><a class="button" href="{_e(entry.viewer.href)}">Open the interactive '
                     f'3D viewer</a> <span class="muted">(orbit, zoom, scrub the fold; programmed and permanent '
                     f'states{"; the worst scatter sample" if entry.worst is not None else ""}; '
                     f'{_e(_size(entry.viewer.size))} page)</span></p>')
    elif entry.viewer_note:
        parts.append(f'<p class="muted">{_e(entry.viewer_note)}</p>')
    kind = "planar strip (side view)" if d.is_planar_strip else "3D crease pattern"
    fold = (f"{_fmt_s(entry.fold_time)} (every hinge at 98 %)" if entry.fold_time is not None
            else "\u2014 (does not complete)")
    parts.append(
        "<table><tbody>"
        f"<tr><th>bath</th><td>{sim['temperature_c']:g} \u00b0C</td></tr>"
        f"<tr><th>fold time</th><td>{_e(fold)}</td></tr>"
        f"<tr><th>structure</th><td>{len(d.panels)} panels, {len(d.hinges)} hinges, {_e(kind)}</td></tr>"
        f"<tr><th>model</th><td>{_e(HINGE_MODEL_TEXT.get(sim['hinge_model'], sim['hinge_model'] + ' hinges'))}; "
        f"collision check {_e(sim['method'])}, "
        f"after contact: {_e(sim['after_contact'])}, dt {_e(sim['dt_s'])} s</td></tr>"
        + (f"<tr><th>jam probability</th><td>{_e(_jam_text(entry.mc))} in {entry.mc['samples']} samples"
           "</td></tr>" if entry.mc is not None else "")
        + "</tbody></table>")
    if entry.contacts:
        rows = "".join(f"<tr><td>{_e(a)}\u2013{_e(b)}</td><td class=\"num\">{t:.3f} s</td><td>{_e(m)}</td></tr>"
                       for a, b, t, m in entry.contacts)
        parts.append("<h3>Contacts</h3><table><thead><tr><th>panels</th><th>time</th><th>found by</th>"
                     f"</tr></thead><tbody>{rows}</tbody></table>")
    rows = []
    for h, hd in zip(d.hinges, sim["hinges"]):
        rows.append(f"<tr><td>{_e(h.id)}</td><td>{_e(h.panels[0])}\u2013{_e(h.panels[1])}</td>"
                    f"<td>{_swatch(lib, h.material)}{_e(h.material)}</td>"
                    f"<td class=\"num\">{hd['target_angle_deg']:g}\u00b0</td>"
                    f"<td class=\"num\">{_e(_fmt_s(hd['fold_time_s']))}</td></tr>")
    parts.append("<h3>Hinges</h3><table><thead><tr><th>hinge</th><th>panels</th><th>material</th>"
                 "<th>target angle</th><th>fold time (98 %)</th></tr></thead>"
                 f"<tbody>{''.join(rows)}</tbody></table>")
    parts.append(_ramp_note(d))
    parts.append("<h3>Goals</h3>")
    if sim["goals"]:
        rows = []
        for g in sim["goals"]:
            what = f"{g['panel']} passes through holes[{g['hole']}] of {g['target']}" \
                if g["type"] == "pass_through" else g["type"]
            met = f"met at {g['time_s']:.2f} s" if g["met"] else (
                "passed out of order" if g["passes_s"] else "NOT met")
            rows.append(f"<tr><td>{_e(g['id'])}</td><td>{_e(what)}</td><td class=\"num\">{g['order']}</td>"
                        f"<td class=\"{'ok' if g['met'] else 'fail'}\">{_e(met)}</td></tr>")
        parts.append("<table><thead><tr><th>goal</th><th>what</th><th>order</th><th>result</th></tr>"
                     f"</thead><tbody>{''.join(rows)}</tbody></table>")
    else:
        parts.append('<p class="muted">No goals.</p>')
    counts = {s: sum(f["severity"] == s for f in chk["findings"]) for s in ("error", "warning", "info")}
    parts.append(f"<h3>Design-rule checks ({_e(chk['printer'])})</h3>")
    parts.append(f"<p>{counts['error']} error(s), {counts['warning']} warning(s), {counts['info']} note(s).</p>")

    def finding(f) -> str:
        hint = f' <span class="muted">\u2014 {_e(f["hint"])}</span>' if f.get("hint") else ""
        return (f'<li><span class="sev-{_e(f["severity"])}">{_e(f["severity"].upper())} {_e(f["code"])}</span> '
                f"{_e(f['message'])}{hint}</li>")

    serious = [f for f in chk["findings"] if f["severity"] in ("error", "warning")]
    if serious:
        parts.append("<ul>" + "".join(finding(f) for f in serious) + "</ul>")
    info = [f for f in chk["findings"] if f["severity"] == "info"]
    if info:
        parts.append(f"<details><summary>{len(info)} note(s)</summary><ul>"
                     + "".join(finding(f) for f in info) + "</ul></details>")
    parts.append(_mc_html(entry))
    parts.append("<h3>Pictures</h3>")
    parts.append('<div class="pics">' + "".join(_img_html(i) for i in entry.images) + "</div>")
    parts.append("<h3>Files</h3><ul>")
    parts.extend(_link_html(link) for link in entry.files)
    parts.extend(_link_html(link) for link in entry.data_links)
    parts.append("</ul>")
    if entry.export_note:
        parts.append(f'<p class="muted">{_e(entry.export_note)}</p>')
    parts.append("</section>")
    return "\n".join(parts)


def _page(entries: list[_Entry], materials_img: _Image, lib: MaterialLibrary, dt: float,
          samples: int = CHECK_SAMPLES, seed: int = CHECK_SEED) -> str:
    rows = []
    for en in entries:
        ok, _ = _status(en)
        passes, _ = _verdict(en)
        codes = ", ".join(dict.fromkeys(f["code"] for f in en.checks["findings"] if f["severity"] == "error"))
        first = (f"{_e(en.contacts[0][0])}\u2013{_e(en.contacts[0][1])} at {en.contacts[0][2]:.3f} s"
                 if en.contacts else "none")
        ft = _fmt_s(en.fold_time)
        jam = "not run" if en.mc is None else _jam_text(en.mc)
        view = (f' <a class="muted" href="{_e(en.viewer.href)}">3D viewer</a>' if en.viewer is not None else "")
        rows.append(f'<tr><td><a href="#{_e("d-" + en.dirname)}">{_e(en.design.name)}</a>{view}</td>'
                    f'<td class="{"ok" if passes else "fail"}">'
                    + (f"passes (exit 0)" if passes else f"fails (exit 1): {_e(codes)}") + "</td>"
                    f'<td class="{"ok" if ok else "fail"}">{"completes" if ok else "does not complete"}</td>'
                    f'<td class="num">{_e(ft)}</td><td>{first}</td><td class="num">{_e(jam)}</td>'
                    f'<td class="num">{en.checks["errors"]}</td><td class="num">{en.checks["warnings"]}</td></tr>')
    summary = ("<table><thead><tr><th>design</th><th>foldprint check</th><th>nominal fold</th><th>fold time</th>"
               "<th>first collision</th><th>jam probability (95 % CI)</th><th>check errors</th><th>warnings</th>"
               f"</tr></thead><tbody>{''.join(rows)}</tbody></table>")
    models = sorted({en.sim["hinge_model"] for en in entries})
    model_text = "; ".join(HINGE_MODEL_TEXT.get(m, f"{m} hinges") for m in models) or "no design"
    mc_text = (f"and each folded {samples} more times under manufacturing scatter (seed {seed}) for its jam "
               "probability: the same check, samples and seed as <code>foldprint check</code>, whose verdict "
               "(exit status and error codes) the summary gives" if samples else
               "without the Monte-Carlo jam probability (0 samples; <code>foldprint check</code> runs it)")
    body = "\n".join(_design_html(en, lib) for en in entries)
    return f"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="foldprint {_e(__version__)}">
<title>foldprint gallery</title>
<style>{_CSS}</style>
</head>
<body>
<header>
<h1>foldprint gallery</h1>
<p>Sequentially self-folding structures printed with digital shape-memory polymers (after Mao et al.,
Sci. Rep. 5, 13616, 2015): {len(entries)} design(s), simulated with {_e(model_text)}
(time step {dt:g} s, first contacts refined between time steps), checked against the design rules
{mc_text}. The paper's point-hinge reduced-order model is a comparison mode
(<code>foldprint simulate --hinge-model point</code>). Generated by foldprint {_e(__version__)}.</p>
</header>
<main>
<h2 id="summary">Summary</h2>
{summary}
<h2 id="materials">Materials</h2>
{_img_html(materials_img)}
{body}
</main>
</body>
</html>
"""
