"""The exact distance between two convex panel prisms (what every reported clearance is)
against independent references: boxes at a known distance (analytic, any common rigid
motion, coplanar faces included), a constrained minimisation (scipy's SLSQP) on random
prisms in random poses, the separating-axis theorem and FCL's collision test for overlap;
the compiled kernel against the numpy reference; each result's certificate (the upper
and lower bounds within ``certify_tol``)."""

from __future__ import annotations

import fcl
import numpy as np
import pytest
from hypothesis import assume, example, given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from foldprint.collision import polytope_distance as ref
from foldprint.collision.polytope_distance import certify_tol, prism_bounds, sat_separation
from foldprint.collision.rigid import prism
from foldprint.core.jit import use_kernels


def _kernel_bounds(*args):
    from foldprint.collision.polytope_distance_kernels import prism_bounds as kernel

    return kernel(*args, ref.CERT_ABS, ref.CERT_REL)


PATHS = [prism_bounds] + ([_kernel_bounds] if use_kernels() else [])


def _pose(rotvec, shift) -> np.ndarray:
    p = np.eye(4)
    p[:3, :3] = Rotation.from_rotvec(rotvec).as_matrix()
    p[:3, 3] = shift
    return p


def _box(w, h) -> np.ndarray:
    return np.array([[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]])


def _world(ring, half, pose):
    return ref.prism_vertices(ring, half) @ pose[:3, :3].T + pose[:3, 3]


def _check_certificate(ub, lb, pa, pb, scale):
    assert ub - lb <= certify_tol(scale)
    if ub > 0:
        assert np.linalg.norm(pa - pb) == pytest.approx(ub, abs=1e-12 * max(1.0, scale))


_ROT = st.tuples(*[st.floats(-3.2, 3.2)] * 3)
_SHIFT = st.tuples(*[st.floats(-500.0, 500.0)] * 3)


@settings(max_examples=150, deadline=None, derandomize=True, database=None)
@given(size=st.tuples(*[st.floats(0.5, 30.0)] * 4), half=st.tuples(st.floats(0.1, 2.0), st.floats(0.1, 2.0)),
       gap=st.tuples(st.floats(-5.0, 20.0), st.floats(-5.0, 20.0), st.sampled_from([0.0, 0.0, 0.5, 3.0, -2.0])),
       rot=_ROT, shift=_SHIFT)
@example(size=(1.0, 16.0, 1.0, 1.0), half=(2.0, 1.0), gap=(-5.960464477539063e-08, 1.0, 0.5),
         rot=(0.0, 2.0, 2.556640625), shift=(0.0, 0.0, 0.0))  # parallel edges overlapping by a hair
def test_boxes_at_a_known_distance(size, half, gap, rot, shift):
    """Two boxes, the second beside the first by ``gap`` along each axis (negative: their
    ranges may overlap on it; dz = 0: coplanar faces, FCL's worst case), both moved by one
    rigid motion: the distance is the norm of the per-axis gaps between their ranges."""
    wa, ha, wb, hb = size
    move = _pose(rot, shift)
    pb = move @ _pose((0.0, 0.0, 0.0), (wa + gap[0], ha + gap[1], half[0] + half[1] + gap[2]))
    a_lo, a_hi = np.array([0.0, 0.0, -half[0]]), np.array([wa, ha, half[0]])
    b_lo = np.array([wa + gap[0], ha + gap[1], half[0] + gap[2]])
    b_hi = b_lo + [wb, hb, 2 * half[1]]
    want = float(np.linalg.norm(np.maximum(0.0, np.maximum(b_lo - a_hi, a_lo - b_hi))))
    scale = float(np.abs(np.vstack([_world(_box(wa, ha), half[0], move), _world(_box(wb, hb), half[1], pb)])).max())
    for path in PATHS:
        ub, lb, qa, qb = path(move, _box(wa, ha), half[0], pb, _box(wb, hb), half[1])
        assert ub == pytest.approx(want, abs=certify_tol(scale)), path
        _check_certificate(ub, lb, qa, qb, scale)


