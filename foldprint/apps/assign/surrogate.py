"""The continuous search's timing side (:mod:`foldprint.apps.assign.continuous`, step 2):
materials of any Tg (the canonical ``VW0.xxx`` nearest to a Tg), the timing table of a
hinge against its Tg computed in one array pass per bath, the surrogate of the jam
probability (:func:`chain_risk`) and the Tg levels and bath that minimise it. No
simulation runs here (``docs/assign.md``, "Continuous fractions").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...model.composition import composition_model, parse_name, vero
from ...model.materials import Material, MaterialLibrary
from ...physics.recovery.batch import batch_ratios, grid_until
from ...simulation.robust import Scatter

#: Coarse bath grid step (C) and the golden-section tolerance of the refinement.
BATH_STEP_C = 2.5
BATH_TOL_C = 0.25


# -- materials of any Tg -------------------------------------------------------------------


def tg_bounds() -> tuple[float, float]:
    """The Tg interval (C) the composition model supports (that of H-1..H-7)."""
    lo, hi = composition_model().tg_supported_c
    return float(lo), float(hi)


def material_name(tg_c: float) -> str:
    """The canonical continuous material (``VW0.xxx``, :mod:`foldprint.model.composition`)
    nearest to Tg ``tg_c`` (clipped into the supported range)."""
    lo, hi = tg_bounds()
    model = composition_model()
    return vero(min(max(model.fraction(min(max(float(tg_c), lo), hi)), model.fraction_range[0]),
                    model.fraction_range[1]))


def canonical_tg(tg_c: float) -> float:
    """Tg (C) of the material :func:`material_name` names: what a written design holds."""
    return float(composition_model().tg_c(parse_name(material_name(tg_c)).knots[0]))


def synth_material(lib: MaterialLibrary, tg_c: float) -> Material:
    """The library's continuous hinge material nearest to Tg ``tg_c``."""
    return lib[material_name(tg_c)]


# -- the timing surrogate ---------------------------------------------------------------------


def _times_to(t: np.ndarray, ratio: np.ndarray, level: float) -> np.ndarray:
    """First time each row of ``ratio`` reaches ``level`` (linear between grid points; inf
    when it does not within ``t``)."""
    hit = ratio >= level
    idx = np.argmax(hit, axis=1)
    ok = hit[np.arange(len(idx)), idx]
    i1 = np.maximum(idx, 1)
    r0, r1 = ratio[np.arange(len(idx)), i1 - 1], ratio[np.arange(len(idx)), i1]
    with np.errstate(invalid="ignore", divide="ignore"):
        x = t[i1 - 1] + (level - r0) / (r1 - r0) * (t[i1] - t[i1 - 1])
    x = np.where(idx == 0, 0.0, x)
    return np.where(ok, x, np.inf)


@dataclass(frozen=True)
class TimingTable:
    """The timing of a hinge against its Tg at one bath and thickness, on a grid:
    ``log_t`` (n, 2) ln of the times to 50 % and 98 % (s; inf: not within the table's
    horizon), ``var`` (n, 2) their variances under the per-hinge scatter components (Tg,
    thickness, local h), ``shared`` (n, 2, 2) their shifts per sd of the shared components
    (rows: bath, the part's h). The same linearisation as
    :func:`foldprint.simulation.timing._time_spread` (finite differences of 0.5 C, 0.02 mm,
    0.1 in ln h, 0.5 C), computed for the whole grid in one array pass per variant."""

    bath_c: float
    thickness_mm: float
    horizon_s: float
    tg_c: np.ndarray
    log_t: np.ndarray
    var: np.ndarray
    shared: np.ndarray

    def splines(self):
        """Cubic splines of the table's columns in Tg (a time beyond the horizon read as
        e times the horizon: a hinge that misses the run for sure)."""
        from scipy.interpolate import CubicSpline

        lt = np.where(np.isfinite(self.log_t), self.log_t, math.log(self.horizon_s) + 1.0)
        y = np.concatenate([lt, self.var, self.shared.reshape(len(self.tg_c), 4)], axis=1)
        return CubicSpline(self.tg_c, y, axis=0)


def timing_table(lib: MaterialLibrary, bath_c: float, thickness_mm: float, fix_c: float, scatter: Scatter,
                 tg_grid: np.ndarray, horizon_s: float) -> TimingTable:
    """:class:`TimingTable` of the continuous materials of ``lib`` over ``tg_grid``."""
    mats = [synth_material(lib, tg) for tg in tg_grid]
    tg = np.array([m.tg_c for m in mats])
    p = mats[0].recovery
    t = grid_until(horizon_s)
    n = len(tg)
    h = np.full(n, p.h_w_m2k)
    th = np.full(n, float(thickness_mm))
    bath = np.full(n, float(bath_c))
    d_tg, d_th, d_ln_h, d_b = 0.5, 0.02, 0.1, 0.5
    variants = [(tg, h, th, bath), (tg + d_tg, h, th, bath), (tg, h, th + d_th, bath),
                (tg, h * math.exp(d_ln_h), th, bath), (tg, h, th, bath + d_b)]
    args = [np.concatenate(c) for c in zip(*variants)]
    ratio, _ = batch_ratios(p, *args, fix_c, t)
    logs = []
    for level in (0.5, 0.98):
        with np.errstate(divide="ignore"):
            logs.append(np.log(_times_to(t, ratio, level)).reshape(5, n))
    lt = np.stack(logs, axis=-1)  # (5 variants, n, 2)
    base = lt[0]
    with np.errstate(invalid="ignore"):
        dtg, dth, dh, db = ((lt[1] - base) / d_tg, (lt[2] - base) / d_th, (lt[3] - base) / d_ln_h,
                            (lt[4] - base) / d_b)
    var = np.nan_to_num((dtg * scatter.tg_sd_c) ** 2 + (dth * scatter.thickness_sd_mm) ** 2
                        + (dh * scatter.h_local_sigma_ln) ** 2, posinf=0.0)
    shared = np.nan_to_num(np.stack([db * scatter.bath_sd_c, dh * scatter.h_shared_sigma_ln], axis=1),
                           posinf=0.0, neginf=0.0)
    for a in (tg, base, var, shared):
        a.setflags(write=False)
    return TimingTable(float(bath_c), float(thickness_mm), float(horizon_s), tg, base, var, shared)


