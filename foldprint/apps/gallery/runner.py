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
  samples; the viewer replays the worst sample (:func:`foldprint.apps.replay.worst_sample`)
  beside the nominal fold;
* ``files/``: the printable files from :meth:`foldprint.apps.pipeline.Evaluation.export` (the part
  the check built)
  (3MF, PrusaSlicer 3MF, STL per material, manifest), when that module is available;

and, once, ``out_dir/materials.png`` (fold time against bath temperature) and
``out_dir/index.html``, one self-contained page (inline CSS, no scripts, relative links)
that ties everything together. Designs are built in parallel worker processes (the
collision checks hold the GIL). The gallery is one set of plain files: it is written into
a staging folder beside ``out_dir`` and published by renaming it into place
(:class:`foldprint.exchange.fileset.StagedSet`), so ``out_dir`` always holds one complete
gallery; nothing is printed, progress is logged and reported to an optional callback. The output is deterministic: building twice, with any
number of processes, gives the same bytes (export files aside, which belong to the exporter).

A design whose inputs did not change since the gallery in ``out_dir`` was built keeps its
folder and its entry (:mod:`foldprint.apps.gallery.cache`: design, materials, code and
data, options); a gallery whose every design is kept and whose page is the same is not
written again; ``cache=False`` builds everything.
"""


from __future__ import annotations

import logging
import os
import re
import time
from pathlib import Path
from typing import Callable, Sequence

from ...core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SCALES, CHECK_SEED
from ...model.design import Design
from ...model.materials import MaterialLibrary, default_library
from .build import GIF_FRAMES, build_design, chart_task  # noqa: F401 (re-exported)
from .page import entry_done, page_html  # noqa: F401 (re-exported)

log = logging.getLogger(__name__)

Progress = Callable[[int, int, str], None]
"""``progress(done, total, message)``: called as each part of the gallery is finished."""


def _slug(name: str) -> str:
    """A directory-name-safe version of a design name."""
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).strip("._") or "design"


def _unique_dirnames(designs: Sequence[Design]) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for d in designs:
        base = _slug(d.name)
        if base.lower() in ("materials.png", "index.html", "viewer", "foldprint-set.json", "gallery-cache.json"):
            base = f"design_{base}"
        k = seen.get(base.lower(), 0) + 1
        seen[base.lower()] = k
        out.append(base if k == 1 else f"{base}-{k}")
    return out


def build_gallery(designs: Sequence[Design], out_dir: str | Path,
                  progress: Progress | None = None, *,
                  library: MaterialLibrary | None = None, dt: float = CHECK_DT_S,
                  gif_frames: int = GIF_FRAMES, jobs: int | None = None, samples: int = CHECK_SAMPLES,
                  seed: int = CHECK_SEED, force: bool = False,
                  activity: Callable[[str], None] | None = None, cache: bool = True) -> Path:
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
        The most Monte-Carlo samples of each design's jam test (per sigma scale) and their
        seed (default: what ``foldprint check`` runs, its sequential test at most
        :data:`foldprint.core.constants.CHECK_SAMPLES` and
        :data:`~foldprint.core.constants.CHECK_SEED`); 0 samples skips it.
    force : bool
        Publish into a folder that holds other files (beside them, file by file) instead
        of refusing it.
    activity : callable, optional
        ``activity(text)``, called as the jam tests consume samples: what the pool is
        doing now ("jam tests: 12 of 30 decided, 1 204 samples"), for a live status line.
    cache : bool
        Keep each design whose inputs did not change from the gallery already in
        ``out_dir`` (:mod:`foldprint.apps.gallery.cache`); False builds every design again.

    Returns
    -------
    Path
        ``out_dir/index.html``.

    Raises
    ------
    foldprint.core.errors.ExportError
        If ``out_dir`` may not take the gallery (a folder of other files without
        ``force``, a system folder, a file; checked before anything is built) or a file
        cannot be written; ``out_dir`` then keeps what it held. A design whose printable
        files cannot be built is reported on the page (and logged), not raised.
    """
    from ...exchange.fileset import StagedSet
    from ...render.viewer import ASSETS, asset_bytes

    from .cache import Earlier

    lib = library or default_library()
    t_start = time.perf_counter()
    dirnames = _unique_dirnames(designs)
    step = _Steps(len(designs) + 2, progress)
    earlier = Earlier(out_dir, cache)
    options = {"dt": dt, "gif_frames": gif_frames, "samples": samples, "seed": seed}
    if _unchanged(earlier, designs, dirnames, lib, options, step):
        return Path(out_dir) / "index.html"
    with StagedSet(out_dir, force) as staged:
        out = staged.path
        for name in ASSETS:
            staged.write(f"viewer/{name}", asset_bytes(name))
        materials_img, entries = _build_all(designs, out, dirnames, lib, options, jobs, step, activity, earlier)
        for entry, design in zip(entries, designs):
            entry.design = design  # the worker's copy came back pickled; keep the caller's
        staged.write("index.html", page_html(entries, materials_img, lib, dt, samples, seed).encode("utf-8"))
    step("index.html")
    log.info("gallery: %d design(s) in %s (%.1f s)", len(entries), out_dir, time.perf_counter() - t_start)
    return Path(out_dir) / "index.html"


