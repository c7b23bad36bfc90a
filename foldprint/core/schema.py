"""The boundary schema: every value of a design file is checked here before anything runs.

Hand-written on purpose (``docs/input-safety.md`` says why): each check knows the file,
the key path (``hinges[1].radius_mm``), the item's id and what would be right, and raises
:class:`~foldprint.core.errors.DesignError`.

The limits are bounds of sanity, not of printability (printer-specific rules are
``foldprint check`` findings); each one is named and documented:

* lengths between :data:`MIN_LENGTH_MM` (1 um) and :data:`MAX_LENGTH_MM` (10 m: 20x the
  largest build volume shipped in ``data/printers.toml``) -- bigger coordinates only make
  the geometry kernels slow or inexact;
* periodic hinge features (step period, tooth pitch) at least :data:`FEATURE_FLOOR_MM`
  (10 um, finer than any printer's layer) and at most :data:`MAX_FEATURES` per hinge;
* counts (panels, points, holes) and the file size bounded, so a file cannot ask for
  unbounded work before a resource guard sees it;
* nesting at most :data:`MAX_NESTING` levels deep, checked on the raw text before the TOML
  or JSON parser recurses.
"""

from __future__ import annotations

import math
import re
import unicodedata
from typing import Any, Mapping

from .errors import DesignError, FoldprintError

MIN_LENGTH_MM = 1e-3
MAX_LENGTH_MM = 1e4
FEATURE_FLOOR_MM = 0.01
MAX_FEATURES = 2000
MAX_PANELS = 5000
MAX_POINTS = 10_000
MAX_HOLES = 256
MAX_GOALS = 1000
#: FOLD faces or edges, SVG segments (after reading, before noding) and SVG element nesting
MAX_FACES = 50_000
MAX_SVG_SEGMENTS = 50_000
MAX_SVG_DEPTH = 64
MAX_NAME = 100
MAX_TEXT = 10_000
MAX_NESTING = 32
MAX_FILE_BYTES = 32 * 1024 * 1024
#: Bath, programming and fixing temperatures: -100 C (below dry ice, -78.5 C) .. 500 C. The
#: recovery model's Arrhenius shift below Tg takes 1/T in kelvin: -273.15 C divided by zero
#: (numpy warnings, then a verdict), and 1e308 C overflowed.
TEMPERATURE_C = (-100.0, 500.0)
#: Glass transitions a material may have: the same span. Printable polymers' Tg lie within it
#: (photopolymers about -30 to 100 C, high-temperature ones up to ~300 C); the recovery
#: law's Arrhenius shift divides by Tg in kelvin (tg_c = -273.15 divided by zero, 1e308
#: overflowed), and a Tg drawn under the largest scatter (sd <= 10 C, x5, 3 sd) stays above 0 K.
TG_C = TEMPERATURE_C
MAX_DURATION_S = 1e12  # s; the resource guard (guards.py) refuses long runs with a better message


def describe(value: Any) -> str:
    """A short, safe rendering of a bad value for a message."""
    if isinstance(value, bool):
        return f"{str(value).lower()} (a boolean)"
    if isinstance(value, str):
        text = value if len(value) <= 40 else value[:37] + "..."
        return f"{text!r} (a string)"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)}"
    if isinstance(value, float):
        return f"{value!r}"
    if isinstance(value, int):
        return str(value) if abs(value) < 10 ** 30 else f"an integer of {len(str(abs(value)))} digits"
    return type(value).__name__


class Where:
    """A location in a design or option file: file and key path, with the item's id for
    messages; ``error`` is the class :meth:`fail` makes (DesignError, or MaterialError for
    a material library)."""

    def __init__(self, source: str = "", path: str = "", item: str = "", error: type[FoldprintError] = DesignError):
        self.source, self.path, self.item, self.error = source, path, item, error

    def __truediv__(self, key) -> "Where":
        if isinstance(key, int):
            return Where(self.source, f"{self.path}[{key}]", self.item, self.error)
        return Where(self.source, f"{self.path}.{key}" if self.path else str(key), self.item, self.error)

    def named(self, item: str) -> "Where":
        return Where(self.source, self.path, item, self.error)

    def __str__(self) -> str:
        parts = [p for p in (self.source, self.path + (f" ({self.item})" if self.item else "")) if p]
        return ": ".join(parts) + ": " if parts else ""

    def fail(self, what: str) -> FoldprintError:
        return self.error(f"{self}{what}")


# -- typed readers ------------------------------------------------------------------------

