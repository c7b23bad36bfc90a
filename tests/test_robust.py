"""Jam probability under scatter (foldprint.simulation.robust, foldprint robust)."""

import json
import math

import numpy as np
import pytest
from scipy.stats import binomtest

from foldprint.cli.commands import main
from foldprint.model.design import Goal, strip
from foldprint.model.materials import default_library
from foldprint.simulation.robust import (Scatter, default_scatter, draw_samples, jam_probability, load_scatter,
                              sample_drive, wilson)
from foldprint.simulation.scatter import KEYS
from foldprint.simulation.simulate import simulate


@pytest.mark.parametrize("k,n", [(0, 60), (1, 60), (6, 60), (30, 60), (60, 60), (3, 7), (0, 1), (1, 1)])
def test_wilson_matches_scipy(k, n):
    ref = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    lo, hi = wilson(k, n)
    assert lo == pytest.approx(ref.low, abs=1e-9) and hi == pytest.approx(ref.high, abs=1e-9)


def test_default_scatter_carries_sources():
    s = default_scatter()
    assert all(s.spread(k) > 0 for k in KEYS)
    assert set(s.sources) == set(KEYS)
    assert all(len(v) > 20 for v in s.sources.values())
    j = s.to_json()
    assert {k: j[k]["scope"] for k in KEYS} == {"bath": "shared", "h_shared": "shared", "tg": "hinge",
                                                 "thickness": "hinge", "h_local": "hinge"}


def test_samples_are_seeded_and_truncated():
    d = strip("s", [20, 20, 20], [90, 90], ["H-1", "H-7"])
    a = draw_samples(d, default_scatter(), 200, 7)
    b = draw_samples(d, default_scatter(), 200, 7)
    assert all(np.array_equal(x.tg_shift_c, y.tg_shift_c) and x.bath_c == y.bath_c for x, y in zip(a, b))
    tg = np.array([x.tg_shift_c for x in a])
    assert np.abs(tg).max() <= 3.0 * default_scatter().tg_sd_c + 1e-12
    assert 0.8 < tg.std() < 1.2  # sd 1 C, truncated at 3 sd
    c = draw_samples(d, default_scatter(), 200, 8)
    assert not np.array_equal(a[0].tg_shift_c, c[0].tg_shift_c)


def test_zero_scatter_reproduces_the_nominal_fold():
    d = strip("z", [20, 25, 20], [90, 90], ["H-2", "H-5"])
    zero = Scatter.zero()
    (s,) = draw_samples(d, zero, 1, 0)
    drive = sample_drive(d, default_library(), s)
    nominal = simulate(d, method="fcl")
    assert np.allclose(drive.angles(nominal.trajectory.times), nominal.trajectory.angles, atol=1e-12)


def test_hotter_or_thinner_hinges_fold_sooner():
    """A physical direction check on the sampled drive: higher Tg -> later."""
    d = strip("t", [20, 20], [90], ["H-4"])
    lib = default_library()
    (s,) = draw_samples(d, Scatter.zero(), 1, 0)
    base = sample_drive(d, lib, s).curves[0].fold_time
    hot = sample_drive(d, lib, type(s)(s.tg_shift_c + 2.0, s.thickness_mm, s.h_scale, s.bath_c)).curves[0].fold_time
    thin = sample_drive(d, lib, type(s)(s.tg_shift_c, s.thickness_mm * 0.9, s.h_scale, s.bath_c)).curves[0].fold_time
    assert hot > base > thin


def test_same_seed_same_answer_on_one_or_two_processes():
    d = strip("r", [20, 20, 25, 25], [90, 90, 90], ["H-3", "H-3", "H-3"])
    a = jam_probability(d, 6, 3, workers=1)
    b = jam_probability(d, 6, 3, workers=2)
    assert a.outcomes == b.outcomes and a.ci95 == b.ci95


def test_robust_cli_contract(capsys):
    code = main(["robust", "helix_graded", "--samples", "4", "--seed", "1", "--json", "--no-contributions"])
    out = json.loads(capsys.readouterr().out)
    assert code == 0
    assert {"design", "samples", "seed", "hinge_model", "jam_probability", "ci95", "collisions", "fold_time_s",
            "nominal"} <= set(out)
    assert out["samples"] == 4 and out["seed"] == 1 and out["hinge_model"] == "arc"
    lo, hi = out["ci95"]
    assert 0 <= lo <= out["jam_probability"] <= hi <= 1
    assert out["nominal"]["completed"] is True
    ft = out["fold_time_s"]
    assert ft is None or ft["p5"] <= ft["p50"] <= ft["p95"]
    assert main(["robust", "helix_graded", "--samples", "4", "--seed", "1", "--json", "--no-contributions"]) == 0
    assert json.loads(capsys.readouterr().out) == out


