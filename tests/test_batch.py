"""The shared Monte-Carlo pool (foldprint.simulation.jamtest.pool) against the one-design path:
the same samples folded in one pool across designs and scales give the outcomes that
jam_probability and the sigma sweep give design by design, the follow-up task receives
them, jam_probability returns them without folding, and the time guard refuses the
same runs."""

from __future__ import annotations

import pytest

from foldprint.simulation import costs
from foldprint.core.guards import ResourceError
from foldprint.core.modes import Method
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.simulation.jamtest.pool import MonteCarloJob, Precomputed, run_batch
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

    monkeypatch.setattr(costs, "check_samples", refuse)
    with pytest.raises(ResourceError):
        jam_probability(d, N, SEED, workers=workers)
    with pytest.raises(ResourceError):
        run_batch([MonteCarloJob(d, N, SEED)], workers=workers)
    assert len(calls) == 2 and calls[0] == calls[1] == (N, workers, d.name, True)


# -- check's sequential jam test ------------------------------------------------------------

MAX = 20  # two chunks (16 + 4): helix_uniform decides inside the first, helix_graded runs to the maximum


def _tested(design, **kw):
    from foldprint.simulation.jamtest.scales import jam_tests
    from foldprint.simulation.jamtest.verdict import jam_test

    return jam_tests(design, jam_test(max_samples=MAX), (1.0, 2.0), SEED, **kw)


def _same(a, b):
    """Two jam tests' results per scale agree in everything reported."""
    assert sorted(a) == sorted(b)
    for k in a:
        assert a[k].outcomes == b[k].outcomes and a[k].decision == b[k].decision, k
        assert (a[k].samples, a[k].jams, a[k].ci95) == (b[k].samples, b[k].jams, b[k].ci95)


@pytest.fixture(scope="module")
def sequential():
    designs = [load_design(templates_dir() / f"{n}.toml") for n in ("helix_uniform", "helix_graded")]
    return designs, {d.name: _tested(d, workers=1) for d in designs}


def test_jam_test_stops_where_its_outcomes_say(sequential):
    """The samples kept are the stream's first n, n the test's stop on them: the uniform
    helix fails after 6 (every sample jams), the graded one reaches the maximum."""
    from foldprint.simulation.jamtest.scales import on_check_stream
    from foldprint.simulation.jamtest.verdict import decide, jam_test

    designs, ref = sequential
    for d in designs:
        for k, r in ref[d.name].items():
            sc = default_scatter() if k == 1.0 else default_scatter().scaled(k)
            fixed = jam_probability(d, MAX, SEED, scatter=sc, workers=1)  # the same stream, all of it
            assert r.outcomes == fixed.outcomes[:r.samples]
            assert r.decision == decide([o.jammed for o in fixed.outcomes], r.decision.test)
            # what check's test makes of the fixed-size estimate on its stream: the same stop
            assert on_check_stream(fixed, SEED, r.decision.test) == r.decision
            assert on_check_stream(fixed, SEED) == decide([o.jammed for o in fixed.outcomes], jam_test())
            assert on_check_stream(fixed, SEED + 1) is None and on_check_stream(r, SEED) is None
    assert [ref["helix_uniform"][k].samples for k in (1.0, 2.0)] == [6, 6]
    assert str(ref["helix_uniform"][1.0].decision.verdict) == "error"
    assert ref["helix_graded"][1.0].samples == MAX and ref["helix_graded"][1.0].decision.truncated


@pytest.mark.parametrize("workers,chunk", [(2, 16), (2, 5), (1, 3)])
def test_jam_test_is_the_same_on_any_workers_and_chunks(sequential, monkeypatch, workers, chunk):
    """One worker or two, chunks of 16, 5 or 3 samples (so chunks come back in any order
    and stops fall mid-chunk): the same samples, verdicts, stops and intervals."""
    from foldprint.simulation.jamtest import pool as batch, scales as seq
    from foldprint.simulation import robust

    for mod in (batch, robust, seq):
        monkeypatch.setattr(mod, "CHUNK", chunk)
    designs, ref = sequential
    for d in designs:
        _same(_tested(d, workers=workers), ref[d.name])


