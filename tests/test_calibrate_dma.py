"""``foldprint calibrate`` on DMA rows (storage, loss, tan_delta, relaxation): a synthetic
sweep drawn from a known viscoelastic model is fitted back, its Tg is the 1 Hz tan-delta
peak, the written file loads back, and bad cells are refused in one line."""

from __future__ import annotations

import json
import time
import tomllib
from dataclasses import replace

import numpy as np
import pytest

from foldprint.apps import calibrate as cal
from foldprint.cli.commands import main
from foldprint.core import guards
from foldprint.core.errors import DataError
from foldprint.io.hinge_data import parse_hinge_data
from foldprint.model.materials import default_library, load_library
from foldprint.physics.calibration.dma import dma_problems, peak_log10_tau
from foldprint.physics.viscoelastic import Viscoelastic

LIB = default_library()
#: The known model the synthetic sweeps are drawn from: not a library grade (moduli of a
#: printed acrylate SMP; shift and width inside calibrate's boxes, off their starts).
TRUE = {"tg_c": 47.0, "glassy_mpa": 1500.0, "rubbery_mpa": 4.0, "c1": 12.0, "c2": 40.0,
        "spectrum_sigma_decades": 1.4}


def true_model(**over) -> Viscoelastic:
    t = {**TRUE, **over}
    rec = replace(LIB["H-1"].recovery, c1=t["c1"], c2=t["c2"], spectrum_sigma_decades=t["spectrum_sigma_decades"])
    tau = peak_log10_tau(t["spectrum_sigma_decades"], rec.spectrum_span_decades, rec.n_branches,
                         t["rubbery_mpa"] / t["glassy_mpa"])
    return Viscoelastic(t["tg_c"], t["glassy_mpa"], t["rubbery_mpa"], replace(rec, log10_tau_ref_s=tau))


def sweep_csv(ve: Viscoelastic, seed: int, noise: float = 0.03, name: str = "MyResin",
              temps=np.arange(15.0, 86.0, 2.0)) -> str:
    """E' and E'' at 1 Hz every 2 C, log-normal noise of ``noise``, sigma stated."""
    rng = np.random.default_rng(seed)
    e1, e2 = ve.dynamic_mpa(1.0, temps)
    rows = ["kind,material,temperature_c,frequency_hz,value,sigma,source"]
    for t, a, b in zip(temps, e1, e2):
        rows.append(f"storage,{name},{t:g},1,{a * np.exp(noise * rng.standard_normal()):.7g},{noise},synthetic")
        rows.append(f"loss,{name},{t:g},1,{b * np.exp(noise * rng.standard_normal()):.7g},{noise},synthetic")
    return "\n".join(rows) + "\n"


def scan_peak(ve: Viscoelastic, lo: float, hi: float) -> float:
    """The 1 Hz tan-delta peak by brute force on a 0.005 C grid (independent of the fit's search)."""
    temps = np.arange(lo, hi, 0.005)
    return float(temps[np.argmax(ve.tan_delta(1.0, temps))])


def test_the_spectrum_centre_puts_the_1hz_peak_at_the_reference_temperature():
    """For several widths and modulus ratios, the derived log10_tau_ref_s puts the model's
    1 Hz tan-delta peak at its reference temperature (a_T = 1) within the scan's grid; the
    shipped library's H-1 (not built that way) peaks well above its tg_c."""
    for sigma, ratio in ((0.6, 1e-3), (1.4, 4 / 1500), (2.5, 0.05)):
        ve = true_model(spectrum_sigma_decades=sigma, rubbery_mpa=ratio * 1500.0)
        assert abs(scan_peak(ve, 20.0, 80.0) - 47.0) <= 0.01, (sigma, ratio)
    h1 = LIB["H-1"]
    lib_ve = Viscoelastic(h1.tg_c, 1500.0, 4.0, h1.recovery)
    assert scan_peak(lib_ve, h1.tg_c - 20.0, h1.tg_c + 60.0) > h1.tg_c + 5.0


