"""The ends of check's anytime-valid interval (:func:`~foldprint.simulation.jamtest.verdict.confidence_sequence`):
the Beta(1, 1) mixture's equation solved by Brent's method, here in plain Python.

scipy's ``brentq`` solved it before; importing scipy.optimize for it cost a ``check``'s
parent 0.4-0.7 CPU-s (its ``__init__`` loads every optimiser), on the cores the workers
fold on. :func:`brentq` is the same algorithm step for step (Brent 1973 as scipy's
``Zeros/brentq.c`` implements it: the same bracket swaps, inverse quadratic or secant
steps, the same acceptance test and tolerance ``(xtol + rtol |x|) / 2``), so it returns
the same number, bit for bit (``tests/test_verdict.py`` compares the two on every (k, n)
up to check's maximum). ``log B(a, b)`` stays scipy.special's ``betaln`` (0.03 CPU-s to
import beside the scipy.linalg numba loads).
"""

from __future__ import annotations

import math
from typing import Callable

#: The root finder's iteration limit (scipy's default, ``maxiter=100``).
MAX_ITER = 100


def brentq(f: Callable[[float], float], xa: float, xb: float, xtol: float, rtol: float) -> float:
    """A root of ``f`` in [xa, xb] (``f(xa)``, ``f(xb)`` of opposite signs, or one zero),
    to ``xtol + rtol |x|`` (Brent's method, scipy's ``brentq``). Raises ValueError without
    a sign change, RuntimeError when :data:`MAX_ITER` steps do not converge."""
    xpre, xcur = float(xa), float(xb)
    xblk = fblk = spre = scur = 0.0
    fpre, fcur = f(xpre), f(xcur)
    if fpre == 0:
        return xpre
    if fcur == 0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    for _ in range(MAX_ITER):
        if fpre != 0 and fcur != 0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0 or abs(sbis) < delta:
            return xcur
        spre, scur = _step(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, sbis, delta)
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = f(xcur)
    raise RuntimeError(f"brentq: no convergence in {MAX_ITER} steps")


def _step(xpre, xcur, xblk, fpre, fcur, fblk, spre, scur, sbis, delta) -> tuple[float, float]:
    """Brent's next (previous step, step): interpolation (secant, or inverse quadratic
    when the bracket's end is not the previous point) where it is a good short step,
    else bisection."""
    if abs(spre) > delta and abs(fcur) < abs(fpre):
        if xpre == xblk:  # interpolate
            stry = -fcur * (xcur - xpre) / (fcur - fpre)
        else:  # extrapolate
            dpre = (fpre - fcur) / (xpre - xcur)
            dblk = (fblk - fcur) / (xblk - xcur)
            stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
        if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):  # good short step
            return scur, stry
    return sbis, sbis


def lower_end(k: int, n: int, level: float) -> float:
    """The confidence sequence's lower end after ``n`` samples with ``k`` jams (0 when
    k = 0): the p below k/n where k log p + (n - k) log(1 - p) = log(1 - level) + log B(k + 1, n - k + 1)."""
    if k == 0:
        return 0.0
    from scipy.special import betaln

    c = math.log(1.0 - level) + float(betaln(k + 1, n - k + 1))

    def g(p: float) -> float:  # > 0 inside the interval
        return k * math.log(p) + ((n - k) * math.log1p(-p) if k < n else 0.0) - c

    return brentq(g, 1e-300, k / n, xtol=1e-14, rtol=1e-12)
