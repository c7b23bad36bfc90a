"""The Monte-Carlo jam test of a fold whose 3D collision search is long is refused before
its first sample: a sample's cost is estimated from the nominal fold's broad-phase work
(:func:`foldprint.simulation.costs.check_swept_samples`), a lower bound of what a sample
measures, and a shipped template stays far below the budget."""

from __future__ import annotations

import time
from itertools import islice
from pathlib import Path

import pytest

from foldprint.core import guards
from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES
from foldprint.io.load import load_design
from foldprint.model.materials import default_library
from foldprint.simulation import costs

TEMPLATES = Path(__file__).resolve().parent.parent / "templates"

pytestmark = pytest.mark.usefixtures("guard_defaults")


def _coiling(tmp_path, n: int):
    """A strip of ``n`` 10 mm panels, every hinge H-1 at 90 deg (a template's strip mutated
    the fuzz harness's way): all hinges fold at once and it coils onto itself, so the broad
    phase splits most of its panel pairs down to single steps."""
    f = tmp_path / f"c{n}.toml"
    f.write_text((f'schema = 1\nname = "c{n}"\n[defaults]\nthickness_mm = 0.8\ndepth_mm = 6.0\nhinge_radius_mm = 5.0\n'
                  f'[strip]\nlengths_mm = {[10] * n}\nangles_deg = {[90] * (n - 1)}\nmaterials = {["H-1"] * (n - 1)}\n')
                 .replace("'", '"'))
    return load_design(f)


def test_the_estimate_is_a_lower_bound_of_a_measured_sample(tmp_path):
    """On a 120-panel coiling strip (about 0.25 million broad-phase nodes a fold) the
    estimate from the nominal fold stays under a sample's measured CPU time, and within
    10x of it."""
    from foldprint.simulation.robust import run_samples, warm_kernels
    from foldprint.simulation.scatter import default_scatter, iter_samples
    from foldprint.simulation.simulate import simulate

    d, lib = _coiling(tmp_path, 120), default_library()
    nominal = simulate(d, dt=CHECK_DT_S, method="fcl", library=lib)
    assert nominal.broad_nodes > 100_000, nominal.broad_nodes
    per = nominal.broad_nodes * costs.BROAD_S_PER_NODE
    samples = list(islice(iter_samples(d, default_scatter(), 3, 0), 3))
    args = (d, lib, samples, "arc", CHECK_DT_S, False, "fcl", "rigid")
    warm_kernels(args)
    start = time.process_time()
    run_samples((d, lib, samples[1:], *args[3:]))
    measured = (time.process_time() - start) / 2
    assert per <= measured, (per, measured)
    assert per >= measured / 10, (per, measured)


def test_a_long_search_is_refused_before_any_sample_is_folded(tmp_path, monkeypatch):
    """With a budget the estimate exceeds, the jam test is refused naming the estimate,
    and no sample is folded (every path that folds one fails the test)."""
    from foldprint.simulation import robust
    from foldprint.simulation.jamtest import pool, scales
    from foldprint.simulation.jamtest.verdict import jam_test
    from foldprint.simulation.simulate import simulate

    d = _coiling(tmp_path, 120)
    nominal = simulate(d, dt=CHECK_DT_S, method="fcl")
    est = CHECK_SAMPLES * nominal.broad_nodes * costs.BROAD_S_PER_NODE

    def boom(*a, **k):
        raise AssertionError("a sample was folded despite the refusal")

    for module in (robust, pool, scales):
        monkeypatch.setattr(module, "run_samples", boom)
    monkeypatch.setattr(scales, "warm_kernels", boom)
    guards.set_time_budget(est / 2)
    with pytest.raises(guards.ResourceError, match=rf"c120: --samples {CHECK_SAMPLES} refused: .*broad-phase nodes"):
        scales.jam_tests(d, jam_test(), nominal=nominal, workers=1)
    with pytest.raises(guards.ResourceError, match=rf"c120: --samples {CHECK_SAMPLES} refused: .*broad-phase nodes"):
        robust.jam_probability(d, CHECK_SAMPLES, nominal=nominal, workers=1, method="fcl")
    guards.set_time_budget(est * 2)  # over the estimate: the first chunk is folded (and fails here)
    with pytest.raises(AssertionError, match="despite the refusal"):
        scales.jam_tests(d, jam_test(), nominal=nominal, workers=1)


@pytest.mark.parametrize("name", sorted(p.stem for p in TEMPLATES.glob("*.toml")))
def test_a_template_is_estimated_far_under_the_budget(name):
    """Every shipped template's check samples are estimated under a hundredth of the
    default budget (none is refused before its first chunk is timed)."""
    from foldprint.simulation.simulate import simulate

    nominal = simulate(load_design(TEMPLATES / f"{name}.toml"), dt=CHECK_DT_S, method="fcl")
    est = costs.check_swept_samples(nominal, CHECK_SAMPLES, 1, name)
    assert est is None or est < guards.time_budget() / 100, est
