"""The evaluation object (the one place stages are chained): each stage computed on first use and kept, derived
per-design data computed once per evaluation in a cache that never travels, a validated
``Design.replace``, and ``simulate`` leaving the caller's drive as given."""

from __future__ import annotations

import importlib
import pickle
from pathlib import Path

import numpy as np
import pytest

import foldprint.apps.pipeline as pipeline
import foldprint.physics.kinematics as kinematics
from foldprint.apps.pipeline import EvalOptions, Evaluation
from foldprint.core.errors import DesignError
from foldprint.core.modes import AfterContact, HingeModel, Method
from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.model import derived
from foldprint.model.derived import DerivedCache
from foldprint.physics.hinge_drive import HingeDrive
from foldprint.simulation.simulate import simulate


@pytest.fixture(scope="module")
def helix():
    return load_design(resolve_design_path("helix_graded"))


#: the modules an evaluation's stages are computed in (pipeline and its four mixins)
STAGE_MODULES = tuple(importlib.import_module(f"foldprint.apps.{m}") for m in (
    "pipeline", "evaluation_nominal", "evaluation_verdict", "evaluation_exports", "evaluation_reports"))


def _count(monkeypatch, module, name):
    """Count the calls of ``name`` (``module`` None: wherever an evaluation's stages call it)."""
    calls = []
    modules = [module] if module is not None else [m for m in STAGE_MODULES if hasattr(m, name)]
    assert modules and all(hasattr(m, name) for m in modules), name
    real = getattr(modules[0], name)

    def counted(*a, **k):
        calls.append(a)
        return real(*a, **k)

    for m in modules:
        monkeypatch.setattr(m, name, counted)
    return calls


def test_a_stage_not_asked_for_is_not_computed(helix, monkeypatch):
    sims = _count(monkeypatch, None, "simulate")
    builds = _count(monkeypatch, None, "build_assembly")
    mc = _count(monkeypatch, None, "jam_tests")
    ev = Evaluation(helix, EvalOptions(samples=4, seed=1))
    assert (sims, builds, mc) == ([], [], [])  # nothing runs at construction
    first = ev.simulation
    assert len(sims) == 1 and builds == [] and mc == []
    assert ev.simulation is first and len(sims) == 1  # kept
    ev.clearance  # needs the simulation (kept), not the assembly nor the samples
    assert len(sims) == 1 and builds == [] and mc == []
    assert ev.computed["simulation"] == 1 and not ev.has("jam_tests") and not ev.has("assembly")


def test_findings_compute_each_stage_once(helix, monkeypatch):
    sims = _count(monkeypatch, None, "simulate")
    builds = _count(monkeypatch, None, "build_assembly")
    mc = _count(monkeypatch, None, "jam_tests")
    ev = Evaluation(helix, EvalOptions(samples=4, seed=1))
    ev.findings
    ev.to_json()
    ev.findings
    assert (len(sims), len(builds), len(mc)) == (1, 1, 1)
    assert all(n == 1 for n in ev.computed.values()), ev.computed


def test_hinge_frames_computed_once_per_evaluation(helix, monkeypatch):
    calls = _count(monkeypatch, kinematics, "_hinge_frames")
    ev = Evaluation(helix, EvalOptions(samples=4, seed=1))
    ev.findings
    assert len([a for a in calls if a[0] is helix]) == 1
    assert ev.cache.computed["hinge_frames"] >= 1
    # a second evaluation of the same design owns its own cache: computed again, once
    Evaluation(helix, EvalOptions(samples=0)).findings
    assert len([a for a in calls if a[0] is helix]) == 2


def test_frames_outside_an_evaluation_are_not_kept_on_the_design(helix):
    kinematics.hinge_frames(helix)
    from foldprint.collision.rigid import rigid_polygon
    rigid_polygon(helix, 0, "arc")
    assert not [k for k in vars(helix) if "cache" in k]
    assert derived.current() is None


def test_the_cache_does_not_travel(helix):
    cache = DerivedCache()
    with pytest.raises(TypeError, match="not sent to workers"):
        pickle.dumps(cache)
    with cache.active():
        kinematics.hinge_frames(helix)
        blob = pickle.dumps(helix)  # the design pickles without any derived data
    assert len(cache) >= 1
    assert len(blob) == len(pickle.dumps(helix))


