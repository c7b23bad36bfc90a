"""The Monte-Carlo's fast path: batched recovery curves (foldprint.physics.recovery.batch) against
the exact per-curve model (the exact sum to round-off, the relaxation table to its bound), the
chunked and guarded jam probability, the worker pool."""

import inspect
import json
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.cli.commands import main
from foldprint.core.constants import CHECK_SAMPLES
from foldprint.core.guards import ResourceError
from foldprint.simulation.costs import check_samples
from foldprint.io.load import load_design
from foldprint.physics.recovery.curve import _curve, _slab_roots
from foldprint.physics.recovery.curve import spectrum
from foldprint.physics.recovery.batch import batch_ratios, grid_until, slab_roots
from foldprint.physics.recovery.relaxation import CUT, relaxation_table
from foldprint.simulation.robust import (default_scatter, draw_samples, iter_samples, jam_probability, run_end, run_samples,
                              sample_drive, sample_drives, wilson)
from foldprint.io.templates import resolve_design_path

#: What the exact batch path may differ from the exact curve by: round-off (measured 2e-15).
ROUND_OFF = 1e-12
#: What the relaxation table may differ from the exact sum by, and so the table's curves
#: from the exact ones (measured 5.5e-9 at the shipped step; 4.9e-8 at 3x it, 5.5e-7 at 10x).
TABLE_BOUND = 2e-8


def _exact(lib, name, tg, hw, th, bath, horizon=600.0):
    m = lib[name]
    m = replace(m, tg_c=float(tg), recovery=replace(m.recovery, h_w_m2k=float(hw)))
    return _curve(m, float(bath), float(th), 10.0, horizon)


@settings(max_examples=12, deadline=None)
@given(name=st.sampled_from(["H-1", "H-3", "H-5", "H-7"]), dtg=st.floats(-3, 3), hs=st.floats(0.55, 1.8),
       th=st.floats(0.5, 1.3), bath=st.floats(60.0, 95.0), until=st.floats(0.5, 59.0))
def test_batch_curve_equals_the_exact_model_up_to_the_run_end(lib, name, dtg, hs, th, bath, until):
    p = lib[name].recovery
    t = grid_until(until)
    assert t[-1] >= until and t[-2] < until + 0.01
    ref = _exact(lib, name, lib[name].tg_c + dtg, p.h_w_m2k * hs, th, bath)
    assert np.array_equal(ref.t[:len(t)], t)
    for table, bound in ((False, ROUND_OFF), (True, TABLE_BOUND)):
        r, mean_t = batch_ratios(p, [lib[name].tg_c + dtg], [p.h_w_m2k * hs], [th], [bath], 10.0, t, table)
        assert np.max(np.abs(r[0] - ref.ratio[:len(t)])) < bound
        assert np.max(np.abs(mean_t[0] - ref.mean_temperature_c[:len(t)])) < 1e-9


@pytest.mark.parametrize("table, bound", [(False, ROUND_OFF), (True, TABLE_BOUND)])
def test_batch_over_the_whole_horizon_keeps_fold_times(lib, table, bound):
    """Past 60 s the grid turns geometric: the full horizon is the exact curve too."""
    t = grid_until(float("inf"))
    p = lib["H-7"].recovery
    r, _ = batch_ratios(p, [65.0, 66.0], [p.h_w_m2k, 0.6 * p.h_w_m2k], [0.8, 1.2], [70.0, 90.0], 10.0, t, table)
    for k, args in enumerate([(65.0, p.h_w_m2k, 0.8, 70.0), (66.0, 0.6 * p.h_w_m2k, 1.2, 90.0)]):
        ref = _exact(lib, "H-7", *args)
        assert len(t) == len(ref.t) and np.max(np.abs(r[k] - ref.ratio)) < bound


def _exact_sum(p, xi):
    tau, g = spectrum(p)
    x = np.asarray(xi, float)[:, None] / tau[None, :]
    return np.sum(np.where(x <= CUT, g * np.exp(-np.minimum(x, CUT)), 0.0), axis=1)


