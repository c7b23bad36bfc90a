"""Recovery curves of many hinges of one material at once (the Monte-Carlo's hot path).

:func:`batch_ratios` returns, for ``n`` hinges that share a material's recovery model
but each have their own Tg, heat-transfer coefficient, thickness and bath temperature,
the recovery ratio on the internal grid of :func:`foldprint.physics.recovery.recovery_curve`,
up to a given time. It computes the same model as :func:`foldprint.physics.recovery._curve`,
in the same order (up to the order of floating-point sums), and is cheaper four ways:

* **causal truncation**: everything in the model is causal (the slab solution at time
  t, the reduced time as a running trapezoid sum, the running maximum), so the curve on
  the grid points up to ``until_s`` does not depend on the later ones. A fold of 20 s
  needs 5 000 of the 15 400 points of the 600 s horizon;
* **negligible terms skipped, element by element**: a slab series term with
  Fo zeta^2 > :data:`CUT` or a relaxation branch with xi / tau > :data:`CUT` is
  below exp(-50) = 2e-22 and is set to exactly 0 (its exponent clamped first, which
  avoids the slow underflow path of ``exp``); it is not computed at all past the time
  every hinge of the batch has left it behind. The test is per element, so a curve does
  not depend on the other curves of its batch (nor on how samples are chunked);
* **half the layers**: the slab is heated from both faces alike, so the temperature of
  the Gauss point at -z equals that at +z; the 8 points are 4 pairs, each computed once
  and weighted twice;
* **one array pass for all hinges**: the roots of the slab's eigen-equation are a
  vectorised bisection, the shift, reduced time and relaxation sum one array expression
  over ``(n, n_t, n_z)``; no BLAS call (no thread pools to fight worker processes).

The difference to the exact per-curve path is round-off: measured max |dR| = 3.3e-16,
asserted < 1e-12 (``tests/test_recovery_batch.py``); the fold verdicts of the two paths
agree sample by sample (``benchmarks/bench_robust.py``).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..core.constants import RECOVERY_HORIZON_S
from ..model.materials import RecoveryParams
from .recovery import N_LAYERS, N_TERMS, curve_time_grid, combine_strips, is_graded, spectrum, strip_tgs

#: Exponent beyond which a series term or relaxation branch is dropped (exp(-50) = 2e-22).
CUT = 50.0
#: Elements (hinges x grid times x layers) of one batch's arrays: bounds the memory of a
#: batch to a few x 8 x this bytes (about 100 MB), whatever the number of hinges.
MAX_BATCH_ELEMENTS = 2_000_000

_LN10 = math.log(10.0)


@lru_cache(maxsize=8)
def _full_grid(horizon_s: float) -> np.ndarray:
    g = curve_time_grid(horizon_s)
    g.setflags(write=False)
    return g


def grid_until(until_s: float, horizon_s: float = RECOVERY_HORIZON_S) -> np.ndarray:
    """The recovery model's internal grid (the one of ``recovery_curve``), cut after the
    first point at or beyond ``until_s`` (the whole grid when ``until_s`` is past it)."""
    g = _full_grid(float(horizon_s))
    k = int(np.searchsorted(g, until_s, side="left"))
    return g[: min(len(g), k + 2)]


def _rate(temp: np.ndarray, tg: np.ndarray, p: RecoveryParams) -> np.ndarray:
    """1 / a_T = exp(-ln 10 log10 a_T) of :func:`foldprint.physics.recovery.log10_shift`,
    the same operations on the same values (bitwise equal) in place, and Arrhenius only
    where it is taken (below Tg): the batch's largest arrays are not allocated again for
    each term."""
    d = temp - tg
    out = np.maximum(d, 0.0)
    out += p.c2
    np.divide(d * (-p.c1), out, out=out)  # WLF: -c1 d / (c2 + max(d, 0))
    below = d < 0.0
    if below.any():
        tgk = tg + 273.15
        arr = temp + 273.15
        np.divide(1.0, arr, out=arr)
        arr -= 1.0 / tgk
        arr *= (p.c1 / p.c2) * tgk**2  # Arrhenius: (c1 / c2) Tg^2 (1 / T - 1 / Tg), in K
        np.copyto(out, arr, where=below)
    out *= -_LN10
    return np.exp(out, out=out)


def slab_roots(biot: np.ndarray, n: int = N_TERMS) -> np.ndarray:
    """Positive roots of zeta tan zeta = Bi for every Bi of ``biot`` (m,), shape (m, n):
    the bisection of :func:`foldprint.physics.recovery._slab_roots` on arrays, stopped when every
    bracket has shrunk to neighbouring floats (from there on it no longer changes)."""
    biot = np.asarray(biot, float)[:, None]
    k = np.arange(n, dtype=float)[None, :]
    lo = np.broadcast_to(k * math.pi + 1e-12, (biot.shape[0], n)).copy()
    hi = np.broadcast_to(k * math.pi + math.pi / 2 - 1e-12, (biot.shape[0], n)).copy()
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if np.all((mid == lo) | (mid == hi)):
            break
        up = mid * np.tan(mid) - biot > 0
        hi = np.where(up, mid, hi)
        lo = np.where(up, lo, mid)
    return 0.5 * (lo + hi)


def material_batch_ratios(material, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c: float,
                          t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`batch_ratios` for ``n`` hinges of ``material`` (Tg ``tg_c`` per hinge, at the
    mean fraction for a graded material): a graded hinge is its strips
    (:func:`foldprint.physics.recovery.strip_tgs`) in one batch, combined by
    :func:`foldprint.physics.recovery.combine_strips`."""
    p = material.recovery
    if not is_graded(material):
        return batch_ratios(p, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c, t)
    tg = np.asarray(tg_c, float)
    n = tg.shape[0]
    tgs, w = strip_tgs(material, tg)  # (n, S)
    s = tgs.shape[1]
    rep = [np.repeat(np.broadcast_to(np.asarray(a, float), (n,)), s) for a in (h_w_m2k, thickness_mm, bath_c)]
    ratio, mean_t = batch_ratios(p, tgs.ravel(), rep[0], rep[1], rep[2], initial_c, t)
    ratio = ratio.reshape(n, s, -1).transpose(1, 0, 2)  # (S, n, n_t)
    eff = combine_strips(ratio, w, material.profile.along)
    eff = np.maximum.accumulate(np.clip(eff, 0.0, 1.0), axis=-1)
    return eff, mean_t.reshape(n, s, -1)[:, 0, :]


