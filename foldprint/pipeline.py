"""The one place the stages are chained: design -> simulation (once) -> assembly ->
checks (given both) -> writers. ``cli``, ``gallery`` and ``assign`` call this module;
no stage below it calls another stage's entry point.
"""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

from .design import Design
from .exchange.export import ANIMATION_DT_S, DEFAULT_FORMATS, TRAJECTORY_FORMATS, check_formats, export_assembly
from .geometry import Assembly, build_assembly
from .materials import MaterialLibrary, default_library
from .modes import DEFAULT_STATE, HingeModel, State, parse


def build(design: Design, state: State | str = DEFAULT_STATE,
          library: MaterialLibrary | None = None) -> Assembly:
    """The printable part in ``state``: one watertight body per material."""
    st = parse(State, state, "state")
    return build_assembly(design, st.value, library or default_library())


def export(design: Design, out_dir: str | Path, state: State | str = DEFAULT_STATE,
           formats: Iterable[str] = DEFAULT_FORMATS, library: MaterialLibrary | None = None) -> list[dict]:
    """Build ``design`` in ``state`` and write ``formats`` into ``out_dir``; the records
    of :func:`foldprint.exchange.export.export_assembly`. The fold is simulated (arc
    hinges, the defaults) only when a format shows it over time (xdmf, glb)."""
    lib = library or default_library()
    formats = check_formats(formats)  # before the (slower) build
    trajectory = None
    if any(f in TRAJECTORY_FORMATS for f in formats):
        from .simulate import simulate

        trajectory = simulate(design, hinge_model=HingeModel.ARC.value, dt=ANIMATION_DT_S,
                              library=lib).trajectory
    return export_assembly(design, build(design, state, lib), out_dir, formats, lib, trajectory)
