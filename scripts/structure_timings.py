"""Every timing statement of Mao et al. 2015 about hinges and structures, beside the model's.

Statements, quotes and sources: foldprint/data/paper_timings.toml. Model values: the
model of record (printed arc hinges, nominal materials, 90 C unless the statement says
otherwise), with the paper's point-hinge ROM and ``--after-contact arrest`` where they tell
something (foldprint.simulation.paper_timings.measure). ``--scatter N`` adds Sample 1 under the
default scatter, each sample folded with ``--after-contact arrest`` (N samples, seed 1).

``--materials FILE`` measures under another material file (e.g. the joint fit that was not
adopted, foldprint/data/recovery_structure_fit.toml).

Usage:  python scripts/structure_timings.py [--json] [--scatter 60] [--materials FILE]
The docs' tables and Sample 1 figures are written by scripts/regen_docs.py (the shipped
materials); this script is for looking at another material file or other samples.
"""

from __future__ import annotations

import argparse
import json
import time

from foldprint.model.materials import load_library
from foldprint.simulation.paper_timings import load_statements, measure, sample1_under_scatter, verdict


def fmt(v):
    return "—" if v is None else f"{v:.2f} s"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--scatter", type=int, default=0, help="Monte-Carlo samples of Sample 1 with arrest")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--materials", help="extra material TOML file (overrides the shipped values)")
    args = ap.parse_args()
    st = load_statements()
    t0 = time.perf_counter()
    lib = load_library(args.materials) if args.materials else None
    m = measure(lib)
    rows = []
    for s in st.items:
        v = m[s.id]
        rows.append({"id": s.id, "what": s.what, "kind": s.kind, "role": s.role, "paper_s": s.value_s,
                     "model_s": None if v.value_s is None else round(v.value_s, 2), "note": v.note,
                     "compare": v.compare, "verdict": verdict(s, v, st.approx_tol_s)})
    out = {"approx_tol_s": st.approx_tol_s, "rows": rows, "measure_s": round(time.perf_counter() - t0, 1)}
    if args.scatter:
        t1 = time.perf_counter()
        out["sample1_scatter_arrest"] = sample1_under_scatter(args.scatter, args.seed, lib)
        out["scatter_s"] = round(time.perf_counter() - t1, 1)
    if args.json:
        print(json.dumps(out, indent=1))
        return
    print("| id | role | statement | paper | model (arc) | verdict | notes |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        paper = {"about": "~", "at_most": "≤ ~", "at_least": "≥ "}.get(r["kind"], "")
        paper = f"{paper}{r['paper_s']:g} s" if r["paper_s"] is not None else r["kind"]
        print(f"| `{r['id']}` | {r['role']} | {r['what']} | {paper} | {fmt(r['model_s'])} | {r['verdict']} | "
              f"{r['note']}; {json.dumps(r['compare']) if r['compare'] else ''} |")
    if args.scatter:
        print(json.dumps(out["sample1_scatter_arrest"]))


if __name__ == "__main__":
    main()
