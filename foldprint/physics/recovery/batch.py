"""Recovery curves of many hinges of one material at once (the Monte-Carlo's hot path).

:func:`batch_ratios` returns, for ``n`` hinges that share a material's recovery model
but each have their own Tg, heat-transfer coefficient, thickness and bath temperature,
the recovery ratio on the internal grid of :func:`foldprint.physics.recovery.curve.recovery_curve`,
up to a given time. It computes the model of :func:`foldprint.physics.recovery.curve._curve`
(slab temperature, reduced time, relaxation) with one approximation, the relaxation
table, and is cheaper these ways:

* **causal truncation**: everything in the model is causal (the slab solution at time
  t, the reduced time as a running trapezoid sum, the running maximum), so the curve on
  the grid points up to ``until_s`` does not depend on the later ones. A fold of 20 s
  needs 5 000 of the 15 400 points of the 600 s horizon;
* **half the layers**: the slab is heated from both faces alike, so the temperature of
  the Gauss point at -z equals that at +z; the 8 points are 4 pairs, each computed once
  and weighted twice;
* **block by block of the time axis**: (hinge, layer pair, time) arrays of
  :data:`BLOCK_ELEMENTS` elements, time contiguous, in working arrays reused from block
  to block and batch to batch (they stay in the cache and cost no page faults); the
  reduced time and the rate are carried from one block to the next, and the running sum
  is taken in groups of :data:`SUM_GROUP` times aligned on the grid, so a value does not
  depend on where blocks end;
* **negligible terms skipped, element by element**: a slab series term with
  Fo zeta^2 > :data:`CUT` or a relaxation branch with xi / tau > :data:`CUT` is
  below exp(-50) = 2e-22 and is set to exactly 0 (its exponent clamped first, which
  avoids the slow underflow path of ``exp``); a block skips the terms and branches cut
  in all of it. The test is per element, so a curve does not depend on the other curves
  of its batch (nor on how samples are chunked);
* **the relaxation sum from a table**: U(xi) = sum_b g_b exp(-xi / tau_b) depends only
  on the spectrum and the scalar xi, so it is tabulated once per spectrum at steps of
  :data:`~foldprint.core.constants.RELAXATION_TABLE_STEP` in ln xi
  (:func:`relaxation_table`) and read by linear interpolation: one log and one
  interpolation per element instead of up to 16 exponentials. Only where asked for
  (``table=True``: the Monte-Carlo's :func:`foldprint.simulation.robust.sample_drives`);
  by default the exponentials are summed (calibration, assignment);
* the roots of the slab's eigen-equation for all hinges at once (Newton's method); no
  BLAS call (no thread pools to fight worker processes).

Error: the table's, max |dR| = 5.5e-9 measured over the templates' spectrum and reduced
times 1e-20..1e12, asserted < 2e-8 (``tests/test_recovery_batch.py``); every template's
Monte-Carlo outcomes (jammed, reason, pair) are those of the exact sum sample by sample
(``benchmarks/bench_relaxation_table.py``). Without the table the difference to the
per-curve path is round-off: measured max |dR| = 2e-15, asserted < 1e-12.

The working arrays and the relaxation table are in
:mod:`foldprint.physics.recovery.relaxation`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...core.constants import RECOVERY_HORIZON_S
from ...core.jit import use_kernels
from ...model.materials import RecoveryParams
from ..viscoelastic import spectrum
from .curve import N_LAYERS, N_TERMS, curve_time_grid, combine_strips, is_graded, strip_tgs
from .relaxation import CUT, Block, Buffers, RelaxationTable, relaxation_table, table_block

#: Elements (hinges x grid times x layer pairs) of one batch: a larger batch is computed
#: in parts of at most this many (bounds its per-hinge arrays, whatever the number of hinges).
MAX_BATCH_ELEMENTS = 2_000_000
#: Elements (hinges x layer pairs x times) of one block of the time axis: our choice, the
#: fastest of 16 Ki..128 Ki elements in one measurement (32 Ki and 128 Ki within 10 % of
#: it); much larger blocks' ten working arrays no longer stay in the cache.
BLOCK_ELEMENTS = 1 << 16
#: Times summed as one group in the running sum of the reduced time (the prefix sums inside
#: the groups run for all groups at once): our choice, 2.6 ns an element against 3.8 for
#: one running sum (4 and 16 no faster, 32 and 64 slower).
SUM_GROUP = 8

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


def _rate(temp: np.ndarray, ref: np.ndarray, p: RecoveryParams, out: np.ndarray | None = None,
          work: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """1 / a_T = exp(-ln 10 log10 a_T) of :func:`foldprint.physics.recovery.curve.log10_shift`,
    the same operations on the same values (bitwise equal), into ``out`` (with ``work``, two
    arrays of ``temp``'s shape, as scratch), and Arrhenius only where it is taken (below T_ref)."""
    d, d_c1 = (None, None) if work is None else work
    d = np.subtract(temp, ref, out=d)
    out = np.maximum(d, 0.0, out=out)
    out += p.c2
    np.divide(np.multiply(d, -p.c1, out=d_c1), out, out=out)  # WLF: -c1 d / (c2 + max(d, 0))
    below = d < 0.0
    if below.any():
        refk = ref + 273.15
        arr = np.add(temp, 273.15, out=d)
        np.divide(1.0, arr, out=arr)
        arr -= 1.0 / refk
        arr *= (p.c1 / p.c2) * refk**2  # Arrhenius: (c1 / c2) Tr^2 (1 / T - 1 / Tr), in K
        np.copyto(out, arr, where=below)
    out *= -_LN10
    return np.exp(out, out=out)


def slab_roots(biot: np.ndarray, n: int = N_TERMS) -> np.ndarray:
    """Positive roots of zeta tan zeta = Bi for every Bi of ``biot`` (m,), shape (m, n): the
    roots of :func:`foldprint.physics.recovery.curve._slab_roots` (to round-off), as the roots of
    h(z) = z - k pi - atan(Bi / z) in (k pi, k pi + pi / 2) by Newton's method. h rises and
    is concave for z > 0, so from the lower bound k pi + atan(Bi / (k pi + pi / 2))
    (atan(sqrt(Bi)) for k = 0) the steps rise to the root without overshooting it; they
    stop at round-off (a few steps, where the bisection takes ~50)."""
    biot = np.asarray(biot, float)[:, None]
    k = np.arange(n, dtype=float)[None, :] * math.pi
    z = np.where(k > 0, k + np.arctan(biot / (k + math.pi / 2)), np.arctan(np.sqrt(biot)))
    for _ in range(60):
        q = biot / z
        step = (z - k - np.arctan(q)) / (1.0 + q / (z * (1.0 + q * q)))  # h / h'
        z -= step
        if np.all(np.abs(step) <= 4e-16 * z):
            break
    return z


@lru_cache(maxsize=1)
def _layers() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 4 Gauss points z > 0 of the 8 through the thickness (the slab is heated from both
    faces alike, so -z has the temperature of z) and each pair's weights: bending (z^2, of
    the ratio) and plain (of the mean temperature)."""
    zg8, wg8 = np.polynomial.legendre.leggauss(N_LAYERS)
    half_n = N_LAYERS // 2  # symmetric points: zg8[half_n + i] == -zg8[half_n - 1 - i]
    w8 = wg8 * zg8**2  # bending (second-moment) weight of each layer
    w8 = w8 / w8.sum()
    m8 = wg8 / wg8.sum()
    out = zg8[half_n:], w8[half_n:] + w8[:half_n][::-1], m8[half_n:] + m8[:half_n][::-1]
    for a in out:
        a.setflags(write=False)
    return out


@dataclass(frozen=True, eq=False)
class _Slab:
    """The slab series of ``n`` hinges: diffusivity, half-thickness squared (n,), minus the
    squared roots -zeta^2 (n, terms) and each term's coef cos(zeta z) at the layers
    (terms, n, n_z)."""

    alpha: float
    half2: np.ndarray
    nsq: np.ndarray
    shape: np.ndarray
    t_cut: np.ndarray  # each term's last time (s) with Fo zeta^2 <= CUT in any hinge


def _slab_block(slab: _Slab, tb: np.ndarray, v: Block, terms: int) -> int:
    """Excess temperature theta (into ``v.theta``) at the block's times ``tb``: the
    series' first ``terms`` terms, each exactly 0 where Fo zeta^2 > CUT. Returns how many
    terms are alive at the block's first time (Fo rises in t and zeta^2 in the term: a term
    cut for every hinge there stays cut, and so does every later term)."""
    fo = np.divide((slab.alpha * tb)[None, :], slab.half2[:, None], out=v.fo)  # (n, m), rising in t
    terms = int(np.count_nonzero(np.max(fo[:, :1] * slab.nsq[:, :terms], axis=0) >= -CUT))
    whole = np.min(fo[:, -1:] * slab.nsq[:, :terms], axis=0) >= -CUT  # no element of the block cut
    # each term on the block's times up to its last time alive in any hinge (a bound with a
    # margin far above round-off: the element-wise test below makes the cut exact)
    alive = np.searchsorted(tb, slab.t_cut[:terms] * (1.0 + 1e-9), side="right")
    theta, prod, arg = v.theta, v.x, v.arg
    if terms == 0 or alive[0] < len(tb):
        theta.fill(0.0)
    for j in range(terms):
        k = int(alive[j])
        a = arg[:, :k]
        np.multiply(fo[:, :k], slab.nsq[:, j:j + 1], out=a)  # -Fo zeta^2
        if not whole[j]:
            np.less(a, -CUT, out=v.cut[:, :k])
            np.maximum(a, -CUT, out=a)  # no slow underflow path in exp
        np.exp(a, out=a)
        if not whole[j]:
            np.copyto(a, 0.0, where=v.cut[:, :k])  # exactly 0 past the cut, element by element
        if j == 0:
            np.multiply(slab.shape[j][:, :, None], a[:, None, :], out=theta[..., :k])
        else:
            p = np.multiply(slab.shape[j][:, :, None], a[:, None, :], out=prod[..., :k])
            theta[..., :k] += p
    return terms


def _reduced_time_block(temp: np.ndarray, ref: np.ndarray, p: RecoveryParams, dt: np.ndarray, v: Block,
                        carry: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Reduced time xi (into ``v.xi``) at the block's times: the running trapezoid sum of
    1 / a_T, continued from ``carry`` = (xi, rate) at the previous block's last time (zero
    before the first; updated for the next block). ``dt`` (m,): each time's step from the
    previous time (0 at t = 0)."""
    xi_end, rate_end = carry
    rate, inc = v.rate, v.e
    _rate(temp, ref[:, None, None], p, out=rate, work=(v.e, v.x))
    flat = rate.reshape(-1)
    np.add(flat[1:], flat[:-1], out=inc.reshape(-1)[1:])  # r_i + r_(i-1); each row's first:
    np.add(rate[..., 0], rate_end, out=inc[..., 0])  # with the previous block's last rate
    inc *= 0.5
    inc *= dt
    xi = _running_sum(inc, xi_end, v.xi)
    rate_end[...] = rate[..., -1]
    return xi


