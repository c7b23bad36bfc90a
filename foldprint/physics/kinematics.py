"""The reduced-order model (ROM): hinge angles from recovery curves, panel poses by
forward kinematics down the hinge tree.

Two hinge models (``docs/simulation.md``):

* ``point``: the paper's Eq. 2-4; a hinge of zero size rotates the child panel about
  the fold line.
* ``arc``: a hinge of flat width w = R |rho_target| centred on the fold line bends with
  uniform curvature, so the child panel also translates; the rigid part of each panel
  is its outline less a strip of w/2 along each of its hinges.

A pose maps a panel's flat-sheet coordinates (x, y, z) to world coordinates; the root
panel stays put. Everything is vectorised over time. The hinge angles over time (the
drive, ``simulate_kinematics``) are in :mod:`foldprint.physics.hinge_drive`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..model.derived import derived
from ..model.design import Design, Hinge, has_loops, spanning_tree, tangent_factor
from ..core.errors import DesignError
from ..core.jit import use_kernels
from .loops.closure import LoopSolution
from ..core.modes import DEFAULT_HINGE_MODEL, HingeModel

HINGE_MODELS = tuple(m.value for m in HingeModel)


@dataclass(frozen=True)
class HingeFrame:
    """Static data of one hinge in the sheet frame.

    ``origin`` (3,) a point on the fold line; ``axis`` (3,) unit rotation axis such that a
    positive angle lifts the child toward +z; ``normal`` (3,) unit in-plane direction from
    the fold line into the child panel; ``width`` the flat width w (mm).
    """

    hinge: Hinge
    index: int
    parent: int
    child: int
    origin: np.ndarray
    axis: np.ndarray
    normal: np.ndarray
    width: float
    tree: bool = True  # False: the hinge closes a loop; forward kinematics skips it
    #: the child turns about the fold line itself (hinge graphs with loops): the arc strip
    #: is the circular arc tangent to both panels (see :func:`hinge_map`)
    centred: bool = False


def hinge_frames(design: Design) -> list[HingeFrame]:
    """Every hinge with its axes: the spanning tree's hinges in tree order (root outward),
    then the hinges closing loops (``tree=False``, parent/child = ``hinge.panels``).
    Computed once per active derived-data cache (:mod:`foldprint.model.derived`)."""
    return list(derived(design, ("hinge_frames",), lambda: tuple(_hinge_frames(design))))


def _hinge_frames(design: Design) -> list[HingeFrame]:
    pidx = design.panel_index()
    hidx = {h.id: i for i, h in enumerate(design.hinges)}
    frames = []
    tree, loops = spanning_tree(design)
    centred = has_loops(design)  # the same test the strain check (FP130) uses
    for h, parent, child in [(h, a, b) for h, a, b in tree] + [(h, a, b) for h, a, b in loops]:
        a, b = h.line
        d = np.array([b[0] - a[0], b[1] - a[1], 0.0])
        d /= np.linalg.norm(d)
        n = np.array([-d[1], d[0], 0.0])
        centroid = design.panels[pidx[child]].polygon.centroid  # by index: panel(id) scans
        mid = 0.5 * (a + b)
        if (centroid.x - mid[0]) * n[0] + (centroid.y - mid[1]) * n[1] < 0:
            n = -n
        axis = np.array([n[1], -n[0], 0.0])  # n x e_z (np.cross costs 0.7 ms a call)
        frames.append(HingeFrame(h, hidx[h.id], pidx[parent], pidx[child],
                                 np.array([mid[0], mid[1], 0.0]), axis, n, h.width,
                                 len(frames) < len(tree), centred))
    return frames


_KERNELS = None


def kernels():
    """The compiled kernels of this subpackage's hot paths (:mod:`foldprint.physics.kinematics_kernels`),
    imported on first use and kept (the narrow phase asks for one pose after another: an
    import statement per call cost more than the kernel). Call only after
    :func:`~foldprint.core.jit.use_kernels` said yes."""
    global _KERNELS
    if _KERNELS is None:
        from . import kinematics_kernels

        _KERNELS = kinematics_kernels
    return _KERNELS


_EYE3 = np.eye(3)
_EYE4 = np.eye(4)
#: Working memory of :func:`forward` beside its result (bytes; our choice: 8 MiB, the whole
#: run at once for the templates, a few dozen times at once for a 1,500-panel sheet, so
#: the memory guard's estimate of a simulation (one pose array) still bounds it).
FORWARD_BLOCK_BYTES = 8 * 2 ** 20
_EZ = np.array([0.0, 0.0, 1.0])


def _rotation(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rodrigues: (n, 3, 3) rotations by ``angle`` (n,) about unit ``axis`` (3,)."""
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return _EYE3 + s * k + (1 - c) * (k @ k)


