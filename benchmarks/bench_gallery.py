"""Gallery build time: every template, in parallel processes against one process, and
the material chart's fold-time table against one recovery curve per point.

    python benchmarks/bench_gallery.py [--jobs N] [--json]

Prints wall times and two ratios measured in the same run: the speed-up of ``--jobs``
worker processes (default: the CPU count) over one, and of the vectorised, cached
:func:`foldprint.recovery_table.fold_times` over the loop a user would write
(``recovery_curve(m, T).fold_time`` per material and bath; each curve computed afresh).
The target is the whole gallery in under 20 s wall on 2 idle cores; the load average is
printed because other processes on the machine slow every wall time down, and the CPU
time (this process and its workers) because it does not depend on them.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import tempfile
import time

import numpy as np

from foldprint.gallery import build_gallery
from foldprint.load import load_design
from foldprint.materials import default_library
from foldprint.recovery import _curve, recovery_curve
from foldprint.recovery_table import _fold_times, fold_times
from foldprint.templates import list_templates

TARGET_S = 20.0


def _cpu() -> float:
    """CPU seconds (user + system) of this process and its finished children."""
    a, b = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return a.ru_utime + a.ru_stime + b.ru_utime + b.ru_stime


def _gallery(jobs: int) -> tuple[float, float]:
    """Wall and CPU seconds of one gallery build of every template."""
    designs = [load_design(t["path"]) for t in list_templates()]
    with tempfile.TemporaryDirectory() as tmp:
        c0, t0 = _cpu(), time.perf_counter()
        build_gallery(designs, tmp, jobs=jobs)
        return time.perf_counter() - t0, _cpu() - c0


def _chart() -> tuple[float, float, float]:
    lib = default_library()
    baths = np.linspace(70.0, 100.0, 16)
    _curve.cache_clear()
    t0 = time.perf_counter()
    loop = {m.name: [recovery_curve(m, float(b)).fold_time for b in baths] for m in lib.hinges()}
    t_loop = time.perf_counter() - t0
    _fold_times.cache_clear()
    t0 = time.perf_counter()
    table = {m.name: fold_times(m, baths) for m in lib.hinges()}
    t_table = time.perf_counter() - t0
    worst = max(abs(a - b) for k in loop for a, b in zip(loop[k], table[k]) if a is not None and b is not None)
    return t_loop, t_table, worst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    load = os.getloadavg()[0]
    t_loop, t_table, worst = _chart()
    t_par, cpu_par = _gallery(args.jobs)
    t_one, cpu_one = _gallery(1)
    res = {"cpus": os.cpu_count(), "load_avg_1min": round(load, 2), "jobs": args.jobs,
           "gallery_parallel_s": round(t_par, 2), "gallery_one_process_s": round(t_one, 2),
           "parallel_speedup": round(t_one / t_par, 2), "target_s": TARGET_S,
           "gallery_parallel_cpu_s": round(cpu_par, 2), "gallery_one_process_cpu_s": round(cpu_one, 2),
           "chart_loop_s": round(t_loop, 3), "chart_table_s": round(t_table, 3),
           "chart_speedup": round(t_loop / t_table, 1), "chart_max_diff_s": worst}
    if args.json:
        print(json.dumps(res))
        return
    print(f"{res['cpus']} CPUs, load average {load:.1f} at start")
    print(f"gallery, every template: {t_par:.1f} s with {args.jobs} processes, {t_one:.1f} s with one "
          f"(x{t_one / t_par:.2f}); target < {TARGET_S:g} s on 2 idle cores")
    print(f"  CPU time (user + system, workers included): {cpu_par:.1f} s in parallel, {cpu_one:.1f} s in one "
          f"process; on {args.jobs} idle cores the parallel build cannot beat {cpu_par / args.jobs:.1f} s")
    print(f"chart fold times, 7 materials x 16 baths: {t_loop:.2f} s one curve each, {t_table:.2f} s "
          f"as one table (x{t_loop / t_table:.1f}), largest difference {worst:.2e} s")


if __name__ == "__main__":
    main()
