"""Design a three-panel strip in Python, simulate its fold and export the printable files.

    python examples/design_strip.py [OUT_DIR]        (default: output/examples/design_strip)

Writes a 3MF with one body per material, a PrusaSlicer 3MF and one STL per material.
"""

import sys
from pathlib import Path

from foldprint.model.design import strip
from foldprint.apps.pipeline import export
from foldprint.simulation.simulate import simulate

out = Path(sys.argv[1] if len(sys.argv) > 1 else "output/examples/design_strip")

# panels p1..p3 (lengths in mm along x, fold line to fold line, 6 mm deep) and hinges h1, h2
# between them: target fold angles in degrees, one shape-memory material per hinge (H-1
# recovers first, H-7 last), bend radius 3 mm
design = strip("my_channel", lengths=[30, 25, 30], angles_deg=[90, 90], materials=["H-1", "H-7"],
               radius=3.0, description="a strip that folds into a U channel, one side after the other")

result = simulate(design)
print(f"{design.name}: {len(design.panels)} panels, {len(design.hinges)} hinges, "
      f"completes: {result.completed}, every hinge at 98 % after {result.fold_time} s")

for rec in export(design, out, state="permanent", formats=("3mf", "prusa3mf", "stl")):
    print(f"  wrote {rec['path']} ({rec['format']}, {rec['bytes']} bytes)")