def test_relaxation_table_error_is_bounded(lib):
    """The table against the exact sum of the 16 exponentials over a wide range of reduced
    times (R = 1 - a weighted mean of U: the bound holds for the ratio): inside the bound
    at the shipped step, outside it at 3x the step (a coarser table fails this test)."""
    xi = np.concatenate([[0.0], np.logspace(-20, 12, 100_001)])
    for name in ("H-1", "H-4", "H-7"):
        p = lib[name].recovery
        err = np.max(np.abs(relaxation_table(p)(xi) - _exact_sum(p, xi)))
        assert 1e-10 < err < TABLE_BOUND
        from foldprint.core.constants import RELAXATION_TABLE_STEP

        assert np.max(np.abs(relaxation_table(p, 3 * RELAXATION_TABLE_STEP)(xi) - _exact_sum(p, xi))) > TABLE_BOUND


def test_relaxation_table_ends(lib):
    """Below the first node the table holds U(1e-13 tau_1) (1 to 1e-13); past CUT tau_16,
    where every branch is cut, it is exactly 0, as the exact sum."""
    p = lib["H-3"].recovery
    tau, _ = spectrum(p)
    table = relaxation_table(p)
    low = table(np.array([1e9, 0.0, 1e-30, 1e-13 * tau[0]]))[1:]  # any order
    assert np.all(np.abs(low - 1.0) < 1e-12)
    high = np.array([CUT * tau[-1] * (1 + 1e-9), 1e9, 1e300])
    assert np.array_equal(table(high), np.zeros(3)) and np.array_equal(_exact_sum(p, high), np.zeros(3))
    mid = np.geomspace(tau[0], tau[-1], 50)
    assert np.all(np.diff(table(mid)) < 0)  # U falls as xi rises


@pytest.mark.parametrize("table", [False, True])
def test_a_curve_does_not_depend_on_its_batch(lib, table):
    """Negligible terms are cut element by element: alone or among others, bit for bit
    the same curve (so the answer cannot depend on how samples are chunked)."""
    p, t = lib["H-1"].recovery, grid_until(20.0)
    args = ([32.3, 64.5, 40.0], [300.0, 420.0, 361.8], [0.78, 0.85, 0.6], [89.5, 90.7, 75.0])
    together, _ = batch_ratios(p, *args, 10.0, t, table)
    for k in range(3):
        alone, _ = batch_ratios(p, *([a[k]] for a in args), 10.0, t, table)
        assert np.array_equal(alone[0], together[k])


@pytest.mark.parametrize("table", [False, True])
def test_blocks_of_any_length_give_the_same_curves(lib, monkeypatch, table):
    """The time axis is computed block by block, the reduced time and the rate carried from
    one block to the next: blocks of 8 times (every block boundary a carry) give bit for
    bit the curves of the default blocks, at every grid time."""
    from foldprint.physics.recovery import batch as recovery_batch

    p, t = lib["H-4"].recovery, grid_until(25.0)
    args = ([40.0, 45.5, 51.0, 43.0], [200.0, 260.0, 320.0, 150.0], [0.7, 0.8, 1.1, 0.9], [70.0, 80.0, 90.0, 85.0])
    big = batch_ratios(p, *args, 10.0, t, table)
    monkeypatch.setattr(recovery_batch, "BLOCK_ELEMENTS", 1)
    small = batch_ratios(p, *args, 10.0, t, table)
    assert np.array_equal(big[0], small[0]) and np.array_equal(big[1], small[1])
    folded = t[np.argmax(big[0] >= 0.98, axis=1)]  # hinges apart: blocks where some are cut, some not
    assert np.all(big[0][:, -1] >= 0.98) and np.ptp(folded) > 1.0


