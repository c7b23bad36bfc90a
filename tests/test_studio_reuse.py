"""What the studio's next revision takes over (``apps.studio_reuse``): an edit's nominal
result equals a fresh evaluation's of the same design (clearance, its curve, the design
rules, the printed crossings), whether the search was bounded or not; the bounded search
does run where it may; the pairs an edit changes agree with paths found in the hinge graph;
the printed part from relabelled pieces equals one built from scratch."""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np
import pytest

from foldprint.apps import studio_reuse
from foldprint.apps.studio_session import Session
from foldprint.collision.broadphase import non_adjacent_pairs
from foldprint.core.modes import State
from foldprint.geometry import build_assembly, build_pieces
from foldprint.geometry.assembly import relabelled
from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.model.printers import default_printer_key, load_printers

KEYS = ("clearance", "clearance_curve", "findings", "printed_crossings", "errors", "warnings", "completed")


def staircase(n: int):
    return strip(f"stairs{n}", [6.0] * n, [90.0 if i % 2 == 0 else -90.0 for i in range(n - 1)], ["H-3"] * (n - 1),
                 depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)


def session(design) -> Session:
    return Session(design, default_library(), load_printers(), default_printer_key())


def fresh(entry) -> dict:
    """The nominal result of a new session on ``entry``'s design and setup (nothing to take over)."""
    s = session(entry.design)
    if entry.setup != s.entry.setup:
        s.apply({"options": entry.setup.to_json()})
    return s.nominal(*s.current())


@pytest.fixture
def counted(monkeypatch):
    """Calls of the library's whole search from the studio's clearance."""
    calls = []
    whole = studio_reuse.swept_min_clearance
    monkeypatch.setattr(studio_reuse, "swept_min_clearance", lambda *a, **k: calls.append(1) or whole(*a, **k))
    return calls


