"""The operating characteristic of check's sequential jam test, simulated (pure numpy).

    python benchmarks/bench_verdict.py [--streams 100000] [--seed 1] [--json] [--write-doc]

For each true jam probability p (the thresholds, the edges of their indifference regions,
and 0-98 %), ``--streams`` independent Bernoulli(p) streams are judged by the test of
:func:`foldprint.simulation.jamtest.verdict.jam_test` (check's defaults): the share of each
verdict, the average sample number (ASN), the share that reached the maximum undecided
(truncated) and the share that needed more than the 80 samples of a fixed-size check.
The stated error rates are checked against the table (a breach is printed and exits 1).
Also: the miscoverage over time of the anytime-valid interval, at a few p.

``--json`` writes ``docs/data/bench_verdict.json``; ``--write-doc`` replaces the table
between the markers in ``docs/verdict.md`` (so the doc's figures come from this run).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from functools import lru_cache
from pathlib import Path

import numpy as np

from foldprint.core.constants import CHECK_SAMPLES, JAM_TEST_ALPHA, JAM_TEST_BETA
from foldprint.simulation.jamtest.verdict import confidence_sequence, decide_many, jam_test

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "verdict.md"
DATA = ROOT / "docs" / "data" / "bench_verdict.json"
BEGIN, END = "<!-- bench_verdict:begin -->", "<!-- bench_verdict:end -->"
P = (0.0, 0.01, 0.02, 0.025, 0.035, 0.046, 0.05, 0.075, 0.10, 0.15, 0.197, 0.20, 0.25, 0.30, 0.50, 0.98)
FIXED_N = 80  # the samples of the earlier fixed-size check


def row(p: float, streams: int, seed: int, block: int = 5000) -> dict:
    test = jam_test()
    rng = np.random.default_rng([seed, int(round(p * 1e6))])
    counts, n_sum, trunc, over80, left = np.zeros(3), 0, 0, 0, streams
    while left:
        b = min(block, left)
        r = decide_many(rng.random((b, test.max_samples)) < p, test)
        v = r["verdict"]
        counts += np.bincount(v, minlength=3)[:3]
        n_sum += int(r["samples"].sum())
        over80 += int(np.sum(r["samples"] > FIXED_N))
        trunc += int(r["truncated"].sum())
        left -= b
    share = counts / streams
    return {"p": p, "pass": share[0], "warning": share[1], "error": share[2], "asn": n_sum / streams,
            "truncated": trunc / streams, "over_80": over80 / streams}


def breaches(rows: list[dict], streams: int) -> list[str]:
    """The stated rates (docs/verdict.md) against the table, with three standard errors."""
    t = jam_test()
    tol = 3 * math.sqrt(0.05 * 0.95 / streams)
    out = []
    for r in rows:
        p = r["p"]
        checks = []
        if p <= t.warning.lo:
            checks.append(("not pass", 1 - r["pass"], t.warning.alpha))
        if p >= t.warning.hi:
            checks.append(("pass", r["pass"], t.warning.beta))
        if p <= t.error.lo:
            checks.append(("error", r["error"], t.error.alpha))
        if p >= t.error.hi:
            checks.append(("not error", 1 - r["error"], t.error.beta))
        out += [f"p = {p}: P({what}) = {v:.4f} > {lim}" for what, v, lim in checks if v > lim + tol]
    return out


def coverage(p: float, streams: int, seed: int) -> float:
    """Share of streams whose interval misses p at some n <= the maximum."""
    cs = lru_cache(maxsize=None)(confidence_sequence)
    rng = np.random.default_rng([seed, 7, int(p * 1e6)])
    ks = np.cumsum(rng.random((streams, CHECK_SAMPLES)) < p, axis=1)
    missed = 0
    for row_k in ks:
        for n in range(1, CHECK_SAMPLES + 1):
            lo, hi = cs(int(row_k[n - 1]), n)
            if not lo <= p <= hi:
                missed += 1
                break
    return missed / streams


def table(rows: list[dict], streams: int) -> str:
    head = ("| true p | pass | warning | error | average samples | truncated at 400 | more than 80 |\n"
            "|---|---|---|---|---|---|---|\n")
    body = "".join(f"| {100 * r['p']:g} % | {r['pass']:.4f} | {r['warning']:.4f} | {r['error']:.4f} | "
                   f"{r['asn']:.1f} | {r['truncated']:.4f} | {r['over_80']:.3f} |\n" for r in rows)
    return head + body + (f"\n({streams} simulated streams per row, `python benchmarks/bench_verdict.py "
                          f"--write-doc`; Monte-Carlo standard error at most {0.5 / math.sqrt(streams):.4f}.)\n")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--streams", type=int, default=100_000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--coverage-streams", type=int, default=2000)
    ap.add_argument("--json", action="store_true", help=f"write {DATA.relative_to(ROOT)}")
    ap.add_argument("--write-doc", action="store_true", help=f"replace the table in {DOC.relative_to(ROOT)}")
    a = ap.parse_args()
    t0 = time.process_time()
    rows = [row(p, a.streams, a.seed) for p in P]
    cov = {p: coverage(p, a.coverage_streams, a.seed) for p in (0.03, 0.2, 0.6)}
    cpu = time.process_time() - t0
    text = table(rows, a.streams)
    print(text)
    print("interval missed the true p at some n <= 400: "
          + ", ".join(f"p = {p:g}: {v:.4f}" for p, v in cov.items()) + f" ({a.coverage_streams} streams each)")
    bad = breaches(rows, a.streams)
    print("stated error rates: " + ("; ".join(bad) if bad else
                                    f"all met (alpha = {JAM_TEST_ALPHA}, beta = {JAM_TEST_BETA})") + f"; {cpu:.1f} CPU-s")
    if a.json:
        DATA.write_text(json.dumps({"streams": a.streams, "seed": a.seed, "max_samples": CHECK_SAMPLES,
                                    "rows": rows, "coverage_miss": {str(k): v for k, v in cov.items()},
                                    "breaches": bad}, indent=1) + "\n")
    if a.write_doc:
        doc = DOC.read_text(encoding="utf-8")
        i, j = doc.index(BEGIN) + len(BEGIN), doc.index(END)
        DOC.write_text(doc[:i] + "\n" + text + doc[j:], encoding="utf-8")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
