"""The jam probability against an independent reference.

A two-panel strip with one H-7 hinge, given a run just long enough for the nominal hinge to
reach 98 %, and a scatter model with only the bath temperature spread (shared by the part):
the sample jams ("unfolded": the hinge is short of 98 % when the run ends) exactly when its
bath is colder than the bath b* at which the hinge's 98 % time equals the run. b* comes from
the recovery model alone (a root of the fold time, no kinematics, no Monte-Carlo), so

* the Monte-Carlo must count, sample by sample, exactly the draws whose bath is below b*;
* its probability must match the truncated-normal tail P(bath < b*) within binomial error.

A jam counter that forgets "unfolded" samples, or counts a finished one, fails both.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.stats import norm

from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.physics.recovery.curve import recovery_curve
from foldprint.simulation.robust import jam_probability
from foldprint.simulation.scatter import TRUNCATE_SD, Scatter, component, draw_samples

BATH_SD_C = 1.0
SAMPLES = 96  # six chunks: enough draws on both sides of b* for the exact count to bite
SEED = 11
DT_S = 0.01  # the Monte-Carlo's time step (core.constants.DEFAULT_DT_S)


def _t98(lib, bath_c: float, fix_c: float) -> float:
    t = recovery_curve(lib["H-7"], bath_c, 0.8, fix_c).fold_time
    assert t is not None
    return t


@pytest.fixture(scope="module")
def case():
    lib = default_library()
    d = strip("ref", [12.0, 12.0], [90.0], ["H-7"], hinge_thickness=0.8)
    fix_c = d.process.fix_temperature_c
    # run length: the 98 % time at a bath 0.8 sd below nominal, so about 21 % of parts jam
    b_ref = d.process.bath_temperature_c - 0.8 * BATH_SD_C
    run = round(_t98(lib, b_ref, fix_c), 2) + 0.005  # between two grid times of the default 0.01 s step
    d = replace(d, process=replace(d.process, duration_s=run))
    run = math.ceil(run / DT_S) * DT_S  # a run ends at the first grid time at or past its duration
    b_star = brentq(lambda b: _t98(lib, b, fix_c) - run, b_ref - 2.0, b_ref + 2.0, xtol=1e-6)
    scatter = replace(Scatter.zero(), **{component("bath").attr: BATH_SD_C})  # the bath alone
    return d, lib, scatter, b_star


def test_the_reference_root_is_where_the_fold_time_crosses_the_run(case):
    d, lib, _, b_star = case
    run, fix_c = math.ceil(d.process.duration_s / DT_S) * DT_S, d.process.fix_temperature_c
    assert _t98(lib, b_star - 0.05, fix_c) > run > _t98(lib, b_star + 0.05, fix_c)


def test_monte_carlo_counts_exactly_the_draws_colder_than_the_root(case):
    d, lib, scatter, b_star = case
    r = jam_probability(d, SAMPLES, SEED, scatter=scatter, library=lib, workers=1, dt=DT_S)
    baths = np.array([s.bath_c for s in draw_samples(d, scatter, SAMPLES, SEED)])
    clear = np.abs(baths - b_star) > 0.01  # a draw within round-off of the root may go either way
    assert clear.sum() >= SAMPLES - 2
    expected = baths < b_star
    got = np.array([o.jammed for o in r.outcomes])
    assert got[clear].tolist() == expected[clear].tolist()
    assert 5 <= expected.sum() <= SAMPLES - 5  # the case has jams and folds
    for o, e in zip(r.outcomes, expected):
        if e:
            assert o.reason == "unfolded" and o.fold_time is None and o.pair is None
        else:
            assert o.reason is None and o.fold_time is not None and o.fold_time <= math.ceil(d.process.duration_s / DT_S) * DT_S + 1e-9


def test_jam_probability_matches_the_truncated_normal_tail(case):
    d, lib, scatter, b_star = case
    r = jam_probability(d, SAMPLES, SEED + 1, scatter=scatter, library=lib, workers=1)
    z = (b_star - d.process.bath_temperature_c) / BATH_SD_C
    lo_cdf = norm.cdf(-TRUNCATE_SD)
    p = (norm.cdf(max(z, -TRUNCATE_SD)) - lo_cdf) / (1.0 - 2.0 * lo_cdf)  # clipped draws sit at +-3 sd
    assert 0.1 < p < 0.35
    # four binomial standard errors: a false alarm about once in 16 000 seeds
    assert abs(r.jam_probability - p) <= 4.0 * math.sqrt(p * (1 - p) / SAMPLES)


def test_percentiles_are_numpys_on_the_same_outcomes(case):
    d, lib, scatter, _ = case
    r = jam_probability(d, SAMPLES, SEED, scatter=scatter, library=lib, workers=1)
    ft = np.array([o.fold_time for o in r.outcomes if o.fold_time is not None])
    got = r.fold_time_percentiles()
    assert ft.size > 10 and np.ptp(ft) > 0.05  # spread enough that 90th and 95th differ
    for key, q in (("p5", 5), ("p50", 50), ("p95", 95)):
        assert got[key] == pytest.approx(float(np.percentile(ft, q)), abs=1e-12)
    assert got["p95"] != pytest.approx(float(np.percentile(ft, 90)), abs=1e-6)
