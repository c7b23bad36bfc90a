"""Hypothesis strategies for hostile inputs (the input boundary's fuzz): SVG documents, FOLD files,
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

# -- option files (--materials, --printers, --scatter) ----------------------------------------

#: TOML values as text, hostile or plausible (numbers past float, past int conversion,
#: absolute zero, strings, tables, nesting past the parsers)
TOML_VALUES = hs.one_of(
    hs.sampled_from(["-273.15", "1e308", "-1e308", "5e-324", "inf", "-inf", "nan", "0", "-0.0", "1", "40",
                     "9" * 401, "9" * 5000, '"5"', '"\\u00e9"', "true", "[]", "{}", "[1, 2]", "[1, 2, 3]",
                     "[" * 40 + "]" * 40, "[" * 2000 + "]" * 2000, "{a = 1}", '"#ff00ff"', '"hinge"', '"panel"']),
    hs.floats(-1e4, 1e4, allow_nan=False).map(repr),
    hs.integers(-(10 ** 6), 10 ** 6).map(str),
)
OPTION_BASES = {  # a valid file of each kind: table -> {key: TOML text}
    "--materials": {"materials.X": {"role": '"hinge"', "tg_c": "40.0", "color": '"#112233"'},
                    "materials.X.recovery": {"h_w_m2k": "400.0", "c1": "17.0", "n_branches": "16"},
                    "materials.H-1": {"max_strain": "0.2"}, "recovery_defaults": {}},
    "--printers": {"printers.p": {"build_mm": "[100, 100, 100]", "layer_mm": "0.03", "min_wall_mm": "0.6",
                                  "min_gap_mm": "0.2", "voxel_mm": "[0.04, 0.08, 0.03]"}},
    "--scatter": {"shared.bath": {"sd_c": "1.0"}, "hinge.tg": {"sd_c": "1.0"}, "hinge.thickness": {"sd_mm": "0.04"},
                  "shared.heat_transfer": {"sigma_ln": "0.2"}, "hinge.heat_transfer": {"sigma_ln": "0.1"}},
}
OPTION_KEYS = {"--materials": ["role", "tg_c", "color", "max_strain", "description", "source", "bogus", "k_w_mk",
                               "rho_kg_m3", "c_j_kgk", "h_w_m2k", "c1", "c2", "log10_tau_ref_s",
                               "spectrum_sigma_decades", "spectrum_span_decades", "n_branches"],
               "--printers": ["build_mm", "layer_mm", "min_wall_mm", "min_gap_mm", "voxel_mm", "name",
                              "technology", "voxel_source", "bogus"],
               "--scatter": ["sd_c", "sd_mm", "sigma_ln", "source", "bogus"]}


@hs.composite
def option_files(draw) -> tuple[str, bytes]:
    """(option, file bytes): a valid option file with 1-3 values replaced or added."""
    option = draw(hs.sampled_from(sorted(OPTION_BASES)))
    tables = json.loads(json.dumps(OPTION_BASES[option]))
    for _ in range(draw(hs.integers(1, 3))):
        table = draw(hs.sampled_from(sorted(tables)))
        tables[table][draw(hs.sampled_from(OPTION_KEYS[option]))] = draw(TOML_VALUES)
    text = "".join(f"[{t}]\n" + "".join(f"{k} = {v}\n" for k, v in kv.items()) for t, kv in tables.items())
    raw = text.encode()
    cut = draw(hs.integers(0, 30))
    return option, (raw[: len(raw) * cut // 30] if cut < 2 else raw)


# -- input paths that are not regular files, or too long or deep ----------------------------

PATH_KINDS = ["fifo", "dev_zero", "dev_urandom", "directory", "missing", "long_name", "long_path", "deep_path",
              "dangling_link", "link_loop"]
READERS = {"design": ["check", "{}", "--samples", "0"], "--materials": ["materials", "--materials", "{}"],
           "--printers": ["check", "d.toml", "--samples", "0", "--printers", "{}"],
           "--scatter": ["robust", "d.toml", "--samples", "1", "--scatter", "{}"],
           "--out": ["export", "d.toml", "--format", "stl", "--out", "{}"],
           "--plot": ["materials", "--plot", "{}"]}


def make_path(case, kind: str, suffix: str) -> str:
    """Make an input of ``kind`` in the folder ``case`` (or only its name); its path."""
    p = os.path.join(case, "input" + suffix)
    if kind == "fifo":
        os.mkfifo(p)
    elif kind in ("dev_zero", "dev_urandom"):
        os.symlink("/dev/" + kind[4:], p)
    elif kind == "directory":
        os.mkdir(p)
    elif kind == "dangling_link":
        os.symlink("nowhere" + suffix, p)
    elif kind == "link_loop":
        os.symlink("input" + suffix, p)
    elif kind == "long_name":
        p = os.path.join(case, "n" * 300 + suffix)
    elif kind == "long_path":
        p = os.path.join(case, "x" * 5000 + suffix)
    elif kind == "deep_path":
        p = os.path.join(case, "a/" * 2100 + "d" + suffix)
    return p


@hs.composite
def path_cases(draw) -> tuple[str, str, str]:
    """(reader, path kind, suffix)."""
    reader = draw(hs.sampled_from(sorted(READERS)))
    suffix = draw(hs.sampled_from([".toml", ".fold", ".svg"] if reader == "design" else
                                  [".png", ".exe", ""] if reader == "--plot" else [".toml", ""]))
    return reader, draw(hs.sampled_from(PATH_KINDS)), suffix


# -- numeric options at their extremes ---------------------------------------------------------

EXTREMES = hs.sampled_from(["1e308", "-1e308", "1e-308", "5e-324", "1e309", "inf", "-inf", "nan", "0", "-0",
                            "-1", "9" * 400, "1e6", "1000001", "4.9e-324", "0x10", "1_0", ""])
NUMERIC = {"simulate": ["--temperature", "--duration", "--dt", "--scale", "--max-memory"],
           "check": ["--samples", "--seed", "--error-above", "--warn-above", "--scales", "--scale", "--max-memory"],
           "robust": ["--samples", "--seed", "--scales"],
           "materials": ["--temperature", "--thickness"],
           "export": ["--scale"],
           "assign": ["--top", "--budget", "--samples", "--temperature", "--workers", "--seed"]}


@hs.composite
def numeric_command_lines(draw) -> list[str]:
    """A command on ``d.toml`` with 1-3 numeric options at extreme values (``--scales``
    gets one or a list); runs stay short: robust and check add few samples, assign a small budget."""
    cmd = draw(hs.sampled_from(sorted(NUMERIC)))
    args = [cmd] + ([] if cmd == "materials" else ["d.toml"])
    for opt in draw(hs.lists(hs.sampled_from(NUMERIC[cmd]), min_size=1, max_size=3, unique=True)):
        v = draw(EXTREMES)
        args += [opt, ",".join([v, draw(EXTREMES)]) if opt == "--scales" and draw(hs.booleans()) else v]
    if cmd in ("robust", "check", "assign") and "--samples" not in args:
        args += ["--samples", "2" if cmd != "check" else "0"]
    if cmd == "assign" and "--budget" not in args:
        args += ["--budget", "4"]
    if cmd == "export":
        args += ["--format", "stl", "--out", "out"]
    return args


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
                        warnings_banned: bool = False, wrote_outside: bool = False,
                        peak_limit_mib: float | None = None) -> list[str]:
    """The exit-and-output contract every foldprint run keeps, as a list of violations (empty:
    fine): no timeout, no traceback, exit 0/1/2 only, JSON on stdout where ``json_stdout``, and
    on exit 2 one line on stderr and nothing written (``wrote_on_exit_2`` says whether the
    caller saw a write); nothing written outside ``--out`` (``wrote_outside``); no
    MemoryError (the guards refuse before one) and a peak resident size under
    ``peak_limit_mib`` (the memory guard's limit) when given. The one definition for
    tests/test_fuzz.py, tests/test_fuzz_inputs.py, tests/test_guards_hold.py and
    benchmarks/fuzz_inputs.py.
    """
    if res["timeout"]:
        return ["timeout"]
    bad = []
    if "Traceback" in res["err"]:
        bad.append("traceback")
    if res["code"] not in (0, 1, 2):
        bad.append(f"exit {res['code']}")
    if "out of memory (MemoryError)" in res["err"]:
        bad.append("MemoryError")
    if peak_limit_mib is not None and res.get("peak_mib", 0.0) > peak_limit_mib:
        bad.append(f"peak {res['peak_mib']:.0f} MiB over {peak_limit_mib:.0f}")
    if wrote_outside:
        bad.append("wrote outside --out")
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


OUTPUT_OPTIONS = ("--out", "--plot", "--write")


def written_outside(args: list[str], before: list[str], after: list[str], folder=".") -> bool:
    """Whether a run in ``folder`` made an entry there other than what its output options
    name (``--out``, ``--plot``, ``--write``: their first path component inside it)."""
    named = {os.path.relpath(os.path.join(folder, v), folder).split(os.sep)[0]
             for o, v in zip(args, args[1:]) if o in OUTPUT_OPTIONS and v}
    return bool(set(after) - set(before) - named)


def run_fresh(args: list[str], cwd, *, address_limit: int | None = None, cpu_s: float = 120.0,
              env: dict | None = None) -> dict:
    """``python -m foldprint <args>`` in a fresh interpreter under an address-space limit
    (``address_limit`` bytes, RLIMIT_AS: an allocation past it is a MemoryError, as on a
    machine that small) and a CPU limit; the dict of ``tests/test_fuzz.py:run_case``
    (code, out, err, seconds, cpu_seconds, timeout, peak_mib: the child's max RSS).
    A fresh process, not a fork: the test process's own address space would count."""
    import resource
    import subprocess
    import sys
    import tempfile
    import time

    def limits():
        if address_limit:
            resource.setrlimit(resource.RLIMIT_AS, (address_limit, address_limit))
        resource.setrlimit(resource.RLIMIT_CPU, (int(cpu_s) + 1, int(cpu_s) + 2))

    t0 = time.monotonic()
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen([sys.executable, "-m", "foldprint", *args], stdout=out, stderr=err, cwd=cwd,
                             preexec_fn=limits, env=dict(os.environ, **(env or {})))
        while True:  # reaped here, not by Popen, to read the child's resource usage
            done, status, usage = os.wait4(p.pid, os.WNOHANG)
            if done:
                break
            if time.monotonic() - t0 > 5 * cpu_s:  # a sleeping hang: the CPU limit never fires
                p.kill()
            time.sleep(0.05)
        p.returncode = code = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        text_out, text_err = out.read().decode(errors="replace"), err.read().decode(errors="replace")
    cpu = usage.ru_utime + usage.ru_stime
    return {"code": code, "out": text_out, "err": text_err, "seconds": time.monotonic() - t0, "cpu_seconds": cpu,
            "timeout": code in (-9, -24) or cpu > cpu_s, "peak_mib": usage.ru_maxrss / 1024}


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
