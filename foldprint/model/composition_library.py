"""The composition model's side of the material library (:mod:`foldprint.model.composition`):
the library material a ``VW...`` name stands for (:func:`synthesise`), the VeroWhite profile
of any hinge material (:func:`fraction_profile`) and the law's fit to the grades as an evenly
spaced ladder of fractions (:func:`ladder_fit`).

This module must not import ``materials`` (that module imports this one).
"""

from __future__ import annotations

import tomllib
from dataclasses import replace
from importlib import resources
from typing import Sequence

import numpy as np

from ..core.errors import MaterialError
from .composition import DECIMALS, CompositionModel, FractionProfile, composition_model, is_composition_name, parse_name


def synthesise(library, name: str):
    """The library material for a ``VW...`` name (a copy of the first hinge material's data
    with Tg at the mean fraction, the ramp colour and the profile). ``library`` is a
    :class:`~foldprint.model.materials.MaterialLibrary` (not imported: no cycle)."""
    model = composition_model()
    prof = parse_name(name, model)
    template = next((m for m in library if m.role == "hinge" and m.recovery is not None), None)
    if template is None:
        raise MaterialError(f"material {name!r}: the library has no hinge material to take "
                            "recovery parameters from")
    mean = prof.mean
    what = (f"VeroWhite fraction {prof.knots[0]:.{DECIMALS}f}" if prof.uniform else
            f"VeroWhite fraction graded {' -> '.join(f'{v:.{DECIMALS}f}' for v in prof.knots)} "
            f"along the hinge's {prof.along.value} (mean {mean:.{DECIMALS}f})")
    return replace(template, name=name, tg_c=float(model._tg(mean)), color=model.color(mean),
                   description=f"digital SMP, {what}",
                   source=f"composition model ({model.source}); recovery as {template.name}",
                   profile=prof)


def fraction_profile(library, material_name: str) -> FractionProfile:
    """The VeroWhite profile of any hinge material of ``library``.

    ``VW...`` names: their spec. Other hinge materials (H-1..H-7, user grades): uniform, at
    the law's inverse of their ``tg_c`` (for the shipped grades this is the assumed mapping of
    composition.toml).
    """
    if is_composition_name(material_name):
        return parse_name(material_name)
    mat = library[material_name]
    if mat.role != "hinge":
        raise MaterialError(f"material {material_name!r} is a {mat.role} material, not a hinge "
                            "material; it has no VeroWhite fraction profile")
    if not mat.blend:
        raise MaterialError(f"material {material_name!r} is not a VeroWhite/TangoBlack digital material (its "
                            "materials file says blend = false); it has no VeroWhite fraction profile")
    w = composition_model().fraction(mat.tg_c)
    return FractionProfile((float(w),), None)


def ladder_fit(model: CompositionModel | None = None, tgs: Sequence[float] | None = None) -> dict:
    """Fit of the law to the grades as an evenly spaced ladder of fractions.

    Fractions w_n = a + (n - 1) b (a, b least squares) for the grades' Tg (default: the
    shipped H-1..H-7); returns a, b, the residuals (deg C) and their RMS / max, for the
    model's law and for Fox on the same end members.
    """
    from scipy.optimize import least_squares

    model = model or composition_model()
    if tgs is None:
        lib = tomllib.loads((resources.files("foldprint") / "data" / "materials.toml").read_text("utf-8"))
        tgs = [float(v["tg_c"]) for v in lib["materials"].values() if v.get("role") == "hinge"]
    tgs = np.asarray(tgs, float)
    n = np.arange(len(tgs))
    out = {}
    for label, m in (("law", model), ("fox", replace(model, law="fox"))):
        w0 = m._w(tgs)
        x0 = [w0[0], (w0[-1] - w0[0]) / max(1, len(tgs) - 1)]
        r = least_squares(lambda x: m._tg(x[0] + n * x[1]) - tgs, x0, xtol=1e-14, ftol=1e-14)
        res = r.fun
        out[label] = {"a": float(r.x[0]), "b": float(r.x[1]), "residual_c": [float(v) for v in res],
                      "rms_c": float(np.sqrt(np.mean(res ** 2))), "max_c": float(np.max(np.abs(res)))}
    return out
