"""Benchmark: the Monte-Carlo of `foldprint robust`, the exact per-curve path vs the batched one.

    python benchmarks/bench_robust.py [--json] [--samples 1000] [--compare 32] [--no-assign]

Prints, in one run (helix_graded, Mao 2015 Sample 2, 9 hinges, seed 1):

1. per-sample cost on the same draws (``--compare`` samples, in this process, one after
   the other): the old path (one exact ``recovery_curve`` per hinge over the 600 s horizon,
   BLAS threads as numpy starts them) against the new one (``sample_drives``: the chunk's
   curves in one array pass up to the run's end), curves alone and curves + fold, CPU
   seconds (all threads) and wall; and whether each sample's verdict, fold time and first
   contact agree;
2. ``foldprint robust helix_graded --samples N`` end to end (a subprocess on all cores):
   wall and CPU seconds, against the old path run beside it on a pool like the old one
   (``--compare`` samples, no BLAS limit in the workers), per sample and as a ratio;
3. ``foldprint check`` of both helices at the default samples (exit, finding, interval);
4. ``foldprint assign helix_uniform --objective robust --seed 1 --samples 60 --write``:
   the jam probability ``foldprint robust`` gives the written best (60 samples, seed 1)
   beside the paper's graded helix under the same seed, and both on an independent seed
   (7, 200 samples): the finalists were chosen on seed 1's draws.

The machine may be shared: the load average is printed; compare ratios, not seconds.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from foldprint.io.load import load_design
from foldprint.model.materials import default_library
from foldprint.core.modes import Method
from foldprint.core.parallel import default_workers
from foldprint.physics.recovery.curve import _curve
from foldprint.simulation.robust import (default_scatter, draw_samples, jam_probability, outcome_of, run_end, run_sample,
                              sample_drive, sample_drives)
from foldprint.simulation.simulate import simulate
from foldprint.io.templates import resolve_design_path


#: Samples of the check on an independent seed (the assign finalists were picked on seed 1).
INDEPENDENT = 200


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _old_mapper(fn, items, progress=None):
    """The pool a competent user writes first: every task submitted at once, no BLAS limit."""
    items = list(items)
    with ProcessPoolExecutor(max_workers=min(default_workers(), max(1, len(items)))) as pool:
        return list(pool.map(fn, items))


def _cli(args: list[str]) -> tuple[dict | None, float, float, int]:
    env = dict(os.environ)
    c0, t0 = _cpu(), time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "foldprint", *args], capture_output=True, text=True, env=env)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    out = None
    if p.stdout.strip().startswith("{"):
        out = json.loads(p.stdout)
    return out, wall, cpu, p.returncode


def per_sample(d, lib, n: int) -> dict:
    drawn = draw_samples(d, default_scatter(), n, 1)
    until = run_end(d, 0.01)
    res: dict = {"samples": n}
    _curve.cache_clear()
    c0, t0 = _cpu(), time.perf_counter()
    old_drives = [sample_drive(d, lib, s, exact=True) for s in drawn]
    res["old_curves_cpu_s"], res["old_curves_wall_s"] = (_cpu() - c0) / n, (time.perf_counter() - t0) / n
    c0, t0 = _cpu(), time.perf_counter()
    new_drives = [dr for k in range(0, n, 16) for dr in sample_drives(d, lib, drawn[k:k + 16], until_s=until)]
    res["new_curves_cpu_s"], res["new_curves_wall_s"] = (_cpu() - c0) / n, (time.perf_counter() - t0) / n
    old, new = [], []
    for label, drives, out in (("old", old_drives, old), ("new", new_drives, new)):
        c0, t0 = _cpu(), time.perf_counter()
        for dr in drives:
            out.append(outcome_of(simulate(d, dt=0.01, method=Method.FCL, drive=dr)))
        res[f"{label}_fold_cpu_s"] = (_cpu() - c0) / n
    for label in ("old", "new"):
        res[f"{label}_sample_cpu_s"] = res[f"{label}_curves_cpu_s"] + res[f"{label}_fold_cpu_s"]
    res["curves_cpu_ratio"] = res["old_curves_cpu_s"] / res["new_curves_cpu_s"]
    res["sample_cpu_ratio"] = res["old_sample_cpu_s"] / res["new_sample_cpu_s"]
    res["verdicts_equal"] = sum(a.jammed == b.jammed and a.reason == b.reason for a, b in zip(old, new))
    res["jams_old"], res["jams_new"] = sum(o.jammed for o in old), sum(o.jammed for o in new)
    dts = [abs(a.fold_time - b.fold_time) for a, b in zip(old, new) if a.fold_time is not None and b.fold_time]
    dct = [abs(a.time - b.time) for a, b in zip(old, new) if a.time is not None and b.time is not None]
    res["max_fold_time_diff_s"] = max(dts, default=0.0)
    res["max_contact_time_diff_s"] = max(dct, default=0.0)
    return res


def robust_run(d, lib, n: int, n_old: int) -> dict:
    out, wall, cpu, code = _cli(["robust", "helix_graded", "--samples", str(n), "--seed", "1", "--json"])
    res = {"samples": n, "wall_s": wall, "cpu_s": cpu, "exit": code,
           "cpu_s_per_sample": cpu / n, "wall_s_per_sample": wall / n,
           "jam_probability": out and out["jam_probability"], "ci95": out and out["ci95"]}
    _curve.cache_clear()  # the old path caches curves: part 1 computed these very draws
    c0, t0 = _cpu(), time.perf_counter()
    old = jam_probability(d, n_old, 1, library=lib, exact=True, mapper=_old_mapper)
    w_old, c_old = time.perf_counter() - t0, _cpu() - c0
    res["old_path"] = {"samples": n_old, "wall_s": w_old, "cpu_s": c_old, "wall_s_per_sample": w_old / n_old,
                       "cpu_s_per_sample": c_old / n_old, "jam_probability": old.jam_probability,
                       "estimated_wall_s_for_samples": w_old / n_old * n}
    res["wall_ratio_old_over_new"] = (w_old / n_old) / (wall / n)
    res["cpu_ratio_old_over_new"] = (c_old / n_old) / (cpu / n)
    return res


def check_runs() -> dict:
    """``foldprint check`` of both helices at the default (CHECK_SAMPLES) samples."""
    res = {}
    for name in ("helix_uniform", "helix_graded"):
        out, wall, cpu, code = _cli(["check", name, "--json"])
        jam = [f for f in (out or {}).get("findings", []) if f["code"] in ("FP180", "FP181", "FP182")]
        res[name] = {"exit": code, "wall_s": wall, "cpu_s": cpu, "finding": jam and jam[0]["code"],
                     "samples": out and out["robust"]["samples"],
                     "jam_probability": out and out["robust"]["jam_probability"],
                     "ci95": out and out["robust"]["ci95"]}
    return res


def assign_run() -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        best = Path(tmp) / "best.toml"
        out, wall, cpu, code = _cli(["assign", "helix_uniform", "--objective", "robust", "--seed", "1",
                                     "--samples", "60", "--json", "--write", str(best)])
        res = {"assign_wall_s": wall, "assign_cpu_s": cpu, "exit": code,
               "best": out and out["best"][:1], "robust_simulations": out and out.get("robust_simulations")}
        if best.exists():
            r, *_ = _cli(["robust", str(best), "--samples", "60", "--seed", "1", "--json"])
            res["best_jam_probability_60_seed1"] = r and r["jam_probability"]
            # the finalists were picked on seed 1's draws: an independent seed, more samples
            r, *_ = _cli(["robust", str(best), "--samples", str(INDEPENDENT), "--seed", "7", "--json"])
            res[f"best_jam_probability_{INDEPENDENT}_seed7"] = r and [r["jam_probability"], r["ci95"]]
    g, *_ = _cli(["robust", "helix_graded", "--samples", "60", "--seed", "1", "--json"])
    res["helix_graded_jam_probability_60_seed1"] = g and g["jam_probability"]
    g, *_ = _cli(["robust", "helix_graded", "--samples", str(INDEPENDENT), "--seed", "7", "--json"])
    res[f"helix_graded_jam_probability_{INDEPENDENT}_seed7"] = g and [g["jam_probability"], g["ci95"]]
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    ap.add_argument("--samples", type=int, default=1000, help="samples of the end-to-end robust run")
    ap.add_argument("--compare", type=int, default=32, help="samples run through both paths")
    ap.add_argument("--no-assign", action="store_true", help="skip the assign run (minutes)")
    a = ap.parse_args()
    lib = default_library()
    d = load_design(resolve_design_path("helix_graded"), lib)
    res = {"machine": {"cores": default_workers(), "load_average_start": os.getloadavg()}}
    res["per_sample"] = per_sample(d, lib, a.compare)
    res["robust"] = robust_run(d, lib, a.samples, a.compare)
    res["check"] = check_runs()
    if not a.no_assign:
        res["assign"] = assign_run()
    res["machine"]["load_average_end"] = os.getloadavg()
    if a.json:
        print(json.dumps(res, indent=1))
        return
    p, r = res["per_sample"], res["robust"]
    print(f"{res['machine']['cores']} cores, load average {res['machine']['load_average_start'][0]:.1f} at start")
    print(f"per sample, same {p['samples']} draws: curves {p['old_curves_cpu_s'] * 1e3:.0f} -> "
          f"{p['new_curves_cpu_s'] * 1e3:.1f} ms CPU ({p['curves_cpu_ratio']:.1f}x); curves + fold "
          f"{p['old_sample_cpu_s'] * 1e3:.0f} -> {p['new_sample_cpu_s'] * 1e3:.0f} ms ({p['sample_cpu_ratio']:.1f}x); "
          f"verdicts equal {p['verdicts_equal']}/{p['samples']}, fold times within {p['max_fold_time_diff_s']:.2g} s")
    print(f"robust --samples {r['samples']}: {r['wall_s']:.1f} s wall, {r['cpu_s_per_sample'] * 1e3:.0f} ms CPU/sample, "
          f"jam probability {r['jam_probability']}; old path ({r['old_path']['samples']} samples): "
          f"{r['old_path']['wall_s_per_sample'] * 1e3:.0f} ms wall/sample -> x{r['wall_ratio_old_over_new']:.1f} wall, "
          f"x{r['cpu_ratio_old_over_new']:.1f} CPU")
    if "assign" in res:
        s = res["assign"]
        print(f"assign --objective robust: {s['assign_wall_s']:.0f} s; its best jams "
              f"{s.get('best_jam_probability_60_seed1')} vs helix_graded {s['helix_graded_jam_probability_60_seed1']} "
              "(60 samples, seed 1)")


if __name__ == "__main__":
    main()
