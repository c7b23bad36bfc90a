"""The shared Monte-Carlo pool (foldprint.simulation.batch) against the one-design path:
the same samples folded in one pool across designs and scales give the outcomes that
jam_probability and the sigma sweep give design by design, the follow-up task receives
them, jam_probability returns them without folding, and the time guard refuses the
same runs."""

from __future__ import annotations

import pytest

from foldprint.core import guards
from foldprint.core.guards import ResourceError
from foldprint.core.modes import Method
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.simulation.batch import MonteCarloJob, Precomputed, run_batch
from foldprint.simulation.robust import jam_probability
from foldprint.simulation.scatter import default_scatter

N = 40  # three chunks, the last one short
SEED = 5


def _designs():
    return [load_design(templates_dir() / f"{n}.toml") for n in ("helix_uniform", "self_lock")]


def _size(i, pre):
    return len, (pre.outcomes,)


@pytest.fixture(scope="module")
def batch():
    designs = _designs()
    jobs = [MonteCarloJob(d, N, SEED, (1.0, 2.0)) for d in designs]
    return designs, run_batch(jobs, workers=2, after=_size, tasks=[(sum, ([1, 2],))])


def test_shared_pool_gives_each_designs_outcomes(batch):
    designs, (pre, after, tasks) = batch
    assert tasks == [3] and after == [2, 2]
    for d, p in zip(designs, pre):
        for k in (1.0, 2.0):
            sc = default_scatter() if k == 1.0 else default_scatter().scaled(k)
            ref = jam_probability(d, N, SEED, scatter=sc, workers=1)
            got = p.lookup(d, sc, N, SEED, ref.hinge_model, 0.01)
            assert got == ref.outcomes and len(got) == N
            # handed to jam_probability, it returns them as its own
            again = jam_probability(d, N, SEED, scatter=sc, workers=1, mapper=p, nominal=ref.nominal)
            assert again.outcomes == ref.outcomes


def test_precomputed_answers_only_its_own_run(batch):
    designs, (pre, _, _) = batch
    p: Precomputed = pre[0]
    d, sc = designs[0], default_scatter()
    assert p.lookup(d, sc, N, SEED, p.hinge_model, 0.01) is not None
    assert p.lookup(d, sc, N, SEED + 1, p.hinge_model, 0.01) is None
    assert p.lookup(d, sc, N + 1, SEED, p.hinge_model, 0.01) is None
    assert p.lookup(d, sc.scaled(0.5), N, SEED, p.hinge_model, 0.01) is None
    assert p.lookup(designs[1], sc, N, SEED, p.hinge_model, 0.01) is None
    assert p.lookup(d, sc, N, SEED, p.hinge_model, 0.01, Method.BOTH) is None  # another collision check


def test_precomputed_result_keeps_its_collision_method():
    d = _designs()[0]  # a planar strip: the paper's 2D index applies
    (p,), _, _ = run_batch([MonteCarloJob(d, N, SEED, method=Method.INDEX2D)], workers=1)
    ref = jam_probability(d, N, SEED, workers=1, method=Method.INDEX2D)
    got = jam_probability(d, N, SEED, workers=1, method=Method.INDEX2D, mapper=p, nominal=ref.nominal)
    assert got.outcomes == ref.outcomes and got.method == ref.method == Method.INDEX2D


@pytest.mark.parametrize("workers", [1, 2])
def test_time_guard_refuses_as_jam_probability_does(monkeypatch, workers):
    """Both ask the guard about the same run (samples, workers, design) with the time per
    sample measured on a first chunk, and a refusal stops both (load-independent: the
    guard is replaced by one that records and refuses)."""
    d = _designs()[0]
    calls = []

    def refuse(samples, per_sample, n_workers, name=""):
        calls.append((samples, n_workers, name, per_sample > 0))
        raise ResourceError(f"{name}: --samples {samples} refused")

    monkeypatch.setattr(guards, "check_samples", refuse)
    with pytest.raises(ResourceError):
        jam_probability(d, N, SEED, workers=workers)
    with pytest.raises(ResourceError):
        run_batch([MonteCarloJob(d, N, SEED)], workers=workers)
    assert len(calls) == 2 and calls[0] == calls[1] == (N, workers, d.name, True)
