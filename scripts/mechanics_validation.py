"""The validation figures of docs/mechanics.md, regenerated: the bar-and-hinge model against
the rigid model, closed forms and its own sensitivity to the hinge modulus's load time.

    PYTHONPATH=. python scripts/mechanics_validation.py [--json docs/data/mechanics_validation.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math

import numpy as np

from foldprint.io.fold_format import design_from_fold
from foldprint.io.load import load_design
from foldprint.model import crease_patterns as cp
from foldprint.model.design import Design, Hinge, Panel, strip
from foldprint.physics.barhinge import equilibrium as bs
from foldprint.physics.barhinge.model import diagonal_curvatures, kresling, kresling_heights
from foldprint.physics.hinge_drive import HingeDrive, run_times
from foldprint.physics.barhinge.stiffness import default_params

STIFF = 1e5


def rigid_comparison(d: Design, modulus=STIFF) -> dict:
    sol = bs.CompliantDrive(d, panel_modulus_mpa=modulus).solve(run_times(d, 0.01))
    ca, ra = sol.grid_angles, HingeDrive(d).angles(sol.grid)
    target = np.abs([h.angle for h in d.hinges])
    return {"max_error_share_of_target": float((np.abs(ca - ra) / target).max()),
            "max_error_deg": float(np.degrees(np.abs(ca - ra).max())),
            "final_error_deg": float(np.degrees(np.abs(ca[-1] - ra[-1]).max())),
            "max_panel_strain": sol.max_strain, "max_bending_deg": float(np.degrees(sol.max_bending)),
            "solved_steps": len(sol.grid), "newton_iterations": sol.iterations}


def two_hinge_loop(load_time_s: float | None = None) -> dict:
    a = Panel("a", [[0, 0], [20, 0], [20, 20], [0, 20]], 0.8, "VeroWhite")
    b = Panel("b", [[20, 0], [40, 0], [40, 20], [20, 20]], 0.8, "VeroWhite")
    r = math.radians(90)
    d = Design("loop2", (a, b), (Hinge("h1", ("a", "b"), [[20, 0], [20, 8]], r, "H-1", 5.0, 0.8),
                                 Hinge("h2", ("a", "b"), [[20, 12], [20, 20]], r, "H-7", 5.0, 0.8)))
    p = default_params()
    if load_time_s is not None:
        p = dataclasses.replace(p, hinge=dataclasses.replace(p.hinge, load_time_s=load_time_s))
    sol = bs.CompliantDrive(d, params=p, panel_modulus_mpa=STIFF).solve(run_times(d, 0.01))
    k, rest, ang = sol.stiffness, sol.rest, sol.grid_angles
    balance = (k[:, 0] * rest[:, 0] + k[:, 1] * rest[:, 1]) / k.sum(axis=1)
    rigid = HingeDrive(d).angles(sol.grid)[:, 0]
    i = int(np.argmax(np.abs(rest[:, 0] - rest[:, 1])))  # the two drives furthest apart
    return {"load_time_s": p.hinge.load_time_s, "max_balance_error_deg": float(np.degrees(np.abs(ang[:, 0] - balance).max())),
            "at_widest_gap": {"time_s": float(sol.grid[i]), "rest_H1_deg": float(np.degrees(rest[i, 0])),
                              "rest_H7_deg": float(np.degrees(rest[i, 1])), "k_H1": float(k[i, 0]),
                              "k_H7": float(k[i, 1]), "bar_hinge_deg": float(np.degrees(ang[i, 0])),
                              "rigid_least_squares_deg": float(np.degrees(rigid[i]))},
            "fold_time_98_s": _time_to(sol.grid, np.abs(ang[:, 0]), 0.98 * r)}


def _time_to(t, a, level):
    k = np.nonzero(a >= level)[0]
    return None if len(k) == 0 else float(t[k[0]])


def kresling_case(n=6, R=20.0, h1=35.0, phi1=math.radians(70), steps=121) -> dict:
    h2, phi2 = kresling_heights(n, R, h1, phi1)
    m = kresling(n, R, h1, phi1)
    zero = np.zeros(1)
    hs = np.linspace(h1, h2, steps)
    path = bs.displacement_path(m, 3 * np.arange(n, 2 * n) + 2, np.repeat(hs[:, None], n, axis=1), zero, zero)
    energy = [eq.energy for eq in path]
    x = path[-1].x
    energy = np.array(energy)
    k = int(np.argmax(energy))
    return {"n": n, "radius_mm": R, "h1_mm": h1, "twist1_deg": math.degrees(phi1),
            "h2_closed_form_mm": h2, "twist2_closed_form_deg": math.degrees(phi2),
            "energy_at_h1_mj": float(energy[0]), "energy_at_h2_mj": float(energy[-1]),
            "barrier_mj": float(energy[k]), "barrier_height_mm": float(hs[k]),
            "twist_at_h2_deg": math.degrees(math.atan2(x[n, 1], x[n, 0])) % 360.0}


def hypar_case() -> dict:
    out = {}
    for sign in (1, -1):
        d = design_from_fold(cp.hypar(4, 80.0, diagonal_deg=20.0 * sign, material="H-3"))
        sol = bs.CompliantDrive(d).solve(run_times(d, 0.01))
        a, b = diagonal_curvatures(sol.model.nodes, sol.x[-1])
        out["valley (+x,+y) diagonal" if sign > 0 else "mountain (+x,+y) diagonal"] = {
            "a_u2_per_mm": float(a), "b_v2_per_mm": float(b), "max_panel_strain": sol.max_strain,
            "max_bending_deg": float(np.degrees(sol.max_bending))}
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    miura = load_design("templates/miura_3x3.toml")
    out = {
        "strip_stiff_panels": rigid_comparison(strip("s", [10, 12, 10, 8], [90, -60, 120], ["H-1", "H-4", "H-7"])),
        "miura_stiff_panels": rigid_comparison(miura),
        "miura_paper_panels_1GPa": rigid_comparison(miura, default_params().panel_modulus_mpa),
        "cross_lock_uniform": rigid_comparison(load_design("templates/cross_lock_uniform.toml"),
                                               default_params().panel_modulus_mpa),
        "two_hinge_loop": [two_hinge_loop(w) for w in (0.1, None, 10.0)],
        "kresling": kresling_case(),
        "hypar": hypar_case(),
    }
    text = json.dumps(out, indent=1)
    print(text)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