@pytest.mark.parametrize("name", ["stairs", "helix_uniform", "mailbox", "miura_3x3"])
def test_an_edit_answers_what_a_fresh_evaluation_does(name, counted):
    design = staircase(24) if name == "stairs" else load_design(resolve_design_path(name))
    s = session(design)
    s.nominal(*s.current())
    ends, mid = design.hinges[0], design.hinges[len(design.hinges) // 2]
    for edit in ({"hinges": {ends.id: {"material": "H-6"}}}, {"hinges": {mid.id: {"material": "H-1"}}},
                 {"hinges": {mid.id: {"material": "H-7"}, ends.id: {"material": "H-2"}}},
                 {"process": {"bath_c": 75}}, {"hinges": {mid.id: {"target_deg": 60}}},
                 {"options": {"hinge_model": "point"}}, {"hinges": {ends.id: {"material": "H-4"}}}):
        counted.clear()
        rev, entry = s.apply(edit)
        got = s.nominal(rev, entry)
        whole = len(counted)
        want = fresh(entry)
        for key in KEYS:
            assert got[key] == want[key], (name, edit, key)
        if name == "stairs" and "hinges" in edit and "target_deg" not in str(edit):
            # one or two hinges changed on a strip: neither the clearance nor a pose of the
            # curve needed the whole search (its minimum is not at the changed hinge)
            assert whole < 1 + len(got["clearance_curve"]["time_s"]), (edit, whole)
    rev, entry = s.undo()
    assert s.nominal(rev, entry)["clearance"] == fresh(entry)["clearance"]


def test_the_bound_is_used_and_a_changed_minimum_is_found(counted):
    """Bounded by the unchanged pairs, the search still finds a smaller gap among the
    changed ones: a strip whose end hinge folds too far closes on its neighbour."""
    # panels shortening along the strip: the smallest gap of every pose is at its far end,
    # one pair (an even staircase's p(k)-p(k+2) gaps are equal to round-off, and which of
    # them the search names, perhaps one h1 spans, is the round-off's choice)
    design = strip("taper12", [6.0 + 0.1 * (12 - k) for k in range(12)],
                   [90.0 if i % 2 == 0 else -90.0 for i in range(11)], ["H-3"] * 11,
                   depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)
    s = session(design)
    base = s.nominal(*s.current())
    counted.clear()
    rev, entry = s.apply({"hinges": {"h1": {"material": "H-1"}}})
    got = s.nominal(rev, entry)
    assert counted == [] and got["clearance"] == fresh(entry)["clearance"]
    counted.clear()
    rev, entry = s.apply({"hinges": {"h11": {"target_deg": 150}}})  # geometry: searched whole
    got = s.nominal(rev, entry)
    assert counted
    want = fresh(entry)
    assert got["clearance"] == want["clearance"]
    assert got["clearance"]["distance_mm"] != base["clearance"]["distance_mm"]
    counted.clear()
    rev, entry = s.apply({"hinges": {"h1": {"material": "H-7"}}})
    got = s.nominal(rev, entry)
    assert got["clearance"] == fresh(entry)["clearance"] and got["clearance_curve"] == \
        fresh(entry)["clearance_curve"]


def test_the_reported_moment_is_the_first_within_the_minimum(monkeypatch):
    """With the minimum and the pair it was first reached by both unchanged, only the
    changed pairs are scanned for an earlier moment within it; the gap reported is the
    whole scan's."""
    scans = []
    whole = studio_reuse.earliest_within
    monkeypatch.setattr(studio_reuse, "earliest_within", lambda *a, **k: scans.append(1) or whole(*a, **k))
    s = session(staircase(12))
    s.nominal(*s.current())
    for hinge in ("h11", "h10", "h1"):
        scans.clear()
        rev, entry = s.apply({"hinges": {hinge: {"material": "H-6"}}})
        got = s.nominal(rev, entry)
        bounded = not scans
        assert got["clearance"] == fresh(entry)["clearance"], hinge
        if hinge == "h11":  # the far end: neither the minimum's pair nor the first one within it changed
            assert bounded


def _path_hinges(design, a: str, b: str) -> set[str]:
    """The hinges on the path from panel a to panel b (breadth-first in the hinge graph)."""
    prev = {a: None}
    q = deque([a])
    while q:
        cur = q.popleft()
        for h in design.hinges:
            if cur in h.panels:
                other = h.panels[1] if h.panels[0] == cur else h.panels[0]
                if other not in prev:
                    prev[other] = (cur, h.id)
                    q.append(other)
    out, cur = set(), b
    while prev[cur] is not None:
        cur, hid = prev[cur]
        out.add(hid)
    return out


@pytest.mark.parametrize("name", ["stairs", "mailbox", "cross_lock_uniform", "self_lock"])
def test_changed_pairs_are_the_pairs_whose_path_crosses_a_changed_hinge(name):
    design = staircase(9) if name == "stairs" else load_design(resolve_design_path(name))
    pairs = np.array(non_adjacent_pairs(design), dtype=np.int64)
    rng = np.random.default_rng(3)
    ids = [p.id for p in design.panels]
    for _ in range(6):
        changed = rng.random(len(design.hinges)) < 0.3
        got = studio_reuse.changed_pairs(design, pairs, changed)
        names = {design.hinges[k].id for k in np.flatnonzero(changed)}
        want = [bool(_path_hinges(design, ids[i], ids[j]) & names) for i, j in pairs]
        assert got.tolist() == want


def test_relabelled_pieces_build_the_same_part():
    lib = default_library()
    design = load_design(resolve_design_path("helix_uniform"))
    new = next(g for g in ("H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7") if g not in design.materials_used)
    other = design.replace(lib, hinges=tuple(h if k % 3 else dataclasses.replace(h, material=new)
                                             for k, h in enumerate(design.hinges)))
    pieces = relabelled(build_pieces(design, State.PERMANENT), other)
    got = build_assembly(other, State.PERMANENT.value, lib, pieces=pieces)
    want = build_assembly(other, State.PERMANENT.value, lib)
    assert [b.material for b in got.bodies] == [b.material for b in want.bodies]
    assert len({b.material for b in want.bodies}) > len({b.material for b in build_assembly(
        design, State.PERMANENT.value, lib).bodies})  # the relabelling changed the bodies
    for a, b in zip(got.bodies, want.bodies):
        assert a.volume == pytest.approx(b.volume, rel=1e-12)
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


def test_a_changed_pair_first_within_the_minimum_is_found():
    """Two end hinges made faster: their pair reaches the strip's smallest gap (every step
    pair's) before the pair an earlier revision reported; the bounded scan finds it, as
    the whole scan (``earliest_within``) does."""
    s = session(staircase(12))
    before = s.nominal(*s.current())
    rev, entry = s.apply({"hinges": {"h10": {"material": "H-1"}, "h11": {"material": "H-1"}}})
    got = s.nominal(rev, entry)
    memo, old = entry.memo, s.history[0].memo.clearance
    assert got["clearance"]["time_s"] < before["clearance"]["time_s"]
    traj = entry.evaluation.simulation.trajectory
    ks = studio_reuse.sampled_poses(studio_reuse.fold_end(entry.evaluation.simulation))
    changed = ~np.all(old.angles == traj.angles[ks], axis=0)
    split = studio_reuse.changed_pairs(entry.design, memo.pairs, changed)
    assert not split[studio_reuse.row_of(memo.pairs, old.earliest[1])]
    now = studio_reuse.Searched(old.times, traj.angles[ks], old.best, split)  # the minimum taken over unchanged
    found = studio_reuse.earliest(memo, traj.poses[ks], now, old)
    whole = studio_reuse.earliest_within(memo.checker, traj.poses[ks][:old.best[2] + 1],
                                         float(old.best[0]) + studio_reuse.tol.length)
    assert found == whole and found != old.earliest and split[studio_reuse.row_of(memo.pairs, found[1])]


def test_two_revisions_of_one_geometry_searched_at_once():
    """Two edits of the same revision (the second after an undo), their nominal results
    computed in two threads at once: they share the parent's checker, one search at a time,
    and each answers what a fresh evaluation does."""
    import threading

    s = session(staircase(16))
    s.nominal(*s.current())
    first = s.apply({"hinges": {"h1": {"material": "H-6"}}})
    s.undo()
    second = s.apply({"hinges": {"h8": {"material": "H-1"}}})
    got = {}
    threads = [threading.Thread(target=lambda r=r: got.__setitem__(r[0], s.nominal(*r))) for r in (first, second)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert first[1].memo.checker is second[1].memo.checker
    for rev, entry in (first, second):
        want = fresh(entry)
        assert all(got[rev][key] == want[key] for key in KEYS), rev
