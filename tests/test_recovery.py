"""The hinge recovery model: invariants, a prediction, and an independent check of the
heat-transfer solution against finite differences. The numbers the recovery parameters were
fitted to are re-asserted apart, in test_calibration_regression.py."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.physics.recovery.curve import (fold_time, log10_shift, recovery_curve, slab_temperature, spectrum)

TEMPS = (70.0, 80.0, 90.0, 100.0)


def ft(lib, name, bath, thickness=0.8):
    return fold_time(lib[name], bath, thickness)


def test_fold_time_rises_with_tg_at_every_temperature(lib):
    for bath in TEMPS:
        times = [ft(lib, m.name, bath) for m in lib.hinges()]
        assert all(t is not None for t in times), (bath, times)
        assert all(b > a for a, b in zip(times, times[1:])), (bath, times)


def test_fold_time_falls_with_temperature_for_every_material(lib):
    for m in lib.hinges():
        times = [ft(lib, m.name, bath) for bath in TEMPS]
        assert all(b < a for a, b in zip(times, times[1:])), (m.name, times)


def test_inner_hinges_start_within_a_second_predicted(lib):
    """Predicted, not fitted (the shipped fit's targets are in
    test_calibration_regression.py): Sample 2's inner hinges (H-1, H-1, H-2) "start the
    shape recovery within ~1s" (paper_timings.toml, read as <= 1.5 s)."""
    assert recovery_curve(lib["H-2"], 90).onset_time <= 1.5
    assert recovery_curve(lib["H-1"], 90).onset_time <= recovery_curve(lib["H-2"], 90).onset_time


def test_high_tg_hinge_is_barely_started_when_low_tg_is_done(lib):
    """R(t) curves, not only fold times: at the time H-1 is done, H-7 has barely moved."""
    t1 = ft(lib, "H-1", 90)
    assert recovery_curve(lib["H-7"], 90)(t1) < 0.1


def test_bath_below_tg_does_not_fold(lib):
    c = recovery_curve(lib["H-7"], 55.0)  # 10 C below Tg
    assert c.fold_time is None
    assert c(300.0) < 0.5  # barely recovers in five minutes
    assert ft(lib, "H-7", 55.0) is None


def test_recovery_is_monotone_bounded_and_starts_at_zero(lib):
    for m in lib.hinges():
        c = recovery_curve(m, 85.0)
        assert c(0.0) == pytest.approx(0.0, abs=1e-9)
        assert np.all(np.diff(c.ratio) >= 0)
        assert c.ratio.min() >= 0 and c.ratio.max() <= 1
        assert c(c.horizon_s) > 0.999


@settings(max_examples=30, deadline=None)
@given(bath=st.floats(70, 110), thick=st.floats(0.3, 2.0))
def test_thicker_hinges_fold_slower(lib, bath, thick):
    a = ft(lib, "H-3", bath, thick)
    b = ft(lib, "H-3", bath, thick * 1.5)
    assert a is not None and b is not None and b > a


def test_shift_factor_continuous_in_value_and_slope_at_tg(lib):
    p = lib["H-4"].recovery
    tg = lib["H-4"].tg_c
    eps = 1e-4
    below, at, above = log10_shift(np.array([tg - eps, tg, tg + eps]), tg, p)
    assert at == 0.0
    assert abs(above - below) < 1e-3
    slope_wlf = -p.c1 / p.c2
    assert (above - at) / eps == pytest.approx(slope_wlf, rel=1e-3)
    assert (at - below) / eps == pytest.approx(slope_wlf, rel=1e-3)


def test_spectrum_has_16_branches_with_unit_weight(lib):
    tau, g = spectrum(lib["H-1"].recovery)
    assert len(tau) == 16 and np.all(np.diff(tau) > 0)
    assert g.sum() == pytest.approx(1.0)


def _fd_step(temp, p, bath, dz, dt):
    """One explicit step of the heat equation through the thickness; Robin faces by ghost
    nodes (-k dT/dz = h (T - Tb))."""
    r = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk) * dt / dz**2
    new = temp.copy()
    new[1:-1] = temp[1:-1] + r * (temp[2:] - 2 * temp[1:-1] + temp[:-2])
    for i, nb in ((0, 1), (len(temp) - 1, len(temp) - 2)):
        ghost = temp[nb] - 2 * dz * p.h_w_m2k / p.k_w_mk * (temp[i] - bath)
        new[i] = temp[i] + r * (ghost - 2 * temp[i] + temp[nb])
    return new


