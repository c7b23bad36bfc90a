"""``foldprint calibrate``: the CSV reader and its errors, the fit (recovery from synthetic
curves with known parameters: the reported intervals cover the truth), the observation
model (angles, inequalities), the materials file it writes (a round trip through the
library loader), the command line, and the paper's data (docs/calibrate.md)."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from foldprint.apps import calibrate as cal
from foldprint.cli.commands import main
from foldprint.core.errors import DataError
from foldprint.io.hinge_data import load_hinge_data, parse_hinge_data
from foldprint.model.materials import default_library, load_library
from foldprint.physics.calibration.fit import Problem, fit, holds, settings
from foldprint.physics.calibration.profile import findings, profile
from foldprint.physics.recovery.curve import recovery_curve

DATA = Path(__file__).resolve().parent.parent / "foldprint" / "data"
#: Parameters the synthetic curves are drawn from (inside every bound, away from them).
TRUTH = dict(h_w_m2k=420.0, c1=12.0, c2=45.0, log10_tau_ref_s=1.2, spectrum_sigma_decades=0.8,
             spectrum_span_decades=8.0)
HEADER = "kind,material,reference,bath_c,thickness_mm,time_s,level,value,relation,sigma,printed_deg,source"


def synthetic(seed: int, sigma: float = 0.02, kind: str = "ratio", fixity: float = 1.0,
              conditions=((75.0, 0.8), (90.0, 1.4)), materials=("H-2", "H-6")):
    """Noisy R(t) (or angle) rows of the model at :data:`TRUTH` (seeded)."""
    rng = np.random.default_rng(seed)
    lib = default_library()
    rows = [HEADER]
    for name in materials:
        m = replace(lib[name], recovery=replace(lib[name].recovery, **TRUTH))
        for bath, th in conditions:
            c = recovery_curve(m, bath, th, horizon_s=30.0)
            for t in np.linspace(0.5, 10.0, 10):
                r = float(c(t)) + rng.normal(0, sigma)
                if kind == "ratio":
                    rows.append(f"ratio,{name},,{bath},{th},{t:.4f},,{r:.9f},,{sigma},,")
                else:  # the angle between the panels of a hinge printed at 90 deg (Eq. 1 with fixity)
                    theta = 180.0 - 90.0 * (1.0 - fixity * (1.0 - r))
                    rows.append(f"angle,{name},,{bath},{th},{t:.4f},,{theta:.9f},,{90 * fixity * sigma},90,")
    if kind == "angle":
        rows += [f"fixity,{name},,,,,,{fixity},,,,measured" for name in materials]
    return parse_hinge_data("\n".join(rows), f"synthetic seed {seed}")


FREE = ("h_w_m2k", "c1", "log10_tau_ref_s")
HELD = {k: TRUTH[k] for k in ("c2", "spectrum_sigma_decades", "spectrum_span_decades")}


def test_synthetic_curves_are_fitted_back_inside_the_reported_intervals():
    """Validation, not calibration: curves drawn from the model at known parameters with 2 %
    noise (4 seeds, 3 free parameters) are fitted back. The 95 % profile intervals cover the
    truth in 11 of the 12 cases (seed 1's h_w_m2k misses: its draw puts the truth at
    delta chi2 = 6.6; a 95 % interval misses 1 in 20), every interval is closed and
    informative (under a quarter of the box) and chi2 is near its degrees of freedom (the
    stated noise is the noise)."""
    lib = default_library()
    covered = []
    for seed in range(4):
        pb = Problem(synthetic(seed), lib, free=FREE, fixed=HELD)
        f = fit(pb)
        assert f.success and f.rank == 3
        assert 0.4 * f.dof < f.chi2 < 1.6 * f.dof, (seed, f.chi2, f.dof)
        for iv in profile(pb, f):
            b = settings().bounds[iv.label]
            covered.append(iv.low <= TRUTH[iv.label] <= iv.high)
            assert not (iv.open_low or iv.open_high) and iv.identified == "yes", (seed, iv)
            assert iv.high - iv.low < 0.25 * (b.upper - b.lower), (seed, iv)
    assert sum(covered) >= len(covered) - 1, covered


def test_angle_rows_carry_the_fixity_and_give_the_ratio_fit():
    """Angles measured between the panels (paper Eq. 1 with a fixity below 1: a 90 deg
    hinge at fixity 0.9 starts 9 deg off flat) carry the same information as the ratio: the
    angle rows of the same draw, converted with the measured fixity, give the ratio fit."""
    lib = default_library()
    a = fit(Problem(synthetic(7, kind="angle", fixity=0.9), lib, free=FREE, fixed=HELD))
    r = fit(Problem(synthetic(7), lib, free=FREE, fixed=HELD))
    np.testing.assert_allclose(a.x, r.x, rtol=1e-3)
    assert a.chi2 == pytest.approx(r.chi2, rel=1e-3)
    pb = Problem(synthetic(7, kind="angle", fixity=0.9), lib, free=FREE, fixed=HELD)
    assert pb.fixity["H-2"] == 0.9
    row = replace(pb.data.observations[0], time_s=0.0)
    assert pb.predict_row(row, pb.curves(a.x)) == pytest.approx(180.0 - 90.0 * (1 - 0.9), abs=1e-9)


def test_an_inequality_counts_only_on_its_wrong_side():
    text = "\n".join([HEADER, "time_to,H-7,,90,0.8,,0.05,3.0,at_least,0.5,,", "time_to,H-1,,90,0.8,,0.05,1.0,at_most,0.5,,",
                      "time_to,H-1,,90,0.8,,0.98,3.0,about,0.5,,"])
    pb = Problem(parse_hinge_data(text, "t.csv"), default_library())
    pred = pb.predict(pb.library_point())
    r = pb.residuals_of(pred)
    onset7, onset1, fold1 = pred
    assert r[0] == (0.0 if onset7 >= 3.0 else pytest.approx((onset7 - 3.0) / 0.5))
    assert r[1] == (0.0 if onset1 <= 1.0 else pytest.approx((onset1 - 1.0) / 0.5))
    assert r[2] == pytest.approx((fold1 - 3.0) / 0.5)
    c = recovery_curve(default_library()["H-1"], 90.0)  # the library's own curve: an independent path
    assert onset1 == pytest.approx(c.onset_time, abs=1e-9) and fold1 == pytest.approx(c.fold_time, abs=1e-9)
    late = pb.residuals_of(pred + np.array([-1.0, 1.0, 0.0]))  # push both inequalities to their wrong side
    assert late[0] < 0 and late[1] > 0


def test_written_file_loads_as_a_library_with_the_fitted_values(tmp_path):
    """Round trip: the materials file calibrate writes loads with --materials and gives
    the fitted parameters, measured Tg and fixity; unmeasured hinge grades keep the
    library's values; its curves are the fit's (same model, same grid)."""
    lib = default_library()
    data = synthetic(3, kind="angle", fixity=0.98)
    c = cal.calibrate(data, lib, fixed=HELD, with_profile=False)
    out = tmp_path / "fitted.toml"
    csv = tmp_path / "d.csv"
    csv.write_text("x")
    cal.write(c, out, csv, "foldprint calibrate d.csv")
    got = load_library(out)
    fitted = dict(zip([p.name for p in c.problem.params], c.fit.x))
    for name in ("H-2", "H-6"):
        rec = got[name].recovery
        for k, v in {**fitted, **HELD}.items():
            assert getattr(rec, k) == pytest.approx(v, rel=1e-6), (name, k)
    assert got["H-4"] == lib["H-4"] and got["H-4"].recovery.h_w_m2k != pytest.approx(fitted["h_w_m2k"])
    assert got["H-2"].fixity == 0.98 and got["H-2"].fixity_source == "measured"
    assert got["H-4"].fixity is None and got["H-1"].tg_c == lib["H-1"].tg_c
    r_fit = c.problem.curves(c.fit.x)[("H-6", 90.0, 1.4, 10.0)]
    r_lib = recovery_curve(got["H-6"], 90.0, 1.4)(c.problem.t)
    assert np.max(np.abs(r_fit - r_lib)) < 1e-5


def test_a_new_material_needs_its_tg_and_gets_it_written(tmp_path):
    lib = default_library()
    rows = synthetic(1, materials=("H-3",)).observations
    text = "\n".join([HEADER] + [f"ratio,MyResin,,{o.bath_c},{o.thickness_mm},{o.time_s},,{o.value},,0.02,,"
                                 for o in rows])
    with pytest.raises(DataError, match=r"line 2: material 'MyResin' is not in the library.*tg row"):
        cal.calibrate(parse_hinge_data(text, "m.csv"), lib, with_profile=False)
    text += "\ntg,MyResin,,,,,,43.0,,,,DMA"
    c = cal.calibrate(parse_hinge_data(text, "m.csv"), lib, fixed=HELD, with_profile=False)
    out = tmp_path / "m.toml"
    cal.write(c, out, DATA / "paper_hinge_data.csv", "test")
    m = load_library(out)["MyResin"]
    assert m.role == "hinge" and m.tg_c == 43.0 and m.recovery.h_w_m2k == pytest.approx(c.fit.x[0], rel=1e-6)


BAD = {
    "unknown column": ("kind,material,value,colour\n", "line 1, column 4: unknown column 'colour'"),
    "no value column": ("kind,material\nratio,H-1\n", "line 1: the header has no 'value' column"),
    "bad kind": (HEADER + "\nratios,H-1,,90,0.8,1,,0.5,,,,\n", "line 2, column kind: 'ratios' is not a kind"),
    "blank needed": (HEADER + "\nratio,H-1,,90,0.8,,,0.5,,,,\n", "line 2, column time_s (ratio row): is blank"),
    "not a number": (HEADER + "\n# a comment\nratio,H-1,,ninety,0.8,1,,0.5,,,,\n",
                     "line 3, column bath_c (ratio row): must be a number"),
    "nan": (HEADER + "\nratio,H-1,,nan,0.8,1,,0.5,,,,\n", "column bath_c (ratio row): must be a finite number"),
    "ratio range": (HEADER + "\nratio,H-1,,90,0.8,1,,7,,,,\n", "line 2, column value (ratio row): must be in"),
    "unused cell": (HEADER + "\ntg,H-1,,90,,,,32,,,,\n", "line 2, column bath_c (tg row): means nothing"),
    "too many cells": (HEADER + "\nratio,H-1,,90,0.8,1,,0.5,,,,,x,y\n", "line 2: 14 cells for 12 columns"),
    "bad relation": (HEADER + "\ntime_to,H-1,,90,0.8,,0.98,3,roughly,,,\n", "column relation (time_to row)"),
    "same reference": (HEADER + "\nspread,H-1,H-1,90,0.8,,0.98,3,,,,\n", "column reference (spread row)"),
    "level 1": (HEADER + "\ntime_to,H-1,,90,0.8,,1.0,3,,,,\n", "column level (time_to row): must be below 1"),
    "negative sigma": (HEADER + "\nratio,H-1,,90,0.8,1,,0.5,,-1,,\n", "column sigma (ratio row)"),
    "only properties": (HEADER + "\ntg,H-1,,,,,,32,,,,\n", "no ratio, angle, time_to or spread rows"),
    "empty": ("# nothing\n", "empty"),
    "sigma 5e-324": (HEADER + "\nratio,H-1,,90,0.8,1,,0.5,,5e-324,,\n", "column sigma (ratio row): must be in [1e-06, 1.5]"),
    "sigma 1e-300": (HEADER + "\nangle,H-1,,90,0.8,1,,120,,1e-300,,\n", "column sigma (angle row): must be in [0.0001, 225]"),
    "sigma 1e308": (HEADER + "\ntime_to,H-1,,90,0.8,,0.98,3,,1e308,,\n", "column sigma (time_to row): must be in"),
    "fullwidth digits": (HEADER + "\nratio,H-1,,\uff19\uff10,0.8,1,,0.5,,,,\n",
                         "column bath_c (ratio row): must be a number in [-100, 500] deg C, written in ASCII"),
    "Arabic-Indic digit": (HEADER + "\nratio,H-1,,90,0.8,\u0663,,0.5,,,,\n", "column time_s (ratio row): must be a number"),
    "underscore": (HEADER + "\nratio,H-1,,90,0.8,1_0,,0.5,,,,\n", "column time_s (ratio row): must be a number"),
    "inf": (HEADER + "\nratio,H-1,,90,0.8,inf,,0.5,,,,\n", "column time_s (ratio row): must be a finite number"),
    "line break in quotes": (HEADER + '\nratio,H-1,,90,0.8,1,,0.5,,,,"a\nb"\n',
                             "line 2: a quoted cell runs past the end of its line (to line 3)"),
    "form feed in quotes": (HEADER + '\nratio,H-1,,90,0.8,1,,0.5,,,,"a\x0cb"\n',
                            "line 2, column source: holds the control character '\\x0c'"),
    "unterminated quote": (HEADER + '\nratio,H-1,,90,0.8,1,,0.5,,,,"ab\n', "line 2: a quoted cell is not closed"),
    "tab in a name": (HEADER + "\nratio,H\t1,,90,0.8,1,,0.5,,,,\n", "column material: holds the control character"),
    "NUL in a name": (HEADER + "\nratio,H\x001,,90,0.8,1,,0.5,,,,\n", "column material: holds the control character"),
    "long name": (HEADER + "\nratio," + "M" * 101 + ",,90,0.8,1,,0.5,,,,\n",
                  "column material (ratio row): is 101 characters long; a name is 1 to 100 characters"),
    "long reference": (HEADER + "\nspread,H-1," + "R" * 300 + ",90,0.8,,0.98,3,,,,\n",
                       "column reference (spread row): is 300 characters long"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_data_names_file_line_and_column(tmp_path, name):
    text, needle = BAD[name]
    f = tmp_path / "bad.csv"
    f.write_text(text)
    with pytest.raises(DataError) as ei:
        load_hinge_data(f)
    assert str(ei.value).startswith(f"{f}: ") and needle in str(ei.value), str(ei.value)


def test_cli_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    f = tmp_path / "bad.csv"
    f.write_text(BAD["not a number"][0])
    out = tmp_path / "never.toml"
    code = main(["calibrate", str(f), "--out", str(out), "--no-profile"])
    _, err = capsys.readouterr()
    assert code == 2 and not out.exists()
    assert err.count("\n") == 1 and "line 3, column bath_c" in err and "Traceback" not in err
    for args, needle in ((["calibrate", str(tmp_path / "missing.csv")], "file not found"),
                         (["calibrate", str(tmp_path)], "not a regular file"),
                         (["calibrate", str(DATA / "paper_hinge_data.csv"), "--fix", "c9"], "'c9' is not a recovery"),
                         (["calibrate", str(DATA / "paper_hinge_data.csv"), "--fix", "c1=abc"],
                          "--fix c1: must be a finite number in [0.1, 100]"),
                         (["calibrate", str(DATA / "paper_hinge_data.csv"), "--fit", "c9"], "'c9': not a recovery"),
                         (["calibrate", str(DATA / "paper_hinge_data.csv"), "--fit", "c1", "--fix", "c1=3"],
                          "--fit c1 and --fix c1: a parameter is either fitted or held"),
                         (["calibrate", str(DATA / "paper_hinge_data.csv"), "--per-material", "c2"],
                          "c2 is held, not fitted; add --fit c2")):
        code = main(args)
        _, err = capsys.readouterr()
        assert code == 2 and needle in err and err.count("\n") == 1, (args, err)


def test_crlf_a_bom_and_quoted_commas_are_read():
    """What a spreadsheet writes is not refused: CRLF line ends, a BOM (read_text), a quoted
    source with commas and doubled quotes."""
    text = (HEADER + '\nratio,H-1,,90,0.8,1,,0.5,,,,"Fig. 2, ""left"""\n').replace("\n", "\r\n")
    d = parse_hinge_data(text, "x.csv")
    assert d.observations[0].source == 'Fig. 2, "left"' and d.observations[0].time_s == 1.0


