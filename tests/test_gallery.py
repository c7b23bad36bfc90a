"""The HTML gallery (foldprint.apps.gallery.runner) and the 3D renders behind it (foldprint.render.stills).

One gallery of two small templates is built per module; the page is checked as files
(every image referenced exists and is valid, every file referenced exists, offline, valid
HTML5 structure) and, where Chromium is installed, in a real headless browser.
"""

from __future__ import annotations

import html
import io
import json
import os
import re
import shutil
import subprocess
import threading
from functools import partial
from html.parser import HTMLParser
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import unquote

import pytest
from PIL import Image

from foldprint.model.design import strip
from foldprint.io.load import load_design
from foldprint.apps.gallery.runner import build_gallery
from foldprint.core.display import seconds
from foldprint.io.templates import templates_dir

FAILING = "self_lock_uniform"  # collides (panels p1 and p6) with the printed, arc hinges
JAMS = "helix_uniform"  # the paper's Sample 1: folds nominally, jams under scatter (check: FP180)
DESIGNS = ("helix_graded", FAILING, JAMS)
PER_DESIGN = ("programmed.png", "permanent.png", "frames.png", "fold.gif", "hinge_angles.png",
              "collision_index.png", "samples.png", "check.json", "simulation.json", "samples.json",
              "viewer.html")
PNGS_PER_DESIGN = 6  # programmed, permanent, frames, hinge angles, collision index, samples
ACTIVITY: list[str] = []  # the gallery's live status lines (its jam tests), as the fixture saw them
VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source",
        "track", "wbr"}


@pytest.fixture(scope="module")
def gallery(tmp_path_factory):
    root = tmp_path_factory.mktemp("gallery")
    out = root / "site"
    steps: list[tuple[int, int, str]] = []
    designs = [load_design(templates_dir() / f"{n}.toml") for n in DESIGNS]
    index = build_gallery(designs, out, progress=lambda *a: steps.append(a), jobs=2, activity=ACTIVITY.append)
    return root, out, index, steps


class _Page(HTMLParser):
    """Collects images, links, text per section, and checks that tags nest."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.images: list[dict] = []
        self.links: list[str] = []
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tags: list[str] = []
        self.meta_charset = None
        self.section = None
        self.text: dict[str | None, list[str]] = {}

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if tag == "img":
            self.images.append(a)
        elif tag in ("a", "link"):
            if "href" in a:
                self.links.append(a["href"])
        elif tag == "meta" and "charset" in a:
            self.meta_charset = a["charset"]
        elif tag == "section":
            self.section = a.get("id")
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            self.errors.append(f"end tag for void element {tag}")
        elif not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}>")
        else:
            self.stack.pop()
        if tag == "section":
            self.section = None

    def handle_data(self, data):
        self.text.setdefault(self.section, []).append(data)


def _parse(index: Path) -> _Page:
    page = _Page()
    page.feed(index.read_text(encoding="utf-8"))
    page.close()
    return page


def _local(out: Path, url: str) -> Path:
    return out / unquote(url.split("#")[0])


# -- files ------------------------------------------------------------------------------

def test_gallery_writes_every_file(gallery):
    _, out, index, steps = gallery
    assert index == out / "index.html" and index.is_file()
    assert (out / "materials.png").is_file()
    for name in DESIGNS:
        for f in PER_DESIGN:
            assert (out / name / f).is_file(), f"{name}/{f} missing"
    # progress: one step per part (chart, each design, the index), counted up to the total
    total = len(DESIGNS) + 2
    assert [(d, t) for d, t, _ in steps] == [(k, total) for k in range(1, total + 1)]
    assert {m for *_, m in steps} >= {"material chart", "index.html"} | {
        f"{n}: simulated, checked, rendered, exported" for n in DESIGNS}
    assert not list(out.rglob("*.tmp")), "write_atomic left temporary files"


def test_gallery_is_one_set_of_plain_files(gallery):
    """Published whole: plain files only, exactly the manifest's names and sha256 (each
    design's printable files an export with its own manifest), nothing beside it."""
    from test_export_copies import check_copy

    root, out, _, _ = gallery
    files = check_copy(out)
    assert "index.html" in files and os.listdir(root) == ["site"]
    for name in DESIGNS:
        if (out / name / "files").is_dir():
            assert f"{name}/files/foldprint-set.json" in files
            check_copy(out / name / "files")


def test_images_are_valid(gallery):
    _, out, _, _ = gallery
    pngs = sorted(out.rglob("*.png"))
    assert len(pngs) == 1 + PNGS_PER_DESIGN * len(DESIGNS)
    for p in pngs:
        with Image.open(p) as im:
            assert im.format == "PNG"
            im.verify()
    for name in DESIGNS:
        with Image.open(out / name / "fold.gif") as im:
            assert im.format == "GIF"
            assert im.n_frames > 1
            assert im.info.get("loop") == 0
            size = im.size
            for k in range(im.n_frames):  # every frame decodes, all the same size
                im.seek(k)
                im.load()
                assert im.size == size


def test_json_outputs(gallery):
    _, out, _, _ = gallery
    graded = json.loads((out / "helix_graded" / "simulation.json").read_text())
    assert graded["design"] == "helix_graded" and graded["completed"] is True
    assert graded["first_collision"] is None and len(graded["hinges"]) == 9
    failing = json.loads((out / FAILING / "simulation.json").read_text())
    assert failing["completed"] is False
    assert sorted(failing["first_collision"]["panels"]) == ["p1", "p6"]
    check = json.loads((out / FAILING / "check.json").read_text())
    assert check["ok"] is False and check["errors"] >= 1
    assert any(f["code"] == "FP170" for f in check["findings"])  # the collision rule


