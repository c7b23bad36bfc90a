"""Benchmark: dense folds at 1000 panels, guards that bound what they claim, big
exports; every figure beside the baseline measured in the same run.

    python benchmarks/bench_scale.py [--json] [--quick]

* ``dense``: simulate + 3D check (``method="fcl"``, arc hinges, default guards, dt 10 ms,
  20 s) in a fresh process each, wall time and peak RSS, for a strip of 10 mm panels at
  +-30 deg and the +-90 deg staircase of 6 mm panels (depth 6, radius 3, 0.8 mm), 100 and
  1000 panels; ``ratio_1000_vs_100``. Targets: < 60 s, < 2 GB, no collision, <= 15x.
  Beside each, the guard's estimate (bytes, seconds before the narrow phase) and its
  ratio to the measurement.
* ``prefix_vs_per_pair``: world poses of every panel at one time by prefix products
  (``TreeTransforms``) against the old narrow-phase composition of the transforms along
  each pair's tree path (``pair_poses``), for 200 non-adjacent pairs of the 1000-panel
  staircase.
* ``swept_vs_trimesh``: the swept check (build + broad + narrow) against trimesh's
  ``CollisionManager.in_collision_internal`` at every time step, 100-panel staircase.
* ``guards``: how long a refusal takes (simulate --duration 1e9, robust --samples 1e9,
  an export over a 5 s budget) and that runs which finish are not refused.
* ``export``: build + export (3MF, PrusaSlicer 3MF, STL) of the 1000-panel strip and the
  100-hinge bench sheet, the guard's estimate against it; the bed report against the
  old probe-against-the-whole-part version on the 100-hinge sheet.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

_CHILD = r"""
import json, resource, sys, time
from foldprint.model.design import strip
from foldprint.simulation import costs
from foldprint.simulation.simulate import simulate
kind, n = sys.argv[1], int(sys.argv[2])
if kind == "staircase":
    d = strip(f"stairs{n}", [6.0] * n, [90.0 if i % 2 == 0 else -90.0 for i in range(n - 1)], ["H-3"] * (n - 1),
              depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)
else:
    d = strip(f"strip{n}", [10.0] * n, [30.0 if i % 2 == 0 else -30.0 for i in range(n - 1)], ["H-3"] * (n - 1))
est = costs.check_simulation(d, 0.01, None, "fcl")
t0 = time.perf_counter()
r = simulate(d, method="fcl")
wall = time.perf_counter() - t0
print(json.dumps({"kind": kind, "panels": n, "wall_s": wall,
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "contacts": len(r.contacts), "completed": bool(r.completed),
                  "estimate_mb": est["bytes"] / 2 ** 20, "estimate_s": est["seconds"]}))