def test_jam_test_through_a_plain_mapper_in_rounds(sequential):
    designs, ref = sequential
    plain = lambda fn, items, progress=None: [fn(x) for x in items]  # noqa: E731 - e.g. a cluster
    for d in designs:
        calls = []
        _same(_tested(d, workers=2, mapper=plain, progress=lambda *a: calls.append(a)), ref[d.name])
        for k in (1.0, 2.0):  # each stage's samples climb to its stop, told as (n, n) once decided
            mine = [c[1:] for c in calls if c[0] == f"jam test at {k:g}x"]
            n = ref[d.name][k].samples
            assert mine[-1] == (n, n) and all(a[0] <= b[0] for a, b in zip(mine, mine[1:])), (d.name, k, mine)
            assert all(m[1] == MAX for m in mine[:-1])


def test_a_plain_mapper_guards_time_only_past_the_first_chunk(monkeypatch):
    """Through a plain mapper the first chunk is folded here and times the rest: a test whose
    every sample is in that chunk has nothing left to guard; one sample more is estimated
    from that chunk's time per sample."""
    from foldprint.simulation.robust import CHUNK
    from foldprint.simulation.jamtest.scales import jam_tests
    from foldprint.simulation.jamtest.verdict import jam_test

    calls = []
    monkeypatch.setattr(costs, "check_samples", lambda n, per, w, name="": calls.append((n, w, name)) or 0.0)
    d = load_design(templates_dir() / "helix_graded.toml")
    plain = lambda fn, items, progress=None: [fn(x) for x in items]  # noqa: E731
    (r,) = jam_tests(d, jam_test(max_samples=CHUNK), (1.0,), SEED, workers=1, mapper=plain).values()
    assert r.samples == CHUNK and r.decision.truncated and calls == []
    jam_tests(d, jam_test(max_samples=CHUNK + 1), (1.0,), SEED, workers=1, mapper=plain)
    assert calls == [(CHUNK + 1, 1, d.name)]


def test_shared_pool_answers_the_jam_test_as_check_alone(sequential):
    """The gallery's path: both designs' streams in one adaptive pool with a follow-up
    each; the Precomputed it hands on gives each design's jam test without folding, equal
    to the test run alone."""
    from foldprint.simulation.jamtest.verdict import jam_test

    from foldprint.simulation.jamtest.stages import check_follow

    designs, ref = sequential
    jobs = [MonteCarloJob(d, MAX, SEED, (1.0,), test=jam_test(max_samples=MAX)) for d in designs]
    pre, after, _ = run_batch(jobs, workers=2, after=_size, follow=check_follow(jobs, (2.0,)))
    # the test at 1x, then the sweep asking whether it flips; helix_graded's pass flips at 2x:
    # its five probes (one per scatter component) join the pool too
    assert after == [2, 7]
    from foldprint.simulation.jamtest import scales as seq

    def no_fold(*_a, **_k):
        raise AssertionError("a precomputed stream was folded again")

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(seq, "run_batch", no_fold)
        mp.setattr(seq, "run_samples", no_fold)
        for d, p in zip(designs, pre):
            calls = []
            _same(_tested(d, workers=1, mapper=p, progress=lambda *a: calls.append(a)), ref[d.name])
            assert [len(e[1]) for e in p.outcomes[:2]] == [ref[d.name][k].samples for k in (1.0, 2.0)]
            assert [e[2] for e in p.outcomes[:2]] == [ref[d.name][k].decision.test for k in (1.0, 2.0)]
            n = [ref[d.name][k].samples for k in (1.0, 2.0)]
            assert calls == [("jam test at 1x", n[0], n[0]), ("jam test at 2x", n[1], n[1])]
        # the flip's probes: answered from the pool's streams, as flip_drivers folds them alone
        from foldprint.simulation.jamtest.flip_drivers import flip_drivers, flips_of
        from foldprint.simulation.sensitivity import SweepPoint

        d, p = designs[1], pre[1]
        r = ref[d.name]
        flips = flips_of(r[1.0], [SweepPoint(k, r[k]) for k in (1.0, 2.0)])
        assert [f.scale for f in flips] == [2.0]
        got = flip_drivers(d, r[1.0], flips, mapper=p)
    alone = flip_drivers(d, r[1.0], flips, workers=1)
    assert [(pr.component.key, pr.result.outcomes, pr.result.decision) for pr in got[0].probes] == [
        (pr.component.key, pr.result.outcomes, pr.result.decision) for pr in alone[0].probes]
    assert len(got[0].probes) == 5 and [len(e[1]) for e in p.outcomes[2:]] == [pr.result.samples for pr in alone[0].probes]