def test_a_forked_process_ignores_the_parents_cache(helix, monkeypatch):
    cache = DerivedCache()
    with cache.active():
        monkeypatch.setattr(cache, "_pid", -1)  # what a forked child sees: another process's cache
        assert derived.current() is None
        kinematics.hinge_frames(helix)
    assert len(cache) == 0


def test_monte_carlo_chunks_derive_once_per_design_content(helix, monkeypatch):
    """A worker gets a fresh copy of the design with every chunk (pickled): the second
    chunk finds the first copy's derived data (keyed by the design's content, not its identity), a changed design does
    not, and the outcomes equal a chunk folded with nothing kept."""
    from itertools import islice

    from foldprint.model.materials import default_library
    from foldprint.simulation import robust
    from foldprint.simulation.scatter import default_scatter, iter_samples

    monkeypatch.setattr(derived, "_kept", type(derived._kept)())
    calls = _count(monkeypatch, kinematics, "_hinge_frames")
    lib = default_library()
    samples = list(islice(iter_samples(helix, default_scatter(), 4, 1), 4))
    chunk = lambda d: robust.run_samples((d, lib, samples, HingeModel.ARC, 0.01))  # noqa: E731
    first = chunk(pickle.loads(pickle.dumps(helix)))
    n = len(calls)
    assert n >= 1
    assert chunk(pickle.loads(pickle.dumps(helix))) == first and len(calls) == n  # kept: not derived again
    other = helix.replace(name="helix_renamed")
    assert derived.content_key(other) != derived.content_key(helix)
    chunk(other)
    assert len(calls) == n + 1  # another design: its own data
    monkeypatch.setattr(derived, "_kept", type(derived._kept)())
    assert chunk(pickle.loads(pickle.dumps(helix))) == first  # nothing kept: the same outcomes
    with DerivedCache().active():  # an active cache (an evaluation) is used as before
        before = len(calls)
        chunk(helix)
        assert len(calls) == before + 1


def test_cached_values_equal_fresh_ones(helix):
    fresh = kinematics._hinge_frames(helix)
    with DerivedCache().active():
        a = kinematics.hinge_frames(helix)
        b = kinematics.hinge_frames(helix)
    assert a is not b and a == b  # a new list each time, the same frames
    assert [f.hinge.id for f in fresh] == [f.hinge.id for f in a]
    assert all(np.allclose(x.axis, y.axis) for x, y in zip(fresh, a))


def test_simulate_leaves_the_callers_drive_as_given():
    from foldprint.model.design import strip

    d = strip("arrest", [20, 20, 20, 20], [170, 170, 170], ["H-1", "H-1", "H-1"])
    drive = HingeDrive(d)
    res = simulate(d, method=Method.FCL, after_contact=AfterContact.ARREST, drive=drive)
    assert res.arrested  # the run did arrest hinges...
    assert drive.frozen_at == {}  # ...on its own copy of the drive
    again = simulate(d, method=Method.FCL, after_contact=AfterContact.ARREST, drive=drive)
    assert again.arrested == res.arrested


def test_design_replace_validates(helix):
    h0 = helix.hinges[0]
    from dataclasses import replace

    ok = helix.replace(name="renamed")
    assert ok.name == "renamed" and ok.hinges == helix.hinges
    with pytest.raises(DesignError, match="not-a-material"):
        helix.replace(hinges=(replace(h0, material="not-a-material"),) + helix.hinges[1:])


def test_options_parse_modes_and_refuse_bad_ones():
    o = EvalOptions(hinge_model="point", method="both", after_contact="arrest", scales=[0.5, 2])
    assert (o.hinge_model, o.method, o.after_contact, o.scales) == (HingeModel.POINT, Method.BOTH,
                                                                    AfterContact.ARREST, (0.5, 2.0))
    with pytest.raises(DesignError, match="hinge_model"):
        EvalOptions(hinge_model="hinged")


