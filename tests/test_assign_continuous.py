"""Continuous assign (``foldprint assign --continuous``, VeroWhite fractions and bath): the surrogate
against the seven-grade proxy and the per-curve recovery model it linearises, the
optimiser against its starting points, the fold orders against independent simulations,
and the written design against ``foldprint robust``."""

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.apps.assign.search import with_materials
from foldprint.apps.assign.continuous import TG_GRID_STEP_C, _levels_for, assign_continuous, find_chains
from foldprint.apps.assign.surrogate import (canonical_tg, chain_risk, material_name, optimise_levels, tg_bounds,
                                             timing_table)
from foldprint.apps.assign.ledger import Ledger
from foldprint.apps.assign.tasks import local_mapper
from foldprint.cli.commands import main
from foldprint.core.modes import Method
from foldprint.io.design_io import design_to_toml
from foldprint.io.load import load_design
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.simulation.robust import default_scatter, jam_probability
from foldprint.simulation.simulate import simulate
from foldprint.simulation.timing import _time_spread, order_risk

LIB = default_library()
SCATTER = default_scatter()
LO, HI = tg_bounds()
GRID = np.arange(LO, HI + 1e-9, TG_GRID_STEP_C)


def _spiral(materials=("H-3", "H-3", "H-3")):
    """The first four panels of the paper's helix (three corner hinges)."""
    return strip("spiral4", [30, 30, 35.8, 35.8], [90, 90, 90], list(materials), radius=5.0)


@pytest.fixture(scope="module")
def table90():
    return timing_table(LIB, 90.0, 0.8, 10.0, SCATTER, GRID, 40.0)


def test_material_names_round_trip_to_their_tg():
    """A Tg maps to the nearest canonical VeroWhite fraction; the library synthesises that
    name at the Tg :func:`canonical_tg` reports, within a step of the fraction's rounding."""
    for tg in (LO, 37.2, 48.5, 61.13, HI):
        name = material_name(tg)
        assert name.startswith("VW") and LIB[name].tg_c == pytest.approx(canonical_tg(tg), abs=1e-9)
        assert abs(canonical_tg(tg) - tg) < 0.05  # 0.001 of fraction is ~0.08 C here
        assert material_name(canonical_tg(tg)) == name


def test_timing_table_equals_the_per_curve_linearisation(table90):
    """The batch table gives the numbers of :func:`timing._time_spread` (per-curve recovery
    model, the proxy of the seven-grade search) at its grid points."""
    for i in (0, 17, 40, len(GRID) - 1):
        m = LIB[material_name(GRID[i])]
        base, var, shared = _time_spread(m, 90.0, 0.8, 10.0, SCATTER)
        assert table90.tg_c[i] == pytest.approx(m.tg_c)
        np.testing.assert_allclose(table90.log_t[i], base, rtol=1e-6, atol=1e-9)
        np.testing.assert_allclose(table90.var[i], var, rtol=1e-5, atol=1e-12)
        np.testing.assert_allclose(table90.shared[i], shared, rtol=1e-5, atol=1e-12)