def test_no_chunk_is_folded_past_a_decided_stop(monkeypatch):
    """In one process the pool folds exactly the samples a stream needs: the uniform helix
    jams at every sample and its test can stop after 6 jams, so each scale's stream is one
    chunk of 6 samples (not a whole chunk of 16, 10 of them past the stop)."""
    from foldprint.simulation.jamtest import pool as batch
    from foldprint.simulation.jamtest.verdict import jam_test

    folded = []
    real = batch._chunk_task
    scale = {default_scatter(): 1.0, default_scatter().scaled(2.0): 2.0}
    monkeypatch.setattr(batch, "_chunk_task",
                        lambda j, sc, a, n: folded.append((j, scale[sc], a, n)) or real(j, sc, a, n))
    d = _designs()[0]
    (p,), _, _ = run_batch([MonteCarloJob(d, MAX, SEED, (1.0, 2.0), test=jam_test(max_samples=MAX))], workers=1)
    assert sorted(folded) == [(0, 1.0, 0, 6), (0, 2.0, 0, 6)] and [len(e[1]) for e in p.outcomes] == [6, 6]


def test_a_chunk_is_sized_to_the_earliest_stop():
    """A stream's next chunk holds the samples after which an unbroken run could stop its
    test (the fewest of all-clean and all-jammed), at least MIN_CHUNK, at most CHUNK; with a
    chunk in flight, or without a test, a whole CHUNK. A loop pattern's chunk is cut only
    where a clean run after the submitted samples would stop, at least LOOP_MIN_CHUNK. No
    chunk is speculated on past where a clean run of the submitted samples stops the test."""
    from foldprint.simulation.jamtest import streams
    from foldprint.simulation.robust import CHUNK, Outcome
    from foldprint.simulation.jamtest.verdict import decide, jam_test

    clean, jam = Outcome(False, None, None, None, 1.0), Outcome(True, None, None, None, None)
    test = jam_test(max_samples=200)

    def first_stop(prefix, more):
        n = len(prefix)
        while not decide(prefix + [more] * (n - len(prefix)), test).decided:
            n += 1
        return n - len(prefix)

    for prefix in ([], [False] * 3, [True] * 2, [False, True] * 5, [True] * 4 + [False] * 30):
        need = min(first_stop(prefix, False), first_stop(prefix, True))
        assert streams.to_decision(prefix, test, 1000) == need
        assert streams.to_decision(prefix, test, need - 1) == need - 1
        s = streams.Stream(0, 1.0, MonteCarloJob(_designs()[0], 200, SEED, test=test), default_scatter(), test)
        s.outcomes = [jam if x else clean for x in prefix]
        s.next = len(prefix)
        assert s.size() == min(CHUNK, max(streams.MIN_CHUNK, need)), prefix
        m = s.take()[1]
        assert m == min(CHUNK, max(streams.MIN_CHUNK, need)) and s.size() == CHUNK  # one in flight
        assert s.open_past_clean_run == (first_stop(prefix, False) > m), prefix
    # a loop pattern's chunks are cut only where a clean run would stop
    miura = load_design(templates_dir() / "miura_3x3.toml")
    s = streams.Stream(0, 1.0, MonteCarloJob(miura, 200, SEED, test=test), default_scatter(), test)
    assert streams.to_decision([], test, CHUNK) < CHUNK and s.size() == CHUNK
    clean_stop = first_stop([], False)
    assert [s.take() for _ in range(4)] == [(0, CHUNK), (CHUNK, CHUNK), (2 * CHUNK, CHUNK),
                                            (3 * CHUNK, clean_stop - 3 * CHUNK)]
    assert not s.open_past_clean_run and s.size() == streams.LOOP_MIN_CHUNK
    s.add(0, [jam] + [clean] * (CHUNK - 1))  # a jam: a clean run of the rest no longer stops it
    assert s.open_past_clean_run
    fixed = streams.Stream(0, 1.0, MonteCarloJob(_designs()[0], 20, SEED), default_scatter(), None)
    assert [fixed.take() for _ in range(2)] == [(0, CHUNK), (CHUNK, 20 - CHUNK)] and not fixed.wants


