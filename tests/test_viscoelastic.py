"""The viscoelastic model's moduli against closed forms of a Prony solid."""

import math
from dataclasses import replace

import numpy as np
import pytest

from foldprint.core.errors import MaterialError
from foldprint.model.materials import default_library, load_library
from foldprint.physics.recovery.batch import grid_until, material_batch_ratios
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.physics.viscoelastic import Viscoelastic, log10_shift, shift_temperature, viscoelastic


def _model(n_branches=16):
    m = default_library()["H-4"]
    return Viscoelastic(m.tg_c, 1500.0, 5.0, replace(m.recovery, n_branches=n_branches))


def test_limits_are_the_plateaus():
    v = _model()
    assert v.relaxation_mpa(0.0, v.tg_c) == pytest.approx(1500.0, rel=1e-12)
    assert v.relaxation_mpa(1e12, v.tg_c) == pytest.approx(5.0, rel=1e-9)
    storage, loss = v.dynamic_mpa(1e12, v.tg_c)
    assert storage == pytest.approx(1500.0, rel=1e-6) and loss < 1e-3


def test_single_branch_loss_peaks_at_omega_tau_one():
    v = _model(n_branches=1)
    tau = 10.0 ** v.params.log10_tau_ref_s  # at Tg, a_T = 1
    f = np.geomspace(1e-3, 1e3, 2001) / (2 * math.pi * tau)
    storage, loss = v.dynamic_mpa(f, v.tg_c)
    k = int(np.argmax(loss))
    assert 2 * math.pi * f[k] * tau == pytest.approx(1.0, rel=0.01)
    assert loss[k] == pytest.approx((1500.0 - 5.0) / 2, rel=1e-4)
    assert storage[k] == pytest.approx(5.0 + (1500.0 - 5.0) / 2, rel=0.01)


def test_hotter_is_softer_and_shift_is_time():
    v = _model()
    temps = np.linspace(v.tg_c - 30, v.tg_c + 30, 61)
    e = v.relaxation_mpa(1.0, temps)
    assert np.all(np.diff(e) <= 1e-9)
    # time-temperature superposition: E(t, T) = E(t / a_T, Tg)
    t, temp = 3.0, v.tg_c + 7.0
    a = 10.0 ** float(v.log10_shift(temp))
    assert v.relaxation_mpa(t, temp) == pytest.approx(v.relaxation_mpa(t / a, v.tg_c), rel=1e-9)


def test_single_branch_tan_delta_peaks_where_the_closed_form_says():
    """One Debye branch: tan delta = (r - 1) w tau / (1 + r (w tau)^2), r = E_g / E_r, peaks
    at w tau a_T = 1 / sqrt(r); the model's peak temperature inverts the WLF shift there."""
    v = _model(n_branches=1)
    r = v.glassy_mpa / v.rubbery_mpa
    tau = 10.0 ** v.params.log10_tau_ref_s
    x = math.log10(1.0 / (math.sqrt(r) * 2 * math.pi * tau))
    assert v.peak_log10_shift == pytest.approx(x, abs=1e-7)
    p = v.params
    want = v.reference_c - x * p.c2 / (p.c1 + x)  # WLF inverted (x < 0: above T_ref)
    assert v.tan_delta_peak_c == pytest.approx(want, abs=1e-5)
    assert float(v.tan_delta(1.0, want)) == pytest.approx((r - 1) / (2 * math.sqrt(r)), rel=1e-9)


def test_tan_delta_peak_matches_a_fine_sweep_and_moves_with_the_reference():
    v = _model()
    T = np.arange(v.tg_c - 20, v.tg_c + 60, 0.002)
    assert v.tan_delta_peak_c == pytest.approx(T[np.argmax(v.tan_delta(1.0, T))], abs=0.002)
    # the shipped grades: the shift referenced at Tg, the model's 1 Hz peak above it
    assert v.reference_c == v.tg_c
    moved = Viscoelastic(v.tg_c, v.glassy_mpa, v.rubbery_mpa, replace(v.params, reference_below_tg_c=12.5))
    assert moved.reference_c == v.tg_c - 12.5
    assert moved.tan_delta_peak_c == pytest.approx(v.tan_delta_peak_c - 12.5, abs=1e-9)
    # a stiffer glass against the same rubber pushes the peak to higher temperature
    stiffer = Viscoelastic(v.tg_c, 10 * v.glassy_mpa, v.rubbery_mpa, v.params)
    assert stiffer.tan_delta_peak_c > v.tan_delta_peak_c + 1.0


