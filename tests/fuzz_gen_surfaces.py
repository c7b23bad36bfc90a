"""Hypothesis strategies for the surfaces added after the first fuzz campaigns: calibrate's
CSV (cells, quoting, digits of other scripts, extremes, kinds of rows), calibrate's options
(``--fix``, ``--fit``, ``--per-material``, ``--plot``) and small designs folded with
``--mechanics bar-hinge``. Each case says whether it must be refused (exit 2): the limits of
``docs/input-safety.md`` as properties. Used by ``tests/test_fuzz_surfaces.py`` (a small
budget) and ``benchmarks/fuzz_inputs.py`` (kinds ``calibrate``, ``calibrate-options``,
``barhinge``)."""

from __future__ import annotations

from hypothesis import strategies as hs

# -- calibrate's CSV ------------------------------------------------------------------------

CAL_COLUMNS = ("kind", "material", "reference", "bath_c", "thickness_mm", "initial_c", "time_s", "level", "value",
               "relation", "sigma", "printed_deg", "source")
NUMERIC_COLUMNS = ("bath_c", "thickness_mm", "initial_c", "time_s", "level", "value", "sigma", "printed_deg")
#: A valid small data set: a new material with its Tg, two library ones (our choice of values:
#: near what the shipped model gives, so a fit converges in a few seconds).
CAL_ROWS = (
    {"kind": "tg", "material": "M1", "value": "45", "source": "DMA"},
    {"kind": "ratio", "material": "M1", "bath_c": "80", "time_s": "2", "value": "0.2"},
    {"kind": "ratio", "material": "M1", "bath_c": "80", "time_s": "5", "value": "0.7", "sigma": "0.03"},
    {"kind": "ratio", "material": "M1", "bath_c": "80", "thickness_mm": "0.8", "initial_c": "10", "time_s": "10",
     "value": "0.97"},
    {"kind": "angle", "material": "H-1", "bath_c": "90", "time_s": "3", "value": "150", "printed_deg": "90"},
    {"kind": "time_to", "material": "H-1", "bath_c": "90", "level": "0.98", "value": "4", "relation": "about"},
    {"kind": "spread", "material": "H-7", "reference": "H-1", "bath_c": "80", "level": "0.98", "value": "7",
     "relation": "at_least"},
    {"kind": "fixity", "material": "M1", "value": "0.98", "source": '"video, frame 3"'},
)
#: Numbers no lab means as one: refused in any numeric column.
BAD_NUMBERS = ["nan", "NaN", "inf", "-inf", "Infinity", "1e309", "-1e309", "\uff18\uff10", "\u0663", "\u0968",
               "1_0", "0x10", "1e", "--1", "1,5", "\u221e", "1e400", "9" * 400]
#: Numbers at the edges of floating point: refused or not, by the column's range.
EDGE_NUMBERS = ["1e308", "-1e308", "5e-324", "1e-300", "0", "-0", "1e6", "-1", "+.5", "1.", "180", "225", "1e-7"]
#: sigma values outside every kind's range (the fit divides by sigma: 5e-324 made residuals infinite).
BAD_SIGMAS = ["5e-324", "1e-300", "1e308", "0", "-1", "1e7"]
#: Names no library can hold (the id rule: 1-100 characters, no control character, no
#: space at either end): refused as a material or reference.
BAD_NAMES = ["M\x00", "a\tb", "x\x7fy", "M" * 101, "N" * 5000, "a\u2028b", "a\x85b"]
#: Names that are awkward but valid: a fitted file must load them back.
ODD_NAMES = ["\u00c4-\u00fc", "\u540d\u524d", "q'uote", '"q""uote"', "back\\slash", "#hash", "[x]", "a.b", "a=b",
             "VW0.5", "VW0.620", "H-1", "M" * 100, "\U0001f600", "\u0663"]
#: Cells a CSV reader may take apart: a line break or form feed inside quotes, an
#: unterminated quote, a control character: refused in any column.
BAD_CELLS = ['"a\nb"', '"a\r\nb"', '"a\x0cb"', '"open', 'x\x0by', 'x\x1cy', '"a"b', 'x\x00']