@pytest.mark.parametrize("item, needle", [
    ("h_w_m2k=inf", "--fix h_w_m2k: must be a finite number in [0.1, 1e+06] W/m^2/K"),
    ("c1=nan", "--fix c1: must be a finite number in [0.1, 100]"),
    ("log10_tau_ref_s=-inf", "--fix log10_tau_ref_s: must be a finite number in [-12, 12]"),
    ("c2=0", "--fix c2: must be a finite number in [1, 1000] K (WLF C2 of polymers is 20-200 K), got 0"),
    ("spectrum_sigma_decades=0", "--fix spectrum_sigma_decades: must be a finite number in [0.01, 20] decades"),
    ("spectrum_sigma_decades=1e308", "got 1e+308"),
    ("spectrum_sigma_decades=-1", "got -1"),
    ("c2=\uff15\uff10", "written in ASCII digits"),
])
def test_fix_values_outside_what_a_materials_file_holds_are_refused(item, needle):
    with pytest.raises(DataError) as ei:
        cal.parse_fixed([item])
    assert needle in str(ei.value), str(ei.value)
    name, _, value = item.partition("=")
    if value not in ("inf", "nan", "-inf") and value.isascii():  # the Python API refuses the number too
        with pytest.raises(DataError, match=f"--fix {name}: must be"):
            holds({name: float(value)})


