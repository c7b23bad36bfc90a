"""Compare two hinge-material assignments of the same strip: which folds in order, which jams?

    python examples/compare_hinges.py

The self-locking strip of Mao et al. (2015, Fig. 5) as designed (graded: H-2, H-2, H-3, H-6,
H-6) against the same geometry with one material everywhere (H-3): every hinge then folds at
once, and the end of the strip can no longer thread through the holes in order.
"""

from dataclasses import replace

from foldprint.io.load import load_design
from foldprint.simulation.simulate import simulate
from foldprint.io.templates import resolve_design_path

graded = load_design(resolve_design_path("self_lock"))
uniform = replace(graded, name="self_lock_all_H-3",
                  hinges=tuple(replace(h, material="H-3") for h in graded.hinges))

for design in (graded, uniform):
    result = simulate(design)
    materials = ", ".join(h.material for h in design.hinges)
    print(f"{design.name} ({materials})")
    c = result.first_collision
    print("  first contact: " + (f"panels {c.panels[0]}-{c.panels[1]} at {c.time:.2f} s" if c else "none"))
    print("  goals: " + ", ".join(f"{g.goal.id} {'met' if g.met else 'NOT met'}" for g in result.goals))
    print(f"  completes: {result.completed}")