def _sinc_terms(angle: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin(a)/a and (1 - cos a)/a, stable at a = 0."""
    a = np.asarray(angle, float)
    small = np.abs(a) < 1e-6
    safe = np.where(small, 1.0, a)
    s = np.where(small, 1.0 - a**2 / 6.0, np.sin(safe) / safe)
    c = np.where(small, a / 2.0, (1.0 - np.cos(safe)) / safe)
    return s, c


def hinge_map(frame: HingeFrame, angle, model: HingeModel = DEFAULT_HINGE_MODEL, fraction=1.0) -> np.ndarray:
    """The one hinge map: (n, 4, 4) transforms, relative to the parent panel, of the hinge
    strip's line at ``fraction`` of its flat width (0 = the parent's edge, 1 = the
    child's edge) when the hinge is bent to ``angle`` (rad). ``angle`` and ``fraction``
    broadcast to (n,). ``fraction = 1`` is the child panel's transform.

    ``arc``: the strip bends with uniform curvature, so the line at width u = w s turns by
    rho s and sits at start + u sinc(rho s) n + u (1 - cos(rho s)) / (rho s) z, where start
    is the parent's edge of the strip. ``point``: a rotation about the fold line (every
    fraction is the fold line). Geometry (``foldprint.geometry``) and rendering build on
    this map, so the printed part and the simulated part move identically.

    ``arc`` on a ``centred`` frame (hinge graphs with loops, ``docs/loops.md``): the child
    turns about the fold line, as for ``point``, so the rigid-origami closure of the
    loops holds for the printed panels too; the strip is the circular arc tangent to both
    panels, of length w (rho/2)/tan(rho/2) (:func:`tangent_factor`) and radius
    R (rho/2)/tan(rho/2) at the target angle: it is printed shorter than its flat width and
    programming stretches it (``checks`` FP130 counts that strain).
    """
    angle, fraction = np.broadcast_arrays(np.atleast_1d(np.asarray(angle, float)),
                                          np.atleast_1d(np.asarray(fraction, float)))
    if str(model) not in HINGE_MODELS:
        raise DesignError(f"hinge model must be one of {HINGE_MODELS}, got {str(model)!r}")
    model = HingeModel(str(model))
    n = len(angle)
    out = np.zeros((n, 4, 4))
    out[:, 3, 3] = 1.0
    q = frame.origin
    if model == HingeModel.POINT:
        rot = _rotation(frame.axis, angle)
        out[:, :3, :3] = rot
        out[:, :3, 3] = q - rot @ q
        return out
    w = frame.width
    phi = angle * fraction
    rot = _rotation(frame.axis, phi)
    out[:, :3, :3] = rot
    start = q - 0.5 * w * frame.normal
    u = w * fraction
    arc = u * tangent_factor(angle) if frame.centred else u  # arc length to the line at u
    s, c = _sinc_terms(phi)
    tip = start[None] + (arc * s)[:, None] * frame.normal[None] + (arc * c)[:, None] * _EZ[None]
    line = start[None] + u[:, None] * frame.normal[None]
    out[:, :3, 3] = tip - np.einsum("nij,nj->ni", rot, line)
    return out


def local_transforms(frame: HingeFrame, angle: np.ndarray, model: HingeModel) -> np.ndarray:
    """(n, 4, 4) transforms of the child relative to the parent for hinge angles (n,):
    :func:`hinge_map` at the child's edge."""
    return hinge_map(frame, angle, model, 1.0)


