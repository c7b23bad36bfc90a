"""The one door for files (no input is opened twice or unbounded): every path foldprint reads -- design files of
each kind and the option files ``--materials``, ``--printers``, ``--scatter`` -- is opened
once by :func:`foldprint.core.inputs.read_input`, refused when it is not a regular file
(FIFO, device, directory, socket) before a byte is read, read up to its size limit only,
and its values pass the same schema as a design's: exit 2 with one line naming the file
and the key, never a traceback, a hang or a warning."""

from __future__ import annotations

import os
import socket
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from foldprint.cli.commands import main
from foldprint.core import inputs
from foldprint.core.errors import DesignError, MaterialError
from foldprint.core.schema import TG_C, TEMPERATURE_C

FOLD = ('{"file_spec": 1.2, "frame_unit": "mm", "vertices_coords": [[0,0],[10,0],[10,6],[0,6],[20,0],[20,6]], '
        '"faces_vertices": [[0,1,2,3],[1,4,5,2]], "edges_vertices": [[1,2]], "edges_assignment": ["V"], '
        '"edges_foldAngle": [90]}')
DIGITS_401, DIGITS_5000 = "9" * 401, "9" * 5000
DEEP = "x = " + "[" * 2000 + "]" * 2000 + "\n"

# option: (the command line up to the option, [(case, file text, words the one line must hold)])
OPTION_CASES = {
    "--materials": (["materials", "--materials"], [
        ("tg_absolute_zero", '[materials.X]\nrole = "hinge"\ntg_c = -273.15\n', ["materials.X.tg_c", "[-100, 500]", "kelvin"]),
        ("tg_1e308", '[materials.X]\nrole = "hinge"\ntg_c = 1e308\n', ["materials.X.tg_c", "1e+308"]),
        ("tg_401_digits", f'[materials.X]\nrole = "hinge"\ntg_c = {DIGITS_401}\n', ["tg_c", "401 digits"]),
        ("tg_5000_digits", f'[materials.X]\nrole = "hinge"\ntg_c = {DIGITS_5000}\n', ["line 3", "5000+ digits"]),
        ("branches_401_digits", f'[materials.H-1.recovery]\nn_branches = {DIGITS_401}\n',
         ["materials.H-1.recovery.n_branches", "[1, 256]"]),
        ("c1_overflows", "[materials.H-1.recovery]\nc1 = 400.0\n", ["recovery.c1", "[0.1, 100]", "overflows"]),
        ("h_string", '[materials.H-1.recovery]\nh_w_m2k = "500"\n', ["h_w_m2k", "without quotes"]),
        ("deep", DEEP, ["line 1", "nested more than 32"]),
        ("description_table", '[materials.H-1]\ndescription = {a = 1}\n', ["materials.H-1.description", "a table"]),
    ]),
    "--printers": (["check", "helix_graded", "--samples", "0", "--printers"], [
        ("build_401_digits", f'[printers.p]\nbuild_mm = [{DIGITS_401}, 1, 1]\nmin_wall_mm = 1\nmin_gap_mm = 1\n',
         ["printers.p.build_mm[0]", "401 digits"]),
        ("build_inf", '[printers.p]\nbuild_mm = [inf, 1, 1]\nmin_wall_mm = 1\nmin_gap_mm = 1\n',
         ["printers.p.build_mm[0]", "finite"]),
        ("build_two", '[printers.p]\nbuild_mm = [1, 1]\nmin_wall_mm = 1\nmin_gap_mm = 1\n', ["build_mm", "three"]),
        ("wall_zero", '[printers.p]\nbuild_mm = [1, 1, 1]\nmin_wall_mm = 0\nmin_gap_mm = 1\n', ["min_wall_mm", "> 0"]),
        ("unknown_key", '[printers.p]\nbuild_mm = [1, 1, 1]\nmin_wall_mm = 1\nmin_gap_mm = 1\nwall = 3\n',
         ["printers.p", "unknown key", "wall"]),
        ("deep", DEEP, ["nested more than 32"]),
        ("printers_number", "printers = 5\n", ["printers", "must be a table"]),
    ]),
    "--scatter": (["check", "helix_graded", "--samples", "0", "--scatter"], [
        ("sd_5000_digits", f"[shared.bath]\nsd_c = {DIGITS_5000}\n", ["line 2", "5000+ digits"]),
        ("sd_401_digits", f"[shared.bath]\nsd_c = {DIGITS_401}\n", ["shared.bath.sd_c", "401 digits"]),
        ("sd_too_wide", "[hinge.tg]\nsd_c = 1e308\n", ["hinge.tg.sd_c", "[0, 10]"]),
        ("sigma_negative", "[hinge.heat_transfer]\nsigma_ln = -0.1\n", ["hinge.heat_transfer.sigma_ln", "[0, 1]"]),
        ("source_number", "[hinge.tg]\nsource = 5\n", ["hinge.tg.source", "string"]),
        ("deep", DEEP, ["nested more than 32"]),
    ]),
}