@settings(max_examples=30, deadline=None)
@given(m=st.integers(0, 40), rows=st.integers(1, 3), seed=st.integers(0, 2**16))
def test_running_sum_is_the_cumsum_from_its_start(m, rows, seed):
    """The reduced time's running sum, in groups of SUM_GROUP and a tail: start + the
    cumulative sum, and start becomes the last sum (what the next block starts from)."""
    from foldprint.physics.recovery.batch import _running_sum

    rng = np.random.default_rng(seed)
    inc, start = rng.random((rows, 2, m)), rng.random((rows, 2))
    want = start[..., None] + np.cumsum(inc, axis=-1)
    out = np.full(rows * 2 * m + 3, np.nan)
    got = _running_sum(inc.copy(), start, out)
    assert got.shape == inc.shape and np.allclose(got, want, rtol=1e-14, atol=0)
    if m:
        assert np.array_equal(start, got[..., -1])


def test_the_monte_carlo_reads_the_relaxation_table(lib, monkeypatch, graded):
    """table=True (what sample_drives asks for) reads U from the table, the default sums
    the exponentials: a coarse table moves the first's curve, not the second's, and the
    Monte-Carlo's drives follow the coarse table."""
    from foldprint.physics.recovery import batch as recovery_batch

    p, t = lib["H-5"].recovery, grid_until(15.0)
    args = ([48.5, 50.0], [227.0, 300.0], [0.8, 0.9], [90.0, 85.0])
    table, exact = batch_ratios(p, *args, 10.0, t, True)[0], batch_ratios(p, *args, 10.0, t)[0]
    assert 0 < np.max(np.abs(table - exact)) < TABLE_BOUND
    coarse = {}
    monkeypatch.setattr(recovery_batch, "relaxation_table", lambda q: coarse.setdefault(q, relaxation_table(q, 0.5)))
    assert np.max(np.abs(batch_ratios(p, *args, 10.0, t, True)[0] - exact)) > 1e-4
    assert np.array_equal(batch_ratios(p, *args, 10.0, t)[0], exact)
    drawn = draw_samples(graded, default_scatter(), 1, 3)
    times = np.linspace(0.0, 10.0, 101)
    fast = sample_drives(graded, lib, drawn, until_s=10.0)[0].ratios(times)
    assert np.max(np.abs(fast - sample_drive(graded, lib, drawn[0], exact=True).ratios(times))) > 1e-4


@pytest.mark.parametrize("biot_scale", [1.0, 100.0])
def test_slab_terms_past_their_cut_are_exactly_zero(lib, biot_scale):
    """A thin hinge (0.2 mm) heats through: past its first term's cut (Fo zeta^2 > CUT,
    every term cut) its excess temperature is exactly 0, before it positive, also where a
    thicker hinge of its batch (0.25 mm) is still computed; at the shipped h (40 s) and at
    100x it (Bi ~ 45, zeta_0^2 > 1: 1.9 s)."""
    from foldprint.physics.recovery.batch import _slab, _slab_block
    from foldprint.physics.recovery.relaxation import Block, fresh_arrays

    p = lib["H-2"].recovery
    hw = np.full(2, p.h_w_m2k * biot_scale)
    slab, thin = _slab(p, hw, np.array([0.2, 0.25])), _slab(p, hw[:1], np.array([0.2]))
    tb = np.linspace(0.75, 1.5, 61) * slab.t_cut[0]
    v = Block(fresh_arrays(8 * len(tb)), 2, 4, len(tb))
    _slab_block(slab, tb, v, slab.nsq.shape[1])
    past = tb > thin.t_cut[0]
    assert np.sum(past & (tb < slab.t_cut[0])) > 10
    assert np.all(v.theta[0][:, past] == 0.0) and np.all(v.theta[0][:, ~past] > 0.0)
    assert np.all(v.theta[1][:, tb < slab.t_cut[0]] > 0.0)


def test_relaxation_branches_past_their_cut_are_exactly_zero(lib):
    """The exact sum, element by element: where every branch is past its cut (xi > CUT
    tau_16) U is exactly 0, also in a block whose other elements are not cut; elsewhere
    the sum of the exponentials."""
    from foldprint.physics.recovery.batch import _unrecovered_block
    from foldprint.physics.recovery.relaxation import Block, fresh_arrays

    p = lib["H-2"].recovery
    tau, g = spectrum(p)
    xi = np.array([0.0, 1e-3, 1.0, 1e3, 1e5, 60.0 * tau[-1], 1e9])[None, None, :]
    v = Block(fresh_arrays(xi.size), 1, 1, xi.shape[-1])
    _unrecovered_block(xi, tau, g, v, 0)
    assert np.array_equal(v.u[0, 0, -2:], np.zeros(2))
    assert np.allclose(v.u[0, 0, :-2], _exact_sum(p, xi[0, 0, :-2]), rtol=1e-14, atol=0)