def test_a_dma_only_sweep_calibrates_to_its_tan_delta_peak_and_its_parameters():
    """A 1 Hz sweep 2 C apart, 3 % noise, 4 seeds: Tg within 3 C of the data's tan-delta
    peak and within 0.3 C of the truth; the model's own 1 Hz peak (scanned) is the written
    Tg; every interval closed; the true parameters inside their 95 % profile intervals in
    at least 21 of 24 cases (6 parameters x 4 seeds; 95 % intervals miss 1 in 20), the
    others within twice the interval's half width; chi2 near its degrees of freedom."""
    truth = {**TRUE, "log10_glassy_mpa": np.log10(TRUE["glassy_mpa"]),
             "log10_rubbery_mpa": np.log10(TRUE["rubbery_mpa"])}
    covered, cases = 0, 0
    for seed in range(4):
        data = parse_hinge_data(sweep_csv(true_model(), seed), "syn.csv")
        c = cal.calibrate(data, LIB)
        assert c.problem is None and len(c.dma) == 1
        d = c.dma[0]
        mat = d.material
        assert abs(mat.tg_c - d.data_peak_c) <= 3.0
        assert abs(mat.tg_c - TRUE["tg_c"]) <= 0.3
        assert abs(scan_peak(d.problem.model(d.fit.x), 20.0, 80.0) - mat.tg_c) <= 0.01
        assert abs(d.model_peak_c - mat.tg_c) <= 0.01
        for p, iv in zip(d.problem.params, d.intervals):
            assert iv.identified == "yes", (seed, p.name, iv)
            cases += 1
            covered += iv.low <= truth[p.name] <= iv.high
            assert abs(truth[p.name] - iv.value) <= (iv.high - iv.low), (seed, p.name, truth[p.name], iv)
        assert abs(d.fit.chi2 - d.fit.dof) < 4 * np.sqrt(2 * d.fit.dof)
        assert mat.glassy_mpa == pytest.approx(1500.0, rel=0.05) and mat.rubbery_mpa == pytest.approx(4.0, rel=0.05)
    assert cases == 24 and covered >= 21, covered


def test_the_written_file_loads_back_with_the_dma_model_and_the_library_unchanged(tmp_path):
    """Round trip: the file's MyResin gives the fitted model's E', E'' and tan delta (to the
    7 digits written), carries its moduli beside tg_c, is its own colour and not a blend;
    every library grade loads exactly as the library's."""
    data_path = tmp_path / "dma.csv"
    data_path.write_text(sweep_csv(true_model(), 3))
    c = cal.run(data_path, LIB, with_profile=False)
    assert not [f for f in c.findings if f["code"] == "tg_row"]
    out = tmp_path / "mine.toml"
    cal.write(c, out, data_path, "test")
    raw = tomllib.loads(out.read_text())["materials"]["MyResin"]
    assert {"tg_c", "glassy_mpa", "rubbery_mpa"} <= set(raw) and raw["blend"] is False
    lib = load_library(out)
    got, fitted = lib["MyResin"], c.dma[0].material
    assert got.tg_c == pytest.approx(fitted.tg_c, rel=1e-6)
    ve_got = Viscoelastic(got.tg_c, got.glassy_mpa, got.rubbery_mpa, got.recovery)
    ve_fit = c.dma[0].problem.model(c.dma[0].fit.x)
    temps = np.arange(15.0, 86.0, 0.5)
    for a, b in zip(ve_got.dynamic_mpa(1.0, temps), ve_fit.dynamic_mpa(1.0, temps)):
        np.testing.assert_allclose(a, b, rtol=1e-4)
    assert got.color not in {m.color for m in LIB.materials}
    for m in LIB.hinges():
        assert lib[m.name] == m, m.name
    assert [ch["material"] for ch in cal.changes(c)] == ["MyResin"]


