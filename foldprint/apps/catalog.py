"""What the material library and the shipped templates hold, as a front end lists them:
each material's Tg, fixity and hinge fold time at each bath temperature (with Fig. 1b's
statements beside the model's values at the paper's hinge thickness), the templates'
names and descriptions.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from ..core.constants import DEFAULT_THICKNESS_MM, JSON_DECIMALS

if TYPE_CHECKING:
    from ..model.materials import MaterialLibrary


def material_rows(lib: "MaterialLibrary", temperatures: Sequence[tuple[str, float]],
                  thickness: float = DEFAULT_THICKNESS_MM) -> list[dict]:
    """One row per material: name, role, Tg, colour, the fold time (s, to
    :data:`JSON_DECIMALS`; None for a hinge that does not fold and for a non-hinge) at
    each ``(key, deg C)`` of ``temperatures`` by its key, the shape fixity and its source."""
    from ..physics.recovery.curve import fold_time

    rows = []
    for m in lib:
        ft = {}
        for key, val in temperatures:
            if m.role == "hinge":
                v = fold_time(m, val, thickness)
                ft[key] = None if v is None else round(v, JSON_DECIMALS)
            else:
                ft[key] = None
        rows.append({"name": m.name, "role": m.role, "tg_c": m.tg_c, "color": m.color, "fold_time_s": ft,
                     "fixity": m.shape_fixity if m.role == "hinge" else None,
                     "fixity_source": (m.fixity_source or "measured") if m.fixity is not None else
                     ("default: E_g / (E_g + E_r), docs/calibrate.md" if m.role == "hinge" else None)})
    return rows


def fig1b_paper_lines(lib: "MaterialLibrary", thickness: float = DEFAULT_THICKNESS_MM) -> list[dict]:
    """Fig. 1b's statements (free hinges at the paper's 0.8 mm) beside the model's values
    (JSON dicts); none at another thickness."""
    from ..simulation.paper_timings import fig1b_lines

    return [] if thickness != DEFAULT_THICKNESS_MM else [ln.to_json() for ln in fig1b_lines(lib)]


def fold_time_chart(lib: "MaterialLibrary", temperatures: Sequence[float], thickness: float, path: str | Path) -> Path:
    """Write a Fig. 1b-style chart of every hinge material's fold time against the bath
    temperature (PNG, SVG or PDF by the suffix of ``path``)."""
    from ..render.figures import fold_time_chart as chart, save_figure

    return save_figure(chart(lib, list(temperatures), thickness), path)


def templates() -> list[dict]:
    """Name, path and description of every shipped template, sorted by name."""
    from ..io.templates import list_templates

    return list_templates()


def templates_dir() -> Path:
    """Where the templates are read from (``$FOLDPRINT_TEMPLATES`` or the checkout's)."""
    from ..io.templates import templates_dir as where

    return where()
