"""Curved hinge strips: poses of the printed states, the arc map across a strip, the
stepped profile, the sliced prism and its bending, slots."""

from __future__ import annotations

import math

import manifold3d as mf
import numpy as np

from ..model.derived import derived
from ..model.design import Design, Hinge, has_loops, tangent_factor
from ..core.errors import GeometryError
from ..core.modes import HingeModel, Interface, State
from ..physics.kinematics import HingeFrame, forward, hinge_frames, hinge_map
from ..physics.hinge_drive import loop_gap_mm
from .solids import (MAX_SLICE_RAD, STATES, TEETH_OVERLAP, checked_solid, solid_from_arrays, apply_pose)

# -- kinematics of the printed states ----------------------------------------------------

#: largest loop misfit (mm) taken as closed without a word: loop hinges turn about their
#: fold lines (``HingeFrame.centred``), so targets on the pattern's folding path close to
#: round-off (our choice: far below any printer's resolution, far above round-off)
LOOP_GAP_TOL_MM = 1e-6
#: decimals of a target angle (deg) read as the design's resolution: targets written with at
#: most this many decimals have a resolution of one unit of their last one (our choice:
#: crease-pattern editors write 1 to 4; more is a computed, exact angle)
MAX_ANGLE_DECIMALS = 4


def angle_resolution_deg(design: Design) -> float | None:
    """The resolution the design writes its target angles with: one unit of the last
    decimal its angles use (0.1 for angles such as 159.1 and 90, 0.01 for 159.06), or None
    when some angle has more than :data:`MAX_ANGLE_DECIMALS` decimals (an exact angle) or
    none has a decimal (a whole number of degrees states no precision: taken as exact)."""
    worst = 0
    for h in design.hinges:
        a = float(h.angle_deg)
        k = next((k for k in range(MAX_ANGLE_DECIMALS + 1)
                  if abs(a * 10 ** k - round(a * 10 ** k)) <= 1e-9 * max(1.0, abs(a) * 10 ** k)), None)
        if k is None:
            return None
        worst = max(worst, k)
    return 10.0 ** -worst if worst else None


def default_resolution_mm() -> float:
    """The default printer's resolution (its layer height, data/printers.toml): the
    tolerance of a build no printer profile was given for."""
    from ..model.printers import default_printer_key, load_printers

    return float(load_printers()[default_printer_key()].layer_mm)


def state_angles(design: Design, state: State, resolution_mm: float | None = None) -> np.ndarray:
    """Hinge angles (rad, ``design.hinges`` order) of a build state: the targets, or for a
    pattern with loops whose targets close them only to within the tolerance, the nearest
    closed angles (:func:`closed_targets`)."""
    return closed_targets(design, state, resolution_mm)[0]


def closed_targets(design: Design, state: State, resolution_mm: float | None = None) -> tuple[np.ndarray, str | None]:
    """The angles of a build state and a note when the targets were moved to close the loops.

    Rounded targets (a FOLD file's ``edges_foldAngle`` written to 0.01 deg) do not close a
    pattern's loops exactly: built as written, a loop hinge misses its panel by the misfit
    and its strip overlaps the panel. The build then takes the closed angles nearest to the
    targets (least squares on the closure constraints, :class:`LoopSolver`) when they are
    within the tolerance: they differ from the targets by at most the design's angle
    resolution (:func:`angle_resolution_deg`), or they move no point of the part by more than
    ``resolution_mm`` (the printer's layer; default :func:`default_resolution_mm`). Beyond
    it, GeometryError names the misfit and the change the closure needs."""
    if state not in STATES:
        raise GeometryError(f"state must be one of {STATES}, got {state!r}")
    if state == State.PROGRAMMED:
        return np.zeros(len(design.hinges)), None
    return derived(design, ("closed_targets", resolution_mm), lambda: _closed_targets(design, resolution_mm))


