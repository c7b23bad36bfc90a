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
                     **_model_fields(m),
                     "fixity": m.shape_fixity if m.role == "hinge" else None,
                     "fixity_source": (m.fixity_source or "measured") if m.fixity is not None else
                     ("default: E_g / (E_g + E_r), docs/calibrate.md" if m.role == "hinge" else None)})
    return rows


def _model_fields(m) -> dict:
    """A hinge material's viscoelastic model as the listing shows it: moduli, the shift's
    reference temperature and the model's own 1 Hz tan delta peak (None for a non-hinge)."""
    if m.role != "hinge":
        return {"glassy_mpa": None, "rubbery_mpa": None, "shift_reference_c": None, "tan_delta_peak_c": None}
    from ..physics.viscoelastic import viscoelastic

    v = viscoelastic(m)
    return {"glassy_mpa": v.glassy_mpa, "rubbery_mpa": v.rubbery_mpa,
            "shift_reference_c": round(v.reference_c, JSON_DECIMALS),
            "tan_delta_peak_c": round(v.tan_delta_peak_c, JSON_DECIMALS)}


def tg_note(rows: Sequence[dict], tol_c: float = 0.5) -> str | None:
    """One line when the model's 1 Hz tan delta peak is not the Tg a material lists (by more
    than ``tol_c``), naming how far above or below it lies; None when they agree."""
    off = [(r["name"], r["tan_delta_peak_c"] - r["tg_c"]) for r in rows if r.get("tan_delta_peak_c") is not None]
    off = [(n, d) for n, d in off if abs(d) > tol_c]
    if not off:
        return None
    lo, hi = min(d for _, d in off), max(d for _, d in off)
    span = f"{lo:+.1f} C" if hi - lo < 0.05 else f"{lo:+.1f} to {hi:+.1f} C"
    return (f"the model's tan delta peak at 1 Hz (the paper's definition of Tg) lies {span} from the listed Tg "
            f"for {', '.join(n for n, _ in off)}: their shift is referenced at Tg - reference_below_tg_c "
            f"(docs/recovery-model.md, 'What Tg means')")


def model_curves(lib: "MaterialLibrary", bath_c: float, thickness: float = DEFAULT_THICKNESS_MM) -> list[dict]:
    """Each hinge material's DMA sweep at 1 Hz (E'(T), tan delta(T) from Tg - 60 to Tg + 80 C,
    every 0.5 C) and its hinge's recovery ratio R(t) at ``bath_c`` (the model's grid to 600 s):
    what :func:`foldprint.render.material_figure.material_model_figure` draws."""
    import numpy as np  # here, not at the top: `foldprint templates` starts without numpy

    from ..physics.recovery.curve import recovery_curve
    from ..physics.viscoelastic import DMA_FREQUENCY_HZ, viscoelastic

    out = []
    for m in lib.hinges():
        v = viscoelastic(m)
        T = np.arange(m.tg_c - 60.0, m.tg_c + 80.0 + 0.25, 0.5)
        storage, loss = v.dynamic_mpa(DMA_FREQUENCY_HZ, T)
        c = recovery_curve(m, bath_c, thickness)
        keep = c.t > 0  # the R(t) panel is on a log time axis
        out.append({"name": m.name, "color": m.color, "tg_c": m.tg_c, "temperature_c": T, "storage_mpa": storage,
                    "tan_delta": loss / storage, "time_s": c.t[keep], "ratio": c.ratio[keep]})
    return out


def model_chart(lib: "MaterialLibrary", bath_c: float, thickness: float, path: str | Path) -> Path:
    """Write :func:`model_curves` as a figure (PNG, SVG or PDF by the suffix of ``path``)."""
    from ..physics.viscoelastic import DMA_FREQUENCY_HZ
    from ..render.figures import save_figure
    from ..render.material_figure import material_model_figure

    return save_figure(material_model_figure(model_curves(lib, bath_c, thickness), bath_c, DMA_FREQUENCY_HZ), path)


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
