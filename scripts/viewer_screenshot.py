"""Regenerate docs/img/viewer.png, the README's screenshot of the fold viewer, and
docs/img/viewer.json, what it shows as text.

    python scripts/viewer_screenshot.py [--gallery DIR]

The viewer page is the gallery's (``foldprint gallery``: a one-design gallery of
:data:`DESIGN` is built in a temporary folder, or ``--gallery`` names one already built),
opened in headless Chromium at :data:`FRAGMENT` and captured at :data:`WINDOW`. The same
page, its scripts run, gives the text the picture shows (its banner, the facts beside the
view, its buttons), written to viewer.json with a digest of the viewer's scripts and
styles. tests/test_viewer_screenshot.py holds the JSON to what the tool says now (the
banner from a fresh simulation and check of the design, the buttons from the viewer page
the code writes, the digest from the viewer's files): when any of them changes, run this
script again. The pixels are not compared.
"""

from __future__ import annotations

import argparse
import hashlib
import html
import json
import re
import shutil
import subprocess
import sys
import tempfile
from html.parser import HTMLParser
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

DESIGN = "self_lock"
FRAGMENT = "t=0.42"  # our choice: the end of the strip threading the first hole (goal hole1 at 1.65 s)
WINDOW = (1000, 960)  # our choice: the page's header, the view, its controls and the facts, in one picture
PNG = ROOT / "docs" / "img" / "viewer.png"
TEXT = ROOT / "docs" / "img" / "viewer.json"
BUDGET_MS = 15000  # Chromium's virtual time for the page to load its data and draw


def chromium() -> str:
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        raise SystemExit("viewer_screenshot: needs a headless Chromium (chromium) on PATH")
    return exe


def _run(args: list[str], profile: Path) -> subprocess.CompletedProcess:
    cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--disable-extensions", "--hide-scrollbars", f"--user-data-dir={profile}",
           f"--virtual-time-budget={BUDGET_MS}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def assets_digest() -> str:
    """A digest of the viewer's scripts, styles and three.js bundle, as the code writes them."""
    from foldprint.render.viewer import ASSETS, asset_bytes

    h = hashlib.sha256()
    for name in ASSETS:
        h.update(name.encode() + b"\0" + asset_bytes(name))
    return h.hexdigest()


class _Controls(HTMLParser):
    """Every button and input of a page (or of the element ``within``), as ``id: label``."""

    def __init__(self, within: str | None = None):
        super().__init__(convert_charrefs=True)
        self.within, self.depth, self.out, self.open = within, 0 if within else 1, [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if self.within and a.get("id") == self.within:
            self.depth = 1
            return
        if self.depth and self.within and tag not in VOID:
            self.depth += 1
        if not self.depth:
            return
        if tag == "button":
            self.open = [a.get("id", "button"), ""]
        elif tag == "input":
            self.out.append(f"{a.get('id', 'input')}: {a.get('aria-label', a.get('type', ''))}")

    def handle_endtag(self, tag):
        if tag == "button" and self.open is not None:
            self.out.append(f"{self.open[0]}: {' '.join(self.open[1].split())}")
            self.open = None
        if self.depth and self.within and tag not in VOID:
            self.depth -= 1

    def handle_data(self, data):
        if self.open is not None:
            self.open[1] += data


VOID = {"input", "br", "img", "meta", "link", "hr", "source", "wbr", "area", "base", "col", "embed", "track"}


def controls(page: str, within: str | None = None) -> list[str]:
    """The page's buttons and inputs (those inside the element of id ``within``), as
    ``id: label``, in page order."""
    parser = _Controls(within)
    parser.feed(page)
    return parser.out


def _text(dom: str, element_id: str) -> str:
    m = re.search(rf'<(\w+)[^>]*\bid="{element_id}"[^>]*>(.*?)</\1>', dom, re.S)
    if not m:
        return ""
    inner = re.sub(r"</(li|h2|p|div)>", "\n", m.group(2))
    lines = [" ".join(html.unescape(re.sub(r"<[^>]+>", " ", ln)).split()) for ln in inner.split("\n")]
    return "\n".join(ln for ln in lines if ln)


def shown_text(page_file: Path, profile: Path) -> dict:
    """What the page says once its scripts ran: the banner, the facts, the run buttons."""
    proc = _run(["--dump-dom", f"{page_file.as_uri()}#{FRAGMENT}"], profile)
    dom = proc.stdout
    if 'id="facts"' not in dom or not _text(dom, "facts"):
        raise SystemExit(f"viewer_screenshot: the page did not draw its facts (exit {proc.returncode}): "
                         f"{proc.stderr[-1000:]}")
    return {"banner": _text(dom, "banner"), "facts": _text(dom, "facts"), "runs": controls(dom, "runs")}


def build(gallery: Path | None, work: Path) -> Path:
    """The design's viewer page: in ``gallery``, or in a one-design gallery built in ``work``."""
    if gallery is not None:
        page = gallery / DESIGN / "viewer.html"
        if not page.is_file():
            raise SystemExit(f"viewer_screenshot: {page} does not exist")
        return page
    from foldprint.apps.gallery.runner import build_gallery
    from foldprint.io.load import load_design
    from foldprint.io.templates import templates_dir

    index = build_gallery([load_design(templates_dir() / f"{DESIGN}.toml")], work / "site", jobs=2)
    return index.parent / DESIGN / "viewer.html"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gallery", type=Path, help="a gallery already built (foldprint gallery --out DIR)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="viewer-shot-") as tmp:
        work = Path(tmp)
        page = build(args.gallery, work)
        shot = work / "viewer.png"
        proc = _run([f"--screenshot={shot}", f"--window-size={WINDOW[0]},{WINDOW[1]}",
                     f"{page.as_uri()}#{FRAGMENT}"], work / "profile")
        if not shot.is_file():
            raise SystemExit(f"viewer_screenshot: Chromium wrote no screenshot (exit {proc.returncode}): "
                             f"{proc.stderr[-1000:]}")
        shown = shown_text(page, work / "profile")
        record = {"design": DESIGN, "fragment": FRAGMENT, "window": list(WINDOW), **shown,
                  "controls": controls(page.read_text(encoding="utf-8")),
                  "viewer_assets_sha256": assets_digest(), "script": "scripts/viewer_screenshot.py"}
        PNG.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(shot, PNG)
    TEXT.write_text(json.dumps(record, indent=2, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"wrote {PNG.relative_to(ROOT)} and {TEXT.relative_to(ROOT)}: {record['banner']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
