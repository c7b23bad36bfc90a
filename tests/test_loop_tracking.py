"""The loop tracker against the solver it replaced, kept here as the reference.

The reference evaluates each cycle's closure as a product of 4x4 transforms, one cycle
at a time, and starts every Gauss-Newton solve by evaluating C and J at the previous
answer. The tracker (:class:`foldprint.physics.loops.LoopSolver`) evaluates all cycles at
once and predicts along the previous answer's tangent space instead of that first
evaluation. Same C and J to round-off; same closed angles along a whole fold within
ANGLE_TOL (both stop when a step moves no angle more than OPT_TOL); every answer closed."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from foldprint.io.fold_format import design_from_fold
from foldprint.io.load import load_design
from foldprint.model import crease_patterns as cp
from foldprint.physics import loops
from foldprint.physics.kinematics import HingeDrive, hinge_frames
from foldprint.physics.loops import CLOSURE_TOL, OPT_TOL, LoopSolver, _rotvec

ROOT = Path(__file__).resolve().parent.parent
#: largest difference (rad) of a closed angle between tracker and reference: a few OPT_TOL
ANGLE_TOL = 10 * OPT_TOL


class Reference(LoopSolver):
    """The solver before closure tracking: per-cycle 4x4 products, no predictor."""

    def __init__(self, frames, hinge_ids):
        super().__init__(frames, hinge_ids)
        self._cyc = [(np.array([k for k, _ in cyc]), np.array([0 if sg > 0 else 1 for _, sg in cyc]),
                      np.array([sg for _, sg in cyc])) for cyc in self.cycles]

    def _factors(self, x):
        ang = np.stack([x, -x])[:, :, None, None]
        r = np.eye(3) + np.sin(ang) * self._k + (1 - np.cos(ang)) * self._k2
        g = np.zeros((2, self.n, 4, 4))
        g[..., :3, :3] = r
        g[..., :3, 3] = self.point[None] - np.einsum("snij,nj->sni", r, self.point)
        g[..., 3, 3] = 1.0
        return g

    def residual(self, x, jacobian=True):
        m = len(self.cycles)
        c = np.zeros(6 * m)
        jac = np.zeros((6 * m, self.n)) if jacobian else None
        fac = self._factors(x)
        for ci, (ks, side, sgn) in enumerate(self._cyc):
            g = np.eye(4)
            pre = np.empty((len(ks), 4, 4))
            for m_, (k, sd) in enumerate(zip(ks, side)):
                pre[m_] = g
                g = g @ fac[sd, k]
            c[6 * ci:6 * ci + 3] = _rotvec(g[:3, :3])
            p = g[:3, 3]
            c[6 * ci + 3:6 * ci + 6] = p
            if jacobian:
                rot, tr = pre[:, :3, :3], pre[:, :3, 3]
                w = np.einsum("lij,lj->li", rot, self.axis[ks])
                v = np.einsum("lij,lj->li", rot, self.twist[ks, 3:]) + np.cross(tr, w)
                v += np.cross(w, p)
                jac[6 * ci:6 * ci + 3, ks] = (sgn[:, None] * w).T
                jac[6 * ci + 3:6 * ci + 6, ks] = (sgn[:, None] * v).T
        return c, jac

    def _project_gen(self, x, target, iters=8, tangent=None):
        return super()._project_gen(x, target, iters, None)  # every solve starts by evaluating at x


def _designs():
    return {"miura_3x3": load_design(ROOT / "templates" / "miura_3x3.toml"),
            "waterbomb": design_from_fold(cp.waterbomb()),
            "degree4": design_from_fold(cp.degree4())}


DESIGNS = _designs()


def _pair(design):
    frames, ids = hinge_frames(design), [h.id for h in design.hinges]
    return LoopSolver(frames, ids), Reference(frames, ids)


@pytest.mark.parametrize("name", sorted(DESIGNS))
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(0.0, 3.0))
def test_batched_residual_and_jacobian_equal_the_reference(name, seed, scale):
    fast, ref = _pair(DESIGNS[name])
    x = scale * np.random.default_rng(seed).uniform(-1, 1, fast.n)
    c0, j0 = ref.residual(x)
    c1, j1 = fast.residual(x)
    assert np.abs(c1 - c0).max() < 1e-12 * max(1.0, np.abs(c0).max())
    assert np.abs(j1 - j0).max() < 1e-12 * max(1.0, np.abs(j0).max())
    assert fast.residual(x, False)[1] is None and np.array_equal(fast.residual(x, False)[0], c1)


@pytest.mark.parametrize("name", sorted(DESIGNS))
def test_tracking_gives_the_reference_angles_closed_and_with_fewer_evaluations(name):
    d = DESIGNS[name]
    fast, ref = _pair(d)
    drive = HingeDrive(d)
    times = np.arange(0.0, min(float(d.process.duration_s), 6.0) + 1e-9, 0.01)
    driven = drive.driven(times)
    counts = {}
    sols = {}
    for key, solver in (("fast", fast), ("ref", ref)):
        n = [0]
        orig = solver.residual

        def counted(x, jacobian=True, _o=orig, _n=n):
            _n[0] += 1
            return _o(x, jacobian)

        solver.residual = counted
        sols[key] = solver.track(times, driven)
        counts[key] = n[0]
    a, b = sols["fast"], sols["ref"]
    assert np.abs(a.angles).max() > 0.5  # it folded
    assert np.abs(a.angles - b.angles).max() < ANGLE_TOL
    assert a.closure < CLOSURE_TOL and b.closure < CLOSURE_TOL
    assert max(fast.closure(x) for x in a.angles) < CLOSURE_TOL  # every grid answer closes
    assert a.locked_at == b.locked_at and a.dof == b.dof and a.stuck == b.stuck
    assert counts["fast"] < counts["ref"]


@pytest.mark.parametrize("name", ["miura_3x3", "waterbomb"])
def test_lockstep_tracking_of_many_drives_gives_each_drives_own_answer(name):
    """track_many (the Monte-Carlo's chunk, one array evaluation per round) against track
    of each drive alone: the same closed angles, stuck hinges, lock and residual."""
    from foldprint.simulation.robust import sample_drives
    from foldprint.simulation.scatter import default_scatter, draw_samples
    from foldprint.model.materials import default_library

    d = DESIGNS[name]
    fast, _ = _pair(d)
    drives = sample_drives(d, default_library(), draw_samples(d, default_scatter(), 5, 11))
    times = np.arange(0.0, 4.0 + 1e-9, 0.01)
    many = fast.track_many(times, [dr.driven(times) for dr in drives])
    for dr, got in zip(drives, many):
        alone = fast.track(times, dr.driven(times))
        assert np.abs(got.angles - alone.angles).max() < 1e-12
        assert (got.stuck, got.locked_at, got.dof) == (alone.stuck, alone.locked_at, alone.dof)
        assert abs(got.closure - alone.closure) < 1e-12 and got.closure < CLOSURE_TOL
