"""Benchmark: the bar-and-hinge equilibrium path (``--mechanics bar-hinge``) on Miura sheets
of growing size, against the rigid loop tracker on the same sheets, in the same run.

    PYTHONPATH=. python benchmarks/bench_barhinge.py [--sizes 4,8,12,16,20] [--rigid-up-to 8] [--json FILE]
    PYTHONPATH=. python benchmarks/bench_barhinge.py --sizes 10,20 --template-fixity --simulate --json FILE

Each sheet is ``crease_patterns.miura(n, n)`` with the Miura template's geometry and
materials (24 x 20 mm panels, rows shifted 8 mm, zigzag creases H-2 at 60 deg, straight
creases H-4, programmed 99 % flat), folded over its whole 20 s run at 90 C. Reported per
size: nodes, solved steps, Newton iterations, CPU-s (user + sys of this process,
``time.process_time``) of building the model and solving the path, CPU-s per Newton
iteration, and the rigid tracker's CPU-s (``HingeDrive.solve_loops`` on the same 0.01 s
grid) up to ``--rigid-up-to``. ``scaling_exponent``: the slope of log CPU-s over log nodes.
Target: the 20 x 20 sheet (441 nodes, 10 x 10 unit cells) through its whole fold
in < 30 s.

``--template-fixity``: the hinges keep their materials' shape fixity (0.9967), as
scripts/make_miura_template.py writes the Miura template, instead of 0.99.
``--simulate``: also the whole ``foldprint simulate SHEET --mechanics bar-hinge --json``
in this process (CPU-s and wall-s; targets: the 10 x 10 sheet < 30 s, the 20 x 20 < 2 min).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time

import numpy as np

from foldprint.io.fold_format import design_from_fold
from foldprint.model import crease_patterns as cp
from foldprint.physics.barhinge.equilibrium import CompliantDrive
from foldprint.physics.hinge_drive import HingeDrive, run_times


def sheet(n: int, template_fixity: bool = False):
    d = design_from_fold(cp.miura(n, n, width=24, height=20, shift=8, zigzag_deg=60,
                                  materials={"zigzag": "H-2", "straight": "H-4"}), default_radius_mm=5.0)
    d = d.replace(name=f"miura_{n}x{n}")
    return d if template_fixity else d.replace(hinges=tuple(dataclasses.replace(h, fixity=0.99) for h in d.hinges))


def simulate_cli(d) -> dict:
    """CPU-s and wall-s of ``foldprint simulate --mechanics bar-hinge --json`` on ``d``, in process."""
    import contextlib
    import io
    import tempfile
    from pathlib import Path

    from foldprint.cli.commands import main
    from foldprint.io.design_io import design_to_toml

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{d.name}.toml"
        path.write_text(design_to_toml(d))
        out, err = io.StringIO(), io.StringIO()
        t0, w0 = time.process_time(), time.perf_counter()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            code = main(["simulate", str(path), "--mechanics", "bar-hinge", "--json"])
        cpu_s, wall_s = time.process_time() - t0, time.perf_counter() - w0
    row = {"simulate_exit": code, "simulate_cpu_s": round(cpu_s, 2), "simulate_wall_s": round(wall_s, 2)}
    if code in (0, 1):
        res = json.loads(out.getvalue())
        return {**row, "simulate_completed": res["completed"], "simulate_fold_time_s": res.get("fold_time_s")}
    return {**row, "simulate_error": (err.getvalue().strip().splitlines() or [""])[0][:200]}


def cpu(fn):
    t0 = time.process_time()
    out = fn()
    return time.process_time() - t0, out


def measure(n: int, rigid: bool, template_fixity: bool = False, whole: bool = False) -> dict:
    d = sheet(n, template_fixity)
    times = run_times(d, 0.01)
    t_bh, sol = cpu(lambda: CompliantDrive(d).solve(times))
    row = {"panels": n * n, "nodes": len(sol.model.nodes), "bars": len(sol.model.bars),
           "springs": len(sol.model.springs), "solved_steps": len(sol.grid), "newton_iterations": sol.iterations,
           "split_steps": sol.splits, "unconverged": len(sol.unconverged), "bar_hinge_cpu_s": round(t_bh, 3),
           "cpu_ms_per_iteration": round(1e3 * t_bh / max(sol.iterations, 1), 3),
           "max_panel_strain": sol.max_strain}
    if rigid:
        t_r, _ = cpu(lambda: HingeDrive(d).solve_loops(times))
        row["rigid_tracker_cpu_s"] = round(t_r, 3)
        row["ratio_bar_hinge_vs_rigid"] = round(t_bh / t_r, 3)
    if whole:
        row.update(simulate_cli(d))
    return row


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", default="4,8,12,16,20")
    ap.add_argument("--rigid-up-to", type=int, default=8)
    ap.add_argument("--json")
    ap.add_argument("--template-fixity", action="store_true")
    ap.add_argument("--simulate", action="store_true")
    a = ap.parse_args()
    sizes = [int(s) for s in a.sizes.split(",")]
    rows = []
    for n in sizes:  # each row printed as it is done: a loaded machine may stop a long run
        rows.append(measure(n, n <= a.rigid_up_to, a.template_fixity, a.simulate))
        print(json.dumps(rows[-1]), flush=True)
    nodes = np.array([r["nodes"] for r in rows], float)
    cpus = np.array([r["bar_hinge_cpu_s"] for r in rows])
    slope = float(np.polyfit(np.log(nodes), np.log(cpus), 1)[0]) if len(rows) > 1 else None
    big = next((r for r in rows if r["panels"] == 400), None)
    out = {"rows": rows, "scaling_exponent": slope, "fixity": "materials'" if a.template_fixity else 0.99,
           "load_average_1min": round(os.getloadavg()[0], 2), "cpus": os.cpu_count(),
           "target_20x20_under_30_cpu_s": None if big is None else bool(big["bar_hinge_cpu_s"] < 30.0)}
    text = json.dumps(out, indent=1)
    print(text)
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
