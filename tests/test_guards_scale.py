"""Guards bound what they claim (a refusal is a promise): runs that finish are not refused, refusals
name the estimate and the limit and come before any work, the memory estimate bounds
the memory a simulation really allocates."""

import json
import time
import tracemalloc

import pytest

from foldprint.core import guards
from foldprint.geometry import build_cost
from foldprint.simulation import costs
from foldprint.cli.commands import main
from foldprint.model.crease_patterns import miura
from foldprint.model.design import strip
from foldprint.io.fold_format import design_from_fold
from foldprint.io.load import load_design
from foldprint.simulation.simulate import simulate
from pathlib import Path

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"


def _strip(n, angle=30.0):
    return strip(f"s{n}", [10.0] * n, [angle if k % 2 == 0 else -angle for k in range(n - 1)], ["H-3"] * (n - 1))


pytestmark = pytest.mark.usefixtures("guard_defaults")


def test_runs_that_finish_in_seconds_are_not_refused():
    """The 100- and 1000-panel strips and a 10x10 Miura sheet pass the default guards
    (the old n_t x all-pairs work bound refused the 100-panel strip)."""
    sheet = design_from_fold(miura(10, 10), "miura10")
    for d in (_strip(100), _strip(1000), sheet):
        est = costs.check_simulation(d, 0.01, None, "fcl")
        assert est["bytes"] < guards.max_memory() and est["seconds"] < guards.time_budget()
    assert costs.check_sample_memory(load_design(TEMPLATES / "helix_graded.toml"), 10 ** 5)["bytes"] < guards.max_memory()
    assert build_cost.check_export(_strip(1000))["seconds"] < guards.time_budget()


def test_memory_estimate_bounds_what_a_simulation_allocates():
    d = _strip(200)
    est = costs.check_simulation(d, 0.01, None, "fcl")
    tracemalloc.start()
    simulate(d, method="fcl")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    arrays = est["bytes"] - guards.BASE_BYTES
    assert peak <= arrays, (peak, arrays)
    assert peak >= 0.25 * arrays, (peak, arrays)  # and is not a wild overestimate


@pytest.mark.parametrize("dur, dt", [(1e300, 1e-300), (1e9, 0.01), (1e308, 1e-10)])
def test_absurd_sizes_are_refused_cleanly(dur, dt):
    with pytest.raises(guards.ResourceError, match="memory limit") as ei:
        costs.check_simulation(_strip(3), dt, dur, "fcl")
    assert "inf" not in str(ei.value).replace("info", "")


def test_samples_refused_by_memory_naming_both_numbers():
    """Outcomes are held to the end: a billion samples do not fit; time is bounded on the
    measured rate (tests/test_recovery_batch.py)."""
    d = load_design(TEMPLATES / "helix_graded.toml")
    with pytest.raises(guards.ResourceError, match=r"1e\+09 samples hold .* over the 2 GiB memory limit"):
        costs.check_sample_memory(d, 1e9)
    guards.set_max_memory("1T")
    assert costs.check_sample_memory(d, 1e9)["bytes"] > 2 * guards.GiB


def test_check_refuses_samples_over_its_memory_limit_at_once(capsys):
    """A million outcomes (1 KiB each) do not fit in 500 MiB: refused before any sample runs
    (--samples over 1e6 is refused at the command line, tests/test_reliability.py)."""
    t0 = time.perf_counter()
    assert main(["check", "helix_graded", "--samples", "1000000", "--max-memory", "500M", "--json"]) == 2
    assert time.perf_counter() - t0 < 10
    out, err = capsys.readouterr()
    assert out == "" and "memory limit" in err and err.count("\n") == 1


def test_export_refused_before_building(tmp_path, monkeypatch, capsys):
    """Over the time budget, export refuses from the design alone: no geometry is built
    and no output directory is left."""
    import foldprint.apps.evaluation_exports as evaluation_exports
    import foldprint.apps.evaluation_nominal as evaluation_nominal
    import foldprint.apps.pipeline as pipeline

    def boom(*a, **k):
        raise AssertionError("built despite the refusal")

    for module in (pipeline, evaluation_nominal, evaluation_exports):  # wherever an evaluation builds
        monkeypatch.setattr(module, "build_assembly", boom)
    monkeypatch.setenv("FOLDPRINT_TIME_BUDGET", "1")
    f = tmp_path / "s.toml"
    n = 300
    f.write_text(f'schema = 1\nname = "s"\n[strip]\nlengths_mm = {[10] * n}\nangles_deg = {[30] * (n - 1)}\n'
                 f'materials = {["H-3"] * (n - 1)}\n'.replace("'", '"'))
    out = tmp_path / "out"
    assert main(["export", str(f), "--out", str(out), "--json"]) == 2
    err = capsys.readouterr().err
    assert "export refused" in err and "time budget" in err and "300 panels" in err
    assert not out.exists()


