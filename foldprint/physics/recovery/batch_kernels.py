"""Compiled kernel of :mod:`foldprint.physics.recovery.batch`: the recovery curves of many
hinges of one material with the relaxation sum read from its table (the Monte-Carlo's
path, ``table=True``), one time at a time, every hinge and layer at once.

The numbers are those of :func:`foldprint.physics.recovery.batch._curves` (the reference),
element by element: the slab series term by term, each exactly 0 past Fo zeta^2 = CUT
(and every later term with it: Fo zeta^2 rises with the term), the temperature clipped,
1 / a_T by WLF above Tg and Arrhenius below it, the reduced time as a trapezoid sum, the
relaxation sum by linear interpolation in ln xi, the ratio clipped and its running
maximum. What differs: the reduced time is summed one step after the other (the reference
sums groups of eight) and the exponentials are :func:`vexp`'s (within 2.2e-16 relative of
numpy's), so xi differs by round-off and the ratio by less than 1e-12
(``tests/test_kernels.py``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ...core.jit import njit

_LN10 = math.log(10.0)
_LN2_HI = 6.93147180369123816490e-01  # ln 2 in two parts (fdlibm's): k ln 2 exact in the high part
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.44269504088896338700e+00


@njit
def vexp(x, out, bits):  # pragma: no cover - compiled
    """exp of every element of ``x`` (each <= 709) into ``out`` (``bits``: int64 scratch
    of the same length): x = k ln 2 + r, |r| <= ln 2 / 2, exp(r) by its Taylor series to
    r^13 (truncation < 2e-17 relative), times 2^k built from its bits. Within 2.2e-16
    relative of numpy's exp (measured over -60..5), and plain arithmetic, so the
    compiler vectorises the loop (numba's own exp is a scalar libm call here, three
    times slower per element than numpy's SIMD exp). 0 below -708 (the callers clamp
    their arguments to -CUT = -50 first)."""
    for i in range(x.shape[0]):
        v = min(max(x[i], -708.0), 709.0)
        kf = math.floor(v * _INV_LN2 + 0.5)
        r = (v - kf * _LN2_HI) - kf * _LN2_LO
        p = 1.0 / 6227020800.0
        p = p * r + 1.0 / 479001600.0
        p = p * r + 1.0 / 39916800.0
        p = p * r + 1.0 / 3628800.0
        p = p * r + 1.0 / 362880.0
        p = p * r + 1.0 / 40320.0
        p = p * r + 1.0 / 5040.0
        p = p * r + 1.0 / 720.0
        p = p * r + 1.0 / 120.0
        p = p * r + 1.0 / 24.0
        p = p * r + 1.0 / 6.0
        p = p * r + 0.5
        p = p * r + 1.0
        out[i] = p * r + 1.0
        bits[i] = (np.int64(kf) + 1023) << 52
    scale = bits.view(np.float64)
    for i in range(x.shape[0]):
        out[i] *= scale[i]


@njit
def _slab_theta(tk, alpha, half2, nsq, shape, cut, theta, fo, xs, e, bits_n):  # pragma: no cover - compiled
    """Excess temperature theta (n * n_z,) of every hinge and layer at time ``tk``: the
    slab series term by term, each exactly 0 where Fo zeta^2 > ``cut`` (and so is every
    later term: zeta rises with the term); 1 at t = 0, where the series converges slowly."""
    n, n_terms, n_z = nsq.shape[0], nsq.shape[1], shape.shape[2]
    if tk <= 0.0:
        theta[:] = 1.0
        return
    theta[:] = 0.0
    for i in range(n):
        fo[i] = (alpha * tk) / half2[i]
    for j in range(n_terms):
        alive = 0
        for i in range(n):
            x = fo[i] * nsq[i, j]
            alive += x >= -cut
            xs[i] = max(x, -cut)
        if alive == 0:
            break
        vexp(xs, e, bits_n)
        for i in range(n):
            ei = e[i] if fo[i] * nsq[i, j] >= -cut else 0.0
            for z in range(n_z):
                theta[i * n_z + z] += shape[j, i, z] * ei


@njit
def _unrecovered(x, y0, step, nodes):  # pragma: no cover - compiled
    """U(xi) read from the relaxation table: linear in ln xi between its nodes, the first
    node's value below it (and at xi = 0), the last's past it."""
    last = nodes.shape[0] - 2
    y = 0.0
    if x > 0.0:
        y = min(max((math.log(x) - y0) * (1.0 / step), 0.0), last)
    fl = math.floor(y)
    b = int(fl)
    return nodes[b, 1] * (y - fl) + nodes[b, 0]


@njit
def curves_table(alpha, half2, nsq, shape, tg, bath, initial_c, t, dt, w, wm, c1, c2, cut, y0, step,
                 nodes):  # pragma: no cover - compiled
    """Ratio and mean temperature (n, m) of n hinges at the m times ``t`` (``dt``: each
    time's step from the previous, 0 at the first). ``half2`` (n,) half-thickness squared,
    ``nsq`` (n, terms) -zeta^2, ``shape`` (terms, n, n_z) each term's coefficient at the
    layers, ``w`` / ``wm`` (n_z,) the layer pairs' bending and plain weights, ``nodes``
    (N, 2) the relaxation table (U and its change to the next node), read at
    (ln xi - ``y0``) / ``step``. Time by time, every hinge and layer at once (the
    exponentials in vectorised loops, :func:`vexp`; the log is numba's scalar one: a
    search of the nodes instead cost more)."""
    n, m, n_z = tg.shape[0], t.shape[0], w.shape[0]
    lanes = n * n_z
    ratio, mean_t = np.empty((n, m)), np.empty((n, m))
    xi, rate_prev = np.zeros(lanes), np.zeros(lanes)
    rate, lg, theta = np.empty(lanes), np.empty(lanes), np.empty(lanes)
    bits = np.empty(lanes, np.int64)
    fo, xs, e, bits_n = np.empty(n), np.empty(n), np.empty(n), np.empty(n, np.int64)
    top = np.zeros(n)
    tgk = tg + 273.15
    arr_k = (c1 / c2) * tgk ** 2
    inv_tgk = 1.0 / tgk
    span = bath - initial_c
    for k in range(m):
        _slab_theta(t[k], alpha, half2, nsq, shape, cut, theta, fo, xs, e, bits_n)
        for i in range(n):
            mean = 0.0
            for z in range(n_z):
                q = i * n_z + z
                temp = bath[i] - min(max(theta[q], 0.0), 1.0) * span[i]
                mean += temp * wm[z]
                d = temp - tg[i]
                if d < 0.0:  # 1 / a_T: Arrhenius below Tg, WLF above
                    lg[q] = ((1.0 / (temp + 273.15) - inv_tgk[i]) * arr_k[i]) * -_LN10
                else:
                    lg[q] = ((d * -c1) / (d + c2)) * -_LN10
            mean_t[i, k] = mean
        vexp(lg, rate, bits)
        for q in range(lanes):  # the reduced time: a trapezoid sum
            xi[q] += (rate[q] + rate_prev[q]) * 0.5 * dt[k]
            rate_prev[q] = rate[q]
        for i in range(n):
            uw = 0.0
            for z in range(n_z):
                uw += _unrecovered(xi[i * n_z + z], y0, step, nodes) * w[z]
            r = min(max(1.0 - uw, 0.0), 1.0)
            if r > top[i]:
                top[i] = r
            ratio[i, k] = top[i]
    return ratio, mean_t
