"""What a front end writes beside an evaluation's own files, and what it needs to know
before: whether an output folder may take a set (the plan), the export formats there
are, the set's manifest name, a simulation's plots, a design saved as TOML.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING


if TYPE_CHECKING:
    from ..exchange.outfolder import Plan
    from ..model.design import Design
    from ..simulation.simulate import SimulationResult


def known_formats() -> tuple[str, ...]:
    """Every format ``export`` writes."""
    from ..exchange.export import FORMATS

    return tuple(FORMATS)


def manifest_name() -> str:
    """The file name of an output set's manifest, in its folder."""
    from ..exchange.outfolder import MANIFEST

    return MANIFEST


def plan_out(out_dir: str | Path, force: bool = False) -> "Plan":
    """Whether ``out_dir`` may take a set and how it will be published
    (:func:`foldprint.exchange.fileset.plan_out`): refused before anything is built."""
    from ..exchange.fileset import plan_out as plan

    return plan(out_dir, force)


def simulation_plots(result: "SimulationResult", out_dir: Path, name: str) -> list[Path]:
    """The hinge angles over time, and the paper's collision index when the simulation
    computed it, as PNGs in ``out_dir`` (made before): the paths written."""
    from ..render.figures import collision_index_figure, hinge_angle_figure, save_figure

    written = [save_figure(hinge_angle_figure(result), out_dir / f"{name}_hinge_angles.png")]
    if result.index2d is not None:
        written.append(save_figure(collision_index_figure(result), out_dir / f"{name}_collision_index.png"))
    return written


def save_design(path: str | Path, design: "Design") -> Path:
    """``design`` written whole as a foldprint TOML file at ``path``."""
    from ..core.files import write_atomic
    from ..io.design_io import design_to_toml

    return write_atomic(path, design_to_toml(design))