def test_index_references_every_image_and_every_reference_exists(gallery):
    _, out, index, _ = gallery
    page = _parse(index)
    srcs = [img["src"] for img in page.images]
    referenced = {_local(out, s).resolve() for s in srcs}
    on_disk = {p.resolve() for p in out.rglob("*") if p.suffix in (".png", ".gif")}
    assert on_disk == referenced, f"unreferenced: {on_disk - referenced}, missing: {referenced - on_disk}"
    for href in page.links:
        if href.startswith("#"):
            continue
        assert _local(out, href).is_file(), f"broken link {href}"
    for img in page.images:  # alt text and the real pixel size as width/height attributes
        assert img.get("alt"), img
        with Image.open(_local(out, img["src"])) as im:
            assert (int(img["width"]), int(img["height"])) == im.size, img["src"]
    data = [h for h in page.links if h.endswith(".json")]
    assert {f"{n}/{f}" for n in DESIGNS for f in ("check.json", "simulation.json")} <= set(data)


def test_index_links_the_printable_files(gallery):
    _, out, index, _ = gallery
    page = _parse(index)
    text = index.read_text(encoding="utf-8")
    for name in DESIGNS:
        files = sorted(p for p in (out / name / "files").glob("*") if p.name != "foldprint-set.json") \
            if (out / name / "files").is_dir() else []  # every file but the set's manifest
        linked = {unquote(h) for h in page.links if h.startswith(f"{name}/files/")}
        if files:
            assert {f"{name}/files/{p.name}" for p in files} == linked
        else:  # the exporter is missing or failed for this design: said on the page
            assert not linked
            section = " ".join(page.text[f"d-{name}"])
            assert "No print files" in section or "not available" in section, name
    if (out / "helix_graded" / "files").is_dir():
        assert re.search(r'href="helix_graded/files/[^"]+\.3mf"', text)
        assert re.search(r'href="helix_graded/files/[^"]+\.stl"', text)


def test_index_is_offline_valid_html5(gallery):
    _, _, index, _ = gallery
    raw = index.read_text(encoding="utf-8")
    assert raw.startswith("<!DOCTYPE html>\n<html lang=\"en\">")
    page = _parse(index)
    assert page.meta_charset == "utf-8"
    assert page.errors == [] and page.stack == []
    assert page.tags.count("html") == page.tags.count("head") == page.tags.count("body") == 1
    assert page.tags.count("title") == 1
    assert "script" not in page.tags and "link" not in page.tags and "iframe" not in page.tags
    for url in [i["src"] for i in page.images] + page.links:
        assert "://" not in url and not url.startswith("/") and not url.startswith("//"), url
    assert not re.search(r"url\(|@import|https?://(?!www\.w3)", raw.split("</style>")[0]), "external CSS"
    ids = re.findall(r'\sid="([^"]+)"', raw)
    assert len(ids) == len(set(ids)), "duplicate ids"


def test_page_reports_status_collision_hinges_and_checks(gallery):
    _, out, index, _ = gallery
    page = _parse(index)
    failing = json.loads((out / FAILING / "simulation.json").read_text())
    t = failing["first_collision"]["time_s"]
    a, b = failing["first_collision"]["panels"]
    bad = " ".join(page.text[f"d-{FAILING}"])
    assert "Does not complete" in bad
    assert f"panels {a} and {b} touch at {seconds(t)}" in bad
    assert "NOT met" in bad  # the two holes
    errors = json.loads((out / FAILING / "check.json").read_text())["errors"]
    assert f"{errors} error(s)" in bad and "FP170" in bad  # the check summary with messages
    good = " ".join(page.text["d-helix_graded"])
    graded = json.loads((out / "helix_graded" / "simulation.json").read_text())
    assert f"Completes in {seconds(graded['fold_time_s'])}" in good  # the simulation's fold time of record
    for h in graded["hinges"]:  # the hinge table: id, material, fold time
        assert re.search(rf"{h['id']}\s*p\d+\u2013p\d+\s*{re.escape(h['material'])}\s*90\u00b0\s*"
                         rf"{re.escape(seconds(h['fold_time_s']))}", good), h
    assert "0 error(s)" in good
    summary = " ".join(page.text[None])
    assert "p1\u2013p6 at" in summary


def test_one_fold_time_on_every_surface(gallery, capsys):
    """helix_uniform's fold time reads the same in ``simulate`` (text and JSON), ``check``
    (its JSON's nominal fold), the gallery's JSON, summary and section, its viewer's banner
    and the print recipe the gallery exported: the simulation's fold time of record, printed
    by one formatter (docs/simulation.md, "The fold time")."""
    from foldprint.cli.commands import main

    _, out, index, _ = gallery
    assert main(["simulate", JAMS, "--json"]) == 0
    s = seconds(json.loads(capsys.readouterr().out)["fold_time_s"])
    assert main(["simulate", JAMS]) == 0
    assert f"  folded in {s}\n" in capsys.readouterr().out
    assert seconds(json.loads((out / JAMS / "simulation.json").read_text())["fold_time_s"]) == s
    assert seconds(json.loads((out / JAMS / "check.json").read_text())["robust"]["nominal"]["fold_time_s"]) == s
    page = _parse(index)
    assert f"Completes in {s}" in " ".join(page.text[f"d-{JAMS}"])
    assert f"{s} (every hinge at 98 %)" in " ".join(page.text[f"d-{JAMS}"])
    assert s in " ".join(page.text[None])  # the summary table's fold-time column
    assert f"Completes in {s}" in html.unescape((out / JAMS / "viewer.html").read_text(encoding="utf-8"))
    recipe = next((out / JAMS / "files").glob("*recipe.md")).read_text(encoding="utf-8")
    assert f"Expected: folded in {s} in the" in recipe


