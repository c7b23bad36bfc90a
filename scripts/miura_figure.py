"""Regenerate docs/img/miura_folding.png: the Miura-ori template folding (docs/loops.md).

    PYTHONPATH=. python scripts/miura_figure.py
"""

from pathlib import Path

from foldprint.io.load import load_design
from foldprint.render.stills import render_frames
from foldprint.simulation.simulate import simulate
from foldprint.io.templates import templates_dir

if __name__ == "__main__":
    d = load_design(templates_dir() / "miura_3x3.toml")
    res = simulate(d, method="fcl", duration=4.0)
    fig = render_frames(res, n=4, dpi=90.0)
    out = Path(__file__).resolve().parent.parent / "docs" / "img" / "miura_folding.png"
    fig.savefig(out, dpi=90)
    print(out, res.completed, res.trajectory.loops.closure)
