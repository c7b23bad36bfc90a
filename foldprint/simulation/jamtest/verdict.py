"""``check``'s jam verdict: a sequential test with stated error rates (``docs/verdict.md``).

The question is a test: is a design's jam probability p below the warning threshold
(pass, FP182), between the thresholds (warning, FP181) or above the error threshold
(error, FP180)? Each threshold theta gets Wald's sequential probability ratio test of
H0: p <= lo against H1: p >= hi, the indifference region (lo, hi) around theta given by
:func:`indifference`, with error rates alpha (H1 accepted although p <= lo) and beta (H0
accepted although p >= hi). After n samples with k jams its log-likelihood ratio is

    L = k log(hi / lo) + (n - k) log((1 - hi) / (1 - lo)),

and it accepts H1 when L >= A = log(1 / alpha), H0 when L <= B = log(beta), frozen at its
first crossing. (Wald's own boundaries log((1 - beta) / alpha) and log(beta / (1 - alpha))
bound the error rates only by alpha / (1 - beta) and beta / (1 - alpha), 5.26 % at 5 %; on
Bernoulli streams at the upper edge of a region they gave 5.1-5.4 %, over the stated 5 %.
Wald's inequalities make alpha and beta strict bounds for these boundaries, at about 2 %
more samples on average: ``docs/verdict.md``.) The verdict: ERROR as soon as the error test accepts H1;
PASS as soon as the warning test accepts H0; WARNING once the warning test has accepted
H1 and the error test H0. At the maximum N a test that has not crossed decides by the
sign of L - (A + B) / 2 (a truncated SPRT; the result says "truncated").

A test can ask less (:class:`~foldprint.core.modes.JamQuestion`): only which side of one
threshold p is on. Then that threshold's test alone runs and the stream stops at its first
crossing, with the same error rates; the answer pins a verdict on one side (below the
warning threshold: pass; above the error threshold: error) and leaves two open on the other
("above 5 %": a warning or an error). The points of the sigma-scale sweep ask no more
than whether the verdict at 1x flips (:func:`sweep_question`), the probes of what drives a
flip no more than which side of the flip's threshold they are on
(:mod:`foldprint.simulation.jamtest.flip_drivers`).

Samples are consumed one at a time, in stream order: the stopping index is a function of
the outcomes alone (so of the seed), never of how many were folded at once or where.
:func:`decide_many` judges many streams at once (the same code judges one, :func:`decide`),
so the error rates can be simulated on Bernoulli streams (:func:`operating_point`).

The interval reported beside the verdict is an anytime-valid confidence sequence, the
Beta(1, 1) mixture of Robbins: {p : B(k + 1, n - k + 1) / (p^k (1 - p)^(n - k)) < 1 / (1 - level)},
which holds at a data-dependent stopping time (Ville's inequality), where a fixed-n
interval looked at after a sequential stop does not (:func:`confidence_sequence`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Sequence

import numpy as np

from ...core.constants import (CHECK_SAMPLES, JAM_ERROR_ABOVE, JAM_INTERVAL_LEVEL, JAM_TEST_ALPHA, JAM_TEST_BETA,
                              JAM_TEST_MAX_HALF_WIDTH, JAM_TEST_MIN_HALF_WIDTH, JAM_TEST_RELATIVE_HALF_WIDTH,
                              JAM_WARN_ABOVE)
from ...core.errors import DesignError
from ...core.modes import JamQuestion, JamVerdict, Side

#: The test's name in reports.
TEST_NAME = "truncated Wald SPRT per threshold"
#: The interval's name in reports.
INTERVAL_NAME = "anytime-valid confidence sequence (Beta(1,1) mixture)"

_VERDICTS = (JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR)  # codes 0, 1, 2 of decide_many
_SIDES = (Side.BELOW, Side.ABOVE)  # codes 0, 1


def indifference(threshold: float) -> tuple[float, float]:
    """The indifference region (lo, hi) of a threshold: theta -/+ delta, delta =
    min(:data:`~foldprint.core.constants.JAM_TEST_RELATIVE_HALF_WIDTH` x theta,
    :data:`~foldprint.core.constants.JAM_TEST_MAX_HALF_WIDTH`) (at least
    :data:`~foldprint.core.constants.JAM_TEST_MIN_HALF_WIDTH`), cut to [0, 1].

    >>> indifference(0.05), indifference(0.2)
    ((0.025, 0.075), (0.15, 0.25))
    """
    t = float(threshold)
    if not 0.0 <= t <= 1.0:
        raise DesignError(f"a jam threshold must be a probability in [0, 1], got {threshold!r}")
    delta = max(JAM_TEST_MIN_HALF_WIDTH, min(JAM_TEST_RELATIVE_HALF_WIDTH * t, JAM_TEST_MAX_HALF_WIDTH))
    return round(max(0.0, t - delta), 12), round(min(1.0, t + delta), 12)


@dataclass(frozen=True)
class Sprt:
    """Wald's sequential probability ratio test of H0: p <= ``lo`` against H1: p >= ``hi``
    (around ``threshold``) with error rates ``alpha`` and ``beta``."""

    threshold: float
    lo: float
    hi: float
    alpha: float = JAM_TEST_ALPHA
    beta: float = JAM_TEST_BETA

    def __post_init__(self):
        if not 0.0 <= self.lo < self.hi <= 1.0:
            raise DesignError(f"an indifference region needs 0 <= lo < hi <= 1, got ({self.lo}, {self.hi})")
        if not (0.0 < self.alpha < 1.0 and 0.0 < self.beta < 1.0 and self.alpha + self.beta < 1.0):
            raise DesignError(f"error rates need 0 < alpha, beta and alpha + beta < 1, got {self.alpha}, {self.beta}")

    @property
    def upper(self) -> float:
        """A = log(1 / alpha): H1 ("above") is accepted at L >= A. Then the chance of
        accepting H1 at p = lo is at most exp(-A) = alpha (Wald's inequality)."""
        return math.log(1.0 / self.alpha)

    @property
    def lower(self) -> float:
        """B = log(beta): H0 ("below") is accepted at L <= B; the chance of accepting H0
        at p = hi is at most exp(B) = beta."""
        return math.log(self.beta)

    @property
    def midpoint(self) -> float:
        """(A + B) / 2: a truncated test accepts H1 when L >= it."""
        return 0.5 * (self.upper + self.lower)

    @property
    def jam_step(self) -> float:
        """What a jam adds to L: log(hi / lo) (infinite when lo = 0: one jam proves p > 0)."""
        return math.inf if self.lo == 0.0 else math.log(self.hi / self.lo)

    @property
    def clean_step(self) -> float:
        """What a clean sample adds to L: log((1 - hi) / (1 - lo)) (-inf when hi = 1)."""
        return -math.inf if self.hi == 1.0 else math.log((1.0 - self.hi) / (1.0 - self.lo))

    def llr(self, jams, samples) -> np.ndarray:
        """L after ``samples`` samples with ``jams`` jams (arrays broadcast)."""
        k = np.asarray(jams, dtype=float)
        n = np.asarray(samples, dtype=float)
        with np.errstate(invalid="ignore"):  # 0 x inf where a count is zero: that term is 0
            up = np.where(k > 0, k * self.jam_step, 0.0)
            down = np.where(n - k > 0, (n - k) * self.clean_step, 0.0)
        return up + down


@dataclass(frozen=True)
class JamTest:
    """The whole test: one :class:`Sprt` per threshold and the maximum sample count."""

    warning: Sprt
    error: Sprt
    max_samples: int
    level: float = JAM_INTERVAL_LEVEL
    question: JamQuestion = JamQuestion.VERDICT
    #: At the maximum a threshold's test that has not crossed decides by the sign of
    #: L - (A + B) / 2 (a truncated SPRT: a verdict is always given). False (a probe's
    #: one-threshold question): it stays undecided there and the answer claims nothing.
    truncate: bool = True

    @property
    def name(self) -> str:
        return TEST_NAME

    def asking(self, question: JamQuestion) -> "JamTest":
        """The same test asking ``question`` (the same thresholds, error rates and maximum)."""
        return replace(self, question=JamQuestion(question))

    def probing(self, question: JamQuestion, max_samples: int | None = None) -> "JamTest":
        """:meth:`asking` ``question``, undecided at the maximum when no boundary was
        crossed (``truncate`` False): a probe of what drives a flip says "on the threshold"
        there instead of deciding by the sign, which inside the indifference region is
        either answer. ``max_samples``: a lower maximum (never above this test's)."""
        most = self.max_samples if max_samples is None else min(self.max_samples, int(max_samples))
        return replace(self, question=JamQuestion(question), truncate=False, max_samples=most)

    @property
    def asked(self) -> Sprt | None:
        """The one threshold's test a one-threshold question runs (None: the verdict, both)."""
        return {JamQuestion.WARNING: self.warning, JamQuestion.ERROR: self.error}.get(self.question)

    def __post_init__(self):
        if isinstance(self.max_samples, bool) or not isinstance(self.max_samples, int) or self.max_samples < 1:
            raise DesignError(f"the jam test's maximum samples must be a whole number >= 1, got {self.max_samples!r}")
        if not self.warning.threshold < self.error.threshold:
            raise DesignError(f"the jam test's warning threshold ({self.warning.threshold:g}, --warn-above) must be "
                              f"below its error threshold ({self.error.threshold:g}, --error-above)")


def jam_test(warn_above: float = JAM_WARN_ABOVE, error_above: float = JAM_ERROR_ABOVE,
             max_samples: int = CHECK_SAMPLES, alpha: float = JAM_TEST_ALPHA, beta: float = JAM_TEST_BETA) -> JamTest:
    """``check``'s test for the two thresholds, each with :func:`indifference` and the
    error rates ``alpha`` and ``beta``, at most ``max_samples`` samples."""
    return JamTest(Sprt(float(warn_above), *indifference(warn_above), alpha, beta),
                   Sprt(float(error_above), *indifference(error_above), alpha, beta), int(max_samples))


def sweep_question(base: JamVerdict) -> JamQuestion:
    """What a point of the sigma-scale sweep asks once the verdict at 1x is ``base``: only
    whether the verdict flips. After a pass, whether p is above the warning threshold (a
    worse verdict, warning or error, is a flip); after an error, whether it is below the
    error threshold; after a warning, the verdict (a flip either way).

    >>> [sweep_question(v).value for v in (JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR)]
    ['warning', 'verdict', 'error']
    """
    return {JamVerdict.PASS: JamQuestion.WARNING, JamVerdict.ERROR: JamQuestion.ERROR}.get(base, JamQuestion.VERDICT)


@dataclass(frozen=True)
class SprtOutcome:
    """One threshold's test on a stream: the side it accepted (None: not yet), after how
    many samples, and whether that came from the truncation at the maximum."""

    side: Side | None
    at: int
    truncated: bool = False


@dataclass(frozen=True)
class JamDecision:
    """The test on a stream of outcomes: the verdict (None: not decided yet, more samples
    needed, or a one-threshold answer that leaves two verdicts open: :attr:`verdicts`), the
    samples it used (``samples``, the stopping index) and their jams."""

    test: JamTest
    verdict: JamVerdict | None
    samples: int
    jams: int
    warning: SprtOutcome
    error: SprtOutcome
    truncated: bool = False  # the verdict needed a test decided by the truncation at the maximum

    @property
    def asked(self) -> SprtOutcome | None:
        """A one-threshold question's outcome (None when the test asks for the verdict)."""
        return {JamQuestion.WARNING: self.warning, JamQuestion.ERROR: self.error}.get(self.test.question)

    @property
    def undecided_at_max(self) -> bool:
        """A one-threshold question that reached the maximum without crossing a boundary,
        its test not truncating (:meth:`JamTest.probing`): p is near the threshold."""
        asked = self.asked
        return asked is not None and asked.side is None and self.truncated

    @property
    def decided(self) -> bool:
        asked = self.asked
        if asked is None:
            return self.verdict is not None
        return asked.side is not None or self.undecided_at_max

    @property
    def verdicts(self) -> tuple[JamVerdict, ...]:
        """The verdicts the answer leaves possible, best first: one for a verdict (or a
        one-threshold answer that pins it), two for "above the warning threshold" (warning
        or error) or "below the error threshold" (pass or warning), all three when a probe
        reached its maximum undecided, none before a decision."""
        if self.verdict is not None:
            return (self.verdict,)
        if not self.decided:
            return ()
        if self.undecided_at_max:
            return _VERDICTS
        return (JamVerdict.WARNING, JamVerdict.ERROR) if self.test.question == JamQuestion.WARNING else \
            (JamVerdict.PASS, JamVerdict.WARNING)

    @property
    def estimate(self) -> float:
        """jams / samples (0 before any sample)."""
        return self.jams / self.samples if self.samples else 0.0

    @property
    def interval_name(self) -> str:
        return INTERVAL_NAME

    @property
    def interval(self) -> tuple[float, float]:
        """The anytime-valid confidence sequence at the stop (:func:`confidence_sequence`)."""
        return confidence_sequence(self.jams, self.samples, self.test.level)


def _first_crossings(sprt: Sprt, cumk: np.ndarray, full: np.ndarray):
    """Per stream (rows of ``cumk``, the running jam counts): the side accepted (-1 none,
    0 below, 1 above), the samples at acceptance (m + 1 when none) and whether it was the
    truncation (rows where ``full``: the stream reached the maximum)."""
    s, m = cumk.shape
    if m == 0:  # no sample yet
        return np.full(s, -1), np.ones(s, dtype=np.int64), np.zeros(s, dtype=bool)
    n = np.arange(1, m + 1)
    llr = sprt.llr(cumk, n[None, :])
    up, down = llr >= sprt.upper, llr <= sprt.lower
    hit = up | down
    crossed = hit.any(axis=1)
    idx = np.where(crossed, hit.argmax(axis=1), m)
    rows = np.arange(s)
    side = np.where(crossed, up[rows, np.minimum(idx, m - 1)].astype(int), -1)
    at = idx + 1
    trunc = ~crossed & full
    side = np.where(trunc, (llr[:, -1] >= sprt.midpoint).astype(int), side)
    at = np.where(trunc, m, at)
    return side, at, trunc


def _seen(side, at, trunc, n, m):
    """A threshold's test cut at each stream's stop ``n``: undecided where it crossed later."""
    seen = (side >= 0) & (at <= n)
    return np.where(seen, side, -1), np.where(seen, at, m + 1), trunc & seen


def decide_many(jammed, test: JamTest) -> dict[str, np.ndarray]:
    """The test on many streams at once: ``jammed`` (streams x samples, bool; the samples
    beyond the maximum are ignored) -> arrays ``verdict`` (-1 undecided, 0 pass, 1 warning,
    2 error), ``decided``, ``samples`` (the stopping index, or all samples when undecided),
    ``jams``, ``truncated`` (the verdict needed a test decided by the truncation), and per test
    ``warning_side``/``error_side`` (-1, 0 below, 1 above), ``..._at``, ``..._truncated``.
    A one-threshold question (``test.question``) stops at that test's crossing; its
    ``verdict`` is -1 where the side leaves two verdicts open (``decided`` says it answered)."""
    x = np.asarray(jammed, dtype=bool)
    if x.ndim != 2:
        raise ValueError("jammed must be a 2D array: streams x samples")
    x = x[:, :test.max_samples]
    s, m = x.shape
    cumk = np.cumsum(x, axis=1, dtype=np.int64)
    full = np.full(s, m >= test.max_samples)
    ws, wat, wtr = _first_crossings(test.warning, cumk, full)
    es, eat, etr = _first_crossings(test.error, cumk, full)
    if test.question == JamQuestion.VERDICT:
        error = (es == 1) & ~((ws == 0) & (wat < eat))  # an error unless the pass came strictly first
        passed = (ws == 0) & ~((es == 1) & (eat <= wat))
        warning = (ws == 1) & (es == 0)
        verdict = np.select([error, passed, warning], [2, 0, 1], -1)
        n = np.select([error, passed, warning], [eat, wat, np.maximum(wat, eat)], m)
        truncated = np.select([error, passed, warning], [etr, wtr, wtr | etr], False)  # the tests the verdict used
        decided = verdict >= 0
    else:  # one threshold's test alone: below the warning threshold pins a pass, above the error one an error
        side, at, trunc = (ws, wat, wtr) if test.question == JamQuestion.WARNING else (es, eat, etr)
        if not test.truncate:  # undecided at the maximum: no side, the stream ends there
            side, at = np.where(trunc, -1, side), np.where(trunc, m, at)
            if test.question == JamQuestion.WARNING:
                ws, wat = side, at
            else:
                es, eat = side, at
        decided = (side >= 0) | trunc
        pinned = side == 0 if test.question == JamQuestion.WARNING else side == 1
        verdict = np.where(pinned, 0 if test.question == JamQuestion.WARNING else 2, -1)
        n = np.where(decided, at, m)
        truncated = trunc & decided
        # the other test as far as the stream goes (its first n samples): the same answer
        # however many samples past the stop were folded
        if test.question == JamQuestion.WARNING:
            es, eat, etr = _seen(es, eat, etr, n, m)
        else:
            ws, wat, wtr = _seen(ws, wat, wtr, n, m)
    k = np.where(n > 0, cumk[np.arange(s), np.maximum(n, 1) - 1] if m else 0, 0)
    return {"verdict": verdict, "decided": decided, "samples": n, "jams": k, "truncated": truncated,
            "warning_side": ws,
            "warning_at": wat, "warning_truncated": wtr, "error_side": es, "error_at": eat, "error_truncated": etr}


def decide(jammed: Sequence[bool], test: JamTest) -> JamDecision:
    """The test on one stream of outcomes (True: the sample jammed), in order."""
    x = np.asarray(list(jammed), dtype=bool).reshape(1, -1)
    r = {key: v[0] for key, v in decide_many(x, test).items()}

    def one(name: str) -> SprtOutcome:
        side = int(r[f"{name}_side"])
        return SprtOutcome(None if side < 0 else _SIDES[side], int(r[f"{name}_at"]) if side >= 0 else 0,
                           bool(r[f"{name}_truncated"]))

    v = int(r["verdict"])
    return JamDecision(test, None if v < 0 else _VERDICTS[v], int(r["samples"]), int(r["jams"]), one("warning"),
                       one("error"), bool(r["truncated"]))


def confidence_sequence(jams: int, samples: int, level: float = JAM_INTERVAL_LEVEL) -> tuple[float, float]:
    """The anytime-valid interval for p after ``samples`` samples with ``jams`` jams: the
    p at which the Beta(1, 1) mixture martingale B(k + 1, n - k + 1) / (p^k (1 - p)^(n - k))
    stays below 1 / (1 - level) (Robbins 1970; by Ville's inequality it covers the true p at
    every n at once with probability >= level). Its ends solve the equality (Brent's method,
    :mod:`.interval`).

    >>> [round(x, 4) for x in confidence_sequence(0, 57)]
    [0.0, 0.1164]
    """
    k, n = int(jams), int(samples)
    if not 0 <= k <= n:
        raise ValueError(f"need 0 <= jams <= samples, got {jams}, {samples}")
    if n == 0:
        return 0.0, 1.0
    return _lower_end(k, n, level), 1.0 - _lower_end(n - k, n, level)


def load_interval_solver() -> None:
    """Import the Beta function :func:`confidence_sequence` uses (scipy.special), e.g.
    while a pool folds the samples."""
    from scipy.special import betaln  # noqa: F401


def _lower_end(k: int, n: int, level: float) -> float:
    """The interval's lower end (0 when k = 0): :func:`.interval.lower_end`."""
    from .interval import lower_end

    return lower_end(k, n, level)


@dataclass(frozen=True)
class OperatingPoint:
    """The test on ``streams`` Bernoulli(p) streams: the share of each verdict, the
    average sample number, and the share truncated at the maximum."""

    p: float
    streams: int
    passed: float
    warning: float
    error: float
    average_samples: float
    truncated: float


def operating_point(p: float, test: JamTest, streams: int, seed: int, block: int = 4096) -> OperatingPoint:
    """Simulate the test on ``streams`` independent streams of outcomes that jam with
    probability ``p`` (one seeded generator; pure numpy, in blocks of ``block`` streams).
    The verdict's test only (a one-threshold question's rates are its :class:`Sprt`'s)."""
    if test.question != JamQuestion.VERDICT:
        raise ValueError("operating_point simulates the verdict's test; ask JamQuestion.VERDICT")
    rng = np.random.default_rng(seed)
    counts = np.zeros(3)
    total_n = truncated = 0
    left = int(streams)
    while left > 0:
        b = min(block, left)
        r = decide_many(rng.random((b, test.max_samples)) < p, test)
        counts += np.bincount(r["verdict"], minlength=3)[:3]
        total_n += int(r["samples"].sum())
        truncated += int(r["truncated"].sum())
        left -= b
    return OperatingPoint(float(p), int(streams), *(counts / streams), total_n / streams, truncated / streams)
