"""The viscoelastic model's moduli against closed forms of a Prony solid."""

import math
from dataclasses import replace

import numpy as np
import pytest

from foldprint.model.materials import default_library
from foldprint.physics.viscoelastic import Viscoelastic


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