def test_a_held_value_at_the_edge_of_a_materials_file_range_is_used():
    """c2 = 1000 K is outside the fit's box (15-80 K) but a materials file may hold it."""
    assert cal.parse_fixed(["c2=1000", "c1"]) == {"c2": 1000.0, "c1": None}
    assert {h.name: h.value for h in holds({"c2": 1000.0})}["c2"] == 1000.0


def test_plot_formats_are_ones_matplotlib_writes():
    from matplotlib.backend_bases import FigureCanvasBase

    from foldprint.core.constants import PLOT_FORMATS

    assert set(PLOT_FORMATS) <= set(FigureCanvasBase.get_supported_filetypes())


@pytest.mark.parametrize("suffix", [".jpg", ".xyz", ".txt", ".raw", ".webp", ".pgf", ".tiff", ""])
def test_a_plot_format_we_do_not_write_is_refused_before_anything_is_written(tmp_path, capsys, suffix):
    out, fig = tmp_path / "m.toml", tmp_path / f"fit{suffix}"
    code = main(["calibrate", str(DATA / "paper_hinge_data.csv"), "--no-profile", "--out", str(out),
                 "--plot", str(fig)])
    _, err = capsys.readouterr()
    assert code == 2 and err.count("\n") == 1 and "must end in .png, .svg, .pdf" in err, err
    assert sorted(tmp_path.iterdir()) == []


