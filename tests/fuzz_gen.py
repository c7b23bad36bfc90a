"""Hypothesis strategies for hostile inputs (issue 20 item 8): SVG documents, FOLD files,
command lines and planted output folders, built from primitives so that hypothesis can
shrink a failing case to its minimal input. Used by ``tests/test_fuzz_inputs.py`` (a
small budget in the suite) and ``benchmarks/fuzz_inputs.py`` (10,000 cases)."""

from __future__ import annotations

import hashlib
import json
import os

from hypothesis import strategies as hs

# -- numbers as text: ordinary, huge, tiny, non-finite, malformed --------------------------

NUM_TEXT = hs.one_of(
    hs.integers(-200, 200).map(str),
    hs.floats(-1e3, 1e3, allow_nan=False).map(lambda v: f"{v:.3f}"),
    hs.sampled_from(["0", "-0", "1e300", "-1e300", "1e309", "1e-300", "1e308", "nan", "inf", "-inf",
                     "9" * 400, "1e", "--1", "", ".", "+.5", "0x10", "1_000", "5e-324"]),
)
NUM_VALUE = hs.one_of(  # JSON values where a number is expected
    hs.integers(-10, 100), hs.floats(allow_nan=False, allow_infinity=False),
    hs.sampled_from([10 ** 400, -(10 ** 30), 2.0, 1e308, 1e-300, True, None, "5", "x", [], {}, [1, 2]]),
)
ANY_JSON = hs.recursive(hs.none() | hs.booleans() | NUM_VALUE | hs.text(max_size=8),
                        lambda kids: hs.lists(kids, max_size=4) | hs.dictionaries(hs.text(max_size=6), kids, max_size=3),
                        max_leaves=12)

# -- SVG ------------------------------------------------------------------------------------

STROKES = ["#000", "#f00", "#00f", "#0f0", "#ff0", "#f0f", "red", "blue", "black", "none", "", "#123456",
           "rgb(255,0,0)", "url(#x)"]
_BORDER = '<rect x="0" y="0" width="100" height="100" stroke="#000" fill="none"/>'


@hs.composite
def transforms(draw) -> str:
    parts = draw(hs.lists(hs.tuples(hs.sampled_from(["translate", "scale", "rotate", "matrix", "skewX", "skewY",
                                                     "bogus"]),
                                    hs.lists(NUM_TEXT, min_size=0, max_size=6)), max_size=3))
    return " ".join(f"{n}({' '.join(a)})" for n, a in parts)


