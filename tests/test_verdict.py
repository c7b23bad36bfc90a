"""check's sequential jam test (foldprint.simulation.jamtest.verdict): the SPRT boundaries and steps
against hand-computed values, streams that stop where a hand count says, the verdict's
independence of how a stream is cut, the stated error rates on simulated Bernoulli
streams, and the confidence sequence's values and its coverage over time."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from foldprint.core.constants import CHECK_SAMPLES, JAM_TEST_ALPHA, JAM_TEST_BETA
from foldprint.core.errors import DesignError
from foldprint.core.modes import JamQuestion, JamVerdict, Side
from foldprint.simulation.jamtest.verdict import (Sprt, confidence_sequence, decide, decide_many, indifference, jam_test,
                                          operating_point)

T = jam_test()  # check's defaults: warning 5 % (2.5-7.5 %), error 20 % (15-25 %), 5 % error rates, 400 samples


def test_boundaries_and_steps_by_hand():
    # A = log(1 / 0.05) = log 20, B = log 0.05; a jam adds log(hi / lo), a clean sample log((1 - hi) / (1 - lo))
    for sprt in (T.warning, T.error):
        assert sprt.upper == pytest.approx(2.995732273553991, abs=1e-12)
        assert sprt.lower == pytest.approx(-2.995732273553991, abs=1e-12)
        assert sprt.midpoint == pytest.approx(0.0, abs=1e-12)
    assert (T.warning.lo, T.warning.hi, T.error.lo, T.error.hi) == (0.025, 0.075, 0.15, 0.25)
    assert T.warning.jam_step == pytest.approx(1.0986122886681098)  # log 3
    assert T.warning.clean_step == pytest.approx(-0.05264373348542191)  # log(0.925 / 0.975)
    assert T.error.jam_step == pytest.approx(0.5108256237659907)  # log(5 / 3)
    assert T.error.clean_step == pytest.approx(-0.12516314295400605)  # log(0.75 / 0.85)
    assert float(T.error.llr(3, 10)) == pytest.approx(3 * 0.5108256237659907 - 7 * 0.12516314295400605)
    assert T.max_samples == CHECK_SAMPLES and (T.warning.alpha, T.warning.beta) == (JAM_TEST_ALPHA, JAM_TEST_BETA)


def test_indifference_rule_and_edges():
    assert indifference(0.05) == (0.025, 0.075) and indifference(0.2) == (0.15, 0.25)  # theta/2..3theta/2, theta-/+0.05
    assert indifference(0.5) == (0.45, 0.55) and indifference(0.01) == (0.005, 0.015)
    assert indifference(0.0) == (0.0, 0.005) and indifference(1.0) == (0.95, 1.0)  # cut to [0, 1]
    with pytest.raises(DesignError):
        indifference(1.5)
    with pytest.raises(DesignError):
        jam_test(max_samples=0)


def test_streams_stop_where_a_hand_count_says():
    # every sample jams: the warning test crosses log 20 at 3 jams (3 log 3 = 3.30), the
    # error test at 6 (6 log(5/3) = 3.06; 5 give 2.55): an error after 6 samples
    d = decide([True] * 50, T)
    assert (d.verdict, d.samples, d.jams) == (JamVerdict.ERROR, 6, 6)
    assert (d.warning.side, d.warning.at, d.error.side, d.error.at) == (Side.ABOVE, 3, Side.ABOVE, 6)
    # none jams: the error test says below at 24 clean (24 x 0.1252 = 3.004; 23: 2.879), the
    # warning test at 57 (57 x 0.05264 = 3.0007; 56: 2.948): a pass after 57
    d = decide([False] * 100, T)
    assert (d.verdict, d.samples, d.jams, d.error.at) == (JamVerdict.PASS, 57, 0, 24)
    # three jams, then clean: "above 5 %" at sample 3, and the error test's L = 3 x 0.5108 -
    # m x 0.1252 reaches -2.996 at m = 37 clean samples (36.18 by hand): a warning after 40
    d = decide([True] * 3 + [False] * 100, T)
    assert (d.verdict, d.samples, d.jams) == (JamVerdict.WARNING, 40, 3)
    assert not d.truncated
    # too few samples to decide: more are needed, nothing is claimed
    d = decide([False] * 56, T)
    assert d.verdict is None and not d.decided and d.samples == 56


def test_truncation_decides_by_the_sign_at_the_maximum():
    short = jam_test(max_samples=10)
    d = decide([False] * 10, short)  # L_warning = 10 x -0.0526 = -0.53: undecided, below the midpoint 0
    assert (d.verdict, d.samples, d.truncated) == (JamVerdict.PASS, 10, True)
    assert d.warning == type(d.warning)(Side.BELOW, 10, True)
    d = decide([True] + [False] * 9, short)  # 1.0986 - 9 x 0.0526 = 0.625 > 0: above 5 %; error test below
    assert (d.verdict, d.truncated) == (JamVerdict.WARNING, True) and d.error.side == Side.BELOW
    # samples past the maximum are ignored
    assert decide([False] * 10 + [True] * 50, short) == decide([False] * 10, short)


@settings(max_examples=200, deadline=None, derandomize=True)
@given(hs.lists(hs.booleans(), min_size=0, max_size=120), hs.integers(1, 120), hs.floats(0.0, 0.6))
def test_a_decision_does_not_depend_on_where_the_stream_is_cut(head, max_samples, p_tail):
    """Deciding on a prefix either says "undecided" or gives the very decision of any
    longer stream (the stopping index is a function of the outcomes up to it); the
    one-stream and many-stream paths agree."""
    test = jam_test(max_samples=max_samples)
    rng = np.random.default_rng(len(head))
    full = head + list(rng.random(max_samples) < p_tail)
    d_full = decide(full, test)
    assert d_full.decided  # a stream that reaches the maximum is always decided
    assert 1 <= d_full.samples <= max_samples and d_full.jams == sum(full[:d_full.samples])
    d_head = decide(head, test)
    if d_head.decided:
        assert d_head == d_full
    else:
        assert d_head.samples == min(len(head), max_samples) and d_full.samples >= d_head.samples
    many = decide_many(np.array([full[:max_samples]]), test)
    assert int(many["samples"][0]) == d_full.samples and int(many["jams"][0]) == d_full.jams


#: The stated error rates: at p at or below the lower end of a threshold's region the
#: chance of the worse verdict, at or above its upper end the chance of missing it.
CASES = [(0.02, "not pass"), (0.025, "not pass"), (0.075, "pass"), (0.10, "pass"), (0.15, "error"),
         (0.05, None), (0.20, None), (0.25, "not error"), (0.30, "not error")]


@pytest.mark.parametrize("p,wrong", CASES)
def test_error_rates_are_what_is_stated(p, wrong):
    """20 000 Bernoulli streams per p (one seed; pure numpy): the share of wrong verdicts
    stays below 5 % plus three standard errors of the simulation; the average sample
    number stays below what docs/verdict.md states (170)."""
    n = 20_000
    o = operating_point(p, T, n, seed=int(p * 1000))
    rate = {"not pass": 1 - o.passed, "pass": o.passed, "error": o.error, "not error": 1 - o.error, None: 0.0}[wrong]
    limit = 0.05 + 3 * math.sqrt(0.05 * 0.95 / n)
    assert rate <= limit, (p, wrong, rate)
    assert o.average_samples <= 170 and o.passed + o.warning + o.error == pytest.approx(1.0)


def test_operating_point_matches_the_one_stream_path():
    rng = np.random.default_rng(7)
    x = rng.random((300, T.max_samples)) < 0.12
    many = decide_many(x, T)
    for row, v, n in zip(x, many["verdict"], many["samples"]):
        d = decide(row, T)
        assert (["pass", "warning", "error"][v], n) == (str(d.verdict), d.samples)


def _loglik(k, n, q):
    return (k * math.log(q) if k else 0.0) + ((n - k) * math.log1p(-q) if n - k else 0.0)


def _g(k, n, p):
    """log of the Beta(1, 1) mixture's likelihood ratio at p, by numerical integration (an
    independent reference for the interval's ends): log int_0^1 q^k (1-q)^(n-k) dq - log p^k (1-p)^(n-k)."""
    from scipy.integrate import quad

    mode = k / n
    top = _loglik(k, n, mode)
    integral = quad(lambda q: math.exp(_loglik(k, n, q) - top), 0, 1, points=[mode] if 0 < mode < 1 else None,
                    limit=200, epsabs=0, epsrel=1e-11)[0]
    return math.log(integral) + top - _loglik(k, n, p)


