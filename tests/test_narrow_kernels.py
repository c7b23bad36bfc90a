"""The compiled narrow phase (``collision/narrow_kernels.py``) against the reference walk
(``SweptChecker.steps``, its splits and refinement, advanced by ``swept_first_contact``'s
heap) on the same trajectories, both on the compiled distances and poses: the same
earliest contact (pair, time, distance, point), the same initial contacts and the same
number of exact distances (the same steps, splits and refinements)."""

from __future__ import annotations

import resource
import sys
from itertools import islice
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from foldprint.collision import swept_search
from foldprint.collision.swept3d import SweptChecker
from foldprint.core import jit
from foldprint.core.constants import CHECK_DT_S, CHECK_SAMPLES, CHECK_SEED
from foldprint.core.modes import VERDICT_METHOD, HingeModel
from foldprint.io.load import load_design
from foldprint.io.templates import templates_dir
from foldprint.model.design import strip
from foldprint.model.materials import default_library
from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics
from foldprint.simulation import robust
from foldprint.simulation.scatter import default_scatter, iter_samples

pytestmark = pytest.mark.skipif(not jit.use_kernels(), reason="numba cannot load here: nothing compiled to compare")

#: contact times and distances of the two walks: the same steps on the same distances; the
#: motion bound is summed hinge by hinge in the kernel, by numpy's product in the reference
TIME_TOL = 1e-12
POINT_TOL = 1e-9


def _reference():
    """The reference walk: ``swept_first_contact`` without the compiled one."""
    return mock.patch.object(swept_search, "walk_tables", lambda checker: None)


def _contacts(d, t_start=0.0, dt=0.05, skip=None):
    """(compiled, reference) results of ``swept_first_contact`` on one nominal fold of
    ``d``: (contact, initial, exact distances before the point is read)."""
    drive = HingeDrive(d)
    traj = simulate_kinematics(d, model=HingeModel.ARC, dt=dt, drive=drive)
    ch = SweptChecker(d, "arc", drive)
    assert swept_search.walk_tables(ch) is not None  # the compiled walk applies

    def run():
        c = ch.with_drive(drive)
        best, initial = swept_search.swept_first_contact(c, traj.times, traj.angles, traj.poses, t_start, skip)
        return best, initial, c.n_distance_calls

    got = run()
    with _reference():
        ref = run()
    return got, ref


def _same(got, ref):
    (c, init, calls), (c0, init0, calls0) = got, ref
    assert calls == calls0  # the same steps, splits and refinements
    assert [(x.pair, x.time, x.distance, x.method) for x in init] == \
        [(x.pair, x.time, x.distance, x.method) for x in init0]
    assert (c is None) == (c0 is None)
    if c is not None:
        assert c.pair == c0.pair and c.method == c0.method
        assert abs(c.time - c0.time) <= TIME_TOL and abs(c.distance - c0.distance) <= TIME_TOL
        assert np.allclose(c.point, c0.point, rtol=0, atol=POINT_TOL), (c.point, c0.point)
        assert all(np.isfinite(c.point))


@settings(max_examples=12, deadline=None, derandomize=True, database=None)
@given(n=st.integers(4, 9), data=st.data())
def test_the_compiled_walk_finds_the_references_contacts_on_coiling_strips(n, data):
    """Strips that fold onto themselves (angles near 180 degrees), so pairs come close,
    intervals are split and contacts refined."""
    lengths = data.draw(st.lists(st.floats(8, 30), min_size=n, max_size=n))
    angles = data.draw(st.lists(st.sampled_from([150, 160, 170, -170, 120]), min_size=n - 1, max_size=n - 1))
    mats = data.draw(st.lists(st.sampled_from(["H-1", "H-2", "H-3", "H-5"]), min_size=n - 1, max_size=n - 1))
    got, ref = _contacts(strip("coil", lengths, angles, mats, radius=2.0))
    _same(got, ref)


def test_a_coil_has_a_contact_split_and_refined():
    """The walks meet a contact here, so the comparison above is not between two Nones."""
    got, ref = _contacts(strip("coil", [30, 10, 30, 10, 30], [170] * 4, ["H-2"] * 4, radius=2.0))
    _same(got, ref)
    assert got[0] is not None and got[2] > 5


def test_a_later_start_and_skipped_pairs_walk_alike():
    """From a start time past 0 (no initial contacts) and with the first pair skipped, as
    an arrest's next round asks."""
    d = strip("coil", [30, 10, 30, 10, 30], [170] * 4, ["H-2"] * 4, radius=2.0)
    (c, _, _), _ = _contacts(d)
    got, ref = _contacts(d, t_start=c.time * 0.5, skip={c.pair})
    _same(got, ref)


def test_helix_uniforms_samples_jam_alike():
    """``check``'s first 16 samples of ``helix_uniform`` (each jams): the same outcomes and
    contact times through ``run_samples`` on either walk."""
    d = load_design(templates_dir() / "helix_uniform.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 16))
    args = (d, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)
    a = robust.run_samples(args)
    with _reference():
        b = robust.run_samples(args)
    assert sum(o.jammed for o in a) > 0
    assert [(o.jammed, o.reason, o.pair) for o in a] == [(o.jammed, o.reason, o.pair) for o in b]
    assert all((x.time is None) == (y.time is None) and (x.time is None or abs(x.time - y.time) <= TIME_TOL)
               for x, y in zip(a, b))


def test_a_contacts_point_is_computed_when_read_and_pickles():
    """The point is computed on first read (the same as the reference's) and a pickled
    contact carries it."""
    import pickle

    got, ref = _contacts(strip("coil", [30, 10, 30, 10, 30], [170] * 4, ["H-2"] * 4, radius=2.0))
    c = got[0]
    assert callable(c.__dict__["point"])
    back = pickle.loads(pickle.dumps(c))
    assert back == c and back.point == c.point == ref[0].point


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_a_jamming_chunk_folded_again_reuses_its_memory():
    """``run_samples`` keeps freed memory for the next sample (``robust.keep_heap``): a
    chunk of 16 jamming samples folded again touches few new pages (165-225 a sample
    without it, 5-9 with it, measured)."""
    if not robust.keep_heap():
        pytest.skip("not glibc: mallopt did not take")
    d = load_design(templates_dir() / "helix_uniform.toml")
    samples = list(islice(iter_samples(d, default_scatter(), CHECK_SAMPLES, CHECK_SEED), 16))
    args = (d, default_library(), samples, HingeModel.ARC, CHECK_DT_S, False, VERDICT_METHOD)
    robust.run_samples(args)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(3):
        robust.run_samples(args)
    assert (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / 48 < 40