def _running_sum(inc: np.ndarray, start: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``start`` + the running sum of ``inc`` (..., m) along its last axis, into ``out``;
    ``start`` becomes the last sum. Summed in groups of :data:`SUM_GROUP` (the prefix sums
    inside each group, then the groups' totals one after the other): the same sums
    whatever the block, as long as blocks start at a multiple of the group (``inc`` is
    overwritten)."""
    m = inc.shape[-1]
    q = m // SUM_GROUP
    full = inc[..., :q * SUM_GROUP].reshape(inc.shape[:-1] + (q, SUM_GROUP))
    tail = inc[..., q * SUM_GROUP:]
    for part in (full, tail[..., None, :]):
        for i in range(1, part.shape[-1]):  # prefix sums inside each group, all groups at once
            part[..., i] += part[..., i - 1]
    res = out.reshape(-1)[:inc.size].reshape(inc.shape)
    if q:
        totals = np.concatenate([start[..., None], full[..., -1]], axis=-1)  # (..., q + 1)
        np.cumsum(totals, axis=-1, out=totals)  # the sum up to each group's end
        np.add(full, totals[..., :-1, None], out=res[..., :q * SUM_GROUP].reshape(full.shape))
        start[...] = totals[..., -1]
    if tail.shape[-1]:
        np.add(tail, start[..., None], out=res[..., q * SUM_GROUP:])
        start[...] = res[..., -1]
    return res


def _unrecovered_block(xi: np.ndarray, tau: np.ndarray, g: np.ndarray, v: Block, first: int) -> int:
    """sum_b g_b exp(-xi / tau_b) (into ``v.u``) over the branches from ``first`` on, each
    exactly 0 where xi / tau_b > CUT. Returns the first branch alive at the block's first
    time (xi rises in t: a branch cut everywhere there stays cut, and so does every
    shorter one)."""
    u, x, e, keep = v.u, v.x, v.e, v.keep
    lo, hi = float(np.min(xi[..., 0])), float(np.max(xi[..., -1]))
    written = zeroed = False
    for b in range(first, len(tau)):
        s = -1.0 / tau[b]
        if lo * s < -CUT:
            first = b + 1
            continue
        np.multiply(xi, s, out=x)
        if hi * s < -CUT:  # exp only where kept (never below -CUT: no slow underflow path)
            np.greater_equal(x, -CUT, out=keep)
            if not zeroed:  # each later (longer) branch is cut on a subset of this one's cut
                e.fill(0.0)
                zeroed = True
            np.exp(x, out=e, where=keep)
        else:
            np.exp(x, out=e)
        if written:
            e *= g[b]
            u += e
        else:
            np.multiply(e, g[b], out=u)
            written = True
    if not written:
        u.fill(0.0)
    return first


def material_batch_ratios(material, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c: float,
                          t: np.ndarray, table: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """:func:`batch_ratios` for ``n`` hinges of ``material`` (Tg ``tg_c`` per hinge, at the
    mean fraction for a graded material): a graded hinge is its strips
    (:func:`foldprint.physics.recovery.curve.strip_tgs`) in one batch, combined by
    :func:`foldprint.physics.recovery.curve.combine_strips`."""
    p = material.recovery
    if not is_graded(material):
        return batch_ratios(p, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c, t, table)
    tg = np.asarray(tg_c, float)
    n = tg.shape[0]
    tgs, w = strip_tgs(material, tg)  # (n, S)
    s = tgs.shape[1]
    rep = [np.repeat(np.broadcast_to(np.asarray(a, float), (n,)), s) for a in (h_w_m2k, thickness_mm, bath_c)]
    ratio, mean_t = batch_ratios(p, tgs.ravel(), rep[0], rep[1], rep[2], initial_c, t, table)
    ratio = ratio.reshape(n, s, -1).transpose(1, 0, 2)  # (S, n, n_t)
    eff = combine_strips(ratio, w, material.profile.along)
    eff = np.maximum.accumulate(np.clip(eff, 0.0, 1.0), axis=-1)
    return eff, mean_t.reshape(n, s, -1)[:, 0, :]


def batch_ratios(p: RecoveryParams, tg_c, h_w_m2k, thickness_mm, bath_c, initial_c: float,
                 t: np.ndarray, table: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Recovery ratio and mean temperature, each (n, len(t)), of ``n`` hinges of the
    recovery model ``p`` (its ``h_w_m2k`` replaced by the given one per hinge), with Tg ``tg_c``
    (the shift referenced at Tg - ``p.reference_below_tg_c``, as
    :meth:`foldprint.physics.viscoelastic.Viscoelastic.reference_for`), thickness
    ``thickness_mm`` (mm) and bath ``bath_c`` (deg C) per hinge, all
    starting at ``initial_c``, at the times ``t`` (a prefix of the model's grid,
    :func:`grid_until`). Inputs are validated by the caller (finite, thickness > 0).
    ``table``: read the relaxation sum from :func:`relaxation_table` (|dR| < 2e-8) instead
    of summing the exponentials (round-off from the per-curve model)."""
    ref = np.asarray(tg_c, float) - p.reference_below_tg_c
    n = ref.shape[0]
    hw = np.broadcast_to(np.asarray(h_w_m2k, float), (n,))
    th = np.broadcast_to(np.asarray(thickness_mm, float), (n,))
    bath = np.broadcast_to(np.asarray(bath_c, float), (n,))
    t = np.asarray(t, float)
    per = max(1, MAX_BATCH_ELEMENTS // max(1, len(t) * N_LAYERS // 2))
    if n > per:  # bounded memory: batches of at most MAX_BATCH_ELEMENTS elements
        parts = [_batch(p, ref[a:a + per], hw[a:a + per], th[a:a + per], bath[a:a + per], initial_c, t, table)
                 for a in range(0, n, per)]
        return np.concatenate([r for r, _ in parts]), np.concatenate([m for _, m in parts])
    return _batch(p, ref, hw, th, bath, initial_c, t, table)


def _batch(p: RecoveryParams, ref: np.ndarray, hw: np.ndarray, th: np.ndarray, bath: np.ndarray,
           initial_c: float, t: np.ndarray, table: bool) -> tuple[np.ndarray, np.ndarray]:
    """One batch of :func:`batch_ratios`, the shift's reference temperatures ``ref`` given."""
    if table and use_kernels():  # the compiled path (batch_kernels) from the slab series on
        from .batch_kernels import slab_series

        alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
        slab = _Slab(alpha, *slab_series(hw, th, float(p.k_w_mk), alpha, _layers()[0], N_TERMS, CUT))
    else:
        slab = _slab(p, hw, th)
    return _curves(p, slab, ref, bath, initial_c, t, relaxation_table(p) if table else None)


def _slab(p: RecoveryParams, hw: np.ndarray, th: np.ndarray) -> _Slab:
    """The slab series of hinges with heat-transfer coefficients ``hw`` and thicknesses
    ``th`` (mm)."""
    zg = _layers()[0]
    half = th * 1e-3 / 2.0
    alpha = p.k_w_mk / (p.rho_kg_m3 * p.c_j_kgk)
    zeta = slab_roots(hw * half / p.k_w_mk)  # (n, terms)
    coef = 4.0 * np.sin(zeta) / (2.0 * zeta + np.sin(2.0 * zeta))
    shape = np.cos(zg[None, :, None] * zeta[:, None, :]) * coef[:, None, :]  # (n, n_z, terms)
    t_cut = np.max(CUT * (half**2)[:, None] / (alpha * zeta**2), axis=0)
    return _Slab(alpha, half**2, -zeta**2, np.ascontiguousarray(shape.transpose(2, 0, 1)), t_cut)


def _curves(p: RecoveryParams, slab: _Slab, ref: np.ndarray, bath: np.ndarray, initial_c: float,
            t: np.ndarray, table: RelaxationTable | None) -> tuple[np.ndarray, np.ndarray]:
    """Ratio and mean temperature (n, len(t)) of the hinges of ``slab``, a block of the time
    axis at a time (:data:`BLOCK_ELEMENTS`)."""
    n = len(ref)
    _, w, wm = _layers()
    if table is not None and use_kernels():  # the compiled path (batch_kernels): the same model
        from .batch_kernels import curves_table

        return curves_table(slab.alpha, slab.half2, slab.nsq, slab.shape, ref, bath, float(initial_c), t, w, wm,
                            float(p.c1), float(p.c2), CUT, table.y0, table.step, table.nodes)
    dt = np.diff(t, prepend=t[:1])  # each time's step from the previous one (0 at the first)
    tau, g = spectrum(p)
    ratio, mean_t = np.empty((n, len(t))), np.empty((n, len(t)))
    bt = max(1, BLOCK_ELEMENTS // (n * len(w) * SUM_GROUP)) * SUM_GROUP
    buf = Buffers(n, len(w), min(bt, len(t)))
    carry = np.zeros((n, len(w))), np.zeros((n, len(w)))  # xi and rate at the previous block's end
    terms, first = slab.nsq.shape[1], 0  # slab terms alive, first relaxation branch alive
    for a in range(0, len(t), bt):
        tb = t[a:a + bt]
        v = buf.block(len(tb))
        terms = _slab_block(slab, tb, v, terms)
        theta = v.theta
        if tb[0] <= 0:
            theta[:, :, tb <= 0] = 1.0  # the series converges slowly at t = 0 exactly
        # temperature, in place: bath - (bath - T0) clip(theta, 0, 1)
        np.clip(theta, 0.0, 1.0, out=theta)
        theta *= (bath - initial_c)[:, None, None]
        temp = np.subtract(bath[:, None, None], theta, out=theta)
        mean_t[:, a:a + len(tb)] = np.einsum("nzt,z->nt", temp, wm, out=v.r)
        xi = _reduced_time_block(temp, ref, p, dt[a:a + len(tb)], v, carry)
        if table is None:
            first = _unrecovered_block(xi, tau, g, v, first)
        else:
            table_block(xi, table, v)
        np.subtract(1.0, np.einsum("nzt,z->nt", v.u, w, out=v.r), out=ratio[:, a:a + len(tb)])
    np.clip(ratio, 0.0, 1.0, out=ratio)
    np.maximum.accumulate(ratio, axis=1, out=ratio)
    return ratio, mean_t