@pytest.mark.parametrize("k,n", [(0, 57), (3, 40), (6, 6), (26, 105), (1, 1), (199, 400), (400, 400), (5, 400)])
def test_confidence_sequence_ends_solve_the_mixture_equation(k, n):
    lo, hi = confidence_sequence(k, n)
    assert 0 <= lo <= k / n <= hi <= 1
    for end in (lo, hi):
        if 0 < end < 1:
            assert _g(k, n, end) == pytest.approx(math.log(20), abs=1e-6)  # B / (p^k (1-p)^(n-k)) = 1 / 0.05
    # just inside the interval the ratio is below 20, just outside above
    eps = 1e-4
    if lo > eps:
        assert _g(k, n, lo - eps) > math.log(20) > _g(k, n, lo + eps)
    if hi < 1 - eps:
        assert _g(k, n, hi + eps) > math.log(20) > _g(k, n, hi - eps)


def test_brent_roots_are_scipys_bit_for_bit():
    """The interval's root finder is scipy's brentq step for step: the same ends on check's
    (k, n) (every k of every 7th n up to the maximum), and on a few other functions."""
    from scipy.optimize import brentq as scipy_brentq
    from scipy.special import betaln

    from foldprint.simulation.jamtest.interval import brentq

    for n in range(1, 401, 7):
        for k in range(1, n + 1):
            c = math.log(1.0 - 0.95) + float(betaln(k + 1, n - k + 1))

            def g(p, k=k, n=n, c=c):
                return k * math.log(p) + ((n - k) * math.log1p(-p) if k < n else 0.0) - c
            assert brentq(g, 1e-300, k / n, 1e-14, 1e-12) == scipy_brentq(g, 1e-300, k / n, xtol=1e-14, rtol=1e-12)
            assert confidence_sequence(k, n)[0] == scipy_brentq(g, 1e-300, k / n, xtol=1e-14, rtol=1e-12)
    for f, a, b in ((math.cos, 0.0, 3.0), (lambda x: x ** 3 - 2 * x - 5, 2.0, 3.0), (math.expm1, -1.0, 2.0),
                    (lambda x: math.atan(x - 1e-3), -5.0, 7.0)):
        assert brentq(f, a, b, 2e-12, 4 * 2.220446049250313e-16) == scipy_brentq(f, a, b)
    with pytest.raises(ValueError):
        brentq(math.cos, 0.0, 1.0, 1e-12, 1e-12)