def _unchanged(earlier, designs, dirnames, lib, options: dict, step: "_Steps") -> bool:
    """Whether the gallery already there is the one these inputs give (nothing to write;
    :meth:`foldprint.apps.gallery.cache.Earlier.unchanged`); each part reported kept."""
    dt, samples, seed = options["dt"], options["samples"], options["seed"]
    if not earlier.unchanged(designs, dirnames, lib, options,
                             lambda es, img: page_html(es, img, lib, dt, samples, seed).encode("utf-8")):
        return False
    for msg in ["material chart"] + [d.name for d in designs]:
        step(f"{msg}: unchanged, kept")
    step("index.html: unchanged, nothing written")
    return True


class _Steps:
    """Counts the finished parts of the gallery, logs each and reports it to ``progress``."""

    def __init__(self, total: int, progress: Progress | None):
        self.total, self.progress, self.done = total, progress, 0

    def __call__(self, msg: str) -> None:
        self.done += 1
        log.info("gallery: [%d/%d] %s", self.done, self.total, msg)
        if self.progress is not None:
            self.progress(self.done, self.total, msg)


class _Tests:
    """The jam tests of the gallery's pool as one status line for ``activity`` (a design's
    sweep and probes join once the test before them decided)."""

    def __init__(self, activity: Callable[[str], None] | None):
        self.activity, self.at = activity, {}

    def __call__(self, st) -> None:
        self.at[(st.job, st.scale)] = st
        if self.activity is not None:
            decided = sum(s.done for s in self.at.values())
            used = sum(s.samples for s in self.at.values())
            self.activity(f"jam tests: {decided} of {len(self.at)} decided, {used} samples used")


def _build_all(designs: Sequence[Design], out: Path, dirnames: list[str], lib: MaterialLibrary, options: dict,
               jobs: int | None, step: "_Steps", activity, earlier):
    """The material chart and every design's entry: kept from the ``earlier`` gallery
    where its inputs did not change (:class:`foldprint.apps.gallery.cache.Earlier`), the
    rest built in one process pool with their Monte-Carlo (:func:`_build_pool`); each
    built one's cache file written beside its files."""
    from .cache import CACHE_FILE, chart_bytes, chart_key, design_key, entry_bytes

    ckey = chart_key(lib)
    chart = earlier.chart(ckey, out)
    if chart is not None:
        step("material chart: unchanged, kept")
    entries: list = [None] * len(designs)
    keys = [design_key(d, lib, n, options) for d, n in zip(designs, dirnames)]
    for i, (d, n) in enumerate(zip(designs, dirnames)):
        entries[i] = earlier.design(d, n, keys[i], out)
        if entries[i] is not None:
            step(f"{d.name}: unchanged, kept")
    todo = [i for i, e in enumerate(entries) if e is None]
    if todo or chart is None:
        built, img = _build_pool([designs[i] for i in todo], out, [dirnames[i] for i in todo], lib, options,
                                 jobs, step, activity, chart is None)
        for i, entry in zip(todo, built):
            entries[i] = entry
            (out / dirnames[i] / CACHE_FILE).write_bytes(entry_bytes(entry, keys[i]))
        if chart is None:
            chart = img
            (out / CACHE_FILE).write_bytes(chart_bytes(img, ckey))
    return chart, entries


def _build_pool(designs: Sequence[Design], out: Path, dirnames: list[str], lib: MaterialLibrary, options: dict,
                jobs: int | None, step: "_Steps", activity, chart: bool):
    """Designs' entries and (``chart``) the material chart, built in one process pool with
    every design's Monte-Carlo (:func:`foldprint.simulation.jamtest.pool.run_batch`)."""
    dt, gif_frames, samples, seed = options["dt"], options["gif_frames"], options["samples"], options["seed"]
    from ...simulation.jamtest.pool import MonteCarloJob, run_batch
    from ...simulation.jamtest.stages import check_follow
    from ...simulation.jamtest.verdict import jam_test

    # the workers fork from here: import what they all need once, before the fork
    from ...checks import rules as checks  # noqa: F401
    from ... import geometry  # noqa: F401
    from ...render import figures as render, anim as render_anim, viewer  # noqa: F401
    from ...simulation import simulate  # noqa: F401
    from ...exchange import export  # noqa: F401 - the printable files (trimesh, meshio, gltf)
    from .. import pipeline  # noqa: F401 - each design's Evaluation
    render.pyplot()  # matplotlib is imported lazily: once here, not in every worker

    # one pool for everything: every design's jam test at 1x, then its sweep, then the probes
    # of a flip (check's stages: foldprint.simulation.jamtest.stages; chunks submitted as
    # workers free up, costliest first, none after a test decides), each design's build once
    # its tests are decided, and the material chart (foldprint.simulation.jamtest.pool)
    test = jam_test(max_samples=samples) if samples else None  # check's test, default thresholds
    mc = [MonteCarloJob(d, samples, seed, (1.0,), dt=dt, test=test) for d in designs]

    def after(i, pre):
        return build_design, (designs[i], out, dirnames[i], lib, dt, gif_frames, samples, seed, pre)

    tests = _Tests(activity)

    def report(kind, what, out=None):
        if kind == "samples":
            tests(what)
        elif kind == "warm":  # a cold numba cache: the first run after an install
            if activity is not None:  # each group 41-43 CPU-s, one a worker (docs/kernels.md)
                activity(f"compiling the kernels, once after an install ({len(what)} groups in parallel, "
                         "about 45 s)")
        else:
            step("material chart" if kind == "task" else entry_done(out))

    _, entries, images = run_batch(
        mc, library=lib, workers=max(1, jobs or os.cpu_count() or 1), after=after,
        tasks=[(chart_task, (out, lib))] if chart else [], progress=report, follow=check_follow(mc, CHECK_SCALES))
    return entries, (images[0] if chart else None)