def _phi_upper(z):
    from scipy.special import ndtr

    return ndtr(-np.asarray(z, float))


def chain_risk(values: np.ndarray, log_duration: float) -> float:
    """The surrogate of the jam probability of hinges that should recover in the order of
    ``values``' rows (each row from :meth:`TimingTable.splines`: ln t50, ln t98, their
    per-hinge variances, the shared shifts): the expected number of pairs (a, b), a before
    b in the chain, whose half recovery scatter reverses, Phi(-(ln t50_b - ln t50_a) / sd),
    plus the number of pairs times the chance that some hinge misses 98 % within the run.
    Signed: a chain ordered against its levels is penalised, so the optimiser keeps it."""
    v = np.asarray(values, float)
    n = len(v)
    pairs = n * (n - 1) / 2
    lt50, lt98, var50, var98 = v[:, 0], v[:, 1], np.maximum(v[:, 2], 0), np.maximum(v[:, 3], 0)
    sh = v[:, 4:8].reshape(n, 2, 2)  # (hinge, component, [t50, t98])
    sd98 = np.sqrt(var98 + np.sum(sh[:, :, 1] ** 2, axis=1))
    miss = _phi_upper((log_duration - lt98) / np.maximum(sd98, 1e-12))
    risk = pairs * (1.0 - float(np.prod(1.0 - miss)))
    a, b = np.triu_indices(n, 1)
    sd = np.sqrt(var50[a] + var50[b] + np.sum((sh[a, :, 0] - sh[b, :, 0]) ** 2, axis=1))
    risk += float(np.sum(_phi_upper((lt50[b] - lt50[a]) / np.maximum(sd, 1e-12))))
    return risk


@dataclass(frozen=True)
class Levels:
    """Optimised Tg levels (C, in chain order, as materials store them) at a bath, and
    their surrogate risk."""

    bath_c: float
    tg_c: tuple[float, ...]
    risk: float


def optimise_levels(table: TimingTable, n: int, lo: float, hi: float, log_duration: float) -> Levels:
    """The ``n`` Tg levels in [lo, hi] of least :func:`chain_risk` at ``table``'s bath
    (L-BFGS-B from evenly spaced levels and from levels evenly spaced in ln t50)."""
    from scipy.optimize import minimize

    spl = table.splines()

    def f(x):
        return chain_risk(spl(np.clip(x, lo, hi)), log_duration)

    starts = [np.linspace(lo, hi, n)]
    # evenly spaced in ln t50 over the levels that finish within the run
    grid = np.linspace(lo, hi, 200)
    vals = spl(grid)
    ok = vals[:, 1] < log_duration
    if ok.any() and n > 1:
        g, l50 = grid[ok], vals[ok, 0]
        target = np.linspace(l50[0], l50[-1], n)
        starts.append(np.interp(target, l50, g))
    best = None
    for x0 in starts:
        r = minimize(f, x0, method="L-BFGS-B", bounds=[(lo, hi)] * n)
        x = np.sort(np.clip(r.x, lo, hi))
        tg = tuple(canonical_tg(v) for v in x)
        risk = f(np.array(tg))
        if best is None or risk < best.risk - 1e-12:
            best = Levels(table.bath_c, tg, risk)
    return best


def optimise_bath(make_table: Callable[[float], TimingTable], n: int, lo: float, hi: float, log_duration: float,
                  bath_lo: float, bath_hi: float) -> tuple[Levels, dict[float, Levels]]:
    """The bath in [bath_lo, bath_hi] (and its levels) of least surrogate risk: a grid
    every :data:`BATH_STEP_C` at most, then golden-section search in the best bracket to
    :data:`BATH_TOL_C`. Returns the best and every bath tried."""
    tried: dict[float, Levels] = {}

    def at(b: float) -> Levels:
        b = round(float(b), 3)
        if b not in tried:
            tried[b] = optimise_levels(make_table(b), n, lo, hi, log_duration)
        return tried[b]

    if bath_hi - bath_lo < 1e-9:
        return at(bath_lo), tried
    k = max(1, int(math.ceil((bath_hi - bath_lo) / BATH_STEP_C - 1e-9)))
    grid = np.linspace(bath_lo, bath_hi, k + 1)
    risks = [at(b).risk for b in grid]
    i = int(np.argmin(risks))
    a, c = grid[max(0, i - 1)], grid[min(k, i + 1)]
    g = (math.sqrt(5) - 1) / 2
    x1, x2 = c - g * (c - a), a + g * (c - a)
    while c - a > BATH_TOL_C:
        if at(x1).risk <= at(x2).risk:
            c, x2 = x2, x1
            x1 = c - g * (c - a)
        else:
            a, x1 = x1, x2
            x2 = a + g * (c - a)
    best = min(tried.values(), key=lambda lv: (lv.risk, lv.bath_c))
    return best, tried
