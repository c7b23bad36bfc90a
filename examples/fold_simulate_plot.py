"""Load a FOLD crease pattern (as Origami Simulator or Rabbit Ear write it), simulate the
fold and plot it.

    python examples/fold_simulate_plot.py [OUT_DIR]  (default: output/examples/fold_simulate_plot)

The crease pattern here is written by the script itself (a 20 mm square with a flap on each
side); point ``load_design`` at your own ``.fold`` file instead. Writes hinge_angles.png
(fold angle of each hinge against time) and frames.png (four 3D views while folding).
"""

import json
import sys
from pathlib import Path

from foldprint.io.load import load_design
from foldprint.render.figures import hinge_angle_figure, save_figure
from foldprint.render.stills import render_frames
from foldprint.simulation.simulate import simulate

out = Path(sys.argv[1] if len(sys.argv) > 1 else "output/examples/fold_simulate_plot")
out.mkdir(parents=True, exist_ok=True)

# a cross: base square 0..20 mm with four 15 mm flaps, valley folds of 90 deg
v = [[0, 0], [20, 0], [20, 20], [0, 20],  # 0-3 base
     [0, -15], [20, -15], [35, 0], [35, 20], [20, 35], [0, 35], [-15, 20], [-15, 0]]
cp = {
    "file_spec": 1.1, "file_creator": "foldprint example", "frame_title": "open_box",
    "frame_unit": "mm", "frame_classes": ["creasePattern"],
    "vertices_coords": v,
    "faces_vertices": [[0, 1, 2, 3], [4, 5, 1, 0], [1, 6, 7, 2], [3, 2, 8, 9], [11, 0, 3, 10]],
    "edges_vertices": [[0, 1], [1, 2], [2, 3], [3, 0], [4, 5], [5, 1], [0, 4], [1, 6], [6, 7], [7, 2],
                       [2, 8], [8, 9], [9, 3], [3, 10], [10, 11], [11, 0]],
    "edges_assignment": ["V", "V", "V", "V"] + ["B"] * 12,
    "edges_foldAngle": [90, 90, 90, 90] + [0] * 12,
}
path = out / "open_box.fold"
path.write_text(json.dumps(cp, indent=1))

design = load_design(path)  # hinge materials default to H-3; see docs for faces_/edges_foldprint:* keys
result = simulate(design)
print(f"{design.name}: {len(design.panels)} panels, {len(design.hinges)} hinges; "
      f"completed={result.completed}, first contact: {result.first_collision}")
save_figure(hinge_angle_figure(result), out / "hinge_angles.png")
save_figure(render_frames(result, 4), out / "frames.png")
print(f"  wrote {out / 'hinge_angles.png'} and {out / 'frames.png'}")
