"""Reading an SVG crease pattern (Origami Simulator's convention, see
:mod:`foldprint.io.svg_format`): the ``<svg>`` root, the document scale, and every
stroked ``path``, ``line``, ``rect``, ``polygon`` and ``polyline`` through its transforms
as line segments with their assignment (by stroke colour) and fold angle (by opacity).
The segments go on to :mod:`foldprint.io.svg_creases`.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET

import numpy as np

from ..core.errors import DesignError
from ..core.schema import MAX_SVG_DEPTH, MAX_SVG_SEGMENTS

_COLOURS = {
    "B": ("#000000", "#000", "black", "rgb(0,0,0)"),
    "M": ("#ff0000", "#f00", "red", "rgb(255,0,0)"),
    "V": ("#0000ff", "#00f", "blue", "rgb(0,0,255)"),
    "C": ("#00ff00", "#0f0", "lime", "rgb(0,255,0)"),
    "F": ("#ffff00", "#ff0", "yellow", "rgb(255,255,0)"),
    "U": ("#ff00ff", "#f0f", "magenta", "fuchsia", "rgb(255,0,255)"),
}
_KIND = {c: k for k, cs in _COLOURS.items() for c in cs}
_KIND["green"] = "C"  # Origami Simulator accepts "green" for #00ff00
CREASE_NAMES = {"B": "border (black)", "M": "mountain (red)", "V": "valley (blue)", "C": "cut (green)",
          "F": "facet (yellow)", "U": "hinge (magenta)"}
_UNITS_MM = {"mm": 1.0, "cm": 10.0, "in": 25.4, "pt": 25.4 / 72, "pc": 25.4 / 6, "px": 25.4 / 96, "": 25.4 / 96}
#: coordinates after the transforms, in user units: 1e7 (10 km at 1 mm per unit, above the
#: schema's 10 m at any document scale down to 1 um per unit); 1e300 overflowed the clustering
MAX_USER_UNITS = 1e7
_NUM = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def _tag(el) -> str:
    return el.tag.rsplit("}", 1)[-1]


def _style(el) -> dict:
    out = {}
    for part in (el.get("style") or "").split(";"):
        k, _, v = part.partition(":")
        if k.strip():
            out[k.strip().lower()] = v.strip()
    return out


def _prop(el, name: str, inherited: dict) -> str | None:
    v = _style(el).get(name) or el.get(name)
    return v if v is not None else inherited.get(name)


def _matrix(text: str | None, src: str) -> np.ndarray:
    """3x3 matrix of an SVG ``transform`` list."""
    m = np.eye(3)
    if not text:
        return m
    for name, args in re.findall(r"(\w+)\s*\(([^)]*)\)", text):
        a = [float(x) for x in re.findall(_NUM, args)]
        if not all(math.isfinite(x) and abs(x) < 1e300 for x in a):
            raise DesignError(f"{src}transform {name}({args.strip()[:40]}) has a number out of range")
        t = np.eye(3)
        if name == "matrix" and len(a) == 6:
            t = np.array([[a[0], a[2], a[4]], [a[1], a[3], a[5]], [0, 0, 1]])
        elif name == "translate" and a:
            t[0, 2], t[1, 2] = a[0], a[1] if len(a) > 1 else 0.0
        elif name == "scale" and a:
            t[0, 0], t[1, 1] = a[0], a[1] if len(a) > 1 else a[0]
        elif name == "rotate" and a:
            c, s = math.cos(math.radians(a[0])), math.sin(math.radians(a[0]))
            r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
            if len(a) == 3:
                tr = np.array([[1, 0, a[1]], [0, 1, a[2]], [0, 0, 1]])
                r = tr @ r @ np.linalg.inv(tr)
            t = r
        elif name == "skewX" and a:
            t[0, 1] = math.tan(math.radians(a[0]))
        elif name == "skewY" and a:
            t[1, 0] = math.tan(math.radians(a[0]))
        else:
            raise DesignError(f"{src}transform {name}({args}) is not understood; flatten transforms in your editor")
        if not np.isfinite(t).all():
            raise DesignError(f"{src}transform {name}({args.strip()[:40]}) has a number out of range")
        with np.errstate(over="ignore", invalid="ignore"):  # a product out of range is refused below
            m = m @ t
    _check_matrix(m, src, f"transform {text.strip()[:60]!r}")
    return m


def _check_matrix(m: np.ndarray, src: str, what: str) -> None:
    """A transform must keep the drawing finite and two-dimensional."""
    a = m[:2, :2]
    big = float(np.abs(m).max()) if np.isfinite(m).all() else math.inf
    if big > MAX_USER_UNITS * 1e6:
        raise DesignError(f"{src}{what} scales or moves the drawing out of range (a factor above "
                          f"{MAX_USER_UNITS * 1e6:g}); give every transform a moderate, finite value")
    if abs(a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]) <= 1e-12 * max(float(np.abs(a).max()), 1e-300) ** 2:
        raise DesignError(f"{src}{what} collapses the drawing (its scale is 0 in some direction); give "
                          "every transform a non-zero scale")


def _path_polylines(d: str, src: str, what: str) -> list[list[tuple[float, float]]]:
    tokens = re.findall(r"[A-Za-z]|" + _NUM, d or "")
    out, cur, pos, start, cmd = [], [], (0.0, 0.0), (0.0, 0.0), None
    i = 0

    def num():
        nonlocal i
        if i >= len(tokens) or re.match(r"[A-Za-z]", tokens[i]):
            raise DesignError(f"{src}{what}: path data ends early near {' '.join(tokens[max(0, i - 3):i + 1])!r}")
        i += 1
        return float(tokens[i - 1])

    while i < len(tokens):
        if re.match(r"[A-Za-z]", tokens[i]):
            cmd = tokens[i]
            i += 1
            if cmd in "Zz":
                if cur:
                    cur.append(start)
                    out.append(cur)
                cur, pos = [], start
                continue
        if cmd is None:
            raise DesignError(f"{src}{what}: path data must start with a command (M)")
        if cmd not in "MmLlHhVv":
            raise DesignError(f"{src}{what}: path command {cmd!r} draws a curve or arc: a curved crease bends "
                              "the panels beside it as it folds, which rigid printed panels joined by straight "
                              "hinges cannot do; foldprint reads straight creases only (flatten the curve to "
                              "lines for a faceted approximation)")
        rel = cmd.islower()
        c = cmd.upper()
        if c in "ML":
            x, y = num(), num()
            p = (pos[0] + x, pos[1] + y) if rel else (x, y)
        elif c == "H":
            x = num()
            p = (pos[0] + x if rel else x, pos[1])
        else:
            y = num()
            p = (pos[0], pos[1] + y if rel else y)
        if c == "M":
            if len(cur) > 1:
                out.append(cur)
            cur, start = [p], p
            cmd = "l" if rel else "L"  # implicit lineto after moveto
        else:
            if not cur:
                cur = [pos]
            cur.append(p)
        pos = p
    if len(cur) > 1:
        out.append(cur)
    return out


def _element_polylines(el, src: str, what: str) -> list[list[tuple[float, float]]]:
    tag = _tag(el)

    def f(name, default=0.0):
        v = el.get(name)
        if v is None:
            return default
        m = re.match(_NUM, v.strip())
        if not m:
            raise DesignError(f"{src}{what}: attribute {name}={v[:40]!r} is not a number")
        return float(m.group(0))

    if tag == "line":
        return [[(f("x1"), f("y1")), (f("x2"), f("y2"))]]
    if tag == "rect":
        x, y, w, h = f("x"), f("y"), f("width"), f("height")
        return [[(x, y), (x + w, y), (x + w, y + h), (x, y + h), (x, y)]]
    if tag in ("polygon", "polyline"):
        nums = [float(v) for v in re.findall(_NUM, el.get("points") or "")]
        pts = list(zip(nums[0::2], nums[1::2]))
        if tag == "polygon" and pts:
            pts.append(pts[0])
        return [pts] if len(pts) > 1 else []
    if tag == "path":
        return _path_polylines(el.get("d") or "", src, what)
    return []


def _opacity(el, inherited: dict) -> float:
    o = 1.0
    for name in ("opacity", "stroke-opacity"):
        v = _prop(el, name, {}) if name == "opacity" else _prop(el, name, inherited)
        if v is not None:
            try:
                o *= float(v.strip().rstrip("%")) / (100.0 if v.strip().endswith("%") else 1.0)
            except ValueError:
                pass
    return o


def _length_mm(v: str | None) -> float | None:
    if not v:
        return None
    m = re.fullmatch(r"\s*(" + _NUM + r")\s*([a-z%]*)\s*", v)
    if not m or m.group(2) not in _UNITS_MM:
        return None
    return float(m.group(1)) * _UNITS_MM[m.group(2)]


def svg_segments(root, src: str) -> tuple[list, float]:
    """(segments, mm per user unit): segments are (p0, p1, assignment, angle deg, element)."""
    vb = [float(x) for x in re.findall(_NUM, root.get("viewBox") or "")]
    w_mm = _length_mm(root.get("width"))
    factor = _UNITS_MM["px"]
    if len(vb) == 4 and vb[2] > 0 and w_mm:
        factor = w_mm / vb[2]
    elif w_mm and root.get("width"):
        factor = _UNITS_MM[re.sub(r"[\d.\s+-eE]", "", root.get("width")) or ""] \
            if re.sub(r"[\d.\s+-eE]", "", root.get("width")) in _UNITS_MM else factor
    segs, bad = [], {}
    count = {"n": 0}

    stack = [(root, np.eye(3), {}, 0)]
    while stack:  # depth first, document order, without recursion (5000 nested <g> are refused)
        el, m, inherited, depth = stack.pop()
        if depth > MAX_SVG_DEPTH:
            raise DesignError(f"{src}elements nested more than {MAX_SVG_DEPTH} levels deep (<{_tag(el)}> at level "
                              f"{depth}); a crease pattern needs a few groups: ungroup in your editor")
        if el.get("transform"):
            m = m @ _matrix(el.get("transform"), src)
            _check_matrix(m, src, f"the transforms down to <{_tag(el)}>")
        inh = dict(inherited)
        for name in ("stroke", "stroke-opacity"):
            v = _prop(el, name, inherited)
            if v is not None:
                inh[name] = v
        tag = _tag(el)
        if tag in ("defs", "metadata", "title", "desc", "namedview", "clipPath", "mask", "symbol"):
            continue
        if tag in ("line", "rect", "polygon", "polyline", "path"):
            count["n"] += 1
            what = f"<{tag}> #{count['n']}" + (f" id={el.get('id')!r}" if el.get("id") else "")
            stroke = (inh.get("stroke") or "").replace(" ", "").lower()
            if stroke in ("", "none"):
                continue
            kind = _KIND.get(stroke)
            if kind is None:
                bad.setdefault(stroke, what)
                continue
            op = _opacity(el, inherited)
            angle = {"M": -180.0 * op, "V": 180.0 * op}.get(kind, 0.0)
            for line in _element_polylines(el, src, what):
                raw = np.array(line, float).reshape(-1, 2)
                with np.errstate(over="ignore", invalid="ignore"):
                    pts = raw @ m[:2, :2].T + m[:2, 2]
                if not (np.isfinite(pts).all() and np.abs(pts).max(initial=0.0) <= MAX_USER_UNITS):
                    k = int(np.argmax(~np.isfinite(pts).all(axis=1) | (np.abs(pts) > MAX_USER_UNITS).any(axis=1)))
                    raise DesignError(f"{src}{what}: point {k} ({raw[k][0]:g}, {raw[k][1]:g}) lies at "
                                      f"({pts[k][0]:g}, {pts[k][1]:g}) after the transforms, outside +-{MAX_USER_UNITS:g} "
                                      "user units; check the coordinates and the transforms")
                for a, b in zip(pts[:-1], pts[1:]):
                    if a[0] != b[0] or a[1] != b[1]:
                        segs.append((a, b, kind, angle, what))
                if len(segs) > MAX_SVG_SEGMENTS:
                    raise DesignError(f"{src}more than {MAX_SVG_SEGMENTS} line segments (at {what}); foldprint "
                                      "reads crease patterns of at most that many segments: simplify the drawing")
        stack.extend((child, m, inh, depth + 1) for child in reversed(list(el)))

    if bad:
        stroke, what = next(iter(bad.items()))
        raise DesignError(f"{src}{what} has stroke colour {stroke!r}, which Origami Simulator's convention "
                          f"does not know ({len(bad)} unknown colour(s): {sorted(bad)}); use "
                          + ", ".join(f"{_COLOURS[k][0]} for {v}" for k, v in CREASE_NAMES.items()))
    return segs, factor


def svg_root(text: str, src: str):
    """The parsed ``<svg>`` root element."""
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        raise DesignError(f"{src}not valid SVG/XML: {exc}") from None
    if _tag(root) != "svg":
        raise DesignError(f"{src}the root element is <{_tag(root)}>, not <svg>")
    _apply_classes(root)
    return root


_CLASS_RULE = re.compile(r"([^{}]+)\{([^{}]*)\}")


def _apply_classes(root) -> None:
    """Class rules of the document's ``<style>`` sheets (``.st2{stroke:#FF0000}``, as
    Illustrator writes them; Origami Simulator reads the browser's computed style, which
    applies them) copied into the ``style`` of the elements of that class, before their own
    inline style (which wins, as in CSS). Only plain class selectors are read."""
    rules: dict[str, str] = {}
    for el in root.iter():
        if _tag(el) == "style" and el.text:
            text = re.sub(r"/\*.*?\*/", "", el.text, flags=re.S)
            for selectors, body in _CLASS_RULE.findall(text):
                for sel in selectors.split(","):
                    sel = sel.strip()
                    if re.fullmatch(r"\.[-\w]+", sel):
                        rules[sel[1:]] = rules.get(sel[1:], "") + ";" + body
    if not rules:
        return
    for el in root.iter():
        names = (el.get("class") or "").split()
        extra = ";".join(rules[n] for n in names if n in rules)
        if extra:
            el.set("style", extra + ";" + (el.get("style") or ""))