"""


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env


def dense(sizes=(100, 1000)):
    rows = []
    for kind in ("strip30", "staircase"):
        for n in sizes:
            p = subprocess.run([sys.executable, "-c", _CHILD, kind, str(n)], capture_output=True, text=True,
                               env=_env(), timeout=900)
            if p.returncode != 0:
                rows.append({"kind": kind, "panels": n, "error": p.stderr.strip().splitlines()[-1:]})
                continue
            r = json.loads(p.stdout.strip().splitlines()[-1])
            r["estimate_vs_measured_memory"] = round(r["estimate_mb"] / r["peak_rss_mb"], 2)
            r["estimate_vs_measured_time"] = round(r["estimate_s"] / r["wall_s"], 2)
            rows.append({k: (round(v, 3) if isinstance(v, float) else v) for k, v in r.items()})
    out = {"runs": rows}
    for kind in ("strip30", "staircase"):
        t = {r["panels"]: r.get("wall_s") for r in rows if r["kind"] == kind}
        if t.get(100) and t.get(1000):
            out[f"{kind}_ratio_1000_vs_100"] = round(t[1000] / t[100], 2)
    return out


def _staircase(n):
    from foldprint.model.design import strip

    return strip(f"stairs{n}", [6.0] * n, [90.0 if i % 2 == 0 else -90.0 for i in range(n - 1)],
                 ["H-3"] * (n - 1), depth=6.0, radius=3.0, thickness=0.8, hinge_thickness=0.8)


def prefix_vs_per_pair(n=1000, pairs=200, repeat=3):
    """Baseline: compose the hinge transforms along each pair's tree path (per pair, what a
    straightforward narrow phase does). New: every panel's world pose once (prefix products)."""
    from foldprint.collision.broadphase import non_adjacent_pairs
    from foldprint.physics.kinematics import TreeTransforms, hinge_frames, local_transforms
    from foldprint.physics.hinge_drive import HingeDrive
    from foldprint.physics.motion import tree_bounds

    d = _staircase(n)
    drive = HingeDrive(d)
    ang = drive.angles([2.0])
    frames = hinge_frames(d)
    frame_of = {f.index: f for f in frames}
    tb = tree_bounds(d, "arc", [f for f in frames if f.tree])
    rng = np.random.default_rng(0)
    allp = non_adjacent_pairs(d)
    chosen = [allp[k] for k in rng.choice(len(allp), pairs, replace=False)]
    paths = [tb.path(i, j)[:2] for i, j in chosen]

    def old():
        out = []
        for up_i, down_j in paths:
            def chain(hinges):
                T = np.eye(4)[None]
                for h in hinges:
                    T = T @ local_transforms(frame_of[h], ang[:, h], "arc")
                return T
            out.append((chain(up_i[::-1]), chain(down_j)))
        return out

    tt = TreeTransforms(d, "arc", frames)

    def new():
        w = tt.poses(ang)[0]
        return [(w[i], w[j]) for i, j in chosen]

    t_old = min(_timed(old) for _ in range(1))
    t_new = min(_timed(new) for _ in range(repeat))
    # the two agree on every pair's relative pose
    a, b = old(), new()
    err = max(float(np.abs(np.linalg.solve(pi[0], pj[0]) - np.linalg.solve(qi, qj)).max())
              for (pi, pj), (qi, qj) in zip(a, b))
    mean_path = float(np.mean([len(u) + len(v) for u, v in paths]))
    return {"panels": n, "pairs": pairs, "mean_path_hinges": round(mean_path, 1),
            "per_pair_ms": round(t_old * 1e3, 2), "prefix_ms": round(t_new * 1e3, 3),
            "ratio": round(t_old / t_new, 1), "max_relative_pose_difference": err}


def _timed(fn):
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def swept_vs_trimesh(n=100):
    from bench_simulation import discrete_trimesh, swept
    from foldprint.physics.hinge_drive import simulate_kinematics

    d = _staircase(n)
    traj = simulate_kinematics(d, model="arc")
    ts = _timed(lambda: swept(d, traj))
    c = swept(d, traj)
    td = _timed(lambda: discrete_trimesh(d, traj))
    disc = discrete_trimesh(d, traj)
    return {"panels": n, "steps": len(traj.times), "swept_s": round(ts, 3), "trimesh_every_step_s": round(td, 2),
            "ratio": round(td / ts, 1), "contact_swept": None if c is None else sorted(c.panels),
            "contact_trimesh": None if disc is None else disc[1]}


def _cli(args, env_extra=None):
    env = _env()
    env.update(env_extra or {})
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "foldprint", *args], capture_output=True, text=True, env=env,
                       timeout=900)
    return {"args": " ".join(args), "exit": p.returncode, "wall_s": round(time.perf_counter() - t0, 2),
            "stderr": p.stderr.strip()[-300:]}


def guards_bench(tmp: Path):
    strip1000 = tmp / "strip1000.toml"
    n = 1000
    strip1000.write_text(f'schema = 1\nname = "strip1000"\n[strip]\nlengths_mm = {[10] * n}\n'
                         f'angles_deg = {[30 if i % 2 == 0 else -30 for i in range(n - 1)]}\n'
                         f'materials = {json.dumps(["H-3"] * (n - 1))}\n')
    rows = [
        _cli(["simulate", "helix_graded", "--duration", "1e9", "--json"]),
        _cli(["robust", "helix_graded", "--samples", "1000000000", "--json"]),
        _cli(["export", str(strip1000), "--out", str(tmp / "o_refused"), "--json"],
             {"FOLDPRINT_TIME_BUDGET": "5"}),
        _cli(["simulate", str(strip1000), "--method", "fcl", "--json"]),
    ]
    return rows, strip1000


