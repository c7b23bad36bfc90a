"""Compiled kernel of :mod:`foldprint.physics.kinematics`: every panel's world pose, hinge
by hinge down the spanning tree, one time at a time.

The map is :class:`~foldprint.physics.kinematics.TreeTransforms`' (the child's edge of
:func:`~foldprint.physics.kinematics.hinge_map`): the rotation I + sin(rho) K + (1 - cos
rho) K^2 about the hinge axis; ``point``: the translation q - R q; ``arc``: the strip's
tip, start + u sinc(rho) n + u (1 - cos rho) / rho z (u the arc length: the flat width, or
for a ``centred`` frame the width times (rho/2) / tan(rho/2)), less R times the child's
edge line. The pose of a child is its parent's pose times that transform, as
:func:`~foldprint.physics.kinematics.forward` takes it; the products are summed in the same
order, the sines and cosines a vectorised polynomial within 1 ulp of libm (:func:`sincos`),
so the poses agree with the reference to round-off (measured up to 3.4e-13 mm on the templates'
100 mm helices, asserted below 1e-11 of the sheet's size in ``tests/test_kernels.py``).

Imported only after :func:`foldprint.core.jit.use_kernels` said yes.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.jit import njit


#: fdlibm's minimax polynomials of sin and cos on [-pi/4, pi/4] (k_sin.c, k_cos.c; Sun
#: Microsystems 1993, the kernels of glibc's and numpy's scalar sin and cos)
_S = (-1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04,
      2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10)
_C = (4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05,
      -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11)
#: 2/pi and pi/2 in three parts (fdlibm's e_rem_pio2.c: Cody and Waite's reduction)
_INV_PIO2 = 6.36619772367581382433e-01
_PIO2 = (1.57079632673412561417e+00, 6.07710050630396597660e-11, 2.02226624871116645580e-21)
#: angles (rad) past which the scalar libm takes over (the three-part reduction keeps
#: full precision to |k| ~ 2**20 quarter turns; fold angles are within a turn)
SINCOS_REDUCED = 1e5


@njit
def sincos(angles):  # pragma: no cover - compiled
    """sin(a) and 1 - cos(a) of every angle, (same shape each): one reduction by pi/2 and
    fdlibm's polynomials, branch-free, so the compiler vectorises the loop (libm's scalar
    sin and cos were half a pose's cost); within 1 ulp of libm (``tests/test_kernels.py``).
    Angles past :data:`SINCOS_REDUCED` or not finite go to libm."""
    x = np.ascontiguousarray(angles).reshape(-1)
    n = x.shape[0]
    s = np.empty(n)
    c1 = np.empty(n)
    s1, s2, s3, s4, s5, s6 = _S
    q1, q2, q3, q4, q5, q6 = _C
    p1, p2, p3 = _PIO2
    for i in range(n):
        v = x[i]
        k = np.floor(v * _INV_PIO2 + 0.5)
        r = ((v - k * p1) - k * p2) - k * p3
        z = r * r
        sn = r + (z * r) * (s1 + z * (s2 + z * (s3 + z * (s4 + z * (s5 + z * s6)))))
        cs = 1.0 - (0.5 * z - z * (z * (q1 + z * (q2 + z * (q3 + z * (q4 + z * (q5 + z * q6)))))))
        q = np.int64(k)
        odd = (q & 1) != 0
        sv = cs if odd else sn
        cv = sn if odd else cs
        s[i] = -sv if (q & 2) != 0 else sv
        c1[i] = 1.0 - (-cv if ((q + 1) & 2) != 0 else cv)
    for i in range(n):  # the rare angle the reduction does not hold: libm
        if not abs(x[i]) <= SINCOS_REDUCED:
            s[i] = math.sin(x[i])
            c1[i] = 1.0 - math.cos(x[i])
    return s.reshape(angles.shape), c1.reshape(angles.shape)


@njit
def chain_poses(angles, hinge, parent, child, root, n_panels, k, kk, q, start, nrm, line, w, centred, point,
                fill_eye):  # pragma: no cover - compiled
    """Poses (n_t, n_panels, 4, 4) for hinge angles (n_t, n_hinges): per tree hinge h (tree
    order, parents first) its ``hinge`` index, ``parent`` and ``child`` panel, its axis's
    cross-product matrix ``k`` (and ``kk`` = K^2), fold-line point ``q``, strip start,
    in-plane normal ``nrm``, child's edge ``line``, flat width ``w`` and whether it is
    ``centred``; ``point``: the point hinge model (else arc). Panels off the tree are
    the identity with ``fill_eye``, else 0 (as ``forward`` leaves them). The rotation and
    translation are held in scalars (registers), the bottom row written, not multiplied."""
    n_t = angles.shape[0]
    nh = hinge.shape[0]
    poses = np.empty((n_t, n_panels, 4, 4))
    sin_a, cos1_a = sincos(angles)
    on_tree = np.zeros(n_panels, np.bool_)
    on_tree[root] = True
    for h in range(nh):
        on_tree[child[h]] = True
    for t in range(n_t):
        P = poses[t]
        for p in range(n_panels):
            if not on_tree[p] or p == root:  # the root and panels off the tree
                d = 1.0 if (fill_eye or p == root) else 0.0
                for a in range(4):
                    for b in range(4):
                        P[p, a, b] = d if a == b else 0.0
        for h in range(nh):
            ang = angles[t, hinge[h]]
            s = sin_a[t, hinge[h]]
            c1 = cos1_a[t, hinge[h]]
            r00 = (1.0 + s * k[h, 0, 0]) + c1 * kk[h, 0, 0]
            r01 = (0.0 + s * k[h, 0, 1]) + c1 * kk[h, 0, 1]
            r02 = (0.0 + s * k[h, 0, 2]) + c1 * kk[h, 0, 2]
            r10 = (0.0 + s * k[h, 1, 0]) + c1 * kk[h, 1, 0]
            r11 = (1.0 + s * k[h, 1, 1]) + c1 * kk[h, 1, 1]
            r12 = (0.0 + s * k[h, 1, 2]) + c1 * kk[h, 1, 2]
            r20 = (0.0 + s * k[h, 2, 0]) + c1 * kk[h, 2, 0]
            r21 = (0.0 + s * k[h, 2, 1]) + c1 * kk[h, 2, 1]
            r22 = (1.0 + s * k[h, 2, 2]) + c1 * kk[h, 2, 2]
            if point:
                q0, q1, q2 = q[h, 0], q[h, 1], q[h, 2]
                t0 = q0 - (r00 * q0 + r01 * q1 + r02 * q2)
                t1 = q1 - (r10 * q0 + r11 * q1 + r12 * q2)
                t2 = q2 - (r20 * q0 + r21 * q1 + r22 * q2)
            else:
                if abs(ang) < 1e-6:
                    sc = 1.0 - ang ** 2 / 6.0
                    cc = ang / 2.0
                else:
                    sc = s / ang
                    cc = c1 / ang
                arc = w[h]
                if centred[h]:
                    half = 0.5 * abs(ang)
                    if half < 1e-6:
                        arc = w[h] * (1.0 - half ** 2 / 3.0)
                    else:
                        arc = w[h] * (half / math.tan(min(half, math.pi / 2 - 1e-12)))
                l0, l1, l2 = line[h, 0], line[h, 1], line[h, 2]
                t0 = (start[h, 0] + (arc * sc) * nrm[h, 0] + 0.0) - (r00 * l0 + r01 * l1 + r02 * l2)
                t1 = (start[h, 1] + (arc * sc) * nrm[h, 1] + 0.0) - (r10 * l0 + r11 * l1 + r12 * l2)
                t2 = (start[h, 2] + (arc * sc) * nrm[h, 2] + (arc * cc)) - (r20 * l0 + r21 * l1 + r22 * l2)
            pa, ch = parent[h], child[h]
            for a in range(3):
                p0, p1, p2 = P[pa, a, 0], P[pa, a, 1], P[pa, a, 2]
                P[ch, a, 0] = p0 * r00 + p1 * r10 + p2 * r20
                P[ch, a, 1] = p0 * r01 + p1 * r11 + p2 * r21
                P[ch, a, 2] = p0 * r02 + p1 * r12 + p2 * r22
                P[ch, a, 3] = p0 * t0 + p1 * t1 + p2 * t2 + P[pa, a, 3]
            P[ch, 3, 0] = 0.0
            P[ch, 3, 1] = 0.0
            P[ch, 3, 2] = 0.0
            P[ch, 3, 3] = 1.0
    return poses


@njit
def stacked_at(grid, stack, t):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.hinge_drive.HingeDrive._stacked` at one time per row: the
    columns of ``stack`` (n_grid, n) interpolated at times ``t`` (n_t,), 0 before 0; the
    same index (``searchsorted(side="right") - 1``, clipped: found by walking on from the
    previous time's where times rise, else by bisection), fraction and sums. Column by
    column: a sample's stack is hinge-major (its transposed rows), read in order."""
    n_t, n, ng = t.shape[0], stack.shape[1], grid.shape[0]
    out = np.empty((n_t, n))
    ks = np.empty(n_t, np.int64)
    fs = np.empty(n_t)
    g0, g1 = grid[0], grid[ng - 1]
    j, prev = 0, np.inf
    for r in range(n_t):
        tc = min(max(t[r], g0), g1)
        if not tc >= prev:  # bisection: the last grid index at or below tc
            lo, hi = 0, ng
            while lo < hi:
                mid = (lo + hi) // 2
                if grid[mid] <= tc:
                    lo = mid + 1
                else:
                    hi = mid
            j = lo - 1
        while j + 1 < ng and grid[j + 1] <= tc:
            j += 1
        prev = tc
        k = min(max(j, 0), ng - 2)
        ks[r] = k
        fs[r] = (tc - grid[k]) / (grid[k + 1] - grid[k])
    for c in range(n):
        for r in range(n_t):
            k = ks[r]
            a = stack[k, c]
            out[r, c] = 0.0 if t[r] < 0 else a + (stack[k + 1, c] - a) * fs[r]
    return out


