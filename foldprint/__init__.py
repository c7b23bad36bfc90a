"""foldprint: design, simulate, check and export sequentially self-folding structures
printed with digital shape-memory polymers (after Mao et al., Sci. Rep. 2015)."""

from __future__ import annotations

import logging

from .core.version import __version__

logging.getLogger(__name__).addHandler(logging.NullHandler())

#: the public API, imported on first use (``import foldprint`` and the command line's
#: start-up stay free of numpy, shapely and the geometry libraries until a name is used)
_API = {
    "model.design": ("Design", "Goal", "Hinge", "HingeStyle", "Panel", "Process", "strip", "validate"),
    "io.design_io": ("design_from_dict", "design_to_dict", "design_to_toml"),
    "io.load": ("load_design",),
    "model.materials": ("Material", "MaterialLibrary", "default_library", "load_library"),
    "model.composition": ("composition_model", "fraction_profile", "vero"),
    "physics.recovery": ("fold_time", "recovery_curve", "recovery_ratio"),
}
_WHERE = {name: mod for mod, names in _API.items() for name in names}

__all__ = ["Design", "Goal", "Hinge", "HingeStyle", "Panel", "Process", "strip", "validate",
           "design_from_dict", "design_to_dict", "design_to_toml", "load_design", "Material",
           "MaterialLibrary", "default_library", "load_library", "fold_time", "recovery_curve",
           "recovery_ratio", "vero", "composition_model", "fraction_profile", "__version__"]


#: the flat module names of foldprint 0.1 -> where they live now (docs/architecture.md);
#: ``from foldprint import robust`` keeps working (checks, render and cli are packages now)
_MOVED = {
    "constants": "core.constants", "errors": "core.errors", "modes": "core.modes",
    "parallel": "core.parallel", "schema": "core.schema", "guards": "core.guards",
    "materials": "model.materials", "design": "model.design",
    "crease_patterns": "model.crease_patterns", "relief": "model.relief",
    "design_io": "io.design_io", "fold_format": "io.fold_format", "svg_format": "io.svg_format",
    "load": "io.load", "templates": "io.templates", "recovery": "physics.recovery",
    "recovery_table": "physics.recovery_table", "recovery_batch": "physics.recovery_batch",
    "kinematics": "physics.kinematics", "loops": "physics.loops", "motion": "physics.motion",
    "rigid": "collision.rigid", "goals": "collision.goals", "collision2d": "collision.index2d",
    "collision3d": "collision.swept3d", "clearance": "collision.clearance",
    "simulate": "simulation.simulate", "scatter": "simulation.scatter",
    "robust": "simulation.robust", "sensitivity": "simulation.sensitivity",
    "timing": "simulation.timing", "paper_timings": "simulation.paper_timings",
    "report": "checks.report", "render3d": "render.stills", "render_scene": "render.scene",
    "render_anim": "render.anim", "viewer": "render.viewer", "pipeline": "apps.pipeline",
    "gallery": "apps.gallery", "assign": "apps.assign", "distributed": "apps.distributed",
    "cli_support": "cli.support",
}


def __dir__():
    return sorted(set(globals()) | set(_WHERE) | set(_MOVED))


def __getattr__(name: str):
    import importlib

    if name in _WHERE:
        value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
        globals()[name] = value  # the next lookup is a plain attribute
        return value
    if name in _MOVED:
        return importlib.import_module(f"{__name__}.{_MOVED[name]}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
