"""Compiled kernel of :mod:`foldprint.physics.recovery.batch`: the recovery curves of many
hinges of one material with the relaxation sum read from its table (the Monte-Carlo's
path, ``table=True``), and the slab series they start from (:func:`slab_series`).

The numbers are those of :func:`foldprint.physics.recovery.batch._curves` (the reference),
element by element: the slab series term by term, each exactly 0 past Fo zeta^2 = CUT
(and every later term with it: Fo zeta^2 rises with the term), the temperature clipped,
1 / a_T by WLF above Tg and Arrhenius below it, the reduced time as a trapezoid sum, the
relaxation sum by linear interpolation in ln xi, the ratio clipped and its running
maximum. What differs, all round-off: the reduced time is summed one step after the
other (the reference sums groups of eight), the shift takes one division where the
reference takes two, the exponentials and logs are :func:`vexp`'s and :func:`vlog`'s
(within one unit in the last place of numpy's), multiply-adds may be fused
(``njit(contract=True)``), and the slab's roots stop each at its own round-off. Measured:
ratios within 2e-15, mean temperatures within 5e-14 degC of the reference; asserted 1e-12
and 1e-9 (``tests/test_kernels.py``, ``tests/test_recovery_kernels.py``).

How it is fast (docs/kernels.md): hinge by hinge, in blocks of :data:`TIME_BLOCK` times
with the :data:`NZ` layer pairs of a time side by side, every loop over a block is plain
arithmetic the compiler vectorises (numba's own exp and log are scalar libm calls, and
its ``/`` tests for a zero divisor, which stops a loop vectorising: ``np.divide``
does not); a hinge whose running maximum is exactly 1 keeps that ratio, so from its next
block on only its mean temperature is computed.

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
#: Times of one block of a hinge's curve: our choice (its working arrays, 8 x 4 layer pairs x
#: this many doubles, stay in the L1/L2 cache).
TIME_BLOCK = 256
#: Layer pairs through the thickness (the model's 8 Gauss points, symmetric:
#: :func:`foldprint.physics.recovery.batch._layers`): a constant, so the loops over them unroll.
NZ = 4


@njit(contract=True)
def vexp(x, out, bits):  # pragma: no cover - compiled
    """exp of every element of ``x`` (each <= 709) into ``out`` (``bits``: int64 scratch
    of the same length): x = k ln 2 + r, |r| <= ln 2 / 2, exp(r) by its Taylor series to
    r^13 (truncation < 2e-17 relative), times 2^k built from its bits. Within 2.2e-16
    relative of numpy's exp (measured over -60..5), and plain arithmetic, so the
    compiler vectorises the loop (numba's own exp is a scalar libm call here, three
    times slower per element than numpy's SIMD exp). Held at exp(-708) below -708 (the
    slab's arguments are >= -CUT = -50, the shift's ln(1 / a_T) tens)."""
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


_LG1 = 6.666666666666735130e-01  # fdlibm's e_log.c: log(1+f) = f - f^2/2 + s (f^2/2 + R(s^2))
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_SQRT2_M1_BITS = 0x95F64 << 32  # fdlibm: mantissa bits at or past sqrt(2) - 1 ...
_BIT52 = 1 << 52  # ... carry into bit 52: the mantissa is halved, k raised by one
_MANT = (1 << 52) - 1
_ONE_BITS = 0x3FF << 52
_RCP0, _RCP1, _RCP2 = 1.4694704, -0.71547883, 0.11544257  # our least-squares fit of 1 / y on
# [1.707, 2.414], relative error 2.2e-3: three Newton steps square it to below 1e-21


@njit(contract=True)
def vlog(x, out, bits):  # pragma: no cover - compiled
    """ln of every element of ``x`` (finite, >= 0; each held at DBL_MIN = 2.2e-308 first, so
    0 and subnormals give ln DBL_MIN = -708.4) into ``out`` (``bits``: int64 scratch of the
    same length). fdlibm's e_log.c without its branches: x = 2^k (1 + f), 1 + f in
    [sqrt(2)/2, sqrt(2)), s = f / (2 + f), ln(1 + f) = f - f^2/2 + s (f^2/2 + R(s^2)) with
    fdlibm's degree-14 R (error < 2^-58.45), k ln 2 in two parts. Within 2.2e-16 relative of
    numpy's log (measured, ``tests/test_kernels.py``), and plain arithmetic the compiler
    vectorises (numba's math.log is a scalar libm call)."""
    xb = x.view(np.int64)  # x >= 0: its bits rise with it, DBL_MIN's are 2^52
    for i in range(x.shape[0]):
        hx = max(xb[i], _BIT52)
        m = hx & _MANT
        c = (m + _SQRT2_M1_BITS) & _BIT52
        bits[i] = m | (_ONE_BITS ^ c)
        out[i] = np.float64(((hx >> 52) - 1023) + (c >> 52))  # k
    f1 = bits.view(np.float64)
    for i in range(x.shape[0]):
        f = f1[i] - 1.0
        dk = out[i]
        y = 2.0 + f  # in [1.707, 2.414]: 1 / y by Newton's method from a quadratic (no division:
        r = _RCP0 + y * (_RCP1 + y * _RCP2)  # numba's checks it for zero, which stops vectorising)
        r = r * (2.0 - y * r)
        r = r * (2.0 - y * r)
        s = f * (r * (2.0 - y * r))
        z = s * s
        w = z * z
        t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
        t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
        hfsq = 0.5 * f * f
        out[i] = s * (hfsq + t1 + t2) + dk * _LN2_LO - hfsq + f + dk * _LN2_HI


@njit(contract=True)
def slab_series(hw, th, k_w, alpha, zg, n_terms, cut):  # pragma: no cover - compiled
    """The slab series of hinges with heat-transfer coefficients ``hw`` and thicknesses
    ``th`` (mm), as :func:`foldprint.physics.recovery.batch._slab` (the reference) computes
    it: half-thickness squared (n,), -zeta^2 (n, terms), each term's coefficient at the
    layers ``zg`` (terms, n, n_z) and each term's last time alive in any hinge (terms,).
    The roots of zeta tan zeta = Bi by the same Newton steps from the same start, each
    root stopped at its own round-off (the reference stops when all are): equal to
    round-off."""
    n, n_z = hw.shape[0], zg.shape[0]
    half2, nsq = np.empty(n), np.empty((n, n_terms))
    shape, t_cut = np.empty((n_terms, n, n_z)), np.zeros(n_terms)
    for i in range(n):
        half = th[i] * 1e-3 / 2.0
        half2[i] = half * half
        biot = hw[i] * half / k_w
        for j in range(n_terms):
            kp = j * math.pi
            z = kp + math.atan(biot / (kp + math.pi / 2)) if j > 0 else math.atan(math.sqrt(biot))
            for _ in range(60):
                q = biot / z
                step = (z - kp - math.atan(q)) / (1.0 + q / (z * (1.0 + q * q)))
                z -= step
                if abs(step) <= 4e-16 * z:
                    break
            nsq[i, j] = -z * z
            coef = 4.0 * math.sin(z) / (2.0 * z + math.sin(2.0 * z))
            for l in range(n_z):
                shape[j, i, l] = math.cos(zg[l] * z) * coef
            t_cut[j] = max(t_cut[j], cut * half2[i] / (alpha * z * z))
    return half2, nsq, shape, t_cut


@njit(contract=True)
def _slab_theta(t, alpha, half2, nsq_i, shape, i, cut, theta, fo, xs, e, bits, ends, terms):  # pragma: no cover - compiled
    """Excess temperature theta (m x NZ, time-major) of hinge ``i``'s layers at the m times
    ``t`` (``half2``: L^2): the slab series term by term, each exactly 0 where
    Fo zeta^2 > ``cut`` (and so is every later term: zeta rises with the term); 1 at
    t = 0, where the series converges slowly. Every alive term's exponent in ``xs``, one
    :func:`vexp` for all. Returns the terms alive at the first time (a term cut there
    stays cut at every later time)."""
    m = t.shape[0]
    for k in range(m):  # Fo = alpha t / L^2 (np.divide: numba's `/` checks for a zero divisor,
        fo[k] = np.divide(alpha * t[k], half2)  # which stops a loop vectorising)
    fo_end = fo[m - 1]
    n_e = 0
    alive = 0
    for j in range(terms):
        c = nsq_i[j]
        if fo_end * c >= -cut:  # alive at every time of the block
            last = m
        else:  # the times alive, Fo zeta^2 <= cut, are a prefix (Fo rises with t)
            lo, last = 0, m
            while lo < last:
                mid = (lo + last) // 2
                if fo[mid] * c < -cut:
                    last = mid
                else:
                    lo = mid + 1
            if last == 0:
                break
        alive = j + 1
        xj = xs[n_e:n_e + last]  # a slice: its index is known >= 0, so the stores are contiguous
        for k in range(last):
            xj[k] = fo[k] * c
        n_e += last
        ends[j] = n_e
    vexp(xs[:n_e], e[:n_e], bits[:n_e])
    start = 0
    for j in range(alive):
        s0, s1, s2, s3 = shape[j, i, 0], shape[j, i, 1], shape[j, i, 2], shape[j, i, 3]
        last = ends[j] - start
        if j == 0:
            for k in range(last):
                q = k * NZ
                ek = e[k]
                theta[q], theta[q + 1], theta[q + 2], theta[q + 3] = s0 * ek, s1 * ek, s2 * ek, s3 * ek
            theta[last * NZ: m * NZ] = 0.0
        else:
            ej = e[start:start + last]
            for k in range(last):
                q = k * NZ
                ek = ej[k]
                theta[q] += s0 * ek
                theta[q + 1] += s1 * ek
                theta[q + 2] += s2 * ek
                theta[q + 3] += s3 * ek
        start = ends[j]
    if alive == 0:
        theta[: m * NZ] = 0.0
    if t[0] <= 0.0:
        for k in range(m):
            if t[k] <= 0.0:
                theta[k * NZ: k * NZ + NZ] = 1.0
    return alive


@njit(contract=True)
def _temperature(theta, mv, bi, span, wm):  # pragma: no cover - compiled
    """The layers' temperature bath - (bath - T0) clip(theta, 0, 1), in place of ``theta``
    (len(mv) x NZ), and its plain-weighted mean into ``mv``."""
    m0, m1, m2, m3 = wm[0], wm[1], wm[2], wm[3]
    for k in range(mv.shape[0]):
        q = k * NZ
        u0 = bi - min(max(theta[q], 0.0), 1.0) * span
        u1 = bi - min(max(theta[q + 1], 0.0), 1.0) * span
        u2 = bi - min(max(theta[q + 2], 0.0), 1.0) * span
        u3 = bi - min(max(theta[q + 3], 0.0), 1.0) * span
        theta[q], theta[q + 1], theta[q + 2], theta[q + 3] = u0, u1, u2, u3
        mv[k] = u0 * m0 + u1 * m1 + u2 * m2 + u3 * m3


@njit(contract=True)
def _ratio_block(temp, tv, t_prev, tg, shift, flat, w, carry, rv, top, work, bits):  # pragma: no cover - compiled
    """The running maximum of the ratio (into ``rv``) at the block's times ``tv`` from the
    layers' temperatures ``temp`` (len(tv) x NZ), continuing the reduced time and rate of
    ``carry`` (x0..x3, r0..r3: updated) and the maximum ``top`` (returned). ``t_prev``: the
    time before the block (``tv[0]`` at the first); ``shift`` = (Arrhenius and WLF factors,
    c2, y0, 1 / step, last node)."""
    mb = tv.shape[0]
    lanes = mb * NZ
    arr_k, wlf, c2, y0, inv_step, last = shift[0], shift[1], shift[2], shift[3], shift[4], shift[5]
    lg, rate, xiv, h = work[0, :lanes], work[1, :lanes], work[2, :lanes], work[3, :mb]
    b = bits[:lanes]
    # ln(1 / a_T) = -ln 10 log10 a_T, d = T - Tg: Arrhenius below Tg, (c1 / c2) Tg d / T ln 10
    # (T, Tg in K), WLF above, c1 d / (c2 + d) ln 10: one division (np.divide: numba's `/`
    # checks for a zero divisor, which stops a loop vectorising)
    for q in range(lanes):
        d = temp[q] - tg
        below = d < 0.0
        lg[q] = np.divide(d * (arr_k if below else wlf), (temp[q] + 273.15) if below else (d + c2))
    vexp(lg, rate, b)
    h[0] = 0.5 * (tv[0] - t_prev)  # half of each time's step from the previous (0 at the first)
    for k in range(1, mb):
        h[k] = 0.5 * (tv[k] - tv[k - 1])
    x0, x1, x2, x3, r0, r1, r2, r3 = carry[0], carry[1], carry[2], carry[3], carry[4], carry[5], carry[6], carry[7]
    for k in range(mb):  # the reduced time: a trapezoid sum, one step after the other
        q = k * NZ
        hk = h[k]
        x0 += (rate[q] + r0) * hk
        x1 += (rate[q + 1] + r1) * hk
        x2 += (rate[q + 2] + r2) * hk
        x3 += (rate[q + 3] + r3) * hk
        r0, r1, r2, r3 = rate[q], rate[q + 1], rate[q + 2], rate[q + 3]
        xiv[q], xiv[q + 1], xiv[q + 2], xiv[q + 3] = x0, x1, x2, x3
    carry[0], carry[1], carry[2], carry[3], carry[4], carry[5], carry[6], carry[7] = x0, x1, x2, x3, r0, r1, r2, r3
    vlog(xiv, lg, b)
    for q in range(lanes):  # U(xi) from the table, linear in ln xi: where (vectorised) ...
        y = min(max((lg[q] - y0) * inv_step, 0.0), last)
        fl = math.floor(y)
        b[q] = int(fl)
        lg[q] = y - fl
    for q in range(lanes):  # ... and the read (a gather; unsigned: no wraparound test)
        nb = np.uint64(b[q]) * np.uint64(2)
        rate[q] = flat[nb + np.uint64(1)] * lg[q] + flat[nb]
    w0, w1, w2, w3 = w[0], w[1], w[2], w[3]
    for k in range(mb):
        q = k * NZ
        lg[k] = min(max(1.0 - (rate[q] * w0 + rate[q + 1] * w1 + rate[q + 2] * w2 + rate[q + 3] * w3), 0.0), 1.0)
    for k in range(mb):
        top = max(top, lg[k])
        rv[k] = top
    return top


@njit(contract=True)
def curves_table(alpha, half2, nsq, shape, tg, bath, initial_c, t, w, wm, c1, c2, cut, y0, step,
                 nodes):  # pragma: no cover - compiled
    """Ratio and mean temperature (n, m) of n hinges at the m times ``t``. ``half2`` (n,)
    half-thickness squared, ``nsq`` (n, terms) -zeta^2, ``shape`` (terms, n, NZ) each
    term's coefficient at the layers, ``w`` / ``wm`` (NZ,) the layer pairs' bending and
    plain weights, ``nodes`` (N, 2) the relaxation table (U and its change to the next
    node), read at (ln xi - ``y0``) / ``step`` (``y0`` > ln DBL_MIN: :func:`vlog` holds 0
    there).

    Hinge by hinge, blocks of :data:`TIME_BLOCK` times, every layer of the block at once
    (the exponentials and logs in vectorised loops, :func:`vexp` and :func:`vlog`); the
    reduced time one step after the other. Once a hinge's running maximum is exactly 1
    its ratio is 1 at every later time: from the next block on only its mean temperature
    is computed."""
    n, m, n_terms = tg.shape[0], t.shape[0], nsq.shape[1]
    if w.shape[0] != NZ or wm.shape[0] != NZ or shape.shape[2] != NZ:
        raise ValueError("curves_table: the layer pairs are not NZ")
    ratio, mean_t = np.empty((n, m)), np.empty((n, m))
    theta, work, bits = np.empty(TIME_BLOCK * NZ), np.empty((4, TIME_BLOCK * NZ)), np.empty(TIME_BLOCK * NZ, np.int64)
    fo, xs, e = np.empty(TIME_BLOCK), np.empty(TIME_BLOCK * n_terms), np.empty(TIME_BLOCK * n_terms)
    sbits, ends = np.empty(TIME_BLOCK * n_terms, np.int64), np.empty(n_terms, np.int64)
    flat = np.ascontiguousarray(nodes).reshape(nodes.size)  # U and its change, node after node
    shift = np.array([0.0, c1 * _LN10, c2, y0, 1.0 / step, float(nodes.shape[0] - 2)])
    carry = np.empty(2 * NZ)  # each layer pair's reduced time and rate at the last time
    for i in range(n):
        shift[0] = (c1 / c2) * (tg[i] + 273.15) * _LN10
        span = bath[i] - initial_c
        terms = n_terms
        carry[:] = 0.0
        top = 0.0
        for a in range(0, m, TIME_BLOCK):
            b = min(a + TIME_BLOCK, m)
            terms = _slab_theta(t[a:b], alpha, half2[i], nsq[i], shape, i, cut, theta, fo, xs, e, sbits, ends, terms)
            _temperature(theta, mean_t[i, a:b], bath[i], span, wm)
            if top == 1.0:  # the ratio is 1 from here on: only the mean temperature
                ratio[i, a:b] = 1.0
            else:
                top = _ratio_block(theta, t[a:b], t[a - 1] if a > 0 else t[0], tg[i], shift, flat, w, carry,
                                   ratio[i, a:b], top, work, bits)
    return ratio, mean_t
