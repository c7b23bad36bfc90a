"""One linear viscoelastic model per material: what DMA measures, what the hinges feel and
how they recover.

A hinge material is a generalised Maxwell (Prony) solid (``docs/recovery-model.md``):

* moduli: glassy ``E_g`` and rubbery ``E_r`` (MPa; ``glassy_mpa``, ``rubbery_mpa`` of its
  ``[materials.NAME]`` table, else the library's ``[modulus_defaults]``);
* time-temperature superposition: log10 a_T (:func:`log10_shift`), WLF above a reference
  temperature T_ref and Arrhenius below it, continuous in value and slope at T_ref;
* a relaxation spectrum: times tau_b at T_ref and normalised weights g_b (:func:`spectrum`,
  the paper's 16 branches).

Then, with tau_b(T) = a_T tau_b and dE = E_g - E_r,

* relaxation modulus  E(t, T)  = E_r + dE sum_b g_b exp(-t / tau_b(T));
* storage modulus     E'(f, T) = E_r + dE sum_b g_b (w tau)^2 / (1 + (w tau)^2), w = 2 pi f;
* loss modulus        E''(f, T) = dE sum_b g_b (w tau) / (1 + (w tau)^2);
* tan delta = E'' / E'.

**Tg and the shift's reference.** The paper's Tg is the temperature of the tan delta peak at
1 Hz (Mao et al. 2015, Methods, Fig. S2). The shift's reference temperature is
T_ref = Tg - ``reference_below_tg_c`` (a recovery parameter, 0 for the shipped grades: their
shift is referenced at Tg, the convention the recovery fit was made in). tan delta depends on
temperature only through a_T (no vertical shift), so its peak is one value x* of log10 a_T
(:func:`peak_log10_shift`, set by the spectrum and E_g / E_r) and the model's own 1 Hz
peak temperature (:attr:`Viscoelastic.tan_delta_peak_c`) follows in closed form; where it is
not Tg, ``foldprint materials`` prints both and docs/recovery-model.md says why.

The recovery ratio R(t) of a hinge is ``1 - sum_b g_b exp(-xi / tau_b)`` with xi its reduced
time under this shift (physics/recovery); the bar-and-hinge hinge stiffness is E(t, T) at the
mechanics data's load time (physics/barhinge/stiffness).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..core.errors import MaterialError
from ..model.materials import Material, RecoveryParams

#: The DMA protocol's frequency (Hz) at whose tan delta peak Tg is read: Mao et al. 2015,
#: Methods ("the strain is oscillated at a frequency of 1 Hz").
DMA_FREQUENCY_HZ = 1.0
_KELVIN = 273.15


def log10_shift(temp_c, reference_c, p: RecoveryParams) -> np.ndarray:
    """log10 a_T about the reference temperature ``reference_c``: WLF above it, Arrhenius
    below (activation energy ln(10) R c1 T_ref^2 / c2: value and slope continuous at T_ref).

    >>> from foldprint.model.materials import default_library
    >>> p = default_library()["H-1"].recovery
    >>> float(log10_shift(np.array([20.0]), 20.0, p)[0]) == 0.0  # no shift at T_ref (it is -0.0)
    True
    """
    d = np.asarray(temp_c, float) - reference_c
    wlf = -p.c1 * d / (p.c2 + np.maximum(d, 0.0))
    tk = np.asarray(temp_c, float) + _KELVIN
    rk = np.asarray(reference_c, float) + _KELVIN
    arrhenius = (p.c1 / p.c2) * rk**2 * (1.0 / tk - 1.0 / rk)  # = Ea/(R ln10) (1/T - 1/T_ref)
    return np.where(d >= 0.0, wlf, arrhenius)


def spectrum(p: RecoveryParams) -> tuple[np.ndarray, np.ndarray]:
    """Relaxation times tau_b (s, at T_ref) and normalised weights g_b of the Prony series."""
    n = p.n_branches
    if n == 1:
        return np.array([10.0**p.log10_tau_ref_s]), np.array([1.0])
    logtau = p.log10_tau_ref_s + np.linspace(-0.5, 0.5, n) * p.spectrum_span_decades
    g = np.exp(-0.5 * ((logtau - p.log10_tau_ref_s) / p.spectrum_sigma_decades) ** 2)
    return 10.0**logtau, g / g.sum()


def _tan_delta_of_shift(x: np.ndarray, omega_tau: np.ndarray, g: np.ndarray, ratio: float) -> np.ndarray:
    """tan delta at log10 a_T = ``x`` of a spectrum (omega tau_b, g_b) with E_g / E_r = ``ratio``."""
    wt = 10.0 ** np.asarray(x, float)[..., None] * omega_tau
    d = ratio - 1.0
    return d * np.sum(g * wt / (1.0 + wt**2), axis=-1) / (1.0 + d * np.sum(g * wt**2 / (1.0 + wt**2), axis=-1))


@lru_cache(maxsize=512)
def peak_log10_shift(p: RecoveryParams, glassy_mpa: float, rubbery_mpa: float,
                     freq_hz: float = DMA_FREQUENCY_HZ) -> float:
    """x* = log10 a_T at which the model's tan delta at ``freq_hz`` peaks (a grid of
    0.01 decade over every branch's loss peak and 12 decades past it, then a bounded
    Brent search to 1e-9). tan delta of a Prony solid with E_r > 0 falls to 0 on both sides, so
    the peak is inside the grid."""
    from scipy.optimize import minimize_scalar

    tau, g = spectrum(p)
    omega_tau = 2.0 * math.pi * freq_hz * tau
    ratio = glassy_mpa / rubbery_mpa
    lo, hi = -math.log10(omega_tau.max()) - 12.0, -math.log10(omega_tau.min()) + 4.0
    x = np.arange(lo, hi, 0.01)
    k = int(np.argmax(_tan_delta_of_shift(x, omega_tau, g, ratio)))
    if k in (0, len(x) - 1):  # not reached for E_r > 0; a guard, not a result
        raise MaterialError(f"the tan delta peak of this spectrum lies outside log10 a_T [{lo:.1f}, {hi:.1f}]")
    res = minimize_scalar(lambda v: -float(_tan_delta_of_shift(v, omega_tau, g, ratio)),
                          bounds=(x[k - 1], x[k + 1]), method="bounded", options={"xatol": 1e-9})
    return float(res.x)


def shift_temperature(reference_c, log10_a: float, p: RecoveryParams) -> np.ndarray:
    """The temperature (deg C) at which log10 a_T = ``log10_a`` for a shift referenced at
    ``reference_c``: the inverse of :func:`log10_shift` (WLF for log10_a <= 0, Arrhenius above).

    >>> from foldprint.model.materials import default_library
    >>> p = default_library()["H-1"].recovery
    >>> t = float(shift_temperature(30.0, -3.0, p)); round(float(log10_shift(t, 30.0, p)), 12)
    -3.0
    """
    ref = np.asarray(reference_c, float)
    x = float(log10_a)
    if x <= 0.0:
        if x <= -p.c1:
            raise MaterialError(f"log10 a_T = {x:.2f} is beyond the WLF limit -c1 = {-p.c1:g}: no temperature "
                                f"reaches it (raise c1 or shorten the spectrum's log10_tau_ref_s)")
        return ref + (-x * p.c2 / (p.c1 + x))
    rk = ref + _KELVIN
    return 1.0 / (1.0 / rk + x * p.c2 / (p.c1 * rk**2)) - _KELVIN


def reference_for_peak(tg_c, peak_log10: float, p: RecoveryParams) -> np.ndarray:
    """T_ref (deg C) with log10 a_T(Tg; T_ref) = ``peak_log10`` for each Tg of ``tg_c``: where
    the shift must be referenced for the model's tan delta peak to lie at Tg. The WLF branch
    (x* <= 0, the peak above T_ref) gives Tg - T_ref = -x* c2 / (c1 + x*); the Arrhenius branch
    (x* > 0) the positive root of (c1/c2) T_ref^2 (1/Tg - 1/T_ref) = x* (kelvin).

    >>> from foldprint.model.materials import default_library
    >>> p = default_library()["H-1"].recovery
    >>> float(reference_for_peak(50.0, 0.0, p))  # x* = 0: the peak at T_ref itself
    50.0
    """
    tg = np.asarray(tg_c, float)
    x, k = float(peak_log10), p.c1 / p.c2
    if x <= 0.0:
        return tg - (float(shift_temperature(0.0, x, p)))
    a = k / (tg + _KELVIN)  # a R^2 - k R - x = 0 for R = T_ref in K
    return (k + np.sqrt(k * k + 4.0 * a * x)) / (2.0 * a) - _KELVIN


@dataclass(frozen=True, eq=False)
class Viscoelastic:
    """A material's viscoelastic model: Tg (deg C, the 1 Hz tan delta peak), moduli (MPa),
    shift and spectrum (``params``: c1, c2, log10_tau_ref_s, spectrum_sigma_decades,
    spectrum_span_decades, n_branches of :class:`~foldprint.model.materials.RecoveryParams`)."""

    tg_c: float
    glassy_mpa: float
    rubbery_mpa: float
    params: RecoveryParams

    @property
    def peak_log10_shift(self) -> float:
        """x*: log10 a_T at the 1 Hz tan delta peak (:func:`peak_log10_shift`)."""
        return peak_log10_shift(self.params, float(self.glassy_mpa), float(self.rubbery_mpa))

    def reference_for(self, tg_c) -> np.ndarray:
        """The shift's reference temperature of this model moved to Tg ``tg_c`` (any shape: a
        scattered Tg moves the whole curve)."""
        return np.asarray(tg_c, float) - self.params.reference_below_tg_c

    @property
    def reference_c(self) -> float:
        """T_ref (deg C): the shift's reference temperature, Tg - ``reference_below_tg_c``."""
        return float(self.reference_for(self.tg_c))

    @property
    def tan_delta_peak_c(self) -> float:
        """The temperature (deg C) of the model's tan delta peak at the DMA's 1 Hz: the paper's
        definition of Tg, applied to the model."""
        return float(shift_temperature(self.reference_c, self.peak_log10_shift, self.params))

    @property
    def offset_for_peak_at_tg_c(self) -> float:
        """The ``reference_below_tg_c`` that would put this model's 1 Hz tan delta peak at its
        Tg (the paper's definition; what a material calibrated from its own DMA sweep sets)."""
        return self.tg_c - float(reference_for_peak(self.tg_c, self.peak_log10_shift, self.params))

    def log10_shift(self, temp_c) -> np.ndarray:
        """log10 a_T at ``temp_c`` (any shape)."""
        return log10_shift(np.asarray(temp_c, float), self.reference_c, self.params)

    def spectrum(self) -> tuple[np.ndarray, np.ndarray]:
        """tau_b (s, at T_ref) and g_b."""
        return spectrum(self.params)

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


@lru_cache(maxsize=1024)
def viscoelastic(material: Material) -> Viscoelastic:
    """The viscoelastic model of a hinge ``material``: its Tg, moduli and recovery parameters
    (shift and spectrum); the one place a model is built from the library."""
    if material.recovery is None or material.glassy_mpa is None or material.rubbery_mpa is None:
        raise MaterialError(f"material {material.name!r} (role {material.role}) has no viscoelastic model; "
                            "hinges need a hinge material such as H-1..H-7")
    return Viscoelastic(material.tg_c, material.glassy_mpa, material.rubbery_mpa, material.recovery)
