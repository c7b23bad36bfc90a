"""The two premises behind "seven grades cannot fold octagon_stack" (docs/composition.md),
checked for every pair of flaps i < j (flap i lands lower):

- swap: flaps i and j exchange their fractions (j folds first): must jam;
- tie: flap j gets flap i's fraction (they fold together): must jam.

Everything else keeps octagon_stack's continuous fractions. Prints one JSON object.

    PYTHONPATH=. python scripts/octagon_pairs.py
"""

from __future__ import annotations

import itertools
import json
from dataclasses import replace

from foldprint.io.load import load_design
from foldprint.io.templates import resolve_design_path
from foldprint.model.composition import parse_name, vero
from foldprint.simulation.simulate import simulate


def main() -> int:
    d = load_design(resolve_design_path("octagon_stack"))
    base = [parse_name(h.material).knots[0] for h in d.hinges]
    out = {"swap": {}, "tie": {}}
    for i, j in itertools.combinations(range(len(base)), 2):
        for kind in ("swap", "tie"):
            f = list(base)
            if kind == "swap":
                f[i], f[j] = f[j], f[i]
            else:
                f[j] = f[i]
            dd = replace(d, hinges=tuple(replace(h, material=vero(x)) for h, x in zip(d.hinges, f)))
            r = simulate(dd)
            out[kind][f"f{i + 1}-f{j + 1}"] = None if r.completed else (list(r.first_collision.panels) if r.first_collision else "not folded")
    out["all_jam"] = all(v is not None for k in ("swap", "tie") for v in out[k].values())
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