def test_simulate_runs_a_design_of_the_dma_material(tmp_path, capsys):
    """``calibrate --json --plot`` on a DMA-only sweep, then ``simulate`` folds a helix whose
    nine hinges are the DMA-calibrated resin (exit 0)."""
    from pathlib import Path

    data_path = tmp_path / "dma.csv"
    data_path.write_text(sweep_csv(true_model(), 4))
    mats = tmp_path / "mine.toml"
    png = tmp_path / "fit.png"
    assert main(["calibrate", str(data_path), "--no-profile", "--out", str(mats), "--json", "--plot", str(png)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fit"] is None and [d["material"] for d in out["dma"]] == ["MyResin"]
    assert abs(out["dma"][0]["tg_c"] - TRUE["tg_c"]) < 0.5 and png.stat().st_size > 1000
    design = tmp_path / "helix.toml"
    tpl = Path(__file__).resolve().parents[1] / "templates" / "helix_uniform.toml"
    design.write_text(tpl.read_text().replace('"H-3"', '"MyResin"'))
    assert main(["simulate", str(design), "--materials", str(mats)]) == 0


def test_recovery_rows_beside_dma_fit_the_heat_transfer_and_keep_the_dma_model():
    """DMA and three ratio rows of one material: the recovery fit frees the heat transfer
    only (the shift and spectrum are the DMA's), and the file's material has both."""
    from foldprint.physics.recovery.curve import recovery_curve

    ve = true_model()
    mat = replace(LIB["H-1"], name="MyResin", tg_c=ve.tg_c, recovery=replace(ve.params, h_w_m2k=400.0))
    curve = recovery_curve(mat, 70.0, 0.8, 10.0)
    ratio = "".join(f"ratio,MyResin,,,{t:g},{float(curve(t)):.5f},0.02,70\n" for t in (0.5, 1.0, 1.5, 2.5))
    head, *rows = sweep_csv(ve, 5).splitlines()
    dma = ["{},{},{},{},,{},{},".format(*r.split(",")[:6]) for r in rows]  # no source; time_s, bath_c blank
    text = "kind,material,temperature_c,frequency_hz,time_s,value,sigma,bath_c\n" + "\n".join(dma) + "\n" + ratio
    text += "tg,MyResin,,,,45.0,,\n"
    c = cal.calibrate(parse_hinge_data(text, "both.csv"), LIB, with_profile=False)
    assert [f["message"][:40] for f in c.findings if f["code"] == "tg_row"] == \
        ["MyResin: its tg row (45 C) is not fitted"]
    assert [p.name for p in c.problem.params] == ["h_w_m2k"]
    assert c.held_values() == {}  # the holds (universal WLF, ...) do not apply to a DMA-measured material
    assert c.fit.x[0] == pytest.approx(400.0, rel=0.15)
    written = {e.material.name: e.material for e in cal.entries(c)}["MyResin"]
    assert written.recovery.c1 == c.dma[0].material.recovery.c1
    assert written.recovery.h_w_m2k == pytest.approx(c.fit.x[0])


HEAD = "kind,material,temperature_c,frequency_hz,time_s,value,sigma\n"
BAD = {
    "temperature not a number": ("storage,R,forty,1,,1500,", "line 2, column temperature_c (storage row): must be a"),
    "temperature nan": ("loss,R,nan,1,,10,", "column temperature_c (loss row): must be a finite number in [-100, 500]"),
    "frequency zero": ("storage,R,40,0,,1500,", "column frequency_hz (storage row): must be in (0, 1e+06] Hz"),
    "modulus negative": ("storage,R,40,1,,-3,", "column value (storage row): must be in (0, 1e+07] MPa"),
    "modulus in Pa": ("storage,R,40,1,,1.5e9,", "column value (storage row): must be in (0, 1e+07] MPa"),
    "tan delta inf": ("tan_delta,R,40,1,,inf,", "column value (tan_delta row): must be a finite number"),
    "relaxation without time": ("relaxation,R,40,,,300,", "column time_s (relaxation row): is blank"),
    "relaxation with frequency": ("relaxation,R,40,1,10,300,", "column frequency_hz (relaxation row): means nothing"),
    "sigma zero": ("storage,R,40,1,,1500,0", "column sigma (storage row): must be in [0.0001, 2] (relative)"),
    "fullwidth digits": ("storage,R,４０,1,,1500,", "column temperature_c (storage row): must be a"),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_dma_cells_are_refused_naming_line_column_and_range(name):
    row, needle = BAD[name]
    with pytest.raises(DataError) as ei:
        parse_hinge_data(HEAD + row + "\n", "bad.csv")
    msg = str(ei.value)
    assert msg.startswith("bad.csv: ") and needle in msg and "\n" not in msg, msg


def test_cli_refuses_a_bad_dma_cell_in_one_line_and_writes_nothing(tmp_path, capsys):
    f = tmp_path / "bad.csv"
    f.write_text(HEAD + "storage,R,40,1,,1500,\nloss,R,40,1,,-1,\n")
    out = tmp_path / "never.toml"
    assert main(["calibrate", str(f), "--out", str(out)]) == 2
    _, err = capsys.readouterr()
    assert err.count("\n") == 1 and "line 3, column value (loss row)" in err and not out.exists()


@pytest.mark.usefixtures("guard_defaults")
def test_the_dma_estimate_bounds_a_measured_fit_and_refuses_over_the_budget():
    """The estimate is above the CPU a 72-row fit takes (no profile) and within 30x of it;
    a budget below it is refused before the first evaluation."""
    from foldprint.physics.calibration import dma as dma_mod
    from foldprint.physics.calibration.fit_cost import dma_estimate

    data = parse_hinge_data(sweep_csv(true_model(), 6), "syn.csv")
    pb = dma_problems(data, LIB)[0]
    est = dma_estimate(pb, pb.config.starts, with_profile=False)
    t0 = time.process_time()
    cal.calibrate(data, LIB, with_profile=False)
    cpu = time.process_time() - t0
    assert cpu <= est["seconds"] <= 30 * cpu, (cpu, est)
    guards.set_time_budget(est["seconds"] / 2)
    real = dma_mod.DmaProblem.predict
    dma_mod.DmaProblem.predict = lambda *a: (_ for _ in ()).throw(AssertionError("evaluated despite the refusal"))
    try:
        with pytest.raises(guards.ResourceError, match=r"syn.csv: calibrate refused: 72 DMA rows of 1 materials"):
            cal.calibrate(data, LIB, with_profile=False)
    finally:
        dma_mod.DmaProblem.predict = real


def test_dynamic_moduli_stay_finite_deep_in_the_glass_and_the_rubber():
    """A steep shift 250 K below Tg puts (w tau)^2 past 1e308: E' is still the glassy
    modulus and E'' a finite non-negative number; far above Tg E' is the rubbery modulus."""
    ve = true_model(c1=20.0, c2=15.0)
    e1, e2 = ve.dynamic_mpa(1.0, np.array([ve.tg_c - 250.0, ve.tg_c + 250.0]))
    assert np.all(np.isfinite(e1)) and np.all(np.isfinite(e2)) and np.all(e2 >= 0.0)
    assert e1[0] == pytest.approx(TRUE["glassy_mpa"]) and e1[1] == pytest.approx(TRUE["rubbery_mpa"])


@pytest.mark.parametrize("table, needle", [
    ("glassy_mpa = 4.0\nrubbery_mpa = 1500.0", "glassy_mpa: must exceed rubbery_mpa (1500 MPa)"),
    ("glassy_mpa = -1.0", "glassy_mpa: must be"),
    ("rubbery_mpa = nan", "rubbery_mpa: must be"),
])
def test_a_materials_file_with_bad_moduli_is_refused_naming_the_field(tmp_path, table, needle):
    from foldprint.core.errors import MaterialError

    f = tmp_path / "m.toml"
    f.write_text(f"[materials.H-1]\n{table}\n")
    with pytest.raises(MaterialError) as ei:
        load_library(f)
    assert needle in str(ei.value) and "materials.H-1" in str(ei.value), str(ei.value)
