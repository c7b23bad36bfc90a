"""The scatter model's split (foldprint.simulation.scatter): what a part or run shares, what varies
hinge to hinge; common random numbers; contributions and the sigma sweep
(foldprint.simulation.sensitivity)."""

import json

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.cli.commands import main
from foldprint.model.design import strip
from foldprint.io.design_io import design_to_toml
from foldprint.core.errors import DesignError
from foldprint.simulation.robust import jam_probability
from foldprint.simulation.scatter import COMPONENTS, KEYS, Scatter, default_scatter, draw_samples
from foldprint.simulation.sensitivity import contributions, parse_scales, sweep

D = strip("s", [20, 20, 25, 25, 30], [90, 90, 90, 90], ["H-2", "H-3", "H-3", "H-5"])


def _ln_h(samples):
    return np.log(np.array([s.h_scale for s in samples]))


def test_shared_components_are_one_draw_per_sample():
    """The part's h and the bath are the same for every hinge of a sample and vary between
    samples by their spread; the per-hinge components differ between the hinges."""
    sc = default_scatter()
    shared = draw_samples(D, sc.only(["h_shared", "bath"]), 400, 5)
    ln = _ln_h(shared)
    assert np.ptp(ln, axis=1).max() < 1e-12  # one factor per part
    assert ln[:, 0].std() == pytest.approx(sc.h_shared_sigma_ln, rel=0.15)
    assert np.array([s.bath_c for s in shared]).std() == pytest.approx(sc.bath_sd_c, rel=0.15)
    assert all(np.allclose(s.h_part, s.h_scale) for s in shared)
    local = draw_samples(D, sc.only(["h_local", "tg"]), 400, 5)
    ln = _ln_h(local)
    within = ln - ln.mean(axis=1, keepdims=True)
    assert within.std() * np.sqrt(4 / 3) == pytest.approx(sc.h_local_sigma_ln, rel=0.15)  # 4 hinges, ddof
    assert {s.bath_c for s in local} == {D.process.bath_temperature_c} and {s.h_part for s in local} == {1.0}
    tg = np.array([s.tg_shift_c for s in local])
    assert abs(np.corrcoef(tg[:, 0], tg[:, 1])[0, 1]) < 0.15  # independent between hinges


@settings(max_examples=25, deadline=None)
@given(k=st.floats(0.0, 4.0), seed=st.integers(0, 2**31), n=st.integers(1, 6))
def test_same_draws_whatever_the_spreads(k, seed, n):
    """Common random numbers: scaling the model scales each sample's deviation from
    nominal (log scale for h); switching a component off leaves the others' values; the
    first samples of a longer run are the samples of a shorter one."""
    sc = default_scatter()
    a = draw_samples(D, sc, n, seed)
    b = draw_samples(D, sc.scaled(k), n, seed)
    t0 = np.array([h.thickness for h in D.hinges])
    for x, y in zip(a, b):
        assert np.allclose(y.tg_shift_c, k * x.tg_shift_c)
        assert np.allclose(np.log(y.h_scale), k * np.log(x.h_scale))
        assert y.bath_c - 90.0 == pytest.approx(k * (x.bath_c - 90.0))
        if np.all(x.thickness_mm > 0.05 * t0) and np.all(y.thickness_mm > 0.05 * t0):
            assert np.allclose(y.thickness_mm - t0, k * (x.thickness_mm - t0))
    c = draw_samples(D, sc.without("tg"), n, seed)
    assert all(np.array_equal(x.h_scale, z.h_scale) and x.bath_c == z.bath_c and not z.tg_shift_c.any()
               for x, z in zip(a, c))
    longer = draw_samples(D, sc, n + 3, seed)
    assert all(np.array_equal(x.tg_shift_c, z.tg_shift_c) for x, z in zip(a, longer))


def test_scatter_validates_its_spreads():
    with pytest.raises(DesignError, match="tg"):
        Scatter(1.0, 0.2, -1.0, 0.04, 0.1)
    with pytest.raises(DesignError, match="scale"):
        default_scatter().scaled(float("nan"))
    with pytest.raises(DesignError, match="wobble"):
        default_scatter().only(["wobble"])
    assert parse_scales("2, 0.5,1,1") == (0.5, 1.0, 2.0)
    for bad in ("", "a,1", "-1", "inf"):
        with pytest.raises(DesignError, match="--scales"):
            parse_scales(bad)


def test_one_component_model_contributions_are_exact():
    """A model with Tg alone: Tg alone is the full run, sample by sample, and all but Tg
    is the nominal part; the other components, switched off, are not folded again."""
    sc = default_scatter().only(["tg"]).scaled(3.0)
    full = jam_probability(D, 3, 2, scatter=sc, workers=1)
    parts = contributions(D, full, workers=1)
    by = {it.component.key: it for it in parts.items}
    assert set(by) == set(KEYS)
    assert by["tg"].alone.outcomes == full.outcomes
    nominal_outcome = by["bath"].alone.outcomes[0]
    assert by["tg"].without.outcomes == (nominal_outcome,) * 3
    assert all(by[k].without is full and by[k].spread == 0 for k in KEYS if k != "tg")