def test_descriptions_are_escaped(tmp_path):
    d = strip("tiny", [10.0, 10.0], [90.0], ["H-1"], description="two panels <&> one hinge")
    index = build_gallery([d], tmp_path / "site", gif_frames=4, jobs=1)
    text = index.read_text(encoding="utf-8")
    assert "two panels &lt;&amp;&gt; one hinge" in text and "<&>" not in text
    assert (tmp_path / "site" / "tiny" / "files").is_dir()  # the printable files are linked


def test_gallery_is_deterministic(tmp_path, monkeypatch):
    d = strip("tiny", [10.0, 12.0, 8.0], [90.0, -60.0], ["H-1", "H-4"])
    a = build_gallery([d], tmp_path / "a", gif_frames=6, jobs=2).parent  # chart and design in parallel
    b = build_gallery([d], tmp_path / "b", gif_frames=6, jobs=1).parent
    files_a = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    files_b = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert files_a == files_b and files_a
    for rel in files_a:
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel


# -- render3d -----------------------------------------------------------------------------

def test_render3d_states_frames_and_gif():
    from foldprint.render import stills as render3d, anim as render_anim
    from foldprint.render.figures import figure_bytes
    from foldprint.simulation.simulate import simulate

    d = load_design(templates_dir() / "self_lock_uniform.toml")
    assert render3d.camera_for(d).azim == -90.0  # a strip: side view along y
    res = simulate(d, dt=0.02)
    times = render3d.frame_times(res, 4)
    assert len(times) == 4 and 0 < times[0] < times[-1] <= render3d.motion_end(res)
    assert res.first_collision.time in times  # one frame sits on the first contact
    for state in ("programmed", "permanent"):
        png = figure_bytes(render3d.render_state(d, render3d.state_poses(d, state), state))
        with Image.open(io.BytesIO(png)) as im:
            assert im.width > 300 and im.height > 50
    # the arc model draws its hinges as ribbons; poses (1, n, 4, 4) are accepted too
    arc = render3d.state_poses(d, "permanent", "arc")[None]
    assert figure_bytes(render3d.render_state(d, arc, "arc", model="arc"))
    gif1 = render_anim.fold_animation_gif(res, 5)
    gif2 = render_anim.fold_animation_gif(res, 5)
    assert gif1 == gif2
    with Image.open(io.BytesIO(gif1)) as im:
        assert im.n_frames == 5 and im.info["loop"] == 0


def test_render3d_shows_the_structure():
    """The render is not blank and the panels are drawn where the geometry says: in the
    flat side view of a strip the drawing spans the strip's length."""
    import numpy as np

    from foldprint.render import stills as render3d
    from foldprint.model.materials import default_library
    from foldprint.render.figures import figure_bytes

    d = strip("bar", [40.0, 40.0], [90.0], ["H-7"])
    png = figure_bytes(render3d.render_state(d, render3d.state_poses(d, "programmed"), "flat"), dpi=100)
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)
    hinge = np.array([int(default_library()["H-7"].color[i:i + 2], 16) for i in (1, 3, 5)])
    near = (np.abs(rgb - hinge).sum(axis=-1) < 40)
    assert near.sum() > 5, "the hinge (H-7 colour) is drawn"
    cols = np.nonzero(near.any(axis=0))[0]
    centre = rgb.shape[1] * 0.5
    assert abs(cols.mean() - centre) < 0.15 * rgb.shape[1], "the hinge sits mid-strip in the side view"


# -- the page in a browser -------------------------------------------------------------------

HARNESS = """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>harness</title></head>
<body><pre id="result">pending</pre>
<iframe id="f" src="site/index.html" width="700" height="900"></iframe>
<script>
const errors = [];
window.addEventListener("error", e => errors.push(String(e.message || e)));
const frame = document.getElementById("f");
frame.addEventListener("load", async () => {
  const doc = frame.contentDocument;
  frame.contentWindow.addEventListener("error", e => errors.push(String(e.message || e)));
  const imgs = Array.from(doc.images);
  await Promise.all(imgs.map(i => i.complete ? null : new Promise(r => { i.onload = i.onerror = r; })));
  const links = [];
  for (const a of doc.querySelectorAll("a[href]")) {
    const href = a.getAttribute("href");
    if (href.startsWith("#")) {
      links.push({href, status: doc.getElementById(href.slice(1)) ? 200 : 404});
      continue;
    }
    try { const r = await fetch(a.href, {method: "HEAD"}); links.push({href, status: r.status}); }
    catch (e) { links.push({href, status: 0}); errors.push("fetch " + href + " " + e); }
  }
  const wrapped = [];  // numbers set over more than one line
  for (const td of doc.querySelectorAll("td.num")) {
    const r = doc.createRange();
    r.selectNodeContents(td);
    const tops = new Set(Array.from(r.getClientRects()).map(x => Math.round(x.top)));
    if (tops.size > 1) wrapped.push(td.textContent);
  }
  document.getElementById("result").textContent = JSON.stringify({
    title: doc.title, charset: doc.characterSet, wrapped,
    images: imgs.map(i => ({src: i.getAttribute("src"), w: i.naturalWidth, h: i.naturalHeight})),
    links, errors, text: doc.body.innerText});
});
</script></body></html>
"""