def test_confidence_sequence_by_hand():
    # k = 0: B(1, n + 1) = 1 / (n + 1), so the upper end solves (1 - p)^n = 0.05 / (n + 1)
    n = 57
    assert confidence_sequence(0, n)[1] == pytest.approx(1 - (0.05 / (n + 1)) ** (1 / n), abs=1e-10)
    assert confidence_sequence(0, 0) == (0.0, 1.0)
    # k = n = 6: the lower end solves p^6 = 0.05 / 7
    assert confidence_sequence(6, 6)[0] == pytest.approx((0.05 / 7) ** (1 / 6), abs=1e-10)
    with pytest.raises(ValueError):
        confidence_sequence(3, 2)


@pytest.mark.parametrize("p", [0.03, 0.2, 0.6])
def test_confidence_sequence_covers_at_every_time_at_once(p):
    """Anytime-valid: the share of streams whose interval misses the true p at ANY of
    their first 400 samples is at most 5 % (plus three standard errors)."""
    streams = 1500
    rng = np.random.default_rng(11)
    x = rng.random((streams, 400)) < p
    cs = lru_cache(maxsize=None)(confidence_sequence)
    ks = np.cumsum(x, axis=1)
    missed = 0
    for row in ks:
        for n in range(1, 401):
            lo, hi = cs(int(row[n - 1]), n)
            if not lo <= p <= hi:
                missed += 1
                break
    assert missed / streams <= 0.05 + 3 * math.sqrt(0.05 * 0.95 / streams)


def test_unequal_error_rates_reach_every_boundary():
    """alpha != beta (the defaults are equal, which hides a midpoint or a rate dropped):
    the boundaries follow the rates given to jam_test, and the truncation point lies
    halfway between them."""
    t = jam_test(alpha=0.01, beta=0.3)
    for sprt in (t.warning, t.error):
        assert (sprt.upper, sprt.lower) == pytest.approx((math.log(100.0), math.log(0.3)), abs=1e-12)
        assert sprt.upper - sprt.midpoint == pytest.approx(sprt.midpoint - sprt.lower, abs=1e-12)