def _slab_by_finite_differences(p, thick_m, bath, t0, times, n=81):
    """Explicit finite differences of the same 1-D problem; the temperatures at ``times``
    (ascending), (len(times), n)."""
    dz = thick_m / (n - 1)
    alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
    dt = 0.2 * dz**2 / alpha / (1.0 + p.h_w_m2k * dz / p.k_w_mk)  # stable with the Robin faces
    temp, t, out = np.full(n, t0), 0.0, []
    for t_end in times:
        steps = max(int(np.ceil((t_end - t) / dt)), 1)
        step = (t_end - t) / steps
        for _ in range(steps):
            temp = _fd_step(temp, p, bath, dz, step)
        t = t_end
        out.append(temp)
    return np.array(out)


def test_slab_temperature_against_finite_differences(lib):
    """Independent reference: explicit finite differences of the same 1-D problem."""
    p = lib["H-1"].recovery
    fd = _slab_by_finite_differences(p, 0.8e-3, 90.0, 10.0, [2.0])[0]
    series = slab_temperature(np.array([2.0]), np.linspace(-1, 1, 81), 90.0, 10.0, 0.8, p)[0]
    assert np.max(np.abs(series - fd)) < 0.3  # deg C


@pytest.mark.parametrize("h_w_m2k", [361.8, 5000.0])
def test_slab_temperature_early_and_at_high_biot_against_finite_differences(lib, h_w_m2k):
    """The series at early times (Fourier number 0.014 to 0.07), where many of its terms
    count, and at the fitted Biot number (0.72) and a high one (10, a thick hinge or a
    stirred bath: the eigenvalues crowd the top of each bracket (k pi, k pi + pi/2)); a
    root taken from the wrong bracket moves the profile by degrees."""
    from dataclasses import replace

    p = replace(lib["H-1"].recovery, h_w_m2k=h_w_m2k)
    times = [0.02, 0.1]
    fd = _slab_by_finite_differences(p, 0.8e-3, 90.0, 10.0, times)
    series = slab_temperature(np.array(times), np.linspace(-1, 1, 81), 90.0, 10.0, 0.8, p)
    assert np.max(np.abs(series - fd)) < 0.25  # deg C, of an 80 deg C step


def test_panel_material_has_no_recovery(lib):
    from foldprint.core.errors import MaterialError

    with pytest.raises(MaterialError, match="VeroWhite"):
        recovery_curve(lib["VeroWhite"], 90.0)


def test_invalid_inputs_raise(lib):
    from foldprint.core.errors import MaterialError

    with pytest.raises(MaterialError, match="thickness"):
        recovery_curve(lib["H-1"], 90.0, thickness_mm=0.0)
    with pytest.raises(MaterialError, match="finite"):
        recovery_curve(lib["H-1"], math.nan)


def _recovery_by_finite_differences(material, bath_c, t_end, thickness_mm=0.8, initial_c=10.0, n=41):
    """The hinge's recovery ratio computed a second way: explicit finite differences of the
    heat equation through the thickness (Robin boundaries), reduced time per node by the
    trapezoid rule, the 16-branch spectrum per node, and the bending (z^2) weight through
    the thickness by the trapezoid rule on the uniform nodes. Shares with the model only
    its definitions (the shift law, the spectrum, the material's numbers)."""
    p = material.recovery
    thick_m = thickness_mm * 1e-3
    dz = thick_m / (n - 1)
    alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
    dt = 0.2 * dz**2 / alpha
    steps = int(np.ceil(t_end / dt))
    temp = np.full(n, initial_c)
    xi = np.zeros(n)
    rate = 10.0 ** (-log10_shift(temp, material.tg_c, p))
    z = np.linspace(-1.0, 1.0, n)
    w = z**2 * np.r_[0.5, np.ones(n - 2), 0.5]
    w /= w.sum()
    tau, g = spectrum(p)
    times, ratios = [0.0], [0.0]
    for k in range(steps):
        temp = _fd_step(temp, p, bath_c, dz, dt)
        new_rate = 10.0 ** (-log10_shift(temp, material.tg_c, p))
        xi += 0.5 * (rate + new_rate) * dt
        rate = new_rate
        if k % 20 == 19:
            unrecovered = (g[:, None] * np.exp(-xi[None, :] / tau[:, None])).sum(axis=0)
            times.append((k + 1) * dt)
            ratios.append(1.0 - float(unrecovered @ w))
    return np.array(times), np.array(ratios)