def test_a_stream_consumes_its_chunks_in_stream_order(monkeypatch):
    """Chunks that come back out of order wait for their predecessors: the outcomes are
    the stream's in order and the stop is counted over them, whatever the arrival order
    (chunks of 4 here: jams only from sample 8 on, so a pass-or-not hinges on the order)."""
    from foldprint.simulation.jamtest import streams
    from foldprint.simulation.robust import Outcome
    from foldprint.simulation.jamtest.verdict import decide, jam_test

    clean, jam = Outcome(False, None, None, None, 1.0), Outcome(True, None, None, None, None)
    stream = [clean] * 8 + [jam] * 12
    test = jam_test(max_samples=20)
    want = decide([o.jammed for o in stream], test)
    for order in ([0, 1, 2, 3, 4], [4, 3, 2, 1, 0], [2, 0, 4, 1, 3]):
        s = streams.Stream(0, 1.0, MonteCarloJob(_designs()[0], 20, SEED, test=test), default_scatter(), test)
        assert [s.take(4) for _ in range(5)] == [(4 * c, 4) for c in range(5)] and not s.wants
        for c in order:
            s.add(4 * c, stream[4 * c:4 * c + 4])
        assert s.done and s.outcomes == stream[:want.samples], order
        assert decide([o.jammed for o in s.outcomes], test) == want


def test_a_batch_run_inside_a_worker_keeps_the_workers_jobs():
    """A gallery worker's follow-up (a design's build) may fold jam tests of its own in a
    batch run there (FP183's probes, not in the shared pool's outcomes): afterwards the
    worker still folds the shared pool's chunks, the same outcomes as before."""
    from foldprint.model.materials import default_library
    from foldprint.simulation.jamtest import pool as batch

    d, lib = _designs()[1], default_library()
    batch._init([MonteCarloJob(d, 4, SEED)], lib)  # what the pool's initializer gives a worker
    try:
        before, _ = batch._chunk_task(0, default_scatter(), 0, 4)
        run_batch([MonteCarloJob(d, 2, SEED + 1)], library=lib, workers=1)  # folded here, in the worker
        after, _ = batch._chunk_task(0, default_scatter(), 0, 4)
    finally:
        batch._STATE.clear()
    assert len(after) == 4 and after == before


def test_jam_tests_fold_the_nominal_with_the_options_given():
    """Without scatter every sample is the nominal fold: made at the step, collision check
    and mechanics the jam test was given, and the result says so."""
    from foldprint.model.design import strip
    from foldprint.simulation.scatter import Scatter
    from foldprint.simulation.jamtest.scales import jam_tests
    from foldprint.simulation.jamtest.verdict import jam_test

    d = strip("n", [15, 15], [90], ["H-7"])
    (r,) = jam_tests(d, jam_test(max_samples=MAX), (1.0,), SEED, scatter=Scatter.zero(), dt=0.02,
                     method=Method.INDEX2D, workers=1).values()
    assert r.method == Method.INDEX2D and r.nominal.method == Method.INDEX2D
    assert r.nominal.trajectory.times[1] == pytest.approx(0.02) and r.jams == 0
    (b,) = jam_tests(d, jam_test(max_samples=MAX), (1.0,), SEED, scatter=Scatter.zero(), dt=0.05,
                     mechanics="bar-hinge", workers=1).values()
    assert b.mechanics == "bar-hinge" and b.nominal.compliant is not None


def test_jam_tests_refuse_a_bad_seed_or_mechanics_by_name():
    from foldprint.core.errors import DesignError
    from foldprint.model.design import strip
    from foldprint.simulation.jamtest.scales import jam_tests
    from foldprint.simulation.jamtest.verdict import jam_test

    d = strip("n", [15, 15], [90], ["H-7"])
    with pytest.raises(DesignError, match=r"^seed must be a whole number >= 0, got -1$"):
        jam_tests(d, jam_test(max_samples=MAX), (1.0,), -1)
    with pytest.raises(DesignError, match=r"^mechanics: 'wobbly' is not one of"):
        jam_tests(d, jam_test(max_samples=MAX), (1.0,), SEED, mechanics="wobbly")