def _ring(sides, radius, stretch, turn):
    ang = turn + np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    return np.column_stack([radius * stretch * np.cos(ang), radius * np.sin(ang)])


def _slsqp(ring_a, ha, pose_a, ring_b, hb, pose_b) -> float:
    """The distance by constrained minimisation over a point of each prism (panel-frame
    coordinates, the prisms as half-spaces), started at the centres."""
    def halfspaces(ring, half):
        e = np.roll(ring, -1, axis=0) - ring
        n = np.column_stack([e[:, 1], -e[:, 0]]) / np.hypot(*e.T)[:, None]  # outward (counter-clockwise)
        return n, (n * ring).sum(axis=1), half

    ca, cb = halfspaces(ring_a, ha), halfspaces(ring_b, hb)

    def inside(x, c):
        n, off, half = c
        return np.r_[off - n @ x[:2], half - abs(x[2])]

    def f(x):
        d = (pose_a[:3, :3] @ x[:3] + pose_a[:3, 3]) - (pose_b[:3, :3] @ x[3:] + pose_b[:3, 3])
        return d @ d

    x0 = np.r_[ring_a.mean(0), 0.0, ring_b.mean(0), 0.0]
    cons = [{"type": "ineq", "fun": lambda x: inside(x[:3], ca)}, {"type": "ineq", "fun": lambda x: inside(x[3:], cb)}]
    res = minimize(f, x0, constraints=cons, method="SLSQP", options={"ftol": 1e-15, "maxiter": 500})
    return float(np.sqrt(max(res.fun, 0.0)))


_PRISM = st.tuples(st.integers(3, 12), st.floats(1.0, 10.0), st.floats(0.3, 2.0), st.floats(0.0, 6.3),
                   st.floats(0.1, 1.5))


@settings(max_examples=80, deadline=None, derandomize=True, database=None)
@given(a=_PRISM, b=_PRISM, rot_a=_ROT, rot_b=_ROT, coplanar=st.booleans(),
       shift=st.tuples(*[st.floats(-25.0, 25.0)] * 3))
def test_random_prisms_against_a_constrained_minimisation(a, b, rot_a, rot_b, coplanar, shift):
    """Random convex prisms in random poses (or the second turned in the first's plane, its
    faces coplanar or parallel): the distance equals SLSQP's minimum over a point in each
    prism, the nearest points lie on the prisms, and the certificate holds."""
    ring_a, ring_b = _ring(*a[:4]), _ring(*b[:4])
    pose_a = _pose(rot_a, (0.0, 0.0, 0.0))
    pose_b = pose_a @ _pose((0, 0, rot_b[2]), (shift[0], shift[1], 0.0 if coplanar else shift[2])) \
        if coplanar else _pose(rot_b, shift)
    got = [path(pose_a, ring_a, a[4], pose_b, ring_b, b[4]) for path in PATHS]
    ub, lb, qa, qb = got[0]
    for other in got[1:]:
        assert other[0] == pytest.approx(ub, abs=1e-12) and other[1] == pytest.approx(lb, abs=1e-12)
    want = _slsqp(ring_a, a[4], pose_a, ring_b, b[4], pose_b)
    scale = 60.0
    assert ub == pytest.approx(want, abs=2e-6), (ub, want)
    _check_certificate(ub, lb, qa, qb, scale)
    if ub > 0:  # the nearest points are points of the prisms
        for q, ring, half, pose in ((qa, ring_a, a[4], pose_a), (qb, ring_b, b[4], pose_b)):
            local = (q - pose[:3, 3]) @ pose[:3, :3]
            e = np.roll(ring, -1, axis=0) - ring
            rel = local[:2] - ring
            assert (e[:, 0] * rel[:, 1] - e[:, 1] * rel[:, 0] >= -1e-9 * np.hypot(*e.T)).all()
            assert abs(local[2]) <= half + 1e-9


def _fcl_object(ring, half, pose):
    v, f = prism(ring, 2 * half)
    obj = fcl.CollisionObject(fcl.Convex(v, len(ring) + 2, f))
    obj.setTransform(fcl.Transform(pose[:3, :3], pose[:3, 3]))
    return obj