def test_narrow_phase_deadline_refuses_past_the_budget():
    guards.set_time_budget(0.05)
    tick = guards.narrow_deadline()
    tick("early")
    t0 = time.process_time()
    while time.process_time() - t0 < 0.1:  # CPU, not wall: the deadline counts work
        pass
    with pytest.raises(guards.ResourceError, match=r"over the 0\.05 s time budget \(late\)"):
        tick("late")


def test_bad_time_budget_is_a_clear_error(monkeypatch):
    monkeypatch.setenv("FOLDPRINT_TIME_BUDGET", "nan")
    with pytest.raises(guards.FoldprintError, match="FOLDPRINT_TIME_BUDGET"):
        guards.time_budget()


@pytest.mark.slow  # ~20 CPU-s: the strip must be large enough (150 panels) for its index to outweigh the rest
def test_both_leaves_out_an_index_over_the_limit_and_says_so(tmp_path, capsys):
    """--method both on a planar strip whose paper index alone would exceed the memory
    limit runs the 3D check (the verdict) and notes the index left out; --method index2d
    still asks for it and is refused with the estimate. The limit sits just under one run
    with the index, over all that ``simulate`` holds at once without it: the fold and the
    other hinge model's with the clearance search, then the margin screen's scattered folds
    beside the fold (a 60-panel strip has no such limit: its index is smaller than that)."""
    from foldprint.apps.pipeline import EvalOptions, Evaluation
    from foldprint.io.design_io import design_to_toml

    d = _strip(150)
    with2d = costs.simulation_estimate(150, 149, 2001, True, 600)["bytes"]
    limit = int(with2d) - 2 ** 20
    assert costs.run_estimate(d, 0.01, None, "fcl", 2, True)["bytes"] < limit
    guards.set_max_memory(limit)
    assert Evaluation(d, EvalOptions(method="fcl")).margin_batch(upfront=True) >= 1  # not refused
    f = tmp_path / "s150.toml"
    f.write_text(design_to_toml(d))
    assert main(["simulate", str(f), "--max-memory", str(limit), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["method"] == "both" and out["completed"] and len(out["notes"]) == 1
    assert "2D collision index was left out" in out["notes"][0]
    assert main(["simulate", str(f), "--max-memory", str(limit), "--method", "index2d", "--json"]) == 2
    assert "memory limit" in capsys.readouterr().err
    guards.set_max_memory(None)
    assert simulate(d).notes == ()  # under the default limit the index runs


def test_the_margin_screen_fits_its_batches_to_the_memory_left():
    """The margin screen's scattered folds give the same closest approaches made one sample
    at a time as all at once; the guard gives every sample room under a large limit, fewer
    under a smaller one, and refuses (exit-2 error naming the screen) when one does not fit."""
    from dataclasses import replace as dc_replace

    from foldprint.apps.pipeline import EvalOptions, Evaluation
    from foldprint.simulation.margin import margin_batch_bytes, scatter_margin
    from foldprint.simulation.robust import default_scatter

    d = _strip(12)
    d = dc_replace(d, process=dc_replace(d.process, duration_s=6.0))
    ev = Evaluation(d, EvalOptions(method="fcl"))
    sim, gap = ev.simulation, ev.clearance
    args = (sim, gap, ev.clearance_checker, default_scatter(), ev.library)
    assert scatter_margin(*args, batch=1).closest == scatter_margin(*args).closest
    guards.set_max_memory(2 ** 40)
    assert ev.margin_batch(upfront=True) == 16
    one, two = (margin_batch_bytes(d, 6.0, k) for k in (1, 2))
    assert 0 < one < two
    lo, hi = 0, 2 ** 40  # the least limit that takes one sample at once
    while hi - lo > 1:
        mid = (lo + hi) // 2
        guards.set_max_memory(mid)
        try:
            ev.margin_batch(upfront=True)
            hi = mid
        except guards.ResourceError:
            lo = mid
    guards.set_max_memory(hi + (two - one) - 1)
    assert ev.margin_batch(upfront=True) == 1
    guards.set_max_memory(hi - 1)
    with pytest.raises(guards.ResourceError, match="margin screen"):
        ev.margin_batch(upfront=True)