def batch_ratios(p: RecoveryParams, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c: float,
                 t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Recovery ratio and mean temperature, each (n, len(t)), of ``n`` hinges of the
    recovery model ``p`` (its ``h_w_m2k`` replaced by the given one per hinge), with Tg
    ``tg_c``, thickness ``thickness_mm`` (mm) and bath ``bath_c`` (deg C) per hinge, all
    starting at ``initial_c``, at the times ``t`` (a prefix of the model's grid,
    :func:`grid_until`). Inputs are validated by the caller (finite, thickness > 0)."""
    tg = np.asarray(tg_c, float)
    n = tg.shape[0]
    hw = np.broadcast_to(np.asarray(h_w_m2k, float), (n,))
    th = np.broadcast_to(np.asarray(thickness_mm, float), (n,))
    bath = np.broadcast_to(np.asarray(bath_c, float), (n,))
    t = np.asarray(t, float)
    per = max(1, MAX_BATCH_ELEMENTS // max(1, len(t) * N_LAYERS // 2))
    if n > per:  # bounded memory: batches of at most MAX_BATCH_ELEMENTS elements
        parts = [batch_ratios(p, tg[a:a + per], hw[a:a + per], th[a:a + per], bath[a:a + per], initial_c, t)
                 for a in range(0, n, per)]
        return np.concatenate([r for r, _ in parts]), np.concatenate([m for _, m in parts])
    zg8, wg8 = np.polynomial.legendre.leggauss(N_LAYERS)
    half_n = N_LAYERS // 2  # symmetric points: zg8[half_n + i] == -zg8[half_n - 1 - i]
    zg = zg8[half_n:]
    w8 = wg8 * zg8**2  # bending (second-moment) weight of each layer
    w8 = w8 / w8.sum()
    w = w8[half_n:] + w8[:half_n][::-1]
    m8 = wg8 / wg8.sum()
    wm = m8[half_n:] + m8[:half_n][::-1]

    # 1. slab temperature: theta = sum_j coef_j exp(-Fo zeta_j^2) cos(zeta_j z)
    half = th * 1e-3 / 2.0
    alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
    zeta = slab_roots(hw * half / p.k_w_mk)  # (n, terms)
    coef = 4.0 * np.sin(zeta) / (2.0 * zeta + np.sin(2.0 * zeta))
    fo = alpha * t[None, :] / (half**2)[:, None]  # (n, n_t), rising in t
    theta = np.zeros((n, len(t), half_n))
    for j in range(zeta.shape[1]):
        z2 = zeta[:, j] ** 2
        # the term is negligible from the first time Fo zeta^2 > CUT on: compute the prefix
        k = int(np.max(np.searchsorted(t, CUT * half**2 / (alpha * z2), side="right")))
        if k == 0:
            break
        arg = fo[:, :k] * z2[:, None]
        mode = np.exp(-np.minimum(arg, CUT))
        mode *= arg <= CUT  # exactly 0 past the cut, element by element
        shape = np.cos(zg[None, :] * zeta[:, j:j + 1]) * coef[:, j:j + 1]  # (n, n_z)
        theta[:, :k, :] += mode[:, :, None] * shape[:, None, :]
    theta[:, t <= 0, :] = 1.0
    temp = bath[:, None, None] - (bath - initial_c)[:, None, None] * np.clip(theta, 0.0, 1.0)

    # 2. reduced time: xi = int dt / a_T(T)
    rate = _rate(temp, tg[:, None, None], p)
    xi = np.zeros_like(rate)
    np.cumsum(0.5 * (rate[:, 1:] + rate[:, :-1]) * np.diff(t)[None, :, None], axis=1, out=xi[:, 1:])

    # 3. relaxation: 1 - sum_b g_b exp(-xi / tau_b), bending-weighted over the layers
    tau, g = spectrum(p)
    xmin = xi.min(axis=(0, 2))  # rising in t: branch b is negligible everywhere past CUT tau_b
    unrecovered = np.zeros_like(xi)
    x, e = np.empty_like(xi), np.empty_like(xi)
    keep = np.empty(xi.shape, dtype=bool)
    for tb, gb in zip(tau, g):
        k = int(np.searchsorted(xmin, CUT * tb, side="right"))
        if k == 0:
            continue
        xk, ek, kk = x[:, :k], e[:, :k], keep[:, :k]
        np.multiply(xi[:, :k], -1.0 / tb, out=xk)
        np.greater_equal(xk, -CUT, out=kk)
        # exp only where kept; exactly 0 past the cut, element by element (the exponent
        # is never below -CUT there: no slow underflow path)
        ek[...] = 0.0
        np.exp(xk, out=ek, where=kk)
        ek *= gb
        unrecovered[:, :k] += ek
    ratio = np.clip(1.0 - np.einsum("ntz,z->nt", unrecovered, w), 0.0, 1.0)
    ratio = np.maximum.accumulate(ratio, axis=1)
    mean_t = np.einsum("ntz,z->nt", temp, wm)
    return ratio, mean_t
