"""Hinge recovery R(t; material, bath temperature, hinge thickness).

Physically grounded, three parts (equations and calibration: ``docs/recovery-model.md``):

1. **Heat transfer.** The hinge is a slab of thickness ``h`` dropped at ``T0`` into a
   bath at ``Tb``; both faces see a heat-transfer coefficient ``h_w_m2k``. The exact
   series solution of 1-D conduction with Robin boundaries gives the temperature at
   Gauss points through the thickness.
2. **Time-temperature superposition** of the material's viscoelastic model
   (:func:`foldprint.physics.viscoelastic.viscoelastic`: WLF above its reference temperature,
   Arrhenius below, the reference set so that the model's 1 Hz tan delta peaks at Tg). Each
   layer accumulates reduced time xi(t) = integral dt / a_T(T(z, t)).
3. **Relaxation spectrum.** A Prony series of ``n_branches`` (16, as the paper's
   multi-branch model) drives free recovery: R_layer = 1 - sum_b g_b exp(-xi / tau_b).
   The hinge's recovery ratio is the bending-weighted (z^2) mean over the layers.

Curves are computed once per (material, bath, thickness, initial temperature) on an
internal grid and cached; evaluating them at any times is one ``np.interp``.

A graded hinge (a ``VW...@width`` / ``@length`` material, ``docs/composition.md``) is a set of
strips, each a uniform hinge at its own Tg (:func:`strip_tgs`); :func:`combine_strips` gives
the hinge's effective recovery: the weighted mean of the strips' ratios across the width
(series strips, curvatures add), the stiffness-weighted mean along the length (parallel
strips sharing one curvature).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from ...core.constants import DEFAULT_FIX_C, DEFAULT_THICKNESS_MM, FOLD_LEVEL, ONSET_LEVEL, RECOVERY_HORIZON_S
from ...core.errors import MaterialError
from ...model.composition import Along, composition_model, strips
from ...model.materials import Material, RecoveryParams
from ..viscoelastic import log10_shift, spectrum, viscoelastic  # noqa: F401  (log10_shift: re-exported)

N_TERMS = 40  # series terms of the slab solution (converged for Fo > ~1e-3)
N_LAYERS = 8  # Gauss-Legendre points through the thickness
_DT_FINE = 0.004  # s, internal step over the first _T_FINE seconds
_T_FINE = 60.0  # s


def _slab_roots(biot: float, n: int = N_TERMS) -> np.ndarray:
    """Positive roots of zeta * tan(zeta) = Bi, one in each (k pi, k pi + pi/2)."""
    roots = np.empty(n)
    for k in range(n):
        lo, hi = k * math.pi + 1e-12, k * math.pi + math.pi / 2 - 1e-12
        f = lambda z: z * math.tan(z) - biot  # noqa: E731
        for _ in range(200):  # bisection: f is increasing on the bracket
            mid = 0.5 * (lo + hi)
            if f(mid) > 0:
                hi = mid
            else:
                lo = mid
        roots[k] = 0.5 * (lo + hi)
    return roots


def slab_temperature(t: np.ndarray, z_frac: np.ndarray, bath_c: float, initial_c: float,
                     thickness_mm: float, p: RecoveryParams) -> np.ndarray:
    """Temperature (deg C) at times ``t`` (n_t,) s and positions ``z_frac`` (n_z,)
    in [-1, 1] of the half-thickness; returns (n_t, n_z)."""
    half = thickness_mm * 1e-3 / 2.0
    alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
    biot = p.h_w_m2k * half / p.k_w_mk
    zeta = _slab_roots(biot)
    coef = 4.0 * np.sin(zeta) / (2.0 * zeta + np.sin(2.0 * zeta))
    fo = alpha * np.asarray(t, float) / half**2
    modes = np.exp(-np.outer(fo, zeta**2))  # (n_t, n_terms)
    shape = np.cos(np.outer(np.abs(z_frac), zeta)) * coef  # (n_z, n_terms)
    theta = modes @ shape.T  # (n_t, n_z) dimensionless excess temperature
    theta[np.asarray(t) <= 0] = 1.0  # the series converges slowly at t = 0 exactly
    return bath_c - (bath_c - initial_c) * np.clip(theta, 0.0, 1.0)


@dataclass(frozen=True, eq=False)
class RecoveryCurve:
    """A hinge's recovery ratio on the model's internal time grid.

    ``t`` (n,) s and ``ratio`` (n,) in [0, 1]; ``mean_temperature_c`` (n,) is the
    hinge's mean temperature, for plots.
    """

    material: str
    tg_c: float
    bath_c: float
    thickness_mm: float
    initial_c: float
    t: np.ndarray
    ratio: np.ndarray
    mean_temperature_c: np.ndarray

    def __call__(self, t) -> np.ndarray:
        """Recovery ratio at times ``t`` (any shape, s); R = 0 before t = 0, and the last
        value is held past the model horizon."""
        return np.interp(np.asarray(t, float), self.t, self.ratio, left=0.0)

    def time_to(self, level: float) -> float | None:
        """First time (s) the ratio reaches ``level``; None if not within the horizon."""
        idx = int(np.argmax(self.ratio >= level))
        if self.ratio[idx] < level:
            return None
        if idx == 0:
            return 0.0
        r0, r1 = self.ratio[idx - 1], self.ratio[idx]
        t0, t1 = self.t[idx - 1], self.t[idx]
        return float(t0 + (level - r0) / (r1 - r0) * (t1 - t0))

    @property
    def fold_time(self) -> float | None:
        """Time to 98 % recovery (s), or None: the hinge does not fold within the horizon."""
        return self.time_to(FOLD_LEVEL)

    @property
    def onset_time(self) -> float | None:
        """Time to 5 % recovery (s), or None."""
        return self.time_to(ONSET_LEVEL)

    @property
    def horizon_s(self) -> float:
        return float(self.t[-1])


def curve_time_grid(horizon_s: float) -> np.ndarray:
    """The times (s) a recovery curve is tabulated at up to ``horizon_s``: steps of
    ``_DT_FINE`` to ``_T_FINE``, then 400 geometrically spaced."""
    fine_end = min(_T_FINE, horizon_s)
    fine = np.arange(0.0, fine_end + _DT_FINE / 2, _DT_FINE)
    if horizon_s <= fine_end:
        return fine
    coarse = np.geomspace(fine_end, horizon_s, 400)[1:]
    return np.concatenate([fine, coarse])


def is_graded(material: Material) -> bool:
    """True for a material whose VeroWhite fraction varies inside the hinge."""
    return material.profile is not None and not material.profile.uniform


def strip_tgs(material: Material, tg_c=None) -> tuple[np.ndarray, np.ndarray]:
    """Tg (deg C) and quadrature weight of each strip of a graded ``material``.

    ``tg_c`` (default ``material.tg_c``; an array gives one row per value) is the hinge's
    Tg at its mean fraction; a shift of it (Monte-Carlo Tg scatter) shifts every strip alike.
    Returns (tg (..., S), weights (S,))."""
    model = composition_model()
    u, w = strips(material.profile)
    base = model._tg(material.profile.at(u))  # (S,)
    offset = np.asarray(material.tg_c if tg_c is None else tg_c, float) - float(model._tg(material.profile.mean))
    return offset[..., None] + base, w


def combine_strips(ratios: np.ndarray, weights: np.ndarray, along: Along,
                   stiffness_ratio: float | None = None) -> np.ndarray:
    """Effective recovery ratio of strips ``ratios`` (S, ...) with weights (S,).

    WIDTH (strips in series, their curvatures add): the weighted mean. LENGTH (parallel strips
    sharing one curvature): the mean weighted also by each strip's stiffness, taken as
    rubbery + glassy x unrecovered part: E_i / E_r = 1 + (r - 1) (1 - R_i), r the composition
    model's ``stiffness_ratio`` (the unrecovered, glassy strip holds the hinge back)."""
    ratios = np.asarray(ratios, float)
    w = np.asarray(weights, float).reshape((-1,) + (1,) * (ratios.ndim - 1))
    if along is Along.WIDTH:
        return np.sum(w * ratios, axis=0)
    r = composition_model().stiffness_ratio if stiffness_ratio is None else float(stiffness_ratio)
    k = w * (1.0 + (r - 1.0) * (1.0 - ratios))
    return np.sum(k * ratios, axis=0) / np.sum(k, axis=0)