@pytest.mark.parametrize("name", ["H-1", "H-7"])
def test_recovery_curve_against_finite_differences(lib, name):
    """R(t) of the model (series heat solution, Gauss-Legendre layers) against the second
    computation above, over the whole fold; and the bending weight matters: the same
    computation weighted uniformly through the thickness is far off (so dropping the z^2
    weight from the model fails this test)."""
    mat = lib[name]
    ft98 = recovery_curve(mat, 90.0).fold_time
    t, r_fd = _recovery_by_finite_differences(mat, 90.0, 1.3 * ft98)
    r_model = recovery_curve(mat, 90.0)(t)
    assert np.max(np.abs(r_model - r_fd)) < 0.01
    # the same reference without the bending weight: not the model
    uniform = _uniform_weight_ratio(mat, 90.0, t)
    assert np.max(np.abs(uniform - r_model)) > 0.05


def _uniform_weight_ratio(material, bath_c, t, initial_c=10.0):
    """The model's layers weighted uniformly through the thickness (not bending)."""
    p = material.recovery
    z = np.linspace(-1.0, 1.0, 81)
    grid = np.linspace(0.0, t[-1], 4001)
    temp = slab_temperature(grid, z, bath_c, initial_c, 0.8, p)
    rate = 10.0 ** (-log10_shift(temp, material.tg_c, p))
    xi = np.concatenate([np.zeros((1, len(z))), np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(grid)[:, None], 0)])
    tau, g = spectrum(p)
    unrec = sum(gb * np.exp(-xi / tb) for tb, gb in zip(tau, g)).mean(axis=1)
    return np.interp(t, grid, 1.0 - unrec)


# ---- the model's contract at its edges (each found by a surviving mutant, docs/testing.md) ----

def test_curve_grid_is_the_documented_grid():
    """Steps of _DT_FINE up to _T_FINE exactly, then 399 more geometric points ending at the
    horizon: strictly increasing, no duplicate at the seam, for a horizon past, at and
    inside the fine part."""
    from foldprint.physics.recovery import curve as rec

    n_fine = int(round(rec._T_FINE / rec._DT_FINE)) + 1
    for horizon in (rec._T_FINE, 600.0, 17.0):
        g = rec.curve_time_grid(horizon)
        assert g[0] == 0.0 and g[-1] == pytest.approx(horizon, rel=1e-12)
        assert np.all(np.diff(g) > 0)
        fine = g[g <= min(horizon, rec._T_FINE) + 1e-9]
        np.testing.assert_allclose(np.diff(fine), rec._DT_FINE, rtol=1e-6)
        if horizon > rec._T_FINE:
            assert len(fine) == n_fine and len(g) == n_fine + 399
            ratios = g[n_fine:] / g[n_fine - 1:-1]
            np.testing.assert_allclose(ratios, (horizon / rec._T_FINE) ** (1 / 399), rtol=1e-9)
        else:
            assert len(g) == int(round(horizon / rec._DT_FINE)) + 1


def test_curve_is_zero_before_the_bath_and_knows_its_horizon(lib):
    c = recovery_curve(lib["H-3"], 90.0, horizon_s=250.0)
    assert c.horizon_s == pytest.approx(250.0, rel=1e-12)
    np.testing.assert_array_equal(c(np.array([-5.0, -1e-3])), [0.0, 0.0])
    assert c(c.horizon_s + 100.0) == c.ratio[-1]  # held past the horizon


