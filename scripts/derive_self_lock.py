"""Derive the holes of templates/self_lock.toml from the printed geometry's motion.

The paper (Mao 2015, Fig. 5) gives the strip's thicknesses, depth, hinge radius and
materials but not where the two holes are or how big they are. Our recipe: fold the
designed strip (H-2,H-2,H-3,H-6,H-6, arc hinges of the stated 5 mm radius: the printed
part) in the nominal bath with no holes and no collision check, record where the rigid
parts of the moving panels and the bent hinge strips pass through the plate's slab, and cut each such region out
of the plate as a rectangle with ``MARGIN`` mm all round. The script prints the holes
and the resulting fold (goals, first contact, smallest clearance).

Run: python scripts/derive_self_lock.py [--margin MM]
"""

from __future__ import annotations

import argparse
import numpy as np

from foldprint.clearance import min_clearance
from foldprint.collision3d import SweptChecker
from foldprint.kinematics import hinge_frames, hinge_map, simulate_kinematics
from foldprint.design_io import design_from_dict, design_to_dict
from foldprint.load import load_design
from foldprint.rigid import rigid_polygon
from foldprint.simulate import simulate


def footprint(design, margin: float, dt: float = 0.002):
    """Rectangles (x0, y0, x1, y1) in the plate's sheet frame where the rigid parts of
    the moving panels pass through the plate (its slab, within its outline)."""
    plate = design.panel_index()[design.root]
    half = design.panels[plate].thickness / 2
    px0, py0, px1, py1 = design.panels[plate].polygon.bounds
    traj = simulate_kinematics(design, dt=dt)
    xs = []
    for i, p in enumerate(design.panels):
        if i == plate:
            continue
        x0, y0, x1, y1 = rigid_polygon(design, i, "arc").bounds
        gx, gy = np.meshgrid(np.linspace(x0, x1, 60), np.linspace(y0, y1, 13))
        local = np.concatenate([np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z), np.ones(gx.size)])
                                for z in (-p.thickness / 2, 0.0, p.thickness / 2)])
        rel = np.linalg.inv(traj.poses[:, plate]) @ traj.poses[:, i]  # (n_t, 4, 4)
        w = np.einsum("tij,mj->tmi", rel, local)[..., :3]
        hit = ((np.abs(w[..., 2]) <= half + margin) & (w[..., 0] >= px0) & (w[..., 0] <= px1)
               & (w[..., 1] >= py0) & (w[..., 1] <= py1))
        xs.append(w[hit][:, :2])
    # the printed hinge strips move through the plate too: sample each strip across its
    # width (fractions of the arc), along the fold line and through its thickness
    frac = np.linspace(0.0, 1.0, 21)
    for f in hinge_frames(design):
        if plate in (f.parent, f.child):
            continue
        a, b = f.hinge.line
        along = np.linspace(0.0, 1.0, 13)
        start = np.column_stack([a[0] + (b[0] - a[0]) * along, a[1] + (b[1] - a[1]) * along])
        start = start - 0.5 * f.width * f.normal[:2]
        t_h = f.hinge.thickness
        maps = hinge_map(f, np.repeat(traj.angles[:, f.index], len(frac)), "arc", np.tile(frac, len(traj.times)))
        maps = maps.reshape(len(traj.times), len(frac), 4, 4)
        world = np.linalg.inv(traj.poses[:, plate])[:, None] @ traj.poses[:, f.parent][:, None] @ maps
        for k, s_ in enumerate(frac):
            for z in (-t_h / 2, 0.0, t_h / 2):
                local = np.column_stack([start + s_ * f.width * f.normal[:2], np.full(len(start), z),
                                         np.ones(len(start))])
                w = np.einsum("tij,mj->tmi", world[:, k], local)[..., :3]
                hit = ((np.abs(w[..., 2]) <= half + margin) & (w[..., 0] >= px0) & (w[..., 0] <= px1)
                       & (w[..., 1] >= py0) & (w[..., 1] <= py1))
                xs.append(w[hit][:, :2])
    xy = np.concatenate(xs)
    xy = xy[np.argsort(xy[:, 0])]
    gaps = np.nonzero(np.diff(xy[:, 0]) > 2 * margin + 1.0)[0]
    return [(part[:, 0].min() - margin, part[:, 1].min() - margin, part[:, 0].max() + margin,
             part[:, 1].max() + margin) for part in np.split(xy, gaps + 1)]


def with_holes(design, holes):
    data = design_to_dict(design)
    for p in data["panels"]:
        if p["id"] == design.root:
            p["holes"] = holes
            if not holes:
                p.pop("holes")
    if not holes:
        data.pop("goals", None)
    return design_from_dict(data, "derived self_lock")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--margin", type=float, default=1.0, help="clearance around the swept region (mm)")
    args = ap.parse_args(argv)
    d = load_design("templates/self_lock.toml")
    plate = d.panel(d.root)
    rects = footprint(with_holes(d, []), args.margin)
    holes = [[[round(float(x0), 1), round(float(y0), 1)], [round(float(x1), 1), round(float(y0), 1)],
              [round(float(x1), 1), round(float(y1), 1)], [round(float(x0), 1), round(float(y1), 1)]]
             for x0, y0, x1, y1 in rects]
    print("plate outline:", plate.outline.tolist())
    print("holes =", holes)
    designed = with_holes(d, holes)
    r = simulate(designed, method="fcl")
    gap = min_clearance(SweptChecker(designed, "arc", None), r.trajectory.times, r.trajectory.poses)
    print("completed:", r.completed, "first contact:", r.first_collision and (r.first_collision.panels, r.first_collision.time))
    print("goals:", [(g.goal.id, g.met, g.time) for g in r.goals])
    print("smallest clearance:", gap and (round(gap.distance, 3), gap.panels, gap.time))


if __name__ == "__main__":
    main()
