"""What the gallery page shows of one design (:class:`Entry`, its pictures and links) and
the small helpers every gallery module shares: relative URLs, times, JSON bytes, HTML
escaping and writing a picture."""

from __future__ import annotations

import html
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

from ...model.design import Design


@dataclass
class Image:
    src: str  # relative URL from index.html
    width: int
    height: int
    alt: str
    caption: str
    wide: bool = False  # spans the whole row of the picture grid


@dataclass
class Link:
    href: str
    label: str
    size: int | None = None


@dataclass
class Entry:
    design: Design
    dirname: str
    sim: dict
    checks: dict
    fold_time: float | None = None  # s, every hinge at 98 % (the simulation's fold time of record)
    contacts: list = field(default_factory=list)  # (panel a, panel b, time, method)
    hinge_done: list = field(default_factory=list)
    images: list = field(default_factory=list)
    files: list = field(default_factory=list)
    data_links: list = field(default_factory=list)
    export_note: str = ""
    viewer: Link | None = None  # the design's interactive 3D viewer page
    viewer_note: str = ""  # why there is none
    mc: dict | None = None  # the Monte-Carlo summary (:func:`mc_summary`) when it was run
    worst: dict | None = None  # the worst sample (:func:`worst_json`)


def url(rel: str) -> str:
    """A relative URL for a POSIX relative path (each segment percent-encoded)."""
    return "/".join(quote(part) for part in rel.split("/"))


def fmt_s(t: float | None) -> str:
    """A time as every output prints it (:func:`foldprint.checks.report.seconds`)."""
    from ...checks.report import seconds

    return seconds(t)


def json_bytes(obj) -> bytes:
    return (json.dumps(obj, indent=2, ensure_ascii=False, allow_nan=False) + "\n").encode("utf-8")


def png_size(data: bytes) -> tuple[int, int]:
    from PIL import Image

    with Image.open(io.BytesIO(data)) as im:
        return int(im.width), int(im.height)


def write_image(out_dir: Path, rel: str, data: bytes, alt: str, caption: str,
                 wide: bool = False) -> Image:
    from ...exchange.fileset import write_atomic

    write_atomic(out_dir / rel, data)
    w, h = png_size(data)
    return Image(url(rel), w, h, alt, caption, wide)


def esc(text) -> str:
    return html.escape(str(text), quote=True)