def _closed_targets(design: Design, resolution_mm: float | None) -> tuple[np.ndarray, str | None]:
    angles = np.array([h.angle for h in design.hinges], dtype=float)
    if not has_loops(design):
        return angles, None
    gap = loop_gap_mm(design, angles, HingeModel.ARC)
    if gap <= LOOP_GAP_TOL_MM:
        return angles, None
    res_mm = default_resolution_mm() if resolution_mm is None else float(resolution_mm)
    res_deg = angle_resolution_deg(design)
    closed, done = _nearest_closed(design, angles)
    change = np.degrees(np.abs(closed - angles))
    k = int(np.argmax(change))
    moved = _largest_move(design, angles, closed) if done else math.inf
    by_angle = res_deg is not None and done and change[k] <= res_deg * (1 + 1e-9)
    if done and (by_angle or moved <= res_mm):
        why = (f"the design's angle resolution {res_deg:g} deg" if by_angle
               else f"the printer's {res_mm:g} mm resolution")
        return closed, (f"the target angles close the loops of the hinge graph only to a {gap:.2g} mm misfit; "
                        f"the part is built at the nearest closed angles, which differ from the targets by at "
                        f"most {change[k]:.2g} deg (hinge {design.hinges[k].id!r}) and move no point more than "
                        f"{moved:.2g} mm: within {why}")
    needed = (f"the nearest closed angles differ from the targets by {change[k]:.3g} deg at hinge "
              f"{design.hinges[k].id!r} and move points up to {moved:.3g} mm" if done else
              "no closed configuration near the targets was found")
    tolerance = (f"the tolerance is the design's angle resolution {res_deg:g} deg or the printer's "
                 f"{res_mm:g} mm" if res_deg is not None else f"the tolerance is the printer's {res_mm:g} mm")
    raise GeometryError(
        f"{design.name}: the target angles do not close the loops of the hinge graph (rigid origami): "
        f"a {gap:.3g} mm misfit at a loop hinge in the folded state; {needed} ({tolerance}), so panels "
        "would overlap or gap; choose targets on the pattern's folding path (foldprint simulate reports the "
        "closed angles, hinges[].final_angle_deg; docs/loops.md); --state programmed builds the flat "
        "(programmed) shape")


def _nearest_closed(design: Design, angles: np.ndarray) -> tuple[np.ndarray, bool]:
    """The closed configuration nearest to ``angles`` (Gauss-Newton from them toward them)
    and whether the solve converged to closure."""
    from ..physics.loops.closure import CLOSURE_TOL, LoopSolver

    solver = LoopSolver(hinge_frames(design), [h.id for h in design.hinges])
    x, res, _, _ = solver.project(angles, angles)
    return x, bool(np.all(np.isfinite(x)) and res <= 1e3 * CLOSURE_TOL)


def _largest_move(design: Design, a: np.ndarray, b: np.ndarray) -> float:
    """The largest distance (mm) a panel corner moves between the tree poses of angles
    ``a`` and ``b`` (arc hinges), the root panel held."""
    poses = forward(design, np.stack([a, b]), HingeModel.ARC)
    move = 0.0
    for k, p in enumerate(design.panels):
        pts = np.column_stack([p.outline, np.zeros(len(p.outline)), np.ones(len(p.outline))])
        d = (poses[0, k] @ pts.T - poses[1, k] @ pts.T)[:3]
        move = max(move, float(np.linalg.norm(d, axis=0).max()))
    return move


def _local(frame: HingeFrame, rho: float) -> np.ndarray:
    """Child relative to parent: exactly the identity for a flat hinge."""
    if rho == 0.0:
        return np.eye(4)
    return hinge_map(frame, rho, HingeModel.ARC, 1.0)[0]


def tree_poses(design: Design, frames: list[HingeFrame], angles: np.ndarray) -> np.ndarray:
    """Each panel's pose, placed from the root outward along the spanning tree, whatever
    the order of ``frames`` (the layout lists them in hinge order: placing a child before
    its parent would leave the pose all zeros, an empty solid: the 8-crease waterbomb)."""
    poses = np.zeros((len(design.panels), 4, 4))
    root = design.panel_index()[design.root]
    poses[root] = np.eye(4)
    below: dict[int, list[HingeFrame]] = {}
    for f in frames:
        if f.tree:  # a hinge closing a loop does not place its child (docs/loops.md)
            below.setdefault(f.parent, []).append(f)
    todo, placed = [root], {root}
    while todo:
        parent = todo.pop()
        for f in below.get(parent, []):
            poses[f.child] = poses[parent] @ _local(f, float(angles[f.index]))
            placed.add(f.child)
            todo.append(f.child)
    if len(placed) != len(design.panels):
        missing = [design.panels[k].id for k in range(len(design.panels)) if k not in placed][:5]
        raise GeometryError(f"panels {missing} are not reached from the root {design.root!r} by the hinge tree")
    return poses