def test_sweep_reuses_the_base_and_scale_zero_is_nominal():
    full = jam_probability(D, 2, 4, workers=1)
    pts = sweep(D, full, (1.0, 0.0, 0.5), workers=1)
    assert [p.scale for p in pts] == [0.0, 0.5, 1.0]
    assert pts[2].result is full
    assert pts[0].result.jams == (0 if full.nominal.completed else 2)
    assert pts[1].result.scatter == full.scatter.scaled(0.5)


def test_robust_cli_contributions_and_sensitivity(tmp_path, capsys):
    f = tmp_path / "strip.toml"
    f.write_text(design_to_toml(D))
    assert main(["robust", str(f), "--samples", "2", "--seed", "1", "--json", "--contributions", "--sensitivity",
                 "--scales", "0,1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [c["component"] for c in out["contributions"]] == [c.key for c in COMPONENTS]
    assert {c["scope"] for c in out["contributions"]} == {"shared", "hinge"}
    for c in out["contributions"]:
        for e in (c["alone"], c["all_but"]):
            assert e["samples"] == 2 and 0 <= e["ci95"][0] <= e["jam_probability"] <= e["ci95"][1] <= 1
    assert [p["scale"] for p in out["sensitivity"]] == [0.0, 1.0]
    assert out["sensitivity"][1]["jams"] == out["jams"]
    assert set(out["scatter"]) == set(KEYS) and all(out["scatter"][k]["source"] for k in KEYS)
    shipped = {k: default_scatter().basis(k).value for k in KEYS}  # what each spread rests on, in the JSON
    assert {k: out["scatter"][k]["basis"] for k in KEYS} == shipped
    assert {c["component"]: c["basis"] for c in out["contributions"]} == shipped


@pytest.mark.parametrize("args", [["check", "helix_graded", "--scales", "x"], ["robust", "helix_graded", "--scales", "-1"]])
def test_bad_scales_exit_2(capsys, args):
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--scales" in err[0]


def test_shared_scatter_keeps_identical_hinges_identical():
    """The physics of the split: a bath or a correlation error shared by the part moves
    every hinge of a uniform strip the same way (the nominal path, at another pace); the
    per-hinge components make them differ."""
    from foldprint.model.materials import default_library
    from foldprint.simulation.robust import sample_drive

    d = strip("u", [20, 22, 24, 26], [90, 90, 90], ["H-3"] * 3)
    sc = default_scatter().scaled(2.0)
    t = np.linspace(0.0, 8.0, 81)
    for s in draw_samples(d, sc.only(["bath", "h_shared"]), 3, 11):
        a = sample_drive(d, default_library(), s).angles(t)
        assert np.ptp(a, axis=1).max() < 1e-9
    spread = [np.ptp(sample_drive(d, default_library(), s).angles(t), axis=1).max()
              for s in draw_samples(d, sc.only(["h_local"]), 3, 11)]
    assert min(spread) > 1e-3


def test_streamed_samples_are_the_drawn_samples():
    """Streaming in blocks gives the very numbers of one draw (bounded memory, same answer)."""
    from foldprint.simulation.scatter import iter_samples, samples_between

    from foldprint.io.load import load_design
    from foldprint.io.templates import resolve_design_path

    d = load_design(resolve_design_path("helix_graded"))
    sc = default_scatter()
    whole = draw_samples(d, sc, 300, 7)
    streamed = list(iter_samples(d, sc, 300, 7, block=64))
    assert len(streamed) == 300
    for a, b in zip(whole, streamed):
        assert np.array_equal(a.tg_shift_c, b.tg_shift_c) and np.array_equal(a.h_scale, b.h_scale)
        assert np.array_equal(a.thickness_mm, b.thickness_mm) and a.bath_c == b.bath_c
    # a chunk's own samples (the pool's tasks draw only theirs): the very ones of the stream
    for start, stop in ((0, 5), (60, 70), (63, 65), (290, 300), (299, 300), (10, 10)):
        part = samples_between(d, sc, 7, start, stop)
        assert len(part) == stop - start
        for a, b in zip(whole[start:stop], part):
            assert np.array_equal(a.tg_shift_c, b.tg_shift_c) and np.array_equal(a.h_scale, b.h_scale)
            assert np.array_equal(a.thickness_mm, b.thickness_mm) and a.bath_c == b.bath_c


def test_robust_leaves_contributions_to_an_opt_in(tmp_path, capsys):
    """A plain robust folds the samples once (contributions cost about 11x: --contributions)."""
    f = tmp_path / "strip.toml"
    f.write_text(design_to_toml(D))
    assert main(["robust", str(f), "--samples", "2", "--seed", "1", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["contributions"] is None
