"""The relaxation table of the batch recovery curves against the exact sum of exponentials:
its error over the library's hinge materials, and every template's Monte-Carlo outcomes
sample by sample, table vs exact (the numbers of docs/robustness-model.md's batch path).

    python benchmarks/bench_relaxation_table.py [--samples 64] [--seed 1] [--json]

Error: max |U_table - U_exact| over xi = 1e-20 .. 1e12 (log-spaced, 200 001 points) for the
spectrum of every hinge material of the default library (U enters the ratio as R = 1 - the
bending-weighted mean of U, so this bounds |dR|), at the shipped step and at 3x and 10x it.
Cost: CPU-ms a sample of ``robust.sample_drives`` (a 16-sample chunk, the best of 5), table vs
exact sum, per template.
Outcomes: ``--samples`` draws of the default scatter per template at 1x and 2x its spreads
(more jams), folded by ``robust.run_samples`` (check's hinge model and time step) once with
the table and once with the exact sum; differing = jammed, reason or pair not equal, or a
fold or first-contact time more than ``TIME_TOL`` apart (or one of them None).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from foldprint.core.constants import CHECK_DT_S, RELAXATION_TABLE_STEP  # noqa: E402
from foldprint.core.modes import DEFAULT_HINGE_MODEL  # noqa: E402
from foldprint.io.load import load_design  # noqa: E402
from foldprint.model.materials import default_library  # noqa: E402
from foldprint.physics.recovery import batch as rb  # noqa: E402
from foldprint.physics.recovery import relaxation as rr  # noqa: E402
from foldprint.physics.recovery.curve import spectrum  # noqa: E402
from foldprint.simulation import robust  # noqa: E402

#: Fold and first-contact times (s) closer than this count as the same.
TIME_TOL = 1e-6


def spectra() -> list:
    """The recovery models of the default library's hinge materials and of every template's
    hinges (graded and continuous materials included), one per distinct spectrum."""
    lib = default_library()
    mats = [m for m in lib if m.recovery is not None]
    for path in sorted((ROOT / "templates").glob("*.toml")):
        mats += [lib[h.material] for h in load_design(path, lib).hinges]
    return list({tuple(np.concatenate(spectrum(m.recovery))): m.recovery for m in mats}.values())


def table_error(step: float) -> float:
    """max |U_table - U_exact| over :func:`spectra` and xi = 0 and 1e-20..1e12."""
    xi = np.concatenate([[0.0], np.logspace(-20, 12, 200_001)])
    worst = 0.0
    for p in spectra():
        tau, g = spectrum(p)
        x = xi[:, None] / tau[None, :]
        exact = np.sum(np.where(x <= rr.CUT, g * np.exp(-np.minimum(x, rr.CUT)), 0.0), axis=1)
        worst = max(worst, float(np.max(np.abs(rr.relaxation_table(p, step)(xi) - exact))))
    return worst


def _with_table(table: bool):
    """``material_batch_ratios`` reading the relaxation table or not, whatever its caller asks."""
    return lambda *args, **kw: rb.material_batch_ratios(*args, **{**kw, "table": table})


def curve_cost(reps: int = 5) -> list[dict]:
    """CPU-ms a sample of the curves of a 16-sample chunk, with the table and the exact sum."""
    lib, rows = default_library(), []
    for path in sorted((ROOT / "templates").glob("*.toml")):
        design = load_design(path, lib)
        drawn = robust.draw_samples(design, robust.default_scatter(), 16, 0)
        until = robust.run_end(design, CHECK_DT_S)
        best = {}
        for _ in range(reps):  # interleaved: both see the same load
            for name, table in (("table", True), ("exact", False)):
                robust.material_batch_ratios = _with_table(table)
                t0 = time.process_time()
                robust.sample_drives(design, lib, drawn, until)
                best[name] = min(best.get(name, 1e9), (time.process_time() - t0) / 16 * 1e3)
        robust.material_batch_ratios = rb.material_batch_ratios
        rows.append({"template": path.stem, "table_cpu_ms": round(best["table"], 2),
                     "exact_cpu_ms": round(best["exact"], 2)})
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def _key(o) -> tuple:
    return o.jammed, o.reason, o.pair


def _same(a, b) -> bool:
    if _key(a) != _key(b):
        return False
    for x, y in ((a.fold_time, b.fold_time), (a.time, b.time)):
        if (x is None) != (y is None) or (x is not None and abs(x - y) > TIME_TOL):
            return False
    return True


def outcomes(samples: int, seed: int) -> list[dict]:
    lib = default_library()
    rows = []
    for path in sorted((ROOT / "templates").glob("*.toml")):
        design = load_design(path, lib)
        for scale in (1.0, 2.0):
            drawn = robust.draw_samples(design, robust.default_scatter().scaled(scale), samples, seed)
            got = {}
            for name, table in (("table", True), ("exact", False)):
                robust.material_batch_ratios = _with_table(table)
                t0 = time.process_time()
                got[name] = robust.run_samples((design, lib, drawn, DEFAULT_HINGE_MODEL, CHECK_DT_S))
                got[name + "_cpu_s"] = time.process_time() - t0
            robust.material_batch_ratios = rb.material_batch_ratios
            diffs = [k for k, (a, b) in enumerate(zip(got["table"], got["exact"])) if not _same(a, b)]
            dt = [abs(a.fold_time - b.fold_time) for a, b in zip(got["table"], got["exact"])
                  if a.fold_time is not None and b.fold_time is not None]
            rows.append({"template": path.stem, "scale": scale, "samples": samples,
                         "jams": sum(o.jammed for o in got["exact"]), "differing": len(diffs),
                         "differing_samples": diffs, "max_fold_time_diff_s": max(dt, default=0.0)})
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    step = RELAXATION_TABLE_STEP
    result = {"step": step, "spectra": len(spectra()), "max_abs_dU": table_error(step),
              "max_abs_dU_at_3x_step": table_error(3 * step), "max_abs_dU_at_10x_step": table_error(10 * step),
              "cost": curve_cost(), "outcomes": outcomes(a.samples, a.seed)}
    result["differing_total"] = sum(r["differing"] for r in result["outcomes"])
    if a.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"step {result['step']}: max |dU| {result['max_abs_dU']:.2e} "
              f"(3x step: {result['max_abs_dU_at_3x_step']:.2e}, 10x: {result['max_abs_dU_at_10x_step']:.2e})")
        for r in result["cost"]:
            print(f"{r['template']:22s} curves: {r['table_cpu_ms']:.2f} CPU-ms a sample "
                  f"(exact sum {r['exact_cpu_ms']:.2f})")
        for r in result["outcomes"]:
            print(f"{r['template']:22s} x{r['scale']:.0f}: {r['jams']:3d} jams of {r['samples']}, "
                  f"{r['differing']} differing, max fold-time diff {r['max_fold_time_diff_s']:.1e} s")
        print(f"differing samples: {result['differing_total']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