def _run(argv, capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy warning means a value went unchecked
        code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _one_line_exit_2(code, out, err, needles):
    assert code == 2, err
    assert out == "" and "Traceback" not in err and "Warning" not in err and err.count("\n") == 1, err
    for n in needles:
        assert n in err, (n, err)
    assert len(err) < 700, err


@pytest.mark.parametrize("option, case", [(o, c[0]) for o, (_, cases) in OPTION_CASES.items() for c in cases])
def test_option_file_values_pass_the_schema(tmp_path, capsys, option, case):
    argv, cases = OPTION_CASES[option]
    _, text, needles = next(c for c in cases if c[0] == case)
    f = tmp_path / "opt.toml"
    f.write_text(text)
    _one_line_exit_2(*_run(argv + [str(f)], capsys), [str(f)] + needles)


def _socket(p: Path) -> None:
    s = socket.socket(socket.AF_UNIX)
    s.bind(p.name)  # relative (the test runs in its folder): a socket path holds at most 108 bytes
    s.close()


NOT_FILES = {"fifo": (os.mkfifo, "a FIFO"), "dev_zero": (lambda p: p.symlink_to("/dev/zero"), "a character device"),
             "dev_urandom": (lambda p: p.symlink_to("/dev/urandom"), "a character device"),
             "directory": (Path.mkdir, "a directory"), "socket": (_socket, "not a regular file")}
READERS = {  # what reads the path: the command line around it, the file's suffix
    "design.toml": (["check", "{}", "--samples", "0"], ".toml"),
    "design.fold": (["check", "{}", "--samples", "0"], ".fold"),
    "design.svg": (["simulate", "{}"], ".svg"),
    "--materials": (["materials", "--materials", "{}"], ".toml"),
    "--printers": (["check", "helix_graded", "--samples", "0", "--printers", "{}"], ".toml"),
    "--scatter": (["robust", "helix_graded", "--samples", "1", "--scatter", "{}"], ".toml"),
}


@pytest.fixture
def deadline():
    """A blocked open (a FIFO without a writer) fails the test instead of hanging the suite."""
    import signal

    def boom(*_):
        raise AssertionError("blocked for 60 s")

    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(60)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


@pytest.mark.parametrize("reader", sorted(READERS))
@pytest.mark.parametrize("kind", sorted(NOT_FILES))
def test_what_is_not_a_regular_file_is_refused_before_reading(tmp_path, capsys, monkeypatch, deadline, reader, kind):
    """A FIFO blocked forever, /dev/zero was read to gigabytes: refused from fstat on the
    descriptor opened non-blocking, naming what it is."""
    monkeypatch.chdir(tmp_path)
    make, what = NOT_FILES[kind]
    argv, suffix = READERS[reader]
    p = tmp_path / f"input{suffix}"
    make(p)
    _one_line_exit_2(*_run([a.format(p) for a in argv], capsys), [str(p), what])


@pytest.mark.parametrize("argv", [
    ["check", "x" * 5000 + ".toml"],
    ["check", "x" * 5000],
    ["check", "a/" * 2100 + "d.fold"],
    ["materials", "--materials", "m" * 5000 + ".toml"],
    ["export", "helix_graded", "--out", "o" * 5000],
    ["export", "helix_graded", "--out", "a/" * 2000],
    ["export", "helix_graded", "--out", "b/" * 1000],
    ["simulate", "helix_graded", "--plot", "p/" * 1000],
    ["materials", "--plot", "x.exe"],
    ["materials", "--plot", "c" * 5000 + ".png"],
    ["materials", "--plot-model", "x.exe"],
], ids=lambda a: f"{a[0]} {a[-1][:12]}... ({len(a[-1])})")
def test_long_and_deep_paths_exit_2(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    code, out, err = _run(argv, capsys)
    _one_line_exit_2(code, out, err, [])
    assert "characters" in err or "x.exe" in err or "no such file" in err or "not found" in err, err
    assert os.listdir(tmp_path) == []


def test_read_input_reads_no_more_than_the_limit(tmp_path, monkeypatch):
    """A file that grows after fstat (or a file system that reports no size) is refused at
    the limit: the reader stops at limit + 1 bytes whatever fstat said."""
    f = tmp_path / "big.toml"
    f.write_bytes(b"#" * 5000)
    assert inputs.read_input(f, "x", limit=5000) == b"#" * 5000
    with pytest.raises(DesignError, match=r"file is 4.88 KiB; input files of at most 4.88 KiB"):
        inputs.read_input(f, "x", limit=4999)
    real = os.fstat
    monkeypatch.setattr(inputs.os, "fstat", lambda fd: os.stat_result((real(fd).st_mode,) + (0,) * 9))
    with pytest.raises(DesignError, match="holds more than"):
        inputs.read_input(f, "x", limit=4999)
    reads = []
    real_read = os.read
    monkeypatch.setattr(inputs.os, "read", lambda fd, n: reads.append(n) or real_read(fd, n))
    with pytest.raises(DesignError):
        inputs.read_input(f, "x", limit=100)
    assert sum(reads) <= 101


def test_read_input_errors_name_the_file_and_the_class(tmp_path):
    with pytest.raises(MaterialError, match=r"nope\.toml: file not found"):
        inputs.read_input(tmp_path / "nope.toml", "x", error=MaterialError)
    f = tmp_path / "latin1.toml"
    f.write_bytes(b"name = '\xe9'\n")
    with pytest.raises(DesignError, match="not a UTF-8 text file; expected a design"):
        inputs.read_input_text(f, "a design")
    f.write_text("x = [[[" + "]]]")
    assert inputs.read_toml(f, "x") == {"x": [[[]]]}
    locked = tmp_path / "locked.toml"
    locked.write_text("x = 1")
    locked.chmod(0)
    if os.geteuid() != 0:  # root reads anything
        with pytest.raises(DesignError, match="permission denied"):
            inputs.read_input(locked, "x")


def test_shown_shortens_long_paths():
    assert inputs.shown("a/b.toml") == "a/b.toml"
    s = inputs.shown("x" * 5000)
    assert len(s) < 250 and s.endswith("(5000 characters)")


def test_an_undecodable_file_name_names_the_design_with_a_replacement(tmp_path):
    from foldprint.io.load import load_design

    p = Path(os.fsdecode(bytes(tmp_path) + b"/n\xffm.fold"))
    p.write_text(FOLD)
    d = load_design(p)
    assert d.name == "n\ufffdm"
    d.name.encode("utf-8")


def test_a_lone_surrogate_in_a_fold_title_is_refused_by_every_command(tmp_path, capsys):
    f = tmp_path / "s.fold"
    f.write_text(FOLD.replace('"file_spec"', '"frame_title": "a\\ud800b", "file_spec"'))
    for argv in (["check", str(f), "--samples", "0"], ["export", str(f), "--out", str(tmp_path / "o")],
                 ["simulate", str(f)], ["robust", str(f), "--samples", "1"]):
        _one_line_exit_2(*_run(argv, capsys), ["frame_title", "lone surrogate"])
    assert not (tmp_path / "o").exists()


def test_names_the_system_gives_as_bytes_print_whatever_the_locale(tmp_path):
    """stdout strict (a UTF-8 locale that is not C): a folder name that is not UTF-8 is
    printed as its bytes, an error message escapes it; exit 0 and 2, never 3."""
    import subprocess
    import sys

    out = os.fsdecode(bytes(tmp_path) + b"/o\xff")
    env = dict(os.environ, PYTHONIOENCODING="utf-8:strict")
    r = subprocess.run([sys.executable, "-m", "foldprint", "export", "helix_graded", "--format", "stl", "--out", out],
                       capture_output=True, env=env)
    assert r.returncode == 0, r.stderr
    assert b"o\xff/helix_graded_H-1.stl" in r.stdout
    r = subprocess.run([sys.executable, "-m", "foldprint", "check", out + "/nope.toml"], capture_output=True, env=env)
    assert r.returncode == 2 and b"o\\udcff/nope.toml: file not found" in r.stderr, r.stderr


# -- the bounds keep the recovery model in floating point ------------------------------------

@settings(max_examples=40, deadline=None, database=None, derandomize=True)
@given(corner=hs.lists(hs.booleans(), min_size=13, max_size=13))
def test_recovery_model_at_the_corners_of_the_bounds_warns_nothing(corner):
    """Every material value at a bound, Tg and the bath at theirs, the thinnest and
    thickest hinge: the fold time is a number or None, never a warning or an error."""
    from foldprint.model.materials import RECOVERY_BOUNDS, default_library
    from foldprint.physics.recovery.curve import fold_time

    m = default_library()["H-3"]
    keys = sorted(RECOVERY_BOUNDS)
    rec = replace(m.recovery, **{k: RECOVERY_BOUNDS[k][1 if c else 0] for k, c in zip(keys, corner)})
    mat = replace(m, tg_c=TG_C[corner[10]], recovery=rec)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        ft = fold_time(mat, TEMPERATURE_C[corner[11]], 1e-3 if corner[12] else 1e4)
    assert ft is None or (np.isfinite(ft) and ft >= 0)


def test_samples_at_the_widest_scatter_stay_finite():
    """Every spread at its maximum, scaled by the largest --scales, baths at both ends of
    their range: the sampled recovery curves are finite, no warning."""
    from foldprint.io.load import load_design
    from foldprint.model.materials import default_library
    from foldprint.simulation.robust import sample_drives
    from foldprint.simulation.scatter import COMPONENTS, MAX_SCALE, SPREAD_MAX, Scatter, draw_samples

    d = load_design(Path(__file__).resolve().parents[1] / "templates" / "helix_graded.toml")
    sc = Scatter(**{c.attr: SPREAD_MAX[c.key][0] for c in COMPONENTS}).scaled(MAX_SCALE)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for bath in TEMPERATURE_C:
            dd = d.replace(process=replace(d.process, bath_temperature_c=bath))
            for drive in sample_drives(dd, default_library(), draw_samples(dd, sc, 8, 1)):
                assert all(np.isfinite(c.ratio).all() for c in drive.curves)
    with pytest.raises(DesignError, match=r"\[0, 5\]"):
        sc.scaled(MAX_SCALE + 1)


def test_an_output_folder_that_is_a_loop_of_links_exits_2(tmp_path, capsys, monkeypatch):
    """Found by the path fuzz: --out naming a link to itself was a RuntimeError (exit 3)."""
    monkeypatch.chdir(tmp_path)
    os.symlink("loop", "loop")
    for argv in (["export", "helix_graded", "--out", "loop"], ["simulate", "helix_graded", "--plot", "loop"]):
        _one_line_exit_2(*_run(argv, capsys), ["'loop'", "loop of symbolic links"])
