"""Graded hinges: effective recovery of strips (physics.recovery.curve) against analytic cases."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from foldprint.model.composition import Along, FractionProfile, composition_model, vero
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import combine_strips, recovery_curve, strip_tgs
from foldprint.physics.recovery.batch import grid_until, material_batch_ratios

LIB = default_library()
M = composition_model()
BATH, TH, FIX = 90.0, 0.8, 10.0


def _uniform(f):
    return recovery_curve(LIB[vero(f)], BATH, TH, FIX)


def test_two_segment_width_hinge_is_the_mean_of_two_uniform_hinges():
    # analytic: two equal strips in series (curvatures add) -> angle = mean of the two curves
    a, b = _uniform(0.6), _uniform(0.9)
    two = combine_strips(np.array([a.ratio, b.ratio]), np.array([0.5, 0.5]), Along.WIDTH)
    assert np.allclose(two, 0.5 * (a.ratio + b.ratio), atol=1e-15)
    # and the staged shape: at the fast strip's fold time the hinge is about half folded
    t = a.fold_time
    assert 0.45 < float(np.interp(t, a.t, two)) < 0.6


def test_length_hinge_is_held_back_by_its_glassy_strip():
    a, b = _uniform(0.6), _uniform(0.9)
    r = np.array([a.ratio, b.ratio])
    eff = combine_strips(r, np.array([0.5, 0.5]), Along.LENGTH)
    assert np.all(eff <= 0.5 * (a.ratio + b.ratio) + 1e-12)  # stiff (glassy) strip holds it back
    assert np.all(eff >= np.minimum(a.ratio, b.ratio) - 1e-12)
    # equal stiffness (ratio 1) is the plain mean; an infinite ratio weights each strip by its
    # unrecovered (glassy) part: sum (1 - R) R / sum (1 - R)
    assert np.allclose(combine_strips(r, np.array([0.5, 0.5]), Along.LENGTH, 1.0), 0.5 * (a.ratio + b.ratio))
    far = combine_strips(r, np.array([0.5, 0.5]), Along.LENGTH, 1e9)
    mask = np.min(r, axis=0) < 0.99
    lim = np.sum((1 - r) * r, axis=0)[mask] / np.sum(1 - r, axis=0)[mask]
    assert np.allclose(far[mask], lim, atol=1e-6)


@pytest.mark.parametrize("along", ["width", "length"])
def test_graded_curve_converges_to_the_integral_over_the_width(along):
    name = vero([0.6, 0.9], along)
    c = recovery_curve(LIB[name], BATH, TH, FIX, horizon_s=30.0)
    # independent reference: 33-point trapezoid over u of uniform curves at Tg(f(u))
    u = np.linspace(0, 1, 33)
    prof = FractionProfile((0.6, 0.9), Along(along))
    tg = M._tg(prof.at(u))
    subs = np.array([recovery_curve(replace(LIB["H-1"], tg_c=float(x)), BATH, TH, FIX, horizon_s=30.0).ratio
                     for x in tg])
    w = np.full(len(u), 1 / (len(u) - 1))
    w[[0, -1]] *= 0.5
    ref = combine_strips(subs, w, Along(along))
    assert np.max(np.abs(c.ratio - ref)) < 0.01
    # between its ends, and later than the fast end
    fast, slow = (recovery_curve(LIB[vero(f)], BATH, TH, FIX, horizon_s=30.0) for f in (0.6, 0.9))
    assert fast.fold_time < c.fold_time <= slow.fold_time + 1e-9


def test_uniform_vw_at_a_grade_fraction_matches_the_grade():
    h3 = recovery_curve(LIB["H-3"], BATH, TH, FIX)
    v = recovery_curve(LIB[vero(M.assumed_fraction("H-3"))], BATH, TH, FIX)
    assert abs(h3.fold_time - v.fold_time) < 0.02


@pytest.mark.parametrize("along", ["width", "length"])
def test_batch_path_equals_the_exact_path_with_tg_shift(along):
    mat = LIB[vero([0.6, 0.9], along)]
    t = grid_until(30.0)
    shifts = np.array([-1.5, 0.0, 2.0])
    ratio, _ = material_batch_ratios(mat, mat.tg_c + shifts, mat.recovery.h_w_m2k, TH, BATH, FIX, t)
    for k, d in enumerate(shifts):
        ref = recovery_curve(replace(mat, tg_c=mat.tg_c + d), BATH, TH, FIX, horizon_s=30.0)
        n = min(len(t), len(ref.ratio))  # the same grid (the batch one may hold one more point)
        assert np.allclose(ratio[k][:n], ref.ratio[:n], atol=1e-9) and np.allclose(t[:n], ref.t[:n])


def test_strip_tgs_shift_alike():
    mat = LIB[vero([0.6, 0.9], "width")]
    a, w = strip_tgs(mat)
    b, _ = strip_tgs(mat, mat.tg_c + 1.0)
    assert np.allclose(b - a, 1.0) and w.sum() == pytest.approx(1.0)


def test_octagon_stack_folds_with_fractions_and_jams_with_seven_grades():
    """docs/composition.md: eight strictly ordered flaps; the continuous version folds, the
    seven-grade one (two flaps share H-7) collides, and its template says which grades."""
    from foldprint.io.load import load_design
    from foldprint.io.templates import resolve_design_path
    from foldprint.simulation.simulate import simulate

    cont = load_design(resolve_design_path("octagon_stack"))
    seven = load_design(resolve_design_path("octagon_stack_seven"))
    fr = [comp_fraction(h.material) for h in cont.hinges]
    assert len(set(fr)) == 8 and fr == sorted(fr)  # eight distinct fractions, lowest flap first
    assert {h.material for h in seven.hinges} <= {f"H-{i}" for i in range(1, 8)}
    assert simulate(cont, dt=0.02).completed
    r = simulate(seven, dt=0.02)
    assert not r.completed and r.first_collision is not None


def comp_fraction(name: str) -> float:
    from foldprint.model.composition import parse_name
    return parse_name(name).knots[0]
