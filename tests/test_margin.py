"""Whether scatter closes the nominal fold's smallest clearance (foldprint.simulation.margin),
and what simulate prints of it."""

from __future__ import annotations

import json

import pytest

from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.core.constants import CHECK_SEED, MARGIN_SAMPLES, tol
from foldprint.core.display import seconds
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.materials import default_library
from foldprint.simulation.margin import scatter_margin
from foldprint.simulation.robust import jam_probability
from foldprint.simulation.scatter import Scatter


def _ev(name: str, **opts) -> Evaluation:
    return Evaluation(load_design(templates_dir() / f"{name}.toml"), EvalOptions(**opts))


def test_the_screen_touches_where_check_collides_sample_by_sample():
    """octagon_stack jams in some samples and not in others: the screen's kinematic folds
    (exact distances at 200 poses, not stopped at contact) touch in exactly the samples that
    check's Monte-Carlo (the 3D swept check, the same seed and draws) sees collide: a
    second method, sample by sample."""
    ev = _ev("octagon_stack")
    m = ev.scatter_margin
    assert m is not None and m.samples == MARGIN_SAMPLES and m.seed == CHECK_SEED
    r = jam_probability(ev.design, MARGIN_SAMPLES, CHECK_SEED, library=ev.library, workers=1)
    touched = [c <= tol.contact for c in m.closest]
    collided = [o.reason == "collision" for o in r.outcomes]
    assert touched == collided
    assert 0 < sum(touched) < MARGIN_SAMPLES  # a mixed case: the comparison means something
    assert m.marginal and m.touching == sum(touched)
    assert m.motion == pytest.approx(ev.clearance.distance)  # some sample closes it all


def test_without_scatter_every_sample_is_the_nominal_fold():
    """Zero spreads: each sample's closest approach is the nominal clearance (the same pair
    and time), so nothing is marginal; also at a bath given for the run (the samples are
    centred on it, not on the design's)."""
    for bath in (None, 85.0):
        ev = _ev("helix_uniform", method="fcl", bath_c=bath)
        gap = ev.clearance
        m = scatter_margin(ev.simulation, gap, ev.clearance_checker, Scatter.zero(), ev.library, samples=3)
        # the samples' curves read the relaxation table (R within 2e-8 of the exact sum the
        # nominal uses, measured 5.5e-9): a distance within ~150 mm/rad x that, 1e-6 mm
        assert m.closest == pytest.approx((gap.distance,) * 3, abs=1e-6)
        assert m.closest[0] == m.closest[1] == m.closest[2]  # zero spreads: the same fold each
        assert m.worst.panels == gap.panels and m.worst.time == pytest.approx(gap.time)
        assert not m.marginal and m.motion == pytest.approx(0.0, abs=1e-6)  # the same table error


def test_a_graded_design_keeps_its_margin_and_a_collision_has_none():
    graded = _ev("helix_graded", method="fcl").scatter_margin
    assert graded is not None and not graded.marginal and graded.touching == 0
    assert min(graded.closest) > 1.0
    assert _ev("self_lock_uniform", method="fcl").scatter_margin is None  # collides nominally: no screen


def test_simulate_says_a_nominal_fold_is_marginal(capsys):
    """helix_uniform (the paper's Sample 1): exit 0 (the nominal fold completes), but the
    first line says MARGINAL, the clearance line names the pair, the value and the time,
    and the JSON carries the same numbers."""
    from foldprint.cli.commands import main

    assert main(["simulate", "helix_uniform", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    gap, m = r["clearance"], r["scatter_margin"]
    assert gap["panels"] == ["p5", "p9"] and gap["distance_mm"] == pytest.approx(1.37, abs=0.01)
    assert m["marginal"] is True and m["touching"] == m["samples"] == MARGIN_SAMPLES and m["seed"] == CHECK_SEED
    assert m["motion_mm"] == pytest.approx(gap["distance_mm"], abs=1e-4)
    assert main(["simulate", "helix_uniform"]) == 0
    text = capsys.readouterr().out
    first = text.splitlines()[0]
    assert "completes nominally, but MARGINAL" in first
    assert f"smallest clearance along the fold: {gap['distance_mm']:.2f} mm (p5-p9 at {seconds(gap['time_s'])})" in text
    assert f"panels touch in {m['touching']} of {m['samples']} scattered folds" in text
    assert "`foldprint check` gives the jam probability" in text


def test_simulate_says_when_scatter_leaves_the_gap_open(capsys):
    from foldprint.cli.commands import main

    assert main(["simulate", "helix_graded"]) == 0
    text = capsys.readouterr().out
    assert "MARGINAL" not in text and "completes" in text.splitlines()[0]
    assert f"no panels touch in {MARGIN_SAMPLES} scattered folds" in text


def test_a_fold_without_loops_is_screened_at_the_searched_poses_only():
    """The screen makes a loop-free sample's kinematics only at the poses the clearance
    search samples: each sample's closest approach equals the one searched on its whole
    trajectory (every step made), with scatter on (octagon_stack: touching and not)."""
    from foldprint.collision.clearance import min_clearance
    from foldprint.physics.hinge_drive import simulate_kinematics
    from foldprint.simulation.robust import default_scatter, sample_drives
    from foldprint.simulation.scatter import draw_samples

    ev = _ev("octagon_stack", method="fcl")
    sim, k = ev.simulation, 6
    m = scatter_margin(sim, ev.clearance, ev.clearance_checker, default_scatter(), ev.library, samples=k)
    drawn = draw_samples(ev.design, default_scatter(), k, CHECK_SEED)
    drives = sample_drives(ev.design, ev.library, drawn, until_s=float(sim.trajectory.times[-1]))
    full = [min_clearance(ev.clearance_checker, t.times, t.poses) for t in
            (simulate_kinematics(ev.design, sim.trajectory.times, model=sim.trajectory.model, drive=d) for d in drives)]
    assert all(d.loops is None for d in drives)
    assert m.closest == pytest.approx(tuple(g.distance for g in full), abs=1e-9)


def test_a_design_with_too_many_pairs_to_screen_says_it_is_left_out(monkeypatch, capsys):
    """Above MARGIN_MAX_PAIRS the screen is not run (its 16 exact searches would cost
    minutes) and simulate says so, text and JSON; at the limit it runs. The pair count is
    the listed pairs' (a second way)."""
    import foldprint.simulation.margin as pl
    from foldprint.cli.commands import main
    from foldprint.collision.broadphase import count_non_adjacent_pairs, non_adjacent_pairs

    d = load_design(templates_dir() / "helix_graded.toml")
    pairs = len(non_adjacent_pairs(d))
    assert count_non_adjacent_pairs(d) == pairs
    monkeypatch.setattr(pl, "MARGIN_MAX_PAIRS", pairs - 1)
    assert main(["simulate", "helix_graded", "--method", "fcl", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["scatter_margin"] is None and any("margin screen is left out" in n for n in r["notes"])
    assert main(["simulate", "helix_graded", "--method", "fcl"]) == 0
    assert "note: the scatter margin screen is left out" in capsys.readouterr().out
    monkeypatch.setattr(pl, "MARGIN_MAX_PAIRS", pairs)
    assert main(["simulate", "helix_graded", "--method", "fcl", "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["scatter_margin"] is not None and not any("left out" in n for n in r["notes"])