def test_odd_but_valid_names_are_written_and_load_back(tmp_path):
    """Names the id rule allows (quotes, backslashes, dots, other scripts, 100 characters,
    a VeroWhite composition the library synthesises) are written as TOML keys every command
    loads back."""
    names = ['q"uote', "back\\slash", "a.b", "\u540d\u524d", "M" * 100, "VW0.620"]
    def q(n):
        return '"' + n.replace('"', '""') + '"'

    rows = [f"tg,{q(n)},,,,,,45,,,," for n in names]
    rows += [f"ratio,{q(n)},,80,0.8,{t},,{v},,,," for n in names for t, v in ((2, 0.2), (6, 0.8))]
    f = tmp_path / "odd.csv"
    f.write_text(HEADER + "\n" + "\n".join(rows) + "\n")
    result = cal.run(f, default_library(), with_profile=False)
    out = cal.write(result, tmp_path / "m.toml", f, "test")
    lib = load_library(out)
    assert all(n in lib and lib[n].tg_c == 45.0 for n in names)


def test_cli_json_out_and_plot(tmp_path, capsys):
    csv = tmp_path / "d.csv"
    rows = synthetic(2).observations
    csv.write_text("\n".join([HEADER] + [f"ratio,{o.material},,{o.bath_c},{o.thickness_mm},{o.time_s},,{o.value},,0.02,,"
                                         for o in rows]))
    out, png = tmp_path / "m.toml", tmp_path / "fit.png"
    code = main(["calibrate", str(csv), "--json", "--no-profile", "--out", str(out), "--plot", str(png), "--fit", "c1",
                 "--fix", "c2=45", "--fix", "spectrum_sigma_decades=0.8", "--fix", "spectrum_span_decades=8"])
    stdout, _ = capsys.readouterr()
    assert code == 0
    data = json.loads(stdout)
    assert {"data", "materials", "parameters", "fixed", "held", "fit", "uncertainty", "start", "curves", "rows",
            "findings", "fixity", "out", "plot"} <= set(data)
    assert data["uncertainty"] == "none" and data["fixed"]["c2"] == 45.0
    assert {p["name"] for p in data["parameters"]} == set(FREE)
    assert {h["name"]: (h["value"], h["source"]) for h in data["held"]} == {
        "c2": (45.0, "--fix"), "spectrum_sigma_decades": (0.8, "--fix"), "spectrum_span_decades": (8.0, "--fix")}
    assert len(data["fit"]["start_ends"]) == 1 + settings().starts and data["fit"]["chi2"] == min(data["fit"]["start_ends"])
    assert "--fit c1" in out.read_text().splitlines()[0]
    assert len(data["rows"]) == len(rows) and len(data["curves"]) == 4
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and load_library(out)["H-2"].recovery.c2 == 45.0
    code = main(["calibrate", str(csv), "--no-profile", "--per-material", "h_w_m2k", "--fix", "c1"])
    stdout, _ = capsys.readouterr()
    assert code == 0 and "h_w_m2k[H-2]" in stdout and "h_w_m2k[H-6]" in stdout


