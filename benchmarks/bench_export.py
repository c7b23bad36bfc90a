"""Build + export time of strip sheets with 10 and 100 hinges (one run, both sizes).

    python benchmarks/bench_export.py [--repeat N] [--json]

Each sheet is a zig-zag strip (alternating +-90 deg folds, so the printed state does not
collide) of 15 mm panels, 20 mm deep, 1 mm thick, with 0.8 mm stepped hinges of radius
5 mm, triangular interfaces and slotted segments (<= 8 mm), cycling through H-1..H-7:
every feature of the builders is exercised. Reported times are the best of --repeat
runs (default 3), split into build (geometry) and export (3MF, PrusaSlicer 3MF, STL and
manifest, written to a temporary directory). The target is a ratio <= 12 between the
100-hinge and the 10-hinge sheet (linear scaling would be 10).
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time

from foldprint.physics.recovery.curve import hinge_fold_times
from foldprint.model.design import HingeStyle, strip
from foldprint.exchange.export import export_assembly
from foldprint.geometry import build_assembly

MATERIALS = ["H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7"]
STYLE = HingeStyle(stepped=True, step_period_mm=2.0, thin_mm=0.4, interface="triangular",
                   tooth_depth_mm=1.5, tooth_pitch_mm=3.0, max_segment_mm=8.0, slot_width_mm=1.0)
TARGET_RATIO = 12.0


def sheet(n_hinges: int):
    return strip(f"bench_{n_hinges}", [15.0] * (n_hinges + 1),
                 [90.0 if i % 2 == 0 else -90.0 for i in range(n_hinges)],
                 [MATERIALS[i % len(MATERIALS)] for i in range(n_hinges)],
                 depth=20.0, thickness=1.0, hinge_thickness=0.8, radius=5.0, style=STYLE)


def measure(n_hinges: int, repeat: int) -> dict:
    design = sheet(n_hinges)
    best_build = best_export = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        asm = build_assembly(design, "permanent")
        t1 = time.perf_counter()
        with tempfile.TemporaryDirectory() as out:
            records = export_assembly(design, asm, out, fold_times=hinge_fold_times(design))
        t2 = time.perf_counter()
        best_build = min(best_build, t1 - t0)
        best_export = min(best_export, t2 - t1)
    return {"hinges": n_hinges, "build_s": round(best_build, 4), "export_s": round(best_export, 4),
            "total_s": round(best_build + best_export, 4),
            "triangles": int(sum(len(b.faces) for b in asm.bodies)),
            "bytes": int(sum(r["bytes"] for r in records)), "bodies": len(asm.bodies)}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    small, large = measure(10, args.repeat), measure(100, args.repeat)
    ratio = large["total_s"] / small["total_s"]
    result = {"small": small, "large": large, "ratio": round(ratio, 2), "target_ratio": TARGET_RATIO,
              "ok": ratio <= TARGET_RATIO}
    if args.json:
        print(json.dumps(result))
    else:
        for r in (small, large):
            print(f"{r['hinges']:4d} hinges: build {r['build_s']:.3f} s + export {r['export_s']:.3f} s = "
                  f"{r['total_s']:.3f} s  ({r['triangles']} triangles, {r['bodies']} bodies, "
                  f"{r['bytes'] / 1e6:.1f} MB written)")
        print(f"ratio 100/10 hinges: {ratio:.2f} (target <= {TARGET_RATIO:g}) -> {'OK' if result['ok'] else 'TOO SLOW'}")
    return result


if __name__ == "__main__":
    main()