@settings(max_examples=80, deadline=None, derandomize=True, database=None)
@given(a=_PRISM, b=_PRISM, rot_a=_ROT, rot_b=_ROT, shift=st.tuples(*[st.floats(-8.0, 8.0)] * 3))
def test_overlap_is_distance_zero_as_the_separating_axis_theorem_and_fcl_say(a, b, rot_a, rot_b, shift):
    """Close prisms, overlapping or not: distance 0 exactly when the separating-axis theorem
    finds no separating axis and FCL's collision test reports a contact (pairs within 1e-9
    mm of touching excluded: each test may call those either way)."""
    ring_a, ring_b = _ring(*a[:4]), _ring(*b[:4])
    pose_a, pose_b = _pose(rot_a, (0.0, 0.0, 0.0)), _pose(rot_b, shift)
    wa, wb = _world(ring_a, a[4], pose_a), _world(ring_b, b[4], pose_b)
    sep = sat_separation(wa, len(ring_a), wb, len(ring_b))
    assume(abs(sep) > 1e-9)
    hit = fcl.collide(_fcl_object(ring_a, a[4], pose_a), _fcl_object(ring_b, b[4], pose_b),
                      fcl.CollisionRequest(), fcl.CollisionResult())
    for path in PATHS:
        ub, lb, qa, qb = path(pose_a, ring_a, a[4], pose_b, ring_b, b[4])
        assert (ub == 0.0) == (sep < 0) == bool(hit), (ub, sep, hit)
        if ub > 0:
            assert sep <= ub + 1e-9  # a projection gap is never more than the distance
            _check_certificate(ub, lb, qa, qb, 30.0)


#: two coplanar rectangles, the second turned half a turn in the plane, 0.0678 mm apart,
#: both turned by a rotation: python-fcl 0.7 reads 0.80 mm (the thickness; measured), so
#: near contact too a distance must not come from FCL
NEAR = ((-0.6599, -1.992, 1.529), 7.5044, -0.0677)


def test_fcl_reads_coplanar_rectangles_near_contact_an_order_too_far():
    rot, tx, ty = NEAR
    a = np.array([[0.0, 0.0], [2.25, 0.0], [2.25, 10.6], [0.0, 10.6]])
    b = np.array([[0.0, 0.0], [5.25, 0.0], [5.25, 10.3], [0.0, 10.3]])
    base = _pose(rot, (0.0, 0.0, 0.0))
    pose_b = base @ _pose((0.0, 0.0, np.pi), (tx, ty, 0.0))
    want = float(np.hypot(tx - 5.25 - 2.25, ty))  # the corners' gap in the plane
    for path in PATHS:
        assert path(base, a, 0.4, pose_b, b, 0.4)[0] == pytest.approx(want, abs=1e-9)
    got = fcl.distance(_fcl_object(a, 0.4, base), _fcl_object(b, 0.4, pose_b), fcl.DistanceRequest(),
                       fcl.DistanceResult())
    assert got > want + 0.5, "FCL is right here now: pick a case it misses (the test's reason)"


