"""Sample 1 under scatter: the jam probability of the paper's two helices (Mao 2015,
Table 1) with the printed geometry, for the shipped geometry (a = 30 mm) and a compact
one within the paper's stated dimensions (a = 15 mm), and which scatter component drives
the graded helix's jams (each component alone and all but each,
foldprint.simulation.sensitivity.contributions).

Prints one JSON object; docs/simulation.md quotes it.
Run: python scripts/sample1_scatter.py [--samples 60] [--seed 1]
"""

from __future__ import annotations

import argparse
import json

from foldprint.model.design import strip
from foldprint.io.load import load_design
from foldprint.simulation.robust import default_scatter, jam_probability
from foldprint.simulation.sensitivity import contributions

PITCH = 5.8  # mm: 5 mm clearance + 0.8 mm thickness (paper)
GRADED = ["H-1", "H-1", "H-2", "H-3", "H-4", "H-5", "H-6", "H-7", "H-7"]


def helix(name: str, a: float, materials: list[str]):
    base = load_design("templates/helix_uniform.toml")
    lengths = [a + PITCH * (k // 2) for k in range(10)]
    return strip(name, lengths, [90.0] * 9, materials, depth=6.0, thickness=0.8, radius=5.0,
                 process=base.process)


def summary(r) -> dict:
    lo, hi = r.ci95
    return {"jam_probability": round(r.jam_probability, 4), "ci95": [round(lo, 4), round(hi, 4)],
            "jams": r.jams, "samples": r.samples, "nominal_completed": bool(r.nominal.completed),
            "collisions": [{"pair": list(p), "count": c} for p, c in r.collisions()[:3]]}


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--samples", type=int, default=60)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    out = {"samples": args.samples, "seed": args.seed, "scatter": default_scatter().to_json(), "helices": {}}
    for a in (30.0, 15.0):
        for label, mats in (("uniform", ["H-3"] * 9), ("graded", GRADED)):
            d = helix(f"helix_{label}_a{a:g}", a, mats)
            out["helices"][f"{label}, a = {a:g} mm"] = summary(jam_probability(d, args.samples, args.seed))
    d = helix("helix_graded_a30", 30.0, GRADED)
    parts = contributions(d, jam_probability(d, args.samples, args.seed))
    out["graded_a30_by_component"] = {it.component.key: {"alone": summary(it.alone), "all_but": summary(it.without)}
                                      for it in parts.items}
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