@pytest.mark.parametrize("n", [1, 2, 7, 40])
def test_llr_is_the_binomial_likelihood_ratio(n):
    """L after n samples with k jams is log(P(k | hi) / P(k | lo)) of the binomial (scipy),
    down to a single sample either way."""
    from scipy.stats import binom

    sprt = T.warning
    k = np.arange(n + 1)
    want = binom.logpmf(k, n, sprt.hi) - binom.logpmf(k, n, sprt.lo)
    assert np.allclose(sprt.llr(k, np.full(n + 1, n)), want, rtol=0, atol=1e-9)


def _first_crossing_by_hand(row, sprt, max_samples):
    """One threshold's test on one stream, a plain loop: (side, samples) at its first
    crossing, the sign at the maximum when it never crosses (None, n: not yet)."""
    llr = 0.0
    for n, jam in enumerate(row[:max_samples], start=1):
        llr += sprt.jam_step if jam else sprt.clean_step
        if llr >= sprt.upper or llr <= sprt.lower:
            return (Side.ABOVE if llr >= sprt.upper else Side.BELOW), n
    if len(row) >= max_samples:
        return (Side.ABOVE if llr >= sprt.midpoint else Side.BELOW), max_samples
    return None, len(row)


@pytest.mark.parametrize("probing", [False, True])
@pytest.mark.parametrize("question", [JamQuestion.WARNING, JamQuestion.ERROR])
def test_a_one_threshold_question_stops_at_that_tests_crossing(question, probing):
    """A sweep point or probe asks one threshold: it stops where a plain loop over that
    threshold's SPRT says, whatever the other test does; below 5 % pins a pass, above 20 %
    an error, the other side leaves two verdicts open. A probe (not truncating) that
    reaches the maximum without a crossing is undecided there, every verdict open."""
    t = jam_test(max_samples=120).probing(question) if probing else jam_test(max_samples=120).asking(question)
    assert t.question == question and t.truncate is (not probing)  # a bool, as the field says
    sprt = t.warning if question == JamQuestion.WARNING else t.error
    rng = np.random.default_rng(11)
    for p in (0.0, 0.03, 0.05, 0.06, 0.12, 0.2, 0.3, 0.9):
        for row in rng.random((40, 130)) < p:
            for cut in (130, 37):  # the whole stream, or a prefix that may not have decided yet
                d = decide(row[:cut], t)
                side, n = _first_crossing_by_hand(row[:cut], sprt, t.max_samples)
                if probing and side is not None and n == t.max_samples and len(row[:cut]) >= t.max_samples \
                        and abs(float(sprt.llr(row[:n].sum(), n))) < max(sprt.upper, -sprt.lower):
                    side = "undecided"  # reached the maximum without crossing: no side
                if side == "undecided":
                    assert d.decided and d.undecided_at_max and d.samples == t.max_samples and d.asked.side is None
                    assert d.verdicts == (JamVerdict.PASS, JamVerdict.WARNING, JamVerdict.ERROR)
                    continue
                assert not d.undecided_at_max
                assert d.decided == (side is not None) and d.samples == n and d.jams == int(row[:n].sum())
                crossed = side is not None and abs(float(sprt.llr(row[:n].sum(), n))) >= min(sprt.upper, -sprt.lower)
                assert d.truncated == (side is not None and not crossed)  # decided by the sign at the maximum
                if side is None:
                    assert d.verdicts == () and d.verdict is None
                    continue
                assert d.asked.side == side
                assert decide(row[:d.samples], t) == d  # nothing past the stop shows, the other test neither
                open_ = {(JamQuestion.WARNING, Side.BELOW): (JamVerdict.PASS,),
                         (JamQuestion.WARNING, Side.ABOVE): (JamVerdict.WARNING, JamVerdict.ERROR),
                         (JamQuestion.ERROR, Side.BELOW): (JamVerdict.PASS, JamVerdict.WARNING),
                         (JamQuestion.ERROR, Side.ABOVE): (JamVerdict.ERROR,)}[question, side]
                assert d.verdicts == open_ and d.verdict == (open_[0] if len(open_) == 1 else None)