# -- what calibrate holds ------------------------------------------------------------------

def test_calibrate_holds_what_calibration_toml_holds_unless_told_to_fit_it():
    """data/calibration.toml holds c1 and c2 at the universal WLF values and the spectrum's
    span at our choice, each with its source; --fit frees one, --fix overrides the value;
    naming a parameter in both is refused."""
    hs = {h.name: h for h in holds()}
    assert {n: h.value for n, h in hs.items()} == {"c1": 17.44, "c2": 51.6, "spectrum_span_decades": 9.336}
    assert all("Williams, Landel & Ferry" in hs[n].source for n in ("c1", "c2"))
    assert hs["spectrum_span_decades"].source.startswith("our choice")
    hs = {h.name: h for h in holds({"c1": None, "c2": 40.0}, ("spectrum_span_decades",))}
    assert {n: (h.value, h.source) for n, h in hs.items()} == {"c1": (None, "--fix: the library's value"),
                                                              "c2": (40.0, "--fix")}
    with pytest.raises(DataError, match="either fitted or held"):
        holds({"c1": 3.0}, ("c1",))
    c = cal.calibrate(synthetic(5), default_library(), with_profile=False)
    assert [p.name for p in c.problem.params] == ["h_w_m2k", "log10_tau_ref_s", "spectrum_sigma_decades"]
    assert c.held_values()["c1"] == (17.44, settings().bounds["c1"].hold_source)
    assert c.problem.recovery(c.fit.x)["H-2"].c2 == 51.6