@pytest.mark.parametrize("x", [-8.0, -1.5, 0.0, 0.7, 3.0])
def test_shift_temperature_inverts_the_shift(x):
    p = _model().params
    t = float(shift_temperature(40.0, x, p))
    assert float(log10_shift(t, 40.0, p)) == pytest.approx(x, abs=1e-10)


def test_the_recovery_curve_reads_the_models_shift():
    """Moving the reference below Tg by d recovers as a material whose Tg is d lower (the
    curve and the batch path alike): the recovery has no copy of the shift of its own."""
    lib = default_library()
    m = lib["H-4"]
    d = 9.0
    moved = replace(m, recovery=replace(m.recovery, reference_below_tg_c=d))
    lower = replace(m, tg_c=m.tg_c - d)
    assert viscoelastic(moved).reference_c == viscoelastic(lower).reference_c
    a, b = recovery_curve(moved, 90.0), recovery_curve(lower, 90.0)
    np.testing.assert_array_equal(a.ratio, b.ratio)
    assert a.fold_time < recovery_curve(m, 90.0).fold_time
    t = grid_until(20.0)
    batch, _ = material_batch_ratios(moved, np.array([m.tg_c]), m.recovery.h_w_m2k, 0.8, 90.0, 10.0, t)
    np.testing.assert_allclose(batch[0], a(t), atol=1e-9)


def test_viscoelastic_of_a_library_material_uses_its_moduli(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text('[materials.H-4]\nglassy_mpa = 2000.0\n[materials.R1]\nrole = "hinge"\ntg_c = 50.0\n'
                 'rubbery_mpa = 8.0\n')
    lib = load_library(f)
    h4, r1 = viscoelastic(lib["H-4"]), viscoelastic(lib["R1"])
    assert (h4.glassy_mpa, h4.rubbery_mpa) == (2000.0, 5.0)
    assert (r1.glassy_mpa, r1.rubbery_mpa) == (1500.0, 8.0)  # the library default, its own override
    assert lib["R1"].shape_fixity == pytest.approx(1500.0 / 1508.0, rel=1e-15)
    assert float(h4.relaxation_mpa(0.0, 20.0)) == pytest.approx(2000.0, rel=1e-12)
    with pytest.raises(MaterialError, match="VeroWhite.*no viscoelastic model"):
        viscoelastic(lib["VeroWhite"])


@pytest.mark.parametrize("body,needle", [
    ('[materials.H-4]\nglassy_mpa = 4.0\n', "must exceed rubbery_mpa"),
    ('[materials.H-4]\nrubbery_mpa = -1.0\n', "rubbery_mpa"),
    ('[materials.H-4]\nglassy_mpa = "1500"\n', "without quotes"),
    ('[modulus_defaults]\nglassy = 1.0\n[materials.H-4]\n', "unknown key"),
])
def test_bad_moduli_name_the_file_and_the_key(tmp_path, body, needle):
    f = tmp_path / "bad.toml"
    f.write_text(body)
    with pytest.raises(MaterialError, match=needle) as err:
        load_library(f)
    assert "bad.toml" in str(err.value)


@pytest.mark.parametrize("log10_tau", [0.894, -5.0])
def test_offset_for_peak_at_tg_puts_the_peak_at_tg(log10_tau):
    """Both branches: a long central time puts the 1 Hz peak above T_ref (WLF), a short one
    below it (Arrhenius); the offset the model names moves the peak onto Tg."""
    v = _model()
    v = Viscoelastic(v.tg_c, v.glassy_mpa, v.rubbery_mpa, replace(v.params, log10_tau_ref_s=log10_tau))
    assert (v.peak_log10_shift < 0) == (log10_tau > 0)
    off = v.offset_for_peak_at_tg_c
    moved = Viscoelastic(v.tg_c, v.glassy_mpa, v.rubbery_mpa, replace(v.params, reference_below_tg_c=off))
    assert moved.tan_delta_peak_c == pytest.approx(v.tg_c, abs=1e-6)
    T = np.arange(v.tg_c - 5, v.tg_c + 5, 0.001)
    assert T[np.argmax(moved.tan_delta(1.0, T))] == pytest.approx(v.tg_c, abs=0.002)


def test_the_grades_moduli_agree_with_the_composition_models_stiffness_ratio():
    """composition.toml's stiffness_ratio (graded hinges' strips) is E_g / E_r of the same
    grades: the two data files must not drift apart, and the default fixity follows."""
    from foldprint.model.composition import composition_model
    from foldprint.model.materials import default_fixity

    r = composition_model().stiffness_ratio
    for m in default_library().hinges():
        assert m.glassy_mpa / m.rubbery_mpa == pytest.approx(r, rel=1e-12)
        assert m.shape_fixity == pytest.approx(default_fixity(), rel=1e-12)