@hs.composite
def svg_element(draw) -> str:
    tag = draw(hs.sampled_from(["line", "rect", "polygon", "polyline", "path", "g", "desc", "circle"]))
    stroke = draw(hs.sampled_from(STROKES))
    extra = ""
    if draw(hs.booleans()):
        extra += f' transform="{draw(transforms())}"'
    if draw(hs.integers(0, 4)) == 0:
        extra += f' opacity="{draw(NUM_TEXT)}"'
    n = lambda: draw(NUM_TEXT)  # noqa: E731
    if tag == "line":
        return f'<line x1="{n()}" y1="{n()}" x2="{n()}" y2="{n()}" stroke="{stroke}"{extra}/>'
    if tag == "rect":
        return f'<rect x="{n()}" y="{n()}" width="{n()}" height="{n()}" stroke="{stroke}"{extra}/>'
    if tag in ("polygon", "polyline"):
        pts = " ".join(f"{n()},{n()}" for _ in range(draw(hs.integers(0, 6))))
        return f'<{tag} points="{pts}" stroke="{stroke}"{extra}/>'
    if tag == "path":
        cmds = draw(hs.lists(hs.sampled_from("MmLlHhVvZzCQA"), min_size=1, max_size=8))
        d = " ".join(f"{c} {n()} {n()}" if c in "MmLl" else f"{c} {n()}" if c in "HhVv" else c for c in cmds)
        if draw(hs.integers(0, 6)) == 0:  # long paths: repeated, back and forth, or crossing
            k = draw(hs.sampled_from([100, 2000, 20000]))
            d = "M 10 10" + (" l1 0 l-1 0" * (k // 2) if draw(hs.booleans()) else
                             "".join(f" L {(i * 37) % 100} {(i * 61) % 100}" for i in range(k)))
        return f'<path d="{d}" stroke="{stroke}"{extra}/>'
    if tag == "desc":
        return f"<desc>{draw(hs.sampled_from(['[' * 40, '{' * 40, '&amp;', 'x']))}</desc>"
    if tag == "g":
        depth = draw(hs.sampled_from([1, 2, 70, 5000]))
        inner = draw(hs.lists(svg_element_leaf(), max_size=3))
        return f'<g stroke="{stroke}"{extra}>' * depth + "".join(inner) + "</g>" * depth
    return f'<circle cx="{n()}" cy="{n()}" r="{n()}" stroke="{stroke}"/>'


@hs.composite
def svg_element_leaf(draw) -> str:
    s = draw(hs.sampled_from(STROKES[:6]))
    c = [draw(NUM_TEXT) for _ in range(4)]
    return f'<line x1="{c[0]}" y1="{c[1]}" x2="{c[2]}" y2="{c[3]}" stroke="{s}"/>'


@hs.composite
def svg_documents(draw) -> bytes:
    """A crease pattern: a border and a valley line, then hostile elements and attributes."""
    root = draw(hs.sampled_from(['width="100mm" height="100mm" viewBox="0 0 100 100"', "",
                                 'width="1e300mm" viewBox="0 0 0 0"', 'width="10in" viewBox="0 0 1e-300 1"',
                                 'width="-5cm" height="nan"']))
    body = [_BORDER] if draw(hs.booleans()) else []
    body += ['<line x1="50" y1="0" x2="50" y2="100" stroke="#00f"/>'] if draw(hs.booleans()) else []
    body += draw(hs.lists(svg_element(), max_size=5))
    text = f'<svg xmlns="http://www.w3.org/2000/svg" {root}>{"".join(body)}</svg>'
    cut = draw(hs.integers(0, 20))
    raw = text.encode()
    return raw[: len(raw) * cut // 20] if cut < 3 else raw


# -- FOLD ------------------------------------------------------------------------------------

FOLD_BASE = {"file_spec": 1.2, "frame_unit": "mm", "frame_title": "f",
             "vertices_coords": [[0, 0], [10, 0], [10, 6], [0, 6], [20, 0], [20, 6]],
             "faces_vertices": [[0, 1, 2, 3], [1, 4, 5, 2]], "edges_vertices": [[1, 2]],
             "edges_assignment": ["V"], "edges_foldAngle": [90]}
FOLD_KEYS = sorted(FOLD_BASE) + ["file_frames", "frame_classes", "faces_foldprint:material",
                                 "edges_foldprint:radius_mm", "faces_foldprint:holes", "edges_foldprint:hinge_id"]


@hs.composite
def fold_documents(draw) -> bytes:
    data = json.loads(json.dumps(FOLD_BASE))
    for _ in range(draw(hs.integers(0, 3))):  # 0: the valid sheet itself
        key = draw(hs.sampled_from(FOLD_KEYS))
        how = draw(hs.integers(0, 3))
        if how == 0:
            data.pop(key, None)
        elif how == 1 or key not in data or not isinstance(data[key], list) or not data[key]:
            data[key] = draw(ANY_JSON)
        else:  # one entry (or one number inside it) replaced
            lst = data[key]
            i = draw(hs.integers(0, len(lst) - 1))
            if isinstance(lst[i], list) and lst[i] and draw(hs.booleans()):
                j = draw(hs.integers(0, len(lst[i]) - 1))
                lst[i][j] = draw(NUM_VALUE)
            else:
                lst[i] = draw(ANY_JSON)
    text = json.dumps(data)
    if draw(hs.integers(0, 8)) == 0:
        text = text.replace("90", "9" * draw(hs.sampled_from([400, 5000])), 1)
    return text.encode()


# -- command lines -------------------------------------------------------------------------

OPTION_VALUES = hs.one_of(NUM_TEXT, hs.sampled_from(["", "/", "1e400TiB", "4G", "-3", "0", "x", "H-1", "M=H-2",
                                                     "index2d", "point", "stop", ".", "99999999999999999999"]))
OPTIONS = {
    "simulate": ["--temperature", "--duration", "--dt", "--method", "--hinge-model", "--after-contact",
                 "--max-memory", "--scale"],
    "check": ["--printer", "--hinge-model", "--samples", "--seed", "--error-above", "--warn-above", "--max-memory"],
    "robust": ["--samples", "--seed", "--hinge-model"],
    "materials": ["--temperature", "--thickness"],
    "export": ["--state", "--format", "--out"],
    "assign": ["--objective", "--top", "--budget", "--samples", "--temperature", "--workers"],
}


@hs.composite
def command_lines(draw) -> list[str]:
    """A command on the small strip design ``d.toml`` with 1-3 options, values hostile or
    plausible; samples and budgets are capped by what the case may cost, not by the value."""
    cmd = draw(hs.sampled_from(sorted(OPTIONS)))
    args = [cmd] + ([] if cmd == "materials" else ["d.toml"])
    for opt in draw(hs.lists(hs.sampled_from(OPTIONS[cmd]), min_size=1, max_size=3, unique=True)):
        args += [opt, draw(OPTION_VALUES)]
    if cmd in ("robust", "check", "assign") and "--samples" not in args:
        args += ["--samples", "2" if cmd != "check" else "0"]
    if cmd == "assign" and "--budget" not in args:
        args += ["--budget", "4"]
    if cmd == "export" and "--out" not in args:
        args += ["--out", "out"]
    return args


SMALL_DESIGN = """schema = 1
name = "d"
[process]
duration_s = 8.0
[strip]
lengths_mm = [10, 12, 14]
angles_deg = [90, 90]
materials = ["H-1", "H-4"]
"""

# -- planted output folders ---------------------------------------------------------------

PLANTS = ["current->../keep.txt", "current->/etc", "current-file", "sets->..", "sets-dir-junk", "legacy-export",
          "manifest-garbage", "manifest-escape", "manifest-ours", "manifest-changed", "user-tmp", "own-tmp-fresh",
          "inside-stage-stale", "inside-stage-user", "name-is-dir", "name-is-link-out", "legacy-file",
          "sibling-file", "sibling-userdir", "sibling-link", "sibling-stale", "sibling-old-user",
          "sibling-old-ours", "out-is-file", "out-is-link"]
#: planted entries that are foldprint's own (by name and manifest): a run may remove them
PLANTS_OURS = {"legacy-export": ["out/.foldprint-", "real_out/.foldprint-"],
               "own-tmp-fresh": ["out/.foldprint-abcdefgh.tmp", "real_out/.foldprint-abcdefgh.tmp"],
               "inside-stage-stale": ["out/.foldprint-tmp-abcdefgh", "real_out/.foldprint-tmp-abcdefgh"],
               "manifest-ours": ["out/gone.stl", "real_out/gone.stl"],
               "sibling-stale": [".out.foldprint-tmp-defghijk", ".real_out.foldprint-tmp-defghijk"],
               "sibling-old-ours": [".out.foldprint-old-fghijklm", ".real_out.foldprint-old-fghijklm"]}


def contract_violations(res: dict, *, wrote_on_exit_2: bool, json_stdout: bool = False,
                        warnings_banned: bool = False) -> list[str]:
    """The exit-and-output contract every foldprint run keeps, as a list of violations (empty:
    fine): no timeout, no traceback, exit 0/1/2 only, JSON on stdout where ``json_stdout``, and
    on exit 2 one line on stderr and nothing written (``wrote_on_exit_2`` says whether the
    caller saw a write). The one definition for tests/test_fuzz.py, tests/test_fuzz_inputs.py
    and benchmarks/fuzz_inputs.py.
    """
    if res["timeout"]:
        return ["timeout"]
    bad = []
    if "Traceback" in res["err"]:
        bad.append("traceback")
    if res["code"] not in (0, 1, 2):
        bad.append(f"exit {res['code']}")
    if json_stdout and res["code"] in (0, 1):
        try:
            json.loads(res["out"])
        except ValueError:
            bad.append("no JSON on stdout")
    if res["code"] == 2:
        if res["err"].count("\n") != 1:
            bad.append("not one line on stderr")
        if wrote_on_exit_2:
            bad.append("wrote on exit 2")
    if warnings_banned and "Warning" in res["err"]:
        bad.append("warning printed")
    return bad

def _manifest(rows) -> str:
    return json.dumps({"tool": "foldprint", "complete": True,
                       "files": [{"name": n, "bytes": len(b), "sha256": hashlib.sha256(b).hexdigest()}
                                 for n, b in rows]})


def plant(out, kind: str, names: list[str]) -> None:
    """Put one planted entry of ``kind`` into ``out`` (created unless the entry goes
    beside it or is ``out`` itself) or beside it."""
    base = out.parent

    def link(target, at):
        if not os.path.lexists(at):
            os.symlink(target, at)

    if kind == "out-is-file":
        if not os.path.lexists(out):
            out.write_text("a file where the folder goes")
        return
    if kind == "out-is-link":
        (base / "real_out").mkdir(exist_ok=True)
        link("real_out", out)
        return
    if kind.startswith("sibling-"):
        pre = f".{out.name}.foldprint-"
        if kind == "sibling-file":
            (base / f"{pre}tmp-abcdefgh").write_text("mine")
        elif kind == "sibling-userdir":
            (base / f"{pre}tmp-bcdefghi").mkdir(exist_ok=True)
            (base / f"{pre}tmp-bcdefghi" / "mine.txt").write_text("mine")
        elif kind == "sibling-link":
            link("keep.txt", base / f"{pre}old-cdefghij")
        elif kind == "sibling-stale":
            (base / f"{pre}tmp-defghijk").mkdir(exist_ok=True)
            (base / f"{pre}tmp-defghijk" / "foldprint-set.json").write_text(_manifest([]))
            (base / f"{pre}tmp-defghijk" / names[0]).write_text("half")
        elif kind == "sibling-old-user":
            (base / f"{pre}old-efghijkl").mkdir(exist_ok=True)
            (base / f"{pre}old-efghijkl" / "mine.txt").write_text("mine")
        elif kind == "sibling-old-ours":
            (base / f"{pre}old-fghijklm").mkdir(exist_ok=True)
            (base / f"{pre}old-fghijklm" / names[0]).write_bytes(b"set aside")
            (base / f"{pre}old-fghijklm" / "foldprint-set.json").write_text(_manifest([(names[0], b"set aside")]))
        return
    if os.path.lexists(out) and not out.is_dir():
        return
    out.mkdir(parents=True, exist_ok=True)
    cur, sets = out / ".foldprint-current", out / ".foldprint-sets"
    if kind.startswith("current->"):
        link(kind.split("->", 1)[1], cur)
    elif kind == "current-file" and not os.path.lexists(cur):
        cur.write_text("../keep.txt\n")
    elif kind == "sets->..":
        link("..", sets)
    elif kind == "sets-dir-junk" and not os.path.lexists(sets):
        sets.mkdir()
        (sets / "junk").write_text("user")
    elif kind == "legacy-export" and not os.path.lexists(sets) and not os.path.lexists(cur):
        (sets / "set-zzzzzzzz").mkdir(parents=True)
        for n in names:
            (sets / "set-zzzzzzzz" / n).write_text("legacy")
            link(f".foldprint-current/{n}", out / n)
        link(".foldprint-sets/set-zzzzzzzz", cur)
    elif kind.startswith("manifest-") and not os.path.lexists(out / "foldprint-set.json"):
        m = out / "foldprint-set.json"
        if kind == "manifest-garbage":
            m.write_bytes(b"\xff{")
        elif kind == "manifest-escape":
            m.write_text(_manifest([("../keep.txt", b"mine")]))
        elif kind == "manifest-ours":
            (out / "gone.stl").write_bytes(b"v0")
            m.write_text(_manifest([("gone.stl", b"v0"), ("missing.stl", b"")]))
        elif kind == "manifest-changed":
            (out / "gone.stl").write_bytes(b"edited")
            m.write_text(_manifest([("gone.stl", b"v0")]))
    elif kind == "user-tmp":
        (out / ".notes.abcdefgh.tmp").write_text("mine")
    elif kind == "own-tmp-fresh":
        (out / ".foldprint-abcdefgh.tmp").write_text("fresh")
    elif kind == "inside-stage-stale":
        (out / ".foldprint-tmp-abcdefgh").mkdir(exist_ok=True)
        (out / ".foldprint-tmp-abcdefgh" / "foldprint-set.json").write_text(_manifest([]))
    elif kind == "inside-stage-user":
        (out / ".foldprint-tmp-zzzzzzzz").mkdir(exist_ok=True)
        (out / ".foldprint-tmp-zzzzzzzz" / "mine.txt").write_text("mine")
    elif kind == "name-is-dir" and not os.path.lexists(out / names[0]):
        (out / names[0]).mkdir()
    elif kind == "name-is-link-out":
        link("../keep.txt", out / names[-1])
    elif kind == "legacy-file" and not os.path.lexists(out / names[0]):
        (out / names[0]).write_text("old export")


FILE_NAMES = hs.lists(hs.sampled_from(["a.3mf", "b_prusa.3mf", "c_H-1.stl", "manifest.json", "d.fold", "e.glb"]),
                      min_size=1, max_size=4, unique=True)
