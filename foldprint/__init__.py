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
    "model.composition": ("composition_model", "vero"),
    "model.composition_library": ("fraction_profile",),
    "physics.recovery.curve": ("fold_time", "recovery_curve", "recovery_ratio"),
    # the door: inputs resolved as the command line resolves them, and the evaluation
    "apps.resolve": ("load_input", "load_printer", "load_scatter"),
    "apps.pipeline": ("EvalOptions", "Evaluation", "evaluate"),
}
_WHERE = {name: mod for mod, names in _API.items() for name in names}

__all__ = ["Design", "Goal", "Hinge", "HingeStyle", "Panel", "Process", "strip", "validate",
           "design_from_dict", "design_to_dict", "design_to_toml", "load_design", "Material",
           "MaterialLibrary", "default_library", "load_library", "fold_time", "recovery_curve",
           "recovery_ratio", "vero", "composition_model", "fraction_profile", "load_input", "load_printer",
           "load_scatter", "EvalOptions", "Evaluation", "evaluate", "__version__"]


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


def __getattr__(name: str):
    import importlib

    if name in _WHERE:
        value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
        globals()[name] = value  # the next lookup is a plain attribute
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