@njit
def driven_at(grid, stack, t, target, fixity):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.hinge_drive.HingeDrive.driven` at one time ``t``, (1, n):
    target (1 - (1 - R) fixity), R the stacked curves at t (:func:`stacked_at`)."""
    tt = np.empty(1)
    tt[0] = t
    r = stacked_at(grid, stack, tt)
    for c in range(r.shape[1]):
        r[0, c] = target[c] * (1.0 - (1.0 - r[0, c]) * fixity[c])
    return r


@njit
def ratios_driven(grid, stack, t, target, fixity):  # pragma: no cover - compiled
    """(ratios, driven angles) at times ``t``: :func:`stacked_at` and target (1 - (1 - R)
    fixity) of each, in one pass (the same numbers as the two apart)."""
    r = stacked_at(grid, stack, t)
    a = np.empty_like(r)
    for i in range(r.shape[0]):
        for c in range(r.shape[1]):
            a[i, c] = target[c] * (1.0 - (1.0 - r[i, c]) * fixity[c])
    return r, a


@njit
def first_reach(values, level):  # pragma: no cover - compiled
    """Per column of ``values`` (n_rows, n): the first row whose value is >= ``level``, -1
    where none is (NaN never is)."""
    n = values.shape[1]
    idx = np.full(n, -1, np.int64)
    for c in range(n):
        for k in range(values.shape[0]):
            if values[k, c] >= level:
                idx[c] = k
                break
    return idx


@njit(inline=True)
def _cross(t0, t1, r0, r1, level):  # pragma: no cover - compiled
    """The time ``level`` is reached between (t0, r0) and (t1, r1), linear: t0 + (level -
    r0) / (r1 - r0) (t1 - t0), in that order."""
    return t0 + (level - r0) / (r1 - r0) * (t1 - t0)


@njit
def crossings(grid, stack, level):  # pragma: no cover - compiled
    """:meth:`foldprint.physics.recovery.curve.RecoveryCurve.time_to` of every column of
    ``stack`` (n_grid, n) on ``grid`` at ``level``: the first time its ratio reaches it,
    linear between that grid time and the one before, 0 at the first; NaN where it does
    not (the same index, test and sums)."""
    n = stack.shape[1]
    out = np.empty(n)
    first = first_reach(stack, level)  # column by column: a drive's stack is hinge-major
    for c in range(n):
        idx = max(first[c], 0)  # none reached: row 0, which the test below then refuses
        if stack[idx, c] < level:
            out[c] = np.nan
        elif idx == 0:
            out[c] = 0.0
        else:
            out[c] = _cross(grid[idx - 1], grid[idx], stack[idx - 1, c], stack[idx, c], level)
    return out


@njit
def level_steps(times, ratios, level):  # pragma: no cover - compiled
    """:func:`foldprint.simulation.simulate.level_crossings` of ``ratios`` (n_t, n) at
    ``times``: each column's first step at ``level`` (-1 where never) and its crossing
    time, linear between that step and the one before (``times[0]`` at the first step,
    NaN where never): the same test and, element by element, the same sums."""
    n = ratios.shape[1]
    first = first_reach(ratios, level)  # column by column (each early out)
    t = np.empty(n)
    for c in range(n):
        j = first[c]
        if j < 0:
            t[c] = np.nan
        elif j == 0:
            t[c] = times[0]
        else:
            t[c] = _cross(times[j - 1], times[j], ratios[j - 1, c], ratios[j, c], level)
    return first, t