def test_robust_says_what_check_makes_of_its_samples(capsys):
    """robust keeps its fixed count (Wilson) and, on check's seed, says where check's
    sequential test stops on these very samples; on another seed, that they differ."""
    assert main(["robust", "helix_uniform", "--samples", "16", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["samples"] == 16 and out["test"] is None and out["interval"] == "Wilson score interval"
    rel = out["check"]
    assert rel["same_stream"] and rel["decided"] and rel["verdict"] == "error" and rel["samples"] == 6
    assert main(["check", "helix_uniform", "--json", "--no-sensitivity"]) == 1
    chk = json.loads(capsys.readouterr().out)["robust"]
    assert (chk["samples"], chk["jams"], chk["seed"]) == (rel["samples"], rel["jams"], out["seed"])
    assert main(["robust", "helix_uniform", "--samples", "2", "--seed", "3"]) == 0
    text = capsys.readouterr().out
    assert "check draws seed 0, other samples than these (seed 3)" in text


@pytest.mark.parametrize("text,needle", [
    ("[hinge.tg]\nsd_c = -1.0\n", "hinge.tg.sd_c"),
    ("[hinge.tg]\nsd_c = nan\n", "hinge.tg.sd_c"),
    ("[shared.bath]\nsd_c = 1.0\nspread = 2\n", "shared.bath.spread"),
    ("[wobble]\nsd = 1\n", "[wobble]"),
    ("[shared.wobble]\nsd = 1\n", "[shared.wobble]"),
    ("[hinge.thickness]\nsd_mm = \"x\"\n", "hinge.thickness.sd_mm"),
    ("[heat_transfer]\nsigma_ln = 0.2\n", "[shared.heat_transfer]"),  # schema 1: says where it went
    ("schema = 1\n", "schema"),
])
def test_bad_scatter_file_exit_2(tmp_path, capsys, text, needle):
    f = tmp_path / "s.toml"
    f.write_text(text)
    before = set(tmp_path.iterdir())
    code = main(["robust", "helix_graded", "--samples", "2", "--scatter", str(f)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and needle in err[0] and str(f) in err[0]
    assert set(tmp_path.iterdir()) == before
    with pytest.raises(Exception):
        load_scatter(f)


@pytest.mark.parametrize("args", [["--samples", "0"], ["--samples", "-3"], ["--seed", "-1"]])
def test_bad_sample_options_exit_2(capsys, args):
    assert main(["robust", "helix_graded", *args]) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_override_keeps_other_fields(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text("[hinge.tg]\nsd_c = 2.5\nsource = 'our DMA'\n")
    s = load_scatter(f)
    assert s.tg_sd_c == 2.5 and s.sources["tg"] == "our DMA"
    assert math.isclose(s.bath_sd_c, default_scatter().bath_sd_c)
    assert s.sources["bath"] == default_scatter().sources["bath"]


# -- the batch path's guarantees, the precomputed path, progress ---------------------------------

def test_sample_drives_are_read_only_and_refuse_a_non_finite_draw():
    """A sample's curves are frozen like every model array; a NaN draw is refused by name."""
    from foldprint.core.errors import MaterialError
    from foldprint.simulation.robust import sample_drives

    d = strip("f", [20, 20, 20], [90, 90], ["H-1", "H-7"])
    lib = default_library()
    (s,) = draw_samples(d, default_scatter(), 1, 2)
    for c in sample_drives(d, lib, [s])[0].curves:
        for a in (c.ratio, c.mean_temperature_c):
            with pytest.raises(ValueError, match="read-only"):
                a[0] = 0.5
    nan = np.full_like(s.tg_shift_c, np.nan)
    for bad, what in [(type(s)(s.tg_shift_c, s.thickness_mm, s.h_scale, float("nan")), "bath temperature"),
                      (type(s)(nan, s.thickness_mm, s.h_scale, s.bath_c), "Tg shift"),
                      (type(s)(s.tg_shift_c, nan, s.h_scale, s.bath_c), "hinge thickness"),
                      (type(s)(s.tg_shift_c, s.thickness_mm, nan, s.bath_c), "heat-transfer multiplier")]:
        with pytest.raises(MaterialError, match=rf"^f: a drawn {what} is not finite$"):
            sample_drives(d, lib, [bad])


def test_precomputed_outcomes_are_returned_without_folding(monkeypatch):
    """A mapper holding this design's outcomes (simulation.jamtest.pool.Precomputed): the same
    result, no sample folded, progress told the whole count at once."""
    from foldprint.simulation import robust
    from foldprint.core.constants import DEFAULT_DT_S
    from foldprint.simulation.jamtest.pool import Precomputed

    d = strip("p", [20, 20, 25], [90, 90], ["H-3", "H-5"])
    ref = jam_probability(d, 5, 4, workers=1)
    pre = Precomputed(d.name, 5, 4, ref.hinge_model, DEFAULT_DT_S, ((ref.scatter, ref.outcomes, None),), ref.method)

    def no_fold(*_a, **_k):
        raise AssertionError("a precomputed sample was folded again")

    monkeypatch.setattr(robust, "run_samples", no_fold)
    calls = []
    got = jam_probability(d, 5, 4, nominal=ref.nominal, mapper=pre, progress=lambda a, b: calls.append((a, b)))
    assert got.outcomes == ref.outcomes and got.jams == ref.jams and calls == [(5, 5)]


def test_progress_counts_every_chunk_and_one_worker_stays_in_process(monkeypatch):
    """Three chunks on one worker: no process pool is started, and progress climbs chunk by
    chunk to the whole count (the last chunk short)."""
    from foldprint.core import parallel
    from foldprint.simulation.robust import CHUNK

    def no_pool(*_a, **_k):
        raise AssertionError("workers=1 started a process pool")

    monkeypatch.setattr(parallel, "ProcessPoolExecutor", no_pool)
    d = strip("c", [15, 15], [90], ["H-7"])
    n = 2 * CHUNK + 3
    calls = []
    r = jam_probability(d, n, 1, workers=1, progress=lambda a, b: calls.append((a, b)))
    assert len(r.outcomes) == n
    assert calls == [(CHUNK, n), (2 * CHUNK, n), (n, n)]


def test_the_sample_count_guard_extrapolates_the_first_chunks_time_per_sample(monkeypatch):
    """A clock on which the first chunk of CHUNK samples takes CHUNK seconds: 1 s a sample,
    so 2 CHUNK + 1 samples on one worker are estimated at 2 CHUNK + 1 s, refused under a
    budget one second shorter and run under one that holds them."""
    from foldprint.core.guards import ResourceError
    from foldprint.simulation import robust
    from foldprint.simulation.robust import CHUNK

    ticks = iter([0.0, float(CHUNK)] * 2)
    monkeypatch.setattr(robust, "work_cpu_s", lambda: next(ticks))
    d = strip("g", [15, 15], [90], ["H-7"])
    n = 2 * CHUNK + 1
    monkeypatch.setenv("FOLDPRINT_TIME_BUDGET", str(n - 1))
    with pytest.raises(ResourceError, match=rf"^g: --samples {n} refused: estimated {n} s \(1e\+03 ms per sample"):
        jam_probability(d, n, 1, workers=1)
    monkeypatch.setenv("FOLDPRINT_TIME_BUDGET", str(n))
    assert len(jam_probability(d, n, 1, workers=1).outcomes) == n


def test_outcome_of_names_each_way_a_sample_fails():
    """A finished fold, a collision, a goal missed with every hinge home, a hinge short of
    home: the four outcomes, each with only the data that belongs to it."""
    from dataclasses import replace

    from foldprint.collision.goals import GoalResult
    from foldprint.core.modes import JamReason
    from foldprint.simulation.robust import outcome_of

    d = strip("o", [20, 20, 25], [90, 90], ["H-3", "H-5"])
    done = simulate(d, method="fcl")
    assert done.completed and done.fold_time is not None
    assert outcome_of(done) == type(outcome_of(done))(False, None, None, None, done.fold_time)
    goal = Goal("g1", "pass_through", "p1", "p2", 0, np.zeros(2))
    missed = replace(done, goals=(GoalResult(goal, False, None, True, ()),))
    assert outcome_of(missed) == type(outcome_of(done))(True, JamReason.GOAL, None, None, None)
    short = simulate(replace(d, process=replace(d.process, duration_s=done.fold_time / 4)), method="fcl")
    assert not short.completed and short.first_collision is None
    assert outcome_of(short) == type(outcome_of(done))(True, JamReason.UNFOLDED, None, None, None)


def test_a_bar_hinge_estimate_says_so_and_folds_that_model():
    """``mechanics`` reaches the result (the report labels the estimate with it) and every
    sample: each outcome is the bar-and-hinge fold of that sample's own drive."""
    from foldprint.simulation.robust import outcome_of

    d = strip("b", [15, 15], [90], ["H-7"])
    r = jam_probability(d, 2, 1, mechanics="bar-hinge", workers=1, dt=0.02)
    assert r.mechanics == "bar-hinge" and r.nominal.compliant is not None
    lib = default_library()
    for o, smp in zip(r.outcomes, draw_samples(d, default_scatter(), 2, 1)):
        res = simulate(d, dt=0.02, method="fcl", drive=sample_drive(d, lib, smp), mechanics="bar-hinge")
        assert outcome_of(res) == o