def table(value, at: Where, allowed: set[str] | None = None) -> Mapping:
    if not isinstance(value, Mapping):
        raise at.fail(f"must be a table, got {describe(value)}")
    if allowed is not None:
        unknown = sorted(str(k) for k in set(value) - allowed)
        if unknown:
            shown = unknown[:5] + (["..."] if len(unknown) > 5 else [])
            raise at.fail(f"unknown key(s) {shown}; allowed: {sorted(allowed)}")
    return value


def array(value, at: Where, max_len: int, what: str = "a list") -> list:
    if not isinstance(value, (list, tuple)):
        raise at.fail(f"must be {what}, got {describe(value)}")
    if len(value) > max_len:
        raise at.fail(f"has {len(value)} entries; at most {max_len} are accepted")
    return list(value)


def number(value, at: Where, lo: float | None = None, hi: float | None = None,
           unit: str = "", lo_open: bool = False) -> float:
    """A finite int or float (not a boolean, not a string) in [lo, hi]."""
    u = f" {unit}" if unit else ""
    rng = range_text(lo, hi, lo_open, u)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        hint = ""
        if isinstance(value, str):
            try:
                float(value)
                hint = f"; write it without quotes: {at.path.rsplit('.', 1)[-1]} = {value.strip()}"
            except ValueError:
                pass
        raise at.fail(f"must be a number{rng}, got {describe(value)}{hint}")
    try:
        v = float(value)
    except OverflowError:
        raise at.fail(f"must be a number{rng}, got {describe(value)}") from None
    if not math.isfinite(v):
        raise at.fail(f"must be a finite number{rng}, got {'NaN' if math.isnan(v) else v}")
    if lo is not None and (v < lo or (lo_open and v <= lo)) or hi is not None and v > hi:
        raise at.fail(f"must be{rng}, got {v:g}")
    return v


#: A number as text (a CSV cell): an optional sign, ASCII digits, a point, an exponent.
#: Python's ``float`` reads more: "nan", "inf", "1_000", and digits of any script
#: (fullwidth "\uff11\uff12", Arabic-Indic "\u0663"), none of which a lab's CSV means as a number.
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def number_text(text: str, at, lo: float | None = None, hi: float | None = None, unit: str = "",
                lo_open: bool = False) -> float:
    """A number written as text (a CSV cell), checked as :func:`number`: decimal ASCII
    digits only (``1.5``, ``-2e-3``), no "nan", "inf", "1_000" or digits of other scripts;
    ``at`` is anything with a ``fail(what)`` method."""
    t = text.strip()
    rng = range_text(lo, hi, lo_open, f" {unit}" if unit else "")
    if not _DECIMAL.fullmatch(t):
        finite = " finite" if t.lower().lstrip("+-") in ("nan", "inf", "infinity") else ""
        raise at.fail(f"must be a{finite} number{rng}, written in ASCII digits (e.g. 0.25, -3 or 1e-3), "
                      f"got {text[:40]!r}")
    return number(float(t), at, lo, hi, unit, lo_open)


def range_text(lo, hi, lo_open, u) -> str:
    """" in [lo, hi] u" (or a one-sided bound, or nothing): how a range reads in a message."""
    if lo is None and hi is None:
        return ""
    if hi is None:
        return f" {'>' if lo_open else '>='} {lo:g}{u}"
    if lo is None:
        return f" <= {hi:g}{u}"
    return f" in {'(' if lo_open else '['}{lo:g}, {hi:g}]{u}"


def jam_thresholds(error, warning) -> tuple[float, float]:
    """``check``'s jam thresholds (``--error-above``, ``--warn-above``): each a probability
    strictly between 0 and 1 (at 1 no part could fail or warn, at 0 every part would, and
    the sequential test's indifference region would leave [0, 1]), the warning's below the
    error's."""
    out = []
    for v, option in ((error, "--error-above"), (warning, "--warn-above")):
        at = Where(option)
        v = number(v, at)
        if not 0.0 < v < 1.0:
            raise at.fail(f"must be a jam probability in (0, 1) (at 1 no part could fail or warn, at 0 every part "
                          f"would), got {v:g}")
        out.append(v)
    if not out[1] < out[0]:
        raise DesignError(f"--warn-above ({out[1]:g}) must be below --error-above ({out[0]:g}): a warning comes "
                          "before the error")
    return out[0], out[1]


def length(value, at: Where) -> float:
    """A length in mm between 1 um and 10 m."""
    v = number(value, at, unit="mm")
    if v <= 0:
        raise at.fail(f"must be > 0 mm, got {v:g}")
    if not MIN_LENGTH_MM <= v <= MAX_LENGTH_MM:
        raise at.fail(f"must be in [{MIN_LENGTH_MM:g}, {MAX_LENGTH_MM:g}] mm (1 um to 10 m), got {v:g}")
    return v


