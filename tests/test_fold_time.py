"""The fold time of record (docs/simulation.md, "The fold time"): when the last hinge's
simulated recovery ratio reaches 98 %, exact for a hinge that follows its recovery curve
(so it does not move with the time step), the ratio's crossing for a hinge held back; and
one string for it wherever a text prints it (``core.display.seconds``). The gallery's
pages against ``simulate`` and ``check``: tests/test_gallery.py
(test_one_fold_time_on_every_surface)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from foldprint.core.constants import FOLD_LEVEL, JSON_DECIMALS
from foldprint.core.display import seconds
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.simulation.simulate import crossing_times, simulate


@pytest.fixture(scope="module")
def uniform():
    return load_design(templates_dir() / "helix_uniform.toml")


def _latest_crossing(design) -> float:
    """An independent reference: each hinge's 98 % time found by root-bracketing its recovery
    ratio (not the tabulated inversion the simulation uses), the latest of them."""
    from scipy.optimize import brentq

    from foldprint.model.materials import default_library
    from foldprint.physics.recovery.curve import recovery_ratio

    lib, pr = default_library(), design.process
    def t98(h):
        f = lambda t: float(recovery_ratio(np.array([t]), lib[h.material], pr.bath_temperature_c,
                                           thickness_mm=h.thickness, initial_c=pr.fix_temperature_c)[0]) - FOLD_LEVEL
        return brentq(f, 1e-3, 600.0, xtol=1e-9)
    return max(t98(h) for h in design.hinges)


def _first_step_past(res) -> float:
    """The first time step at which every hinge is at 98 % (what a step-based count says)."""
    r, t = res.trajectory.ratios, res.trajectory.times
    return max(float(t[np.nonzero(r[:, i] >= FOLD_LEVEL)[0][0]]) for i in range(r.shape[1]))


def test_the_fold_time_is_the_recovery_curves_at_any_step(uniform):
    """helix_uniform (every hinge free): the latest curve's 98 % time, exactly, at the
    default step and at 5x it, equal to an independent root of the recovery ratio; the first
    step past it moves with the step."""
    runs = {dt: simulate(uniform, dt=dt, method="fcl") for dt in (0.01, 0.05)}
    curve = max(runs[0.01].trajectory.fold_times)
    for dt, res in runs.items():
        assert res.completed
        assert res.fold_time == curve
        assert res.hinge_fold_times == res.trajectory.fold_times
    assert curve == pytest.approx(_latest_crossing(uniform), abs=2e-3)
    assert seconds(runs[0.01].fold_time) == seconds(runs[0.05].fold_time)
    for dt, res in runs.items():  # a step-based count lands on the grid after the crossing
        step = _first_step_past(res)
        assert curve <= step < curve + dt + 1e-9 and step == pytest.approx(round(step / dt) * dt, abs=1e-9)
    assert _first_step_past(runs[0.05]) > _first_step_past(runs[0.01])


def test_a_held_back_hinge_folds_when_its_ratio_crosses(uniform):
    """A hinge whose simulated ratio lags its curve (as a loop's closure holds one back)
    folds when that ratio reaches 98 %, linear between the steps; one that never does
    leaves the design without a fold time."""
    res = simulate(uniform, dt=0.01, method="fcl")
    traj = res.trajectory
    lag = 0.3
    r = np.array(traj.ratios)
    r[:, 0] = np.interp(traj.times - lag, traj.times, traj.ratios[:, 0], left=0.0)
    held = dataclasses.replace(res, trajectory=dataclasses.replace(traj, ratios=r))
    t0 = held.hinge_fold_times[0]
    assert t0 == pytest.approx(traj.fold_times[0] + lag, abs=2e-3) and t0 != traj.fold_times[0] + lag
    assert t0 == pytest.approx(crossing_times(held, FOLD_LEVEL)[0], abs=1e-12)
    assert held.hinge_fold_times[1:] == traj.fold_times[1:]
    r[:, 0] = np.minimum(r[:, 0], 0.9)
    never = dataclasses.replace(res, trajectory=dataclasses.replace(traj, ratios=r))
    assert never.hinge_fold_times[0] is None and never.fold_time is None


def test_seconds_prints_a_time_and_its_json_value_alike():
    """A page printing the raw number and one printing the JSON's (rounded to
    JSON_DECIMALS) agree even next to a rounding edge."""
    for t in (2.514996, 2.515004, 5.3677113617184125, 0.004999, 9.995):
        assert seconds(t) == seconds(round(t, JSON_DECIMALS))
    assert seconds(2.5102015714458843) == "2.51 s" and seconds(None) == "\u2014"


def test_simulate_and_check_print_one_fold_time(capsys):
    """``simulate`` (text and JSON) and ``check`` (JSON: its nominal fold; text: the
    paper's line about the fold) give helix_uniform's fold time as one string."""
    from foldprint.cli.commands import main

    assert main(["simulate", "helix_uniform", "--json"]) == 0
    sim = json.loads(capsys.readouterr().out)
    s = seconds(sim["fold_time_s"])
    assert s == seconds(_latest_crossing(load_design(templates_dir() / "helix_uniform.toml")))
    assert main(["simulate", "helix_uniform"]) == 0
    text = capsys.readouterr().out
    assert f"  folded in {s}\n" in text and f"every hinge reaches 98 % by {s}" in text
    assert main(["check", "helix_uniform", "--samples", "8", "--no-sensitivity", "--json"]) == 1
    chk = json.loads(capsys.readouterr().out)
    assert seconds(chk["robust"]["nominal"]["fold_time_s"]) == s
    assert main(["check", "helix_uniform", "--samples", "8", "--no-sensitivity"]) == 1
    assert f"every hinge reaches 98 % by {s}" in capsys.readouterr().out