def export_bench(strip1000: Path, tmp: Path):
    from bench_export import sheet
    from foldprint.geometry.build_cost import check_export
    from foldprint.exchange.export import export_assembly
    from foldprint.geometry import build_assembly
    from foldprint.geometry import bed as asm_mod  # bed_report and its probe
    from foldprint.io.load import load_design
    from foldprint.physics.recovery.curve import hinge_fold_times

    rows = []
    for d in (sheet(100), load_design(strip1000)):
        est = check_export(d)
        t0 = time.perf_counter()
        asm = build_assembly(d, "permanent")
        t1 = time.perf_counter()
        with tempfile.TemporaryDirectory() as out:
            export_assembly(d, asm, out, ["3mf", "prusa3mf", "stl"], fold_times=hinge_fold_times(d))
        t2 = time.perf_counter()
        rows.append({"design": d.name, "panels": len(d.panels), "features": est["features"],
                     "build_s": round(t1 - t0, 2), "export_s": round(t2 - t1, 2),
                     "estimate_s": round(est["seconds"], 2),
                     "estimate_vs_measured_time": round(est["seconds"] / (t2 - t0), 2)})
    # bed report: each probe against the whole part (before) vs against the units it meets
    import manifold3d as mf

    asm = build_assembly(sheet(100), "permanent")

    def whole_part():
        solids = [b.solid for b in asm.bodies]
        part = mf.Manifold.batch_boolean(solids, mf.OpType.Add)
        areas = []
        for u in asm.units:
            mesh = u.solid.to_mesh64()
            v = np.asarray(mesh.vert_properties)[:, :3]
            tri = v[np.asarray(mesh.tri_verts, dtype=np.int64)]
            nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
            a2 = np.linalg.norm(nrm, axis=1)
            sel = (nrm[:, 2] < -np.cos(asm_mod.BOTTOM_FACE_RAD) * a2) & (
                tri[:, :, 2].min(axis=1) + float(asm.print_offset[2]) > asm_mod.BED_TOL)
            area = float(0.5 * a2[sel].sum())
            if area > 0:
                area = max(0.0, area - (asm_mod._prisms(tri[sel], asm_mod.SUPPORT_PROBE_MM) ^ part).volume()
                           / asm_mod.SUPPORT_PROBE_MM)
            areas.append(round(area, 3))
        return areas

    t_old = _timed(whole_part)
    t_new = _timed(lambda: asm_mod.bed_report(asm))
    same = whole_part() == [r["unsupported_area_mm2"] for r in asm_mod.bed_report(asm)]
    return {"exports": rows, "bed_report": {"units": len(asm.units), "whole_part_s": round(t_old, 2),
                                            "near_units_s": round(t_new, 2), "ratio": round(t_old / t_new, 1),
                                            "identical_areas": same}}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--quick", action="store_true", help="skip the 1000-panel runs and exports")
    args = ap.parse_args(argv)
    res = {"load_average": os.getloadavg()[0], "cpus": os.cpu_count()}
    res["dense"] = dense((100,) if args.quick else (100, 1000))
    res["prefix_vs_per_pair"] = prefix_vs_per_pair(300 if args.quick else 1000)
    res["swept_vs_trimesh"] = swept_vs_trimesh(100)
    with tempfile.TemporaryDirectory() as tmp:
        res["guards"], strip1000 = guards_bench(Path(tmp))
        if not args.quick:
            res["export"] = export_bench(strip1000, Path(tmp))
    res["load_average_end"] = os.getloadavg()[0]
    print(json.dumps(res, indent=None if args.json else 1))
    return res


if __name__ == "__main__":
    main()