def integer(value, at: Where, lo: int | None = None, hi: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (
            isinstance(value, float) and not (math.isfinite(value) and value == int(value))):
        raise at.fail(f"must be a whole number, got {describe(value)}")
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise at.fail(f"must be a whole number in [{lo}, {hi}], got {v}")
    return v


def string(value, at: Where, max_len: int = MAX_NAME, what: str = "a string") -> str:
    """Text of at most ``max_len`` characters that is valid Unicode: a lone surrogate (a
    JSON escape such as \\ud800 without its pair) cannot be written to any file or
    terminal, so it is refused here, where its key is known."""
    if not isinstance(value, str):
        raise at.fail(f"must be {what}, got {describe(value)}")
    if len(value) > max_len:
        raise at.fail(f"is {len(value)} characters long; at most {max_len} are accepted")
    if not value.isascii():
        bad = next((c for c in value if 0xD800 <= ord(c) <= 0xDFFF), None)
        if bad is not None:
            raise at.fail(f"holds a lone surrogate ({bad!r}), which is not text any file or terminal can hold; "
                          "write the character itself (UTF-8) or leave it out")
    return value


#: The one rule for ids and material names (a design's panels and hinges, a material
#: library, calibrate's CSV): what it says, for messages.
ID_RULE = (f"1 to {MAX_NAME} characters, no control characters (tab, NUL, line breaks), no space at either "
           "end")


def control_char(text: str) -> str | None:
    """The first control character of ``text`` (Unicode categories Cc, Cs: tab, NUL, DEL,
    C1 controls, lone surrogates; and the line and paragraph separators), None without."""
    for c in text:
        if (c < " " or "\x7f" <= c <= "\x9f" or c in "\u2028\u2029"
                or (not c.isascii() and unicodedata.category(c) in ("Cc", "Cs"))):
            return c
    return None


def ident(value, at: Where) -> str:
    """A panel/hinge/goal id or a material name: a non-empty string (numbers are accepted
    and become text) of :data:`ID_RULE`; a TOML key of any such name loads back."""
    if isinstance(value, bool) or not isinstance(value, (str, int)):
        raise at.fail(f"must be an id (a string), got {describe(value)}")
    text = str(value)
    if len(text) > MAX_NAME:
        raise at.fail(f"is {len(text)} characters long; a name is {ID_RULE}")
    bad = control_char(text)
    if not text or bad is not None or text != text.strip():
        what = ("is empty" if not text else f"holds the control character {bad!r}" if bad is not None
                else "has a space at its start or end")
        raise at.fail(f"{what} ({text[:40]!r}); a name is {ID_RULE}")
    return string(text, at)


def name(value, at: Where) -> str:
    """A design name: it becomes file and directory names, so no path separators."""
    text = string(value, at, MAX_NAME, "a non-empty string")
    if not text.strip():
        raise at.fail("must be a non-empty string")
    if any(c in text for c in "/\\") or any(ord(c) < 32 for c in text) or text.strip(".") == "":
        raise at.fail(f"{text[:40]!r} cannot be used as a file name; use letters, digits, spaces, "
                      "'-', '_' or '.' (no '/' or '\\')")
    return text


def boolean(value, at: Where) -> bool:
    if not isinstance(value, bool):
        raise at.fail(f"must be true or false, got {describe(value)}")
    return value


def points(value, at: Where, exact: int | None = None) -> list[list[float]]:
    """A list of [x, y] points with finite coordinates within +-10 m."""
    pts = array(value, at, MAX_POINTS, "a list of [x, y] points")
    if exact is not None and len(pts) != exact:
        raise at.fail(f"must be {exact} points [[x0, y0], [x1, y1]], got {len(pts)}")
    out = []
    for k, p in enumerate(pts):
        if not isinstance(p, (list, tuple)) or len(p) != 2:
            raise (at / k).fail(f"must be a point [x, y], got {describe(p)}")
        out.append([number(c, at / k / i, -MAX_LENGTH_MM, MAX_LENGTH_MM, "mm") for i, c in enumerate(p)])
    return out


def ring(value, at: Where) -> list[list[float]]:
    pts = points(value, at)
    if len(pts) < 3:
        raise at.fail(f"needs at least 3 points, got {len(pts)}")
    return pts


# -- raw text -----------------------------------------------------------------------------

_TOML_TOKENS = re.compile(r'"""|\'\'\'|"|\'|#|\[|\]|\{|\}|\n|\\')
_JSON_TOKENS = re.compile(r'"|\[|\]|\{|\}|\\')


_LONG_INT = re.compile(r"\d{4000,}")


def parse_error(exc: Exception, text: str, source: str, kind: str) -> str:
    """The message for a parser's ValueError: a file position for an integer literal
    too long to convert (Python refuses over 4300 digits, raising a bare ValueError that
    is not a decode error), the parser's own text otherwise."""
    what = "TOML" if kind == "toml" else "JSON"
    m = _LONG_INT.search(text) if "digits" in str(exc) else None
    if m:
        line = text.count("\n", 0, m.start()) + 1
        return (f"{source}: line {line}: a number with {len(m.group())}+ digits; no value of a design or option "
                f"file needs more than 20 (lengths at most {MAX_LENGTH_MM:g} mm, indices at most a few thousand)")
    return f"{source}: not valid {what}: {exc}"


def check_text(text: str, source: str, kind: str) -> None:
    """Refuse files too large or nested too deeply before a recursive parser sees them.

    ``kind`` is "toml" or "json". The scan skips strings (and TOML comments), so brackets
    inside a description do not count."""
    if len(text) > MAX_FILE_BYTES:
        raise DesignError(f"{source}: file is {len(text) / 2**20:.0f} MiB; design files of at most "
                          f"{MAX_FILE_BYTES // 2**20} MiB are accepted")
    depth = deepest = 0
    quote = None  # the open string delimiter
    comment = False
    escape_next = False
    last_end = 0
    tokens = _TOML_TOKENS if kind == "toml" else _JSON_TOKENS
    for m in tokens.finditer(text):
        tok = m.group()
        if escape_next:
            escape_next = False
            if m.start() == last_end:
                last_end = m.end()
                continue
        last_end = m.end()
        if comment:
            if tok == "\n":
                comment = False
            continue
        if quote is not None:
            if tok == "\\" and quote in ('"', '"""'):
                escape_next = True
            elif tok == quote or (quote in ('"', "'") and tok in ('"""', "'''") and tok[0] == quote):
                quote = None
            elif tok == "\n" and quote in ('"', "'"):
                quote = None  # an unterminated one-line string: the parser reports it
            continue
        if tok in ('"', "'", '"""', "'''"):
            quote = tok
        elif tok == "#" and kind == "toml":
            comment = True
        elif tok in "[{":
            depth += 1
            if depth > deepest:
                deepest = depth
                if deepest > MAX_NESTING:
                    line = text.count("\n", 0, m.start()) + 1
                    raise DesignError(f"{source}: line {line}: lists or tables nested more than "
                                      f"{MAX_NESTING} levels deep; a design or option file needs at most 5")
        elif tok in "]}":
            depth = max(0, depth - 1)


# -- FOLD per-item fields ------------------------------------------------------------------

def check_fold(frame, source: str) -> None:
    """Types of foldprint's per-face and per-edge FOLD fields (null or the right kind),
    checked before the FOLD reader indexes them."""
    if not isinstance(frame, Mapping):
        return
    top = Where(source)
    if "file_spec" in frame:  # FOLD: a number (1, 1.1, 1.2)
        number(frame["file_spec"], top / "file_spec", 0.0, 100.0)
    for key in ("frame_title", "file_title", "file_creator", "file_author", "frame_unit", "frame_author",
                "frame_description", "file_description"):
        if key in frame:
            string(frame[key], top / key, MAX_TEXT)
    for key in ("frame_classes", "file_classes", "frame_attributes"):
        if key in frame and not (isinstance(frame[key], list) and all(isinstance(c, str) for c in frame[key])):
            raise (top / key).fail(f"must be a list of strings, got {describe(frame[key])}")
        for i, c in enumerate(frame.get(key) or ()):
            string(c, top / key / i, MAX_TEXT)
    for key in ("faces_foldprint:holes",):
        raw = frame.get(key)
        if raw is None:
            continue
        for f, holes in enumerate(array(raw, top / key, MAX_POINTS)):
            if holes is not None:
                for k, h in enumerate(array(holes, top / key / f, MAX_HOLES, "null or a list of hole polygons")):
                    ring(h, top / key / f / k)
    for key in ("faces_foldprint:thickness_mm", "edges_foldprint:radius_mm", "edges_foldprint:thickness_mm"):
        raw = frame.get(key)
        if raw is not None:
            for i, v in enumerate(array(raw, top / key, 10 * MAX_POINTS)):
                if v is not None:
                    length(v, top / key / i)
    for key in ("faces_foldprint:id", "faces_foldprint:material", "edges_foldprint:hinge_id",
                "edges_foldprint:material"):
        raw = frame.get(key)
        if raw is not None:
            for i, v in enumerate(array(raw, top / key, 10 * MAX_POINTS)):
                # a hinge material may also be {"vero_fraction": ...} (model.composition parses it)
                if v is not None and not (key == "edges_foldprint:material" and isinstance(v, dict)):
                    ident(v, top / key / i)