def arc_transform(frame: HingeFrame, rho: float, u: float) -> np.ndarray:
    """(4, 4) map of the strip line at width ``u`` (0 = parent edge, w = child edge) of
    a hinge bent to ``rho``: :func:`foldprint.physics.kinematics.hinge_map` at fraction u / w.
    u = 0 gives the identity, u = w the child transform."""
    if rho == 0.0 or u <= 0.0:
        return np.eye(4)
    return hinge_map(frame, rho, HingeModel.ARC, u / frame.width)[0]


# -- hinge strips ------------------------------------------------------------------------

def strip_profile(hinge: Hinge, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """Slice boundaries ``u`` (K+1,) across the strip width and the thickness of each
    slice (K,): uniform bend slices of <= 5 deg, split at the step edges of a stepped
    hinge (thin sections centred in each period, thick quarter-periods at both ends)."""
    w, t, st = hinge.width, hinge.thickness, hinge.style
    n_bend = max(1, math.ceil(abs(rho) / MAX_SLICE_RAD - 1e-9))
    cuts = list(np.linspace(0.0, w, n_bend + 1))
    thin: list[tuple[float, float]] = []
    if st.stepped and st.thin_mm < t:
        n_per = max(1, round(w / st.step_period_mm))
        period = w / n_per
        for i in range(n_per):
            thin.append((period * (i + 0.25), period * (i + 0.75)))
        edges = [e for pair in thin for e in pair]
        snap = 1e-4 * max(w, 1.0)
        cuts = [c for c in cuts if all(abs(c - e) > snap for e in edges)] + edges
    if st.interface == Interface.TRIANGULAR and w > 4 * TEETH_OVERLAP:
        # thin end slices where the teeth reach into the strip: their chords hug the arc
        snap = 1e-4 * max(w, 1.0)
        ends = [TEETH_OVERLAP, w - TEETH_OVERLAP]
        cuts = [c for c in cuts if all(abs(c - e) > snap for e in ends)] + ends
    u = np.unique(np.array(sorted(cuts)))
    u[0], u[-1] = 0.0, w
    mids = 0.5 * (u[:-1] + u[1:])
    thick = np.full(len(mids), float(t))
    for a, b in thin:
        thick[(mids > a) & (mids < b)] = float(st.thin_mm)
    return u, thick


def _prism(u: np.ndarray, thick: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A prism along v of the stepped (u, z) profile. Returns the profile points (P, 2),
    their column index into ``u`` and the faces (over 2P vertices: profile at v0, then
    at v1). Every triangle spans one slice only, so bending it slice by slice is exact
    at the slice boundaries."""
    k_n = len(thick)
    pts: list[tuple[float, float]] = []
    col: list[int] = []

    def add(j, z):
        pts.append((u[j], z))
        col.append(j)

    # counter-clockwise in (u, z): bottom to the right, up, top to the left, down
    add(0, -thick[0] / 2)
    for j in range(1, k_n):
        add(j, -thick[j - 1] / 2)
        if thick[j] != thick[j - 1]:
            add(j, -thick[j] / 2)
    add(k_n, -thick[k_n - 1] / 2)
    add(k_n, thick[k_n - 1] / 2)
    for j in range(k_n - 1, 0, -1):
        add(j, thick[j] / 2)
        if thick[j - 1] != thick[j]:
            add(j, thick[j - 1] / 2)
    add(0, thick[0] / 2)
    pts_a = np.array(pts)
    col_a = np.array(col)
    n_p = len(pts_a)
    a = np.arange(n_p)
    b = np.roll(a, -1)
    sides = np.concatenate([np.stack([a + n_p, b + n_p, b], 1), np.stack([a + n_p, b, a], 1)])
    columns: dict[int, list[int]] = {}
    for i in np.argsort(pts_a[:, 1], kind="stable"):
        columns.setdefault(int(col_a[i]), []).append(int(i))
    caps = []
    for k in range(k_n):  # caps: zip the two columns of each slice
        half = thick[k] / 2 + 1e-12
        left = [i for i in columns[k] if abs(pts_a[i, 1]) <= half]
        right = [i for i in columns[k + 1] if abs(pts_a[i, 1]) <= half]
        i = j = 0
        while i < len(left) - 1 or j < len(right) - 1:
            if j == len(right) - 1 or (i < len(left) - 1 and pts_a[left[i + 1], 1] <= pts_a[right[j + 1], 1]):
                caps.append((left[i], right[j], left[i + 1]))
                i += 1
            else:
                caps.append((left[i], right[j], right[j + 1]))
                j += 1
    caps_a = np.array(caps, dtype=np.int64)  # counter-clockwise in (u, z): the cap at v0
    faces = np.concatenate([sides, caps_a, caps_a[:, [0, 2, 1]] + n_p])  # then the cap at v1
    return pts_a, col_a, faces.astype(np.int64)


def strip_solids(hinge: Hinge, frame: HingeFrame, d: np.ndarray, p0: np.ndarray,
                 parent_pose: np.ndarray, rho: float,
                 segments: list[tuple[float, float]]) -> list[mf.Manifold]:
    """The bent strip of each segment [v0, v1] of a hinge, placed with the parent's pose."""
    u, thick = strip_profile(hinge, rho)
    pts, col, faces = _prism(u, thick)
    w = hinge.width
    n3 = frame.normal
    d3 = np.array([d[0], d[1], 0.0])
    base = np.array([p0[0], p0[1], 0.0])
    n_p = len(pts)
    # orientation: the prism is built in (u, v, z); the sheet frame (n, d, z) may mirror it
    if np.dot(np.cross(n3, d3), [0.0, 0.0, 1.0]) < 0:
        faces = faces[:, ::-1]
    last = len(u) - 1
    poses = []
    for j in range(len(u)):
        if j == last and rho != 0.0:
            local = _local(frame, rho)  # bit-identical to the child's pose
        else:
            local = arc_transform(frame, rho, float(u[j]))
        poses.append(parent_pose @ local)
    uu = np.concatenate([pts[:, 0], pts[:, 0]])
    zz = np.concatenate([pts[:, 1], pts[:, 1]])
    cc = np.concatenate([col, col])
    groups = [np.flatnonzero(cc == j) for j in range(len(u))]
    du = np.diff(u)
    dphi = np.abs(rho) * du / w
    sinc = np.where(dphi > 0, np.sin(dphi) / np.where(dphi > 0, dphi, 1.0), 1.0)
    # centred (loop) hinges: the printed arc is shorter than the flat strip
    shrink = float(tangent_factor(rho)) if frame.centred else 1.0
    area = float(np.sum(thick * du * shrink * sinc))
    radius = hinge.radius * shrink
    out = []
    for v0, v1 in segments:
        vv = np.concatenate([np.full(n_p, v0), np.full(n_p, v1)])
        flat = base + vv[:, None] * d3 + (uu - 0.5 * w)[:, None] * n3 + zz[:, None] * np.array([0, 0, 1.0])
        world = np.empty_like(flat)
        for pose, sel in zip(poses, groups):
            world[sel] = apply_pose(pose, flat[sel])
        what = f"hinge {hinge.id!r} strip [{v0:.3f}, {v1:.3f}] mm"
        solid = solid_from_arrays(world, faces, what)
        out.append(checked_solid(solid, what + f" (bend radius {radius:.3g} mm must exceed half the "
                            f"hinge thickness {hinge.thickness / 2:g} mm)", (v1 - v0) * area))
    return out


def hinge_segments(hinge: Hinge) -> list[tuple[float, float]]:
    """Intervals [v0, v1] (mm along the fold line from ``line[0]``) of hinge material:
    one, or several separated by slots when the hinge is longer than max_segment_mm."""
    length, st = hinge.length, hinge.style
    if st.max_segment_mm <= 0 or length <= st.max_segment_mm:
        return [(0.0, length)]
    n = math.ceil((length + st.slot_width_mm) / (st.max_segment_mm + st.slot_width_mm) - 1e-9)
    n = max(n, 2)
    seg = (length - (n - 1) * st.slot_width_mm) / n
    if seg <= 0:
        raise GeometryError(f"hinge {hinge.id!r}: slots of {st.slot_width_mm:g} mm leave no material "
                            f"on a {length:g} mm hinge; reduce slot_width_mm or raise max_segment_mm")
    return [(i * (seg + st.slot_width_mm), i * (seg + st.slot_width_mm) + seg) for i in range(n)]