def test_a_batch_split_for_memory_gives_every_hinge_its_exact_curve(lib, monkeypatch):
    """Over the element bound, a batch is computed in parts (here 2 hinges a part, 5
    hinges): each hinge's ratio and mean temperature are still the exact model's."""
    from foldprint.physics.recovery import batch as recovery_batch
    from foldprint.physics.recovery.curve import N_LAYERS

    t = grid_until(20.0)
    monkeypatch.setattr(recovery_batch, "MAX_BATCH_ELEMENTS", 2 * len(t) * N_LAYERS // 2)
    p = lib["H-3"].recovery
    tg, hw = [38.0, 40.5, 43.0, 41.0, 39.5], [p.h_w_m2k * f for f in (0.7, 1.0, 1.3, 0.9, 1.6)]
    th, bath = [0.6, 0.8, 1.0, 1.2, 0.7], [70.0, 75.0, 80.0, 85.0, 90.0]
    r, mean_t = batch_ratios(p, tg, hw, th, bath, 10.0, t)
    assert r.shape == mean_t.shape == (5, len(t))
    for k in range(5):
        ref = _exact(lib, "H-3", tg[k], hw[k], th[k], bath[k])
        assert np.max(np.abs(r[k] - ref.ratio[:len(t)])) < ROUND_OFF
        assert np.max(np.abs(mean_t[k] - ref.mean_temperature_c[:len(t)])) < 1e-9


def test_vectorised_roots_match_the_scalar_bisection():
    biot = np.array([1e-4, 0.3, 0.72, 5.0, 80.0])
    ref = np.array([_slab_roots(b) for b in biot])
    assert np.max(np.abs(slab_roots(biot) - ref) / ref) < 1e-14


@pytest.fixture(scope="module")
def graded(lib):
    return load_design(resolve_design_path("helix_graded"), lib)


def test_streamed_draws_are_the_listed_draws(graded):
    a = draw_samples(graded, default_scatter(), 40, 5)
    b = list(iter_samples(graded, default_scatter(), 40, 5))
    assert all(np.array_equal(x.tg_shift_c, y.tg_shift_c) and x.bath_c == y.bath_c for x, y in zip(a, b))


def test_sample_drives_match_the_exact_drive(graded, lib):
    drawn = draw_samples(graded, default_scatter(), 2, 3)
    until = run_end(graded, 0.01)
    times = np.linspace(0.0, until, 777)
    for s, fast in zip(drawn, sample_drives(graded, lib, drawn, until_s=until)):
        exact = sample_drive(graded, lib, s, exact=True)
        assert np.max(np.abs(fast.ratios(times) - exact.ratios(times))) < TABLE_BOUND


def test_fast_and_exact_paths_give_the_same_verdicts(graded, lib):
    """The same draws through the exact per-curve path and the batch path: the same jam
    verdict per sample (the curves agree to the relaxation table's 2e-8, far inside any contact
    tolerance), the same fold and contact times. Samples with and without a jam (the
    spreads doubled: at 1x the split scatter model jams the graded helix too rarely)."""
    drawn = draw_samples(graded, default_scatter().scaled(2.0), 32, 1)
    fast = run_samples((graded, lib, drawn, "arc", 0.01))
    jammed = [k for k, o in enumerate(fast) if o.jammed]
    ok = [k for k, o in enumerate(fast) if not o.jammed]
    assert jammed and ok, "the draws should include both verdicts"
    pick = jammed[:1] + ok[:2]
    exact = run_samples((graded, lib, [drawn[k] for k in pick], "arc", 0.01, True))
    for k, e in zip(pick, exact):
        f = fast[k]
        assert (f.jammed, f.reason, f.pair) == (e.jammed, e.reason, e.pair)
        for a, b in ((f.fold_time, e.fold_time), (f.time, e.time)):
            assert (a is None) == (b is None) and (a is None or abs(a - b) <= 1e-3)


def test_chunking_and_workers_do_not_change_the_answer(graded, lib):
    one = jam_probability(graded, 20, 4, library=lib, workers=1)
    two = jam_probability(graded, 20, 4, library=lib, workers=2, nominal=one.nominal)
    assert one.outcomes == two.outcomes


def test_check_samples_refuses_only_over_budget(monkeypatch):
    monkeypatch.setenv("FOLDPRINT_TIME_BUDGET", "100")
    assert check_samples(1000, 0.1, 2) == pytest.approx(50.0)
    with pytest.raises(ResourceError, match=r"estimated 1e\+08 s .*over the 1.67 min time budget.*about 1000 samples"):
        check_samples(10 ** 9, 0.2, 2, "helix")


def test_millions_of_samples_are_refused_with_the_estimate(capsys):
    """A million outcomes fit in memory (1 KiB each); their time does not fit the 15 min budget."""
    code = main(["robust", "helix_graded", "--samples", "1000000"])
    err = capsys.readouterr().err
    assert code == 2 and "refused: estimated" in err and "ms per sample" in err and "Traceback" not in err


def test_check_default_samples_separate_the_thresholds():
    """One constant: the CLI and the pipeline use it, and at it the 95 % intervals at 5 %
    and 20 % jam probability do not overlap (they do at the old 20)."""
    from foldprint.cli import commands as cli
    from foldprint.apps import pipeline

    assert inspect.signature(pipeline.evaluate).parameters["samples"].default == CHECK_SAMPLES
    assert inspect.signature(cli.check).parameters["samples"].default.default == CHECK_SAMPLES
    n = CHECK_SAMPLES
    assert wilson(0.05 * n, n)[1] < wilson(0.2 * n, n)[0]
    assert wilson(0.05 * 20, 20)[1] > wilson(0.2 * 20, 20)[0]


def _blas_threads(_):
    from threadpoolctl import threadpool_info

    return max((p["num_threads"] for p in threadpool_info()), default=1)


def test_workers_run_with_one_blas_thread():
    from foldprint.core.parallel import map_ordered

    assert map_ordered(_blas_threads, iter(range(4)), workers=2, total=4) == [1, 1, 1, 1]


def test_map_ordered_streams_a_generator_in_order():
    from foldprint.core.parallel import map_ordered

    seen = []
    out = map_ordered(abs, (-k for k in range(30)), workers=2, total=30, progress=lambda d, n: seen.append((d, n)))
    assert out == list(range(30)) and seen[-1] == (30, 30)


def test_robust_json_reports_what_it_ran(capsys):
    assert main(["robust", "helix_graded", "--samples", "20", "--seed", "2", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["samples"] == 20 and 0.0 <= out["jam_probability"] <= 1.0


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(["H-1", "H-4", "H-7"]), tg_shift=st.floats(-5.0, 5.0),
       temps=st.lists(st.floats(-20.0, 120.0), min_size=1, max_size=30))
def test_batch_shift_rate_is_the_models_shift_bit_for_bit(lib, name, tg_shift, temps):
    """The batch's in-place 1 / a_T is recovery.log10_shift's, exponentiated, to the bit
    (a second copy of the WLF/Arrhenius law, kept for speed: it must not drift)."""
    from foldprint.physics.recovery.curve import log10_shift
    from foldprint.physics.recovery.batch import _LN10, _rate

    p = lib[name].recovery
    tg = lib[name].tg_c + tg_shift
    temp = np.asarray(temps, float)[:, None]
    want = np.exp(-_LN10 * log10_shift(temp, tg, p))
    got = _rate(temp.copy(), np.full_like(temp, tg), p)
    assert np.array_equal(got, want)
    work = (np.full_like(temp, np.nan), np.full_like(temp, np.nan))
    into = _rate(temp.copy(), np.full_like(temp, tg), p, out=np.full_like(temp, np.nan), work=work)
    assert np.array_equal(into, want)
