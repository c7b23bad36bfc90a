"""Count how often the hinge frames and the spanning tree are computed in one CLI
command, in this process:

    python scripts/count_derived.py check helix_graded --samples 8 --seed 3 --json

Counts executions of the computing function by its code name: ``_hinge_frames`` /
``_spanning_tree`` where they sit behind the derived-data cache, else the public
``hinge_frames`` / ``spanning_tree`` (the layout before the cache). Prints one JSON line
to stderr: the command, its exit code and the counts.
"""

from __future__ import annotations

import json
import sys
from collections import Counter


def main(argv: list[str]) -> int:
    import importlib

    import foldprint.physics.kinematics as kin
    try:  # the spanning tree sits in model/hinge_graph since the split of model/design.py
        design = importlib.import_module("foldprint.model.hinge_graph")
    except ImportError:
        import foldprint.model.design as design
    from foldprint.cli.commands import main as cli

    names = {}
    for mod, name in ((kin, "hinge_frames"), (design, "spanning_tree")):
        names[f"_{name}" if hasattr(mod, f"_{name}") else name] = name
    counts: Counter = Counter()

    def prof(frame, event, _arg):
        if event == "call" and frame.f_code.co_name in names and "foldprint" in frame.f_code.co_filename:
            counts[names[frame.f_code.co_name]] += 1

    sys.setprofile(prof)
    try:
        code = cli(argv)
    finally:
        sys.setprofile(None)
    print(json.dumps({"command": argv, "exit": code, "computed": dict(sorted(counts.items()))}), file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