def _graded_curve(material: Material, bath_c: float, thickness_mm: float, initial_c: float,
                  horizon_s: float) -> RecoveryCurve:
    tgs, w = strip_tgs(material)
    subs = [_curve(replace(material, tg_c=float(tg), profile=None), bath_c, thickness_mm, initial_c, horizon_s)
            for tg in tgs]
    ratio = combine_strips(np.array([c.ratio for c in subs]), w, material.profile.along)
    ratio = np.maximum.accumulate(np.clip(ratio, 0.0, 1.0))
    ratio.setflags(write=False)
    return RecoveryCurve(material.name, material.tg_c, float(bath_c), float(thickness_mm), float(initial_c),
                         subs[0].t, ratio, subs[0].mean_temperature_c)


@lru_cache(maxsize=512)
def _curve(material: Material, bath_c: float, thickness_mm: float, initial_c: float,
           horizon_s: float) -> RecoveryCurve:
    if is_graded(material):
        return _graded_curve(material, bath_c, thickness_mm, initial_c, horizon_s)
    p = material.recovery
    model = viscoelastic(material)
    t = curve_time_grid(horizon_s)
    zg, wg = np.polynomial.legendre.leggauss(N_LAYERS)
    temp = slab_temperature(t, zg, bath_c, initial_c, thickness_mm, p)  # (n_t, n_z)
    rate = 10.0 ** (-model.log10_shift(temp))  # d xi / d t
    xi = np.zeros_like(rate)
    xi[1:] = np.cumsum(0.5 * (rate[1:] + rate[:-1]) * np.diff(t)[:, None], axis=0)
    tau, g = model.spectrum()
    unrecovered = np.zeros_like(xi)
    for tb, gb in zip(tau, g):  # loop over 16 branches keeps memory at (n_t, n_z)
        unrecovered += gb * np.exp(-xi / tb)
    w = wg * zg**2  # bending (second-moment) weight of each layer
    w = w / w.sum()
    ratio = np.clip(1.0 - unrecovered @ w, 0.0, 1.0)
    ratio = np.maximum.accumulate(ratio)  # monotone by construction; remove round-off
    for arr in (t, ratio):
        arr.setflags(write=False)
    mean_t = temp @ (wg / wg.sum())
    mean_t.setflags(write=False)
    return RecoveryCurve(material.name, material.tg_c, float(bath_c), float(thickness_mm),
                         float(initial_c), t, ratio, mean_t)