class _QuietHandler(SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def _chromium() -> str | None:
    return shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.mark.skipif(_chromium() is None, reason="chromium is not on PATH: the in-browser check of "
                    "index.html needs a headless Chromium")
def test_page_in_headless_chromium(gallery, tmp_path):
    root, _, _, _ = gallery
    (root / "harness.html").write_text(HARNESS, encoding="utf-8")
    server = ThreadingHTTPServer(("127.0.0.1", 0), partial(_QuietHandler, directory=str(root)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}/harness.html"
        cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
               "--no-first-run", "--disable-background-networking", "--disable-component-update",
               "--disable-sync", "--disable-extensions", f"--user-data-dir={tmp_path / 'profile'}",
               "--virtual-time-budget=15000", "--dump-dom", url]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    finally:
        server.shutdown()
        server.server_close()
    m = re.search(r'<pre id="result">(.*?)</pre>', proc.stdout, re.S)
    assert m, f"no result from Chromium (exit {proc.returncode}): {proc.stderr[-2000:]}"
    assert m.group(1) != "pending", "the page did not finish loading in the time budget"
    res = json.loads(html.unescape(m.group(1)))
    assert res["errors"] == []
    assert res["charset"] == "UTF-8" and res["title"] == "foldprint gallery"
    assert len(res["images"]) == 1 + (PNGS_PER_DESIGN + 1) * len(DESIGNS)  # + the GIF
    for img in res["images"]:
        assert img["w"] > 0 and img["h"] > 0, f"{img['src']} did not load"
    assert res["links"] and all(link["status"] == 200 for link in res["links"]), \
        [link for link in res["links"] if link["status"] != 200]
    assert "Does not complete" in res["text"] and "p1 and p6 touch at" in res["text"]
    assert res["wrapped"] == [], "a number wraps onto two lines"


# -- the interactive viewer ------------------------------------------------------------------

def _viewer_data(page: Path) -> dict:
    raw = page.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="fold-data">(.*?)</script>', raw, re.S)
    assert m, f"{page}: no data block"
    return json.loads(m.group(1))


def test_viewer_pages_are_offline_and_linked(gallery):
    _, out, index, _ = gallery
    page = _parse(index)
    for name in DESIGNS:
        assert f"{name}/viewer.html" in page.links  # index.html links a viewer per design
    assets = out / "viewer"
    assert (assets / "three-viewer.min.js").stat().st_size > 100_000
    assert "MIT License" in (assets / "LICENSE-three.txt").read_text(encoding="utf-8")
    for html_file in sorted(out.rglob("*.html")):
        raw = html_file.read_text(encoding="utf-8")
        urls = re.findall(r'<(?:script|link)\b[^>]*?(?:src|href)="([^"]*)"', raw)
        for url in urls:  # scripts and stylesheets: relative files that exist
            assert "://" not in url and not url.startswith("/"), (html_file, url)
            assert (html_file.parent / unquote(url)).is_file(), (html_file, url)
        assert not re.search(r"https?://", raw), f"{html_file}: a network URL"
        assert not re.search(r"@import|url\(", raw), f"{html_file}: external CSS"


def test_viewer_data_is_the_printed_part_in_the_simulated_poses():
    """Decoded page data: panel poses are the simulation's forward kinematics (flat at t=0,
    the printed state in the 'permanent' slot); every hinge ribbon starts on its parent
    panel's edge and ends on its child's (to the 16-bit quantisation step)."""
    import base64

    import numpy as np

    from foldprint.geometry.hinges import hinge_segments
    from foldprint.physics.kinematics import forward, hinge_frames, target_angles
    from foldprint.physics.hinge_drive import HingeDrive
    from foldprint.model.materials import default_library
    from foldprint.render.scene import motion_end
    from foldprint.simulation.simulate import simulate
    from foldprint.render.viewer import RIBBON_SECTIONS, viewer_data

    d = load_design(templates_dir() / "self_lock.toml")
    res = simulate(d, dt=0.02, hinge_model="arc")
    data = json.loads(json.dumps(viewer_data(res, default_library())))  # as the page gets it
    dec = lambda s, t: np.frombuffer(base64.b64decode(s), dtype=t)  # noqa: E731
    n_f, n_p = data["frames"], len(d.panels)
    poses = dec(data["poses"], "<f4").reshape(n_f + 2, n_p, 4, 4).swapaxes(-1, -2)
    assert data["times"][0] == 0.0 and data["times"][-1] == pytest.approx(motion_end(res))
    # t = 0: the programmed sheet (flat but for the share of each printed angle its fixity keeps)
    programmed = HingeDrive(d).angles([0.0])
    np.testing.assert_allclose(poses[0], forward(d, programmed, "arc")[0], atol=1e-4)
    # near flat: no panel turned by more than the programmed angles along the chain add up to
    assert 0 < np.abs(programmed).sum() < 0.1
    assert np.abs(poses[0][:, :3, :3] - np.eye(3)).max() <= np.abs(programmed).sum() + 1e-4
    np.testing.assert_allclose(poses[-1], forward(d, target_angles(d)[None], "arc")[0], atol=1e-4)
    k = n_f // 2
    traj = res.trajectory
    angles = [np.interp(data["times"][k], traj.times, traj.angles[:, i]) for i in range(len(d.hinges))]
    np.testing.assert_allclose(poses[k], forward(d, np.array([angles]), "arc")[0], atol=1e-4)
    # panels: the printed solids, as thick as the panels
    for it in data["items"]:
        v = dec(it["v"], "<f4").reshape(-1, 3)
        if it["kind"] == "panel":
            assert np.ptp(v[:, 2]) == pytest.approx(d.panels[it["panel"]].thickness, rel=1e-5)
    # ribbons: both ends on the panels they join, in every frame
    lo, hi = np.array(data["bounds"][0]), np.array(data["bounds"][1])
    q = dec(data["ribbon"]["q"], "<u2").reshape(n_f + 2, data["ribbon"]["n"], 3)
    rib = lo + q / 65535.0 * (hi - lo)
    step = float((hi - lo).max()) / 65535.0
    frames = {f.index: f for f in hinge_frames(d)}
    owners = data["ribbon"]["owners"]
    assert len(owners) == sum(len(hinge_segments(h)) for h in d.hinges)
    seg_of: dict[int, int] = {}
    for h_idx, start, count in owners:
        fr = frames[h_idx]
        h = fr.hinge
        j = seg_of.get(h_idx, 0)
        seg_of[h_idx] = j + 1
        v0, v1 = hinge_segments(h)[j]
        a, b = np.asarray(h.line, float)
        dvec = np.array([*(b - a) / np.linalg.norm(b - a), 0.0])
        assert count == 4 * (RIBBON_SECTIONS + 1)
        for side, pidx, block in ((-1, fr.parent, slice(start, start + 4)),
                                  (1, fr.child, slice(start + count - 4, start + count))):
            edge = np.array([a[0], a[1], 0.0]) + side * 0.5 * fr.width * fr.normal
            corners = np.array([edge + v * dvec + np.array([0, 0, 0.5 * z * h.thickness])
                                for v, z in ((v0, -1), (v1, -1), (v1, 1), (v0, 1))])
            for f in (0, k, n_f - 1, n_f + 1):
                want = corners @ poses[f, pidx][:3, :3].T + poses[f, pidx][:3, 3]
                np.testing.assert_allclose(rib[f, block], want, atol=2 * step + 1e-4)


def _chromium_run(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    cmd = [_chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--disable-extensions", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
           f"--user-data-dir={profile}", "--window-size=1100,900", "--hide-scrollbars",
           "--virtual-time-budget=8000", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=120)


@pytest.mark.skipif(_chromium() is None, reason="chromium is not on PATH: the viewer check needs a "
                    "headless Chromium (SwiftShader WebGL)")
def test_viewer_in_headless_chromium_moves_with_the_url(gallery, tmp_path):
    """Opened from file:// with no network: the page at load (t = 0), at #t=0.5, in the
    permanent state and the worst sample at #t=0.5 give different pictures, and the 3D
    canvas is drawn (not one colour)."""
    import numpy as np

    _, out, _, _ = gallery
    url = (out / FAILING / "viewer.html").resolve().as_uri()
    shots, states, runs = [], [], []
    for k, suffix in enumerate(("", "#t=0.5", "#state=permanent", "#run=worst&t=0.5")):
        dom = _chromium_run(["--dump-dom", url + suffix], tmp_path / f"p{k}")
        m = re.search(r'<body[^>]*data-canvas="(\d+),(\d+),(\d+),(\d+)"[^>]*>', dom.stdout)
        assert m and 'data-ready="1"' in m.group(0), f"viewer did not start: {dom.stderr[-2000:]}"
        states.append(re.search(r'data-t="([^"]+)"', m.group(0)).group(1))
        runs.append(re.search(r'data-run="([^"]+)"', m.group(0)).group(1))
        x, y, w, h = (int(v) for v in m.groups())
        png = tmp_path / f"shot{k}.png"
        shot = _chromium_run([f"--screenshot={png}", url + suffix], tmp_path / f"s{k}")
        assert png.is_file(), shot.stderr[-2000:]
        with Image.open(png) as im:
            rgb = np.asarray(im.convert("RGB")).astype(int)
        canvas = rgb[y + 2:y + h - 2, x + 2:x + w - 2]
        assert canvas.size, (x, y, w, h, rgb.shape)
        colours = np.unique(canvas.reshape(-1, 3), axis=0)
        assert len(colours) > 20, f"the 3D view is blank ({len(colours)} colours)"
        shots.append(canvas)
    assert states == ["0.000", "0.500", "permanent", "0.500"]
    assert runs == ["nominal", "nominal", "nominal", "worst"]
    for k in (1, 2, 3):
        diff = np.abs(shots[0] - shots[k]).sum(axis=-1) > 30
        assert diff.mean() > 0.005, f"picture {k} is the one at load ({diff.mean():.4f} changed)"
    diff = np.abs(shots[1] - shots[3]).sum(axis=-1) > 30
    assert diff.mean() > 0.002, f"the worst sample at t=0.5 is the nominal fold ({diff.mean():.4f} changed)"


# -- the material chart's fold-time table ----------------------------------------------------

def test_fold_time_table_equals_the_recovery_curves(lib):
    """The vectorised table gives each recovery curve's own 98 % time, including 'never'
    (a bath far below Tg) and a thicker hinge."""
    from foldprint.physics.recovery.curve import recovery_curve
    from foldprint.physics.recovery.table import fold_times

    baths = [20.0, 71.5, 84.0, 100.0]
    for name, thick in (("H-1", 0.8), ("H-4", 1.2), ("H-7", 0.8)):
        m = lib[name]
        got = fold_times(m, baths, thick, 10.0)
        for b, g in zip(baths, got):
            want = recovery_curve(m, b, thick, 10.0).fold_time
            if want is None:
                assert g is None, (name, b, g)
            else:
                assert g == pytest.approx(want, rel=1e-12, abs=1e-12), (name, b)
        assert got[0] is None  # 20 C: no hinge material recovers


def test_a_design_without_printable_geometry_gets_a_note_not_a_crash(tmp_path):
    """A flat hinge (angle 0) has no printed strip: no viewer and no files, both said."""
    d = strip("flat", [10.0, 10.0], [0.0], ["H-1"])
    index = build_gallery([d], tmp_path / "site", gif_frames=3, jobs=1)
    text = index.read_text(encoding="utf-8")
    assert "No 3D viewer:" in text and "No print files:" in text
    assert not (tmp_path / "site" / "flat" / "viewer.html").exists()
    assert (tmp_path / "site" / "flat" / "simulation.json").is_file()


# -- the gallery runs foldprint check -------------------------------------------------------

def test_gallery_gives_the_verdict_of_foldprint_check(gallery, capsys):
    """helix_uniform (the paper's Sample 1) folds nominally but jams under scatter: the
    gallery's check, run in a worker process, is the command's own, with its samples and
    seed (same jam probability, interval, pairs, findings, exit status), and the summary
    row says so."""
    from foldprint.core import constants
    from foldprint.cli.commands import main

    _, out, index, _ = gallery
    code = main(["check", JAMS, "--json"])
    cli = json.loads(capsys.readouterr().out)
    mine = json.loads((out / JAMS / "check.json").read_text())
    assert code == 1 and cli["ok"] is False and any(f["code"] == "FP180" for f in cli["findings"])
    test = cli["robust"]["test"]  # check's sequential test: its maximum, its stop
    assert test["max_samples"] == constants.CHECK_SAMPLES and cli["robust"]["seed"] == constants.CHECK_SEED
    assert cli["robust"]["samples"] == test["samples"] and test["verdict"] == "error"
    assert mine == cli  # every finding, the estimate, its interval, the colliding pairs, the nominal fold
    row = next(r for r in re.findall(r"<tr>(.*?)</tr>", index.read_text(encoding="utf-8"), re.S)
               if f'href="#d-{JAMS}"' in r)
    text = re.sub(r"<[^>]+>", " ", html.unescape(row))
    lo, hi = cli["robust"]["ci95"]
    codes = ", ".join(dict.fromkeys(f["code"] for f in cli["findings"] if f["severity"] == "error"))
    assert f"fails (exit 1): {codes}" in text
    n, k = cli["robust"]["samples"], cli["robust"]["jams"]
    assert (f"{100 * cli['robust']['jam_probability']:.1f} % (95 % interval {100 * lo:.1f}-{100 * hi:.1f} %), "
            f"{k} of {n} samples jam" in text)  # the number check prints, in the summary
    assert "completes" in text and "does not complete" not in text  # the nominal fold, beside the verdict
    good = next(r for r in re.findall(r"<tr>(.*?)</tr>", index.read_text(encoding="utf-8"), re.S)
                if 'href="#d-helix_graded"' in r)
    graded = json.loads((out / "helix_graded" / "check.json").read_text())
    assert graded["ok"] is ("passes (exit 0)" in good)


def test_gallery_reports_its_jam_tests_as_they_run(gallery):
    """From its first jam-test samples the gallery says how many of its tests have decided
    (per design 1x, 0.5x and 2x, and a flip's probes) and how many samples they used; at the
    end all have, and the tests and samples are those the designs' check.json files hold."""
    _, out, _, _ = gallery
    assert ACTIVITY and all(a.startswith("jam tests: ") for a in ACTIVITY)
    checks = [json.loads((out / n / "check.json").read_text()) for n in DESIGNS]
    tests = [c["robust"]["samples"] for c in checks] + [
        p["samples"] for c in checks for p in c["sensitivity"] if p["scale"] != 1.0] + [
        w["samples"] for c in checks for fd in c["flip_drivers"] for w in fd["probes"]]
    assert ACTIVITY[-1] == f"jam tests: {len(tests)} of {len(tests)} decided, {sum(tests)} samples used"
    assert any(" 0 of " in a for a in ACTIVITY[:3])  # it speaks before the first test decides


def test_page_names_the_hinge_model(gallery):
    _, out, index, _ = gallery
    page = _parse(index)
    header = " ".join(page.text[None])
    assert "printed (arc) hinges" in header
    assert "simulated with the paper's reduced-order model" not in " ".join(header.split())
    for name in DESIGNS:
        assert json.loads((out / name / "simulation.json").read_text())["hinge_model"] == "arc"
        assert "printed (arc) hinges" in " ".join(page.text[f"d-{name}"])


def test_design_page_shows_the_distribution_of_the_samples(gallery):
    """The pairs table counts what samples.json records per sample; the fold-time table
    the percentiles of the samples that complete."""
    from collections import Counter

    import numpy as np

    _, out, index, _ = gallery
    page = _parse(index)
    for name in DESIGNS:
        mc = json.loads((out / name / "samples.json").read_text())
        assert len(mc["outcomes"]) == mc["samples"]
        text = " ".join(" ".join(page.text[f"d-{name}"]).split())
        counts = Counter(tuple(o["pair"]) for o in mc["outcomes"] if o["pair"] is not None)
        assert sum(counts.values()) == mc["failures"]["collision"] <= mc["jams"]
        for (a, b), k in counts.items():
            times = [o["contact_s"] for o in mc["outcomes"] if o["pair"] == [a, b]]
            assert re.search(rf"{a}\u2013{b} {k} {100 * k / mc['samples']:.1f} % {min(times):.2f} s "
                             rf"{np.median(times):.2f} s {max(times):.2f} s", text), (name, a, b)
        ft = [o["fold_time_s"] for o in mc["outcomes"] if o["fold_time_s"] is not None]
        if ft:
            p5, p50, p95 = np.percentile(ft, [5, 50, 95])
            assert f"{len(ft)} {min(ft):.2f} s {p5:.2f} s {p50:.2f} s {p95:.2f} s {max(ft):.2f} s" in text
        else:
            assert "No sample completes its fold." in text
        assert f"{mc['jams']} of {mc['samples']} samples jam" in text


def test_viewer_replays_the_worst_sample(gallery):
    """The viewer data holds a second run: the sample with the earliest first contact,
    folded again from the same seed, colliding where and when the Monte-Carlo recorded."""
    import base64

    import numpy as np

    from foldprint.core.constants import tol

    _, out, _, _ = gallery
    for name in (JAMS, FAILING):
        mc = json.loads((out / name / "samples.json").read_text())
        hits = [o for o in mc["outcomes"] if o["contact_s"] is not None]
        assert hits, name
        earliest = min(hits, key=lambda o: (o["contact_s"], o["sample"]))
        data = _viewer_data(out / name / "viewer.html")
        w = data["worst"]
        assert w is not None and w["sample"] == earliest["sample"] == mc["worst"]["sample"]
        assert mc["worst"]["replay_agrees"] is True
        assert sorted(w["contacts"][0]["panels"]) == sorted(earliest["pair"])
        assert w["contacts"][0]["time"] == pytest.approx(earliest["contact_s"], abs=tol.time)
        assert w["times"][0] == 0.0 and w["times"][-1] == pytest.approx(w["end"])
        n_f, n_p = data["frames"], len(data["panels"])
        poses = np.frombuffer(base64.b64decode(w["poses"]), "<f4").reshape(n_f + 2, n_p, 4, 4)
        nominal = np.frombuffer(base64.b64decode(data["poses"]), "<f4").reshape(n_f + 2, n_p, 4, 4)
        np.testing.assert_allclose(poses[0], nominal[0], atol=1e-6)  # the same programmed sheet at t = 0
        np.testing.assert_allclose(poses[-2:], nominal[-2:], atol=1e-6)  # same programmed/permanent states
        assert np.abs(poses[n_f // 2] - nominal[n_f // 2]).max() > 1e-3  # a different fold
        q = np.frombuffer(base64.b64decode(w["q"]), "<u2")
        assert q.size == (n_f + 2) * data["ribbon"]["n"] * 3
        params = mc["worst"]["parameters"]
        assert len(params["tg_shift_c"]) == len(data["hinges"]) and "bath_c" in params


# -- what the page says: legend, the paper's names and statements, marginal folds -------------

def _summary_row(index: Path, name: str) -> str:
    return next(r for r in re.findall(r"<tr>(.*?)</tr>", index.read_text(encoding="utf-8"), re.S)
                if f'href="#d-{name}"' in r)


def test_summary_explains_its_columns_and_names_the_papers_samples(gallery):
    """A legend entry for every column of the summary; the paper's structures named as the
    paper names them (their template's [paper] table), in the summary and their sections."""
    _, out, index, _ = gallery
    raw = index.read_text(encoding="utf-8")
    heads = re.findall(r"<th>(.*?)</th>", raw.split("<tbody>")[0])
    legend = re.search(r'<dl class="legend">(.*?)</dl>', raw, re.S).group(1)
    terms = [term for t in re.findall(r"<dt>(.*?)</dt>", legend) for term in html.unescape(t).split(", ")]
    for h in heads:
        assert any(h.split(" (")[0] in (t, f"check {t}") for t in terms), f"no legend for {h!r}"
    for name, words in ((JAMS, "the paper's Sample 1 (Fig. 2b)"), ("helix_graded", "the paper's Sample 2 (Fig. 2c)"),
                        (FAILING, "after the paper's Fig. 5")):
        assert words in html.unescape(_summary_row(index, name)), name
    page = _parse(index)
    header = " ".join(" ".join(page.text[None]).split())
    assert "The paper's own structures:" in header
    assert "Sample 1 (Fig. 2b): helix_uniform" in header and "Sample 2 (Fig. 2c): helix_graded" in header
    assert "The paper's Sample 1 (Fig. 2b)" in " ".join(page.text[f"d-{JAMS}"])


def test_a_design_that_jams_under_scatter_is_not_green(gallery):
    """helix_uniform completes nominally but check's printed parts jam: the nominal cell is
    amber and says both; a design whose parts do not jam stays green."""
    _, out, index, _ = gallery
    chk = json.loads((out / JAMS / "check.json").read_text())
    row = _summary_row(index, JAMS)
    cell = re.search(r'<td class="(\w+)">(nominal: [^<]*)</td>', row)
    assert cell and cell.group(1) == "warn"
    assert cell.group(2) == f"nominal: completes; printed parts: jam {100 * chk['robust']['jam_probability']:.1f} %"
    graded = _summary_row(index, "helix_graded")
    assert '<td class="ok">completes</td>' in graded
    section = " ".join(" ".join(_parse(index).text[f"d-{JAMS}"]).split())
    assert f"Printed parts jam under scatter: jam probability {100 * chk['robust']['jam_probability']:.1f} %" in section


def test_the_fp183_line_names_what_drives_the_flip(gallery):
    """The gallery's check takes each flip apart in the design's worker (its own jam tests
    with a component removed, beside the shared pool's): a design whose verdict flips in the
    sweep gets FP183 naming the driving components and what their spreads rest on, the same
    line in check.json and on its page."""
    from foldprint.checks.report import basis_text
    from foldprint.core.modes import SpreadBasis

    _, out, index, _ = gallery
    page = _parse(index)
    flips = 0
    for n in DESIGNS:
        chk = json.loads((out / n / "check.json").read_text())
        fps = [f for f in chk["findings"] if f["code"] == "FP183"]
        assert len(fps) == (1 if chk["flip_drivers"] else 0)
        for f in fps:
            for fd in chk["flip_drivers"]:
                flips += 1
                named = fd["drivers"] or [fd["strongest"]]
                change = "without it" if fd["worse"] else "with it at its 1x spread"
                for w in fd["probes"]:
                    said = f"({w['component']}, {basis_text(SpreadBasis(w['basis']))}; {change} the test"
                    assert (said in f["message"]) == (w["component"] in named)
            section = " ".join(" ".join(page.text[f"d-{n}"]).split())
            assert " ".join(f["message"].split()) in section
    assert flips  # helix_graded's verdict flips at 2x at check's defaults (docs/robustness-model.md)


def test_each_section_quotes_the_paper_beside_the_model(gallery):
    from foldprint.model.paper_statements import load_statements

    _, out, index, _ = gallery
    st = load_statements()
    for name in (JAMS, "helix_graded"):
        lines = json.loads((out / name / "check.json").read_text())["paper"]
        text = " ".join(" ".join(_parse(index).text[f"d-{name}"]).split())
        assert lines and "The paper beside the model" in text
        for ln in lines:
            assert st[ln["id"]].quote in text and ln["model"] in text
            if ln["ratio"] is not None:
                assert f"{ln['ratio']:.2f}" in text
            if ln["reading"] and ln["verdict"] in ("meets", "misses"):  # the tolerance beside a verdict on a number
                assert f"{ln['verdict']} ({ln['reading']['read_as']})" in text


def test_a_part_that_cannot_be_built_is_reported_as_a_verdict_not_a_crash(tmp_path):
    """A part that cannot be built: the progress line and the page say it has no print
    files because it cannot be built (not 'exported', and not "export FAILED", which reads
    like a crash of the tool)."""
    d = strip("flat", [10.0, 10.0], [0.0], ["H-1"])
    steps = []
    index = build_gallery([d], tmp_path / "site", gif_frames=3, jobs=1, samples=4,
                          progress=lambda *a: steps.append(a[2]))
    line = next(m for m in steps if m.startswith("flat:"))
    assert "no print files: the part cannot be built (" in line and "exported" not in line
    assert "no 3D viewer" in line and "FAILED" not in line
    assert '<p class="status fail">No print files:' in index.read_text(encoding="utf-8")
    assert '<span class="sev-error">no print files: cannot be built</span>' in _summary_row(index, "flat")


def test_no_empty_samples_chart():
    """Every sample jams without a collision or a finished fold (a loop that locks): no
    chart at all; samples that complete but never collide: one panel, no empty pair axes."""
    from dataclasses import replace as dreplace

    from foldprint.core.modes import HingeModel, JamReason
    from foldprint.render.figures import sample_outcomes_figure
    from foldprint.simulation.robust import Outcome, RobustResult
    from foldprint.simulation.scatter import Scatter
    from foldprint.simulation.simulate import simulate

    d = strip("two", [10.0, 10.0], [90.0], ["H-1"])
    nominal = simulate(d)
    stuck = simulate(d, bath_c=20.0, duration=1.0)  # below Tg: the hinge never folds
    assert stuck.fold_time is None and stuck.first_collision is None
    unfolded = RobustResult("two", 3, 0, HingeModel.ARC, Scatter.zero(), (Outcome(True, JamReason.UNFOLDED, None, None, None),) * 3,
                            stuck)
    assert sample_outcomes_figure(unfolded) is None
    done = dreplace(unfolded, outcomes=(Outcome(False, None, None, None, 1.0),) * 3, nominal=nominal)
    fig = sample_outcomes_figure(done)
    assert fig is not None and len(fig.axes) == 1


@pytest.mark.skipif(_chromium() is None, reason="chromium is not on PATH: the viewer check needs a "
                    "headless Chromium (SwiftShader WebGL)")
def test_viewer_frames_the_part_at_every_moment_and_names_the_worst_contact(gallery, tmp_path):
    """helix_uniform in Chromium: the folded part fills most of the canvas (the camera
    frames each moment, not the whole trajectory: the flat strip is 416 mm, the folded
    spiral 56 mm); the flat strip is whole in view; in worst-sample mode the banner names
    that sample's first contact, pair and time."""
    import numpy as np

    _, out, _, _ = gallery
    page = out / JAMS / "viewer.html"
    url = page.resolve().as_uri()
    w = _viewer_data(page)["worst"]
    spans = {}
    for k, suffix in enumerate(("#state=permanent", "")):
        dom = _chromium_run(["--dump-dom", url + suffix], tmp_path / f"d{k}")
        x, y, cw, ch = (int(v) for v in re.search(r'data-canvas="(\d+),(\d+),(\d+),(\d+)"', dom.stdout).groups())
        png = tmp_path / f"v{k}.png"
        _chromium_run([f"--screenshot={png}", url + suffix], tmp_path / f"s{k}")
        with Image.open(png) as im:
            rgb = np.asarray(im.convert("RGB")).astype(int)[y + 2:y + ch - 2, x + 2:x + cw - 2]
        part = np.abs(rgb - 247).sum(axis=-1) > 24  # the clear colour is #f7f7f7
        rows, cols = np.nonzero(part.any(axis=1))[0], np.nonzero(part.any(axis=0))[0]
        spans[suffix] = (np.ptp(cols) / part.shape[1], np.ptp(rows) / part.shape[0], cols.min(), cols.max(),
                         part.shape[1])
    wf, hf, *_ = spans["#state=permanent"]
    assert max(wf, hf) > 0.6, f"the folded part spans {wf:.0%} x {hf:.0%} of the canvas"
    wf, hf, left, right, width = spans[""]
    assert wf > 0.6 and left > 0 and right < width - 1, "the flat strip does not fit the canvas"
    dom = _chromium_run(["--dump-dom", url + "#run=worst&t=0.5"], tmp_path / "w")
    banner = html.unescape(re.search(r'id="banner"[^>]*>(.*?)</p>', dom.stdout, re.S).group(1))
    c = w["contacts"][0]
    assert banner.startswith(f"Worst scatter sample, #{w['sample']}")
    assert f"panels {c['panels'][0]}\u2013{c['panels'][1]} touch at {seconds(c['time'])}" in banner
    nominal = _chromium_run(["--dump-dom", url], tmp_path / "n")
    assert re.search(r'id="banner"[^>]*>Nominal fold:', nominal.stdout)