@pytest.mark.parametrize("name", ["mailbox", "octagon_stack"])
def test_panel_distances_agree_on_every_path_over_a_fold(name):
    """Every non-adjacent pair of a template at 12 poses of its fold: the numpy path seeded
    by FCL's nearest points, the numpy enumeration alone and the compiled kernel give the
    same distance (within the certificate's tolerance), each certified; on these poses FCL's
    own distance is sometimes millimetres high (measured: 4 mm on the mailbox), so a path
    that took it uncertified would fail here."""
    from foldprint.collision.broadphase import non_adjacent_pairs
    from foldprint.collision.polytope_distance import _panel_bounds, _seeds, prism_set
    from foldprint.collision.swept3d import SweptChecker
    from foldprint.io.load import load_design
    from foldprint.io.templates import resolve_design_path
    from foldprint.physics.hinge_drive import simulate_kinematics

    d = load_design(resolve_design_path(name))
    tr = simulate_kinematics(d, model="arc")
    ch = SweptChecker(d, "arc", None)
    s = prism_set(ch)
    seeds = _seeds(ch, s)
    tol = certify_tol(200.0)
    kernel = None
    if use_kernels():
        from foldprint.collision.polytope_distance_kernels import panel_bounds as kernel
    seeded = 0
    for k in np.linspace(0, len(tr.times) - 1, 12).astype(int):
        for i, j in non_adjacent_pairs(d):
            P, Q = tr.poses[k, i], tr.poses[k, j]
            plain = _panel_bounds(P, Q, i, j, s)
            fast = _panel_bounds(P, Q, i, j, s, seeds)
            assert fast[0] == pytest.approx(plain[0], abs=tol) and plain[0] - plain[1] <= tol
            assert fast[0] - fast[1] <= tol
            if kernel is not None:
                got = kernel(P, Q, i, j, s.ring, s.piece_off, s.panel_off, s.half, s.cen, s.rad,
                             ref.CERT_ABS, ref.CERT_REL)
                assert got[0] == pytest.approx(plain[0], abs=tol)
            seeded += fast[0] > 0
    assert seeded > 0


@pytest.mark.parametrize("ulps", [0, 1])
@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(rot=_ROT, shift=st.tuples(*[st.floats(-5.0, 5.0)] * 3), gap=st.floats(0.0, 6.0))
def test_a_repeated_ring_vertex_is_the_same_prism(ulps, rot, shift, gap):
    """A convex piece can hold a vertex twice, exactly or one ulp apart (the waterbomb's
    reliefs made one): in the world its two ends can coincide, an edge of length 0. The
    distance is that of the ring without the repeat, on every path (no division by zero)."""
    ring = np.array([[-14.4, 20.0], [-4.69, 10.25], [-3.9269908169872414, 10.56172152977031], [-3.93, 20.0]])
    twice = np.insert(ring, 3, ring[2] + [ulps * np.spacing(ring[2, 0]), 0.0], axis=0)
    pa = _pose(rot, shift)
    pb = pa @ _pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.8 + gap))
    for path in PATHS:
        want = path(pa, ring, 0.4, pb, ring, 0.4)[0]
        for a, b in ((twice, ring), (ring, twice), (twice, twice)):
            ub, lb, qa, qb = path(pa, a, 0.4, pb, b, 0.4)
            assert ub == pytest.approx(want, abs=1e-9) and ub == pytest.approx(gap, abs=1e-9), path
            _check_certificate(ub, lb, qa, qb, 30.0)


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(size=st.tuples(st.floats(1.0, 30.0), st.floats(1.0, 30.0), st.floats(0.1, 2.0)), gap=st.floats(0.01, 5.0),
       rot=_ROT, shift=_SHIFT)
def test_a_contact_face_reports_its_centre(size, gap, rot, shift):
    """Two equal boxes side by side, face to face: every point of the facing faces is
    nearest. The reported point is the centre between the faces, wherever the rigid motion
    puts them (a first-found nearest pair would be a corner, and which corner depends on
    round-off and on the path)."""
    w, h, half = size
    move = _pose(rot, shift)
    ring = _box(w, h)
    s = ref.PrismSet(np.vstack([ring, ring]), np.array([0, 4, 8]), np.array([0, 1, 2]), np.array([half, half]),
                     np.array([[w / 2, h / 2, 0.0]] * 2), np.array([np.hypot(w, h) / 2 + half] * 2))
    pb = move @ _pose((0.0, 0.0, 0.0), (w + gap, 0.0, 0.0))
    for path in PATHS:
        dist = path(move, ring, half, pb, ring, half)[0]
        assert dist == pytest.approx(gap, abs=1e-9)
        point = ref.nearest_centre(s, 0, 1, move, pb, dist)
        want = move[:3, :3] @ [w + gap / 2, h / 2, 0.0] + move[:3, 3]
        assert np.abs(point - want).max() <= 1e-9 * max(1.0, np.abs(want).max())
