"""Fold times of one hinge material over many bath temperatures at once (for charts).

The same model and internal time grid as :func:`foldprint.physics.recovery.curve.recovery_curve`, the
work shared between baths: the slab's dimensionless temperature does not depend on the
bath (T = Tb - (Tb - T0)(1 - s(t, z))), the shift and the reduced time are evaluated for
every bath in one array, and the relaxation sum, the expensive part, only where the 98 %
crossing is searched (every ``_STRIDE``-th grid time, then the one block that brackets it).
The answer equals ``recovery_curve(...).fold_time`` (same grid, same interpolation).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ...core.constants import DEFAULT_FIX_C, DEFAULT_THICKNESS_MM, FOLD_LEVEL, RECOVERY_HORIZON_S
from ...model.materials import Material
from ..viscoelastic import viscoelastic
from .curve import N_LAYERS, curve_time_grid, slab_temperature

_STRIDE = 64


def _ratio(xi: np.ndarray, tau: np.ndarray, g: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Recovery ratio from reduced times xi (..., n_z): 1 - sum_b g_b exp(-xi / tau_b), bending-weighted."""
    unrecovered = np.zeros_like(xi)
    for tb, gb in zip(tau, g):
        unrecovered += gb * np.exp(-xi / tb)
    return np.clip(1.0 - unrecovered @ w, 0.0, 1.0)


@lru_cache(maxsize=64)
def _fold_times(material: Material, baths: tuple[float, ...], thickness_mm: float, initial_c: float,
                horizon_s: float, level: float) -> tuple[float | None, ...]:
    p = material.recovery
    t = curve_time_grid(horizon_s)
    zg, wg = np.polynomial.legendre.leggauss(N_LAYERS)
    s = slab_temperature(t, zg, 1.0, 0.0, thickness_mm, p)  # (n_t, n_z): 1 - theta
    tb = np.asarray(baths, float)[:, None, None]
    temp = tb - (tb - initial_c) * (1.0 - s[None])  # (n_b, n_t, n_z)
    model = viscoelastic(material)
    rate = 10.0 ** (-model.log10_shift(temp))
    xi = np.zeros_like(rate)
    xi[:, 1:] = np.cumsum(0.5 * (rate[:, 1:] + rate[:, :-1]) * np.diff(t)[None, :, None], axis=1)
    tau, g = model.spectrum()
    w = wg * zg**2
    w = w / w.sum()
    coarse = np.arange(0, len(t), _STRIDE)
    if coarse[-1] != len(t) - 1:
        coarse = np.append(coarse, len(t) - 1)
    out: list[float | None] = []
    for b in range(len(baths)):
        rc = np.maximum.accumulate(_ratio(xi[b, coarse], tau, g, w))
        k = int(np.argmax(rc >= level))
        if rc[k] < level:
            out.append(None)
            continue
        if k == 0:
            out.append(0.0)
            continue
        lo, hi = coarse[k - 1], coarse[k]
        r = np.maximum.accumulate(np.maximum(_ratio(xi[b, lo:hi + 1], tau, g, w), rc[k - 1]))
        j = int(np.argmax(r >= level))
        r0, r1, t0, t1 = r[j - 1], r[j], t[lo + j - 1], t[lo + j]
        out.append(float(t0 + (level - r0) / (r1 - r0) * (t1 - t0)))
    return tuple(out)


def fold_times(material: Material, baths, thickness_mm: float = DEFAULT_THICKNESS_MM, initial_c: float = DEFAULT_FIX_C,
               horizon_s: float = RECOVERY_HORIZON_S, level: float = FOLD_LEVEL) -> list[float | None]:
    """Time (s) to ``level`` recovery at each bath temperature (deg C) of ``baths``; None
    where the hinge does not get there within the horizon. Cached per arguments."""
    return list(_fold_times(material, tuple(float(b) for b in baths), float(thickness_mm),
                            float(initial_c), float(horizon_s), float(level)))
