"""Benchmark: the swept 3D check and the vectorised 2D index against the baselines a user
would write, measured in the same run.

    python benchmarks/bench_simulation.py [--json] [--repeat 3] [--no-scaling]

* ``ratio_3d_vs_discrete``: per template, hinge model (arc: the printed part, primary;
  point: the paper's ROM) and dt (10 ms, 1 ms): the swept check (build + broad + narrow
  phase) against trimesh ``CollisionManager.in_collision_internal`` at every time step
  (same trajectory, same rigid panel solids, stopping at its first contact), and the
  contacts each found. Target: >= 20x at dt 1 ms, >= 1x at dt 10 ms, every
  contact the baseline finds found at a time no later.
* ``ratio_2d_vs_loop``: the paper's index for every pair and step against a plain-Python
  loop over pairs and steps on Python floats (Eq. 5-6 written literally), with a check that
  both give bit-identical S_ij and contact flags. Target: >= 50x.
* ``scaling``: wall time and peak memory (max RSS of a fresh process) of simulate + 3D check
  (``method="fcl"``, arc hinges) for 100- and 1000-panel strips (10 mm panels, +-30 deg
  alternating, all H-3), and their ratio. Target: 1000 panels < 60 s, <= 15x the
  100-panel time, < 2 GB.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from foldprint.collision.index2d import collision_index, world_side_segments
from foldprint.collision.broadphase import non_adjacent_pairs
from foldprint.collision.swept3d import SweptChecker
from foldprint.collision.swept_search import swept_first_contact
from foldprint.physics.hinge_drive import HingeDrive, simulate_kinematics
from foldprint.io.load import load_design
from foldprint.collision.rigid import rigid_polygons

ROOT = Path(__file__).resolve().parent.parent
TEMPLATES = ROOT / "templates"


def best_of(fn, repeat):
    best, out = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


# -- 3D ----------------------------------------------------------------------------------

def discrete_trimesh(design, traj):
    """Baseline: trimesh's CollisionManager (FCL broad + narrow phase) at every time step
    of the trajectory, the same rigid panel solids; stops at the first step where a
    non-adjacent pair touches. Returns (time, sorted pair ids at that step) or None."""
    cm = trimesh.collision.CollisionManager()
    for p, poly in zip(design.panels, rigid_polygons(design, traj.model)):
        m = trimesh.creation.extrude_polygon(poly, p.thickness)
        m.apply_translation([0, 0, -p.thickness / 2])
        cm.add_object(p.id, m)
    allowed = {frozenset((design.panels[i].id, design.panels[j].id)) for i, j in non_adjacent_pairs(design)}
    for k, t in enumerate(traj.times):
        for i, p in enumerate(design.panels):
            cm.set_transform(p.id, traj.poses[k, i])
        hit, names = cm.in_collision_internal(return_names=True)
        names = sorted(tuple(sorted(n)) for n in names if frozenset(n) in allowed)
        if names:
            return float(t), names
    return None


def swept(design, traj):
    checker = SweptChecker(design, traj.model, HingeDrive(design))
    c, _ = swept_first_contact(checker, traj.times, traj.angles, traj.poses)
    return c


def bench_3d(repeat):
    rows = []
    for name in ("helix_uniform", "helix_graded"):
        d = load_design(TEMPLATES / f"{name}.toml")
        for model in ("arc", "point"):
            for dt in (0.01, 0.001):
                traj = simulate_kinematics(d, dt=dt, model=model)
                swept(d, traj)  # warm caches (rigid polygons, recovery curves) for both
                ts, c = best_of(lambda: swept(d, traj), repeat)
                td, disc = best_of(lambda: discrete_trimesh(d, traj), repeat if dt >= 0.005 else 1)
                sw = None if c is None else {"pair": sorted(c.panels), "time": round(c.time, 4)}
                ds = None if disc is None else {"pairs": [list(p) for p in disc[1]], "time": round(disc[0], 4)}
                # every contact the baseline finds, found no later (the first contact decides)
                ok = disc is None or (c is not None and c.time <= disc[0] + 1e-9)
                rows.append({"template": name, "hinge_model": model, "dt_s": dt,
                             "swept_ms": round(ts * 1e3, 2), "discrete_ms": round(td * 1e3, 2),
                             "ratio": round(td / ts, 2), "contact_swept": sw, "contact_discrete": ds,
                             "swept_finds_baseline_contacts_no_later": ok})
    return rows


# -- 2D ----------------------------------------------------------------------------------

def index_loop(design, traj):
    """Baseline: the paper's Eq. 5-6 pair by pair, step by step, on Python floats.
    Returns S_ij (n_t, n_pairs) as nested lists and the contact flags."""
    segs = [s.tolist() for s in world_side_segments(design, traj.poses, traj.model)]
    n = len(design.panels)
    n_t = len(traj.times)
    s_out, c_out = [], []
    for k in range(n_t):
        srow, crow = [], []
        for i in range(n):
            for j in range(i + 1, n):
                best, best_d, hit = math.nan, math.inf, False
                for (p1, p2) in segs[i][k]:
                    for (q1, q2) in segs[j][k]:
                        dpx, dpy = p2[0] - p1[0], p2[1] - p1[1]
                        dqx, dqy = q2[0] - q1[0], q2[1] - q1[1]
                        rx, ry = q1[0] - p1[0], q1[1] - p1[1]
                        denom = dpx * dqy - dpy * dqx
                        lp = math.sqrt(dpx * dpx + dpy * dpy)
                        lq = math.sqrt(dqx * dqx + dqy * dqy)
                        if abs(denom) <= 1e-9 * max(lp * lq, 1e-12):  # parallel: no C_ij
                            lp = max(lp, 1e-12)
                            off = abs(rx * dpy - ry * dpx) / lp
                            if off <= 1e-9 * max(lp, 1.0):  # collinear: 1-D overlap
                                ux, uy = dpx / lp, dpy / lp
                                b0 = rx * ux + ry * uy
                                b1 = (q2[0] - p1[0]) * ux + (q2[1] - p1[1]) * uy
                                if min(lp, max(b0, b1)) - max(0.0, min(b0, b1)) > 1e-9:
                                    hit = True
                            continue
                        s_i = (rx * dqy - ry * dqx) / denom  # Eq. 5: C_ij along panel i
                        s_j = (rx * dpy - ry * dpx) / denom  # and along panel j
                        s = s_i * s_j  # Eq. 6
                        if (0 < s < 1 and not (0 < s_i < 1 and s_j > 1)
                                and not (0 < s_j < 1 and s_i > 1) and not (s_i < 0 and s_j < 0)):
                            hit = True
                        if abs(s - 0.5) < best_d:
                            best, best_d = s, abs(s - 0.5)
                srow.append(best)
                crow.append(hit)
        s_out.append(srow)
        c_out.append(crow)
    return s_out, c_out


def bench_2d(repeat):
    rows = []
    for name in ("helix_uniform", "helix_graded", "self_lock"):
        d = load_design(TEMPLATES / f"{name}.toml")
        traj = simulate_kinematics(d, dt=0.01, model="arc")
        tv, idx = best_of(lambda: collision_index(traj), repeat)
        tl, (s_loop, c_loop) = best_of(lambda: index_loop(d, traj), 1)
        s_loop = np.array(s_loop, dtype=float).reshape(idx.s_ij.shape)
        same = bool(np.array_equal(s_loop, idx.s_ij, equal_nan=True)
                    and np.array_equal(np.array(c_loop, dtype=bool).reshape(idx.contact.shape), idx.contact))
        rows.append({"template": name, "hinge_model": "arc", "dt_s": 0.01, "steps": len(traj.times),
                     "pairs": int(len(idx.pairs)), "vectorised_ms": round(tv * 1e3, 2),
                     "loop_ms": round(tl * 1e3, 1), "ratio": round(tl / tv, 1), "bit_identical": same})
    return rows


# -- scaling -----------------------------------------------------------------------------

_CHILD = r"""
import json, resource, sys, time
from foldprint.model.design import strip
from foldprint.simulation.simulate import simulate
n = int(sys.argv[1])
d = strip(f"strip{n}", [10.0] * n, [30.0 if k % 2 == 0 else -30.0 for k in range(n - 1)], ["H-3"] * (n - 1))
t0 = time.perf_counter()
r = simulate(d, method="fcl", hinge_model="arc")
wall = time.perf_counter() - t0
c = r.first_collision
print(json.dumps({"panels": n, "wall_s": round(wall, 3),
                  "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
                  "contact": None if c is None else [list(c.panels), round(c.time, 4)]}))
