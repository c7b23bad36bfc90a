"""foldprint: design, simulate, check and export sequentially self-folding structures
printed with digital shape-memory polymers (after Mao et al., Sci. Rep. 2015)."""

from __future__ import annotations

import logging

__version__ = "0.1.0"

logging.getLogger(__name__).addHandler(logging.NullHandler())

from .design import Design, Goal, Hinge, HingeStyle, Panel, Process, strip, validate  # noqa: E402
from .design_io import design_from_dict, design_to_dict, design_to_toml  # noqa: E402
from .load import load_design  # noqa: E402
from .materials import Material, MaterialLibrary, default_library, load_library  # noqa: E402
from .recovery import fold_time, recovery_curve, recovery_ratio  # noqa: E402

__all__ = ["Design", "Goal", "Hinge", "HingeStyle", "Panel", "Process", "strip", "validate",
           "design_from_dict", "design_to_dict", "design_to_toml", "load_design", "Material",
           "MaterialLibrary", "default_library", "load_library", "fold_time", "recovery_curve",
           "recovery_ratio", "__version__"]
