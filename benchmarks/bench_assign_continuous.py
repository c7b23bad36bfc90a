"""Benchmark: `assign --continuous` against the seven-grade `assign --objective robust`
on helix_uniform's geometry, under one seed.

    python benchmarks/bench_assign_continuous.py [--json] [--seed 1] [--samples 60]
        [--range 75 90] [--compare 400] [--no-fair]
    python benchmarks/bench_assign_continuous.py --recheck OUT.json --seed 7 --compare 1000 [--json]

Runs, one after the other, each as `foldprint ...` in a subprocess (wall and CPU seconds
of it and its workers):

1. the baseline: `assign helix_uniform --objective robust --seed S --samples N` (the
   design's 90 C bath: the result docs/assign.md reports);
2. `assign helix_uniform --continuous --seed S --samples N` at the design's bath, and
   with `--temperature-range LO HI` (the bath chosen too);
3. unless `--no-fair`: the seven-grade search given the same range
   (`--objective robust --temperature-range LO HI`, every 5 C);
4. `foldprint robust FILE --samples N --seed S` of every written best (it must repeat
   the estimate assign reported), then every best again with `--compare` samples under
   the same seed, and the paired comparison of the continuous best against each
   seven-grade best on those common draws: samples where exactly one of the two jams
   (discordant pairs) and the exact two-sided sign-test p-value of them.

``--recheck OUT.json`` reads the JSON of an earlier run and only re-estimates every best it
reports (its assignment and bath) with ``--compare`` samples at ``--seed``: draws the
searches never saw, with the same paired comparison.

Evaluations are counted as assign counts them: `evaluated` (nominal simulations) and
`robust_simulations` (Monte-Carlo folds). The machine may be shared: compare ratios and
CPU seconds measured in the same run, not wall seconds across runs.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from foldprint.io.load import load_design
from foldprint.simulation.robust import jam_probability, wilson


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def _cli(args: list[str]) -> tuple[dict | None, float, float, int, str]:
    c0, t0 = _cpu(), time.perf_counter()
    p = subprocess.run([sys.executable, "-m", "foldprint", *args], capture_output=True, text=True,
                       env=dict(os.environ))
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    out = json.loads(p.stdout) if p.stdout.strip().startswith("{") else None
    return out, wall, cpu, p.returncode, p.stderr.strip()[-400:]


def _sign_test(a: int, b: int) -> float:
    """Exact two-sided binomial (p = 1/2) test of ``a`` against ``b`` discordant pairs."""
    n, k = a + b, min(a, b)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2 ** n
    return min(1.0, 2 * tail)


def _round(x):
    return None if x is None else round(x, 4)


def _paired(base: list[dict]) -> list[dict]:
    pairs = []
    for c in (r for r in base if "continuous" in r["run"]):
        for g in (r for r in base if "seven-grade" in r["run"]):
            only_c = sum(x and not y for x, y in zip(c["_outcomes"], g["_outcomes"]))
            only_g = sum(y and not x for x, y in zip(c["_outcomes"], g["_outcomes"]))
            pairs.append({"continuous": c["run"], "seven_grade": g["run"], "only_continuous_jams": only_c,
                          "only_seven_grade_jams": only_g, "sign_test_p": round(_sign_test(only_c, only_g), 4)})
    return pairs


def recheck(a) -> None:
    from foldprint.apps.assign.search import with_materials
    from foldprint.io.templates import resolve_design_path

    prev = json.loads(a.recheck.read_text())
    helix = load_design(resolve_design_path(prev["design"]))
    res = {"design": prev["design"], "seed": a.seed, "samples": a.compare, "recheck_of": str(a.recheck),
           "load_average_start": os.getloadavg()[0], "runs": []}
    for r in prev["runs"]:
        if "assignment" not in r:
            continue
        d = with_materials(helix, [r["assignment"][h.id] for h in helix.hinges], r["temperature_c"])
        t0, c0 = time.perf_counter(), _cpu()
        big = jam_probability(d, a.compare, a.seed)
        row = {"run": r["run"], "temperature_c": r["temperature_c"], "jams": big.jams,
               "jam_probability": _round(big.jam_probability), "ci95": [_round(x) for x in big.ci95],
               "wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(_cpu() - c0, 1),
               "_outcomes": [o.jammed for o in big.outcomes]}
        res["runs"].append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "_outcomes"}), file=sys.stderr, flush=True)
    res["paired"] = _paired(res["runs"])
    for r in res["runs"]:
        del r["_outcomes"]
    res["load_average_end"] = os.getloadavg()[0]
    print(json.dumps(res, indent=1) if a.json else "\n".join(map(str, res["runs"] + res["paired"])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON object on stdout")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--samples", type=int, default=60)
    ap.add_argument("--range", type=float, nargs=2, default=(75.0, 90.0), metavar=("LO", "HI"))
    ap.add_argument("--compare", type=int, default=400, help="samples of the common-draw comparison")
    ap.add_argument("--no-fair", action="store_true", help="skip the seven-grade run over the same range")
    ap.add_argument("--recheck", type=Path, help="re-estimate the bests of this earlier --json output only")
    a = ap.parse_args()
    if a.recheck:
        return recheck(a)
    s, n = str(a.seed), str(a.samples)
    rng = [f"{a.range[0]:g}", f"{a.range[1]:g}"]
    runs = [("seven-grade, 90 C", ["--objective", "robust"]),
            ("continuous, 90 C", ["--continuous"]),
            (f"continuous, bath {rng[0]}-{rng[1]} C", ["--continuous", "--temperature-range", *rng])]
    if not a.no_fair:
        runs.append((f"seven-grade, bath {rng[0]}-{rng[1]} C", ["--objective", "robust", "--temperature-range", *rng]))
    res: dict = {"design": "helix_uniform", "seed": a.seed, "samples": a.samples, "compare_samples": a.compare,
                 "load_average_start": os.getloadavg()[0], "cores": os.cpu_count(), "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        for label, extra in runs:
            best_file = Path(tmp) / f"best{len(res['runs'])}.toml"
            out, wall, cpu, code, err = _cli(["assign", "helix_uniform", *extra, "--seed", s, "--samples", n,
                                              "--json", "--write", str(best_file)])
            row = {"run": label, "args": extra, "exit": code, "wall_s": round(wall, 1), "cpu_s": round(cpu, 1)}
            if out is None or not out["best"]:
                row["error"] = err
                res["runs"].append(row)
                continue
            b = out["best"][0]
            row.update(evaluated=out["evaluated"], robust_simulations=out["robust_simulations"],
                       assignment=b["assignment"], temperature_c=b["temperature_c"],
                       jam_probability=b["jam_probability"], jam_ci95=b["jam_ci95"], tg_c=b.get("tg_c"))
            rob, *_ = _cli(["robust", str(best_file), "--samples", n, "--seed", s, "--json"])
            row["robust_reverified"] = None if rob is None else rob["jam_probability"]
            d = load_design(best_file)
            t0, c0 = time.perf_counter(), _cpu()
            big = jam_probability(d, a.compare, a.seed)
            row["compare"] = {"jams": big.jams, "samples": a.compare, "jam_probability": _round(big.jam_probability),
                              "ci95": [_round(x) for x in wilson(big.jams, a.compare)],
                              "wall_s": round(time.perf_counter() - t0, 1), "cpu_s": round(_cpu() - c0, 1)}
            row["_outcomes"] = [o.jammed for o in big.outcomes]
            res["runs"].append(row)
            print(f"{label}: {json.dumps({k: v for k, v in row.items() if k != '_outcomes'})}", file=sys.stderr,
                  flush=True)
    base = [r for r in res["runs"] if "_outcomes" in r]
    pairs = _paired(base)
    for r in base:
        del r["_outcomes"]
    res["paired"] = pairs
    g90 = next((r for r in base if r["run"] == "seven-grade, 90 C"), None)
    if g90:
        for r in base:
            r["evaluated_ratio_to_seven_grade_90"] = round(r["evaluated"] / g90["evaluated"], 3)
            r["mc_folds_ratio_to_seven_grade_90"] = round(r["robust_simulations"] / g90["robust_simulations"], 3)
            r["cpu_ratio_to_seven_grade_90"] = round(r["cpu_s"] / g90["cpu_s"], 3)
    res["load_average_end"] = os.getloadavg()[0]
    if a.json:
        print(json.dumps(res, indent=1))
    else:
        for r in res["runs"]:
            print(f"{r['run']:<32} evaluated {r.get('evaluated')!s:>4}  MC folds {r.get('robust_simulations')!s:>5}  "
                  f"CPU {r['cpu_s']:>6} s  jam {r.get('jam_probability')} {r.get('jam_ci95')}  "
                  f"robust {r.get('robust_reverified')}  {a.compare} samples: {r.get('compare')}")
        for p in pairs:
            print(p)


if __name__ == "__main__":
    main()
