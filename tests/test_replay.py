"""Replaying Monte-Carlo samples (foldprint.apps.pipeline.worst_sample, replay_sample): the
sample the gallery's viewer shows beside the nominal fold."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.core.constants import tol
from foldprint.model.design import strip
from foldprint.io.load import load_design
from foldprint.apps.pipeline import replay_sample, worst_sample
from foldprint.simulation.robust import Outcome, jam_probability, outcome_of
from foldprint.io.templates import templates_dir

_PAIRS = [("p1", "p2"), ("p1", "p6"), ("p2", "p5")]
_outcome = st.one_of(
    st.builds(lambda t: Outcome(False, None, None, None, t), st.floats(0.5, 20.0)),
    st.builds(lambda p, t: Outcome(True, "collision", p, t, None), st.sampled_from(_PAIRS), st.floats(0.0, 20.0)),
    st.builds(lambda r: Outcome(True, r, None, None, None), st.sampled_from(["goal", "unfolded"])),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(_outcome, max_size=12))
def test_worst_sample_is_the_earliest_contact_else_a_jam_else_the_slowest_fold(outs):
    k = worst_sample(SimpleNamespace(outcomes=tuple(outs)))
    if not outs:
        assert k is None
        return
    w = outs[k]
    hits = [o.time for o in outs if o.reason == "collision"]
    if hits:
        assert w.reason == "collision" and w.time == min(hits)
        assert all(o.time != w.time for o in outs[:k] if o.reason == "collision")  # the first of ties
    elif any(o.jammed for o in outs):
        assert w.jammed and not any(o.jammed for o in outs[:k])
    else:
        assert w.fold_time == max(o.fold_time for o in outs)


def _same(a: Outcome, b: Outcome) -> None:
    assert (a.jammed, a.reason, a.pair) == (b.jammed, b.reason, b.pair)
    for x, y in ((a.time, b.time), (a.fold_time, b.fold_time)):
        assert (x is None) == (y is None)
        if x is not None:
            assert x == pytest.approx(y, abs=tol.time)


@pytest.mark.parametrize("design", [
    strip("pair", [10.0, 12.0, 8.0], [90.0, -60.0], ["H-1", "H-4"]),  # completes: fold times vary
    load_design(templates_dir() / "self_lock_uniform.toml"),  # collides: pairs and contact times
], ids=["completes", "collides"])
def test_replay_gives_each_sample_its_recorded_outcome(design):
    """Round trip: each sample drawn again from the seed and folded alone ends as the
    Monte-Carlo (run in another order, in another process) recorded it."""
    r = jam_probability(design, 4, seed=3, workers=2)
    for k in range(r.samples):
        rep = replay_sample(design, r, k)
        assert rep.index == k and rep.outcome == r.outcomes[k]
        _same(outcome_of(rep.result), r.outcomes[k])
        assert rep.agrees
        assert rep.result.trajectory.bath_c == pytest.approx(rep.sample.bath_c)
    with pytest.raises(ValueError, match="outside 0..3"):
        replay_sample(design, r, 4)