@hs.composite
def calibrate_csvs(draw) -> tuple[bytes, str | None]:
    """(file bytes, why it must be refused or None): the valid data set with 0-2 cells
    replaced, then file-level changes (a BOM, CRLF, comments, blank lines, a cut)."""
    rows = [dict(r) for r in CAL_ROWS]
    # M1's tg row and at least one measurement (a file without either is refused, which the
    # file-level cuts and the kind changes below draw often enough)
    keep = draw(hs.lists(hs.integers(1, len(rows) - 2), min_size=1, max_size=len(rows) - 2, unique=True))
    rows = [rows[0]] + [rows[k] for k in sorted(keep)] + ([rows[-1]] if draw(hs.booleans()) else [])
    must = None
    extra_cols: list[str] = []
    for _ in range(draw(hs.integers(0, 2))):
        r = draw(hs.integers(0, len(rows) - 1))
        how = draw(hs.sampled_from(["number", "edge", "sigma", "name", "odd", "cell", "kind"]))
        if how in ("number", "edge"):
            col = draw(hs.sampled_from(NUMERIC_COLUMNS))
            rows[r][col] = draw(hs.sampled_from(BAD_NUMBERS if how == "number" else EDGE_NUMBERS))
            must = must or (f"{col} {rows[r][col]!r} is not a number" if how == "number" else None)
        elif how == "sigma":
            col = "sigma"
            rows[r][col] = draw(hs.sampled_from(BAD_SIGMAS))
            must = must or f"sigma {rows[r][col]!r} is outside every kind's range"
        elif how == "name":
            col = draw(hs.sampled_from(["material", "reference"]))
            if col == "reference" and rows[r]["kind"] != "spread":
                col = "material"
            rows[r][col] = draw(hs.sampled_from(BAD_NAMES))
            must = must or f"name {rows[r][col][:20]!r} breaks the id rule"
        elif how == "odd":  # the new material renamed in every row (its tg row too)
            col, odd = "material", draw(hs.sampled_from(ODD_NAMES))
            for row in rows:
                row.update({k: odd for k in ("material", "reference") if row.get(k) == "M1"})
        elif how == "cell":
            col = draw(hs.sampled_from(CAL_COLUMNS))
            rows[r][col] = draw(hs.sampled_from(BAD_CELLS))
            must = must or f"cell {rows[r][col]!r} is not one line of text"
        else:
            col = "kind"
            rows[r][col] = draw(hs.sampled_from(["Ratio", "", "tg ", "curve", "\u0072atio"]))
            must = must or (None if rows[r][col].strip() in ("ratio", "tg") else "not a kind")
        extra_cols.append(col)
    used = [c for c in CAL_COLUMNS if c in ("kind", "material", "value") or c in extra_cols
            or any(c in row for row in rows)]
    if draw(hs.integers(0, 3)) == 0:
        used = draw(hs.permutations(used))
    lines = [",".join(used)] + [",".join(row.get(c, "") for c in used) for row in rows]
    if draw(hs.booleans()):
        lines.insert(draw(hs.integers(0, len(lines))), draw(hs.sampled_from(["# a comment, with commas", "",
                                                                            "  # indented", ",,,"])))
    text = "\n".join(lines) + draw(hs.sampled_from(["\n", "", "\n\n"]))
    if draw(hs.integers(0, 5)) == 0:
        text = text.replace("\n", "\r\n")
    raw = text.encode("utf-8")
    if draw(hs.integers(0, 7)) == 0:
        raw = b"\xef\xbb\xbf" + raw
    cut = draw(hs.integers(0, 40))
    if cut < 2:
        raw, must = raw[: len(raw) * cut // 2], None
    elif cut == 2:
        raw, must = raw + b"\xff\xfe", "not UTF-8"
    return raw, must


# -- calibrate's options ------------------------------------------------------------------

FITTABLE = ("h_w_m2k", "c1", "c2", "log10_tau_ref_s", "spectrum_sigma_decades", "spectrum_span_decades")
FIX_VALUES = ["inf", "-inf", "nan", "1e309", "1e308", "-1e308", "0", "-1", "5e-324", "1e-300", "\uff18", "",
              "17.44", "51.6", "400", "0.5", "1", "9.336", "100", "1000", "1e6", "12", "-12", "20", "30"]
PLOT_SUFFIXES = [".png", ".svg", ".pdf", ".PNG", ".jpg", ".xyz", ".txt", ".raw", ".webp", ".pgf", ".tiff", ".eps",
                 ".ps", ".rgba", ""]


def _fix_refused(name: str, value: str) -> bool:
    """Whether ``--fix name=value`` must be refused: not a finite ASCII number, or outside
    what a materials file may hold (independent of the code: 1e308 is past every parameter's
    range, 0, -1 and 5e-324 past all but the log of a time)."""
    if value in ("inf", "-inf", "nan", "1e309", "\uff18", "1e308", "-1e308"):
        return True
    if value in ("0", "-1", "5e-324", "1e-300") and name != "log10_tau_ref_s":
        return True
    return value in ("1e6", "1000") and name not in ("h_w_m2k", "c2") or value in ("100",) and name in (
        "log10_tau_ref_s", "spectrum_sigma_decades", "spectrum_span_decades")


@hs.composite
def calibrate_command_lines(draw, profile: bool = True) -> tuple[list[str], str | None]:
    """(arguments, why they must be refused or None) of ``calibrate h.csv`` on the valid data
    set with 0-4 options; ``--no-profile`` except one case in six when ``profile`` (the
    profile costs ~10 CPU-s, the point alone ~2)."""
    args = ["calibrate", "h.csv"] + (["--no-profile"] if not profile or draw(hs.integers(0, 5)) else [])
    must = None
    fixed, fitted = set(), set()
    for _ in range(draw(hs.integers(0, 4))):
        opt = draw(hs.sampled_from(["--fix", "--fix", "--fit", "--per-material", "--plot", "--out", "--json"]))
        if opt == "--fix":
            name = draw(hs.sampled_from(FITTABLE + ("c9", "k_w_mk")))
            value = draw(hs.sampled_from(FIX_VALUES))
            args += ["--fix", f"{name}={value}" if value or draw(hs.booleans()) else name]
            if name not in FITTABLE:
                must = must or f"--fix {name}: not a fitted parameter"
            elif value and _fix_refused(name, value):
                must = must or f"--fix {name}={value} is not a value a materials file holds"
            fixed.add(name)
        elif opt in ("--fit", "--per-material"):
            name = draw(hs.sampled_from(FITTABLE + ("c9",)))
            args += [opt, name]
            if name == "c9":
                must = must or f"{opt} c9: not a fitted parameter"
            (fitted if opt == "--fit" else set()).add(name)
        elif opt == "--plot" and "--plot" not in args:
            suffix = draw(hs.sampled_from(PLOT_SUFFIXES))
            args += ["--plot", "fit" + suffix]
            if suffix.lower() not in (".png", ".svg", ".pdf"):
                must = must or f"--plot fit{suffix}: not a figure format we write"
        elif opt == "--out" and "--out" not in args:
            args += ["--out", "m.toml"]
        elif opt == "--json" and "--json" not in args:
            args.append("--json")
    if fixed & fitted:
        must = must or "a parameter both --fit and --fix"
    return args, must


# -- small designs through the bar-and-hinge model ------------------------------------------

ANGLES = [0, 1e-6, 30, 90, -90, 120, 150, 179, 179.99, 180, -180, 90.5]
LENGTHS = [0.01, 0.5, 3, 10, 25, 200]
HINGE_MATERIALS = ['"H-1"', '"H-4"', '"H-7"', '"VeroWhite"', '"VW0.5"', '"H-9"']


def _square(x, y, w, h) -> str:
    return f"[[{x}, {y}], [{x + w}, {y}], [{x + w}, {y + h}], [{x}, {y + h}]]"


@hs.composite
def _outline(draw, x0: float, w: float, h: float) -> str:
    """A panel's outline: a rectangle, with extra (collinear or jittered) vertices along its
    top edge, or a sliver."""
    extra = draw(hs.sampled_from([0, 0, 2, 12, 40]))
    jitter = draw(hs.sampled_from([0.0, 0.0, 1e-9, 0.3]))
    top = [f"[{x0 + w - (k + 1) * w / (extra + 1):.9g}, {h + (jitter if k % 2 else 0.0):.9g}]" for k in range(extra)]
    pts = [f"[{x0}, 0]", f"[{x0 + w}, 0]", f"[{x0 + w}, {h}]"] + top + [f"[{x0}, {h}]"]
    return "[" + ", ".join(pts) + "]"


@hs.composite
def barhinge_designs(draw) -> tuple[str, list[str]]:
    """(TOML design, arguments): a strip, panels in a row (extra outline vertices, holes),
    a single panel or the four-panel loop, with extreme angles, sizes and hinge materials,
    through ``simulate`` or ``check --samples 0`` with ``--mechanics bar-hinge``."""
    shape = draw(hs.sampled_from(["strip", "row", "row", "loop", "single"]))
    thick = draw(hs.sampled_from([0.05, 0.8, 0.8, 3.0]))
    radius = draw(hs.sampled_from([0.1, 2.5, 2.5, 10.0]))
    lines = ["schema = 1", 'name = "b"', "[process]", f"duration_s = {draw(hs.sampled_from([2.0, 4.0, 6.0]))}",
             "[defaults]", f"thickness_mm = {thick}", f"hinge_radius_mm = {radius}"]
    if shape == "strip":
        n = draw(hs.integers(2, 5))
        lengths = [draw(hs.sampled_from(LENGTHS)) for _ in range(n)]
        lines += ["[strip]", f"lengths_mm = {lengths}",
                  f"angles_deg = {[draw(hs.sampled_from(ANGLES)) for _ in range(n - 1)]}",
                  f"materials = [{', '.join(draw(hs.sampled_from(HINGE_MATERIALS)) for _ in range(n - 1))}]"]
    elif shape in ("row", "single"):
        n = 1 if shape == "single" else draw(hs.integers(2, 3))
        w, h = draw(hs.sampled_from([5.0, 20.0])), draw(hs.sampled_from([0.05, 6.0, 20.0]))
        for i in range(n):
            lines += ["[[panels]]", f'id = "p{i}"', f"outline = {draw(_outline(i * w, w, h))}"]
            k = draw(hs.sampled_from([0, 0, 1, 4]))
            if k:
                s = min(w, h) / (2 * k + 1)
                lines.append("holes = [" + ", ".join(_square(i * w + s * (2 * j + 1) / 2, h / 3, s / 2, s / 2)
                                                     for j in range(k)) + "]")
        for i in range(n - 1):
            lines += ["[[hinges]]", f'panels = ["p{i}", "p{i + 1}"]',
                      f"angle_deg = {draw(hs.sampled_from(ANGLES))}",
                      f"material = {draw(hs.sampled_from(HINGE_MATERIALS))}"]
    else:  # four squares around a vertex: a loop
        s = draw(hs.sampled_from([2.0, 20.0]))
        for pid, (x, y) in zip("abcd", ((0, 0), (s, 0), (0, s), (s, s))):
            lines += ["[[panels]]", f'id = "{pid}"', f"outline = {_square(x, y, s, s)}"]
        for pair in ("ab", "bd", "dc", "ca"):
            lines += ["[[hinges]]", f'id = "{pair}"', f'panels = ["{pair[0]}", "{pair[1]}"]',
                      f"angle_deg = {draw(hs.sampled_from(ANGLES))}", 'material = "H-3"']
    cmd = draw(hs.sampled_from([["simulate", "b.toml"], ["check", "b.toml", "--samples", "0", "--json"]]))
    return "\n".join(lines) + "\n", cmd + ["--mechanics", "bar-hinge"]