"""


def bench_scaling(sizes=(100, 1000)):
    out = {}
    env = dict(__import__("os").environ)
    env["PYTHONPATH"] = str(ROOT) + (":" + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    for n in sizes:
        p = subprocess.run([sys.executable, "-c", _CHILD, str(n)], capture_output=True, text=True, env=env,
                           timeout=1800)
        if p.returncode != 0:
            out[str(n)] = {"error": p.stderr.strip().splitlines()[-1] if p.stderr else "failed"}
            continue
        out[str(n)] = json.loads(p.stdout.strip().splitlines()[-1])
    a, b = out.get(str(sizes[0]), {}), out.get(str(sizes[-1]), {})
    if "wall_s" in a and "wall_s" in b:
        out["time_ratio"] = round(b["wall_s"] / a["wall_s"], 2)
    out["what"] = ("simulate(method='fcl', hinge_model='arc'): kinematics + swept check, 10 mm panels, "
                   "+-30 deg alternating, all H-3, dt 10 ms, 20 s; peak memory = max RSS of a fresh process")
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    ap.add_argument("--no-scaling", action="store_true", help="skip the 100/1000-panel strips")
    ap.add_argument("--only-2d", action="store_true", help="run only the 2D index against its loop")
    args = ap.parse_args()
    res = {} if args.only_2d else {"ratio_3d_vs_discrete": bench_3d(args.repeat)}
    res["ratio_2d_vs_loop"] = bench_2d(args.repeat)
    if not (args.no_scaling or args.only_2d):
        res["scaling"] = bench_scaling()
    if args.json:
        print(json.dumps(res))
        return
    if "ratio_3d_vs_discrete" in res:
        print("3D: swept check vs trimesh CollisionManager every step (same trajectory)")
    for r in res.get("ratio_3d_vs_discrete", []):
        print(f"  {r['template']:<14}{r['hinge_model']:<6}dt {r['dt_s']:<6g}{r['swept_ms']:>9.1f} ms"
              f"{r['discrete_ms']:>10.1f} ms{r['ratio']:>8.1f}x  swept {r['contact_swept']} | "
              f"discrete {r['contact_discrete']}")
    print("2D index: vectorised vs plain-Python loop")
    for r in res["ratio_2d_vs_loop"]:
        print(f"  {r['template']:<14}{r['vectorised_ms']:>9.1f} ms{r['loop_ms']:>10.1f} ms{r['ratio']:>8.1f}x"
              f"  bit-identical {r['bit_identical']}")
    if "scaling" in res:
        print("scaling:", json.dumps(res["scaling"], indent=1))


if __name__ == "__main__":
    main()