def recovery_curve(material: Material, bath_c: float, thickness_mm: float = DEFAULT_THICKNESS_MM,
                   initial_c: float = DEFAULT_FIX_C, horizon_s: float = RECOVERY_HORIZON_S) -> RecoveryCurve:
    """The (cached) recovery curve of a hinge of ``material`` and ``thickness_mm`` that
    starts at ``initial_c`` (the fixing temperature of the programming protocol) and is
    dropped into a bath at ``bath_c``."""
    if material.recovery is None:
        raise MaterialError(
            f"material {material.name!r} (role {material.role}) has no recovery model; "
            "hinges need a hinge material such as H-1..H-7")
    for name, v in (("bath temperature", bath_c), ("hinge thickness", thickness_mm),
                    ("initial temperature", initial_c), ("horizon", horizon_s)):
        if not math.isfinite(v):
            raise MaterialError(f"{name} must be finite, got {v}")
    if thickness_mm <= 0:
        raise MaterialError(f"hinge thickness must be > 0 mm, got {thickness_mm}")
    if horizon_s <= 0:
        raise MaterialError(f"horizon must be > 0 s, got {horizon_s}")
    return _curve(material, float(bath_c), float(thickness_mm), float(initial_c), float(horizon_s))


def recovery_ratio(t, material: Material, bath_c: float, thickness_mm: float = DEFAULT_THICKNESS_MM,
                   initial_c: float = DEFAULT_FIX_C) -> np.ndarray:
    """R(t) for times ``t`` (s), vectorised."""
    return recovery_curve(material, bath_c, thickness_mm, initial_c)(t)


def hinge_fold_times(design, library=None) -> dict[str, float | None]:
    """Each hinge's 98 % recovery time (s) in the design's bath, None where it does not
    fold within the model horizon: what an export's manifest reports (the exporter is
    given these; it does not run the recovery model)."""
    from ...model.materials import default_library

    lib = library or default_library()
    pr = design.process
    return {h.id: fold_time(lib[h.material], pr.bath_temperature_c, h.thickness, pr.fix_temperature_c)
            for h in design.hinges}


def fold_time(material: Material, bath_c: float, thickness_mm: float = DEFAULT_THICKNESS_MM,
              initial_c: float = DEFAULT_FIX_C, level: float = FOLD_LEVEL) -> float | None:
    """Time (s) to reach ``level`` recovery, or None when the hinge does not fold
    within the model horizon (e.g. a bath below the material's Tg)."""
    return recovery_curve(material, bath_c, thickness_mm, initial_c).time_to(level)