def forward(design: Design, angles: np.ndarray, model: HingeModel = DEFAULT_HINGE_MODEL,
            frames: list[HingeFrame] | None = None, compiled: bool = False) -> np.ndarray:
    """Panel poses (n_t, n_panels, 4, 4) for hinge angles (n_t, n_hinges) in
    ``design.hinges`` order (rad): every tree hinge's child transform in one array pass
    (:meth:`TreeTransforms.local`), then one product per hinge root outward (the parent's
    pose times the child transform, exactly; :meth:`TreeTransforms.poses` takes the
    products by pointer doubling instead). ``compiled``: the simulation's and the
    Monte-Carlo's callers ask for the compiled kernel
    (:func:`~foldprint.physics.kinematics_kernels.chain_poses`, where
    :func:`~foldprint.core.jit.use_kernels`; the same poses to round-off); geometry,
    exports and renders keep this reference path."""
    angles = np.atleast_2d(np.asarray(angles, float))
    if frames is None:
        tt = derived(design, ("tree_transforms", str(model)), lambda: TreeTransforms(design, model))
    else:
        tt = TreeTransforms(design, model, frames)
    n_t, n_p = angles.shape[0], len(design.panels)
    root = design.panel_index()[design.root]
    if compiled and use_kernels():
        return tt.compiled_poses(angles, root, fill_eye=False)
    parent, child = tt.parent.tolist(), tt.child.tolist()
    poses = np.empty((n_t, n_p, 4, 4))
    # a block of times at a time: the working arrays (panel-major poses, the hinges'
    # transforms twice) stay within FORWARD_BLOCK_BYTES beside the result, whatever n_t
    step = max(1, FORWARD_BLOCK_BYTES // (128 * (n_p + 2 * len(child))))
    for k0 in range(0, n_t, step):
        k1 = min(n_t, k0 + step)
        block = np.zeros((n_p, k1 - k0, 4, 4))  # panel-major while built
        block[root] = _EYE4
        loc = tt.local(angles[k0:k1], hinge_major=True)
        for h, (p, c) in enumerate(zip(parent, child)):  # tree order: parents first
            np.matmul(block[p], loc[h], out=block[c])
        poses[k0:k1] = block.swapaxes(0, 1)
    return poses


class TreeTransforms:
    """Every tree hinge's child transform at once and the panel poses as prefix products
    along the tree (pointer doubling): world poses of all panels at a few times in
    O(log depth) batched products, instead of one 4x4 product per hinge and time
    (:func:`forward`) or per hinge on a pair's tree path (the swept check's old
    ``pair_poses``). Same map as :func:`hinge_map` at the child's edge."""

    def __init__(self, design: Design, model: HingeModel, frames: list[HingeFrame] | None = None):
        frames = [f for f in (frames if frames is not None else hinge_frames(design)) if f.tree]
        if str(model) not in HINGE_MODELS:
            raise DesignError(f"hinge model must be one of {HINGE_MODELS}, got {model!r}")
        self.model = HingeModel(str(model))
        n = len(design.panels)
        self.n = n
        self.root = int(np.setdiff1d(np.arange(n), [f.child for f in frames])[0]) if n else 0
        self.hinge = np.array([f.index for f in frames], dtype=np.int64)
        self.child = np.array([f.child for f in frames], dtype=np.int64)
        parent = np.arange(n)
        parent[self.child] = [f.parent for f in frames]
        self.parent = parent[self.child]  # each tree hinge's parent panel
        depth = np.zeros(n, dtype=np.int64)
        for f in frames:  # tree order: parents first
            depth[f.child] = depth[f.parent] + 1
        self.up = [parent]
        while (1 << len(self.up)) <= int(depth.max(initial=0)):
            self.up.append(self.up[-1][self.up[-1]])
        q = np.array([f.origin for f in frames]).reshape(-1, 3)
        ax = np.array([f.axis for f in frames]).reshape(-1, 3)
        nrm = np.array([f.normal for f in frames]).reshape(-1, 3)
        w = np.array([f.width for f in frames])
        self.q, self.nrm, self.w = q, nrm, w
        self.centred = np.array([f.centred for f in frames], dtype=bool)
        self.any_centred = bool(self.centred.any())
        k = np.zeros((len(frames), 3, 3))
        k[:, 0, 1], k[:, 0, 2], k[:, 1, 2] = -ax[:, 2], ax[:, 1], -ax[:, 0]
        k -= k.transpose(0, 2, 1)
        self.k, self.kk = k, k @ k
        self.start = q - 0.5 * w[:, None] * nrm
        self.line = self.start + w[:, None] * nrm

    def local(self, angles: np.ndarray, hinge_major: bool = False) -> np.ndarray:
        """(m, n_tree_hinges, 4, 4) child transforms for hinge angles (m, n_hinges), or
        (n_tree_hinges, m, 4, 4) with ``hinge_major`` (each hinge's transforms contiguous)."""
        a = np.atleast_2d(np.asarray(angles, float))[:, self.hinge].T  # (nh, m)
        nh, m = a.shape
        # computed as (nh, 4, 4, m): every entry a contiguous row over the times
        out = np.zeros((nh, 4, 4, m))
        out[:, 3, 3] = 1.0
        rot = out[:, :3, :3]
        rot[:] = _EYE3[None, :, :, None] + np.sin(a)[:, None, None] * self.k[..., None]
        rot += (1 - np.cos(a))[:, None, None] * self.kk[..., None]
        if self.model == HingeModel.POINT:  # q - rot @ q, by matmul as hinge_map takes it
            turned = np.ascontiguousarray(rot.transpose(0, 3, 1, 2)) @ self.q[:, None, :, None]
            out[:, :3, 3] = self.q[..., None] - turned[..., 0].transpose(0, 2, 1)
        else:
            # rot @ line as hinge_map's einsum takes it (the same sums in the same order)
            turned = rot[:, :, 0] * self.line[:, None, 0, None] + rot[:, :, 1] * self.line[:, None, 1, None] \
                + rot[:, :, 2] * self.line[:, None, 2, None]  # (nh, 3, m)
            arc = np.where(self.centred[:, None], self.w[:, None] * tangent_factor(a), self.w[:, None]) \
                if self.any_centred else self.w[:, None]
            s, c = _sinc_terms(a)
            tip = self.start[..., None] + (arc * s)[:, None] * self.nrm[..., None] + (arc * c)[:, None] * _EZ[:, None]
            out[:, :3, 3] = tip - turned
        out = np.ascontiguousarray(out.transpose(0, 3, 1, 2))
        return out if hinge_major else out.swapaxes(0, 1)

    def compiled_poses(self, angles: np.ndarray, root: int, fill_eye: bool = True) -> np.ndarray:
        """World poses (m, n_panels, 4, 4) by the compiled kernel
        (:mod:`foldprint.physics.kinematics_kernels`): one product per hinge root outward."""
        return kernels().chain_poses(np.ascontiguousarray(np.atleast_2d(np.asarray(angles, float))),
                                     *self.chain_tables(root), fill_eye)

    def chain_tables(self, root: int) -> tuple:
        """What the compiled ``chain_poses`` reads after the angles, the tree from ``root``
        outward (also the compiled narrow phase's kinematics, which makes its split times' poses)."""
        return (self.hinge, self.parent, self.child, int(root), self.n, self.k, self.kk, self.q, self.start,
                self.nrm, self.line, self.w, self.centred, self.model == HingeModel.POINT)

    def poses(self, angles: np.ndarray) -> np.ndarray:
        """World poses (m, n_panels, 4, 4) for hinge angles (m, n_hinges): prefix products
        root outward by pointer doubling (A <- A[ancestor] @ A, log2(depth) rounds); the
        compiled kernel's products down the tree where :func:`~foldprint.core.jit.use_kernels`
        (the same poses to round-off)."""
        if use_kernels():
            return self.compiled_poses(angles, self.root)
        loc = self.local(angles)
        A = np.empty((len(loc), self.n, 4, 4))
        A[:] = _EYE4
        A[:, self.child] = loc
        for up in self.up:
            A = A[:, up] @ A
        return A


def target_angles(design: Design) -> np.ndarray:
    """(n_hinges,) target fold angles (rad): the permanent, printed state."""
    return np.array([h.angle for h in design.hinges])


@dataclass(frozen=True, eq=False)
class Trajectory:
    """The ROM's answer: ``times`` (n_t,) s, ``ratios`` and ``angles`` (n_t, n_hinges)
    (recovery ratio, fold angle in rad), ``poses`` (n_t, n_panels, 4, 4)."""

    design: Design
    times: np.ndarray
    ratios: np.ndarray
    angles: np.ndarray
    poses: np.ndarray
    model: HingeModel
    bath_c: float
    fold_times: tuple[float | None, ...]  # per hinge, s (98 % recovery), None = does not fold
    onset_times: tuple[float | None, ...]
    loops: LoopSolution | None = None  # hinge graphs with loops: the closure solve's report


def transform_points(pose: np.ndarray, pts2d: np.ndarray, z: float = 0.0) -> np.ndarray:
    """Apply one (4, 4) pose to sheet points (n, 2) at height ``z``; returns (n, 3)."""
    pts = np.column_stack([pts2d, np.full(len(pts2d), z)])
    return pts @ pose[:3, :3].T + pose[:3, 3]