def test_the_sweep_is_folded_ahead_and_handed_to_its_stream():
    """While the test at 1x runs, a worker with no chunk sure to be used gets the first
    chunk of a sweep scale (the sweep asks for it whatever the verdict at 1x), once, and no
    chunk past where a clean run of the samples in flight would stop the test; when
    the sweep starts, its stream consumes that chunk's outcomes first and folds on after it."""
    from foldprint.model.materials import default_library
    from foldprint.simulation.jamtest import pool as batch
    from foldprint.simulation.jamtest.stages import check_follow
    from foldprint.simulation.jamtest.streams import MIN_CHUNK
    from foldprint.simulation.jamtest.verdict import decide, jam_test
    from foldprint.simulation.robust import Outcome

    clean = Outcome(False, None, None, None, 1.0)
    name = "jam test at 2x"
    jobs = [MonteCarloJob(_designs()[0], 400, SEED, (1.0,), test=jam_test(max_samples=400))]
    b = batch._Batch(jobs, default_library(), 2, None, [], None, check_follow(jobs, (2.0,)))
    (one,) = b.streams
    start, size = one.take(57)  # in flight: nothing else of the test at 1x is sure to be used
    work = b.next_work()
    assert work[:3] == ("early", 0, name) and work[3] == default_scatter().scaled(2.0) and work[4] == (0, MIN_CHUNK)
    # the scale's first chunk once; then none: a clean run of the 57 in flight stops the
    # test at 1x, so a chunk after them would be thrown away (one jam among them and it is not)
    assert b.next_work() is None
    early = [clean] * (MIN_CHUNK - 1) + [Outcome(True, None, None, None, None)]
    b.early[(0, name)] = ("back", 0, (early, 0.001))
    b.chunk_done(one, start, [clean] * size, 0.001)  # 57 clean samples: a pass, the sweep starts
    assert decide([o.jammed for o in one.outcomes], one.test).verdict == "pass"
    (two,) = [s for s in b.streams if s.k == name]
    assert two.outcomes == early and two.next == MIN_CHUNK and two.flying == 0 and not b.early
    assert two.take()[0] == MIN_CHUNK  # it folds on after the chunk folded ahead


def test_a_chunk_folded_ahead_still_in_flight_becomes_its_streams():
    """A sweep chunk folded ahead and not yet back when the sweep starts is handed to the
    new stream: in flight as its first chunk (its outcomes go to that stream), not folded again."""
    from foldprint.model.materials import default_library
    from foldprint.simulation.jamtest import pool as batch
    from foldprint.simulation.jamtest.stages import check_follow
    from foldprint.simulation.jamtest.streams import MIN_CHUNK
    from foldprint.simulation.jamtest.verdict import jam_test
    from foldprint.simulation.robust import Outcome

    clean = Outcome(False, None, None, None, 1.0)
    name = "jam test at 2x"
    jobs = [MonteCarloJob(_designs()[0], 400, SEED, (1.0,), test=jam_test(max_samples=400))]
    b = batch._Batch(jobs, default_library(), 2, None, [], None, check_follow(jobs, (2.0,)))
    (one,) = b.streams
    start, size = one.take(57)
    assert b.next_work()[:3] == ("early", 0, name)
    fut = object()  # the pool's future of that chunk, still running
    b.pending[fut] = ("early", 0, name, 0)
    b.chunk_done(one, start, [clean] * size, 0.001)
    (two,) = [s for s in b.streams if s.k == name]
    assert b.pending[fut] == ("chunk", two, 0) and two.flying == 1 and two.next == MIN_CHUNK and not two.outcomes
    assert two.add(0, [clean] * MIN_CHUNK) is False and len(two.outcomes) == MIN_CHUNK and two.flying == 0


def test_kernels_are_warmed_on_two_samples_of_a_loop_pattern(monkeypatch):
    """Before the workers fork, a strip folds its first sample and a pattern with loops its
    first two (one drive would take the reference tracker, not the compiled round the
    workers use); nothing on the numpy path."""
    from foldprint.model.materials import default_library
    from foldprint.simulation import robust
    from foldprint.simulation.scatter import samples_between

    folded = []
    monkeypatch.setattr(robust, "run_samples", lambda args: folded.append(len(args[2])) or [])
    import foldprint.collision.polytope_distance as pd
    monkeypatch.setattr(pd, "warm_kernel", lambda: None)
    miura = load_design(templates_dir() / "miura_3x3.toml")
    for design, want in ((_designs()[0], 1), (miura, 2)):
        head = samples_between(design, default_scatter(), SEED, 0, 16)
        for kernels, n in ((True, want), (False, None)):
            monkeypatch.setattr(robust, "use_kernels", lambda k=kernels: k)
            folded.clear()
            robust.warm_kernels((design, default_library(), head, "arc", 0.01, False))
            assert folded == ([n] if n else []), (design.name, kernels)