@pytest.mark.parametrize("question,p,wrong", [(JamQuestion.WARNING, 0.025, Side.ABOVE),
                                              (JamQuestion.WARNING, 0.075, Side.BELOW),
                                              (JamQuestion.ERROR, 0.15, Side.ABOVE),
                                              (JamQuestion.ERROR, 0.25, Side.BELOW)])
def test_a_one_threshold_question_keeps_its_error_rates(question, p, wrong):
    """20 000 Bernoulli streams at the edges of the asked threshold's region: the wrong side
    at most 5 % (plus three standard errors of the simulation), as the full test states."""
    n = 20_000
    t = T.asking(question)
    r = decide_many(np.random.default_rng(int(p * 1000) + 5).random((n, t.max_samples)) < p, t)
    side = r["warning_side"] if question == JamQuestion.WARNING else r["error_side"]
    assert r["decided"].all()
    rate = float(np.mean(side == (1 if wrong == Side.ABOVE else 0)))
    assert rate <= 0.05 + 3 * math.sqrt(0.05 * 0.95 / n), (question, p, rate)


def test_operating_point_refuses_a_one_threshold_question():
    with pytest.raises(ValueError, match="verdict"):
        operating_point(0.1, T.asking(JamQuestion.WARNING), 10, seed=0)


def test_bad_error_rates_and_thresholds_are_refused_by_name():
    with pytest.raises(DesignError, match="error rates need 0 < alpha, beta and alpha \\+ beta < 1, got 0.6, 0.5"):
        Sprt(0.05, 0.025, 0.075, 0.6, 0.5)
    with pytest.raises(DesignError, match=r"warning threshold \(0.3, --warn-above\) must be below its error "
                                          r"threshold \(0.1, --error-above\)"):
        jam_test(0.3, 0.1)
    with pytest.raises(DesignError, match="must be below"):
        jam_test(0.2, 0.2)


def test_a_region_up_to_certainty_proves_p_below_one_with_one_clean_sample():
    """hi = 1 (a threshold of 1): a clean sample adds -inf, so one clean sample accepts
    "below"; a jam adds log(1 / 0.95) and "above" needs many."""
    sprt = Sprt(1.0, *indifference(1.0))
    assert (sprt.lo, sprt.hi) == (0.95, 1.0) and sprt.clean_step == -math.inf
    assert float(sprt.llr(0, 1)) == -math.inf and float(sprt.llr(3, 3)) == pytest.approx(3 * math.log(1 / 0.95))


def test_operating_point_does_not_depend_on_its_blocks():
    """The same streams judged in blocks of 64 or all at once: the same shares and the
    same average sample number (every block's samples counted)."""
    a = operating_point(0.1, T, 300, seed=3, block=64)
    b = operating_point(0.1, T, 300, seed=3, block=300)
    assert a == b and a.average_samples > 20


def test_check_refuses_a_warning_threshold_above_the_error_threshold(capsys, tmp_path, monkeypatch):
    """At the command line: exit 2, one line naming both options, nothing on stdout."""
    from foldprint.cli.commands import main

    monkeypatch.chdir(tmp_path)
    assert main(["check", "self_lock", "--warn-above", "0.3", "--error-above", "0.1", "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1 and "--warn-above" in err and "--error-above" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("p,wrong", [(0.025, 1), (0.075, 0)])
def test_a_probe_capped_at_its_maximum_keeps_its_error_rates(p, wrong):
    """A probe (the warning threshold alone, undecided at PROBE_MAX_SAMPLES): on 20 000
    Bernoulli streams at each edge of the region it names the wrong side at most 5 % of
    the time (plus three standard errors), however many end undecided (the share the
    constant's comment states, 11 % and 8 %, within 2 points)."""
    from foldprint.core.constants import PROBE_MAX_SAMPLES

    n = 20_000
    t = T.probing(JamQuestion.WARNING, PROBE_MAX_SAMPLES)
    assert t.max_samples == PROBE_MAX_SAMPLES < T.max_samples and not t.truncate
    r = decide_many(np.random.default_rng(17 + wrong).random((n, t.max_samples)) < p, t)
    assert r["decided"].all()
    undecided = (r["warning_side"] < 0).mean()
    assert float(np.mean(r["warning_side"] == wrong)) <= 0.05 + 3 * math.sqrt(0.05 * 0.95 / n)
    assert abs(undecided - {0.025: 0.11, 0.075: 0.08}[p]) < 0.02