def test_every_argument_reaches_the_curve(lib):
    """recovery_ratio, fold_time and hinge_fold_times pass each argument on: a thicker
    hinge, a warmer start, a colder bath each change the answer the physical way."""
    from foldprint.model.design import Process, strip
    from foldprint.physics.recovery.curve import hinge_fold_times, recovery_ratio

    m = lib["H-3"]
    t = np.linspace(0.1, 3.0, 30) * fold_time(m, 90.0, 0.8)  # through the transition, whatever the library
    base = recovery_ratio(t, m, 90.0)
    np.testing.assert_array_equal(base, recovery_curve(m, 90.0)(t))
    assert np.all(recovery_ratio(t, m, 90.0, thickness_mm=1.6) <= base)
    assert np.any(recovery_ratio(t, m, 90.0, thickness_mm=1.6) < base - 1e-3)
    assert np.any(recovery_ratio(t, m, 90.0, initial_c=40.0) > base + 1e-3)
    assert np.any(recovery_ratio(t, m, 80.0) < base - 1e-3)
    assert fold_time(m, 90.0, 0.8, initial_c=40.0) < fold_time(m, 90.0, 0.8) < fold_time(m, 90.0, 1.6)

    d = strip("s", [10, 10, 10], [90, 90], ["H-1", "H-7"], hinge_thickness=[0.8, 1.2],
              process=Process(fix_temperature_c=30.0, bath_temperature_c=85.0))
    got = hinge_fold_times(d, lib)
    want = {"h1": fold_time(lib["H-1"], 85.0, 0.8, 30.0), "h2": fold_time(lib["H-7"], 85.0, 1.2, 30.0)}
    assert got == pytest.approx(want, rel=1e-12)
    assert got["h1"] != fold_time(lib["H-1"], 85.0, 0.8) and got["h2"] != fold_time(lib["H-7"], 85.0, 0.8, 30.0)
    assert hinge_fold_times(d) == pytest.approx(want, rel=1e-12)  # the default library is the same


def test_single_branch_spectrum_sits_at_the_reference_time(lib):
    """A one-branch Prony series is one relaxation time, tau_ref, with weight 1 (the
    general formula would put it half a span early)."""
    from dataclasses import replace

    p = replace(lib["H-1"].recovery, n_branches=1)
    tau, g = spectrum(p)
    np.testing.assert_allclose(tau, [10.0 ** p.log10_tau_ref_s])
    np.testing.assert_allclose(g, [1.0])


@pytest.mark.parametrize("name", ["H-3", "VW0.600-0.900@width", "VW0.600-0.900@length"])
def test_curve_records_its_inputs_and_is_read_only(lib, name):
    """A cached curve is shared by every caller: its arrays must refuse writes, and it
    states the hinge it was computed for (uniform and graded)."""
    m = lib[name]
    c = recovery_curve(m, 87.0, thickness_mm=0.9, initial_c=15.0, horizon_s=300.0)
    assert (c.material, c.tg_c, c.bath_c, c.thickness_mm, c.initial_c) == (m.name, m.tg_c, 87.0, 0.9, 15.0)
    for arr in (c.t, c.ratio, c.mean_temperature_c):
        assert not arr.flags.writeable
        with pytest.raises(ValueError):
            arr[0] = 0.5


def test_a_horizon_that_is_not_positive_is_refused(lib):
    from foldprint.core.errors import MaterialError

    for horizon in (0.0, -1.0):
        with pytest.raises(MaterialError, match="horizon must be > 0 s"):
            recovery_curve(lib["H-3"], 90.0, horizon_s=horizon)


@settings(max_examples=300, derandomize=True, database=None)
@given(steps=st.lists(st.tuples(st.floats(0.01, 5.0), st.floats(0.0, 0.3)), min_size=1, max_size=25),
       level=st.floats(0.01, 1.0))
def test_time_to_is_the_first_crossing_of_the_tabulated_curve(steps, level):
    """Reference: the piecewise-linear curve the model tabulates, read by np.interp: the
    time returned reaches ``level`` exactly, and no earlier grid point does; None exactly
    when the curve never gets there."""
    from foldprint.physics.recovery.curve import RecoveryCurve

    t = np.concatenate([[0.0], np.cumsum([dt for dt, _ in steps])])
    ratio = np.minimum(np.concatenate([[0.0], np.cumsum([dr for _, dr in steps])]), 1.0)
    curve = RecoveryCurve("m", 50.0, 90.0, 0.8, 10.0, t, ratio, np.zeros_like(t))
    got = curve.time_to(level)
    if ratio[-1] < level:
        assert got is None
        return
    assert np.interp(got, t, ratio) == pytest.approx(level, abs=1e-9)
    assert np.all(ratio[t < got - 1e-9] < level)