@settings(max_examples=10, deadline=None)
@given(st.lists(st.integers(0, (len(GRID) - 1) // 4), min_size=2, max_size=9))
def test_chain_risk_of_a_monotone_chain_is_order_risk(table90, idx):
    """For levels rising along the chain the signed surrogate is the seven-grade proxy
    :func:`order_risk` (an independent implementation), ties included; reversing the chain
    can only raise it."""
    idx = sorted(4 * i for i in idx)  # every 2 C: few distinct materials for order_risk's cache
    d = strip("s", [30.0] * (len(idx) + 1), [90.0] * len(idx), ["H-1"] * len(idx), radius=5.0)
    mats = [material_name(table90.tg_c[i]) for i in idx]
    values = table90.splines()(table90.tg_c[idx])
    r = chain_risk(values, math.log(20.0))
    assert r == pytest.approx(order_risk(d, LIB, mats, 90.0, SCATTER), rel=1e-6, abs=1e-9)
    assert chain_risk(values[::-1], math.log(20.0)) >= r - 1e-12


def test_optimised_levels_beat_their_starts_and_the_grades(table90):
    n, log_dur = 9, math.log(20.0)
    lv = optimise_levels(table90, n, LO, HI, log_dur)
    spl = table90.splines()
    assert list(lv.tg_c) == sorted(lv.tg_c) and LO - 1e-9 <= lv.tg_c[0] and lv.tg_c[-1] <= HI + 1e-9
    assert all(canonical_tg(t) == t for t in lv.tg_c)  # what a written design holds
    assert lv.risk == pytest.approx(chain_risk(spl(np.array(lv.tg_c)), log_dur))
    assert lv.risk <= chain_risk(spl(np.linspace(LO, HI, n)), log_dur) + 1e-9
    graded = [LIB[m].tg_c for m in ("H-1", "H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7", "H-7")]
    assert lv.risk < chain_risk(spl(np.array(graded)), log_dur)


def test_chains_fold_and_their_critical_steps_are_real():
    """Every chain found folds when simulated independently (3D and 2D); a step counted
    critical is one whose swap with the step before collides, checked by a direct run."""
    d = _spiral()
    led = Ledger(local_mapper(1), 60, None)
    found = find_chains(d, LIB, led, 90.0, 0.01, cap=60, want=3)
    assert found and led.evaluated <= 60
    levels = np.linspace(LO, HI, 3)
    for chain, crit, _clear in found:
        assert sorted(chain) == [0, 1, 2]
        res = simulate(with_materials(d, _levels_for(chain, 3, levels)), method=Method.BOTH)
        assert res.completed, chain
        # a swap of the whole chain's last two hinges that collides makes at least that step critical
        sw = chain[:-2] + (chain[-1], chain[-2])
        if not simulate(with_materials(d, _levels_for(sw, 3, levels)), method=Method.INDEX2D).completed:
            assert crit >= 1
    assert [c for _ch, c, _cl in found] == sorted(c for _ch, c, _cl in found)


def test_cli_continuous_writes_a_design_robust_reverifies(tmp_path, capsys):
    """`assign --continuous --write` names its materials canonically, so `foldprint robust`
    of the written file makes the very estimate assign reported (same seed and samples)."""
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_spiral()))
    out_file = tmp_path / "best.toml"
    code = main(["assign", str(f), "--continuous", "--samples", "8", "--seed", "3", "--top", "1",
                 "--temperature-range", "89", "90", "--budget", "30", "--workers", "1", "--json", "--write",
                 str(out_file)])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    out = json.loads(cap.out)
    assert out["continuous"] and out["search_space"] is None and out["best"]
    best = out["best"][0]
    assert 89.0 <= best["temperature_c"] <= 90.0 and out["evaluated"] <= 30
    assert all(m.startswith("VW") for m in best["assignment"].values())
    written = load_design(out_file)
    assert {h.id: h.material for h in written.hinges} == best["assignment"]
    assert written.process.bath_temperature_c == pytest.approx(best["temperature_c"])
    again = jam_probability(written, 8, 3)
    assert again.jam_probability == best["jam_probability"]
    assert main(["robust", str(out_file), "--samples", "8", "--seed", "3", "--json"]) in (0, 1)
    rob = json.loads(capsys.readouterr().out)
    assert rob["jam_probability"] == pytest.approx(best["jam_probability"])


@pytest.mark.parametrize("args, needle", [
    (["--materials", "H-1,H-7"], "--materials does not apply"),
    (["--fixed", "h1=H-1"], "--fixed does not apply"),
    (["--objective", "margin"], "ranks by jam probability"),
])
def test_bad_continuous_options_exit_2(tmp_path, capsys, args, needle):
    f = tmp_path / "spiral.toml"
    f.write_text(design_to_toml(_spiral()))
    assert main(["assign", str(f), "--continuous", *args]) == 2
    err = capsys.readouterr().err
    assert needle in err and err.count("\n") == 1
