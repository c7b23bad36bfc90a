"""The compiled recovery curves (``physics/recovery/batch_kernels.py``) against the numpy
reference (``batch._curves``, ``batch._slab``, numpy's log), beyond the templates'
materials of ``tests/test_kernels.py``: random hinges, baths, thicknesses, start
temperatures and run lengths, hinges that finish recovering (the kernel stops computing
their ratio once its running maximum is exactly 1), and the kernel's own log and slab
series. Tolerances as docs/kernels.md states them: ratios 1e-12, mean temperatures
1e-9 degC; the log within 2^-51 relative of numpy's, the slab roots within 4 ulp."""

from __future__ import annotations

import os
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.core import jit
from foldprint.model.composition import vero
from foldprint.model.materials import default_library
from foldprint.physics.recovery.batch import _layers, _slab, grid_until, material_batch_ratios
from foldprint.physics.recovery.curve import N_TERMS
from foldprint.physics.recovery.relaxation import CUT

pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled to compare")

RATIO_TOL = 1e-12
MEAN_T_TOL = 1e-9
LOG_REL = 2.0**-51  # 4.4e-16: two units in the last place of numpy's log (measured: one)
HINGES = ["H-1", "H-2", "H-3", "H-4", "H-5", "H-7"]
GRADED = [vero([0.6, 0.9], "width"), vero([0.6, 0.95], "length")]  # graded hinges: their strips in one batch


def _both(fn):
    """``fn()`` on the numpy path, then on the compiled one."""
    with mock.patch.dict(os.environ, {jit.ENV: "numpy"}):
        ref = fn()
    with mock.patch.dict(os.environ, {jit.ENV: "numba"}):
        return ref, fn()


def _compare(mat, tg, hw, th, bath, initial_c, until_s):
    t = grid_until(until_s)
    (r0, m0), (r1, m1) = _both(lambda: material_batch_ratios(mat, tg, hw, th, bath, initial_c, t, table=True))
    assert r0.shape == r1.shape == m0.shape == m1.shape == (len(tg), len(t))
    assert np.all(np.diff(r1, axis=1) >= 0) and np.all((r1 >= 0) & (r1 <= 1))
    assert np.abs(r0 - r1).max() < RATIO_TOL, np.abs(r0 - r1).max()
    assert np.abs(m0 - m1).max() < MEAN_T_TOL, np.abs(m0 - m1).max()
    return r1


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(data=st.data())
def test_random_hinges_match_the_numpy_path(data):
    """Hinges of one material with Tg 25 degC either side of its own, h x0.3..3,
    0.3..2 mm thick, baths 30..110 degC, starting at -10..45 degC, curves 0.5..60 s long
    (below and above Tg, Arrhenius and WLF, slow and finished recoveries)."""
    mat = default_library()[data.draw(st.sampled_from(HINGES + GRADED))]
    assert mat.recovery is not None
    n = data.draw(st.integers(1, 12))
    u = lambda lo, hi: np.array(data.draw(st.lists(st.floats(lo, hi), min_size=n, max_size=n)))  # noqa: E731
    _compare(mat, mat.tg_c + u(-25, 25), mat.recovery.h_w_m2k * u(0.3, 3.0), u(0.3, 2.0), u(30, 110),
             data.draw(st.floats(-10, 45)), data.draw(st.floats(0.5, 60.0)))


def test_finished_hinges_stay_at_one_and_match():
    """Thin hinges in a hot bath recover completely early (ratio exactly 1, after which
    the kernel computes only their mean temperature); slow ones beside them in the same
    batch do not. Both match the reference over 60 s."""
    mat = default_library()["H-2"]
    n = 8
    r = _compare(mat, np.full(n, mat.tg_c), np.full(n, mat.recovery.h_w_m2k), np.linspace(0.3, 1.6, n),
                 np.r_[np.full(n // 2, 110.0), np.full(n // 2, mat.tg_c - 5)], 20.0, 60.0)
    done = r[:, -1] == 1.0
    assert done[: n // 2].all() and not done[n // 2:].any()
    first = np.argmax(r == 1.0, axis=1)[: n // 2]
    assert np.all(first < r.shape[1] // 2)  # finished well before the end: the skip is exercised


def test_vlog_is_numpys_log_to_round_off():
    """Over the kernel's whole domain (reduced times >= 0): 0 and the subnormals give
    ln DBL_MIN, the normal doubles numpy's log within 2^-51 relative (and exactly 0 at 1)."""
    from foldprint.physics.recovery.batch_kernels import vlog

    rng = np.random.default_rng(7)
    tiny = np.finfo(float).tiny
    x = np.concatenate([np.exp(rng.uniform(np.log(tiny), np.log(np.finfo(float).max), 200_000)),
                        np.linspace(0.5, 2.0, 100_001), 1.0 + rng.uniform(-1e-6, 1e-6, 10_000),
                        [1.0, tiny, np.nextafter(tiny, 1), np.sqrt(0.5), np.sqrt(2.0), np.finfo(float).max]])
    out, bits = np.empty_like(x), np.empty(x.shape, np.int64)
    vlog(x, out, bits)
    ref = np.log(x)
    err = np.abs(out - ref)
    assert np.all(err <= LOG_REL * np.abs(ref)), np.max(err / np.maximum(np.abs(ref), tiny))
    assert out[np.flatnonzero(x == 1.0)].tolist() == [0.0]
    low = np.array([0.0, 5e-324, 1e-310, tiny / 2])
    out, bits = np.empty_like(low), np.empty(low.shape, np.int64)
    vlog(low, out, bits)
    assert np.all(out == np.log(tiny))


@pytest.mark.parametrize("biot_scale", [0.01, 1.0, 100.0])
def test_slab_series_is_the_references(biot_scale):
    """The compiled slab series (roots of zeta tan zeta = Bi, the terms' coefficients at
    the layers, each term's last time alive) against ``batch._slab``, thin to thick hinges."""
    from foldprint.physics.recovery.batch_kernels import slab_series

    p = default_library()["H-3"].recovery
    th = np.linspace(0.2, 3.0, 9)
    hw = np.full(th.shape, p.h_w_m2k * biot_scale)
    ref = _slab(p, hw, th)
    half2, nsq, shape, t_cut = slab_series(hw, th, float(p.k_w_mk), ref.alpha, _layers()[0], N_TERMS, CUT)
    assert np.array_equal(half2, ref.half2)
    assert np.all(np.abs(nsq - ref.nsq) <= 8 * np.spacing(np.abs(ref.nsq)))  # zeta^2: 4 ulp of zeta, twice
    assert np.abs(shape - ref.shape).max() < 1e-13
    assert np.allclose(t_cut, ref.t_cut, rtol=1e-14, atol=0)
