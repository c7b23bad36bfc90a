"""The memory guard against the peaks it bounds: per command and size,
the guard's estimate beside the peak resident size of a fresh process, and whether a
lower limit refuses it.

    PYTHONPATH=$PWD python benchmarks/guard_peaks.py [--quick] [--json out.json]

For strips of 250 to 2000 panels (10 mm, +-30 deg, H-3, 20 s at dt 10 ms; robust's at
+-10 deg so its samples do not spend their time in contact) and the 1,500-face FOLD strip:

* ``check --samples 0`` (the fold held, then the clearance search), ``simulate`` (the
  fold and the other hinge model's, held at once, each with the paper's 2D index of the
  strip while it fits, then the clearance search; the scatter margin screen that follows
  is bounded on its own, its batches fitted to the memory left, and left out above
  ``MARGIN_MAX_PAIRS``) and ``robust --samples 16`` (the fold
  held while a chunk of samples folds in this process): the estimate of
  ``costs.run_estimate`` with the runs the command holds, and the measured peak (max RSS
  of the command in its own process, no address limit), their ratio;
* the same command with ``--max-memory`` (``FOLDPRINT_MAX_MEMORY``) set to 0.8x its
  measured peak (it must refuse: exit 2 at once, naming the estimate) and to 1.5x (it
  must run). A guard that refused a run fitting in 1.5x its peak would refuse too much;
  one that let 0.8x run would not hold.

Wall times on the shared 2-core machine mean little; CPU seconds are reported.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from fuzz_gen import run_fresh  # noqa: E402
from test_guards_hold import _fold_strip, _strip  # noqa: E402

RUNS = {"check": (1, True), "simulate": (2, True), "robust": (2, False)}


def _estimate(path: Path, command: str) -> float:
    from foldprint.simulation import costs
    from foldprint.io.load import load_design
    from foldprint.simulation.robust import curve_batch

    runs, clearance = RUNS[command]
    d = load_design(path)
    # simulate runs --method both: the paper's 2D index too on a strip, unless it is left out
    both = command == "simulate" and not costs.index2d_skip_reason(d, 0.01, None)
    curves = curve_batch(d, 0.01, 16)[1] if command == "robust" else 0.0  # the chunk's sampled curves
    return costs.run_estimate(d, 0.01, None, "both" if both else "fcl", runs, clearance, curves)["bytes"]


def _args(command: str, name: str) -> list[str]:
    return {"check": ["check", name, "--samples", "0", "--json"], "simulate": ["simulate", name, "--json"],
            "robust": ["robust", name, "--samples", "16", "--json"]}[command]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="250 and 1000 panels only")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    sizes = [250, 1000] if a.quick else [250, 500, 1000, 2000]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        designs = []
        for n in sizes:
            (tmp / f"s{n}.toml").write_text(_strip(n, 30.0))
            (tmp / f"r{n}.toml").write_text(_strip(n, 10.0))
            designs += [("check", f"s{n}.toml"), ("simulate", f"s{n}.toml"), ("robust", f"r{n}.toml")]
        (tmp / "f1500.fold").write_text(_fold_strip(1500))
        designs += [("check", "f1500.fold"), ("simulate", "f1500.fold")]
        for command, name in designs:
            est = _estimate(tmp / name, command)
            res = run_fresh(_args(command, name), tmp, cpu_s=1800)
            peak = res["peak_mib"] * 2 ** 20
            row = {"command": command, "design": name, "estimate_mib": round(est / 2 ** 20),
                   "peak_mib": round(res["peak_mib"]), "estimate_over_peak": round(est / peak, 2),
                   "code": res["code"], "cpu_s": round(res["cpu_seconds"], 1)}
            for k in (0.8, 1.5):
                lim = {"FOLDPRINT_MAX_MEMORY": str(int(k * peak))}
                r = run_fresh(_args(command, name), tmp, cpu_s=1800, env=lim)
                row[f"at_{k}x_peak"] = {"code": r["code"], "cpu_s": round(r["cpu_seconds"], 1),
                                        "refused": "memory limit" in r["err"]}
            rows.append(row)
            print(json.dumps(row), flush=True)
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
