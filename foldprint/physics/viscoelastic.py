"""One linear viscoelastic model per material: what DMA measures and what the hinges feel.

A material is a generalised Maxwell (Prony) solid about its Tg:

* moduli: glassy ``E_g`` and rubbery ``E_r`` (MPa);
* time-temperature superposition: log10 a_T from :func:`~foldprint.physics.recovery.curve.log10_shift`
  (WLF above Tg, Arrhenius below, continuous in value and slope at Tg);
* a relaxation spectrum: times tau_b at Tg and normalised weights g_b
  (:func:`~foldprint.physics.recovery.curve.spectrum`, the paper's 16 branches).

Then, with tau_b(T) = a_T tau_b and dE = E_g - E_r,

* relaxation modulus  E(t, T)  = E_r + dE sum_b g_b exp(-t / tau_b(T));
* storage modulus     E'(f, T) = E_r + dE sum_b g_b (w tau)^2 / (1 + (w tau)^2), w = 2 pi f;
* loss modulus        E''(f, T) = dE sum_b g_b (w tau) / (1 + (w tau)^2);
* tan delta = E'' / E'.

The recovery ratio R(t) of a hinge is ``1 - sum_b g_b exp(-xi / tau_b)`` with xi its reduced
time (physics/recovery), the same spectrum and shift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model.materials import RecoveryParams
from .recovery.curve import log10_shift, spectrum


@dataclass(frozen=True, eq=False)
class Viscoelastic:
    """A material's viscoelastic model: Tg (deg C), moduli (MPa), shift and spectrum
    (``params``: c1, c2, log10_tau_ref_s, spectrum_sigma_decades, spectrum_span_decades,
    n_branches of :class:`~foldprint.model.materials.RecoveryParams`)."""

    tg_c: float
    glassy_mpa: float
    rubbery_mpa: float
    params: RecoveryParams

    def log10_shift(self, temp_c) -> np.ndarray:
        """log10 a_T at ``temp_c`` (any shape)."""
        return log10_shift(np.asarray(temp_c, float), self.tg_c, self.params)

    def _taus(self, temp_c) -> tuple[np.ndarray, np.ndarray]:
        """tau_b(T) (..., n_branches) s and the weights g_b (n_branches,)."""
        tau, g = spectrum(self.params)
        with np.errstate(over="ignore"):  # a_T = inf deep in the glass: every branch frozen
            a = 10.0 ** self.log10_shift(temp_c)
        return a[..., None] * tau, g

    def relaxation_mpa(self, t_s, temp_c) -> np.ndarray:
        """E(t, T) in MPa at times ``t_s`` after a step strain held at ``temp_c``
        (broadcast together)."""
        t, temp = np.broadcast_arrays(np.asarray(t_s, float), np.asarray(temp_c, float))
        taus, g = self._taus(temp)
        u = np.sum(g * np.exp(-t[..., None] / taus), axis=-1)
        return self.rubbery_mpa + (self.glassy_mpa - self.rubbery_mpa) * u

    def dynamic_mpa(self, freq_hz, temp_c) -> tuple[np.ndarray, np.ndarray]:
        """(E', E'') in MPa at ``freq_hz`` and ``temp_c`` (broadcast together)."""
        f, temp = np.broadcast_arrays(np.asarray(freq_hz, float), np.asarray(temp_c, float))
        taus, g = self._taus(temp)
        wt = 2.0 * math.pi * f[..., None] * taus
        d = self.glassy_mpa - self.rubbery_mpa
        with np.errstate(over="ignore", divide="ignore"):  # (w tau)^2 past 1e308 deep in the glass
            storage = self.rubbery_mpa + d * np.sum(g / (1.0 + wt**-2.0), axis=-1)  # = wt^2 / (1 + wt^2)
            loss = d * np.sum(g / (wt + 1.0 / wt), axis=-1)  # = wt / (1 + wt^2)
        return storage, loss

    def tan_delta(self, freq_hz, temp_c) -> np.ndarray:
        """tan delta = E'' / E' at ``freq_hz`` and ``temp_c``."""
        storage, loss = self.dynamic_mpa(freq_hz, temp_c)
        return loss / storage