# -- the paper's data ----------------------------------------------------------------------

@pytest.fixture(scope="module")
def paper():
    return cal.calibrate(load_hinge_data(DATA / "paper_hinge_data.csv"), default_library(), with_profile=False)


def test_paper_data_rows_have_sources_and_the_fit_says_what_it_misses(paper):
    """With the holds, the paper's six rows fix the three free parameters (rank 3, 3 degrees
    of freedom), and calibrate names the row it misses beyond two sigma: Fig. 1b's 100 C
    spread (docs/recovery-model.md)."""
    data = paper.problem.data
    assert all(o.source for o in data.observations) and all(p.source for p in data.properties)
    assert {o.relation for o in data.observations} == {"about", "at_most", "at_least"}
    assert (paper.fit.rank, paper.fit.dof) == (3, 3)
    codes = [f["code"] for f in paper.findings]
    assert "underdetermined" not in codes and "rank" not in codes
    line = next(o.line for o in data.observations if o.kind == "spread" and o.bath_c == 100.0)
    missed = {f["line"]: f["message"] for f in paper.findings if f["code"] == "miss"}
    assert set(missed) == {line} and "spread of H-7 - H-1 at 100 C: measured 2 s" in missed[line]


def test_all_six_parameters_are_not_identified_by_the_paper_data():
    """Why calibrate holds three: fitted all together (one start, from the library), six
    rows fix fewer than six combinations of the six parameters (the Jacobian's rank)."""
    pb = Problem(load_hinge_data(DATA / "paper_hinge_data.csv"), default_library())
    f = fit(pb)
    assert len(pb.params) == 6 and f.dof == 0 and f.rank < 6
    assert {x["code"] for x in findings(pb, f, ())} >= {"underdetermined", "rank"}