def test_export_takes_the_evaluations_assembly(helix, tmp_path, monkeypatch):
    ev = Evaluation(helix, EvalOptions(samples=0))
    ev.findings
    builds = _count(monkeypatch, None, "build_assembly")
    recs = ev.export(tmp_path / "a", formats=("stl",))
    assert builds == [] and recs
    fresh = pipeline.export(helix, tmp_path / "b", formats=("stl",))
    # the same files; the recipe of the checked evaluation also carries the check's verdict
    assert [r["format"] for r in recs] == [r["format"] for r in fresh]
    assert [(tmp_path / "a" / r["path"].split("/")[-1]).read_bytes() for r in recs if r["format"] != "recipe"] == \
        [(tmp_path / "b" / r["path"].split("/")[-1]).read_bytes() for r in fresh if r["format"] != "recipe"]
    (checked,) = [Path(r["path"]).read_text() for r in recs if r["format"] == "recipe"]
    (unchecked,) = [Path(r["path"]).read_text() for r in fresh if r["format"] == "recipe"]
    assert "`foldprint check`: **" in checked and "Not checked in this export" in unchecked


def test_the_stl_writer_is_given_the_fold_times(helix, tmp_path, monkeypatch):
    """The manifest reports the fold times it is given and runs no recovery model; without
    them the writer refuses (and writes nothing)."""
    import json
    import sys

    import foldprint.physics.recovery.curve as recovery
    from foldprint.core.errors import ExportError
    from foldprint.exchange.export import export_assembly
    from foldprint.geometry import build_assembly

    asm = build_assembly(helix)
    given = {h.id: 1.0 + k for k, h in enumerate(helix.hinges)}

    def boom(*a, **k):
        raise AssertionError("the writer ran the recovery model")

    monkeypatch.setattr(recovery, "fold_time", boom)
    monkeypatch.setattr(recovery, "recovery_curve", boom)
    export_assembly(helix, asm, tmp_path / "a", ["stl"], fold_times=given)
    doc = json.loads((tmp_path / "a" / "manifest.json").read_text())
    assert doc["programming"]["hinge_fold_times_s"] == given
    assert doc["programming"]["expected_fold_time_s"] == max(given.values())
    with pytest.raises(ExportError, match="fold time"):
        export_assembly(helix, asm, tmp_path / "b", ["stl"])
    assert not (tmp_path / "b").exists() or not any((tmp_path / "b").iterdir())
    stl = sys.modules["foldprint.exchange.stl"]
    assert not any(getattr(stl, n, None) is not None for n in ("fold_time", "recovery_curve"))


def test_the_manifest_fold_times_are_the_recovery_models(helix, tmp_path):
    import json

    from foldprint.physics.recovery.curve import fold_time
    from foldprint.model.materials import default_library

    pipeline.export(helix, tmp_path, formats=("stl",))
    doc = json.loads((tmp_path / "manifest.json").read_text())
    lib, pr = default_library(), helix.process
    for h in helix.hinges:  # an independent call of the recovery model, per hinge
        t = fold_time(lib[h.material], pr.bath_temperature_c, h.thickness, pr.fix_temperature_c)
        assert doc["programming"]["hinge_fold_times_s"][h.id] == pytest.approx(t, abs=5e-4)


@pytest.mark.parametrize("name", ["cross_lock_uniform", "helix_uniform"])
def test_shared_nominal_work_gives_each_simulation_unchanged(name):
    """An evaluation's simulations share the nominal drive (a loop pattern's closure
    tracked once) and, off a planar strip, 'both' is the 3D check's simulation (no nominal work twice):
    each equals the simulation run on its own, field for field."""
    from foldprint.checks.report import simulation_json

    d = load_design(resolve_design_path(name))
    ev = Evaluation(d, EvalOptions(samples=0))
    for m in (Method.FCL, Method.BOTH):
        alone = simulate(d, method=m, dt=ev.options.dt)
        shared = ev.simulation_for(m)
        assert shared.method == m
        assert simulation_json(shared) == simulation_json(alone)
        assert np.array_equal(shared.trajectory.angles, alone.trajectory.angles)
        assert np.array_equal(shared.trajectory.poses, alone.trajectory.poses)
    other = HingeModel.POINT if ev.options.hinge_model == HingeModel.ARC else HingeModel.ARC
    alt = simulate(d, method=ev.options.method, dt=ev.options.dt, hinge_model=other)
    comp = ev.comparison
    assert (comp is None) == (pipeline.verdict_of(alt) == pipeline.verdict_of(ev.simulation))
    if comp is not None:
        assert simulation_json(comp.result) == simulation_json(alt)
